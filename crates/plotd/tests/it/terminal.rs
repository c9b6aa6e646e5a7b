//! `plotd` at the terminal and in pipes, as users and scripts meet it: a
//! reader that goes away (`plotd watch | head -1`), logs that are not a
//! terminal (no colour codes), `submit --follow` without a terminal (plain
//! progress lines that count the job's strokes exactly), error messages in
//! the user's words, and the generated completions and man page.

use crate::child;

use child::Setup;
use plotd_e2e::{hpgl_lines, strokes_of, DaemonHandle};
use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn plotd() -> Command {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_plotd"));
    cmd.env_remove("PLOTD_SOCKET").env_remove("RUST_LOG");
    cmd
}

#[test]
fn watch_into_a_pipe_its_reader_closed_exits_0() {
    let setup = Setup::hp_escb("");
    let d = setup.start();
    // Online first: watchers hear the plotter come online too, and the
    // line read is to be the job's.
    d.wait_online(Duration::from_secs(60));
    // `plotd watch | head -1`: the reader takes one line and goes.
    let mut watch = plotd().arg("watch").arg("--socket").arg(&setup.socket).stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().unwrap();
    let job = setup.dir.path().join("a.hpgl");
    std::fs::write(&job, hpgl_lines(30, 1)).unwrap();
    let o = plotd().args(["submit", "--socket"]).arg(&setup.socket).arg(&job).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mut first = String::new();
    BufReader::new(watch.stdout.take().unwrap()).read_line(&mut first).unwrap();
    assert!(first.starts_with("{\"job\":1"), "{first}");
    // The pipe's read end is closed now; the next event written hits EPIPE.
    let end = Instant::now() + Duration::from_secs(60);
    let status = loop {
        if let Some(s) = watch.try_wait().unwrap() {
            break s;
        }
        assert!(Instant::now() < end, "watch still running after its reader left");
        std::thread::sleep(Duration::from_millis(20));
    };
    let mut stderr = String::new();
    std::io::Read::read_to_string(&mut watch.stderr.take().unwrap(), &mut stderr).unwrap();
    assert_eq!(status.code(), Some(0), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
}

#[test]
fn follow_without_a_terminal_prints_progress_lines_counting_strokes_exactly() {
    let setup = Setup::hp_escb("");
    let _d = setup.start();
    let text = hpgl_lines(150, 2);
    let strokes = strokes_of(&text, "hp7475a").len();
    assert_eq!(strokes, 150);
    let job = setup.dir.path().join("b.hpgl");
    std::fs::write(&job, &text).unwrap();
    let o = plotd().args(["submit", "--follow", "--socket"]).arg(&setup.socket).arg(&job).output().unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{stderr}");
    // A line per progress step (at most one per 2 s), not silence until the end.
    let lines: Vec<&str> = stderr.lines().collect();
    assert!(lines.len() >= 2, "{stderr}");
    assert!(lines.iter().all(|l| l.starts_with("job 1: ")), "{stderr}");
    assert!(lines.iter().any(|l| l.contains(", plotting")), "{stderr}");
    // Counted in the job's strokes, exactly; the last line says it is done.
    let last = lines.last().unwrap();
    assert!(last.starts_with(&format!("job 1: {strokes}/{strokes} strokes, done")), "{stderr}");
    for l in &lines {
        let total: usize = l.split('/').nth(1).and_then(|s| s.split(' ').next()).and_then(|s| s.parse().ok()).unwrap_or(strokes);
        assert_eq!(total, strokes, "{l}");
    }
    assert!(!stderr.contains('\x1b'), "escape codes in a pipe: {stderr:?}");
}

#[test]
fn logs_that_are_not_a_terminal_carry_no_colour_codes() {
    let dir = tempfile::tempdir().unwrap();
    // An animated scene rendered to one file warns that it draws frame 0 only.
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/surface_orbit.toml");
    let o = plotd().arg("render").arg(&scene).arg("-o").arg(dir.path().join("o.svg")).output().unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    assert!(stderr.contains("WARN") && stderr.contains("frame 0 only"), "{stderr}");
    assert!(!stderr.contains('\x1b'), "escape codes in a log: {stderr:?}");
}

#[test]
fn errors_name_languages_not_type_names() {
    let dir = tempfile::tempdir().unwrap();
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/cube.toml");
    let o = plotd().arg("render").arg(&scene).arg("-o").arg(dir.path().join("c.gcode")).args(["--device", "hp7475a"]).output().unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr.contains("device hp7475a speaks HP-GL, but the file is G-code"), "{stderr}");
}

#[test]
fn completions_complete_subcommands_in_bash() {
    let o = plotd().args(["completions", "bash"]).output().unwrap();
    assert!(o.status.success());
    let script = String::from_utf8(o.stdout).unwrap();
    // bash itself, asked to complete `plotd su` and `plotd completions z`.
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("plotd.bash"), &script).unwrap();
    let complete = |words: &str| {
        let cmd = format!(
            "source {}; COMP_WORDS=({words}); COMP_CWORD=$((${{#COMP_WORDS[@]}} - 1)); COMP_LINE=\"{words}\"; COMP_POINT=${{#COMP_LINE}}; _plotd plotd \"${{COMP_WORDS[-1]}}\" \"${{COMP_WORDS[-2]}}\"; printf '%s\\n' \"${{COMPREPLY[@]}}\"",
            dir.path().join("plotd.bash").display()
        );
        let o = Command::new("bash").args(["-c", &cmd]).output().unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        String::from_utf8(o.stdout).unwrap()
    };
    assert_eq!(complete("plotd su").trim(), "submit");
    let shells = complete("plotd completions ''");
    assert!(["bash", "zsh", "fish"].iter().all(|s| shells.lines().any(|l| l == *s)), "{shells}");
    for (shell, marker) in [("zsh", "#compdef plotd"), ("fish", "complete -c plotd")] {
        let o = plotd().args(["completions", shell]).output().unwrap();
        let script = String::from_utf8(o.stdout).unwrap();
        assert!(o.status.success() && script.contains(marker) && script.contains("submit"), "{shell}: {script}");
    }
}

#[test]
fn the_man_page_documents_every_subcommand_and_formats() {
    let o = plotd().arg("man").output().unwrap();
    assert!(o.status.success());
    let page = String::from_utf8(o.stdout).unwrap();
    assert!(page.starts_with(".ie \\n(.g .ds Aq") || page.contains(".TH plotd 1"), "{}", &page[..200.min(page.len())]);
    for sub in ["render", "demo", "serve", "submit", "watch", "completions"] {
        assert!(page.contains(&format!(".SS \"plotd {sub}\"")), "no section for {sub}");
    }
    // groff reads it without a warning and shows the options' text.
    if !plotd_e2e::present_or_skip(
        "the_man_page_documents_every_subcommand_and_formats (groff's reading)",
        plotd_e2e::program_missing("groff", "groff-base"),
    ) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("plotd.1");
    std::fs::write(&file, &page).unwrap();
    let o = Command::new("groff").args(["-man", "-Tutf8", "-ww", "-z"]).arg(&file).output().unwrap();
    assert!(o.status.success() && o.stderr.is_empty(), "groff: {}", String::from_utf8_lossy(&o.stderr));
    let o = Command::new("groff").args(["-man", "-Tascii"]).arg(&file).output().unwrap();
    // Bold and underline come as overstrikes (`c\x08c`): keep the last of each.
    let plain = String::from_utf8_lossy(&o.stdout).replace("_\x08", "");
    let plain: String = plain.chars().collect::<Vec<_>>().windows(2).filter(|w| w[1] != '\x08' && w[0] != '\x08').map(|w| w[0]).collect();
    let text = plain.split_whitespace().collect::<Vec<_>>().join(" ");
    assert!(text.contains("plotd render [OPTIONS] --output <OUTPUT> <SCENE>"), "{text}");
    assert!(text.contains("-o, --output Output file; its extension picks the format"), "{text}");
}
