//! Position known or a person asked: the rules of a job whose device's
//! coordinates can no longer be trusted.
//!
//! A device reset or power-cycled mid-job starts again from a zero of its
//! own: a GRBL board's is wherever the carriage stood when it restarted, so
//! what it draws after lands shifted on the paper (issue 36: 70 strokes
//! drawn 207 mm off an A4 sheet). A GRBL alarm (a limit switch, a reset in
//! motion) stops the motors at once, and steps may be lost. So such a job
//! pauses with the cause [`PauseCause::PositionLost`]; a board locked since
//! it started because homing is enabled (`$22=1`) is never unlocked unasked:
//! the job waits [`PauseCause::NeedsHoming`]. Each reason says what happened
//! and what to do; the link is watched (`status` shows when the plotter is
//! back), but `auto_resume` never moves the pen. A person either parks the
//! pen at the origin and runs `plotd resume ID --position-confirmed` (a
//! board in alarm is then unlocked), or, on a plotter with homing
//! switches (`homing = true`), runs `plotd resume ID`: the machine homes
//! before the job goes on from its checkpoint. The reasons name the board's
//! own commands for those ([`Op::Home`], [`Op::Unlock`]), as its manual
//! does. What the resume
//! allows is the run's [`Restore`].

use super::error::ControlError;
use crate::spool::{JobId, JobState, PauseCause};
use crate::stream::{Alarm, Restore};
use plotcode::control::grbl::Op;
use std::fmt::Display;

/// What a person does to go on after a restart, on a plotter without
/// homing switches.
pub(super) const WHAT_TO_DO: &str =
    "park the pen at the paper's origin (or home the machine), then run `plotd resume ID --position-confirmed`";
/// The same on a plotter with homing switches.
fn home_to_go_on() -> String {
    format!("run `plotd resume ID` to home the machine ({}) and go on", Op::Home)
}
/// What a person does after an alarm (which keeps the board's idea of its
/// place), on a plotter without homing switches.
const CHECK_THE_PLACE: &str =
    "check that the pen is where the board stopped it (or home the machine), then run `plotd resume ID --position-confirmed`";
/// What unlocks a board locked until homed, on a plotter without switches.
fn park_to_unlock() -> String {
    format!(
        "this plotter has no homing switches (`homing = true`): park the pen at the paper's origin, then run `plotd resume ID --position-confirmed` ({} unlocks it)",
        Op::Unlock
    )
}

/// The pause of job `job` whose device's position was lost, as `what`
/// says (a reset, an alarm), on a plotter with homing switches or not.
/// Logged at WARN: only a person can make it go on.
pub(super) fn lost(job: JobId, what: &dyn Display, alarm: bool, homing: bool) -> JobState {
    let to_do = match (homing, alarm) {
        (true, _) => home_to_go_on(),
        (false, true) => CHECK_THE_PLACE.to_owned(),
        (false, false) => WHAT_TO_DO.to_owned(),
    };
    let reason = format!("position lost: {what}; {}", to_do.replace("ID", &job.to_string()));
    tracing::warn!(job, reason = %reason, "the device's position cannot be trusted: the job waits for a person");
    JobState::paused(PauseCause::PositionLost, reason)
}

/// The pause of job `job` on a board in `alarm`: locked until homed
/// ([`PauseCause::NeedsHoming`]), or, for an alarm it raised, lost.
pub(super) fn alarmed(job: JobId, alarm: Alarm, homing: bool) -> JobState {
    if alarm != Alarm::NeedsHoming {
        return lost(job, &alarm, true, homing);
    }
    let to_do = if homing { home_to_go_on() } else { park_to_unlock() };
    let reason = format!("needs homing: {alarm}; {}", to_do.replace("ID", &job.to_string()));
    tracing::warn!(job, reason = %reason, "the board is locked until homed: the job waits for a person");
    JobState::paused(PauseCause::NeedsHoming, reason)
}

/// Whether a job paused with `cause` is watched while it waits: its
/// plotter is asked whether it is there, so that `status` shows when it is
/// back (and, for a lost link alone, `auto_resume` goes on).
pub(super) fn watched(cause: PauseCause) -> bool {
    matches!(cause, PauseCause::Offline | PauseCause::PositionLost | PauseCause::NeedsHoming)
}

/// What a person's `resume` of job `id` in `state` lets its next run do to
/// the device (`position_confirmed`: the person said the pen is at the
/// origin; `homing`: the plotter has homing switches), or why it may not
/// go on.
pub(super) fn may_resume(id: JobId, state: &JobState, position_confirmed: bool, homing: bool) -> Result<Restore, ControlError> {
    match state.pause_cause() {
        Some(PauseCause::PositionLost | PauseCause::NeedsHoming) if position_confirmed => Ok(Restore::Confirmed),
        Some(PauseCause::PositionLost | PauseCause::NeedsHoming) if homing => Ok(Restore::Home),
        Some(PauseCause::PositionLost) => Err(ControlError::PositionLost(id)),
        Some(PauseCause::NeedsHoming) => Err(ControlError::NeedsHoming(id)),
        _ => Ok(Restore::Nothing),
    }
}
