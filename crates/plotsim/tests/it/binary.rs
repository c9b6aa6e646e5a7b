//! The `plotsim` binary: pty path on stdout, control socket, files on exit.

use crate::common;

use common::{Port, WAIT};
use std::io::{BufRead, BufReader, Write};
use std::os::unix::net::UnixStream;
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn control(sock: &PathBuf, line: &str) -> String {
    let mut s = UnixStream::connect(sock).unwrap();
    s.set_read_timeout(Some(WAIT)).unwrap();
    writeln!(s, "{line}").unwrap();
    let mut answer = String::new();
    BufReader::new(s).read_line(&mut answer).unwrap();
    answer.trim_end().to_string()
}

/// Kills the child if the test fails half-way, so it does not outlive the run.
struct Reap(std::process::Child);

impl Drop for Reap {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

#[test]
fn the_binary_plots_obeys_its_control_socket_and_saves_on_sigterm() {
    let dir = std::env::temp_dir().join(format!("plotsim-bin-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (link, sock, json, svg) = (dir.join("tty"), dir.join("ctl"), dir.join("r.json"), dir.join("r.svg"));
    let child = Command::new(env!("CARGO_BIN_EXE_plotsim"))
        .args(["--personality", "hp7475a", "--speed-scale", "0", "--baud", "115200"])
        .arg("--link")
        .arg(&link)
        .arg("--control")
        .arg(&sock)
        .arg("--record")
        .arg(&json)
        .arg("--svg")
        .arg(&svg)
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut child = Reap(child);
    let mut first = String::new();
    BufReader::new(child.0.stdout.take().unwrap()).read_line(&mut first).unwrap();
    let pty = PathBuf::from(first.trim());
    assert!(pty.starts_with("/dev/pts"), "{first}");
    assert_eq!(std::fs::read_link(&link).unwrap(), pty);
    let t0 = Instant::now();
    while !sock.exists() {
        assert!(t0.elapsed() < WAIT, "control socket never appeared");
        std::thread::sleep(Duration::from_millis(10));
    }

    let mut port = Port::open(&link);
    port.send(b"IN;SP1;PD0,0,400,0,400,400;PU;");
    assert_eq!(port.ask(b"OA;"), "400,400,0");
    assert_eq!(control(&sock, "lever up"), "ok");
    assert_eq!(port.ask(b"\x1b.O"), "40", "lever up and buffer empty");
    assert_eq!(control(&sock, "lever down"), "ok");
    assert_eq!(control(&sock, "error"), "ok");
    port.send(b"SP2;");
    assert_eq!(port.ask(b"OE;"), "1");
    assert_eq!(control(&sock, "garbage"), "ok");
    assert!(port.ask(b"\x1b.B").parse::<u32>().is_err());
    assert!(control(&sock, "status").starts_with("ok state=ready"));
    assert!(control(&sock, "unplug x").starts_with("error: unplug"));
    assert!(control(&sock, "fly").starts_with("error: unknown command"));
    assert_eq!(control(&sock, "save"), "ok");
    let saved: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(saved["strokes"][0]["pen"], 1);
    assert_eq!(saved["strokes"][0]["points"].as_array().unwrap().len(), 3);

    assert_eq!(control(&sock, "unplug 200"), "ok");
    let t0 = Instant::now();
    let relinked = loop {
        if let Ok(p) = std::fs::read_link(&link) {
            if p != pty {
                break p;
            }
        }
        assert!(t0.elapsed() < WAIT, "link never came back");
        std::thread::sleep(Duration::from_millis(10));
    };
    let mut port = Port::open(&relinked);
    port.send(b"PD0,400;PU;");
    assert_eq!(port.ask(b"OA;"), "0,400,0");

    nix::sys::signal::kill(nix::unistd::Pid::from_raw(child.0.id() as i32), nix::sys::signal::Signal::SIGTERM).unwrap();
    let status = child.0.wait().unwrap();
    assert!(status.success(), "{status:?}");
    let saved: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    // The line drawn after the replug starts where the pen stayed, (400,400),
    // but after a PU: a stroke of its own.
    assert_eq!(saved["strokes"][1]["points"].as_array().unwrap().len(), 2, "drawn after the replug, saved on SIGTERM");
    assert_eq!(saved["overruns"], 0);
    assert!(saved["faults"].as_array().unwrap().len() >= 5);
    assert!(std::fs::read_to_string(&svg).unwrap().contains("<polyline"));
    assert!(!sock.exists() && std::fs::symlink_metadata(&link).is_err(), "socket and link cleaned up");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bad_arguments_are_refused_with_a_message() {
    let out = Command::new(env!("CARGO_BIN_EXE_plotsim")).args(["--personality", "plotter9000"]).output().unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("unknown personality 'plotter9000'"));
    let out = Command::new(env!("CARGO_BIN_EXE_plotsim")).args(["--personality", "grbl", "--buffer-size", "1"]).output().unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("buffer_size"));
}
