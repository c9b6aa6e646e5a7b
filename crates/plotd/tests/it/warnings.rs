//! What a person must act on is in the daemon's log at WARN, and in
//! `plotd status` and `plotd jobs` (issue 36 item 4): the `plotd` binary as
//! a child, its stderr captured. Before: the fallback to the checkpoint
//! ("strokes will be drawn again") and a plotter offline were at INFO and
//! debug, and `status` said only "(offline)".

use crate::child::Setup;
use plotd::protocol::State;
use plotd::spool::JobKind;
use plotd_e2e::{render_for, repo_root, wait_for, DaemonHandle};
use plotsim::SimConfig;
use std::path::Path;
use std::process::Command;
use std::time::Duration;

const LONG: Duration = Duration::from_secs(120);

/// `plotd ARGS --socket S`'s standard output.
fn plotd(args: &[&str], socket: &Path) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_plotd")).args(args).arg("--socket").arg(socket).output().expect("plotd runs");
    assert!(out.status.success(), "{args:?}: {}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout).expect("UTF-8")
}

/// The log's lines at WARN that say all of `words`.
fn warned(log: &Path, words: &[&str]) -> Vec<String> {
    let text = std::fs::read_to_string(log).unwrap_or_default();
    text.lines().filter(|l| l.contains("WARN") && words.iter().all(|w| l.contains(w))).map(str::to_owned).collect()
}

/// A GRBL board that loses the lines in its buffer mid-job: the run resyncs
/// and goes on from the checkpoint, drawing strokes again, and says so at
/// WARN. A second plotter's port is missing: WARN, and `status` and `jobs`
/// say why, and what its job waits for.
#[test]
fn warnings_a_person_must_act_on_are_warn_and_status_says_why() {
    let setup = Setup::new(SimConfig::grbl().with_speed_scale(0.05).with_baud(115_200), "grbl-servo", "grbl", "pen_change = \"ignore\"");
    let missing = setup.dir.path().join("ttyUSB9");
    let text = std::fs::read_to_string(&setup.config).unwrap();
    let table = format!("\n[[plotter]]\nname = \"gone\"\nport = \"{}\"\ndevice = \"hp7475a\"\nhandshake = \"escb\"\n", missing.display());
    std::fs::write(&setup.config, text + &table).unwrap();
    let log = setup.dir.path().join("plotd.log");
    let d = setup.start_logging(&log);

    let no_such = format!("{}: no such file", missing.display());
    wait_for("the missing port at WARN", LONG, || !warned(&log, &["plotter offline", &no_such]).is_empty());
    let status = plotd(&["status"], d.socket());
    assert!(status.contains(&format!("plotter gone: hp7475a on {} (offline: {no_such}, fresh sheet)", missing.display())), "{status}");
    let job = plotd::client::JobFile { kind: JobKind::Hpgl, content: "IN;SP1;PU0,0;PD100,100;PU;".into(), files: Default::default() };
    let placing = plotd::client::Placing { plotter: Some("gone"), same_sheet: true, ..Default::default() };
    let waiting = d.client().submit_job(job, &placing, "test").expect("job accepted");
    let jobs = plotd(&["jobs"], d.socket());
    let line = jobs.lines().find(|l| l.trim_start().starts_with(&format!("{waiting} "))).unwrap_or_else(|| panic!("{jobs}"));
    assert!(line.contains(&format!("(waiting for plotter gone (offline: {no_such}))")), "{line}");

    let big = render_for(&repo_root().join("examples/lattice.toml"), "grbl-servo");
    let id = d.submit(JobKind::Gcode, &big);
    setup.sim.wait_received(big.len() as u64 / 3, LONG).unwrap();
    setup.sim.lose_input().unwrap();
    d.wait_state(id, State::Done, LONG);
    let again = warned(&log, &["resuming from the checkpoint", "strokes will be drawn again"]);
    assert!(!again.is_empty(), "{}", std::fs::read_to_string(&log).unwrap());
}
