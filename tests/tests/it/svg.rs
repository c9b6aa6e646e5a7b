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
