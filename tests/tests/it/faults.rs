//! Device faults end to end: the daemon against plotsim over a real pty, on
//! the larger lattice drawing. Every case ends with the job drawn exactly
//! once, at most the stroke in flight at the interruption drawn again.

use plotd::protocol::State;
use plotd::spool::JobKind;
use plotd_e2e::{assert_drawn_once, recorded, render_for, repo_root, strokes_of, DaemonHandle, Rig};
use plotsim::SimConfig;
use std::time::Duration;

const LONG: Duration = Duration::from_secs(120);

fn drawing(name: &str, device: &str) -> String {
    render_for(&repo_root().join("examples").join(name), device)
}

fn hp() -> SimConfig {
    SimConfig::hp7475a().with_speed_scale(0.0).with_baud(9600)
}

/// Plots `text` on `rig`, applies `fault` once a third of it has reached the
/// device, then `recover`; checks the drawing (at most one stroke repeated)
/// and the overruns.
fn hp_fault(rig: &Rig, text: &str, fault: impl FnOnce(&Rig), recover: impl FnOnce(&Rig, u64)) {
    let id = rig.submit(JobKind::Hpgl, text);
    rig.sim.wait_received(text.len() as u64 / 3, LONG).unwrap();
    fault(rig);
    recover(rig, id);
    rig.wait_state(id, State::Done, LONG);
    rig.sim.wait_idle(Duration::from_secs(20)).unwrap();
    let repeats = assert_drawn_once(&recorded(&rig.sim), &strokes_of(text, &rig.device), 1);
    eprintln!("{repeats} strokes drawn again");
    assert_eq!(rig.sim.record().overruns, 0);
}

#[test]
fn hp_lattice_power_cycle() {
    let rig = Rig::start(hp(), "hp7475a", "escb", "");
    hp_fault(
        &rig,
        &drawing("lattice.toml", "hp7475a"),
        |r| r.sim.power_cycle(),
        |r, id| {
            // A power cycle loses the pen's position: a person confirms it
            // (plotsim's HP comes back with its carriage at the origin).
            assert!(r.paused_reason(id, LONG).contains("position"));
            r.resume_position_confirmed(id);
        },
    );
}

#[test]
fn hp_lattice_unplug() {
    let rig = Rig::start(hp(), "hp7475a", "escb", "");
    hp_fault(
        &rig,
        &drawing("lattice.toml", "hp7475a"),
        |r| r.sim.unplug(Duration::from_millis(500)).unwrap(),
        |r, id| r.resume_after_replug(id, LONG),
    );
}
