//! What a restart (after a stop, a crash, a SIGKILL, a power loss) does to
//! a job found in the spool.

use super::ending::INTERRUPTED;
use crate::spool::{JobRecord, JobState, PauseCause};

/// The state a restart gives a job found in `record`'s state, when it
/// changes it. A job that was plotting comes back paused `interrupted`, for
/// a person to `resume`: **the pen must not move on its own after a
/// restart**. So does one the device held (no run goes on with it), and
/// one resumed by a person that had not moved yet. A job caught rendering
/// goes back to `queued`: nothing was drawn.
#[must_use]
pub fn after_restart(record: &JobRecord) -> Option<JobState> {
    match record.state {
        JobState::Plotting | JobState::Paused { cause: PauseCause::DeviceHold, .. } => Some(interrupted()),
        JobState::Queued if record.checkpoint > 0 => Some(interrupted()),
        JobState::Rendering => Some(JobState::Queued),
        _ => None,
    }
}

fn interrupted() -> JobState {
    JobState::paused(PauseCause::Interrupted, INTERRUPTED)
}
