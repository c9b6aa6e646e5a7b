//! The `plotd` client commands against the `plotd serve` binary and a plotsim
//! HP 7475A at 9600 baud: `submit` (with `--follow` and its exit codes: 0
//! done, 3 cancelled, 4 failed), `jobs`, `status`, `pause`, `resume`,
//! `cancel` of a job while it plots (both stop at a stroke boundary, pen up),
//! and the `watch` events a progress bar is drawn from.

use crate::child;

use child::Setup;
use plotd::protocol::{Event, State};
use plotd_e2e::{assert_drawn_once, assert_plotted, hpgl_lines, recorded, strokes_of, wait_for, DaemonHandle};
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::Duration;

const LONG: Duration = Duration::from_secs(60);

fn write_job(setup: &Setup, name: &str, text: &str) -> PathBuf {
    let path = setup.dir.path().join(name);
    std::fs::write(&path, text).unwrap();
    path
}

fn plotd(socket: &Path, args: &[&str]) -> Command {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_plotd"));
    cmd.args(args).arg("--socket").arg(socket).env_remove("PLOTD_SOCKET");
    cmd
}

fn run(socket: &Path, args: &[&str]) -> Output {
    plotd(socket, args).output().expect("plotd runs")
}

fn ok(socket: &Path, args: &[&str]) -> String {
    let o = run(socket, args);
    assert!(o.status.success(), "plotd {args:?}: {}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8(o.stdout).unwrap()
}

/// The strokes drawn since `before` are the first strokes of `want`, whole.
fn whole_prefix(got: &[(u32, Vec<[f64; 2]>)], before: usize, want: &[(u32, Vec<[f64; 2]>)]) -> usize {
    let n = got.len() - before;
    assert!(n < want.len(), "all {} strokes drawn: the job was not stopped", want.len());
    assert_drawn_once(&got[before..], &want[..n], 0);
    n
}

#[test]
fn pause_resume_cancel_and_follow_from_the_command_line() {
    let setup = Setup::hp_escb("");
    let d = setup.start();
    let socket = setup.socket.as_path();
    // Job 2 is long enough that the cancel finds strokes not yet sent, on
    // a loaded machine too: with 120 the run had once sent everything (the
    // device then drew it all) by the time the cancel came, and ended done.
    let (a, b, c) = (hpgl_lines(120, 1), hpgl_lines(1200, 2), hpgl_lines(40, 3));
    let (want_a, want_b, want_c) = (strokes_of(&a, "hp7475a"), strokes_of(&b, "hp7475a"), strokes_of(&c, "hp7475a"));

    // submit prints the id; pause stops at a stroke boundary with the pen up.
    let out = ok(socket, &["submit", write_job(&setup, "a.hpgl", &a).to_str().unwrap()]);
    assert_eq!(out.trim(), "1");
    wait_for("a few strokes of job 1", LONG, || d.job(1).checkpoint >= 3);
    ok(socket, &["pause", "1"]);
    assert_eq!(d.paused_reason(1, LONG), "paused by user");
    let idle = setup.sim.wait_idle(LONG).unwrap();
    assert!(!idle.device.pen_down, "pen left down at the pause");
    let paused_at = whole_prefix(&recorded(&setup.sim), 0, &want_a);
    let jobs = ok(socket, &["jobs"]);
    assert!(jobs.lines().any(|l| l.split_whitespace().take(2).eq(["1", "paused"])), "{jobs}");
    let status = ok(socket, &["status"]);
    assert!(status.contains("plotter p: hp7475a on") && status.contains("(online)"), "{status}");
    assert_eq!(d.job(1).state, State::Paused);
    assert_eq!((recorded(&setup.sim).len(), setup.sim.status().bytes_received), (paused_at, idle.bytes_received), "sent while paused");

    // resume goes on; job 2 follows it, and is cancelled mid-plot: its
    // `submit --follow` exits 3.
    ok(socket, &["resume", "1"]);
    let mut follow = plotd(socket, &["submit", write_job(&setup, "b.hpgl", &b).to_str().unwrap(), "--follow"])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut first = String::new();
    BufReader::new(follow.stdout.as_mut().unwrap()).read_line(&mut first).unwrap();
    assert_eq!(first.trim(), "2");
    d.wait_state(1, State::Done, LONG);
    wait_for("a few strokes of job 2", LONG, || d.job(2).checkpoint >= 3);
    ok(socket, &["cancel", "2"]);
    assert_eq!(follow.wait().unwrap().code(), Some(3), "submit --follow of a cancelled job");
    assert_eq!(d.job(2).state, State::Cancelled);
    assert!(!setup.sim.wait_idle(LONG).unwrap().device.pen_down, "pen left down at the cancel");
    let got = recorded(&setup.sim);
    assert_drawn_once(&got[..want_a.len()], &want_a, 0);
    whole_prefix(&got, want_a.len(), &want_b);

    // Refusals exit 1 and say why.
    for (args, why) in [(["cancel", "2"], "already cancelled"), (["cancel", "99"], "no job 99"), (["resume", "2"], "not paused")] {
        let o = run(socket, &args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.code() == Some(1) && err.contains(why), "plotd {args:?}: {:?} {err}", o.status);
    }

    // Job 3 to the end: `--follow` exits 0; its events, as `watch` sends
    // them, count strokes and acknowledged bytes up and the estimate down.
    let events = std::thread::scope(|s| {
        // Watching every job (job 3 does not exist yet), until job 3 ends.
        let mut w = d.client();
        w.watch(None).unwrap();
        let watcher = s.spawn(move || {
            let mut events: Vec<Event> = Vec::new();
            while let Some(ev) = w.next_event().unwrap() {
                let end = ev.job == 3 && ev.state.is_final();
                if ev.job == 3 {
                    events.push(ev);
                }
                if end {
                    break;
                }
            }
            events
        });
        let o = plotd(socket, &["submit", write_job(&setup, "c.hpgl", &c).to_str().unwrap(), "--follow"]).output().unwrap();
        assert_eq!((o.status.code(), String::from_utf8_lossy(&o.stdout).trim()), (Some(0), "3"));
        watcher.join().unwrap()
    });
    let last = events.last().expect("events");
    // Strokes count the job's strokes exactly (its tail is a chunk, not a stroke).
    let total = want_c.len();
    assert_eq!(d.job(3).strokes_total, Some(total));
    assert_eq!((last.state, last.strokes_done, last.strokes_total), (State::Done, total, Some(total)));
    assert!(events.iter().all(|e| e.strokes_total.is_none_or(|t| t == total) && e.strokes_done <= total), "{events:?}");
    let plotting: Vec<&Event> = events.iter().filter(|e| e.state == State::Plotting).collect();
    assert!(plotting.len() >= 3, "{events:?}");
    assert!(events.windows(2).all(|w| w[0].strokes_done <= w[1].strokes_done), "{events:?}");
    assert!(plotting.windows(2).all(|w| w[0].bytes_acked <= w[1].bytes_acked), "{events:?}");
    let acked = plotting.last().unwrap().bytes_acked;
    assert!(acked >= c.len() as u64 / 2, "{acked} bytes acknowledged of {}", c.len());
    // The final event keeps the count: a progress bar must not fall back to 0.
    assert!(events.windows(2).all(|w| w[0].bytes_acked <= w[1].bytes_acked), "{events:?}");
    assert!(last.bytes_acked >= acked && last.bytes_acked > 0, "{events:?}");
    let etas: Vec<f64> = plotting.iter().filter_map(|e| e.eta_s).collect();
    assert!(etas.len() >= 2 && etas.first() > etas.last(), "ETA from the plot-time model: {etas:?}");

    setup.sim.wait_idle(LONG).unwrap();
    let mut want = want_a.clone();
    want.extend_from_slice(&want_b[..recorded(&setup.sim).len() - want_a.len() - want_c.len()]);
    want.extend(want_c);
    assert_plotted(&setup.sim, &want, 0);
}

#[test]
fn a_device_error_fails_the_job_when_configured_and_follow_exits_4() {
    let setup = Setup::hp_escb("on_device_error = \"fail\"");
    let d = setup.start();
    setup.sim.fail_next(Some(3));
    let path = write_job(&setup, "x.hpgl", &hpgl_lines(20, 4));
    let o = plotd(&setup.socket, &["submit", path.to_str().unwrap(), "--follow"]).output().unwrap();
    assert_eq!(o.status.code(), Some(4), "{}", String::from_utf8_lossy(&o.stderr));
    let jobs = ok(&setup.socket, &["jobs"]);
    assert!(jobs.lines().any(|l| l.split_whitespace().take(2).eq(["1", "failed"])), "{jobs}");
    let job = d.job(1);
    assert_eq!(job.state, State::Failed);
    let reason = job.reason.unwrap_or_default();
    assert!(reason.contains("error"), "{reason}");
}
