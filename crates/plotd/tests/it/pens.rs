//! A job's pens mapped to the plotter's at submit (`--pens`), on plotsim,
//! through the `plotd` binary: the strokes of a mapped pen are drawn with
//! the pen it maps to; a pen the plotter lacks is refused at submit,
//! naming it.

use crate::child;

use child::Setup;
use plotd::client::{JobFile, Placing};
use plotd::pen_map::PenMap;
use plotd::protocol::State;
use plotd::spool::JobKind;
use plotd_e2e::{recorded, DaemonHandle};
use std::collections::BTreeMap;
use std::time::Duration;

const LONG: Duration = Duration::from_secs(60);
/// Red lines first (pen 1), then blue (pen 2).
const SVG: &str = r#"<svg xmlns="http://www.w3.org/2000/svg" width="100mm" height="100mm" viewBox="0 0 100 100">
<path d="M10 10 L50 10" stroke="red" fill="none"/><path d="M10 50 L50 70" stroke="blue" fill="none"/></svg>"#;

fn svg() -> JobFile {
    JobFile { kind: JobKind::Svg, content: SVG.into(), files: BTreeMap::new() }
}

#[test]
fn pens_1_3_draws_the_pen_1_strokes_with_pen_3() {
    let setup = Setup::hp_escb("");
    let d = setup.start();
    let plain = d.client().submit_job(svg(), &Placing::default(), "plain.svg").unwrap();
    d.wait_state(plain, State::Done, LONG);
    let unmapped = recorded(&setup.sim);
    assert_eq!(unmapped.iter().map(|s| s.0).collect::<Vec<_>>(), [1, 2], "{unmapped:?}");

    let map = PenMap::from([(1, 3)]);
    let placing = Placing { same_sheet: true, pens: Some(&map), ..Placing::default() };
    let mapped = d.client().submit_job(svg(), &placing, "mapped.svg").unwrap();
    let job = d.wait_state(mapped, State::Done, LONG);
    assert_eq!(job.pens, map, "the job's record keeps its map");
    let want: Vec<_> =
        unmapped.iter().cloned().chain(unmapped.iter().map(|(pen, points)| (if *pen == 1 { 3 } else { *pen }, points.clone()))).collect();
    assert_eq!(recorded(&setup.sim), want);
}

#[test]
fn a_pen_the_plotter_lacks_after_mapping_is_refused_at_submit() {
    let setup = Setup::hp_escb("");
    let d = setup.start();
    let map = PenMap::from([(1, 3), (2, 7)]);
    let placing = Placing { pens: Some(&map), ..Placing::default() };
    let e = d.client().submit_job(svg(), &placing, "a.svg").unwrap_err().to_string();
    assert!(e.contains("--pens 2=7: the hp7475a has pens 1 to 6, no pen 7"), "{e}");
    // HP-GL goes to the device as written: its pens are not mapped.
    let hpgl = JobFile { kind: JobKind::Hpgl, content: "IN;SP1;PU0,0;PD100,100;PU;".into(), files: BTreeMap::new() };
    let map = PenMap::from([(1, 2)]);
    let e = d.client().submit_job(hpgl, &Placing { pens: Some(&map), ..Placing::default() }, "a.hpgl").unwrap_err().to_string();
    assert!(e.contains("HP-GL is sent as written"), "{e}");
    assert!(d.client().jobs().unwrap().is_empty(), "nothing was queued");
}
