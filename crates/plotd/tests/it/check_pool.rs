//! Submit checks run in a bounded pool (issue #42 item 2): K clients
//! submitting at once never start more than one job worker per plotter
//! plus one. The daemon is the `plotd` binary (a child process); the test
//! counts its live job workers from `/proc` and freezes each one it finds
//! (SIGSTOP), so a worker it has seen stays live until the test lets it
//! go: the count can only err low, never past what the daemon started.

use crate::child;

use child::Setup;
use nix::sys::signal::{kill, Signal};
use nix::unistd::Pid;
use plotd::spool::JobKind;
use plotd_e2e::hpgl_lines;
use std::collections::BTreeSet;
use std::time::{Duration, Instant};

/// Concurrent submits, from one user.
const K: usize = 8;
/// Two plotters: one worker each, plus one.
const POOL: usize = 3;

/// A second plotter that never comes online: its jobs stay queued, so no
/// render's worker runs beside the checks.
const OFFLINE: &str = "[[plotter]]\nname = \"offline\"\nport = \"/nonexistent/tty\"\ndevice = \"hp7475a\"\nhandshake = \"escb\"\n";

/// Whether `pid` is a live `plotd job-worker` (not a zombie).
fn live_worker(pid: u32) -> bool {
    let cmdline = std::fs::read(format!("/proc/{pid}/cmdline")).unwrap_or_default();
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).unwrap_or_default();
    let state = stat.rsplit(')').next().and_then(|rest| rest.split_whitespace().next()).unwrap_or("Z");
    state != "Z" && cmdline.split(|&b| b == 0).any(|arg| arg == b"job-worker")
}

#[test]
fn concurrent_submits_never_run_more_checks_than_the_pool() {
    let setup = Setup::hp_escb(OFFLINE);
    let daemon = setup.start();
    let content = hpgl_lines(3000, 7);
    let submits: Vec<_> = (0..K)
        .map(|k| {
            let (socket, content) = (setup.socket.clone(), content.clone());
            std::thread::spawn(move || {
                let job = plotd::client::JobFile { kind: JobKind::Hpgl, content, files: std::collections::BTreeMap::new() };
                let placing = plotd::client::Placing { plotter: Some("offline"), same_sheet: true, ..plotd::client::Placing::default() };
                plotd::client::Client::connect(&socket)
                    .expect("connects")
                    .submit_job(job, &placing, &format!("flood-{k}"))
                    .map_err(|e| e.to_string())
            })
        })
        .collect();
    let (mut most, mut frozen, mut thawed) = (0, BTreeSet::new(), BTreeSet::new());
    let end = Instant::now() + Duration::from_secs(120);
    let mut last_new = Instant::now();
    while !submits.iter().all(std::thread::JoinHandle::is_finished) {
        assert!(Instant::now() < end, "the submits did not finish");
        let live: Vec<u32> = daemon.children().into_iter().filter(|&p| live_worker(p)).collect();
        most = most.max(live.len());
        assert!(live.len() <= POOL, "{} job workers at once, the pool is {POOL}", live.len());
        for &pid in &live {
            if frozen.insert(pid) {
                let _ = kill(Pid::from_raw(pid as i32), Signal::SIGSTOP);
                last_new = Instant::now();
            }
        }
        // With the pool full of frozen workers, or no new one for a while
        // (the pacing of the test, not something it asserts), let one go on.
        let held: Vec<u32> = live.iter().copied().filter(|p| !thawed.contains(p)).collect();
        if !held.is_empty() && (held.len() >= POOL || last_new.elapsed() > Duration::from_millis(300)) {
            let _ = kill(Pid::from_raw(held[0] as i32), Signal::SIGCONT);
            thawed.insert(held[0]);
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    for pid in daemon.children().into_iter().filter(|&p| live_worker(p)) {
        let _ = kill(Pid::from_raw(pid as i32), Signal::SIGCONT);
    }
    let (mut queued, mut refused) = (0, 0);
    for t in submits {
        match t.join().expect("submit thread") {
            Ok(_) => queued += 1,
            Err(e) => {
                assert!(e.contains("submits being checked"), "refused for another reason: {e}");
                refused += 1;
            }
        }
    }
    eprintln!("{queued} queued, {refused} refused (their user's share), at most {most} job workers at once");
    assert!(queued >= 4, "at least the user's share is checked and queued");
    assert!(most >= 1, "the test saw the workers");
}
