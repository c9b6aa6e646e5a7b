//! Pen changes on a single-pen device: the job pauses at each change with
//! "insert pen N", the pen up and nothing drawn, until `pen-changed`. On a
//! pen carousel it pauses only when the config says `pen_change = "pause"`.

use plotd::protocol::{Reply, Request, State};
use plotd::spool::{JobKind, PauseCause};
use plotd_e2e::{assert_drawn_once, assert_plotted, recorded, strokes_of, DaemonHandle, Rig};
use plotsim::SimConfig;
use std::time::Duration;

const LONG: Duration = Duration::from_secs(120);

/// Two strokes per pen, pens 1, 2, 3 and back to 1, in the shape `plotd
/// render --device grbl-servo` emits.
fn job() -> String {
    let mut g = String::from("G21 G90\nM5\nG4 P0.15\n");
    for (k, pen) in [1, 2, 3, 1].into_iter().enumerate() {
        g += &format!("T{pen}\n");
        for s in 0..2 {
            let (x, y) = (10 + 40 * k, 10 + 30 * s);
            g += &format!("G0 X{x} Y{y}\nM3 S1000\nG4 P0.15\nG1 X{} Y{y} F3000\nG1 X{} Y{}\nM5\nG4 P0.15\n", x + 20, x + 20, y + 15);
        }
    }
    g + "M5\nG4 P0.15\nG0 X0 Y0\n"
}

/// Waits for job `id` to pause for `pen` (cause `load`), the pen up and
/// exactly `drawn` on the paper; returns the idle device's status.
fn paused_for_pen(rig: &Rig, id: u64, pen: u32, drawn: &[(u32, Vec<[f64; 2]>)]) -> plotsim::Status {
    let j = rig.wait_state(id, State::Paused, LONG);
    let reason = format!("insert pen {pen}");
    assert_eq!((j.cause, j.reason, j.insert_pen, j.load_page), (Some(PauseCause::Load), Some(reason), Some(pen), None));
    let st = rig.sim.wait_idle(LONG).unwrap();
    assert!(!st.device.pen_down, "pen left down for the change");
    assert_drawn_once(&recorded(&rig.sim), drawn, 0);
    st
}

#[test]
fn single_pen_device_pauses_at_each_pen_change() {
    let rig = Rig::start(SimConfig::grbl().with_speed_scale(0.0), "grbl-servo", "grbl", "");
    let text = job();
    let want = strokes_of(&text, "grbl-servo");
    assert_eq!(want.iter().map(|s| s.0).collect::<Vec<_>>(), [1, 1, 2, 2, 3, 3, 1, 1]);
    let id = rig.submit(JobKind::Gcode, &text);
    // Pen 1 is taken to be in at the start; then one pause per change.
    for (pen, drawn) in [(2, 2), (3, 4), (1, 6)] {
        let st = paused_for_pen(&rig, id, pen, &want[..drawn]);
        // Still paused, and still nothing more on the paper.
        assert_eq!(rig.job(id).state, State::Paused);
        assert_eq!(rig.sim.status().bytes_received, st.bytes_received);
        rig.client().call(&Request::PenChanged { plotter: Some("p".into()) }).unwrap();
    }
    let j = rig.wait_state(id, State::Done, LONG);
    assert_eq!(j.pen_loaded, Some(1));
    rig.sim.wait_idle(LONG).unwrap();
    assert_plotted(&rig.sim, &want, 0);
}

/// Two strokes per pen, pens 1, 2 and back to 1, for an HP 7475A (6 pens).
fn hp_job() -> String {
    let mut t = String::from("IN;");
    for (k, pen) in [1, 2, 1].into_iter().enumerate() {
        t += &format!("SP{pen};");
        for s in 0..2 {
            let (x, y) = (1000 + 2000 * k, 1000 + 1500 * s);
            t += &format!("PU{x},{y};PD{},{y},{},{};", x + 800, x + 800, y + 600);
        }
    }
    t + "PU;SP0;"
}

#[test]
fn a_pen_carousel_pauses_at_pen_changes_only_when_configured() {
    let text = hp_job();
    let want = strokes_of(&text, "hp7475a");
    assert_eq!(want.iter().map(|s| s.0).collect::<Vec<_>>(), [1, 1, 2, 2, 1, 1]);

    // `auto` on a 6-pen device: the plotter changes pens itself.
    let rig = Rig::start(SimConfig::hp7475a().with_speed_scale(0.0).with_baud(0), "hp7475a", "escb", "");
    let id = rig.submit(JobKind::Hpgl, &text);
    rig.wait_state(id, State::Done, LONG);
    rig.sim.wait_idle(LONG).unwrap();
    assert_plotted(&rig.sim, &want, 0);

    // `pause`: every change waits for `pen-changed`, the pen up.
    let rig = Rig::start(SimConfig::hp7475a().with_speed_scale(0.0).with_baud(0), "hp7475a", "escb", "pen_change = \"pause\"");
    let id = rig.submit(JobKind::Hpgl, &text);
    for (pen, drawn) in [(2, 2), (1, 4)] {
        paused_for_pen(&rig, id, pen, &want[..drawn]);
        rig.client().call(&Request::PenChanged { plotter: None }).unwrap();
    }
    rig.wait_state(id, State::Done, LONG);
    rig.sim.wait_idle(LONG).unwrap();
    assert_plotted(&rig.sim, &want, 0);
}

/// A one-pen G-code job with two pens parks off the drawing before asking:
/// when the job pauses for pen 2 the carriage rests outside the box of
/// every stroke, pen up; the plotter's status then says pen 2 is in.
#[test]
fn a_one_pen_gcode_job_with_two_pens_parks_off_the_drawing_before_asking() {
    let rig = Rig::start(SimConfig::grbl().with_speed_scale(0.0), "grbl-servo", "grbl", "");
    let mut text = String::from("G21 G90\nM5\nG4 P0.15\n");
    for (k, pen) in [1, 1, 2, 2].into_iter().enumerate() {
        if k % 2 == 0 {
            text += &format!("T{pen}\n");
        }
        let x = 20 + 30 * k;
        text += &format!("G0 X{x} Y20\nM3 S1000\nG4 P0.15\nG1 X{x} Y60 F3000\nM5\nG4 P0.15\n");
    }
    text += "M5\nG4 P0.15\nG0 X0 Y0\n";
    let want = strokes_of(&text, "grbl-servo");
    let id = rig.submit(JobKind::Gcode, &text);
    let st = paused_for_pen(&rig, id, 2, &want[..2]);
    let points = want.iter().flat_map(|s| s.1.iter().copied());
    let (lo, hi) =
        points.fold(([f64::MAX; 2], [f64::MIN; 2]), |(lo, hi), [x, y]| ([lo[0].min(x), lo[1].min(y)], [hi[0].max(x), hi[1].max(y)]));
    let [x, y] = st.device.position;
    let inside = (lo[0]..=hi[0]).contains(&x) && (lo[1]..=hi[1]).contains(&y);
    assert!(!inside, "parked at ({x}, {y}), on the drawing's box {lo:?}..{hi:?}");
    assert!(!st.device.pen_down);
    let Reply::Status { plotters, .. } = rig.client().call(&Request::Status {}).unwrap() else { panic!("not a status") };
    assert_eq!(plotters[0].pen_loaded, Some(1), "pen 1 was in for the start");
    rig.client().call(&Request::PenChanged { plotter: Some("p".into()) }).unwrap();
    rig.wait_state(id, State::Done, LONG);
    let Reply::Status { plotters, .. } = rig.client().call(&Request::Status {}).unwrap() else { panic!("not a status") };
    assert_eq!(plotters[0].pen_loaded, Some(2), "the plotter remembers the pen put in");
    rig.sim.wait_idle(LONG).unwrap();
    assert_plotted(&rig.sim, &want, 0);
}
