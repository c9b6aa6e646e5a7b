//! `Streamer::locate` against plotsim over a real pty: after answers were
//! lost (an unplugged adapter, a killed daemon), where the device's pen rests
//! decides which chunk plotting goes on from, among every chunk between the
//! confirmed checkpoint and the last one written.
//!
//! Each case puts the device somewhere by streaming part of a program (and
//! perhaps a few raw bytes of the next chunk, as a write cut short would),
//! then asks `locate` as if only `checkpoint` had been confirmed.

use plotcode::answer::ErrorCode;
use plotcode::Handshake;
use plotcode::Program;
use plotd::stream::{Alarm, SerialPort, Span, StreamError, StreamSettings, Streamer, Written};
use plotsim::{Quirk, SimConfig, Simulator};
use std::time::Duration;

/// Chunk 0 and chunk 3 end at the same place, (1000, 0) with the pen down.
const HPGL: &str = "IN;SP1;PU0,0;PD1000,0;PU1000,500;PD2000,500,2000,1500;PU3000,0;PD3000,1000;PU4000,0;PD1000,0;PU;";

/// The same shape for a GRBL pen on a servo.
const GCODE: &str = "G21 G90\nM5\nG0 X0 Y0\nM3 S1000\nG1 X10 Y0 F3000\nM5\nG0 X10 Y5\nM3 S1000\nG1 X20 Y5\nG1 X20 Y15\nM5\nG0 X30 Y0\nM3 S1000\nG1 X30 Y10\nM5\nG0 X40 Y0\nM3 S1000\nG1 X10 Y0\nM5\n";

/// The same shape for a GRBL pen on a Z axis.
const GCODE_Z: &str = "G21 G90\nG0 Z5\nG0 X0 Y0\nG1 Z0 F1000\nG1 X10 Y0 F3000\nG0 Z5\nG0 X10 Y5\nG1 Z0 F1000\nG1 X20 Y5\nG1 X20 Y15\nG0 Z5\nG0 X30 Y0\nG1 Z0 F1000\nG1 X30 Y10\nG0 Z5\n";

struct Bench {
    sim: Simulator,
    program: Program,
    streamer: Streamer<SerialPort>,
    rt: tokio::runtime::Runtime,
}

impl Bench {
    fn new(sim: SimConfig, device: &str, handshake: Handshake, text: &str) -> Bench {
        let baud = sim.baud;
        let sim = Simulator::start(sim).expect("simulator starts");
        let program = plotcode::cut(text.as_bytes(), &plotcode::DeviceProfile::builtin(device).unwrap()).unwrap();
        let rt = tokio::runtime::Builder::new_current_thread().enable_all().build().unwrap();
        let port = rt.block_on(async { SerialPort::open(&sim.slave_path().unwrap(), baud, false) }).expect("pty opens");
        let mut settings = StreamSettings::new(handshake);
        settings.reply_timeout = Duration::from_secs(2);
        settings.motion_timeout = Duration::from_secs(20);
        Bench { sim, program, streamer: Streamer::new(port, settings), rt }
    }

    fn hp() -> Bench {
        Bench::new(SimConfig::hp7475a().with_speed_scale(0.0).with_baud(9600), "hp7475a", Handshake::Escb, HPGL)
    }

    fn grbl() -> Bench {
        Bench::new(SimConfig::grbl().with_speed_scale(0.0).with_baud(115_200), "grbl-servo", Handshake::Grbl, GCODE)
    }

    fn grbl_z() -> Bench {
        Bench::new(SimConfig::grbl().with_speed_scale(0.0).with_baud(115_200), "grbl-z", Handshake::Grbl, GCODE_Z)
    }

    /// Streams chunks `..until` (the device runs them) and waits until it is idle.
    fn draw(&mut self, until: usize) {
        let (_tx, mut stop) = tokio::sync::watch::channel(plotd::stream::Stop::Continue);
        let Bench { program, streamer, rt, .. } = self;
        let outcome = rt.block_on(streamer.run(Span { until, ..Span::all(program) }, &mut stop, &mut |_| {}));
        outcome.expect("run");
        self.sim.wait_idle(Duration::from_secs(20)).unwrap();
    }

    /// Writes `bytes` as a write cut short would have left them, and lets
    /// the device run them (a restart or replug takes longer than that;
    /// `locate` drops whatever the device still holds).
    fn raw(&mut self, bytes: &[u8]) {
        let Bench { streamer, rt, .. } = self;
        rt.block_on(streamer.link.write(bytes)).unwrap();
        self.sim.wait_idle(Duration::from_secs(20)).unwrap();
    }

    fn locate(&mut self, checkpoint: usize, mark: Written) -> Result<Option<usize>, StreamError> {
        let Bench { program, streamer, rt, .. } = self;
        rt.block_on(streamer.locate(program, checkpoint, mark))
    }
}

#[test]
fn hpgl_pen_at_the_end_of_a_chunk_resumes_after_it() {
    let mut b = Bench::hp();
    b.draw(2);
    // Chunks 0 and 1 ran; the answers to both were lost.
    assert_eq!(b.locate(0, Written::Through(4)).unwrap(), Some(2));
    assert_eq!(b.locate(0, Written::Into(3)).unwrap(), Some(2));
    // Nothing past the checkpoint written: where chunk 1 leaves the pen is the checkpoint.
    assert_eq!(b.locate(2, Written::Through(3)).unwrap(), Some(2));
}

#[test]
fn hpgl_pen_inside_a_chunk_draws_it_again() {
    let mut b = Bench::hp();
    b.draw(1);
    // Chunk 1 cut short after its first pen-down move.
    b.raw(b"PU1000,500;PD2000,500;");
    assert_eq!(b.locate(0, Written::Into(1)).unwrap(), Some(1));
    assert_eq!(b.locate(0, Written::Through(4)).unwrap(), Some(1));
    // Only the pen-up move to its start ran.
    b.raw(b"PU1000,500;");
    assert_eq!(b.locate(1, Written::Into(1)).unwrap(), Some(1));
    // Chunk 2 cut short after its `PU`: the pen lifts where chunk 1 left it.
    b.raw(b"PD2000,500,2000,1500;PU");
    assert_eq!(b.locate(0, Written::Through(3)).unwrap(), Some(2));
}

#[test]
fn hpgl_pen_where_two_chunks_end_takes_the_first() {
    let mut b = Bench::hp();
    b.draw(4);
    // Chunks 0 and 3 both leave the pen at (1000, 0): chunks 1 to 3 are not
    // provably drawn, so they are drawn again rather than skipped.
    assert_eq!(b.locate(0, Written::Through(4)).unwrap(), Some(1));
    // From the checkpoint right after chunk 0, that is where nothing after it ran.
    assert_eq!(b.locate(1, Written::Through(4)).unwrap(), Some(1));
    // From a checkpoint past it, only chunk 3 agrees.
    assert_eq!(b.locate(2, Written::Through(4)).unwrap(), Some(4));
}

#[test]
fn hpgl_pen_where_no_chunk_goes_falls_back_to_the_checkpoint() {
    let mut b = Bench::hp();
    b.draw(2);
    b.raw(b"PU5000,5000;");
    assert_eq!(b.locate(0, Written::Through(4)).unwrap(), None);
    // A corner of chunk 1, but with the pen up: no chunk rests there so.
    b.raw(b"PU2000,500;");
    assert_eq!(b.locate(0, Written::Through(3)).unwrap(), None);
    // Where chunk 2 would leave it, but chunk 2 was never written.
    b.raw(b"PU3000,0;PD3000,1000;");
    assert_eq!(b.locate(0, Written::Through(2)).unwrap(), None);
}

#[test]
fn hpgl_error_left_by_lost_bytes_is_reported() {
    let mut b = Bench::hp();
    b.draw(2);
    // An instruction error after the last marker that ran: its answer was lost.
    b.sim.fail_next(Some(3));
    b.raw(b"PU3000,0;");
    let e = b.locate(0, Written::Into(2)).unwrap_err();
    assert!(matches!(&e, StreamError::Device(d) if d.code == ErrorCode::Hpgl(3)), "{e}");
    // Read once: the device's register is cleared, and the next locate finds the pen.
    assert_eq!(b.locate(2, Written::Into(2)).unwrap(), Some(2));
    // An I/O error (a bad device-control byte) is one too.
    b.raw(b"\x1b.Q");
    let e = b.locate(0, Written::Through(2)).unwrap_err();
    assert!(matches!(&e, StreamError::Device(d) if d.code == ErrorCode::DeviceControl(11)), "{e}");
}

/// Fault 3: locate insisted on an ESC.L answer, which older firmware does
/// not give ("cannot tell where the device got"), and strokes were drawn
/// again needlessly. Before: `None`.
#[test]
fn hpgl_locate_on_firmware_without_esc_l() {
    let sim = SimConfig::hp7475a().with_speed_scale(0.0).with_baud(9600).with_quirks([Quirk::NoEscL]);
    let mut b = Bench::new(sim, "hp7475a", Handshake::Escb, HPGL);
    b.draw(2);
    assert_eq!(b.locate(0, Written::Through(4)).unwrap(), Some(2));
}

/// Fault 2: after a SIGKILL a chained `OE` was left waiting for its next
/// letter in an emulator whose ESC.K keeps it: ESC.B stayed two bytes short
/// of the size, locate polled it until the motion timeout (before: `None`
/// after 20 s here), and the stale marker's answer then confirmed a chunk
/// the pen had not drawn.
#[test]
fn hpgl_stale_half_read_marker_neither_holds_locate_nor_confirms_a_chunk() {
    let sim = SimConfig::hp7475a().with_speed_scale(0.0).with_baud(9600).with_quirks([Quirk::AbortKeepsPartial]);
    let mut b = Bench::new(sim, "hp7475a", Handshake::Escb, HPGL);
    b.draw(2);
    b.raw(b"OE");
    assert_eq!(b.locate(0, Written::Through(2)).unwrap(), Some(2));
    // Every confirmation comes after the device drew the chunk it confirms.
    let (_tx, mut stop) = tokio::sync::watch::channel(plotd::stream::Stop::Continue);
    let Bench { sim, program, streamer, rt } = &mut b;
    let total = program.chunks.len();
    let mut seen = Vec::new();
    let mut on_confirm = |k: usize| seen.push((k, sim.record().strokes.len()));
    rt.block_on(streamer.run(Span { from: 2, resume: true, ..Span::all(program) }, &mut stop, &mut on_confirm)).expect("run");
    let strokes_in = |k: usize| program.chunks[..k].iter().filter(|c| c.draws).count();
    assert_eq!(seen.last().map(|s| s.0), Some(total), "{seen:?}");
    for (k, drawn) in seen {
        assert!(drawn >= strokes_in(k), "chunk {k} confirmed with {drawn} strokes drawn of {}", strokes_in(k));
    }
}

#[test]
fn grbl_tool_at_the_end_of_a_chunk_resumes_after_it() {
    let mut b = Bench::grbl();
    b.draw(2);
    assert_eq!(b.locate(0, Written::Through(4)).unwrap(), Some(2));
    b.draw(4);
    // Chunks 0 and 3 both end at (10, 0): the first is taken.
    assert_eq!(b.locate(0, Written::Through(4)).unwrap(), Some(1));
    assert_eq!(b.locate(2, Written::Through(4)).unwrap(), Some(4));
}

#[test]
fn grbl_tool_inside_a_chunk_or_nowhere() {
    let mut b = Bench::grbl();
    b.draw(1);
    // Chunk 1 cut short after its first feed move.
    b.raw(b"G0 X10 Y5\nM3 S1000\nG1 X20 Y5\n");
    assert_eq!(b.locate(0, Written::Into(1)).unwrap(), Some(1));
    b.raw(b"G0 X50 Y50\n");
    assert_eq!(b.locate(0, Written::Through(4)).unwrap(), None);
}

/// A board in alarm says nothing of how far it got, and stopped at once:
/// locate ends with the alarm, so the job waits for a person to confirm the
/// position (issue 36; issue #15's fault 8 unlocked it silently).
#[test]
fn grbl_alarm_left_by_lost_answers_is_the_alarm() {
    let mut b = Bench::grbl();
    b.draw(2);
    b.sim.alarm(1).unwrap();
    let e = b.locate(0, Written::Through(3)).unwrap_err();
    assert!(matches!(e, StreamError::Alarm(Alarm::Raised(1))), "{e}");
}

#[test]
fn grbl_pen_down_where_a_chunk_ends_is_inside_it() {
    // A servo: `$G` shows the spindle.
    let mut b = Bench::grbl();
    b.draw(2);
    assert_eq!(b.locate(0, Written::Through(3)).unwrap(), Some(2));
    // Where chunk 1 ends, but with the pen down: its lift never ran.
    b.raw(b"M3 S1000\n");
    assert_eq!(b.locate(0, Written::Through(3)).unwrap(), Some(1));
    // A Z axis: `MPos` shows it.
    let mut b = Bench::grbl_z();
    b.draw(2);
    assert_eq!(b.locate(0, Written::Through(3)).unwrap(), Some(2));
    b.raw(b"G1 Z0 F1000\n");
    assert_eq!(b.locate(0, Written::Through(3)).unwrap(), Some(1));
}

/// Not `locate`, but the marker it relies on: a chunk that does not fit the
/// window beside the one before it can follow only once that one's `OE` is
/// answered, so that `OE` must not wait for the next chunk's first letter, or
/// the run would wait for an answer that never comes.
#[test]
fn hpgl_marker_before_a_chunk_that_cannot_share_the_window_is_answered() {
    let stroke = |x: u32| {
        let pairs: Vec<String> = (0..15).map(|i| format!("{},{}", x + i * 10, 1000 + (i % 2) * 500)).collect();
        format!("PU{x},0;PD{};", pairs.join(","))
    };
    let text = format!("IN;SP1;{}{}PU;", stroke(0), stroke(4000));
    let mut b = Bench::new(SimConfig::hp7475a().with_speed_scale(0.0).with_baud(9600), "hp7475a", Handshake::Escb, &text);
    let (c0, c1) = (b.program.chunks[0].bytes.len(), b.program.chunks[1].bytes.len());
    assert!(c0 + 2 + c1 > 256 && c1 < 256, "chunk 1 ({c1} bytes) must fit the window, but not beside chunk 0 ({c0})");
    b.streamer.settings.motion_timeout = Duration::from_secs(5);
    b.draw(3);
    assert_eq!(b.sim.record().strokes.len(), 2);
}
