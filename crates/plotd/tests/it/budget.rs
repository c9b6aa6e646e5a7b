//! Renders under a budget (issue 20, defects 3 and 5): every job is checked
//! and rendered by `plotd job-worker`, a child of the daemon with limits of
//! time and memory. A render past its budget fails the job and the daemon
//! goes on; `cancel` and SIGTERM stop a render at once; a failed job stays
//! failed after a restart; a scene asking for more work than the limits
//! allow is refused at submit, naming the limit.

use crate::child;

use child::Setup;
use plotd::client::Client;
use plotd::protocol::{Reply, Request, State};
use plotd::spool::JobKind;
use plotd_e2e::DaemonHandle;
use std::time::{Duration, Instant};

const LONG: Duration = Duration::from_secs(60);

/// A surface beside a polyline: not the grid engine's, so `n` x `n` cells
/// give the general engine `2 n^2` faces, seconds of work for a few hundred.
fn heavy_scene(n: usize) -> String {
    format!(
        "[camera]\neye = [6.0, -8.0, 5.0]\ntarget = [0.0, 0.0, 0.0]\nfov_deg = 30.0\n\
         [[surface]]\nz = \"sin(3*x) * cos(3*y)\"\nx = {{ from = -2.0, to = 2.0, steps = {n} }}\ny = {{ from = -2.0, to = 2.0, steps = {n} }}\n\
         [[polyline]]\npoints = [[-2.0, -2.0, 1.5], [2.0, 2.0, 1.5]]\n"
    )
}

fn reason(job: &plotd::protocol::JobInfo) -> &str {
    job.reason.as_deref().unwrap_or_default()
}

/// Waits until the daemon has no child process (no worker left running).
fn no_worker(d: &child::Daemon) {
    let end = Instant::now() + Duration::from_secs(10);
    while !d.children().is_empty() {
        assert!(Instant::now() < end, "a job worker is still running: {:?}", d.children());
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// Waits for the job worker: the state says "rendering" a moment before the
/// child is spawned, a moment a loaded machine stretches.
fn a_worker(d: &child::Daemon) {
    let end = Instant::now() + Duration::from_secs(10);
    while d.children().is_empty() {
        assert!(Instant::now() < end, "the render runs in a worker");
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[test]
fn a_render_past_its_time_fails_alone_and_stays_failed_after_a_restart() {
    let setup = Setup::hp_escb("");
    setup.top_level("render_seconds = 1.0");
    let mut d = setup.start();
    let slow = d.submit(JobKind::Scene, &heavy_scene(700));
    let job = d.wait_state(slow, State::Failed, LONG);
    assert!(reason(&job).contains("budget of 1 s"), "{:?}", job.state);
    no_worker(&d);
    // The daemon goes on with the next job.
    let next = d.submit(JobKind::Hpgl, "IN;SP1;PU0,0;PD100,100;PU;");
    d.wait_state(next, State::Done, LONG);
    // Failed for good: a restart does not render it again, nor touch its
    // record. Once a job submitted after the restart is done, the daemon
    // has been through its queue.
    let record = setup.dir.path().join(format!("spool/jobs/{slow}.json"));
    let stamp = |p: &std::path::Path| {
        let m = std::fs::metadata(p).unwrap();
        (std::os::unix::fs::MetadataExt::ino(&m), m.modified().unwrap())
    };
    let saved = stamp(&record);
    d.terminate(LONG);
    let d = setup.start();
    let after = d.submit(JobKind::Hpgl, "IN;SP1;PU0,0;PD100,100;PU;");
    d.wait_state(after, State::Done, LONG);
    assert_eq!(d.job(slow).state, State::Failed);
    assert_eq!(stamp(&record), saved, "the failed job's record was written again");
    assert!(d.children().is_empty());
}

#[test]
fn a_render_past_its_memory_fails_alone() {
    let setup = Setup::hp_escb("");
    setup.top_level("render_memory_mb = 400");
    let d = setup.start();
    // 3.9 million faces for the general engine: under the work limit, far over 400 MiB.
    let big = d.submit(JobKind::Scene, &heavy_scene(1400));
    let job = d.wait_state(big, State::Failed, Duration::from_secs(120));
    assert!(reason(&job).contains("budget of 400 MiB"), "{:?}", job.state);
    no_worker(&d);
    assert!(d.client().jobs().is_ok());
}

#[test]
fn cancel_and_sigterm_stop_a_render_at_once() {
    let setup = Setup::hp_escb("");
    let mut d = setup.start();
    let a = d.submit(JobKind::Scene, &heavy_scene(600));
    d.wait_state(a, State::Rendering, LONG);
    a_worker(&d);
    let asked = Instant::now();
    let Reply::Ok { .. } = d.client().call(&Request::Cancel { id: a, now: false }).unwrap() else { panic!("cancel refused") };
    d.wait_state(a, State::Cancelled, Duration::from_secs(5));
    eprintln!("cancelled in {:?}", asked.elapsed());
    no_worker(&d);

    let b = d.submit(JobKind::Scene, &heavy_scene(600));
    d.wait_state(b, State::Rendering, LONG);
    let asked = Instant::now();
    assert!(d.terminate(Duration::from_secs(5)).success());
    eprintln!("stopped in {:?}", asked.elapsed());
    // Nothing was drawn: it waits in the queue for the next start.
    let rec: plotd::spool::JobRecord =
        serde_json::from_slice(&std::fs::read(setup.dir.path().join(format!("spool/jobs/{b}.json"))).unwrap()).unwrap();
    assert_eq!(rec.state.name(), "queued");
}

#[test]
fn work_beyond_the_limits_is_refused_at_submit() {
    let setup = Setup::hp_escb("");
    let d = setup.start();
    let mut c = Client::connect(&setup.socket).unwrap();
    // 3000 x 3000 cells beside a polyline: 18 million faces for the general engine.
    let e = c.submit(JobKind::Scene, None, "big.toml", heavy_scene(3000)).unwrap_err().to_string();
    assert!(e.contains("faces for the general hidden-line engine") && e.contains("limit"), "{e}");
    // A million frames of a small map.
    let dir = tempfile::tempdir().unwrap();
    let examples = plotd_e2e::repo_root().join("examples");
    std::fs::create_dir(dir.path().join("map")).unwrap();
    for f in ["westmark.geojson", "towns.csv"] {
        std::fs::copy(examples.join("map").join(f), dir.path().join("map").join(f)).unwrap();
    }
    let movie = std::fs::read_to_string(examples.join("map_movie.toml"))
        .unwrap()
        .replace("frames = 48", "frames = 1000000")
        .replace("frame = 47", "frame = 999999");
    let path = dir.path().join("movie.toml");
    std::fs::write(&path, movie).unwrap();
    let job = plotd::client::read_job_file(&path, None).unwrap();
    let e = c.submit_job(job, None, "movie.toml").unwrap_err().to_string();
    assert!(e.contains("1000000 frames"), "{e}");
    assert!(c.jobs().unwrap().is_empty());
    drop(d);
}

/// `plotd render FLAGS.. SCENE -o OUT`, run to its end.
fn render(flags: &[&str], scene: &std::path::Path, out: &std::path::Path) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_plotd")).arg("render").args(flags).arg(scene).arg("-o").arg(out).output().unwrap()
}

#[test]
fn plotd_render_stops_at_its_budget_with_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("heavy.toml");
    std::fs::write(&scene, heavy_scene(700)).unwrap();
    let out = dir.path().join("heavy.svg");
    let started = Instant::now();
    let o = render(&["--time-limit", "1"], &scene, &out);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("render stopped: it took longer than its budget of 1 s"), "{stderr}");
    assert!(started.elapsed() < Duration::from_secs(30), "{:?}", started.elapsed());
    assert!(!out.exists());
    // Within its budget the same command renders as before.
    std::fs::write(&scene, heavy_scene(20)).unwrap();
    let o = render(&[], &scene, &out);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stderr).contains("visible length"));
}

#[test]
fn a_budget_out_of_range_is_a_clear_error_not_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("small.toml");
    std::fs::write(&scene, heavy_scene(5)).unwrap();
    let out = dir.path().join("small.svg");
    // 16 MiB was the documented minimum, and ended in a panic of the
    // render's thread pool reported as "the renderer crashed" (issue 40).
    for (flag, value) in
        [("--time-limit", "1e20"), ("--time-limit", "inf"), ("--time-limit", "0"), ("--memory-limit", "8"), ("--memory-limit", "16")]
    {
        let o = render(&[flag, value], &scene, &out);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{flag} {value}: {stderr}");
        assert!(!stderr.contains("panicked"), "{flag} {value}: {stderr}");
        assert!(stderr.contains(flag), "{flag} {value}: {stderr}");
        assert!(!out.exists());
    }
    // At the minimum a small scene renders, under its budget.
    let o = render(&["--memory-limit", "64"], &scene, &out);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stderr).contains("visible length"));
}
