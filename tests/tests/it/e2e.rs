//! The daemon against plotsim over a real pty: each personality and handshake,
//! and the faults. Every test checks what the simulator drew
//! against what `plotd render --device` produces, with zero overruns.

use plotd::protocol::State;
use plotd::spool::JobKind;
use plotd_e2e::{assert_drawn_once, assert_plotted, recorded, render_for, repo_root, strokes_of, DaemonHandle, Rig};
use plotsim::SimConfig;
use std::time::Duration;

const LONG: Duration = Duration::from_secs(120);

fn lattice(device: &str) -> String {
    render_for(&repo_root().join("examples/lattice.toml"), device)
}

fn hp(baud: u32) -> SimConfig {
    SimConfig::hp7475a().with_speed_scale(0.0).with_baud(baud)
}

fn grbl() -> SimConfig {
    SimConfig::grbl().with_speed_scale(0.0)
}

/// Submits `text`, waits for `done`, checks the drawing and the overruns.
fn plot_exactly(rig: &Rig, kind: JobKind, text: &str) {
    let id = rig.submit(kind, text);
    let job = rig.wait_state(id, State::Done, LONG);
    assert_eq!(job.checkpoint, job.total.unwrap());
    rig.sim.wait_idle(Duration::from_secs(20)).unwrap();
    let want = strokes_of(text, &rig.device);
    assert!(want.len() >= 3, "the test drawing has strokes");
    assert_plotted(&rig.sim, &want, 0);
}

#[test]
fn hp_escb_draws_exactly_the_render() {
    let rig = Rig::start(hp(0), "hp7475a", "escb", "");
    plot_exactly(&rig, JobKind::Hpgl, &lattice("hp7475a"));
}

#[test]
fn hp_xonxoff_draws_exactly_the_render() {
    let rig = Rig::start(hp(0), "hp7475a", "xonxoff", "");
    plot_exactly(&rig, JobKind::Hpgl, &lattice("hp7475a"));
}

#[test]
fn hp_hardware_draws_exactly_the_render() {
    let rig = Rig::start(hp(0), "hp7475a", "hardware", "");
    plot_exactly(&rig, JobKind::Hpgl, &lattice("hp7475a"));
}

#[test]
fn grbl_draws_exactly_the_render() {
    let rig = Rig::start(grbl().with_baud(0), "grbl-servo", "grbl", "pen_change = \"ignore\"");
    plot_exactly(&rig, JobKind::Gcode, &lattice("grbl-servo"));
}

#[test]
fn scene_job_is_rendered_by_the_daemon() {
    let rig = Rig::start(hp(0), "hp7475a", "escb", "");
    let path = repo_root().join("examples/box_with_hole.toml");
    let scene = std::fs::read_to_string(&path).unwrap();
    let id = rig.submit(JobKind::Scene, &scene);
    rig.wait_state(id, State::Done, LONG);
    rig.sim.wait_idle(Duration::from_secs(20)).unwrap();
    assert_drawn_once(&recorded(&rig.sim), &strokes_of(&render_for(&path, "hp7475a"), "hp7475a"), 0);
    assert_eq!(rig.sim.record().overruns, 0);
}

/// Runs a job at 9600 baud, applies `fault` once the device has received
/// a third of it, then `recover`, and checks the drawing.
fn fault_case(handshake: &str, extra: &str, fault: impl FnOnce(&Rig, u64), recover: impl FnOnce(&Rig, u64)) {
    fault_case_checked(handshake, extra, fault, recover, |got, want| {
        assert_drawn_once(got, want, 1);
    });
}

type Strokes = [(u32, Vec<[f64; 2]>)];

fn fault_case_checked(
    handshake: &str,
    extra: &str,
    fault: impl FnOnce(&Rig, u64),
    recover: impl FnOnce(&Rig, u64),
    check: impl FnOnce(&Strokes, &Strokes),
) {
    let rig = Rig::start(hp(9600), "hp7475a", handshake, extra);
    // The lattice drawing runs through these faults in `faults.rs`.
    let text = render_for(&repo_root().join("examples/box_with_hole.toml"), "hp7475a");
    let id = rig.submit(JobKind::Hpgl, &text);
    rig.sim.wait_received(text.len() as u64 / 3, LONG).unwrap();
    fault(&rig, id);
    recover(&rig, id);
    rig.wait_state(id, State::Done, LONG);
    rig.sim.wait_idle(Duration::from_secs(20)).unwrap();
    check(&recorded(&rig.sim), &strokes_of(&text, "hp7475a"));
    assert_eq!(rig.sim.record().overruns, 0);
}

#[test]
fn unplug_mid_job_then_replug_and_resume() {
    fault_case("escb", "", |rig, _| rig.sim.unplug(Duration::from_millis(500)).unwrap(), |rig, id| rig.resume_after_replug(id, LONG));
}

/// The job pauses as the device goes offline and, with `auto_resume`,
/// plots on by itself once the port is back: no `resume` is sent.
#[test]
fn unplug_with_auto_resume() {
    let mut watch = None;
    fault_case(
        "escb",
        "auto_resume = true",
        |rig, id| {
            // Watched before the fault, so a pause that ends at once is seen.
            watch = Some(rig.watch_job(id));
            rig.sim.unplug(Duration::from_millis(300)).unwrap();
        },
        |_, _| {},
    );
    let events = watch.expect("watched").until_end(LONG);
    let states: Vec<State> = events.iter().map(|e| e.state).collect();
    let paused = events.iter().position(|e| e.state == State::Paused).unwrap_or_else(|| panic!("never paused: {states:?}"));
    let reason = events[paused].reason.as_deref().unwrap_or("");
    assert!(reason.contains("offline"), "{reason}");
    assert!(states[paused..].contains(&State::Plotting), "did not plot on after the pause: {states:?}");
    assert_eq!(states.last(), Some(&State::Done), "{states:?}");
}

/// The job pauses with the device's reason while the paper lever is up,
/// and plots on by itself once it is down.
#[test]
fn paper_lever_up_mid_job() {
    fault_case(
        "escb",
        "",
        |rig, _| rig.sim.lever(true).unwrap(),
        |rig, id| {
            let reason = rig.paused_reason(id, LONG);
            assert!(reason.contains("paper lever"), "{reason}");
            let events = rig.watch_job(id);
            rig.sim.lever(false).unwrap();
            let states: Vec<State> = events.until_end(LONG).into_iter().map(|e| e.state).collect();
            assert_eq!(states.first(), Some(&State::Paused), "{states:?}");
            assert!(states.contains(&State::Plotting), "did not plot on once the lever was down: {states:?}");
        },
    );
}

#[test]
fn device_error_mid_job_pauses_with_its_text() {
    // The failed instruction may be a pen-up the device then skipped: the
    // device itself draws one wrong line. Every expected segment is still drawn.
    fault_case_checked(
        "escb",
        "",
        |rig, _| rig.sim.fail_next(Some(3)),
        |rig, id| {
            let reason = rig.paused_reason(id, LONG);
            assert!(reason.contains("error"), "{reason}");
            rig.resume(id);
        },
        |got, want| {
            let segs = |s: &Strokes| -> Vec<[i64; 4]> {
                s.iter().flat_map(|(_, p)| p.windows(2).map(|w| [w[0][0], w[0][1], w[1][0], w[1][1]].map(|v| v.round() as i64))).collect()
            };
            let drawn = segs(got);
            for s in segs(want) {
                assert!(drawn.contains(&s), "segment {s:?} not drawn");
            }
        },
    );
}

#[test]
fn three_jobs_queued_while_offline() {
    let rig = Rig::start(hp(0), "hp7475a", "escb", "");
    rig.sim.unplug(Duration::from_millis(1500)).unwrap();
    let jobs: Vec<String> = (0..3).map(|i| format!("IN;SP1;PU{0},0;PD{0},500,{1},500;PU;", i * 1000, i * 1000 + 500)).collect();
    let ids: Vec<u64> = jobs.iter().map(|t| rig.submit(JobKind::Hpgl, t)).collect();
    for id in &ids {
        rig.wait_state(*id, State::Done, LONG);
    }
    rig.sim.wait_idle(Duration::from_secs(20)).unwrap();
    let want: Vec<_> = jobs.iter().flat_map(|t| strokes_of(t, "hp7475a")).collect();
    assert_drawn_once(&recorded(&rig.sim), &want, 0);
}

#[test]
fn malformed_job_among_good_ones() {
    let rig = Rig::start(hp(0), "hp7475a", "escb", "");
    let good = "IN;SP1;PU0,0;PD100,100;PU;";
    let a = rig.submit(JobKind::Hpgl, good);
    assert!(rig.client().submit(JobKind::Hpgl, None, "bad", "IN;PU0,0;\u{2}garbage".into()).is_err());
    let b = rig.submit(JobKind::Hpgl, good);
    rig.wait_state(a, State::Done, LONG);
    rig.wait_state(b, State::Done, LONG);
    rig.sim.wait_idle(Duration::from_secs(20)).unwrap();
    let want: Vec<_> = [good, good].iter().flat_map(|t| strokes_of(t, "hp7475a")).collect();
    assert_drawn_once(&recorded(&rig.sim), &want, 0);
}

// The load test (100 jobs from 10 clients, with the daemon's memory) runs the
// `plotd` binary as a child: `crates/plotd/tests/it/load.rs`.
