//! The `plotd` binary as a child process, streaming to plotsim over a real
//! pty, killed or stopped mid-job and started again on the same spool and
//! config: interrupted jobs come back `paused` and the pen does not move until
//! `resume`; then every stroke is drawn once.

mod child;

use child::{assert_drawn_with_replay, Daemon, Setup};
use plotd::device::Device;
use plotd::program::Program;
use plotd::protocol::{Reply, Request};
use plotd::spool::{JobKind, JobState};
use plotd_e2e::{assert_drawn_once, recorded, render_for, repo_root, strokes_of, DaemonHandle};
use std::time::Duration;

const LONG: Duration = Duration::from_secs(120);

fn drawing() -> String {
    render_for(&repo_root().join("examples/lattice.toml"), "hp7475a")
}

/// A short job queued behind the big one.
const SMALL: &str = "IN;SP1;PU7000,5000;PD7400,5000,7400,5400;PU;";

/// After a restart, the daemon must not touch the plotter while the job is
/// paused: its port stays closed (`link` `unknown`) and the device receives
/// nothing.
fn assert_pen_left_alone(setup: &Setup, d: &Daemon) {
    let before = setup.sim.status().bytes_received;
    let Reply::Status { plotters, .. } = d.client().call(&Request::Status).unwrap() else { panic!("status") };
    assert_eq!(plotters[0].link, "unknown", "the port was opened for a paused job");
    assert_eq!(setup.sim.status().bytes_received, before, "bytes sent to a plotter whose job is paused");
}

#[test]
fn sigkill_mid_job_then_restart_and_resume() {
    let setup = Setup::hp_escb("");
    let big = drawing();
    let mut d = setup.start();
    let a = d.submit(JobKind::Hpgl, &big);
    let b = d.submit(JobKind::Hpgl, SMALL);
    setup.sim.wait_received(big.len() as u64 / 3, LONG).unwrap();
    d.kill();
    // The device goes on with what it had received, then stops.
    setup.sim.wait_idle(LONG).unwrap();
    let drawn_before = setup.sim.record().strokes.len();

    let d = setup.start();
    let ja = d.job(a);
    let JobState::Paused { reason, .. } = &ja.state else { panic!("job {a} came back {:?}", ja.state) };
    assert!(reason.contains("interrupted"), "{reason}");
    assert!(ja.checkpoint > 0 && ja.checkpoint < ja.total.unwrap(), "checkpoint {} of {:?}", ja.checkpoint, ja.total);
    assert_eq!(d.job(b).state, JobState::Queued);
    assert_pen_left_alone(&setup, &d);
    assert_eq!(setup.sim.record().strokes.len(), drawn_before);

    d.resume(a);
    d.wait_state(a, "done", LONG);
    d.wait_state(b, "done", LONG);
    setup.sim.wait_idle(LONG).unwrap();
    let want: Vec<_> = [big.as_str(), SMALL].iter().flat_map(|t| strokes_of(t, "hp7475a")).collect();
    // Plotting resumed at the last confirmed stroke. What the device ran after
    // the kill beyond it is drawn again: a dead daemon cannot say how far the
    // device got. The streamer never has more unconfirmed than the device's
    // buffer holds, which bounds the replay.
    let program = Program::build(big.as_bytes(), &Device::lookup("hp7475a").unwrap()).unwrap();
    let resumed = program.chunks[..ja.checkpoint].iter().filter(|c| c.draws).count();
    let buffer = setup.sim.status().device.buffer_capacity;
    let mut bytes = 0;
    let bound = program.chunks[ja.checkpoint..]
        .iter()
        .take_while(|c| {
            bytes += c.bytes.len();
            bytes <= buffer + c.bytes.len()
        })
        .filter(|c| c.draws)
        .count();
    let replayed = assert_drawn_with_replay(&recorded(&setup.sim), &want, resumed);
    assert!(replayed <= bound, "{replayed} strokes drawn again; the device buffer holds {bound}");
    eprintln!("SIGKILL: resumed at stroke {resumed}, {replayed} strokes drawn again (bound {bound})");
    let rec = setup.sim.record();
    assert_eq!(rec.overruns, 0);
    assert!(rec.errors.is_empty(), "{:?}", rec.errors);
}

#[test]
fn sigterm_mid_job_stops_at_a_stroke_boundary_and_resumes_after_restart() {
    let setup = Setup::hp_escb("");
    let big = drawing();
    let want = strokes_of(&big, "hp7475a");
    let mut d = setup.start();
    let a = d.submit(JobKind::Hpgl, &big);
    setup.sim.wait_received(big.len() as u64 / 3, LONG).unwrap();
    assert!(d.terminate(LONG).success(), "plotd exits 0 on SIGTERM");
    setup.sim.wait_idle(LONG).unwrap();
    let st = setup.sim.status();
    assert!(!st.device.pen_down, "pen left down");
    // Whole strokes only, and nothing else.
    let got = recorded(&setup.sim);
    assert!(!got.is_empty() && got.len() < want.len(), "{} of {} strokes drawn at the stop", got.len(), want.len());
    assert_drawn_once(&got, &want[..got.len()], 0);

    let d = setup.start();
    let ja = d.job(a);
    let JobState::Paused { reason, .. } = &ja.state else { panic!("job came back {:?}", ja.state) };
    assert!(reason.contains("shut down"), "{reason}");
    let program = Program::build(big.as_bytes(), &Device::lookup("hp7475a").unwrap()).unwrap();
    let confirmed = program.chunks[..ja.checkpoint].iter().filter(|c| c.draws).count();
    assert_eq!(confirmed, got.len(), "the checkpoint is the stroke boundary it stopped at");
    assert_pen_left_alone(&setup, &d);

    d.resume(a);
    d.wait_state(a, "done", LONG);
    setup.sim.wait_idle(LONG).unwrap();
    assert_drawn_once(&recorded(&setup.sim), &want, 0);
    assert_eq!(setup.sim.record().overruns, 0);
}
