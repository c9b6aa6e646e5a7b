//! A plotter's task carrying out a person's manual request
//! ([`crate::job::Manual`], accepted by the job's life): the device's
//! commands from [`plotcode::control::manual`], streamed and confirmed as a
//! job's chunks are, so the answer comes once the device has done it. A
//! frame renders its job as the plotter will plot it and goes round the
//! box its strokes are drawn in, with the pen up, stopping
//! [`FRAME_PAUSE`] at each corner for the person to look.

use super::plotter::{answers, open};
use super::registry::Registry;
use super::rendering::NoProgram;
use crate::job::{Manual, ManualWork};
use crate::protocol::{Manoeuvre, PlotterEvent, EVENT_VERSION};
use crate::spool::JobId;
use crate::stream::{SerialPort, Span, Stop, StreamError, Streamer};
use plotcode::control::manual::{self, Motion};
use plotcode::DeviceProfile;
use std::sync::Arc;
use std::time::Duration;
use strokes::DVec2;
use tokio::sync::watch;

/// How long a frame's pen stays at each corner: long enough to see where
/// it is against the paper's edge, short enough not to wait for.
pub const FRAME_PAUSE: Duration = Duration::from_secs(1);

/// Carries out `work` on plotter `name`'s port (opened if it is closed):
/// the answer for the person, and the event for watchers.
pub async fn carry_out(
    reg: &Arc<Registry>,
    name: &str,
    port: &mut Option<Streamer<SerialPort>>,
    work: ManualWork,
) -> Result<(String, PlotterEvent), String> {
    let device = reg.config(name).ok_or_else(|| format!("plotter {name:?} is gone"))?.loaded_device()?;
    let event =
        |did, mm: Option<DVec2>, job| PlotterEvent { plotter: name.to_owned(), did, mm: mm.map(|p| [p.x, p.y]), job, v: EVENT_VERSION };
    let (motions, message, ev) = match work.op {
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
        Manual::Frame { job } => {
            let placed = DeviceProfile { origin_offset_mm: work.offset_mm, ..device.clone() };
            let (lo, hi) = frame_box(reg, job, work.kind, &placed).await?;
            let corners = [lo, DVec2::new(hi.x, lo.y), hi, DVec2::new(lo.x, hi.y), lo];
            let message =
                format!("traced job {job}'s frame on plotter {name}: ({:.1}, {:.1}) to ({:.1}, {:.1}) mm, pen up", lo.x, lo.y, hi.x, hi.y);
            (corners.iter().map(|&c| Motion::MoveTo(c)).collect(), message, event(Manoeuvre::Framed, Some(lo), Some(job)))
        }
    };
    // Every command written before the pen moves: a point out of reach is
    // refused with nothing done.
    let programs = motions.into_iter().map(|m| manual::program(&device, m)).collect::<Result<Vec<_>, _>>().map_err(|e| e.to_string())?;
    if !answers(name, port, || open(reg, name)).await {
        return Err(format!("plotter {name} does not answer"));
    }
    let Some(streamer) = port.as_mut() else { return Err(format!("plotter {name} does not answer")) };
    // A frame stops at each corner but the last.
    let pause = programs.len() > 1;
    for (k, program) in programs.iter().enumerate() {
        let (_keep, mut stop) = watch::channel(Stop::Continue);
        if let Err(e) = streamer.run(Span::all(program), &mut stop, &mut |_: usize| {}).await {
            if matches!(e, StreamError::Offline(_)) {
                *port = None;
            }
            return Err(format!("plotter {name}: {e}"));
        }
        if pause && k + 1 < programs.len() {
            tokio::time::sleep(FRAME_PAUSE).await;
        }
    }
    Ok((message, ev))
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
