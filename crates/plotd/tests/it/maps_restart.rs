//! The files a scene names travel with the job and live in the spool: an
//! animated map submitted by the client code path, the daemon SIGKILLed
//! during a paper change and started again, the user's copies deleted; on
//! `resume` it renders the remaining frames from the spooled attachments
//! and every frame is drawn once, in order.

use crate::child;

use child::Setup;
use plotd::protocol::State;
use plotd_e2e::{assert_plotted, frames_for, repo_root, strokes_of, DaemonHandle};
use plotsim::SimConfig;
use std::time::Duration;

const LONG: Duration = Duration::from_secs(120);

#[test]
fn attachments_survive_a_daemon_restart() {
    let setup = Setup::new(SimConfig::hp7475a().with_speed_scale(0.0).with_baud(0), "hp7475a", "escb", "");
    let work = tempfile::tempdir().unwrap();
    std::fs::create_dir(work.path().join("map")).unwrap();
    for f in ["westmark.geojson", "towns.csv"] {
        std::fs::copy(repo_root().join("examples/map").join(f), work.path().join("map").join(f)).unwrap();
    }
    let path = work.path().join("movie.toml");
    std::fs::write(
        &path,
        "[camera]\neye = [-9.0, -17.0, 10.0]\ntarget = [0.0, 0.0, 1.0]\nfov_deg = 32.0\nframe = \"fov\"\n\
         [[map]]\noutline = \"map/westmark.geojson\"\nprojection = \"mercator\"\noffset = [-15.0, -55.7]\n\
         [[symbols]]\ndata = \"map/towns.csv\"\nshape = \"box\"\nsize = 0.5\nheight_scale = 0.01\n\
         [[labels]]\nplacement = \"ground\"\n\
         [animation]\nframes = 3\nfrom = \"pop1970\"\nto = \"pop2000\"\n\
         [[animation.camera]]\nframe = 2\neye = [12.0, -15.0, 6.0]\n",
    )
    .unwrap();
    let frames: Vec<_> = frames_for(&path, "hp7475a").iter().map(|t| strokes_of(t, "hp7475a")).collect();

    let mut d = setup.start();
    let job = plotd::client::read_job_file(&path, None).unwrap();
    let id = d.client().submit_job(job, None, "movie.toml").unwrap();
    let j = d.wait_state(id, State::Paused, LONG);
    assert_eq!((j.state, j.load_page), (State::Paused, Some(1)), "{:?}", j.reason);
    setup.sim.wait_idle(LONG).unwrap();
    d.kill();
    drop(work);

    let d = setup.start();
    assert_eq!(d.job(id).state, State::Paused);
    for page in 1..3 {
        d.resume(id);
        if page < 2 {
            let j = d.wait_state(id, State::Paused, LONG);
            assert_eq!((j.state, j.load_page), (State::Paused, Some(2)), "{:?}", j.reason);
        }
    }
    d.wait_state(id, State::Done, LONG);
    setup.sim.wait_idle(LONG).unwrap();
    assert_plotted(&setup.sim, &frames.concat(), 0);
}
