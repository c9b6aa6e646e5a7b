//! A spool that cannot be written mid-job (issue 20, defect 2): the job
//! pauses with the reason, and no stroke is ever sent twice because of it;
//! a queued job can still be cancelled; no temp file is left behind. The
//! daemon is a child process whose limits are lowered while it plots
//! (`prlimit`): a file size limit makes every record write fail as a full
//! disk does; a descriptor limit is the exhaustion seen with 20,000 held
//! connections.

use crate::child;

use child::Setup;
use nix::sys::resource::Resource;
use plotd::client::Client;
use plotd::protocol::{JobInfo, Reply, Request, State};
use plotd::spool::{JobKind, JobRecord};
use plotd_e2e::{assert_drawn_once, assert_plotted, hpgl_lines, recorded, strokes_of};
use std::time::{Duration, Instant};

const LONG: Duration = Duration::from_secs(60);
const UNLIMITED: u64 = nix::libc::RLIM_INFINITY;

/// Polls job `id` on `c` (one connection, opened before any limit) until `f` holds.
fn wait_job(c: &mut Client, id: u64, what: &str, f: impl Fn(&JobInfo) -> bool) -> JobInfo {
    let end = Instant::now() + LONG;
    loop {
        let job = c.jobs().expect("jobs answered").into_iter().find(|j| j.id == id).expect("job listed");
        if f(&job) {
            return job;
        }
        assert!(Instant::now() < end, "timed out waiting for job {id} to be {what}: {job:?}");
        std::thread::sleep(Duration::from_millis(20));
    }
}

fn reason(job: &JobInfo) -> &str {
    job.reason.as_deref().unwrap_or_default()
}

/// Starts a long job, lowers `resource` to `soft` while it plots, and
/// checks the pause; then lifts it, resumes, and checks every stroke was
/// drawn once. Returns the client and the spool directory for more checks
/// while the limit holds (run by `during`).
fn pause_on_unwritable_spool(resource: Resource, soft: impl Fn(&child::Daemon) -> u64, during: impl FnOnce(&mut Client, &Setup)) {
    let setup = Setup::hp_escb("");
    let d = setup.start();
    let text = hpgl_lines(300, 3);
    let want = strokes_of(&text, "hp7475a");
    let mut c = Client::connect(&setup.socket).unwrap();
    let id = c.submit(JobKind::Hpgl, None, "long.hpgl", text.clone()).unwrap();
    wait_job(&mut c, id, "plotting past stroke 20", |j| j.checkpoint >= 20);

    let (_, hard) = d.rlimit(resource);
    d.prlimit(resource, soft(&d), hard);
    let job = wait_job(&mut c, id, "paused", |j| j.state == State::Paused);
    assert!(reason(&job).contains("spool cannot be written"), "{job:?}");
    during(&mut c, &setup);
    // Nothing was drawn twice: what the plotter has is a prefix of the job.
    setup.sim.wait_idle(LONG).unwrap();
    let drawn = recorded(&setup.sim);
    assert!(drawn.len() < want.len(), "the job ran to its end ({} strokes) instead of pausing", drawn.len());
    assert_drawn_once(&drawn, &want[..drawn.len()], 0);

    // The spool works again: resume, and the job ends with every stroke drawn once.
    d.prlimit(resource, hard, hard);
    assert!(matches!(c.call(&Request::Resume { id: Some(id), position_confirmed: false }).unwrap(), Reply::Ok { .. }));
    wait_job(&mut c, id, "done", |j| j.state == State::Done);
    setup.sim.wait_idle(LONG).unwrap();
    assert_plotted(&setup.sim, &want, 1);
    let on_disk: JobRecord =
        serde_json::from_slice(&std::fs::read(setup.dir.path().join(format!("spool/jobs/{id}.json"))).unwrap()).unwrap();
    assert_eq!((on_disk.state.name(), on_disk.checkpoint), ("done", on_disk.total.unwrap()));
}

/// Names in the spool's `jobs/` and `data/` starting with a dot: temp files left behind.
fn temp_files(setup: &Setup) -> Vec<String> {
    ["jobs", "data"]
        .iter()
        .flat_map(|sub| std::fs::read_dir(setup.dir.path().join("spool").join(sub)).unwrap())
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with('.'))
        .collect()
}

#[test]
fn records_that_cannot_be_written_pause_the_job_and_a_queued_job_can_still_be_cancelled() {
    // A record is a few hundred bytes: a 64-byte file size limit fails every save.
    pause_on_unwritable_spool(
        Resource::RLIMIT_FSIZE,
        |_| 64,
        |c, setup| {
            let queued = c.submit(JobKind::Hpgl, None, "next.hpgl", hpgl_lines(3, 9));
            // Submitting needs the spool: refused, saying why.
            let e = queued.unwrap_err().to_string();
            assert!(e.contains("cannot spool the job"), "{e}");
            assert!(temp_files(setup).is_empty(), "{:?}", temp_files(setup));
        },
    );
}

#[test]
fn a_queued_job_is_cancelled_on_a_spool_that_cannot_be_written() {
    let setup = Setup::hp_escb("");
    let d = setup.start();
    let mut c = Client::connect(&setup.socket).unwrap();
    let first = c.submit(JobKind::Hpgl, None, "long.hpgl", hpgl_lines(300, 4)).unwrap();
    let queued = c.submit(JobKind::Hpgl, None, "queued.hpgl", hpgl_lines(3, 5)).unwrap();
    wait_job(&mut c, first, "plotting", |j| j.checkpoint >= 5);
    d.prlimit(Resource::RLIMIT_FSIZE, 64, UNLIMITED);
    let Reply::Ok { message } = c.call(&Request::Cancel { id: queued, now: false }).unwrap() else { panic!("cancel refused") };
    assert!(message.contains("cancelled"), "{message}");
    assert_eq!(c.jobs().unwrap().iter().find(|j| j.id == queued).map(|j| j.state), Some(State::Cancelled));
    assert!(temp_files(&setup).is_empty(), "{:?}", temp_files(&setup));
    // The cancelled job's record is gone rather than left queued: it stays cancelled after a restart.
    assert!(!setup.dir.path().join(format!("spool/jobs/{queued}.json")).exists());
    d.prlimit(Resource::RLIMIT_FSIZE, UNLIMITED, UNLIMITED);
    c.call(&Request::Cancel { id: first, now: false }).unwrap();
}

#[test]
fn exhausted_descriptors_pause_the_job_instead_of_plotting_it_again() {
    // No descriptor left for a temp file; the client's connection is already open.
    pause_on_unwritable_spool(Resource::RLIMIT_NOFILE, child::Daemon::lowest_free_fd, |_, _| {});
}
