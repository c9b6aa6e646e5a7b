//! ES, the servo power timeout, V+ lost, the PRG button, and what the pen
//! leaves on the paper.

use super::Rig;
use crate::ebb::board::Io;
use crate::ebb::firmware::Firmware;

/// Lifts the pen and waits until it is up.
fn pen_up(r: &mut Rig) {
    r.send("SP,1,500\r");
    r.finish(2);
    r.take();
    assert!(!r.b.pen.on_paper());
}

fn set_vplus(r: &mut Rig, on: bool) {
    let mut io = Io { out: &mut r.out, record: &mut r.record, garble: &mut r.garble };
    r.b.set_vplus(on, &mut io);
}

#[test]
fn es_stops_now_and_flushes() {
    // 2.8.1: interrupted, the queued move's steps, the current one's left.
    let mut r = Rig::new(Firmware::V2_8_1);
    let t0 = r.b.tick;
    r.write("SM,1000,1000,500\rSM,1000,200,100\r");
    r.to(t0 + 2 + 250 * 25);
    assert_eq!(r.take(), "OK\r\nOK\r\n", "the second SM went in when the first started");
    assert_eq!(r.send("ES\r"), "1,200,100,750,375\n\rOK\r\n");
    r.finish(1);
    assert_eq!(r.b.engine.counters, [250, 125]);
    assert_eq!(r.send("ES\r"), "0,0,0,0,0\n\rOK\r\n");
    // 3.0.2: the flag only; ES,1 also disables the motors.
    let mut r = Rig::new(Firmware::V3_0_2);
    r.send("CU,4,4\rSM,1000,1000,0\rSP,0\rSM,1000,1000,0\r");
    r.wait_ms(100);
    assert_eq!(r.send("ES,1\r"), "1\n\rOK\r\n");
    assert!(r.b.engine.idle());
    assert_eq!(r.b.motors.enabled, [false, false]);
}

#[test]
fn es_on_2x_leaves_a_queued_pen_move() {
    let mut r = Rig::new(Firmware::V2_8_1);
    r.send("SM,200,100,0\rSP,0\r");
    r.wait_ms(10);
    r.take();
    assert_eq!(r.send("ES\r"), "1,0,0,96,0\n\rOK\r\n");
    r.finish(1);
    assert!(!r.b.servos.pen_up, "the SP,0 behind the move still ran");
}

#[test]
fn the_pen_drops_when_the_servo_power_times_out() {
    // EggBot #184: SR's countdown (60 s at boot) starts at the last pen
    // move; when it ends the servo goes limp and the pen falls on the paper,
    // so a move after a long pause draws.
    for fw in Firmware::ALL {
        let mut r = Rig::new(fw);
        pen_up(&mut r);
        assert_eq!(r.send("QR\r").chars().next(), Some('1'));
        r.wait_ms(59_000);
        assert!(!r.b.pen.on_paper(), "{fw}: still up after 59 s");
        r.wait_ms(1_500);
        assert!(r.b.pen.on_paper(), "{fw}: dropped at 60 s");
        assert_eq!(r.send("QR\r").chars().next(), Some('0'));
        // The firmware still says the pen is up.
        assert!(r.b.servos.pen_up);
        r.send("XM,500,800,0\r");
        r.finish(1);
        assert_eq!(r.record.strokes.len(), 1, "{fw}: the move drew");
        assert_eq!(r.record.strokes[0].points, vec![[0.0, 0.0], [10.0, 0.0]]);
    }
    // SR,0: the power stays on.
    let mut r = Rig::new(Firmware::V2_8_1);
    r.send("SR,0\r");
    pen_up(&mut r);
    r.wait_ms(120_000);
    assert!(!r.b.pen.on_paper());
}

#[test]
fn a_square_in_millimetres() {
    // The AxiDraw's CoreXY: XM's A is x, B is y towards the front; 80 steps
    // per mm at 1/16 steps. The record's y is up, so the front is -y.
    for fw in Firmware::ALL {
        let mut r = Rig::new(fw);
        // A fast servo (30000 per 24 ms: the whole way in one step), so the
        // pen is down well within SP's 200 ms.
        r.send("EM,1,1\rSC,4,20000\rSC,5,14000\rSC,10,30000\r");
        pen_up(&mut r);
        r.send("XM,500,800,800\rSP,0,200\rXM,1000,1600,0\rXM,1000,0,1600\rXM,1000,-1600,0\rXM,1000,0,-1600\rSP,1,200\rXM,500,-800,-800\r");
        r.finish(10);
        assert_eq!(r.record.strokes.len(), 1, "{fw}: {:?}", r.record.strokes);
        let square = [[10.0, -10.0], [30.0, -10.0], [30.0, -30.0], [10.0, -30.0], [10.0, -10.0]];
        assert_eq!(r.record.strokes[0].points, square, "{fw}");
        assert_eq!(r.b.motors.shaft(), [0, 0]);
        // 1/8 steps: each step is two sixteenths.
        let mut r = Rig::new(fw);
        r.send("EM,2,2\rSC,10,30000\r");
        pen_up(&mut r);
        r.send("SP,0,300\rXM,500,400,0\r");
        r.finish(2);
        assert_eq!(r.record.strokes[0].points, vec![[0.0, 0.0], [10.0, 0.0]], "{fw}");
    }
}

#[test]
fn a_pen_lowered_without_a_delay_lands_late() {
    // SP,0 with no delay lets the next move start at once; the pen reaches
    // the paper 45 ms + the travel later (axidraw_conf's servo model), so
    // the line's start is missing.
    let mut r = Rig::new(Firmware::V2_8_1);
    r.send("SC,10,65535\r");
    pen_up(&mut r);
    r.send("SP,0\rXM,1000,8000,0\r");
    r.finish(2);
    let start = r.record.strokes[0].points[0][0];
    assert!(start > 5.0 && start < 20.0, "the line starts at {start} mm, not 0");
    assert_eq!(r.record.strokes[0].points[1], [100.0, 0.0]);
}

#[test]
fn sp_3_lifts_at_once_past_the_queue() {
    let mut r = Rig::new(Firmware::V3_0_2);
    r.send("CU,4,8\r");
    pen_up(&mut r);
    r.send("SP,0,300\rXM,2000,8000,0\rSP,0\rXM,2000,0,8000\r");
    r.wait_ms(1000);
    assert!(r.b.pen.on_paper());
    let t = r.b.tick;
    assert_eq!(r.send("SP,3\r"), "OK\r\n");
    r.wait_ms(300);
    assert!(!r.b.pen.on_paper(), "up within 300 ms at the default rate, with motion still queued");
    assert!(!r.b.engine.idle());
    r.finish(10);
    assert!(!r.b.pen.on_paper(), "the queued SP,0 was turned into a lift");
    assert_eq!(r.b.servos.down, r.b.servos.up, "and SC,5 follows SC,4 until set again");
    let _ = t;
    // 2.8.1 has no SP,3: it is SP,1 through the queue.
    let mut r = Rig::new(Firmware::V2_8_1);
    pen_up(&mut r);
    r.send("SP,0,300\rXM,2000,8000,0\r");
    r.wait_ms(1000);
    r.write("SP,3\r");
    r.wait_ms(300);
    assert!(r.b.pen.on_paper(), "2.8.1 lifts only after the move");
}

#[test]
fn power_loss_costs_the_position_and_3x_flags_it() {
    for fw in Firmware::ALL {
        let mut r = Rig::new(fw);
        r.send("CU,60,250\rEM,1,1\r");
        pen_up(&mut r);
        r.send("XM,1000,800,0\r");
        r.wait_ms(500);
        set_vplus(&mut r, false);
        let stopped = r.b.motors.shaft();
        assert!((stopped[0] - 400).abs() <= 1, "{fw}: half way, {stopped:?}");
        assert_eq!(r.send("QC\r"), if fw.is_v3() { "394,0\r\nOK\r\n" } else { "0394,0000\r\nOK\r\n" });
        r.finish(2);
        // The firmware counted every step; the carriage stopped half way.
        assert_eq!(r.b.engine.counters, [800, 800]);
        assert_eq!(r.b.motors.shaft(), stopped);
        set_vplus(&mut r, true);
        // Energised again, each rotor jumps to the driver's phase (within two full steps).
        let shaft = r.b.motors.shaft();
        assert!(shaft.iter().zip(stopped).all(|(s, t)| (s - t).abs() <= 32), "{fw}: {shaft:?}");
        // 3.0.2 flags V+ below CU,60's threshold in QG bit 6 until read;
        // on 2.8.1 bits 6 and 7 are pins RB2 and RB5 (pulled up).
        if fw.is_v3() {
            assert_eq!(r.send("QG\r"), "50\r\n");
            assert_eq!(r.send("QG\r"), "10\r\n", "read once, then cleared");
        } else {
            assert_eq!(r.send("QG\r"), "D0\r\n");
        }
        // The pen fell when the servo's supply went.
        assert!(r.b.pen.on_paper());
    }
}

#[test]
fn the_prg_button_latches_until_read() {
    for fw in Firmware::ALL {
        let mut r = Rig::new(fw);
        r.b.press_button();
        assert_eq!(r.send("QB\r"), "1\r\nOK\r\n");
        assert_eq!(r.send("QB\r"), "0\r\nOK\r\n");
        r.b.press_button();
        let qg = r.send("QG\r");
        assert_eq!(u8::from_str_radix(&qg[..2], 16).unwrap() & 0x20, 0x20, "{fw}");
        assert_eq!(u8::from_str_radix(&r.send("QG\r")[..2], 16).unwrap() & 0x20, 0, "{fw}");
    }
}

#[test]
fn r_resets_the_firmware_and_keeps_the_carriage_and_name() {
    for fw in Firmware::ALL {
        let mut r = Rig::new(fw);
        r.send("ST,left\rEM,1,1\rSM,100,50,0\rCU,2,0\r");
        r.finish(1);
        r.take();
        r.send("R\r");
        r.finish(1);
        assert_eq!(r.b.engine.counters, [0, 0]);
        assert_eq!(r.b.motors.enabled, [false, false]);
        assert_eq!(r.b.motors.shaft(), [50, 0]);
        assert_eq!(r.send("QT\r"), "left\r\nOK\r\n");
        // 3.0.2 sets limit checks again; 2.8.1 only at power-on.
        assert_eq!(r.b.settings.limit_checks, fw.is_v3(), "{fw}");
    }
}

#[test]
fn stepper_timeout_disables_the_motors_on_3x() {
    let mut r = Rig::new(Firmware::V3_0_2);
    r.send("CU,61,2\rSM,100,10,10\r");
    r.finish(1);
    assert_eq!(r.b.motors.enabled, [true, true]);
    r.wait_ms(1_900);
    assert_eq!(r.b.motors.enabled, [true, true]);
    r.wait_ms(200);
    assert_eq!(r.b.motors.enabled, [false, false]);
}

/// `park`: a person pushes the carriage home by hand. Refused while the
/// motors hold it; with them off, the carriage is home; enabled again, each
/// rotor falls into its driver's phase (which a hand does not move), within
/// two full steps (32 sixteenths) of home.
#[test]
fn a_carriage_parked_by_hand_is_home_and_its_counters_are_not() {
    for fw in Firmware::ALL {
        let mut r = Rig::new(fw);
        pen_up(&mut r);
        r.send("EM,1,1\rXM,500,810,-330\r");
        r.finish(1);
        let park = |r: &mut Rig| {
            let mut io = Io { out: &mut r.out, record: &mut r.record, garble: &mut r.garble };
            r.b.park(&mut io)
        };
        assert!(park(&mut r).unwrap_err().contains("motors hold"), "{fw}");
        r.send("EM,0,0\r");
        r.finish(1);
        park(&mut r).unwrap();
        assert_eq!(r.b.motors.position_mm(), [0.0, 0.0], "{fw}");
        r.send("EM,1,1\r");
        r.finish(1);
        let shaft = r.b.motors.shaft();
        assert!(shaft.iter().all(|s| s.abs() <= 32), "{fw}: {shaft:?}");
        assert_eq!(r.record.strokes.len(), 0, "{fw}: the pen up all along");
    }
}
