//! Every command of README.md that needs no plotter runs, as written.
//!
//! The commands are taken from the README's `sh` blocks when this test runs,
//! so they cannot drift from what the binary does: each line starting with
//! `plotd` or `cargo run --release --` (read as `plotd`), its trailing
//! comment dropped. `render`, `completions` and `man` run in a scratch
//! directory holding the repository's `examples/` and the files the
//! examples name but do not make (`drawing.svg`, `old-plot.hpgl`,
//! `my-plotter.toml`), with the output's directory made first as a user
//! would; a redirection `> PATH` goes to a file of that name there. The
//! daemon's commands (`serve`, `submit`, `jobs`, ...) need a daemon and a
//! plotter and are tested elsewhere (`tests/tests/it/`, this binary's other modules), as is
//! `demo` (`crates/plotd/tests/it/demo.rs`: it plots for half a minute on a virtual
//! plotter); any other subcommand fails this test until it is sorted into
//! one of the two lists.

use crate::repo;
use std::path::Path;
use std::process::Command;

/// Subcommands run here.
const RUN: &[&str] = &["render", "completions", "man"];
/// Subcommands that need the daemon or run for long on a virtual plotter.
const ELSEWHERE: &[&str] = &[
    "demo",
    "serve",
    "submit",
    "jobs",
    "status",
    "pause",
    "resume",
    "cancel",
    "pen-changed",
    "sheet-loaded",
    "watch",
    "pen",
    "move",
    "jog",
    "frame",
    "home",
    "offset",
];

/// The README's command lines, as `plotd` argument lists (comment dropped).
fn readme_commands() -> Vec<String> {
    let readme = std::fs::read_to_string(repo().join("README.md")).unwrap();
    let mut in_sh = false;
    let mut out = Vec::new();
    for line in readme.lines() {
        if line.starts_with("```") {
            in_sh = line.trim() == "```sh";
            continue;
        }
        let line = line.trim();
        let command = line
            .strip_prefix("cargo run --release -- ")
            .map(|rest| format!("plotd {rest}"))
            .or_else(|| line.starts_with("plotd ").then(|| line.to_string()));
        if let (true, Some(command)) = (in_sh, command) {
            let command = command.split(" #").next().unwrap().trim().to_string();
            out.push(command);
        }
    }
    out
}

/// A small SVG with overlapping filled shapes and a title.
const DRAWING_SVG: &str = r#"<svg xmlns="http://www.w3.org/2000/svg" width="100mm" height="60mm" viewBox="0 0 100 60">
  <rect x="10" y="10" width="40" height="30" fill="white" stroke="black"/>
  <circle cx="50" cy="35" r="15" fill="white" stroke="black"/>
  <text x="50" y="56" font-size="6" text-anchor="middle">drawing</text>
</svg>"#;

#[test]
fn every_readme_command_without_a_plotter_runs() {
    let scratch = tempfile::tempdir().unwrap();
    let dir = scratch.path();
    std::os::unix::fs::symlink(repo().join("examples"), dir.join("examples")).unwrap();
    std::fs::write(dir.join("drawing.svg"), DRAWING_SVG).unwrap();
    std::fs::copy(repo().join("config/devices/hp7475a.toml"), dir.join("my-plotter.toml")).unwrap();
    let plotd = |args: &[&str]| Command::new(env!("CARGO_BIN_EXE_plotd")).args(args).current_dir(dir).output().unwrap();
    let made = plotd(&["render", "examples/lattice.toml", "-o", "old-plot.hpgl", "--device", "hp7475a"]);
    assert!(made.status.success(), "{}", String::from_utf8_lossy(&made.stderr));

    let commands = readme_commands();
    assert!(commands.len() >= 20, "the README's commands were not found: {commands:?}");
    let mut ran = 0;
    for command in &commands {
        let words: Vec<&str> = command.split_whitespace().collect();
        let sub = words[1];
        if ELSEWHERE.contains(&sub) {
            continue;
        }
        assert!(RUN.contains(&sub), "README: `{command}`: subcommand {sub} is neither run here nor listed as tested elsewhere");
        let (args, redirect) = match words.iter().position(|w| *w == ">") {
            Some(k) => (&words[1..k], words.get(k + 1).map(|p| Path::new(p).file_name().unwrap().to_owned())),
            None => (&words[1..], None),
        };
        if let Some(k) = args.iter().position(|w| *w == "-o") {
            if let Some(parent) = Path::new(args[k + 1]).parent() {
                std::fs::create_dir_all(dir.join(parent)).unwrap();
            }
        }
        let o = plotd(args);
        assert!(o.status.success(), "README: `{command}` failed: {}", String::from_utf8_lossy(&o.stderr));
        if let Some(name) = redirect {
            assert!(!o.stdout.is_empty(), "README: `{command}` printed nothing");
            std::fs::write(dir.join(name), &o.stdout).unwrap();
        }
        ran += 1;
    }
    assert!(ran >= 12, "{ran} commands ran");
    // What the conversion wrote is G-code for the pen-by-Z device.
    assert!(std::fs::read_to_string(dir.join("old-plot.gcode")).unwrap().contains("G1 Z0"));
    assert!(dir.join("frames/frame-0047.svg").exists() && dir.join("frames/orbit-03.gcode").exists());
}
