//! SVG jobs: the daemon reads the drawing, chains, orders and emits it as
//! `plotd render drawing.svg -o out.hpgl` does, so the plot equals the dry run.

use clap::Parser;
use plotd::protocol::State;
use plotd::spool::JobKind;
use plotd_e2e::{assert_drawn_once, recorded, strokes_of, DaemonHandle, Rig};
use plotsim::SimConfig;
use std::time::Duration;

const LONG: Duration = Duration::from_secs(120);

/// Two colours (two pens), straight and curved paths, shapes, a transform.
const DRAWING: &str = r##"<svg xmlns="http://www.w3.org/2000/svg" width="200mm" height="150mm" viewBox="0 0 200 150">
  <path d="M10 10 L60 10 L60 50" fill="none" stroke="#000"/>
  <path d="M70 20 C90 0 110 40 130 20" fill="none" stroke="#000"/>
  <g transform="translate(20 80) rotate(15)">
    <rect x="0" y="0" width="40" height="25" fill="none" stroke="#c00"/>
    <circle cx="90" cy="10" r="15" fill="none" stroke="#c00"/>
  </g>
  <polyline points="150,120 170,100 190,120" fill="none" stroke="#000"/>
  <line x1="60" y1="50" x2="100" y2="60" stroke="#000"/>
</svg>
"##;

#[test]
fn svg_job_draws_exactly_the_dry_run() {
    let rig = Rig::start(SimConfig::hp7475a().with_speed_scale(0.0).with_baud(0), "hp7475a", "escb", "");
    let svg = rig.dir.path().join("drawing.svg");
    let dry = rig.dir.path().join("dry.hpgl");
    std::fs::write(&svg, DRAWING).unwrap();
    let cli =
        plotd::cli::Cli::try_parse_from(["plotd".as_ref(), "render".as_ref(), svg.as_os_str(), "-o".as_ref(), dry.as_os_str()]).unwrap();
    assert_eq!(cli.run().unwrap(), 0);
    let want = strokes_of(&std::fs::read_to_string(&dry).unwrap(), "hp7475a");
    assert!(want.len() >= 4 && want.iter().any(|s| s.0 == 2), "the drawing has strokes in two pens: {want:?}");

    let id = rig.submit(JobKind::Svg, DRAWING);
    rig.wait_state(id, State::Done, LONG);
    rig.sim.wait_idle(LONG).unwrap();
    assert_drawn_once(&recorded(&rig.sim), &want, 0);
    assert_eq!(rig.sim.record().overruns, 0);

    // A broken SVG is refused at submission, saying why, and queues nothing.
    let e = rig.client().submit(JobKind::Svg, None, "bad.svg", "<svg><path d=".into()).unwrap_err();
    assert!(e.to_string().contains("SVG"), "{e}");
    assert_eq!(rig.client().jobs().unwrap().len(), 1);
}

/// A line crossed by a filled square drawn after it: with `--occult` the
/// square hides the line's middle.
const COVERED: &str = r##"<svg xmlns="http://www.w3.org/2000/svg" width="200mm" height="150mm" viewBox="0 0 200 150">
  <path d="M10 75 L190 75" fill="none" stroke="#000"/>
  <rect x="80" y="50" width="40" height="50" fill="#fff" stroke="#000"/>
</svg>
"##;

fn length(strokes: &[(u32, Vec<[f64; 2]>)]) -> f64 {
    strokes.iter().flat_map(|(_, s)| s.windows(2)).map(|w| (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1])).sum()
}

/// `submit --occult` plots what `render --occult` writes: the square's fill
/// hides the 40 mm of the line under it (before: the socket refused the
/// field, and the daemon drew SVG jobs as they were). Occlusion is for SVG
/// drawings only: any other job asking for it is refused, saying why.
#[test]
fn an_svg_submitted_with_occult_plots_its_occulted_dry_run() {
    let rig = Rig::start(SimConfig::hp7475a().with_speed_scale(0.0).with_baud(0), "hp7475a", "escb", "");
    let svg = rig.dir.path().join("covered.svg");
    std::fs::write(&svg, COVERED).unwrap();
    let dry_run = |flags: &[&str]| {
        let dry = rig.dir.path().join("dry.hpgl");
        let mut args = vec!["plotd".as_ref(), "render".as_ref(), svg.as_os_str(), "-o".as_ref(), dry.as_os_str()];
        args.extend(flags.iter().map(std::ffi::OsStr::new));
        assert_eq!(plotd::cli::Cli::try_parse_from(args).unwrap().run().unwrap(), 0);
        strokes_of(&std::fs::read_to_string(&dry).unwrap(), "hp7475a")
    };
    let (plain, occulted) = (dry_run(&[]), dry_run(&["--occult"]));
    // HP-GL plotter units: 40 to the millimetre.
    let hidden = (length(&plain) - length(&occulted)) / 40.0;
    assert!((hidden - 40.0).abs() < 0.5, "the fill hides 40 mm of the line, not {hidden:.2} mm");

    let placing = plotd::client::Placing { occult: Some(plotd::spool::Occult::Layer), ..Default::default() };
    let job = plotd::client::JobFile { kind: JobKind::Svg, content: COVERED.into(), files: Default::default() };
    let id = rig.client().submit_job(job, &placing, "covered.svg").unwrap();
    rig.wait_state(id, State::Done, LONG);
    rig.sim.wait_idle(LONG).unwrap();
    assert_drawn_once(&recorded(&rig.sim), &occulted, 0);

    let job = plotd::client::JobFile { kind: JobKind::Hpgl, content: "IN;SP1;PA0,0;PD100,0;PU;".into(), files: Default::default() };
    let e = rig.client().submit_job(job, &placing, "line.hpgl").unwrap_err().to_string();
    assert!(e.contains("occult: only an SVG drawing's filled shapes hide lines"), "{e}");
}
