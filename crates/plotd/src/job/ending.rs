//! How a run ends, and why a job waits: every pause's typed cause with the
//! reason a person reads, and the one mapping from a [`StreamError`] to
//! how the job ends ([`after_stream_error`]).

use super::action::StopReason;
use super::position;
use crate::config::DeviceErrorPolicy;
use crate::protocol::LinkCause;
use crate::spool::{JobId, JobRecord, JobState, PauseCause};
use crate::stream::{Hold, StreamError};
use plotcode::Program;

/// Reason of a pause by a person (`plotd pause`).
pub(super) const BY_PERSON: &str = "paused by user";
/// Reason of a pause because the spool could not be written.
pub(super) const UNSAVED: &str = "paused: the spool cannot be written, so plotting stopped before the record fell behind the device";
/// Reason of a job found plotting (or held by the device) when the daemon starts.
pub(super) const INTERRUPTED: &str = "interrupted: the daemon stopped mid-job";
/// Reason of a job stopped at a stroke boundary by a shutdown.
const SHUT_DOWN: &str = "interrupted: the daemon shut down";
/// What a pause caused by the link begins with.
const OFFLINE: &str = "device offline";

/// How a run ends, as the run knows it.
#[derive(Debug)]
pub(super) enum Ending {
    /// In this state (done, a person's load, failed to render, unsaved).
    State(JobState),
    /// Stopped as asked; the state follows from why ([`after_stop`]).
    /// `forget_mark`: the device holds nothing of the job (a stop during a
    /// span confirms everything written, or drops it).
    Stopped { forget_mark: bool },
    /// The stream failed ([`after_stream_error`]).
    Failed(StreamError),
}

/// How a run's end leaves the job, the written mark and the port.
#[derive(Debug, PartialEq)]
pub(super) struct End {
    pub state: JobState,
    /// The device holds nothing known of what was written: forget the mark.
    pub forget_mark: bool,
    /// The port must be opened afresh before it is used again: the link
    /// was lost, for this cause.
    pub lost: Option<LinkCause>,
}

impl Ending {
    /// The end this ending is, for `job`'s run asked to stop for `why` (if
    /// it was) on a plotter whose device errors do `policy`.
    pub fn end(self, job: JobId, why: Option<StopReason>, policy: DeviceErrorPolicy) -> End {
        match self {
            Ending::State(state) => End { state, forget_mark: false, lost: None },
            Ending::Stopped { forget_mark } => End { state: after_stop(why), forget_mark, lost: None },
            Ending::Failed(e) => after_stream_error(job, &e, policy),
        }
    }
}

/// The one mapping from a stream error to how `job` ends. A reset lost
/// what the device held (nothing it reports tells how far it got) and its
/// coordinates: the mark is forgotten, and the job waits for a person to
/// confirm the pen's position ([`position::lost`]). Any other lost link
/// keeps the mark, so that the pen's place decides
/// where to go on. A device error with the link fine (the streamer
/// dropped what the device held) pauses or fails the job by `policy`.
pub(super) fn after_stream_error(job: JobId, e: &StreamError, policy: DeviceErrorPolicy) -> End {
    let offline = || JobState::paused(PauseCause::Offline, format!("{OFFLINE}: {e}"));
    match e {
        StreamError::Reset(reset) => End { state: position::lost(job, reset), forget_mark: true, lost: e.link_cause(None) },
        e if e.link_lost() => End { state: offline(), forget_mark: false, lost: e.link_cause(None) },
        e => {
            let state = match policy {
                DeviceErrorPolicy::Pause => JobState::paused(PauseCause::DeviceError, e.to_string()),
                DeviceErrorPolicy::Fail => JobState::Failed { reason: e.to_string() },
            };
            End { state, forget_mark: true, lost: None }
        }
    }
}

/// The state of a run stopped as asked for `why` (none: a stop nobody
/// explained is a person's pause).
pub(super) fn after_stop(why: Option<StopReason>) -> JobState {
    match why {
        Some(StopReason::Cancel) => JobState::Cancelled,
        Some(StopReason::Shutdown) => JobState::paused(PauseCause::Interrupted, SHUT_DOWN),
        Some(StopReason::Pause) | None => by_person(),
        // A checkpoint that cannot be saved ends the run through the span's
        // end with its error ([`unsaved`]); this is its reason without one.
        Some(StopReason::Unsaved) => JobState::paused(PauseCause::Unsaved, UNSAVED),
    }
}

/// A person's pause.
pub(super) fn by_person() -> JobState {
    JobState::paused(PauseCause::Person, BY_PERSON)
}

/// Paused because a record could not be saved (`error`).
pub(super) fn unsaved(error: &str) -> JobState {
    JobState::paused(PauseCause::Unsaved, format!("{UNSAVED}: {error}"))
}

/// The state of a job the device holds (`Some`), or the state it goes back
/// to when the device goes on: a pause with another cause stays.
pub(super) fn held(state: &JobState, why: Option<Hold>) -> Option<JobState> {
    match (why, state.pause_cause()) {
        (Some(why), None) => Some(JobState::paused(PauseCause::DeviceHold, format!("held by the plotter: {why}"))),
        (None, Some(PauseCause::DeviceHold)) => Some(JobState::Plotting),
        _ => None,
    }
}

/// Where the next pause for a person falls, from chunk `from` on: the first
/// chunk on a page other than the one loaded (new paper), or with
/// `pens_pause`, the first drawing chunk whose pen is not the one loaded.
pub(super) fn next_load(program: &Program, from: usize, record: &JobRecord, pens_pause: bool) -> usize {
    program.chunks[from..]
        .iter()
        .position(|c| c.page != record.page_loaded || (pens_pause && c.draws && c.pen.is_some() && c.pen != record.pen_loaded))
        .map_or(program.chunks.len(), |i| from + i)
}

/// The pause that asks a person to load what chunk `at` needs: its page's
/// paper, else its pen.
pub(super) fn load(program: &Program, at: usize, record: &JobRecord) -> JobState {
    let chunk = &program.chunks[at];
    if chunk.page != record.page_loaded {
        let reason = format!("load paper for frame {} of {}", chunk.page + 1, program.page_count());
        return JobState::Paused { cause: PauseCause::Load, reason, insert_pen: None, load_page: Some(chunk.page) };
    }
    let pen = chunk.pen.unwrap_or(0);
    JobState::Paused { cause: PauseCause::Load, reason: format!("insert pen {pen}"), insert_pen: Some(pen), load_page: None }
}
