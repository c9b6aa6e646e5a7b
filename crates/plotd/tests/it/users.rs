//! Users on a shared daemon (issue #42 item 5), with real uids: the daemon
//! (root, a child process) listens on a socket of mode 0660 whose group is
//! the plotting group; `plotd` clients run as two users in that group and
//! one outside it (`Command::uid`/`gid`: the uids need no account). One
//! user can never cancel, pause, resume or read the other's job; root may
//! act on any job; a user outside the group cannot connect.
//!
//! Needs root to change uid: without it the test fails under CI (`CI` set)
//! and is skipped elsewhere, saying why.

use crate::child;

use child::Setup;
use plotd::protocol::State;
use plotd_e2e::{present_or_skip, DaemonHandle};
use std::os::unix::fs::PermissionsExt;
use std::os::unix::process::CommandExt;
use std::path::Path;
use std::process::{Command, Output};

/// The group that may use the socket, and its users; one user outside it.
const GROUP: u32 = 64_100;
const ALICE: u32 = 64_101;
const BOB: u32 = 64_102;
const MALLORY: u32 = 64_103;

/// A second plotter that never comes online: jobs sent to it stay queued.
const OFFLINE: &str = "[[plotter]]\nname = \"offline\"\nport = \"/nonexistent/tty\"\ndevice = \"hp7475a\"\nhandshake = \"escb\"\n";

/// `plotd ARGS --socket SOCKET` run as `uid` with primary group `gid`.
fn plotd_as(uid: u32, gid: u32, socket: &Path, args: &[&str]) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_plotd"));
    cmd.args(args).arg("--socket").arg(socket).uid(uid).gid(gid).env("HOME", "/nonexistent").current_dir("/");
    cmd.output().expect("plotd runs")
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// Succeeded, with its standard output.
fn ok(out: &Output, what: &str) -> String {
    assert!(out.status.success(), "{what}: {}{}", text(&out.stdout), text(&out.stderr));
    text(&out.stdout)
}

/// Refused, with its standard error.
fn refused(out: &Output, what: &str) -> String {
    assert!(!out.status.success(), "{what} was allowed: {}", text(&out.stdout));
    text(&out.stderr)
}

#[test]
fn one_user_cannot_act_on_or_read_anothers_job_and_outsiders_cannot_connect() {
    let missing = (!nix::unistd::geteuid().is_root()).then(|| "not root (changing uid needs it)".to_owned());
    if !present_or_skip("users", missing) {
        return;
    }
    let setup = Setup::hp_escb(OFFLINE);
    let daemon = setup.start();
    // The socket's group is the plotting group; its directory is open to
    // look up (a system daemon's /run/plotd is 0755 too).
    let socket = &setup.socket;
    nix::unistd::chown(socket.as_path(), None, Some(nix::unistd::Gid::from_raw(GROUP))).expect("chgrp the socket");
    std::fs::set_permissions(setup.dir.path(), std::fs::Permissions::from_mode(0o755)).unwrap();
    let file = setup.dir.path().join("secret-plans.hpgl");
    std::fs::write(&file, "IN;SP1;PU0,0;PD100,100;PU;").unwrap();
    nix::unistd::chown(&file, Some(nix::unistd::Uid::from_raw(ALICE)), None).unwrap();
    let path = file.to_str().unwrap();

    // Alice submits; the job is hers, by the socket's credentials.
    let out = plotd_as(ALICE, GROUP, socket, &["submit", path, "--plotter", "offline"]);
    let id: u64 = ok(&out, "alice's submit").trim().parse().expect("the job's id");
    let job = daemon.job(id);
    assert_eq!((job.uid, job.state), (ALICE, State::Queued));
    let id = id.to_string();

    // Bob may not act on it, by id or through every job at once.
    for (args, why) in [
        (vec!["cancel", id.as_str()], "belongs to uid 64101"),
        (vec!["pause", id.as_str()], "belongs to uid 64101"),
        (vec!["resume", id.as_str()], "belongs to uid 64101"),
        (vec!["pause"], "without a job id acts on every user's jobs"),
        (vec!["resume"], "without a job id acts on every user's jobs"),
    ] {
        let err = refused(&plotd_as(BOB, GROUP, socket, &args), &format!("bob's {args:?}"));
        assert!(err.contains(why), "bob's {args:?}: {err}");
    }
    assert_eq!(daemon.job(id.parse().unwrap()).state, State::Queued, "untouched");
    // Bob reads that there is a job, not what it is.
    let listed = ok(&plotd_as(BOB, GROUP, socket, &["jobs"]), "bob's jobs");
    assert!(listed.contains(&id) && !listed.contains("secret-plans"), "bob's jobs: {listed}");
    let status = ok(&plotd_as(BOB, GROUP, socket, &["status"]), "bob's status");
    assert!(!status.contains("secret-plans"), "bob's status: {status}");
    // Alice reads all of it, and pauses and cancels it.
    let listed = ok(&plotd_as(ALICE, GROUP, socket, &["jobs"]), "alice's jobs");
    assert!(listed.contains("secret-plans"), "alice's jobs: {listed}");
    ok(&plotd_as(ALICE, GROUP, socket, &["pause", &id]), "alice's pause");
    ok(&plotd_as(ALICE, GROUP, socket, &["cancel", &id]), "alice's cancel");
    assert_eq!(daemon.job(id.parse().unwrap()).state, State::Cancelled);

    // Root (an operator) acts on anyone's job.
    let bobs = setup.dir.path().join("bob.hpgl");
    std::fs::write(&bobs, "IN;SP1;PU0,0;PD100,0;PU;").unwrap();
    nix::unistd::chown(&bobs, Some(nix::unistd::Uid::from_raw(BOB)), None).unwrap();
    let out = plotd_as(BOB, GROUP, socket, &["submit", bobs.to_str().unwrap(), "--plotter", "offline"]);
    let bob_job: u64 = ok(&out, "bob's submit").trim().parse().expect("the job's id");
    ok(&plotd_as(0, 0, socket, &["cancel", &bob_job.to_string()]), "root's cancel");
    assert_eq!(daemon.job(bob_job).state, State::Cancelled);

    // Outside the group: the socket's mode refuses the connection.
    let err = refused(&plotd_as(MALLORY, MALLORY, socket, &["status"]), "mallory's status");
    assert!(err.contains("ermission denied"), "mallory: {err}");
}
