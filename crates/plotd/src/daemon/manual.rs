//! What a person's manual request ([`crate::job::Manual`], accepted by the
//! job's life) sends, and how: the device's commands from
//! [`plotcode::control::manual`] ([`plan`]), streamed and confirmed as a
//! job's chunks are ([`stream`]), so the answer comes once the device has
//! done it; the plotter's task (`plotter.rs`) runs them on its port. A
//! frame renders its job as the plotter will plot it and goes round the
//! box its strokes are drawn in, with the pen up, stopping
//! [`FRAME_PAUSE`] at each corner for the person to look.

use super::registry::Registry;
use super::rendering::NoProgram;
use crate::job::{Manual, ManualWork};
use crate::protocol::{Manoeuvre, PlotterEvent, EVENT_VERSION};
use crate::spool::JobId;
use crate::stream::{Restore, Span, Stop, StreamError, Streamer};
use plotcode::control::manual::{self, Motion};
use plotcode::{DeviceProfile, Program};
use std::time::Duration;
use strokes::DVec2;
use tokio::io::{AsyncRead, AsyncWrite};
use tokio::sync::watch;

/// How long a frame's pen stays at each corner: long enough to see where
/// it is against the paper's edge, short enough not to wait for.
pub const FRAME_PAUSE: Duration = Duration::from_secs(1);

/// What a manual request sends: one program a motion, in order.
pub struct Plan {
    /// The device's commands.
    pub programs: Vec<Program>,
    /// The answer for the person once they are done.
    pub message: String,
    /// What watchers hear then.
    pub event: PlotterEvent,
    /// What the link's set-up does first ([`Restore::Home`]: the homing cycle).
    pub restore: Restore,
}

/// The commands that carry out `work` on plotter `name` (a frame's job
/// rendered first), all written before the pen moves: a point out of reach
/// is refused with nothing done.
pub async fn plan(reg: &Registry, name: &str, work: &ManualWork) -> Result<Plan, String> {
    let device = reg.config(name).ok_or_else(|| format!("plotter {name:?} is gone"))?.loaded_device()?;
    let event =
        |did, mm: Option<DVec2>, job| PlotterEvent { plotter: name.to_owned(), did, mm: mm.map(|p| [p.x, p.y]), job, v: EVENT_VERSION };
    let restore = if work.op == Manual::Home { Restore::Home } else { Restore::Nothing };
    let (motions, message, event) = match work.op {
        Manual::Pen { down } => {
            let (m, did, word) = if down { (Motion::PenDown, Manoeuvre::PenDown, "down") } else { (Motion::PenUp, Manoeuvre::PenUp, "up") };
            (vec![m], format!("pen {word} on plotter {name}"), event(did, None, None))
        }
        Manual::MoveTo { x_mm, y_mm } => {
            let p = DVec2::new(x_mm, y_mm);
            (vec![Motion::MoveTo(p)], format!("plotter {name} at ({x_mm}, {y_mm}) mm, pen up"), event(Manoeuvre::Moved, Some(p), None))
        }
        Manual::Jog { dx_mm, dy_mm } => {
            let d = DVec2::new(dx_mm, dy_mm);
            (
                vec![Motion::Jog(d)],
                format!("plotter {name} moved by ({dx_mm}, {dy_mm}) mm, pen up"),
                event(Manoeuvre::Jogged, Some(d), None),
            )
        }
        // The set-up homes the board ([`Restore::Home`]); then the pen is
        // raised, so the answer comes once the board confirmed both.
        Manual::Home => (vec![Motion::PenUp], format!("plotter {name} homed"), event(Manoeuvre::Homed, Some(DVec2::ZERO), None)),
        Manual::Frame { job } => {
            let placed = DeviceProfile { origin_offset_mm: work.offset_mm, ..device.clone() };
            let (lo, hi) = frame_box(reg, job, work.kind, &placed).await?;
            let corners = [lo, DVec2::new(hi.x, lo.y), hi, DVec2::new(lo.x, hi.y), lo];
            let message =
                format!("traced job {job}'s frame on plotter {name}: ({:.1}, {:.1}) to ({:.1}, {:.1}) mm, pen up", lo.x, lo.y, hi.x, hi.y);
            (corners.iter().map(|&c| Motion::MoveTo(c)).collect(), message, event(Manoeuvre::Framed, Some(lo), Some(job)))
        }
    };
    let programs = motions.into_iter().map(|m| manual::program(&device, m)).collect::<Result<Vec<_>, _>>().map_err(|e| e.to_string())?;
    Ok(Plan { programs, message, event, restore })
}

/// Streams `programs` in order, each confirmed by the device before the
/// next; with several (a frame), waits [`FRAME_PAUSE`] between them.
///
/// # Errors
/// The first [`StreamError`].
/// The first goes after `restore`, on a link set up afresh.
pub async fn stream<T: AsyncRead + AsyncWrite + Unpin>(
    streamer: &mut Streamer<T>,
    programs: &[Program],
    restore: Restore,
) -> Result<(), StreamError> {
    if restore != Restore::Nothing {
        streamer.forget_device();
    }
    for (k, program) in programs.iter().enumerate() {
        let (_keep, mut stop) = watch::channel(Stop::Continue);
        let restore = if k == 0 { restore } else { Restore::Nothing };
        streamer.run(Span { restore, ..Span::all(program) }, &mut stop, &mut |_: usize| {}).await?;
        if k + 1 < programs.len() {
            tokio::time::sleep(FRAME_PAUSE).await;
        }
    }
    Ok(())
}

/// The box job `job` is drawn in on `device`, mm from its origin: its
/// program rendered as its plotter will plot it.
async fn frame_box(
    reg: &Registry,
    job: JobId,
    kind: Option<crate::spool::JobKind>,
    device: &DeviceProfile,
) -> Result<(DVec2, DVec2), String> {
    let kind = kind.ok_or_else(|| format!("job {job}: its kind is not known"))?;
    let program = super::rendering::program(reg, job, kind, device, std::future::pending()).await.map_err(|e| match e {
        NoProgram::Failed(reason) => format!("job {job} cannot be rendered: {reason}"),
        NoProgram::Stopped => format!("job {job}: rendering stopped"),
    })?;
    let (lo, hi) = program
        .inked_bounds()
        .ok_or_else(|| format!("job {job} draws nothing whose place can be followed (labels or arcs only): no frame to trace"))?;
    Ok((lo * device.unit_mm, hi * device.unit_mm))
}
