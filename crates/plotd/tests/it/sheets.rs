//! Sheets on plotsim, through the `plotd` binary: a job after one that drew
//! waits `load-sheet` until `sheet-loaded`, also across a restart (the
//! plotter's sheet is kept in the spool); a job for the same sheet goes at
//! once.

use crate::child;

use child::Setup;
use plotd::client::JobFile;
use plotd::client::Placing;
use plotd::protocol::{Reply, Request, State};
use plotd::spool::{JobKind, PauseCause};
use plotd_e2e::{recorded, strokes_of, DaemonHandle};
use std::collections::BTreeMap;
use std::time::Duration;

const LONG: Duration = Duration::from_secs(60);
const A: &str = "IN;SP1;PU1000,1000;PD2000,1000;PU;";
const B: &str = "IN;SP1;PU1000,2000;PD2000,2000;PU;";
const C: &str = "IN;SP1;PU1000,3000;PD2000,3000;PU;";

#[test]
fn the_next_job_waits_for_a_fresh_sheet_even_after_a_restart() {
    let setup = Setup::hp_escb("");
    let mut d = setup.start();
    let a = d.client().submit(JobKind::Hpgl, None, "a.hpgl", A.into()).unwrap();
    d.wait_state(a, State::Done, LONG);
    // The daemon goes away with the drawn sheet in the plotter.
    d.kill();
    let d = setup.start();
    let b = d.client().submit(JobKind::Hpgl, None, "b.hpgl", B.into()).unwrap();
    let mut events = d.watch_job(b);
    events.until(LONG, |e| e.cause == Some(PauseCause::LoadSheet));
    let waiting = d.job(b);
    assert_eq!((waiting.state, waiting.cause), (State::Paused, Some(PauseCause::LoadSheet)), "{waiting:?}");
    assert_eq!(waiting.reason.as_deref(), Some("load a fresh sheet on plotter p, then: plotd sheet-loaded p"));
    let Reply::Status { plotters, .. } = d.client().call(&Request::Status {}).unwrap() else { panic!("status") };
    assert_eq!(plotters[0].sheet, plotd::spool::Sheet::Used);
    assert_eq!(recorded(&setup.sim), strokes_of(A, "hp7475a"), "job {b} drew on the used sheet");

    let reply = d.client().call(&Request::SheetLoaded { plotter: "p".into() }).unwrap();
    assert_eq!(reply, Reply::Ok { message: format!("resumed job(s) {b}") });
    let ends = events.until_end(LONG);
    assert_eq!(ends.last().map(|e| e.state), Some(State::Done));

    // An overlay goes at once, on the sheet job b drew on.
    let job = JobFile { kind: JobKind::Hpgl, content: C.into(), files: BTreeMap::new() };
    let c = d.client().submit_job(job, &Placing { same_sheet: true, ..Placing::default() }, "c.hpgl").unwrap();
    let events = d.watch_job(c).until_end(LONG);
    assert!(events.iter().all(|e| e.state != State::Paused), "{events:?}");
    assert_eq!(events.last().map(|e| e.state), Some(State::Done));
    let want: Vec<_> = [A, B, C].iter().flat_map(|t| strokes_of(t, "hp7475a")).collect();
    assert_eq!(recorded(&setup.sim), want);
}

/// `--copies 3`: the plotter draws the job three times, waiting for
/// `sheet-loaded` before the second and the third; each wait and the
/// job's events say which copy is next.
#[test]
fn three_copies_draw_three_times_with_a_wait_for_a_sheet_between() {
    let setup = Setup::hp_escb("");
    let d = setup.start();
    let job = JobFile { kind: JobKind::Hpgl, content: A.into(), files: BTreeMap::new() };
    let id = d.client().submit_job(job, &Placing { copies: 3, ..Placing::default() }, "a.hpgl").unwrap();
    let mut events = d.watch_job(id);
    for copy in 2..=3 {
        events.until(LONG, |e| e.cause == Some(PauseCause::LoadSheet));
        let waiting = d.job(id);
        assert_eq!((waiting.state, waiting.copy, waiting.copies), (State::Paused, copy, 3), "{waiting:?}");
        let want = format!("copy {copy} of 3: load a fresh sheet on plotter p, then: plotd sheet-loaded p");
        assert_eq!(waiting.reason.as_deref(), Some(want.as_str()));
        let drawn: Vec<_> = (1..copy).flat_map(|_| strokes_of(A, "hp7475a")).collect();
        assert_eq!(recorded(&setup.sim), drawn, "copy {} drew before its sheet was loaded", copy);
        let reply = d.client().call(&Request::SheetLoaded { plotter: "p".into() }).unwrap();
        assert_eq!(reply, Reply::Ok { message: format!("resumed job(s) {id}") });
    }
    let ends = events.until_end(LONG);
    let last = ends.last().unwrap();
    assert_eq!((last.state, last.copy, last.copies), (State::Done, 3, 3), "{ends:?}");
    let want: Vec<_> = (0..3).flat_map(|_| strokes_of(A, "hp7475a")).collect();
    assert_eq!(recorded(&setup.sim), want);
}
