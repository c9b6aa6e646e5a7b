//! The typed refusals of the job's life: a request about jobs
//! ([`ControlError`]) and a submit ([`SubmitError`]), each worded for the
//! person who asked.

use crate::spool::JobId;
use thiserror::Error;

/// Why a request about jobs was refused.
#[derive(Clone, Debug, PartialEq, Eq, Error)]
pub enum ControlError {
    /// No job has the id.
    #[error("no job {0}")]
    NoJob(JobId),
    /// The job is done, failed or cancelled already.
    #[error("job {id} is already {state}")]
    Finished {
        /// The job.
        id: JobId,
        /// Its state's name.
        state: &'static str,
    },
    /// `pause ID` of a job that is finished or paused.
    #[error("no job {0} that can be paused")]
    NotPausable(JobId),
    /// `resume ID` of a job that is not paused.
    #[error("job {0} is not paused")]
    NotPaused(JobId),
    /// `resume ID` of a job its plotter holds (the paper lever up).
    #[error("job {0} is held by the plotter and goes on by itself once the plotter does (for a paper lever: lower it)")]
    HeldByPlotter(JobId),
    /// `resume ID` of a job whose device's position was lost, without
    /// `--position-confirmed`.
    #[error("job {0} lost the pen's position: park the pen at the paper's origin (or home the machine), then run `plotd resume {0} --position-confirmed`")]
    PositionLost(JobId),
    /// `resume ID` of a job waiting for its board to be homed, on a plotter
    /// without homing switches, without `--position-confirmed`.
    #[error("job {0} waits for its plotter to be homed, and it has no homing switches (`homing = true`): park the pen at the paper's origin, then run `plotd resume {0} --position-confirmed`")]
    NeedsHoming(JobId),
    /// `resume` with nothing paused.
    #[error("no paused job")]
    NothingPaused,
    /// `resume ID` of a job waiting for a fresh sheet.
    #[error("job {id} waits for a fresh sheet: load one on plotter {plotter}, then: plotd sheet-loaded {plotter}")]
    SheetAwaited {
        /// The job.
        id: JobId,
        /// Its plotter.
        plotter: String,
    },
    /// A manual request while a job plots on the plotter.
    #[error("plotter {plotter} is plotting job {job}: pause it first (plotd pause {job}), or wait for it to end")]
    Plotting {
        /// The plotter.
        plotter: String,
        /// The job it plots.
        job: JobId,
    },
    /// A manual request while another is carried out on the plotter.
    #[error("plotter {0} is still carrying out a manual request")]
    ManualBusy(String),
    /// `home` on a plotter without homing switches.
    #[error(
        "plotter {0} has no homing switches (`homing = true` in its [[plotter]] table is for a GRBL board with them): \
         park the carriage at the origin by hand, or `plotd move 0 0`"
    )]
    NoHoming(String),
    /// A manual request that names no plotter, with several configured.
    #[error("name the plotter: {}", .0.join(", "))]
    WhichPlotter(Vec<String>),
    /// `offset` by a distance that is not one, or leaves no room to draw.
    #[error("plotter {plotter}: an origin offset of {offset} mm leaves no room on its sheets (or is not a distance)")]
    BadOffset {
        /// The plotter.
        plotter: String,
        /// The offset asked for, `(dx, dy)`.
        offset: String,
    },
    /// A request while the daemon shuts down.
    #[error("the daemon is shutting down")]
    ShuttingDown,
    /// A request names a plotter that is not configured.
    #[error("no plotter {0:?}")]
    NoSuchPlotter(String),
    /// `frame ID` of a job for a class of plotters none has taken yet: it
    /// has no sheet to be traced on.
    #[error("job {id} waits for a plotter of {class} to take it: frame it once one has (plotd jobs shows which)")]
    NotTaken {
        /// The job.
        id: JobId,
        /// `any`, or the device named.
        class: String,
    },
    /// `pen-changed` with no job waiting for a pen.
    #[error("no job is waiting for a pen")]
    NoPenAwaited,
    /// The change holds in the daemon, but the spool could not record it.
    #[error("{0}")]
    Unsaved(String),
    /// A cancel whose record could not be rewritten, nor the job's files deleted.
    #[error("job {id} is cancelled until the daemon restarts: the spool cannot record it ({saving}; {removing})")]
    CancelUnrecorded {
        /// The job.
        id: JobId,
        /// Why the record could not be saved.
        saving: String,
        /// Why the files could not be deleted.
        removing: String,
    },
}

/// Why a job was not accepted.
#[derive(Clone, Debug, PartialEq, Eq, Error)]
pub enum SubmitError {
    /// SIGTERM came: no new job.
    #[error("the daemon is shutting down")]
    ShuttingDown,
    /// The name is neither a plotter, nor a configured device, nor `any`.
    #[error("no plotter or device {name:?}: name a plotter ({}), a device of one ({}), or any", configured.join(", "), devices.join(", "))]
    NoSuchPlotter {
        /// The name asked for.
        name: String,
        /// The plotters there are.
        configured: Vec<String>,
        /// Their devices.
        devices: Vec<String>,
    },
    /// No plotter of the class named can draw the job.
    #[error("no plotter for {class} can draw this job: {}", why.iter().map(|(p, e)| format!("{p}: {e}")).collect::<Vec<_>>().join("; "))]
    NoneFits {
        /// `any`, or the device named.
        class: String,
        /// Each of its plotters, and why not.
        why: Vec<(String, String)>,
    },
    /// No plotter at all.
    #[error("no plotter configured")]
    NoPlotter,
    /// The plotter's device profile cannot be had.
    #[error("{0}")]
    Device(String),
    /// The job itself: its attachments, or what the check found.
    #[error("job refused: {0}")]
    Refused(String),
    /// The spool could not store it.
    #[error("cannot spool the job: {0}")]
    Spool(String),
}
