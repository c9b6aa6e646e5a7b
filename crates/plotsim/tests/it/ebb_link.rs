//! The EBB personality over a real pty: a host's command text, USB flow
//! control, and the faults.

use crate::common;

use common::{Port, WAIT};
use plotsim::{Firmware, SimConfig, Simulator};
use std::time::Duration;

/// Sends a command and returns the reply lines up to and including the OK.
fn command(port: &mut Port, cmd: &str) -> Vec<String> {
    port.send(format!("{cmd}\r").as_bytes());
    let mut lines = Vec::new();
    loop {
        let l = port.line();
        let done = l == "OK" || l.starts_with('!');
        lines.push(l);
        if done {
            return lines;
        }
    }
}

fn start(fw: Firmware, scale: f64) -> (Simulator, Port) {
    let sim = Simulator::start(SimConfig::ebb(fw).with_speed_scale(scale)).unwrap();
    let port = Port::open(&sim.slave_path().unwrap());
    (sim, port)
}

/// The square saxi would draw: 1/8 steps (`EM,2,2`, 40 steps per mm), the
/// servo kept powered (`SR,0,1`), the pen moved with `S2` on pin RP4 at its
/// 50 % / 60 % heights (17750 / 15700), constant-rate `LM` moves with motor
/// 1 = x + y and motor 2 = x - y (y towards the front), and `QM` polled until
/// the motors stop.
const SAXI_SQUARE: [&str; 11] = [
    "EM,2,2",
    "SR,0,1",
    "S2,17750,4,0,300",
    "LM,85899346,800,0,0,0,0",
    "S2,15700,4,0,300",
    "LM,85899346,800,0,85899346,800,0",
    "LM,85899346,800,0,85899346,-800,0",
    "LM,85899346,-800,0,85899346,-800,0",
    "LM,85899346,-800,0,85899346,800,0",
    "S2,17750,4,0,300",
    "LM,85899346,-800,0,0,0,0",
];

#[test]
fn a_host_draws_a_square_in_millimetres() {
    for fw in Firmware::ALL {
        let (sim, mut port) = start(fw, 0.0);
        port.send(b"V\r");
        assert_eq!(port.line(), format!("EBBv13_and_above EB Firmware Version {fw}"));
        for c in SAXI_SQUARE {
            assert_eq!(command(&mut port, c), ["OK"], "{fw} {c}");
        }
        loop {
            port.send(b"QM\r");
            if port.line() == "QM,0,0,0,0" {
                break;
            }
        }
        assert_eq!(command(&mut port, "EM,0,0"), ["OK"]);
        assert_eq!(command(&mut port, "SR,60000,0"), ["OK"]);
        sim.wait_idle(WAIT).unwrap();
        let r = sim.record();
        assert_eq!((r.personality.as_str(), r.units_per_mm), ("ebb", 1.0));
        assert_eq!(r.strokes.len(), 1, "{fw}: {:?}", r.strokes);
        assert_eq!(r.strokes[0].points, [[10.0, -10.0], [30.0, -10.0], [30.0, -30.0], [10.0, -30.0], [10.0, -10.0]], "{fw}");
        assert!(r.errors.is_empty(), "{:?}", r.errors);
        // 5 moves of 0.8 s, the pen's 3 × 0.3 s and 0.8 s back home.
        assert!((r.plot_seconds - 5.7).abs() < 0.01, "{}", r.plot_seconds);
    }
}

#[test]
fn the_board_holds_the_host_off_and_answers_at_the_pace_of_motion() {
    // Real time: twenty 20 ms moves written at once. The board reads what
    // fits in its endpoint; the rest waits in the pty; each OK comes as a
    // move starts. Nothing is lost.
    let (sim, mut port) = start(Firmware::V2_8_1, 1.0);
    let one = "LM,42949673,10,0,42949673,10,0\r"; // 10 steps at 500 steps/s: 20 ms
    port.send(one.repeat(20).as_bytes());
    let s = sim.wait_until(WAIT, |s| s.pending_input > 0 && s.device.buffer_used == 128).unwrap();
    assert!(s.bytes_received < 20 * one.len() as u64);
    assert_eq!(s.device.state, "queue-full");
    for _ in 0..20 {
        assert_eq!(port.line(), "OK");
    }
    sim.wait_idle(WAIT).unwrap();
    port.send(b"QS\r");
    assert_eq!(port.line(), "200,200");
    assert_eq!(sim.status().overruns, 0);
    let plot_seconds = sim.record().plot_seconds;
    assert!(plot_seconds >= 0.4);
    // While it holds the host off, the board wakes at the pace of its
    // motion (about once a millisecond), not whenever the pty it leaves
    // unread is readable: that spun a core for the length of every plot.
    let passes = sim.status().passes - s.passes;
    assert!((passes as f64) < 3000.0 * plot_seconds + 200.0, "{passes} passes in {plot_seconds} s of motion");
}

#[test]
fn an_unplugged_board_plots_on_and_comes_back_on_a_new_port() {
    let (sim, mut port) = start(Firmware::V3_0_2, 1.0);
    assert_eq!(command(&mut port, "SM,300,600,600"), ["OK"]);
    sim.unplug(Duration::from_millis(200)).unwrap();
    assert!(port.poll_in(Duration::from_millis(500)).is_err(), "the host's port hangs up");
    let path = sim.wait_connected(WAIT).unwrap();
    let mut port = Port::open(&path);
    sim.wait_idle(WAIT).unwrap();
    port.send(b"QS\r");
    assert_eq!(port.line(), "600,600", "the move went on while unplugged");
}

#[test]
fn power_cycle_resets_the_board_keeps_its_name_and_re_enumerates() {
    let mut cfg = SimConfig::ebb(Firmware::V3_0_2).with_speed_scale(0.0);
    cfg.ebb.nickname = "left".into();
    let sim = Simulator::start(cfg).unwrap();
    let first = sim.slave_path().unwrap();
    let mut port = Port::open(&first);
    assert_eq!(command(&mut port, "QT"), ["left", "OK"]);
    assert_eq!(command(&mut port, "EM,1,1"), ["OK"]);
    assert_eq!(command(&mut port, "SM,100,50,50"), ["OK"]);
    assert_eq!(command(&mut port, "ST,right"), ["OK"]);
    sim.power_cycle();
    let second = sim.wait_until(WAIT, |s| s.slave_path.as_ref().is_some_and(|p| *p != first)).unwrap();
    let mut port = Port::open(second.slave_path.as_ref().unwrap());
    assert_eq!(command(&mut port, "QT"), ["right", "OK"], "the nickname is in flash");
    assert_eq!(command(&mut port, "QS"), ["0,0", "OK"]);
    assert_eq!(command(&mut port, "QE"), ["0,0", "OK"], "motors off after a reset");
    // RB reboots the same way, with no reply.
    let second = second.slave_path.unwrap();
    port.send(b"RB\r");
    sim.wait_until(WAIT, |s| s.slave_path.as_ref().is_some_and(|p| *p != second)).unwrap();
}

#[test]
fn power_loss_and_the_button_from_the_api() {
    let (sim, mut port) = start(Firmware::V3_0_2, 0.0);
    assert_eq!(command(&mut port, "CU,60,250"), ["OK"]);
    sim.power_loss(None).unwrap();
    assert_eq!(command(&mut port, "QC"), ["394,0", "OK"]);
    port.send(b"QG\r");
    assert_eq!(port.line(), "50", "power lost (bit 6), pen up (bit 4)");
    assert_eq!(sim.status().device.state, "no-motor-power");
    sim.power_restore().unwrap();
    assert_eq!(command(&mut port, "QC"), ["394,300", "OK"]);
    sim.button().unwrap();
    assert_eq!(command(&mut port, "QB"), ["1", "OK"]);
    let faults: Vec<String> = sim.record().faults.into_iter().map(|f| f.kind).collect();
    assert_eq!(faults, ["power-loss", "power-restore", "button"]);
    let (hp, _) = (Simulator::start(SimConfig::hp7475a()).unwrap(), ());
    assert!(hp.button().is_err() && hp.power_loss(None).is_err());
}

#[test]
fn future_syntax_over_the_wire() {
    let (sim, mut port) = start(Firmware::V3_0_2, 0.0);
    port.send(b"CU,10,1\rQS\r");
    assert_eq!(port.line(), "QS,0,0");
    port.send(b"SM,10,5,5\r");
    assert_eq!(port.line(), "SM");
    sim.wait_idle(WAIT).unwrap();
    port.send(b"QG\r");
    assert_eq!(port.line(), "QG,10");
}

/// Issue 37: a host that reconnects after an unplug may find half a
/// command in the board's line buffer (the rest was lost with the link),
/// which takes the host's first command as its tail and is refused; the
/// refusal empties the buffer, so the command asked again is answered.
/// (A bare CR to end the half line would instead run it, cut short, if it
/// reads as a whole command: `SM,30` is a move.)
#[test]
fn a_half_command_left_by_an_unplug_takes_the_next_as_its_tail() {
    for fw in Firmware::ALL {
        let (sim, mut port) = start(fw, 0.0);
        port.send(b"SM,30");
        sim.wait_until(WAIT, |s| s.bytes_received == 5).unwrap();
        sim.unplug(Duration::from_millis(50)).unwrap();
        let mut port = Port::open(&sim.wait_connected(WAIT).unwrap());
        port.send(b"V\r");
        let tail = port.line();
        assert!(tail.contains("!5"), "{fw}: the V ended the half command: {tail}");
        port.send(b"V\r");
        assert_eq!(port.line(), format!("EBBv13_and_above EB Firmware Version {fw}"), "{fw}");
        sim.wait_idle(WAIT).unwrap();
        assert_eq!(command(&mut port, "QS"), ["0,0", "OK"], "{fw}: no step made");
    }
}

/// `QT` in both reply syntaxes: 2.x and 3.x legacy `name` then `OK`, 3.x's
/// future syntax `QT,name`; a board with no nickname answers it empty.
#[test]
fn the_nickname_is_answered_in_both_syntaxes() {
    for fw in Firmware::ALL {
        for name in ["axi1", ""] {
            let mut cfg = SimConfig::ebb(fw).with_speed_scale(0.0);
            cfg.ebb.nickname = name.into();
            let sim = Simulator::start(cfg).unwrap();
            let mut port = Port::open(&sim.slave_path().unwrap());
            let legacy: &[&str] = if name.is_empty() { &["OK"] } else { &[name, "OK"] };
            assert_eq!(command(&mut port, "QT"), legacy, "{fw}");
            if fw == Firmware::V3_0_2 {
                // The switch's own answer is a bare line end (its name was
                // due before the syntax changed).
                port.send(b"CU,10,1\r");
                port.send(b"QT\r");
                assert_eq!(port.line(), format!("QT,{name}"));
            }
        }
    }
}

/// Issue 37: the record says how long the motion FIFO ran empty between
/// one command and the next (the carriage stopped while the host had more
/// to send): none while the host keeps the FIFO fed, the host's pause when
/// it waits before sending the next move; the wait after the last move is
/// not stutter.
#[test]
fn the_record_counts_the_time_the_motion_fifo_ran_empty_between_commands() {
    let (sim, mut port) = start(Firmware::V2_8_1, 1.0);
    let one = "SM,20,10,10\r"; // 20 ms
    port.send(one.repeat(5).as_bytes());
    for _ in 0..5 {
        assert_eq!(port.line(), "OK");
    }
    sim.wait_idle(WAIT).unwrap();
    // (The simulator runs in real time: a thread of it held off the CPU
    // counts too, so the bound leaves room for a loaded machine.)
    let fed = sim.record().starved_seconds;
    assert!(fed < 0.01, "fed: {fed} s");
    // Idle now, for at least as long as the second wait below.
    let paused = std::time::Instant::now();
    sim.wait_until(WAIT, |s| s.device.idle).unwrap();
    // The host pausing is what is under test here, not a wait for an event.
    std::thread::sleep(Duration::from_millis(50));
    let pause = paused.elapsed().as_secs_f64();
    assert!(sim.record().starved_seconds - fed < 1e-9, "idle at the end is not counted yet");
    port.send(one.as_bytes());
    assert_eq!(port.line(), "OK");
    sim.wait_idle(WAIT).unwrap();
    let starved = sim.record().starved_seconds;
    assert!(starved - fed >= pause - 0.005 && starved - fed < pause + 0.2, "starved {starved} s after a pause of {pause} s");
}
