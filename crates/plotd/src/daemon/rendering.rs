//! A job's program, made when its plotter takes it: the job worker renders
//! the spooled content to device commands page by page ([`crate::worker`],
//! in a process of its own, under the config's budget), and each page is
//! cut into chunks here as it arrives, so an animation's device text is
//! never all held at once. `cancel`, `pause` and shutdown kill the worker.

use super::registry::Registry;
use crate::spool::{JobId, JobKind};
use crate::worker::{JobInput, WorkerError};
use plotcode::DeviceProfile;
use plotcode::Program;
use std::future::Future;

/// Why there is no program.
#[derive(Debug)]
pub enum NoProgram {
    /// The job cannot be rendered (the reason, for its `failed` state).
    Failed(String),
    /// Stopped on request before it was done.
    Stopped,
}

/// Renders job `id` for `device`; gives up when `stop` resolves.
pub async fn program(
    reg: &Registry,
    id: JobId,
    kind: JobKind,
    device: &DeviceProfile,
    stop: impl Future<Output = ()>,
) -> Result<Program, NoProgram> {
    let spool = reg.spool.clone();
    let read = tokio::task::spawn_blocking(move || Ok::<_, crate::spool::SpoolError>((spool.content(id)?, spool.files(id)?))).await;
    let (content, files) = match read {
        Ok(Ok(v)) => v,
        Ok(Err(e)) => return Err(NoProgram::Failed(e.to_string())),
        Err(e) => return Err(NoProgram::Failed(format!("cannot read the job: {e}"))),
    };
    let mut pages = Vec::new();
    let mut cut = |text: Vec<u8>| -> Result<(), String> {
        // Cutting is quick next to rendering; off the runtime's threads all
        // the same where the runtime allows it.
        let cut = || plotcode::cut(&text, device);
        let program = match tokio::runtime::Handle::current().runtime_flavor() {
            tokio::runtime::RuntimeFlavor::MultiThread => tokio::task::block_in_place(cut),
            _ => cut(),
        }
        .map_err(|e| e.to_string())?;
        pages.push(program);
        Ok(())
    };
    // Its pens mapped as it was submitted, drawn as its plotter's table says.
    let record = reg.job(id);
    let pens = record.as_ref().map(|r| r.pens.clone()).unwrap_or_default();
    let occult = record.as_ref().and_then(|r| r.occult);
    let pen_table = record.and_then(|r| reg.config(&r.plotter)).map(|c| crate::pen_table::settings(&c.pen)).unwrap_or_default();
    let job = JobInput { kind, content: &content, files: &files, device, pens: &pens, pen_table: &pen_table, occult };
    match reg.worker.render(job, &mut cut, stop).await {
        Ok(()) => Program::paged(pages).ok_or_else(|| NoProgram::Failed("nothing to plot".into())),
        Err(WorkerError::Stopped) => Err(NoProgram::Stopped),
        Err(e) => Err(NoProgram::Failed(e.to_string())),
    }
}
