//! Reasons a person can read (issue 36 item 4), end to end over ptys:
//! `status` says why each plotter is offline, typed, and a job that waits
//! says for what, in `jobs` and in `watch`. Before: "(offline)" for every
//! one of them, and the job `queued` with no word.
//!
//! Beside plotsim (plotter `p`), the test plays the devices plotsim has no
//! fault for on ptys of its own: one that never answers, one that answers
//! every question with garbage.

use nix::pty::{openpty, OpenptyResult};
use plotd::protocol::{LinkFault, LinkState, PlotterInfo, Reply, Request, State, Waiting};
use plotd::spool::JobKind;
use plotd_e2e::{hpgl_lines, wait_for, DaemonHandle, Rig};
use plotsim::SimConfig;
use std::io::{Read, Write};
use std::os::fd::OwnedFd;
use std::path::{Path, PathBuf};
use std::time::Duration;

const LONG: Duration = Duration::from_secs(60);

/// A pty whose device end the test holds; its port's path.
fn pty() -> (OwnedFd, OwnedFd, PathBuf) {
    let OpenptyResult { master, slave } = openpty(None, None).expect("openpty");
    let path = nix::unistd::ttyname(&slave).expect("ttyname");
    (master, slave, path)
}

/// A device that answers whatever it is sent with `##garbage##` and CR.
fn spewing(master: OwnedFd) {
    std::thread::spawn(move || {
        let mut device = std::fs::File::from(master);
        let mut buf = [0u8; 256];
        while let Ok(n) = device.read(&mut buf) {
            if n == 0 || device.write_all(b"##garbage##\r").is_err() {
                return;
            }
        }
    });
}

/// A `[[plotter]]` table: `name` an HP 7475A on `port`.
fn plotter(name: &str, port: &Path) -> String {
    format!(
        "\n[[plotter]]\nname = \"{name}\"\nport = \"{}\"\ndevice = \"hp7475a\"\nhandshake = \"escb\"\nreply_timeout_s = 1.0\n",
        port.display()
    )
}

fn status(rig: &Rig) -> Vec<PlotterInfo> {
    match rig.client().call(&Request::Status {}) {
        Ok(Reply::Status { plotters, .. }) => plotters,
        other => panic!("{other:?}"),
    }
}

fn plotter_info(rig: &Rig, name: &str) -> PlotterInfo {
    status(rig).into_iter().find(|p| p.name == name).unwrap_or_else(|| panic!("no plotter {name}"))
}

/// Waits until plotter `name` is offline with a cause of `kind`; its message.
fn offline_for(rig: &Rig, name: &str, kind: LinkFault) -> String {
    wait_for(&format!("plotter {name} offline ({kind:?})"), LONG, || {
        let p = plotter_info(rig, name);
        p.link == LinkState::Offline && p.cause.as_ref().is_some_and(|c| c.kind == kind)
    });
    plotter_info(rig, name).cause.expect("a cause").message
}

/// A missing port, a silent device, a device spewing garbage and a port two
/// entries share (two paths to one tty, as `/dev/serial/by-id` links are):
/// `status` names each cause; a job for the missing one waits saying so,
/// in `jobs` and in `watch`, with the cause typed.
#[test]
fn status_says_why_each_plotter_is_offline_and_a_job_what_it_waits_for() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("ttyUSB7");
    let (_silent_master, _silent_slave, silent) = pty();
    let (garbage_master, _garbage_slave, garbage) = pty();
    spewing(garbage_master);
    // Rig's plotsim is `p`, its port the link `<rig dir>/tty`; `shared` names
    // the same tty through a link of its own, made once the rig is up.
    let shared = dir.path().join("by-id-link");
    let extra = format!(
        "reply_timeout_s = 1.0\nmotion_timeout_s = 20.0\n{}{}{}{}",
        plotter("missing", &missing),
        plotter("silent", &silent),
        plotter("garbage", &garbage),
        plotter("shared", &shared)
    );
    std::os::unix::fs::symlink(std::env::temp_dir().join("none"), &shared).ok();
    let rig = Rig::start(SimConfig::hp7475a().with_speed_scale(0.0).with_baud(9600), "hp7475a", "escb", &extra);
    std::fs::remove_file(&shared).ok();
    std::os::unix::fs::symlink(rig.dir.path().join("tty").canonicalize().unwrap(), &shared).unwrap();

    let message = offline_for(&rig, "missing", LinkFault::NoSuchPort);
    assert_eq!(message, format!("{}: no such file", missing.display()));
    assert_eq!(offline_for(&rig, "silent", LinkFault::Silent), "no answer to ESC.B for 1 s");
    assert_eq!(offline_for(&rig, "garbage", LinkFault::Unreadable), "answers we can't read: \"##garbage##\"");
    // Whichever of the two opened the tty first holds it; the other names it.
    wait_for("one of p and shared online, the other held", LONG, || {
        let (p, s) = (plotter_info(&rig, "p"), plotter_info(&rig, "shared"));
        let held_by = |by: &str| format!("port held by plotter {by:?}");
        let says = |q: &PlotterInfo, by: &str| q.cause.as_ref().is_some_and(|c| c.kind == LinkFault::PortHeld && c.message == held_by(by));
        (p.link == LinkState::Online && says(&s, "p")) || (s.link == LinkState::Online && says(&p, "shared"))
    });

    // A job for the missing plotter: queued, saying what it waits for.
    let job = plotd::client::JobFile { kind: JobKind::Hpgl, content: hpgl_lines(3, 1), files: Default::default() };
    let placing = plotd::client::Placing { plotter: Some("missing"), same_sheet: true, ..Default::default() };
    let id = rig.client().submit_job(job, &placing, "test").expect("job accepted");
    let shown = rig.job(id);
    let want = format!("waiting for plotter missing (offline: {}: no such file)", missing.display());
    assert_eq!((shown.state, shown.reason.as_deref()), (State::Queued, Some(want.as_str())));
    let Some(Waiting::Plotter { plotter, cause: Some(cause) }) = shown.waiting else { panic!("{:?}", shown.waiting) };
    assert_eq!((plotter.as_str(), cause.kind), ("missing", LinkFault::NoSuchPort));
    let mut events = rig.watch_job(id);
    let first = &events.seen()[0];
    assert_eq!((first.state, first.reason.as_deref()), (State::Queued, Some(want.as_str())));
    assert!(first.waiting.is_some(), "{first:?}");
    // The path comes to exist, its device silent (a tty of its own, so
    // that no other plotter holds it): `watch` tells it.
    let (_master, _slave, plugged) = pty();
    std::os::unix::fs::symlink(&plugged, &missing).unwrap();
    let next = events.next(LONG).expect("an event").clone();
    assert_eq!(next.reason.as_deref(), Some("waiting for plotter missing (offline: no answer to ESC.B for 1 s)"), "{next:?}");
}
