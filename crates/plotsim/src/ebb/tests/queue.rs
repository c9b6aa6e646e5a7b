//! The motion FIFO and its flow control: when each OK comes, on the hand-moved clock.

use super::Rig;
use crate::ebb::clock::TICKS_PER_MS;
use crate::ebb::firmware::Firmware;

/// 100 ms of motion on axis 1 (80 steps at 800 steps/s), as an LM.
const LM_100MS: &str = "LM,68719477,80,0,0,0,0\r";

#[test]
fn a_2x_board_holds_one_command_and_delays_the_next_ok() {
    let mut r = Rig::new(Firmware::V2_8_1);
    let t0 = r.b.tick;
    let left = r.write(&LM_100MS.repeat(4));
    assert!(left.is_empty());
    // The first goes to the FIFO (the ISR takes it in the next tick), the
    // second waits in the parser: one OK now.
    assert_eq!(r.take(), "OK\r\n");
    r.to(t0 + 1);
    // The ISR took the first: the second is queued, the third waits.
    assert_eq!(r.take(), "OK\r\n");
    let taken = r.b.taken;
    assert_eq!(taken, 3 * LM_100MS.len() as u64, "the fourth command stays unread");
    // The first move ends after 2500 ticks; the third goes in then.
    r.to(t0 + 2500);
    assert_eq!(r.take(), "");
    r.to(t0 + 2501);
    assert_eq!(r.take(), "OK\r\n");
    r.to(t0 + 5001);
    assert_eq!(r.take(), "OK\r\n");
    r.finish(1);
    assert_eq!(r.b.engine.counters, [320, 0]);
    assert_eq!(r.b.busy_ticks - 1, 4 * 2500, "back to back, no gap (the first tick is the power-on pen move)");
}

#[test]
fn a_full_endpoint_leaves_the_rest_with_the_host() {
    let mut r = Rig::new(Firmware::V2_8_1);
    let text = LM_100MS.repeat(20);
    let left = r.write(&text);
    // Two commands queued (FIFO and ISR a tick later), one waiting, and the
    // 128-byte endpoint full behind it.
    let read = text.len() - left.len();
    assert_eq!(read as u64, r.b.taken + 128);
    assert!(r.b.taken < 4 * LM_100MS.len() as u64);
}

#[test]
fn a_3x_fifo_is_as_deep_as_cu_4_makes_it() {
    let mut r = Rig::new(Firmware::V3_0_2);
    assert_eq!(r.send("CU,4,8\r"), "OK\r\n");
    let t0 = r.b.tick;
    r.write(&LM_100MS.repeat(10));
    assert_eq!(r.take(), "OK\r\n".repeat(8));
    r.to(t0 + 1);
    assert_eq!(r.take(), "OK\r\n", "the ISR took one: room for the ninth");
    r.to(t0 + 2501);
    assert_eq!(r.take(), "OK\r\n");
    // Deeper than 32 is 32.
    r.finish(10);
    r.send("CU,4,99\r");
    assert_eq!(r.b.engine.depth(), 32);
}

#[test]
fn cu_4_waits_for_the_motion_to_end() {
    let mut r = Rig::new(Firmware::V3_0_2);
    let t0 = r.b.tick;
    assert_eq!(r.send("SM,200,100,0\rCU,4,4\r"), "OK\r\n");
    r.to(t0 + 199 * TICKS_PER_MS);
    assert_eq!(r.take(), "");
    assert_eq!(r.b.engine.depth(), 1);
    r.finish(1);
    assert_eq!(r.take(), "OK\r\n");
    assert_eq!(r.b.engine.depth(), 4);
}

#[test]
fn lt_holds_the_3x_isr_one_tick_longer() {
    // 2.8.1 ends an LT in the tick of its last interval; 3.0.2 clears its
    // "not done" flag before counting the interval down, so the next command
    // starts a tick later.
    for (fw, ticks) in [(Firmware::V2_8_1, 100), (Firmware::V3_0_2, 101)] {
        let mut r = Rig::new(fw);
        let t0 = r.b.tick;
        r.send("LT,100,85899346,0,0,0,3\r");
        r.finish(1);
        assert_eq!(r.b.tick - t0 - 1, ticks, "{fw}");
        assert_eq!(r.b.engine.counters, [4, 0], "{fw}");
    }
}

#[test]
fn hm_goes_home_to_where_em_enabled_the_motors() {
    for fw in Firmware::ALL {
        let mut r = Rig::new(fw);
        r.send("EM,1,1\rSM,500,1000,5\r");
        r.finish(2);
        r.take();
        assert_eq!(r.b.engine.counters, [1000, 5]);
        // At 100 steps/s the minor axis would step slower than 1.31 Hz:
        // 2.8.1 first takes it home on a diagonal (two moves: the OK comes
        // when the second fits, a tick later), 3.0.2 goes straight.
        let t0 = r.b.tick;
        r.write("HM,100\r");
        if fw.is_v3() {
            assert_eq!(r.take(), "OK\r\n");
        } else {
            assert_eq!(r.take(), "");
            r.to(t0 + 1);
            assert_eq!(r.take(), "OK\r\n");
            assert_eq!(r.b.engine.current.steps, [5, 5], "the diagonal leg");
        }
        r.finish(20);
        assert_eq!(r.b.engine.counters, [0, 0], "{fw}");
        assert_eq!(r.b.motors.shaft(), [0, 0], "{fw}: the carriage is back");
        // HM waits for the motion system to be idle, then reads the counters.
        let t0 = r.b.tick;
        assert_eq!(r.send("SM,100,20,20\rHM,1000,-30,40\r"), "OK\r\n");
        r.to(t0 + 2_000);
        assert_eq!(r.take(), "", "{fw}: not before the SM is done");
        r.finish(5);
        assert_eq!(r.take(), "OK\r\n");
        assert_eq!(r.b.engine.counters, [-30, 40], "{fw}");
    }
}

#[test]
fn qs_and_qm_show_a_move_in_progress() {
    for fw in Firmware::ALL {
        let mut r = Rig::new(fw);
        let t0 = r.b.tick;
        r.send("SM,1000,1000,-500\r");
        r.to(t0 + 12_501);
        let qs = r.send("QS\r");
        let c: Vec<i32> = qs.split(['\n', ',']).take(2).map(|v| v.parse().unwrap()).collect();
        // 500 ms of 1000 and 500 steps/s: half way, to a step.
        assert!((c[0] - 500).abs() <= 1 && (c[1] + 250).abs() <= 1, "{fw}: {qs:?}");
        assert_eq!(r.send("QM\r"), "QM,1,1,1,0\n\r", "{fw}");
        r.finish(1);
        assert_eq!(r.send("QM\r"), "QM,0,0,0,0\n\r", "{fw}");
    }
}
