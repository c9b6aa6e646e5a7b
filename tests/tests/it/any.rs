//! Jobs for any free plotter (`submit --plotter any`, or a device name):
//! two idle plotters share four jobs, both plotting at once, each drawing
//! exactly its jobs; a job none of them can draw, and a name that is no
//! plotter, device or `any`, are refused at submit saying why.

use plotd::client::{JobFile, Placing};
use plotd::protocol::{Reply, Request, State};
use plotd::spool::JobKind;
use plotd_e2e::{assert_plotted, hpgl_lines, second_plotter, strokes_of, wait_for, DaemonHandle, Rig};
use plotsim::SimConfig;
use std::collections::BTreeMap;
use std::time::Duration;

const LONG: Duration = Duration::from_secs(120);

/// Submits HP-GL `text` for `plotter` on the sheet in it.
fn submit_for(rig: &Rig, plotter: &str, text: &str) -> Result<u64, plotd::client::ClientError> {
    let job = JobFile { kind: JobKind::Hpgl, content: text.to_owned(), files: BTreeMap::new() };
    rig.client().submit_job(job, &Placing { plotter: Some(plotter), same_sheet: true, ..Placing::default() }, "test")
}

/// The plotters `status` shows running a job, by name.
fn plotting(rig: &Rig) -> Vec<String> {
    let Ok(Reply::Status { plotters, .. }) = rig.client().call(&Request::Status {}) else { return Vec::new() };
    plotters.into_iter().filter(|p| p.job.is_some()).map(|p| p.name).collect()
}

#[test]
fn two_idle_plotters_share_jobs_for_any_and_plot_at_once() {
    let links = tempfile::tempdir().unwrap();
    // Paced as the real plotter is: each job takes a few seconds.
    let hp = || SimConfig::hp7475a();
    let (second, table) = second_plotter(links.path(), "q", hp(), "hp7475a", "escb");
    let rig = Rig::start(hp(), "hp7475a", "escb", &table);
    wait_for("both plotters to answer", LONG, || {
        let Ok(Reply::Status { plotters, .. }) = rig.client().call(&Request::Status {}) else { return false };
        plotters.iter().all(|p| p.link == plotd::protocol::LinkState::Online)
    });
    let texts: Vec<String> = (0..4).map(|seed| hpgl_lines(12, seed)).collect();
    let ids: Vec<u64> = texts.iter().map(|t| submit_for(&rig, "any", t).expect("job for any accepted")).collect();
    wait_for("both plotters plotting at once", LONG, || plotting(&rig).len() == 2);
    let mut by_plotter: BTreeMap<String, Vec<usize>> = BTreeMap::new();
    for (k, &id) in ids.iter().enumerate() {
        let j = rig.wait_state(id, State::Done, LONG);
        assert_eq!(j.class.as_deref(), Some("any"), "job {id} keeps its class");
        by_plotter.entry(j.plotter).or_default().push(k);
    }
    let shares: Vec<(&str, usize)> = by_plotter.iter().map(|(p, jobs)| (p.as_str(), jobs.len())).collect();
    assert_eq!(shares, [("p", 2), ("q", 2)], "two each: {by_plotter:?}");
    for (name, sim) in [("p", &rig.sim), ("q", &second)] {
        sim.wait_idle(LONG).unwrap();
        // Each plotter drew its jobs, in the order it took them, each
        // equal to its dry run.
        let want: Vec<_> = by_plotter[name].iter().flat_map(|&k| strokes_of(&texts[k], "hp7475a")).collect();
        assert_plotted(sim, &want, 0);
    }
}

#[test]
fn a_job_no_plotter_can_draw_and_an_unknown_name_are_refused_at_submit() {
    let links = tempfile::tempdir().unwrap();
    let hp = || SimConfig::hp7475a().with_speed_scale(0.0).with_baud(0);
    let (_second, table) = second_plotter(links.path(), "q", hp(), "hp7475a", "escb");
    let rig = Rig::start(hp(), "hp7475a", "escb", &table);
    // Beyond the 7475A's largest paper.
    let far = "IN;SP1;PU40000,40000;PD40100,40000;PU;SP0;";
    for class in ["any", "hp7475a"] {
        let e = submit_for(&rig, class, far).expect_err("no plotter can draw it").to_string();
        assert!(e.contains(&format!("no plotter for {class} can draw this job")) && e.contains("p: ") && e.contains("q: "), "{e}");
        assert!(e.contains("40000"), "says why: {e}");
    }
    let e = submit_for(&rig, "hp7550a", &hpgl_lines(2, 1)).expect_err("no such plotter or device").to_string();
    assert!(e.contains("no plotter or device \"hp7550a\": name a plotter (p, q), a device of one (hp7475a), or any"), "{e}");
    assert!(rig.client().jobs().unwrap().is_empty(), "nothing was queued");
}
