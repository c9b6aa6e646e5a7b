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

/// A `plotsim` process, with its link, control socket, record (`r.json`)
/// and picture (`r.svg`) in a directory of its own.
struct Running {
    child: Reap,
    dir: PathBuf,
    link: PathBuf,
    sock: PathBuf,
    /// The pty slave path it printed.
    pty: PathBuf,
}

fn start(tag: &str, args: &[&str]) -> Running {
    let dir = std::env::temp_dir().join(format!("plotsim-bin-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (link, sock) = (dir.join("tty"), dir.join("ctl"));
    let child = Command::new(env!("CARGO_BIN_EXE_plotsim"))
        .args(args)
        .arg("--link")
        .arg(&link)
        .arg("--control")
        .arg(&sock)
        .arg("--record")
        .arg(dir.join("r.json"))
        .arg("--svg")
        .arg(dir.join("r.svg"))
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut child = Reap(child);
    let mut first = String::new();
    BufReader::new(child.0.stdout.take().unwrap()).read_line(&mut first).unwrap();
    let pty = PathBuf::from(first.trim());
    assert!(pty.starts_with("/dev/pts"), "{first}");
    // The line comes once the control socket listens.
    assert!(sock.exists(), "no control socket once the pty path was printed");
    Running { child, dir, link, sock, pty }
}

fn saved(run: &Running) -> serde_json::Value {
    assert_eq!(control(&run.sock, "save"), "ok");
    serde_json::from_str(&std::fs::read_to_string(run.dir.join("r.json")).unwrap()).unwrap()
}

#[test]
fn the_binary_plots_obeys_its_control_socket_and_saves_on_sigterm() {
    let Running { mut child, dir, link, sock, pty } = start("hp", &["--personality", "hp7475a", "--speed-scale", "0", "--baud", "115200"]);
    let (json, svg) = (dir.join("r.json"), dir.join("r.svg"));
    assert_eq!(std::fs::read_link(&link).unwrap(), pty);

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
    let out =
        Command::new(env!("CARGO_BIN_EXE_plotsim")).args(["--personality", "hp7475a", "--quirks", "no-esc-o,no-esc-q"]).output().unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("unknown quirk 'no-esc-q'"), "{}", String::from_utf8_lossy(&out.stderr));
    let out = Command::new(env!("CARGO_BIN_EXE_plotsim")).args(["--personality", "hp7475a", "--quirks", "reset-on-open"]).output().unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("quirks: reset-on-open is a quirk of grbl firmware, not of hp7475a"), "{err}");
    let out = Command::new(env!("CARGO_BIN_EXE_plotsim")).args(["--personality", "ebb", "--firmware", "2.9"]).output().unwrap();
    assert!(String::from_utf8_lossy(&out.stderr).contains("unknown EBB firmware '2.9' (2.8.1 or 3.0.2)"));
    let out = Command::new(env!("CARGO_BIN_EXE_plotsim")).args(["--personality", "ebb", "--model", "axidraw-v9"]).output().unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("model: 'axidraw-v9' is not an AxiDraw model"));
}

/// `--quirks` for an HP-GL clone: `ESC.O` unanswered, `ESC.M` not honoured
/// (answers end with CR), a bare `;` is error 1; `reset` is a power cycle.
#[test]
fn the_binary_plays_an_hpgl_clone_with_its_quirks() {
    let run = start("hp-quirks", &["--personality", "hp7475a", "--speed-scale", "0", "--quirks", "no-esc-o,no-esc-m,strict-separators"]);
    let mut port = Port::open(&run.link);
    port.send(b"\x1b.M;;;13;10:\x1b.O");
    assert_eq!(port.ask(b"\x1b.B"), "1024", "ESC.O said nothing; the terminator is CR alone");
    assert!(port.inbox.is_empty(), "{:?}", port.inbox);
    assert_eq!(port.ask(b";OI;"), "7475A");
    assert_eq!(port.ask(b"OE;"), "1");
    assert_eq!(control(&run.sock, "lever up"), "ok");
    port.send(b"SP1;PD0,0,400,0;PU;");
    assert_eq!(port.ask(b"\x1b.B"), "1005", "held in the buffer while the lever is up");
    assert_eq!(control(&run.sock, "reset"), "ok");
    assert_eq!(port.ask(b"\x1b.B"), "1024", "the buffer is empty after the reset");
    assert_eq!(control(&run.sock, "lever down"), "ok");
    assert_eq!(port.ask(b"OA;"), "0,0,0", "nothing was drawn");
    assert!(control(&run.sock, "park").starts_with("error: "), "an HP plotter cannot be parked by hand");
    let record = saved(&run);
    assert_eq!(record["errors"][0]["kind"], "hpgl");
    assert_eq!(record["errors"][0]["code"], 1);
    assert_eq!(record["faults"][1]["kind"], "reset");
    assert!(record["strokes"].as_array().unwrap().is_empty());
    std::fs::remove_dir_all(&run.dir).ok();
}

/// `--quirks` for a GRBL board that requires homing and resets when its
/// port opens: locked after each reset (the port opening, the `reset`
/// control); `$X` unlocks it unhomed, which the record keeps.
#[test]
fn the_binary_plays_a_grbl_board_that_resets_and_requires_homing() {
    let run = start("grbl-quirks", &["--personality", "grbl", "--speed-scale", "0", "--quirks", "homing-required,reset-on-open"]);
    let greeting = |port: &mut Port| {
        for line in ["", "Grbl 1.1h ['$' for help]", "[MSG:'$H'|'$X' to unlock]"] {
            assert_eq!(port.read_until(b"\r\n"), line);
        }
    };
    let mut port = Port::open(&run.link);
    greeting(&mut port);
    assert!(control(&run.sock, "status").starts_with("ok state=Alarm"));
    port.send(b"$H\nG0X30Y20\n");
    for _ in 0..2 {
        assert_eq!(port.read_until(b"\r\n"), "ok");
    }
    assert_eq!(control(&run.sock, "reset"), "ok");
    greeting(&mut port);
    port.send(b"$X\n");
    assert_eq!(port.read_until(b"\r\n"), "[MSG:Caution: Unlocked]");
    assert_eq!(port.read_until(b"\r\n"), "ok");
    assert_eq!(control(&run.sock, "park"), "ok");
    let record = saved(&run);
    assert_eq!(record["unlocked_without_homing"], true);
    let faults: Vec<&str> = record["faults"].as_array().unwrap().iter().map(|f| f["kind"].as_str().unwrap()).collect();
    assert_eq!(faults, ["reset-on-open", "reset", "park"]);
    std::fs::remove_dir_all(&run.dir).ok();
}

#[test]
fn the_ebb_binary_draws_a_square_and_obeys_its_control_socket() {
    let run = start("ebb-bin", &["--personality", "ebb", "--firmware", "3.0.2", "--nickname", "axi1", "--speed-scale", "0"]);
    let Running { mut child, dir, link, sock, .. } = run;
    let (json, svg) = (dir.join("r.json"), dir.join("r.svg"));
    let mut port = Port::open(&link);
    let ask = |port: &mut Port, cmd: &str| {
        port.send(format!("{cmd}\r").as_bytes());
        port.line()
    };
    assert_eq!(ask(&mut port, "V"), "EBBv13_and_above EB Firmware Version 3.0.2");
    assert_eq!(ask(&mut port, "QT"), "axi1");
    assert_eq!(port.line(), "OK");
    // What axicli sends for a 20 mm square at 10 mm from home: its pen
    // heights (60 % up, 30 % down of 9855..27831) and rates, the servo
    // timeout, 1/16 steps, then XM moves (A = x, B = y towards the front, 80
    // steps per mm) with the pen lowered and raised between.
    for c in [
        "SC,4,20641",
        "SC,5,15248",
        "SC,11,1618",
        "SC,12,1079",
        "SR,60000",
        "EM,1,1",
        "SP,1,200",
        "XM,500,800,800",
        "SP,0,200",
        "XM,1000,1600,0",
        "XM,1000,0,1600",
        "XM,1000,-1600,0",
        "XM,1000,0,-1600",
        "SP,1,200",
        "XM,500,-800,-800",
    ] {
        assert_eq!(ask(&mut port, c), "OK", "{c}");
    }
    assert_eq!(control(&sock, "button"), "ok");
    assert_eq!(ask(&mut port, "QB"), "1");
    assert_eq!(port.line(), "OK");
    assert_eq!(control(&sock, "power-loss 200"), "ok");
    assert_eq!(ask(&mut port, "QC"), "394,0");
    assert_eq!(port.line(), "OK");
    let t0 = Instant::now();
    loop {
        let qc = ask(&mut port, "QC");
        assert_eq!(port.line(), "OK");
        if qc == "394,300" {
            break;
        }
        assert!(t0.elapsed() < WAIT, "V+ never came back");
    }
    // The servo lost its supply with V+: the pen fell on the paper at home,
    // and rose when V+ came back. That leaves a dot.
    let t0 = Instant::now();
    while !control(&sock, "status").contains(" pen=up ") {
        assert!(t0.elapsed() < WAIT, "the pen never rose again");
        std::thread::sleep(Duration::from_millis(10));
    }
    assert!(control(&sock, "status").starts_with("ok state=idle"), "{}", control(&sock, "status"));
    assert!(control(&sock, "lever up").starts_with("error: an EBB has no paper lever"));
    nix::sys::signal::kill(nix::unistd::Pid::from_raw(child.0.id() as i32), nix::sys::signal::Signal::SIGTERM).unwrap();
    assert!(child.0.wait().unwrap().success());
    let saved: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(saved["personality"], "ebb");
    assert_eq!(saved["strokes"].as_array().unwrap().len(), 2);
    let square: Vec<[f64; 2]> = serde_json::from_value(saved["strokes"][0]["points"].clone()).unwrap();
    assert_eq!(square, [[10.0, -10.0], [30.0, -10.0], [30.0, -30.0], [10.0, -30.0], [10.0, -10.0]]);
    let dot: Vec<[f64; 2]> = serde_json::from_value(saved["strokes"][1]["points"].clone()).unwrap();
    assert_eq!(dot, [[0.0, 0.0], [0.0, 0.0]]);
    assert_eq!(saved["limits"], serde_json::json!([0.0, -218.0, 300.0, 0.0]), "an AxiDraw V3's travel below its home corner");
    assert!(std::fs::read_to_string(&svg).unwrap().contains("<polyline"));
    std::fs::remove_dir_all(&dir).ok();
}
