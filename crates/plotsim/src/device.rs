//! The interface between the link (pty, pacing, faults) and a personality.
//!
//! A personality is a plain state machine: bytes in, reply bytes out, work done
//! up to an instant. It never touches file descriptors or sleeps, so unit tests
//! drive it directly with a fake clock.

use crate::record::Record;
use std::time::{Duration, Instant};

/// What a personality may touch while handling a byte or running.
pub(crate) struct Ctx<'a> {
    /// The current time.
    pub now: Instant,
    /// Bytes to send to the host.
    pub out: &'a mut Vec<u8>,
    /// The run's record.
    pub record: &'a mut Record,
    /// Wall-clock seconds per simulated second (0 = instant).
    pub speed_scale: f64,
    /// Set by the `garbage` fault: the next reply is replaced by noise.
    pub garble_next: &'a mut bool,
}

/// Noise sent instead of a reply by the `garbage` fault: bytes no reply
/// contains (high-bit and punctuation), then the reply's own terminator so a
/// line-reading host does not hang on it.
const GARBAGE: &[u8] = b"\xfe#\x8f?\xa5!%";

impl Ctx<'_> {
    /// Sends a reply (answer to a query, `ok`, a status report).
    pub fn reply(&mut self, text: &[u8], terminator: &[u8]) {
        if std::mem::take(self.garble_next) {
            self.out.extend_from_slice(GARBAGE);
        } else {
            self.out.extend_from_slice(text);
        }
        self.out.extend_from_slice(terminator);
        self.record.replies += 1;
    }

    /// Wall-clock duration of `sim_seconds` of plotting.
    pub fn scaled(&self, sim_seconds: f64) -> Duration {
        let s = sim_seconds * self.speed_scale;
        if s.is_finite() && s > 0.0 {
            Duration::from_secs_f64(s.min(1e6))
        } else {
            Duration::ZERO
        }
    }
}

/// A snapshot of the device for waits and tests.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DeviceStatus {
    /// Bytes waiting in the input buffer.
    pub buffer_used: usize,
    /// Input buffer size (logical: HP's `ESC.@` can shrink it).
    pub buffer_capacity: usize,
    /// Nothing buffered, nothing moving (a last instruction still waiting
    /// for its terminator does not count).
    pub idle: bool,
    /// Position in device units.
    pub position: [f64; 2],
    /// Pen down?
    pub pen_down: bool,
    /// Personality state: HP `ready`/`lever up`; GRBL `Idle`, `Run`, `Hold:0`, `Alarm`, `Check`.
    pub state: String,
    /// Hardware-handshake line (the plotter's CTS/DTR output): false while the
    /// buffer has less free space than the block size. A pty has no modem lines,
    /// so this is where tests read it.
    pub cts: bool,
    /// XOFF was sent and XON not yet.
    pub xoff: bool,
}

/// A plotter personality.
pub(crate) trait Device: Send {
    /// A byte arrives over the link.
    fn receive(&mut self, byte: u8, ctx: &mut Ctx<'_>);
    /// Does buffered work that is due by `ctx.now`; returns when it next has
    /// work due, `None` when it waits for input (or is paused).
    fn run(&mut self, ctx: &mut Ctx<'_>) -> Option<Instant>;
    /// A snapshot for waits and tests.
    fn status(&self) -> DeviceStatus;
    /// Power off and on: buffer, parser and modal state lost.
    fn power_cycle(&mut self, ctx: &mut Ctx<'_>);
    /// The device's reset. A plotter with no reset line (HP) is reset by
    /// its power switch: a power cycle. GRBL has its own: the reset button,
    /// or an Arduino's DTR pulse when the port opens.
    fn reset(&mut self, ctx: &mut Ctx<'_>) {
        self.power_cycle(ctx);
    }
    /// A person moves the carriage by hand to the paper's origin, the pen
    /// up; the device is not told. Only where motors let go of the
    /// carriage (GRBL).
    fn park(&mut self, _ctx: &mut Ctx<'_>) -> Result<(), String> {
        Err("this plotter's motors hold its carriage, and it finds its own origin at power-on".into())
    }
    /// Paper lever (HP): up pauses plotting.
    fn set_lever(&mut self, up: bool) -> Result<(), String>;
    /// GRBL: raises `ALARM:code` now, as a hard limit switch does: motion
    /// stops where it is, everything received and planned is dropped, and the
    /// board is locked (G-code answers `error:9`) until `$X`.
    fn alarm(&mut self, code: u32, ctx: &mut Ctx<'_>) -> Result<(), String>;
    /// GRBL: the lines in the receive buffer (and the one being read, with
    /// the rest of it still on the wire) are lost unanswered, as on a board
    /// whose serial handler hung: it finishes
    /// what it planned and reports `Idle` with the host's lines in flight.
    fn lose_input(&mut self) -> Result<(), String>;
    /// Makes the next instruction of the job fail with the given device
    /// error number (`None`: the personality's usual "bad instruction"
    /// error); HP output instructions, the host's own queries, pass it by.
    fn fail_next(&mut self, code: Option<u32>);
    /// Bytes the device has taken from its input buffer since power-on (for
    /// tests of buffer accounting).
    fn consumed(&self) -> u64;
    /// Bytes the device takes off the link now. A USB device holds the host
    /// off when its buffers are full (nothing is lost); a serial device
    /// takes everything and loses what does not fit.
    fn rx_space(&self) -> usize {
        usize::MAX
    }
    /// The device left the bus and comes back after this long (a USB board
    /// that reset): the link goes and comes back at a new pty.
    fn take_reenumeration(&mut self) -> Option<Duration> {
        None
    }
    /// The motor supply fails, for `lasting` or until
    /// [`Device::power_restore`], while the device stays on the link.
    fn power_loss(&mut self, _lasting: Option<Duration>, _ctx: &mut Ctx<'_>) -> Result<(), String> {
        Err("only an EBB has a separate motor supply to lose".into())
    }
    /// The motor supply comes back.
    fn power_restore(&mut self, _ctx: &mut Ctx<'_>) -> Result<(), String> {
        Err("only an EBB has a separate motor supply to restore".into())
    }
    /// Someone presses the device's button (the EBB's PRG button).
    fn press_button(&mut self) -> Result<(), String> {
        Err("only an EBB has a PRG button".into())
    }
}
