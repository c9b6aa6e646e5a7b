//! The GRBL personality driven directly, with a hand-moved clock.

use super::*;
use crate::record::Record;
use std::time::Duration;

struct Rig {
    g: Grbl,
    record: Record,
    out: Vec<u8>,
    now: Instant,
    garble: bool,
    scale: f64,
}

impl Rig {
    fn new(cfg: SimConfig) -> Rig {
        let now = Instant::now();
        let mut out = Vec::new();
        let g = Grbl::new(&cfg, now, &mut out);
        Rig { g, record: Record::default(), out, now, garble: false, scale: cfg.speed_scale }
    }

    fn instant() -> Rig {
        let mut r = Rig::new(SimConfig::grbl().with_speed_scale(0.0));
        assert_eq!(r.take(), "\r\nGrbl 1.1h ['$' for help]\r\n");
        r
    }

    fn with<R>(&mut self, f: impl FnOnce(&mut Grbl, &mut Ctx<'_>) -> R) -> R {
        let mut ctx =
            Ctx { now: self.now, out: &mut self.out, record: &mut self.record, speed_scale: self.scale, garble_next: &mut self.garble };
        f(&mut self.g, &mut ctx)
    }

    fn arrive(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.record.bytes_received += 1;
            self.with(|g, ctx| g.receive(b, ctx));
        }
    }

    fn run(&mut self) -> Option<Instant> {
        self.with(|g, ctx| g.run(ctx))
    }

    fn send(&mut self, bytes: &[u8]) -> String {
        self.arrive(bytes);
        self.run();
        self.take()
    }

    /// Real-time motion at constant speed (no acceleration), so that times
    /// and positions are easy to work out; the banner read.
    fn timed(quirks: &[Quirk]) -> Rig {
        let mut cfg = SimConfig::grbl().with_speed_scale(1.0).with_quirks(quirks.iter().copied());
        cfg.motion.acceleration = None;
        let mut r = Rig::new(cfg);
        r.take();
        r
    }

    /// The reset line pulled, and the bootloader's time passed.
    fn reset_and_boot(&mut self) {
        self.with(|g, ctx| g.reset(ctx));
        self.now += RESET_BOOT;
        self.run();
    }

    /// Runs the clock forward until nothing is due.
    fn finish(&mut self) {
        while let Some(t) = self.run() {
            self.now = t.max(self.now);
        }
    }

    fn take(&mut self) -> String {
        String::from_utf8_lossy(&std::mem::take(&mut self.out)).into_owned()
    }
}

#[test]
fn every_line_is_answered_ok_or_error() {
    let mut r = Rig::instant();
    assert_eq!(r.send(b"G21 G90\n"), "ok\r\n");
    assert_eq!(r.send(b"g1 x10 (comment) y5 f600 ; tail\n"), "ok\r\n");
    assert_eq!(r.send(b"\n"), "ok\r\n", "empty line");
    assert_eq!(r.send(b"G1X\n"), "error:2\r\n");
    assert_eq!(r.send(b"M7 M8\n"), "error:21\r\n");
    assert_eq!(r.send(b"G0X1\r\n"), "ok\r\nok\r\n", "CR and LF each end a line, as in GRBL");
    let codes: Vec<u32> = r.record.errors.iter().map(|e| e.code).collect();
    assert_eq!(codes, vec![2, 21]);
}

#[test]
fn long_lines_answer_error_11() {
    let mut r = Rig::instant();
    let mut line = b"G1X1".to_vec();
    line.resize(90, b'0');
    line.push(b'\n');
    assert_eq!(r.send(&line), "error:11\r\n");
    // 79 characters still fit.
    let mut ok = b"G0X".to_vec();
    ok.resize(79, b'0');
    ok.push(b'\n');
    assert_eq!(r.send(&ok), "ok\r\n");
}

#[test]
fn pen_follows_the_spindle_and_strokes_are_recorded() {
    let mut r = Rig::instant();
    r.send(b"G21G90F1000\nG0X10Y10\nM3S1000\nG1X20Y10\nG1X20Y20\nM5\nG0X0Y0\nM3S1000\nG1X5Y0\nM5\n");
    r.finish();
    let s = &r.record.strokes;
    assert_eq!(s.len(), 2);
    assert_eq!(s[0].points, vec![[10.0, 10.0], [20.0, 10.0], [20.0, 20.0]]);
    assert_eq!(s[1].points, vec![[0.0, 0.0], [5.0, 0.0]]);
    assert_eq!(r.record.travel, vec![[10.0, 10.0], [0.0, 0.0]], "where the pen-up moves ended");
}

#[test]
fn pen_can_follow_z_instead() {
    let mut cfg = SimConfig::grbl().with_speed_scale(0.0);
    cfg.grbl_pen = GrblPen::ZBelow(0.5);
    let mut r = Rig::new(cfg);
    r.send(b"G0Z5\nG0X1Y1\nG1Z0F500\nG1X2Y1\nG0Z5\nG0X3Y3\n");
    r.finish();
    assert_eq!(r.record.strokes.len(), 1);
    assert_eq!(r.record.strokes[0].points, vec![[1.0, 1.0], [2.0, 1.0]]);
    assert_eq!(r.record.travel, vec![[1.0, 1.0], [3.0, 3.0]], "a Z lift alone is no travel");
}

#[test]
fn receive_buffer_overflow_loses_bytes() {
    let mut r = Rig::instant();
    // A stalled planner (feed hold with a full planner) stops reading lines.
    r.g.hold = true;
    let line = b"G1X1F100\n";
    for _ in 0..40 {
        r.arrive(line);
        r.run();
    }
    // 16 blocks in the planner, one line waiting, 128 bytes buffered, the rest lost.
    assert_eq!(r.g.planner.len(), 16);
    assert_eq!(r.g.rx.len(), 128);
    assert!(r.record.overruns > 0);
    assert_eq!(r.record.overruns, 40 * 9 - 128 - 17 * 9);
}

#[test]
fn status_reports_state_position_and_buffers() {
    let mut r = Rig::timed(&[]);
    assert_eq!(r.send(b"?"), "<Idle|MPos:0.000,0.000,0.000|FS:0,0>\r\n");
    assert_eq!(r.send(b"$10=3\n"), "ok\r\n");
    // 60 mm at 600 mm/min: six seconds.
    r.send(b"G1X60F600\n");
    r.now += Duration::from_secs(3);
    r.run();
    let s = r.send(b"?");
    assert!(s.starts_with("<Run|MPos:30.000,0.000,0.000|Bf:16,128|FS:600,0>"), "{s}");
    r.send(b"!");
    r.now += Duration::from_secs(10);
    r.run();
    assert!(r.send(b"?").starts_with("<Hold:0|MPos:30.000"), "a feed hold stops the clock");
    r.send(b"~");
    r.now += Duration::from_secs(3);
    r.run();
    assert!(r.send(b"?").starts_with("<Idle|MPos:60.000"));
    assert!((r.record.plot_seconds - 6.0).abs() < 1e-9);
}

/// M0 is a program pause: the moves before it finish, then the board holds
/// (lines after it are read and queued, not run) until cycle start.
#[test]
fn m0_holds_after_the_moves_before_it_until_cycle_start() {
    let mut r = Rig::instant();
    assert_eq!(r.send(b"G0X10\nM0\nG0X20\n"), "ok\r\nok\r\nok\r\n");
    r.run();
    assert!(r.send(b"?").starts_with("<Hold:0|MPos:10.000"), "held at the pause");
    r.send(b"~");
    r.run();
    assert!(r.send(b"?").starts_with("<Idle|MPos:20.000"), "cycle start runs the rest");
    // M1 (optional stop) is ignored, as GRBL does without the switch.
    assert_eq!(r.send(b"M1\nG0X5\n"), "ok\r\nok\r\n");
    r.run();
    assert!(r.send(b"?").starts_with("<Idle|MPos:5.000"));
}

#[test]
fn realtime_bytes_bypass_the_buffer_even_mid_line() {
    let mut r = Rig::instant();
    r.arrive(b"G0X");
    assert!(r.send(b"?").starts_with("<Idle"));
    assert_eq!(r.send(b"5\n"), "ok\r\n");
    assert_eq!(r.g.at, [5.0, 0.0, 0.0]);
}

#[test]
fn system_commands() {
    let mut r = Rig::instant();
    assert_eq!(r.send(b"$I\n"), "[VER:1.1h.20190825:]\r\n[OPT:V,16,128]\r\nok\r\n");
    let all = r.send(b"$$\n");
    assert!(all.starts_with("$0=10\r\n") && all.ends_with("$132=200.000\r\nok\r\n"), "{all}");
    assert_eq!(r.send(b"$H\n"), "error:5\r\n");
    assert_eq!(r.send(b"$Q\n"), "error:3\r\n");
    assert_eq!(r.send(b"$999=1\n"), "error:3\r\n");
    assert_eq!(r.send(b"$\n"), format!("{}\r\nok\r\n", reports::HELP));
    assert!(r.send(b"$G\n").starts_with("[GC:G0 G54 G17 G21 G90 G94 M5 M9 T0 F0 S0]"));
}

#[test]
fn check_mode_parses_without_moving_and_leaves_by_reset() {
    let mut r = Rig::instant();
    assert_eq!(r.send(b"$C\n"), "[MSG:Enabled]\r\nok\r\n");
    assert!(r.send(b"?").starts_with("<Check"));
    assert_eq!(r.send(b"M3S100\nG1X10F100\nG1Q1\n"), "ok\r\nok\r\nerror:20\r\n");
    r.finish();
    assert!(r.record.strokes.is_empty());
    assert_eq!(r.send(b"$C\n"), "[MSG:Disabled]\r\nok\r\n\r\nGrbl 1.1h ['$' for help]\r\n");
    assert!(r.send(b"?").starts_with("<Idle|MPos:0.000"));
}

#[test]
fn soft_reset_in_motion_alarms_until_unlocked() {
    let mut r = Rig::new(SimConfig::grbl().with_speed_scale(1.0));
    r.take();
    r.send(b"G1X100F100\nG1X0\n");
    r.arrive(&[0x18]);
    assert_eq!(r.take(), "ALARM:3\r\n\r\nGrbl 1.1h ['$' for help]\r\n[MSG:'$H'|'$X' to unlock]\r\n");
    assert!(r.send(b"?").starts_with("<Alarm"));
    assert_eq!(r.send(b"G0X1\n"), "error:9\r\n");
    assert_eq!(r.send(b"$X\n"), "[MSG:Caution: Unlocked]\r\nok\r\n");
    assert_eq!(r.send(b"G0X1\n"), "ok\r\n");
    // A reset while idle is quiet.
    r.finish();
    r.arrive(&[0x18]);
    assert_eq!(r.take(), "\r\nGrbl 1.1h ['$' for help]\r\n");
}

/// A reset once a feed hold is complete stops nothing in motion (GRBL's
/// `mc_reset` alarms only in a cycle or a hold still decelerating): no
/// alarm, the position kept, the buffers and the rest of the job dropped,
/// the spindle (a servo pen) off. How a sender stops a job now.
#[test]
fn soft_reset_in_a_completed_hold_keeps_the_position_without_alarm() {
    let mut r = Rig::timed(&[]);
    r.send(b"M3S1000\nG1X60F600\nG1X0\n");
    r.now += Duration::from_secs(3);
    r.run();
    r.send(b"!");
    assert!(r.send(b"?").starts_with("<Hold:0|MPos:30.000"));
    r.arrive(&[0x18]);
    assert_eq!(r.take(), "\r\nGrbl 1.1h ['$' for help]\r\n", "no alarm");
    r.now += Duration::from_secs(10);
    r.run();
    assert!(r.send(b"?").starts_with("<Idle|MPos:30.000,0.000,0.000|FS:0,0>"), "position kept, nothing left to run");
    assert_eq!(r.send(b"G0X1\n"), "ok\r\n", "not locked");
}

#[test]
fn hard_limit_alarm_drops_what_was_planned_and_locks_until_unlocked() {
    let mut r = Rig::new(SimConfig::grbl().with_speed_scale(1.0));
    r.take();
    assert_eq!(
        r.send(
            b"M3S1000
G1X100F600
G1X100Y100
"
        ),
        "ok\r\nok\r\nok\r\n"
    );
    r.arrive(b"G1X0Y");
    r.now += Duration::from_secs(1);
    r.run();
    assert!(r.with(|g, ctx| g.alarm(1, ctx)).is_ok());
    assert_eq!(r.take(), "ALARM:1\r\n");
    let st = r.g.status();
    assert_eq!(st.state, "Alarm");
    assert!(!st.pen_down && st.idle, "{st:?}");
    // Stopped part way along the first move; the second never runs.
    assert!(st.position[0] > 0.0 && st.position[0] < 100.0 && st.position[1] == 0.0, "{st:?}");
    assert_eq!(r.record.errors.last().map(|e| e.code), Some(1));
    // The half line received before the alarm is gone too.
    assert_eq!(r.send(b"100\n"), "error:9\r\n");
    assert_eq!(r.send(b"G0X1\n"), "error:9\r\n");
    assert_eq!(r.send(b"$X\n"), "[MSG:Caution: Unlocked]\r\nok\r\n");
    assert_eq!(r.send(b"G0X1\n"), "ok\r\n");
    r.finish();
    assert_eq!(r.g.status().position, [1.0, 0.0]);
    assert!(r.with(|g, ctx| g.alarm(42, ctx)).is_err());
}

#[test]
fn planner_fills_to_16_blocks_and_ok_waits_for_room() {
    let mut r = Rig::new(SimConfig::grbl().with_speed_scale(1.0));
    r.take();
    let mut oks = 0;
    for i in 0..20 {
        oks += r.send(format!("G1X{}F6000\n", i + 1).as_bytes()).matches("ok").count();
    }
    // One block executing, 16 planned, the 18th line waits for room.
    assert_eq!(oks, 17);
    assert_eq!(r.g.planner.len(), 16);
    r.finish();
    assert_eq!(r.take().matches("ok").count(), 3);
}

#[test]
fn spindle_changes_wait_for_the_planner() {
    let mut r = Rig::new(SimConfig::grbl().with_speed_scale(1.0));
    r.take();
    assert_eq!(r.send(b"G1X10F600\n"), "ok\r\n");
    assert_eq!(r.send(b"M3S500\n"), "", "M3 syncs: no ok until the move is done");
    r.finish();
    assert_eq!(r.take(), "ok\r\n");
}

#[test]
fn injected_error_and_garbage() {
    let mut r = Rig::instant();
    r.g.fail_next(None);
    assert_eq!(r.send(b"G0X1\n"), "error:20\r\n");
    r.garble = true;
    let g = r.send(b"G0X1\n");
    assert!(!g.contains("ok") && g.ends_with("\r\n"));
    assert_eq!(r.send(b"G0X2\n"), "ok\r\n");
}

#[test]
fn power_cycle_prints_the_banner_and_forgets_everything() {
    let mut r = Rig::new(SimConfig::grbl().with_speed_scale(1.0));
    r.take();
    r.send(b"$10=3\nG1X100F100\n");
    r.with(|g, ctx| g.power_cycle(ctx));
    assert_eq!(r.take(), "\r\nGrbl 1.1h ['$' for help]\r\n");
    // While the bootloader runs, input is lost.
    assert_eq!(r.send(b"?"), "");
    r.now += Duration::from_millis(200);
    assert_eq!(r.send(b"?"), "<Idle|MPos:0.000,0.000,0.000|FS:0,0>\r\n");
    assert!(r.g.set_lever(true).is_err());
}

#[test]
fn random_bytes_never_panic_and_every_line_is_answered() {
    let mut r = Rig::instant();
    let mut x: u64 = 0x2545_f491_4f6c_dd1d;
    let mut lines = 0;
    for round in 0..20_000 {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        let b = match x % 8 {
            0 => b'\n',
            1 => b"GMXYZFSIJRP$"[(x >> 8) as usize % 12],
            2 | 3 => b"0123456789.-"[(x >> 8) as usize % 12],
            4 => b"()=;"[(x >> 8) as usize % 4],
            _ => (x >> 16) as u8 & 0x7f,
        };
        // Real-time bytes are left out: a reset drops lines without answering them.
        if matches!(b, b'?' | b'!' | b'~' | 0x18 | b'\r') {
            continue;
        }
        if b == b'\n' {
            lines += 1;
        }
        r.arrive(&[b]);
        if round % 5 == 0 {
            r.finish();
        }
    }
    r.arrive(b"\n");
    lines += 1;
    r.finish();
    let out = r.take();
    let answers = out.matches("ok\r\n").count() + out.matches("error:").count();
    assert_eq!(r.record.overruns, 0);
    assert_eq!(answers, lines, "one ok or error per line");
}

/// A serial handler that hangs loses the line it was receiving whole: the
/// rest of that line, still on the wire then (a pty hands bytes over in
/// pieces, so some may come after the loss), is not read as a line of its
/// own. It would be a valid move (`Y5`) answered `ok`, and a host counting
/// answers would take that `ok` for a lost line's.
#[test]
fn lost_input_takes_the_rest_of_the_line_on_the_wire_with_it() {
    let mut r = Rig::instant();
    assert_eq!(r.send(b"G1 X10 F600\n"), "ok\r\n");
    r.arrive(b"G1 X2");
    r.g.lose_input().unwrap();
    assert_eq!(r.send(b"0 Y5\n"), "", "the tail of the lost line");
    assert_eq!(r.send(b"G0 X1\n"), "ok\r\n", "the next whole line");
    r.finish();
    assert_eq!(r.g.at, [1.0, 0.0, 0.0]);
    // Lost at a line boundary, the next line is whole and read.
    r.g.lose_input().unwrap();
    assert_eq!(r.send(b"G0 X3\n"), "ok\r\n");
}

const BANNER: &str = "\r\nGrbl 1.1h ['$' for help]\r\n";
const LOCKED: &str = "[MSG:'$H'|'$X' to unlock]\r\n";

fn homing_board(scale: f64) -> Rig {
    Rig::new(SimConfig::grbl().with_speed_scale(scale).with_quirks([Quirk::HomingRequired]))
}

/// GRBL 1.1 with `$22=1` (HOMING_INIT_LOCK): it powers up in the alarm
/// state and says so after the banner (no `ALARM:n` line: nothing failed),
/// refuses G-code with error 9 and `$C` with error 8, answers `$` commands,
/// and `$H` homes it: the machine position becomes `-$27` on each axis
/// homed towards its positive end ($23=0), and it takes G-code again.
#[test]
fn a_board_that_requires_homing_boots_locked_until_homed() {
    let mut r = homing_board(0.0);
    assert_eq!(r.take(), format!("{BANNER}{LOCKED}"));
    assert_eq!(r.send(b"?"), "<Alarm|MPos:0.000,0.000,0.000|FS:0,0>\r\n");
    assert_eq!(r.send(b"G0X10\n"), "error:9\r\n");
    assert_eq!(r.send(b"M3S1000\n"), "error:9\r\n");
    assert_eq!(r.send(b"$C\n"), "error:8\r\n", "check mode needs the board idle");
    assert!(r.send(b"$$\n").contains("$22=1\r\n"));
    assert_eq!(r.send(b"$H\n"), "ok\r\n");
    assert_eq!(r.send(b"?"), "<Idle|MPos:-1.000,-1.000,0.000|FS:0,0>\r\n");
    assert_eq!(r.send(b"G0X10\n"), "ok\r\n");
    r.finish();
    assert_eq!(r.send(b"?"), "<Idle|MPos:10.000,-1.000,0.000|FS:0,0>\r\n");
    assert!(!r.record.unlocked_without_homing);
    assert_eq!(r.record.errors.iter().map(|e| e.code).collect::<Vec<_>>(), [9, 9, 8]);
    // Homing towards the negative ends ($23=3): the position is -$130 + $27.
    assert_eq!(r.send(b"$23=3\n$130=300\n$H\n"), "ok\r\nok\r\nok\r\n");
    assert_eq!(r.send(b"?"), "<Idle|MPos:-299.000,-199.000,0.000|FS:0,0>\r\n");
    // Without homing enabled, $H is refused.
    let mut r = Rig::instant();
    assert_eq!(r.send(b"$H\n"), "error:5\r\n");
}

/// `$X` unlocks a board without homing it, with GRBL's caution; the record
/// keeps that it happened (a host must never do it unasked). `$X` after a
/// later alarm, once homed, is not that.
#[test]
fn unlocking_without_homing_is_recorded() {
    let mut r = homing_board(0.0);
    r.take();
    assert_eq!(r.send(b"$X\n"), "[MSG:Caution: Unlocked]\r\nok\r\n");
    assert!(r.record.unlocked_without_homing);
    assert_eq!(r.send(b"G0X5\n"), "ok\r\n");

    let mut r = homing_board(0.0);
    r.take();
    assert_eq!(r.send(b"$H\n"), "ok\r\n");
    r.with(|g, ctx| g.alarm(1, ctx)).unwrap();
    assert_eq!(r.send(b"$X\n"), "ALARM:1\r\n[MSG:Caution: Unlocked]\r\nok\r\n");
    assert!(!r.record.unlocked_without_homing);
}

/// Homing runs at the seek rate ($25) to the switches, then locates them
/// ($27 off at the seek rate, back at the feed rate $24, off again); `?`
/// reports `Home` meanwhile, the `ok` comes when it is done, and lines sent
/// meanwhile wait. The pen draws nothing on the way (a servo pen is up after
/// power-on).
#[test]
fn homing_takes_the_time_of_its_moves_and_answers_when_done() {
    let mut r = Rig::timed(&[Quirk::HomingRequired]);
    assert_eq!(r.send(b"$X\nG0X50Y20\n"), "[MSG:Caution: Unlocked]\r\nok\r\nok\r\n");
    r.finish();
    let before = r.record.plot_seconds;
    assert_eq!(r.send(b"$H\nG0X0\n"), "");
    assert!(r.send(b"?").starts_with("<Home|MPos:50.000,20.000"), "at the start of the cycle");
    assert_eq!(r.send(b"!~?").split('|').next(), Some("<Home"), "a feed hold does not stop homing");
    r.finish();
    assert_eq!(r.take(), "ok\r\nok\r\n");
    // 50 mm to the X switch at 500 mm/min, then 1 mm off it at 500, back at
    // 25 mm/min, and off again at 500.
    let want = (50.0 + 2.0) / (500.0 / 60.0) + 1.0 / (25.0 / 60.0);
    let homing = r.record.plot_seconds - before;
    assert!(homing > want && homing < want + 0.1, "{homing} s, the G0 X0 after it included; homing alone {want} s");
    assert_eq!(r.send(b"?"), "<Idle|MPos:0.000,-1.000,0.000|FS:0,0>\r\n");
    assert!(r.record.strokes.is_empty());
}

/// A soft reset (0x18) during homing alarms with 6, as GRBL's does; the
/// board is still not homed.
#[test]
fn a_soft_reset_during_homing_is_alarm_6() {
    let mut r = homing_board(1.0);
    r.take();
    r.send(b"$H\n");
    r.now += Duration::from_millis(500);
    r.run();
    r.arrive(&[0x18]);
    assert_eq!(r.take(), format!("ALARM:6\r\n{BANNER}{LOCKED}"));
    assert_eq!(r.send(b"G0X1\n"), "error:9\r\n");
    assert_eq!(r.record.errors.iter().find(|e| e.kind == "alarm").map(|e| e.code), Some(6));
}

/// The reset line (button, or an Arduino's DTR when its port opens): the
/// chip restarts where the carriage stands, which becomes the board's zero.
/// Motion stops where it is (the pen drew up to there) with no message;
/// input is lost while the bootloader runs, and the banner comes after it.
/// The `$` settings are kept (EEPROM). The record stays on the paper: what
/// is drawn after lands shifted by where the reset happened.
#[test]
fn a_reset_loses_the_position_and_the_paper_shows_it() {
    let mut r = Rig::timed(&[]);
    r.send(b"$10=3\nG0X100Y50\nM3S1000\nG1X160F600\n");
    r.finish();
    r.send(b"G1X100\n");
    r.now += Duration::from_secs(3);
    r.run();
    r.with(|g, ctx| g.reset(ctx));
    assert_eq!(r.take(), "", "the chip restarts: nothing said");
    assert_eq!(r.record.strokes[0].points, vec![[100.0, 50.0], [160.0, 50.0], [130.0, 50.0]], "drawn up to the reset");
    assert_eq!(r.g.status().state, "Boot");
    assert_eq!(r.send(b"?G0X1\n"), "", "lost in the bootloader");
    r.now += RESET_BOOT;
    assert_eq!(r.run(), None);
    assert_eq!(r.take(), BANNER);
    assert_eq!(r.send(b"?"), "<Idle|MPos:0.000,0.000,0.000|Bf:16,128|FS:0,0>\r\n", "at zero, $10 kept");
    // The host draws 10 mm along x from what it believes is (0, 0).
    assert_eq!(r.send(b"M3S1000\nG1X10F600\nM5\n"), "ok\r\nok\r\n");
    r.finish();
    assert_eq!(r.take(), "ok\r\n");
    assert_eq!(r.record.strokes[1].points, vec![[130.0, 50.0], [140.0, 50.0]]);
}

/// After a reset a board that requires homing is locked again; homing
/// brings the paper's frame back.
#[test]
fn a_reset_with_homing_required_locks_until_homed_again() {
    let mut r = homing_board(0.0);
    r.take();
    assert_eq!(r.send(b"$H\nG0X40Y30\n"), "ok\r\nok\r\n");
    r.finish();
    r.reset_and_boot();
    assert_eq!(r.take(), format!("{BANNER}{LOCKED}"));
    assert_eq!(r.send(b"?"), "<Alarm|MPos:0.000,0.000,0.000|FS:0,0>\r\n");
    assert_eq!(r.send(b"$H\nM3S1000\nG1X10Y10F600\nM5\n"), "ok\r\nok\r\nok\r\nok\r\n");
    r.finish();
    assert_eq!(r.record.strokes.len(), 1);
    assert_eq!(r.record.strokes[0].points, vec![[-1.0, -1.0], [10.0, 10.0]]);
    assert!(!r.record.unlocked_without_homing);
}

/// A power cycle, unlike a reset, puts the settings back to their defaults
/// (with homing required, $22=1) and the carriage back at the origin.
#[test]
fn a_power_cycle_of_a_board_that_requires_homing_boots_it_locked() {
    let mut r = homing_board(0.0);
    r.take();
    assert_eq!(r.send(b"$22=0\n$X\nG0X40\n"), "ok\r\n[MSG:Caution: Unlocked]\r\nok\r\nok\r\n");
    r.finish();
    r.with(|g, ctx| g.power_cycle(ctx));
    assert_eq!(r.take(), format!("{BANNER}{LOCKED}"));
    r.now += Duration::from_secs(1);
    assert_eq!(r.send(b"G0X1\n"), "error:9\r\n");
}

/// Where the motors let go of the carriage, a person can move it by hand:
/// parked at the paper's origin after a reset, the board (still at its own
/// zero) draws where the host means again. Not while it moves.
#[test]
fn a_carriage_parked_by_hand_draws_from_the_paper_origin() {
    let mut r = Rig::instant();
    r.send(b"G0X40Y30\n");
    r.finish();
    r.reset_and_boot();
    assert_eq!(r.take(), BANNER);
    r.with(|g, ctx| g.park(ctx)).unwrap();
    assert_eq!(r.send(b"?"), "<Idle|MPos:0.000,0.000,0.000|FS:0,0>\r\n", "the board is not told");
    r.send(b"M3S1000\nG1X10Y5F600\nM5\n");
    r.finish();
    assert_eq!(r.record.strokes.len(), 1);
    assert_eq!(r.record.strokes[0].points, vec![[0.0, 0.0], [10.0, 5.0]]);

    let mut r = Rig::new(SimConfig::grbl().with_speed_scale(1.0));
    r.send(b"G1X100F100\n");
    let e = r.with(|g, ctx| g.park(ctx)).unwrap_err();
    assert!(e.contains("moving"), "{e}");
}
