//! An AxiDraw's faults end to end (issue 37): the daemon against plotsim's
//! virtual EiBotBoard over a real pty, plotting faster than real time. Each
//! case ends with every stroke drawn, at most one twice, as the dry run
//! draws it within a motor step.

use plotd::protocol::{Event, State};
use plotd::spool::{JobKind, PauseCause};
use plotd_e2e::ebb::{assert_drawn_once, drawn_strokes, planned_strokes, zigzags};
use plotd_e2e::{render_for, DaemonHandle, Rig};
use plotsim::{Firmware, SimConfig};
use std::time::Duration;

const LONG: Duration = Duration::from_secs(120);

/// Motion at this fraction of real time: a job of a few seconds, long
/// enough to be interrupted mid-job.
const SPEED_SCALE: f64 = 0.25;

/// A daemon driving a virtual EBB of `fw` as an `axidraw`.
fn rig(fw: Firmware, extra: &str) -> Rig {
    // The board ignores the baud rate; the config takes only standard ones.
    Rig::start(SimConfig::ebb(fw).with_speed_scale(SPEED_SCALE).with_baud(115_200), "axidraw", "ebb", extra)
}

/// The zig-zag scene, and the strokes its dry run draws in the record's
/// millimetres.
fn job(rig: &Rig) -> (String, Vec<Vec<[f64; 2]>>) {
    let scene = zigzags(30);
    let path = rig.dir.path().join("zigzags.toml");
    std::fs::write(&path, &scene).unwrap();
    let want = planned_strokes(&render_for(&path, "axidraw"));
    assert_eq!(want.len(), 30);
    (scene, want)
}

/// Waits for the job's event that says it paused; returns its cause.
fn paused(events: &mut plotd_e2e::JobEvents) -> Option<PauseCause> {
    loop {
        let ev: &Event = events.next(LONG).expect("the job pauses before it ends");
        if ev.state == State::Paused {
            return ev.cause;
        }
    }
}

/// Waits until the board has drawn `n` strokes.
fn drawn(rig: &Rig, n: usize) {
    plotd_e2e::wait_for("strokes drawn", LONG, || rig.sim.record().strokes.len() >= n);
}

/// No board error but the refusal of the one command the unplug may have
/// cut in two (its start in the board, its end lost with the port): the
/// `V` the daemon asks on the new port ends it, and the board refuses it
/// for its missing arguments (one line, perhaps several messages).
fn assert_at_most_the_command_cut_in_two_refused(rig: &Rig, fw: Firmware) {
    let errors = rig.sim.record().errors;
    let cut = |e: &plotsim::ErrorEvent| e.kind == "ebb" && matches!(e.code, 4 | 5) && e.at_byte == errors[0].at_byte;
    assert!(errors.iter().all(cut), "{fw}: {errors:?}");
}

/// The USB cable pulled for 3 s a third of the way through the job, on
/// 2.8.1 and 3.0.2: the job pauses offline (the event waited for), and once
/// the board is back one `resume` draws the rest: every stroke, at most the
/// one in flight twice. The board ran on through what it held meanwhile; its
/// step counters (kept while it is powered) tell the daemon how far.
#[test]
fn an_unplug_mid_job_pauses_offline_and_one_resume_draws_every_stroke() {
    for fw in Firmware::ALL {
        let rig = rig(fw, "");
        let (scene, want) = job(&rig);
        let id = rig.submit(JobKind::Scene, &scene);
        let mut events = rig.watch_job(id);
        drawn(&rig, want.len() / 3);
        rig.sim.unplug(Duration::from_secs(3)).unwrap();
        assert_eq!(paused(&mut events), Some(PauseCause::Offline), "{fw}");
        rig.resume_after_replug(id, LONG);
        rig.wait_state(id, State::Done, LONG);
        rig.sim.wait_idle(LONG).unwrap();
        assert_at_most_the_command_cut_in_two_refused(&rig, fw);
        let repeats = assert_drawn_once(&drawn_strokes(&rig.sim), &want, 1);
        eprintln!("{fw}: unplugged, {repeats} stroke drawn again");
    }
}
