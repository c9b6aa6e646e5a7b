//! Position known or a person asked: the rules of a job whose device's
//! coordinates can no longer be trusted.
//!
//! A device reset or power-cycled mid-job starts again from a zero of its
//! own: a GRBL board's is wherever the carriage stood when it restarted, so
//! what it draws after lands shifted on the paper (issue 36: 70 strokes
//! drawn 207 mm off an A4 sheet). So such a job pauses with the cause
//! [`PauseCause::PositionLost`], its reason saying what happened and what to
//! do; the link is watched (`status` shows when the plotter is back), but
//! neither `auto_resume` nor a plain `resume` moves the pen. A person parks
//! the pen at the origin and runs `plotd resume ID --position-confirmed`:
//! the job goes on from its checkpoint.

use super::error::ControlError;
use crate::spool::{JobId, JobState, PauseCause};
use crate::stream::Reset;

/// What a person does to go on after the position was lost.
pub(super) const WHAT_TO_DO: &str =
    "park the pen at the paper's origin (or home the machine), then run `plotd resume ID --position-confirmed`";

/// The pause of a job whose device was reset mid-job, as `reset` showed.
/// Logged at WARN: only a person can make it go on.
pub(super) fn lost(job: JobId, reset: &Reset) -> JobState {
    let reason = format!("position lost: {reset}; {}", WHAT_TO_DO.replace("ID", &job.to_string()));
    tracing::warn!(job, reason = %reason, "the device's position cannot be trusted: the job waits for a person");
    JobState::paused(PauseCause::PositionLost, reason)
}

/// Whether a job paused with `cause` is watched while it waits: its
/// plotter is asked whether it is there, so that `status` shows when it is
/// back (and, for a lost link alone, `auto_resume` goes on).
pub(super) fn watched(cause: PauseCause) -> bool {
    matches!(cause, PauseCause::Offline | PauseCause::PositionLost)
}

/// Whether a person's `resume` may take job `id` in `state`
/// (`position_confirmed`: the person said the pen is at the origin), or why
/// not.
pub(super) fn may_resume(id: JobId, state: &JobState, position_confirmed: bool) -> Result<(), ControlError> {
    match state.pause_cause() {
        Some(PauseCause::PositionLost) if !position_confirmed => Err(ControlError::PositionLost(id)),
        _ => Ok(()),
    }
}
