//! systemd without systemd: `plotd serve` as a child with `NOTIFY_SOCKET`
//! pointing at a datagram socket this test listens on, and a watchdog asked
//! for (`WATCHDOG_USEC`, `WATCHDOG_PID` = the daemon's pid, as systemd sets
//! them). Checks what a `Type=notify` unit with `WatchdogSec=` relies on:
//! READY=1 once the socket listens, STATUS= naming the job being plotted,
//! WATCHDOG=1 pings from the main loop, STOPPING=1 on SIGTERM.

use crate::child;

use child::Setup;
use plotd::protocol::State;
use plotd::spool::JobKind;
use plotd_e2e::{render_for, repo_root, DaemonHandle};
use std::os::unix::net::{UnixDatagram, UnixStream};
use std::process::Command;
use std::sync::mpsc;
use std::time::{Duration, Instant};

const LONG: Duration = Duration::from_secs(60);

/// Every notification datagram, as (arrival, text), read on a thread so the
/// daemon's sends never wait on a full queue.
fn listen(path: &std::path::Path) -> mpsc::Receiver<(Instant, String)> {
    let sock = UnixDatagram::bind(path).expect("notify socket binds");
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let mut buf = vec![0u8; 4096];
        while let Ok(n) = sock.recv(&mut buf) {
            if tx.send((Instant::now(), String::from_utf8_lossy(&buf[..n]).into_owned())).is_err() {
                return;
            }
        }
    });
    rx
}

/// The next message with a line starting `prefix`, skipping others (kept in `seen`).
fn next_with(rx: &mpsc::Receiver<(Instant, String)>, prefix: &str, seen: &mut Vec<(Instant, String)>) -> (Instant, String) {
    let end = Instant::now() + LONG;
    loop {
        let left = end.saturating_duration_since(Instant::now());
        let (at, msg) = rx.recv_timeout(left).unwrap_or_else(|_| panic!("no {prefix} from the daemon; got {seen:?}"));
        seen.push((at, msg.clone()));
        if msg.lines().any(|l| l.starts_with(prefix)) {
            return (at, msg);
        }
    }
}

#[test]
fn ready_status_and_watchdog_reach_the_notify_socket() {
    let setup = Setup::hp_escb("");
    let notify = setup.dir.path().join("notify.sock");
    let rx = listen(&notify);
    // systemd sets WATCHDOG_PID to the service's pid; the shell execs plotd, keeping its own.
    let mut cmd = Command::new("sh");
    cmd.args(["-c", "WATCHDOG_PID=$$ exec \"$0\" serve --config \"$1\"", env!("CARGO_BIN_EXE_plotd")])
        .arg(&setup.config)
        .env("NOTIFY_SOCKET", &notify)
        .env("WATCHDOG_USEC", "400000");
    let mut d = setup.start_command(cmd);
    let mut seen = Vec::new();

    let (_, ready) = next_with(&rx, "READY=1", &mut seen);
    assert!(ready.contains(&format!("STATUS=listening on {}", setup.socket.display())), "{ready}");
    // READY only after the socket listens: it was ready when the message was sent.
    assert!(UnixStream::connect(&setup.socket).is_ok());

    // Pings at half the period the unit asks for (200 ms), from the main loop.
    let (first, _) = next_with(&rx, "WATCHDOG=1", &mut seen);
    let mut last = first;
    for _ in 0..4 {
        last = next_with(&rx, "WATCHDOG=1", &mut seen).0;
    }
    let mean = (last - first) / 4;
    // Not more often than the 100 ms floor, and well inside the period.
    assert!(
        mean >= Duration::from_millis(100) && mean < Duration::from_millis(400),
        "mean ping interval {mean:?} for WATCHDOG_USEC = 400 ms"
    );

    // A job at 9600 baud takes a while: STATUS names it while it plots.
    let id = d.submit(JobKind::Hpgl, &render_for(&repo_root().join("examples/cube.toml"), "hp7475a"));
    let (_, status) = next_with(&rx, &format!("STATUS=job {id}: plotting, stroke "), &mut seen);
    // Counted in strokes, as progress events count them.
    assert!(status.lines().any(|l| l.ends_with(&format!("/{}", d.job(id).strokes_total.unwrap()))), "{status}");
    d.wait_state(id, State::Done, LONG);
    next_with(&rx, &format!("STATUS=job {id}: done"), &mut seen);
    // Pings go on while and after plotting.
    next_with(&rx, "WATCHDOG=1", &mut seen);

    assert!(d.terminate(LONG).success());
    next_with(&rx, "STOPPING=1", &mut seen);
}
