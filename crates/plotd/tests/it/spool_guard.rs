//! The spool kept whole against a second daemon and damaged records (issue
//! 20, defects 6 and 7), and what `plotd jobs` shows of what clients named
//! (defect 10): the `plotd` binary as a child process.

use crate::child;

use child::Setup;
use plotd::client::Client;
use plotd::protocol::State;
use plotd::spool::{JobKind, JobRecord};
use plotd_e2e::{hpgl_lines, DaemonHandle};
use std::time::{Duration, Instant};

const LONG: Duration = Duration::from_secs(60);

fn record_on_disk(setup: &Setup, id: u64) -> JobRecord {
    serde_json::from_slice(&std::fs::read(setup.dir.path().join(format!("spool/jobs/{id}.json"))).unwrap()).unwrap()
}

#[test]
fn a_second_daemon_on_the_spool_exits_and_changes_nothing() {
    let setup = Setup::hp_escb("");
    let d = setup.start();
    let id = d.submit(JobKind::Hpgl, &hpgl_lines(200, 1));
    d.wait_state(id, State::Plotting, LONG);
    let before = std::fs::read(setup.dir.path().join(format!("spool/jobs/{id}.json"))).unwrap();

    let second = std::process::Command::new(env!("CARGO_BIN_EXE_plotd"))
        .args(["serve", "--config"])
        .arg(&setup.config)
        .env("RUST_LOG", "warn")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&second.stderr);
    assert_eq!(second.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("in use by another plotd"), "{stderr}");
    // The first daemon's job is as it was: still plotting, on disk and live.
    let after = record_on_disk(&setup, id);
    assert_eq!(after.state.name(), "plotting", "{after:?}");
    let before: JobRecord = serde_json::from_slice(&before).unwrap();
    assert!(after.checkpoint >= before.checkpoint);
    d.wait_state(id, State::Done, LONG);
}

#[test]
fn a_corrupt_record_is_shown_kept_with_its_content_and_its_id_not_reused() {
    let setup = Setup::hp_escb("");
    let mut d = setup.start();
    // Two jobs wait (the plotter is held by a paused first one).
    let hold = d.submit(JobKind::Hpgl, "IN;SP1;PU0,0;PD10,10;PU;");
    d.wait_state(hold, State::Done, LONG);
    let a = d.submit(JobKind::Hpgl, "IN;SP1;PU0,0;PD20,20;PU;");
    let b = d.submit(JobKind::Hpgl, "IN;SP1;PU0,0;PD30,30;PU;");
    d.wait_state(b, State::Done, LONG);
    d.terminate(LONG);
    // The newest record is torn (a disk fault, a hand edit).
    let path = setup.dir.path().join(format!("spool/jobs/{b}.json"));
    let bytes = std::fs::read(&path).unwrap();
    std::fs::write(&path, &bytes[..bytes.len() / 2]).unwrap();

    let d = setup.start();
    let (jobs, corrupt) = d.client().job_list().unwrap();
    assert_eq!(jobs.iter().map(|j| j.id).collect::<Vec<_>>(), [hold, a]);
    assert_eq!(corrupt.len(), 1, "{corrupt:?}");
    assert_eq!(corrupt[0].id, b);
    assert!(corrupt[0].path.ends_with(format!("corrupt/{b}.json")), "{:?}", corrupt[0].path);
    // Kept aside as it was, its content kept.
    assert_eq!(std::fs::read(&corrupt[0].path).unwrap(), &bytes[..bytes.len() / 2]);
    assert_eq!(std::fs::read(setup.dir.path().join(format!("spool/data/{b}"))).unwrap(), b"IN;SP1;PU0,0;PD30,30;PU;");
    // `plotd jobs` shows it.
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_plotd")).args(["jobs", "--socket"]).arg(&setup.socket).output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.lines().any(|l| l.trim_start().starts_with(&format!("{b}  corrupt"))), "{text}");
    // The next job takes a new id, and the kept content is untouched.
    let next = d.submit(JobKind::Hpgl, "IN;SP1;PU0,0;PD40,40;PU;");
    assert_eq!(next, b + 1);
    assert_eq!(std::fs::read(setup.dir.path().join(format!("spool/data/{b}"))).unwrap(), b"IN;SP1;PU0,0;PD30,30;PU;");
}

#[test]
fn names_with_control_characters_are_shown_escaped() {
    let setup = Setup::hp_escb("");
    let d = setup.start();
    // A name that would erase its line and forge another.
    let forged = "x.hpgl\u{1b}[2K\r   99  done       p                5/5  payroll.hpgl\n\u{9b}31m";
    let id = Client::connect(&setup.socket).unwrap().submit(JobKind::Hpgl, None, forged, "IN;SP1;PU0,0;PD10,10;PU;".into()).unwrap();
    d.wait_state(id, State::Done, LONG);
    let plotd = |args: &[&str]| {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_plotd")).args(args).arg("--socket").arg(&setup.socket).output().unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        String::from_utf8(out.stdout).unwrap()
    };
    let jobs = plotd(&["jobs"]);
    assert_eq!(jobs.lines().count(), 1, "{jobs:?}");
    assert!(!jobs.trim_end_matches('\n').chars().any(char::is_control), "{jobs:?}");
    assert!(jobs.contains(r"x.hpgl\u{1b}[2K\r   99") && jobs.contains(r"\n\u{9b}31m"), "{jobs}");
    let watch = std::process::Command::new(env!("CARGO_BIN_EXE_plotd"))
        .args(["watch", &id.to_string(), "--socket"])
        .arg(&setup.socket)
        .output()
        .unwrap();
    let watch = String::from_utf8(watch.stdout).unwrap();
    assert!(!watch.trim_end_matches('\n').chars().any(char::is_control), "{watch:?}");
    let start = Instant::now();
    let status = plotd(&["status"]);
    assert!(!status.trim_end_matches('\n').chars().any(|c| c.is_control() && c != '\n'), "{status:?}");
    assert!(start.elapsed() < LONG);
}

#[test]
fn unknown_request_fields_are_refused() {
    let setup = Setup::hp_escb("");
    let _d = setup.start();
    let mut s = std::os::unix::net::UnixStream::connect(&setup.socket).unwrap();
    use std::io::{BufRead, Write};
    s.write_all(b"{\"cmd\":\"jobs\",\"x\":1}\n{\"cmd\":\"status\",\"all\":true}\n").unwrap();
    let mut lines = std::io::BufReader::new(s).lines();
    for _ in 0..2 {
        let reply: serde_json::Value = serde_json::from_str(&lines.next().unwrap().unwrap()).unwrap();
        assert_eq!(reply["reply"], "error", "{reply}");
        assert!(reply["message"].as_str().unwrap().contains("unknown field"), "{reply}");
    }
}
