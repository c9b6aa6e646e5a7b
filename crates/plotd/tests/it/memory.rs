//! Memory comes back after large jobs (issue 20, defect 5): six 12 MB jobs
//! submitted at once and cancelled leave the daemon (a child process, its
//! resident memory read from `/proc`) within a few megabytes of where it
//! started. (Seen before: 2.1 GB held after six 16 MiB submits, from the
//! checks run in the daemon's process and from freed blocks the allocator
//! kept.)

use crate::child;

use child::Setup;
use plotd::client::Client;
use plotd::protocol::{LinkState, Reply, Request};
use plotd::spool::JobKind;
use plotd_e2e::{wait_for, DaemonHandle};
use std::time::{Duration, Instant};

/// Resident growth allowed after the jobs are gone, kB.
const SLACK_KB: u64 = 48 * 1024;

/// About `bytes` of G-code drawing short strokes.
fn gcode(bytes: usize, seed: usize) -> String {
    let mut t = String::from("G21 G90\nM5\n");
    let mut k = seed;
    while t.len() < bytes {
        let (x, y) = ((k * 37) % 180, (k * 53) % 120);
        t += &format!("G0 X{x}.5 Y{y}.25\nM3 S1000\nG1 X{}.75 Y{}.125 F3000\nM5\n", x + 10, y + 5);
        k += 1;
    }
    t
}

#[test]
fn memory_comes_back_after_six_large_submits() {
    // A GRBL board that is never plugged in: the jobs wait in the queue.
    let offline =
        "[[plotter]]\nname = \"cnc\"\nport = \"/nonexistent/tty\"\nbaud = 115200\ndevice = \"grbl-servo\"\nhandshake = \"grbl\"\n";
    let setup = Setup::hp_escb(offline);
    let d = setup.start();
    // At rest: the plotter's port open and set up, the other one found missing.
    wait_for("both plotters' links known", Duration::from_secs(30), || {
        let Ok(Reply::Status { plotters, .. }) = d.client().call(&Request::Status {}) else { return false };
        plotters.iter().map(|p| p.link).eq([LinkState::Online, LinkState::Offline])
    });
    let before = d.rss_kb();
    let ids: Vec<u64> = std::thread::scope(|s| {
        let hs: Vec<_> = (0..6)
            .map(|i| {
                let socket = setup.socket.clone();
                s.spawn(move || {
                    Client::connect(&socket).unwrap().submit(JobKind::Gcode, Some("cnc"), "big.gcode", gcode(12 << 20, i)).unwrap()
                })
            })
            .collect();
        hs.into_iter().map(|h| h.join().unwrap()).collect()
    });
    let mut c = Client::connect(&setup.socket).unwrap();
    let peak = d.rss_kb();
    for id in &ids {
        assert!(matches!(c.call(&Request::Cancel { id: *id, now: false }).unwrap(), Reply::Ok { .. }));
    }
    drop(c);
    // Nothing tells when freed memory has gone back to the kernel: read it
    // until it has, or until a deadline.
    let mut after = d.rss_kb();
    let end = Instant::now() + Duration::from_secs(10);
    while after > before + SLACK_KB && Instant::now() < end {
        std::thread::sleep(Duration::from_millis(50));
        after = d.rss_kb();
    }
    eprintln!("plotd resident memory: {before} kB at rest, {peak} kB after six 12 MB submits, {after} kB once they were cancelled");
    assert!(after <= before + SLACK_KB, "plotd kept {} kB after the jobs were gone", after - before);
}
