//! The job's life's vocabulary: what it asks the daemon to do
//! ([`Action`], [`Step`], a person's [`Manual`] request), what a save carries ([`Save`], [`Then`]) and why a
//! run is stopped ([`StopReason`]). The machine's parts all speak it; it
//! names none of them.

use super::error::ControlError;
use crate::spool::{JobId, JobKind, JobRecord, PlotterState};
use crate::stream::{Restore, Stop};
use crate::written::Written;
use plotcode::Program;
use std::sync::Arc;
use std::time::Instant;

/// Progress figures that go with an announcement but are not saved.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Progress {
    /// Job bytes the device has confirmed.
    pub bytes_acked: u64,
    /// Estimated seconds left.
    pub eta_s: Option<f64>,
}

/// Why a plotter's run is asked to stop.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StopReason {
    /// `plotd pause`.
    Pause,
    /// `plotd cancel`.
    Cancel,
    /// The daemon is shutting down (SIGTERM).
    Shutdown,
    /// A confirmed checkpoint could not be saved: the job pauses rather
    /// than run ahead of its record.
    Unsaved,
}

/// A changed record to save, then announce ([`Action::Save`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Save {
    /// The record as it is now.
    pub record: JobRecord,
    /// What goes with its announcement.
    pub progress: Progress,
    /// Which of the job's changes this is: a save that finishes after a
    /// newer one changes nothing shown.
    pub(super) version: u64,
    /// What follows from the save, or from its failure.
    pub(super) then: Then,
}

/// What follows a save ([`JobLife::saved`]).
#[derive(Clone, Debug, PartialEq)]
pub(super) enum Then {
    /// Nothing; a failure is only logged (the change is kept in memory).
    Nothing,
    /// The run goes on with this step; a failure ends it, paused `unsaved`.
    Run(RunStep),
    /// A checkpoint a run confirmed: a failure stops the run at the next
    /// stroke boundary.
    Checkpoint,
    /// A person's request, answered once it is saved.
    Answer(Answer),
}

/// A run's step that waits for a save.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum RunStep {
    /// Render the job (saved `rendering`).
    Render,
    /// Read the written mark (saved `plotting`, with its totals).
    ReadMark,
    /// Begin this run's mark and stream (the located checkpoint saved).
    Stream,
}

/// Why a job is deleted from the spool ([`Action::Remove`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Removal {
    /// A finished job beyond `keep_finished`.
    Pruned,
    /// A cancelled job whose record could not be rewritten (`unsaved`: why):
    /// without its files it cannot come back queued after a restart.
    Cancelled {
        /// The save's error.
        unsaved: String,
    },
}

/// What the daemon must do, in order. Where an action has a result, the
/// daemon reports it with the call named, and does what that returns
/// before the actions after this one.
#[derive(Clone, Debug, PartialEq)]
pub enum Action {
    /// Save the record, then announce it (even when the save failed: the
    /// daemon acts on it); report with [`JobLife::saved`].
    Save(Save),
    /// The same for a checkpoint of a running span: only the newest one
    /// matters, and the device's answers must never wait for the disk (an
    /// answer left unread when a cable is pulled is a stroke drawn again),
    /// so these are saved on a task of their own, the newest first.
    SaveCheckpoint(Save),
    /// Save a plotter's state (its sheet, offset, pen) in the spool, then
    /// announce the plotter to watchers; a failure is only logged (the
    /// state holds in memory, and a restart finds the older one).
    SavePlotter {
        /// The plotter.
        plotter: String,
        /// Its state now.
        state: PlotterState,
    },
    /// Announce a record already saved (a new job).
    Announce(JobRecord),
    /// Announce the plotter's state to watchers: its link went or came
    /// back, or its cause changed (what is saved is announced by
    /// [`Action::SavePlotter`]).
    AnnouncePlotter(String),
    /// Delete the job from the spool; report with [`JobLife::removed`].
    Remove {
        /// The job.
        job: JobId,
        /// Why.
        why: Removal,
    },
    /// Forget the job's written mark: what the device holds is not known
    /// to be what was written (it was told to drop it, or lost it).
    ForgetWritten(JobId),
    /// Ask the plotter's run to stop (`how`: the most asked of it).
    Stop {
        /// The plotter.
        plotter: String,
        /// How soon.
        how: Stop,
    },
    /// Wake the plotter's task: it polls again ([`JobLife::poll`]).
    Wake(String),
    /// The answer to the request being handled.
    Reply(Result<String, ControlError>),
    /// Render the job for the plotter's device; report with [`JobLife::rendered`].
    Render {
        /// The job.
        job: JobId,
        /// What its content is.
        kind: JobKind,
        /// The plotter's origin offset it is drawn with, mm.
        offset_mm: [f64; 2],
    },
    /// Read the job's written mark; report with [`JobLife::mark_read`].
    ReadMark(JobId),
    /// Ask the device how far it got in what `mark` says was written,
    /// from chunk `from` on; report with [`JobLife::located`].
    Locate {
        /// The job's program.
        program: Arc<Program>,
        /// The first candidate chunk.
        from: usize,
        /// What was written.
        mark: Written,
    },
    /// Begin this run's written mark: forget the last one, and record from
    /// now on how far the run writes.
    StartMark(JobId),
    /// Stream chunks `from..until`; report confirmations with
    /// [`JobLife::confirmed`], holds with [`JobLife::held`], and the end
    /// with [`JobLife::span_ended`].
    Stream {
        /// The job's program.
        program: Arc<Program>,
        /// The first chunk.
        from: usize,
        /// The chunk after the last.
        until: usize,
        /// Give the device its state at `from` first (an interrupted run goes on).
        resume: bool,
        /// Lift the pen after the last chunk (a person's change follows).
        lift: bool,
        /// What the link's set-up may do to a device whose position is
        /// lost (a person confirmed it, or asked for homing).
        restore: Restore,
    },
    /// Move the head, pen up, to `at_mm` (mm from the origin), off the
    /// drawing, for a person to change the pen; report with
    /// [`JobLife::parked`].
    Park {
        /// Where.
        at_mm: [f64; 2],
    },
    /// The run is over; with `lost`, the port must be opened afresh.
    RunEnded {
        /// The link was lost.
        lost: bool,
    },
}

/// What a plotter's task does next ([`JobLife::poll`]).
#[derive(Debug, PartialEq)]
pub enum Step {
    /// Open the port if it is closed and ask the device something it
    /// answers at once; report with [`JobLife::probed`].
    Probe,
    /// Run the job: carry out `actions` and what follows them until
    /// [`Action::RunEnded`].
    Run {
        /// The job.
        job: JobId,
        /// The run's first actions.
        actions: Vec<Action>,
    },
    /// Carry out these actions (none a run's), then poll again.
    Act(Vec<Action>),
    /// Carry out a person's manual request; report with
    /// [`JobLife::manual_done`].
    Manual(ManualWork),
    /// Reset the device, which has just answered: drop what it holds and
    /// lift the pen, as this cancelled job's program lifts it; report with
    /// [`JobLife::reset_done`]. A cancelled job's run that could not tell
    /// the device to stop (the link lost, the device stalled) owes this.
    Reset(Arc<Program>),
    /// Nothing to do until then (`None`: until woken).
    Wait(Option<Instant>),
    /// The daemon is shutting down (or the plotter is gone): the task ends.
    Quit,
}

/// What a person asks of a plotter's carriage.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Manual {
    /// Lower (`true`) or raise the pen where it is.
    Pen {
        /// Lower it.
        down: bool,
    },
    /// Raise the pen and go to this point, mm from the device's origin.
    MoveTo {
        /// mm.
        x_mm: f64,
        /// mm.
        y_mm: f64,
    },
    /// Raise the pen and move by this much, mm.
    Jog {
        /// mm.
        dx_mm: f64,
        /// mm.
        dy_mm: f64,
    },
    /// Run the homing cycle (a GRBL board with homing switches).
    Home,
    /// Trace job `job`'s bounding box on its sheet with the pen up.
    Frame {
        /// The job.
        job: JobId,
    },
}

/// A manual request for a plotter's task to carry out ([`Step::Manual`]).
#[derive(Clone, Debug, PartialEq)]
pub struct ManualWork {
    /// What was asked.
    pub op: Manual,
    /// For a frame: the job's content kind, to render it.
    pub kind: Option<JobKind>,
    /// For a frame: the origin offset the job is drawn with (its own once
    /// it started, else the plotter's), mm.
    pub offset_mm: [f64; 2],
}

/// A request answered once its save is done.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(super) enum Answer {
    /// `cancel` of a job that was not running.
    Cancelled,
    /// `pause ID` of a job that was not running.
    Paused {
        /// Stop now was asked.
        now: bool,
    },
    /// `resume` or `pen-changed`: the jobs resumed so far, and those left.
    Resumed {
        /// Saved, in order.
        done: Vec<JobId>,
        /// To resume next, in order.
        rest: Vec<JobId>,
    },
}
