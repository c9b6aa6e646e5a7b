//! What a run of chunks is asked ([`Stop`], [`Restore`]) and how it ends
//! ([`Outcome`]), and why a device may hold its work meanwhile ([`Hold`]).

/// What a run is asked to do about stopping; the latest request counts
/// when it asks for more (a stop now outranks one at the stroke's end).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord)]
pub enum Stop {
    /// Go on.
    #[default]
    Continue,
    /// Stop at the end of the chunk being written; everything written is
    /// drawn and confirmed.
    AfterStroke,
    /// Stop the pen where it is (`pause --now`, `cancel --now`): HP-GL
    /// drops the device's buffer (ESC.K), GRBL holds (`!`) and resets; the
    /// pen is lifted. Chunks not confirmed are drawn again on resume, at
    /// most the interrupted one in part.
    Now,
}

impl Stop {
    /// A person's stop: [`Stop::Now`] when `now`, else [`Stop::AfterStroke`].
    #[must_use]
    pub fn asked(now: bool) -> Stop {
        if now {
            Stop::Now
        } else {
            Stop::AfterStroke
        }
    }
}

/// What a run may do to a device whose position it cannot vouch for (a
/// GRBL board in alarm, or restarted since the job began): a person
/// decides, never the run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Restore {
    /// Nothing: the run ends with the alarm ([`super::StreamError::Alarm`])
    /// or the restart ([`super::StreamError::Reset`]), for a person.
    #[default]
    Nothing,
    /// A person parked the pen at the paper's origin and said so: an alarm
    /// is cleared (unlocked), and the board's place taken for the job's.
    Confirmed,
    /// The machine has homing switches and a person asked it to go on: it
    /// homes first, which finds its zero again.
    Home,
}

/// Why a device holds its work and waits for a person.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Hold {
    /// HP-GL ESC.O bit 5: the paper lever is raised.
    PaperLever,
}

impl std::fmt::Display for Hold {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Hold::PaperLever => "paper lever raised",
        })
    }
}

/// How a run ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Outcome {
    /// Every chunk up to `until` is confirmed.
    Finished,
    /// A stop was requested; the pen is up and every chunk written is confirmed.
    Stopped,
    /// Someone pressed the device's own button (an EiBotBoard's PRG): it
    /// stopped as [`Outcome::Stopped`] does, at the end of its stroke.
    ButtonPressed,
}
