//! The GRBL personality over a real pty: character counting, overflow, faults.

use crate::common;

use common::{Port, WAIT};
use plotsim::{Quirk, SimConfig, Simulator};
use std::time::Duration;

/// A square spiral drawn with the pen down, one G1 per line.
fn job(lines: usize) -> Vec<String> {
    let mut v = vec!["G21G90".to_string(), "G0X0Y0".to_string(), "M3S1000".to_string(), "F6000".to_string()];
    for i in 0..lines {
        let r = 1.0 + i as f64 * 0.25;
        let (x, y) = match i % 4 {
            0 => (r, -r),
            1 => (r, r),
            2 => (-r, r),
            _ => (-r, -r),
        };
        v.push(format!("G1X{x:.3}Y{y:.3}"));
    }
    v.push("M5".to_string());
    v
}

fn start(scale: f64) -> (Simulator, Port) {
    let sim = Simulator::start(SimConfig::grbl().with_speed_scale(scale)).unwrap();
    let mut port = Port::open(&sim.slave_path().unwrap());
    assert_eq!(port.read_until(b"\r\n"), "");
    assert_eq!(port.read_until(b"\r\n"), "Grbl 1.1h ['$' for help]");
    (sim, port)
}

#[test]
fn a_character_counting_streamer_never_overflows() {
    let (sim, mut port) = start(0.01);
    let lines = job(300);
    let mut in_flight: std::collections::VecDeque<usize> = Default::default();
    let mut oks = 0;
    let mut peak = 0;
    for l in &lines {
        let n = l.len() + 1;
        // Wait for oks until the line fits in GRBL's 128-byte receive buffer.
        while in_flight.iter().sum::<usize>() + n > 128 {
            let reply = port.read_until(b"\r\n");
            assert_eq!(reply, "ok");
            in_flight.pop_front();
            oks += 1;
        }
        port.send(format!("{l}\n").as_bytes());
        in_flight.push_back(n);
        peak = peak.max(in_flight.iter().sum::<usize>());
    }
    while in_flight.pop_front().is_some() {
        assert_eq!(port.read_until(b"\r\n"), "ok");
        oks += 1;
    }
    assert_eq!(oks, lines.len());
    sim.wait_idle(WAIT).unwrap();
    let r = sim.record();
    assert_eq!(r.overruns, 0);
    assert!(r.errors.is_empty());
    assert!(peak > 100, "the buffer was kept nearly full: {peak}");
    assert_eq!(r.strokes.len(), 1);
    assert_eq!(r.strokes[0].points.len(), 301);
}

#[test]
fn a_naive_streamer_overflows() {
    let (sim, mut port) = start(0.0);
    // Feed hold: the planner fills and stops taking lines, like a slow machine.
    port.send(b"!");
    let text: String = job(100).iter().map(|l| format!("{l}\n")).collect();
    port.send(text.as_bytes());
    sim.wait_received(1 + text.len() as u64, WAIT).unwrap();
    let s = sim.status();
    assert!(s.overruns > 0);
    assert_eq!(s.device.buffer_used, 128);
    assert_eq!(s.device.state, "Hold:0");
    port.send(b"?");
    let report = port.read_until(b">\r\n");
    assert!(report.ends_with("<Hold:0|MPos:0.000,0.000,0.000|FS:0,0"), "{report}");
}

#[test]
fn status_build_info_and_settings_over_the_wire() {
    let (_sim, mut port) = start(0.0);
    port.send(b"$I\n");
    assert_eq!(port.read_until(b"\r\n"), "[VER:1.1h.20190825:]");
    assert_eq!(port.read_until(b"\r\n"), "[OPT:V,16,128]");
    assert_eq!(port.read_until(b"\r\n"), "ok");
    port.send(b"$$\n");
    assert_eq!(port.read_until(b"\r\n"), "$0=10");
    let rest = port.read_until(b"ok\r\n");
    assert!(rest.contains("$110="));
    port.send(b"?");
    assert_eq!(port.read_until(b"\r\n"), "<Idle|MPos:0.000,0.000,0.000|FS:0,0>");
}

#[test]
fn soft_reset_and_power_cycle_print_the_banner() {
    let (sim, mut port) = start(1.0);
    port.send(b"G1X50F60\n");
    assert_eq!(port.read_until(b"\r\n"), "ok");
    sim.wait_until(WAIT, |s| s.device.state == "Run").unwrap();
    port.send(&[0x18]);
    assert_eq!(port.read_until(b"\r\n"), "ALARM:3");
    assert_eq!(port.read_until(b"\r\n"), "");
    assert_eq!(port.read_until(b"\r\n"), "Grbl 1.1h ['$' for help]");
    assert_eq!(port.read_until(b"\r\n"), "[MSG:'$H'|'$X' to unlock]");
    port.send(b"G0X0\n");
    assert_eq!(port.read_until(b"\r\n"), "error:9");
    sim.power_cycle();
    assert_eq!(port.read_until(b"\r\n"), "");
    assert_eq!(port.read_until(b"\r\n"), "Grbl 1.1h ['$' for help]");
    // Input is lost while the board boots: ask for status until it answers.
    let t0 = std::time::Instant::now();
    loop {
        port.send(b"?");
        port.poll_in(Duration::from_millis(50)).expect("port alive");
        if port.inbox.starts_with(b"<") {
            break;
        }
        assert!(t0.elapsed() < WAIT, "the board never came out of boot");
    }
    assert!(port.read_until(b"\r\n").starts_with("<Idle"));
    port.send(b"G0X0\n");
    // A `?` sent just before the first answer came may be answered after it
    // (on a loaded machine, one in a few runs): status reports come at any
    // time, and a host reads past them to the line's answer, as here.
    let answer = std::iter::repeat_with(|| port.read_until(b"\r\n")).find(|l| !l.starts_with('<')).expect("an answer");
    assert_eq!(answer, "ok", "power-cycle clears the alarm");
    assert!(sim.lever(true).is_err(), "GRBL has no paper lever");
}

#[test]
fn injected_error_and_garbage_over_the_wire() {
    let (sim, mut port) = start(0.0);
    sim.fail_next(Some(22));
    port.send(b"G0X1\n");
    assert_eq!(port.read_until(b"\r\n"), "error:22");
    sim.garbage();
    port.send(b"?");
    let g = port.read_until(b"\r\n");
    assert!(!g.starts_with('<'), "{g:?}");
    port.send(b"G0X1\n");
    assert_eq!(port.read_until(b"\r\n"), "ok");
    let kinds: Vec<String> = sim.record().faults.into_iter().map(|f| f.kind).collect();
    assert_eq!(kinds, ["error", "garbage"]);
}

#[test]
fn stall_holds_lines_in_the_buffer() {
    let (sim, mut port) = start(0.0);
    sim.stall(Duration::from_millis(300)).unwrap();
    port.send(b"G0X1\n");
    let s = sim.wait_received(5, WAIT).unwrap();
    assert!(s.stalled && s.device.buffer_used == 5);
    assert_eq!(port.read_until(b"\r\n"), "ok", "answered once the stall ends");
    assert!(!sim.status().stalled);
}

/// Reads a reset board's greeting: what comes once its bootloader is done.
fn banner(port: &mut Port) {
    assert_eq!(port.read_until(b"\r\n"), "");
    assert_eq!(port.read_until(b"\r\n"), "Grbl 1.1h ['$' for help]");
}

fn oks(port: &mut Port, n: usize) {
    for _ in 0..n {
        assert_eq!(port.read_until(b"\r\n"), "ok");
    }
}

fn fault_kinds(sim: &Simulator) -> Vec<String> {
    sim.record().faults.into_iter().map(|f| f.kind).collect()
}

/// An Arduino resets when its port is opened (DTR): each time a host opens
/// it, the board restarts where the carriage stands. Bytes sent at once are
/// lost in the bootloader; the banner comes after it (and nothing the board
/// said while the port was closed). What the host then draws from "zero"
/// lands where the carriage was.
#[test]
fn reset_on_open_restarts_the_board_each_time_the_port_opens() {
    let sim = Simulator::start(SimConfig::grbl().with_speed_scale(0.0).with_quirks([Quirk::ResetOnOpen])).unwrap();
    let path = sim.slave_path().unwrap();
    let mut port = Port::open(&path);
    port.send(b"G0X5\n");
    banner(&mut port);
    port.send(b"?");
    assert_eq!(port.read_until(b"\r\n"), "<Idle|MPos:0.000,0.000,0.000|FS:0,0>", "the G0 X5 was lost");
    port.send(b"M3S1000\nG1X30F1000\nM5\nG0Y20\n");
    oks(&mut port, 4);
    sim.wait_idle(WAIT).unwrap();
    drop(port);
    assert_eq!(fault_kinds(&sim), ["reset-on-open"]);

    let mut port = Port::open(&path);
    banner(&mut port);
    port.send(b"?");
    assert_eq!(port.read_until(b"\r\n"), "<Idle|MPos:0.000,0.000,0.000|FS:0,0>");
    port.send(b"M3S1000\nG1X10F1000\nM5\n");
    oks(&mut port, 3);
    sim.wait_idle(WAIT).unwrap();
    let r = sim.record();
    let strokes: Vec<_> = r.strokes.iter().map(|s| s.points.clone()).collect();
    assert_eq!(strokes, [vec![[0.0, 0.0], [30.0, 0.0]], vec![[30.0, 20.0], [40.0, 20.0]]]);
    assert_eq!(fault_kinds(&sim), ["reset-on-open", "reset-on-open"]);
    assert!(r.errors.is_empty(), "{:?}", r.errors);

    // Unplugged and plugged in again: the new port resets it when it opens.
    drop(port);
    sim.unplug(Duration::from_millis(100)).unwrap();
    let mut port = Port::open(&sim.wait_connected(WAIT).unwrap());
    banner(&mut port);
    assert_eq!(fault_kinds(&sim), ["reset-on-open", "reset-on-open", "unplug", "reset-on-open"]);
}

/// A reset by hand (the `reset` control): the board restarts at its own
/// zero where the carriage stands; parked by hand at the paper's origin, it
/// draws in place again. A board that requires homing is locked after the
/// reset and homing finds the paper's frame by itself.
#[test]
fn reset_then_park_or_home_puts_the_drawing_back_in_place() {
    let (sim, mut port) = start(0.0);
    port.send(b"G0X50Y40\n");
    oks(&mut port, 1);
    sim.wait_idle(WAIT).unwrap();
    sim.reset();
    banner(&mut port);
    sim.park().unwrap();
    port.send(b"M3S1000\nG1X10F1000\nM5\n");
    oks(&mut port, 3);
    sim.wait_idle(WAIT).unwrap();
    assert_eq!(sim.record().strokes[0].points, vec![[0.0, 0.0], [10.0, 0.0]]);
    assert_eq!(fault_kinds(&sim), ["reset", "park"]);

    let sim = Simulator::start(SimConfig::grbl().with_speed_scale(0.0).with_quirks([Quirk::HomingRequired])).unwrap();
    let mut port = Port::open(&sim.slave_path().unwrap());
    banner(&mut port);
    assert_eq!(port.read_until(b"\r\n"), "[MSG:'$H'|'$X' to unlock]");
    port.send(b"$H\nG0X50Y40\n");
    oks(&mut port, 2);
    sim.wait_idle(WAIT).unwrap();
    sim.reset();
    banner(&mut port);
    assert_eq!(port.read_until(b"\r\n"), "[MSG:'$H'|'$X' to unlock]");
    assert_eq!(sim.status().device.state, "Alarm");
    port.send(b"G0X0\n$H\nM3S1000\nG1X10F1000\nM5\n");
    assert_eq!(port.read_until(b"\r\n"), "error:9");
    oks(&mut port, 4);
    sim.wait_idle(WAIT).unwrap();
    let r = sim.record();
    assert_eq!(r.strokes[0].points, vec![[-1.0, -1.0], [10.0, -1.0]]);
    assert!(!r.unlocked_without_homing, "homed, never unlocked");
    assert!(sim.park().is_ok());
    let hp = Simulator::start(SimConfig::hp7475a().with_speed_scale(0.0)).unwrap();
    assert!(hp.park().is_err(), "an HP plotter's motors hold its carriage");
}
