//! The load test: 50 jobs from 10 concurrent clients to the `plotd` binary
//! (a child process, so its memory can be read from `/proc`), driving plotsim
//! over a pty. All are drawn once, in id order, and the daemon's resident
//! memory stays flat from the 10th job to the 50th.

mod child;

use child::Setup;
use plotd::spool::JobKind;
use plotd_e2e::{assert_drawn_once, recorded, strokes_of, DaemonHandle};
use plotsim::SimConfig;
use std::time::Duration;

const LONG: Duration = Duration::from_secs(300);
const CLIENTS: usize = 10;
const JOBS_PER_CLIENT: usize = 5;
/// Strokes per job: about 40 kB of HP-GL, so a job that stayed in memory
/// would show against [`MAX_GROWTH_KB`].
const STROKES: usize = 1000;
/// Resident growth allowed between the 10th and the 50th job, kB: well under
/// the 40 further jobs' content (about 1.6 MB), let alone their programs.
const MAX_GROWTH_KB: u64 = 1024;

fn job(n: usize) -> String {
    let mut t = String::from("IN;SP1;");
    for k in 0..STROKES {
        let (x, y) = ((n * 97 + k * 13) % 9000, (n * 31 + k * 7) % 7000);
        t += &format!("PU{x},{y};PD{},{};", x + 50 + k % 100, y + 20);
    }
    t + "PU;"
}

#[test]
fn fifty_jobs_from_ten_clients_in_order_with_flat_memory() {
    let setup = Setup::new(SimConfig::hp7475a().with_speed_scale(0.0).with_baud(0), "hp7475a", "escb", "");
    let d = setup.start();
    let d = &d;
    let submitted: Vec<Vec<(u64, String)>> = std::thread::scope(|s| {
        let hs: Vec<_> = (0..CLIENTS)
            .map(|c| {
                s.spawn(move || {
                    let mut client = d.client();
                    (0..JOBS_PER_CLIENT)
                        .map(|k| {
                            let t = job(c * JOBS_PER_CLIENT + k);
                            (client.submit(JobKind::Hpgl, None, "load", t.clone()).unwrap(), t)
                        })
                        .collect()
                })
            })
            .collect();
        hs.into_iter().map(|h| h.join().unwrap()).collect()
    });
    let mut all: Vec<(u64, String)> = submitted.into_iter().flatten().collect();
    all.sort_by_key(|(id, _)| *id);
    assert_eq!(all.len(), CLIENTS * JOBS_PER_CLIENT);
    d.wait_state(all[9].0, "done", LONG);
    let rss_10 = d.rss_kb();
    for (id, _) in &all {
        d.wait_state(*id, "done", LONG);
    }
    let rss_50 = d.rss_kb();
    eprintln!("plotd resident memory: {rss_10} kB after 10 jobs, {rss_50} kB after 50");
    assert!(rss_50 <= rss_10 + MAX_GROWTH_KB, "plotd grew from {rss_10} kB to {rss_50} kB over 40 jobs");
    setup.sim.wait_idle(Duration::from_secs(20)).unwrap();
    // In id order on the paper.
    let want: Vec<_> = all.iter().flat_map(|(_, t)| strokes_of(t, "hp7475a")).collect();
    assert_drawn_once(&recorded(&setup.sim), &want, 0);
    assert_eq!(setup.sim.record().overruns, 0);
}
