//! The `plotd` binary SIGKILLed mid-job while it drives plotsim's virtual
//! EiBotBoard, started again on the same spool, and the job resumed
//! (issue 37): the board ran on through what it held; its step counters,
//! kept while it is powered, tell the new daemon how far, so every stroke is
//! drawn, at most one twice.

use crate::child::Setup;
use plotd::protocol::State;
use plotd::spool::JobKind;
use plotd_e2e::ebb::{assert_drawn_once, drawn_strokes, planned_strokes, zigzags};
use plotd_e2e::{render_for, wait_for, DaemonHandle};
use plotsim::{Firmware, SimConfig};
use std::time::Duration;

const LONG: Duration = Duration::from_secs(120);

#[test]
fn ebb_sigkill_mid_job_then_restart_and_resume() {
    for fw in Firmware::ALL {
        // The board ignores the baud rate; the config takes only standard ones.
        let sim = SimConfig::ebb(fw).with_speed_scale(0.25).with_baud(115_200);
        let setup = Setup::new(sim, "axidraw", "ebb", "");
        let scene = zigzags(30);
        let path = setup.dir.path().join("zigzags.toml");
        std::fs::write(&path, &scene).unwrap();
        let want = planned_strokes(&render_for(&path, "axidraw"));
        let mut d = setup.start();
        let id = d.submit(JobKind::Scene, &scene);
        wait_for("a third of the strokes drawn", LONG, || setup.sim.record().strokes.len() >= want.len() / 3);
        d.kill();
        // The board runs on through what it holds, then stops.
        setup.sim.wait_idle(LONG).unwrap();
        let drawn_before = setup.sim.record().strokes.len();

        let d = setup.start();
        let job = d.job(id);
        assert_eq!(job.state, State::Paused, "{fw}: {:?}", job.reason);
        assert_eq!(setup.sim.record().strokes.len(), drawn_before, "{fw}: the pen moved before resume");
        d.resume(id);
        d.wait_state(id, State::Done, LONG);
        setup.sim.wait_idle(LONG).unwrap();
        let errors = setup.sim.record().errors;
        assert!(errors.is_empty(), "{fw}: {errors:?}");
        let repeats = assert_drawn_once(&drawn_strokes(&setup.sim), &want, 1);
        eprintln!("{fw}: SIGKILL after {drawn_before} strokes, {repeats} drawn again");
    }
}
