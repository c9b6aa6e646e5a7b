//! Why streaming stopped short ([`StreamError`]), in types: which question
//! went unanswered, the device's error number and where it came, an
//! excerpt of what was received, what the reset looked like.

use crate::protocol::{LinkCause, LinkFault};
use plotcode::answer::ErrorCode;
use plotcode::control::{ebb, grbl, hpgl};
use std::fmt;
use std::time::Duration;
use thiserror::Error;

/// Longest excerpt of a device's answer an error quotes, in characters.
pub const MAX_EXCERPT_CHARS: usize = 60;

/// Why streaming stopped short.
#[derive(Debug, Error)]
pub enum StreamError {
    /// The port is gone (EIO, EOF, unplugged adapter).
    #[error("{}", port_gone(.0))]
    Offline(std::io::Error),
    /// The device did not answer in time.
    #[error("no answer to {0}")]
    Timeout(Unanswered),
    /// The device answered with an empty line where this answer was due.
    #[error("answered {0} with an empty line")]
    Empty(Unanswered),
    /// The device reported an error.
    #[error("device error: {0}")]
    Device(DeviceError),
    /// The device answered with something that is not an answer.
    #[error("device sends garbage: {0}")]
    Garbled(Garbled),
    /// The device was power-cycled or reset: its buffer and state are lost.
    #[error("power cycle: {0}")]
    Reset(Reset),
    /// A GRBL board in alarm: it moves no more until unlocked or homed, and
    /// its position cannot be trusted. The link is fine.
    #[error("{0}")]
    Alarm(Alarm),
    /// The device stopped answering lines it was sent while the link works
    /// (a GRBL board `Idle` with lines unanswered): resync and resume from
    /// the confirmed chunk.
    #[error("device stalled with {unanswered} lines unanswered")]
    Stalled {
        /// Lines written and never answered.
        unanswered: usize,
    },
    /// Spans ended as finished, twice in a row, having confirmed none of
    /// their chunks: the driver lost track of the device (a fault of
    /// plotd's, not the device's), so the job stops instead of asking for
    /// the same chunks for ever.
    #[error("the device finished twice having confirmed none of chunks {from}..{until}: plotd lost track of where it is")]
    Unconfirmed {
        /// The spans' first chunk.
        from: usize,
        /// The chunk after their last.
        until: usize,
    },
}

impl StreamError {
    /// Whether the link should be dropped and reopened (as opposed to a device
    /// error with the link still fine).
    #[must_use]
    pub fn link_lost(&self) -> bool {
        matches!(
            self,
            StreamError::Offline(_) | StreamError::Timeout(_) | StreamError::Empty(_) | StreamError::Garbled(_) | StreamError::Reset(_)
        )
    }

    /// Why the device is offline after this error, for `status`; `None` for
    /// an error that leaves the link fine. `waited`: how long an unanswered
    /// question was waited for, when that is known.
    #[must_use]
    pub fn link_cause(&self, waited: Option<Duration>) -> Option<LinkCause> {
        let cause = match self {
            StreamError::Offline(_) => LinkCause::new(LinkFault::PortClosed, self.to_string()),
            StreamError::Timeout(asked) => {
                let waited = waited.map(|t| format!(" for {} s", t.as_secs_f64())).unwrap_or_default();
                LinkCause::new(LinkFault::Silent, format!("no answer to {asked}{waited}"))
            }
            StreamError::Empty(_) => LinkCause::new(LinkFault::Unreadable, self.to_string()),
            StreamError::Garbled(Garbled::Noise { last, .. }) => {
                LinkCause::new(LinkFault::Unreadable, format!("answers we can't read: {last}"))
            }
            StreamError::Garbled(g) => LinkCause::new(LinkFault::Unreadable, g.to_string()),
            StreamError::Reset(r) => LinkCause::new(LinkFault::Reset, r.to_string()),
            StreamError::Device(_) | StreamError::Stalled { .. } | StreamError::Alarm(_) | StreamError::Unconfirmed { .. } => return None,
        };
        Some(cause)
    }
}

/// What a failed port says: one that closed under us (end of file, or
/// EIO/ENXIO/ENODEV, what a tty whose adapter was pulled or whose device
/// end closed returns) was unplugged or switched off; any other failure
/// is told as it is.
fn port_gone(e: &std::io::Error) -> String {
    let closed = e.kind() == std::io::ErrorKind::UnexpectedEof
        || matches!(e.raw_os_error(), Some(nix::libc::EIO | nix::libc::ENXIO | nix::libc::ENODEV));
    if closed {
        format!("the port closed: the device was unplugged or switched off ({e})")
    } else {
        format!("the port failed: {e}")
    }
}

/// What the device did not answer in time.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Unanswered {
    /// An HP-GL instruction: a device-control query, or an output
    /// instruction (`OE`, `OI`, `OA`) the buffer never ran up to.
    Hpgl(hpgl::Op),
    /// HP-GL: the buffer size, asked with ESC.L and then ESC.B.
    BufferSize,
    /// HP-GL: XON, the device having said XOFF.
    Xon,
    /// A GRBL command.
    Grbl(grbl::Op),
    /// GRBL: the banner that follows a soft reset.
    ResetBanner,
    /// An EiBotBoard command.
    Ebb(ebb::Op),
}

impl fmt::Display for Unanswered {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Unanswered::Hpgl(op) => write!(f, "{op}"),
            Unanswered::BufferSize => write!(f, "{} or {}", hpgl::Op::BufferSize, hpgl::Op::FreeSpace),
            Unanswered::Xon => f.write_str("XOFF (never XON)"),
            Unanswered::Grbl(op) => write!(f, "GRBL {op}"),
            Unanswered::Ebb(op) => write!(f, "EBB {op}"),
            Unanswered::ResetBanner => write!(f, "GRBL {} (no banner)", grbl::Op::SoftReset),
        }
    }
}

/// An error the device reported, and where in the exchange it came.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DeviceError {
    /// The device's error, by its number.
    pub code: ErrorCode,
    /// Where it came, when that says more than the number.
    pub at: Option<ErrorAt>,
}

impl DeviceError {
    /// `code`, where it came not told.
    #[must_use]
    pub fn new(code: ErrorCode) -> DeviceError {
        DeviceError { code, at: None }
    }

    /// `code`, at `at`.
    #[must_use]
    pub fn at(code: ErrorCode, at: ErrorAt) -> DeviceError {
        DeviceError { code, at: Some(at) }
    }
}

/// Where in the exchange a device reported an error.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ErrorAt {
    /// The marker after this chunk (the job's stroke) answered it.
    Stroke(usize),
    /// The line ending at this byte of the run's bytes was refused.
    RunByte(usize),
    /// The answer to the unlock of a board in alarm.
    Unlocking,
    /// The answer to the homing cycle.
    Homing,
}

impl fmt::Display for DeviceError {
    /// `HP-GL error 3 (out-of-range parameter) in stroke 12`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.code)?;
        match self.at {
            None => Ok(()),
            Some(ErrorAt::Stroke(k)) => write!(f, " in stroke {k}"),
            Some(ErrorAt::RunByte(b)) => write!(f, " at byte {b} of the run"),
            Some(ErrorAt::Unlocking) => write!(f, " (unlocking with {})", grbl::Op::Unlock),
            Some(ErrorAt::Homing) => write!(f, " (homing with {})", grbl::Op::Home),
        }
    }
}

/// What was received that is not an answer.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Garbled {
    /// More lines than a run tolerates answered nothing asked; the last of
    /// them, an excerpt.
    Noise {
        /// Lines that answered nothing asked.
        lines: usize,
        /// The last one, at most [`MAX_EXCERPT_CHARS`] characters.
        last: Excerpt,
    },
    /// GRBL's build info gave a receive buffer too small to count
    /// characters in.
    ReceiveBuffer {
        /// The size it gave, bytes.
        bytes: usize,
        /// The smallest a run can count characters in.
        least: usize,
    },
}

impl fmt::Display for Garbled {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Garbled::Noise { lines, last } => write!(f, "{lines} lines that answer nothing asked, the last {last}"),
            Garbled::ReceiveBuffer { bytes, least } => {
                write!(f, "a receive buffer of {bytes} bytes, too small to count characters in (at least {least})")
            }
        }
    }
}

/// How a reset or power cycle showed.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Reset {
    /// An HP-GL answer ended by CR, the plotter's power-on terminator, where
    /// the daemon had set LF: its buffer and settings are lost.
    PowerOnTerminator {
        /// The answer, an excerpt.
        answer: Excerpt,
    },
    /// GRBL's welcome banner: the board restarted.
    Banner(Excerpt),
    /// An EiBotBoard's motors are off (`QE`): it was reset or
    /// power-cycled, and its step counters start from zero where the
    /// carriage stands.
    MotorsOff,
    /// An EiBotBoard's motor supply (V+) failed: `QC` read `supply`, under
    /// the least the motors run on (`None`: 3.x's `QG` said it dropped
    /// since the last reading). The motors lost the steps they were sent.
    MotorPower {
        /// `QC`'s V+ reading, when that is what told.
        supply: Option<u16>,
    },
}

impl fmt::Display for Reset {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Reset::PowerOnTerminator { answer } => {
                write!(f, "the plotter answered {answer} with its power-on terminator: its buffer and settings are lost")
            }
            Reset::Banner(banner) => write!(f, "the board restarted ({})", banner.0),
            Reset::MotorsOff => f.write_str("the EiBotBoard's motors are off: it was reset or power-cycled"),
            Reset::MotorPower { supply: Some(adc) } => write!(
                f,
                "the motor power failed (V+ read {adc}, under {}): the motors lost their place",
                plotcode::answer::ebb::MIN_MOTOR_POWER_ADC
            ),
            Reset::MotorPower { supply: None } => f.write_str("the motor power dropped: the motors lost their place"),
        }
    }
}

/// Why a GRBL board is in alarm, as far as the daemon heard.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Alarm {
    /// It said why, `ALARM:N` (a hard or soft limit, a reset in motion:
    /// 1, 2, 3): it stopped at once, steps may be lost.
    Raised(u32),
    /// Mid-job, in alarm with no `ALARM:N` heard: raised while nobody read.
    Unexplained,
    /// Locked since it started, no `ALARM:N` said: a board with homing
    /// enabled (`$22=1`) starts so, and moves only once homed or
    /// unlocked (which takes where it stands for where it is).
    NeedsHoming,
}

impl fmt::Display for Alarm {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Alarm::Raised(n) => write!(f, "{}", ErrorCode::GrblAlarm(*n)),
            Alarm::Unexplained => write!(f, "{}", ErrorCode::GrblInAlarm),
            Alarm::NeedsHoming => write!(f, "the board is locked until it is homed (GRBL with homing enabled, $22=1, starts locked)"),
        }
    }
}

/// At most [`MAX_EXCERPT_CHARS`] characters of what a device sent, shown
/// quoted with control characters escaped.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Excerpt(pub String);

impl Excerpt {
    /// The start of `text`, `...` marking a cut.
    #[must_use]
    pub fn of(text: &str) -> Excerpt {
        match text.char_indices().nth(MAX_EXCERPT_CHARS) {
            Some((cut, _)) => Excerpt(format!("{}...", &text[..cut])),
            None => Excerpt(text.to_owned()),
        }
    }
}

impl fmt::Display for Excerpt {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:?}", self.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The messages a person reads: at least as clear as the strings they
    /// replace, and short whatever the device sent.
    #[test]
    fn errors_say_what_happened_in_the_devices_words() {
        let timeout = StreamError::Timeout(Unanswered::Hpgl(hpgl::Op::FreeSpace));
        assert_eq!(timeout.to_string(), "no answer to ESC.B");
        assert_eq!(StreamError::Timeout(Unanswered::BufferSize).to_string(), "no answer to ESC.L or ESC.B");
        let build_info = StreamError::Timeout(Unanswered::Grbl(grbl::Op::BuildInfo));
        assert_eq!(build_info.to_string(), format!("no answer to GRBL {}", grbl::Op::BuildInfo));
        let stroke = StreamError::Device(DeviceError::at(ErrorCode::Hpgl(3), ErrorAt::Stroke(12)));
        assert_eq!(stroke.to_string(), "device error: HP-GL error 3 (out-of-range parameter) in stroke 12");
        let unlock = StreamError::Device(DeviceError::at(ErrorCode::GrblAlarm(1), ErrorAt::Unlocking));
        let expected = format!("device error: GRBL ALARM:1 (hard limit triggered) (unlocking with {})", grbl::Op::Unlock);
        assert_eq!(unlock.to_string(), expected);
        let noise = StreamError::Garbled(Garbled::Noise { lines: 9, last: Excerpt::of(&"\u{7}x".repeat(100)) });
        let shown = noise.to_string();
        assert!(shown.starts_with("device sends garbage: 9 lines that answer nothing asked, the last \"\\u{7}x"), "{shown}");
        assert!(shown.ends_with("...\""), "{shown}");
        assert_eq!(Excerpt::of(&"x".repeat(1000)).0.len(), MAX_EXCERPT_CHARS + "...".len());
        assert_eq!(Excerpt::of("ok").0, "ok");
        let reset = StreamError::Reset(Reset::PowerOnTerminator { answer: Excerpt::of("1024") });
        assert!(reset.to_string().starts_with("power cycle: the plotter answered \"1024\" with its power-on terminator"), "{reset}");
        assert!(reset.link_lost() && timeout.link_lost() && noise.link_lost() && !stroke.link_lost());
    }

    /// Issue 36: "the port failed: unexpected end of file" for an unplug,
    /// "no answer" for an empty answer or for garbage. Each says what
    /// happened, and the cause `status` shows is typed.
    #[test]
    fn messages_point_the_right_way() {
        let eof = StreamError::Offline(std::io::Error::from(std::io::ErrorKind::UnexpectedEof));
        assert_eq!(eof.to_string(), "the port closed: the device was unplugged or switched off (unexpected end of file)");
        let eio = StreamError::Offline(std::io::Error::from_raw_os_error(nix::libc::EIO));
        assert!(eio.to_string().starts_with("the port closed: the device was unplugged"), "{eio}");
        let denied = StreamError::Offline(std::io::Error::from_raw_os_error(nix::libc::EACCES));
        assert!(denied.to_string().starts_with("the port failed: Permission denied"), "{denied}");
        assert_eq!(eof.link_cause(None).unwrap().kind, LinkFault::PortClosed);
        let empty = StreamError::Empty(Unanswered::Hpgl(hpgl::Op::Identify));
        assert_eq!(empty.to_string(), "answered OI with an empty line");
        assert!(empty.link_lost());
        assert_eq!(empty.link_cause(None).unwrap().kind, LinkFault::Unreadable);
        let silent = StreamError::Timeout(Unanswered::Hpgl(hpgl::Op::FreeSpace)).link_cause(Some(Duration::from_secs(10))).unwrap();
        assert_eq!((silent.kind, silent.message.as_str()), (LinkFault::Silent, "no answer to ESC.B for 10 s"));
        let noise = StreamError::Garbled(Garbled::Noise { lines: 3, last: Excerpt::of("##garbage##\u{1b}") });
        let cause = noise.link_cause(None).unwrap();
        assert_eq!((cause.kind, cause.message.as_str()), (LinkFault::Unreadable, "answers we can't read: \"##garbage##\\u{1b}\""));
        let device = StreamError::Device(DeviceError::new(ErrorCode::Hpgl(3)));
        assert_eq!(device.link_cause(None), None, "the link is fine");
    }
}
