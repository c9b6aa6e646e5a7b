//! An animated map submitted the way `plotd submit` does it: the client loads
//! the scene, attaches every file it names (outline, places), and the daemon
//! renders from those attachments alone. Frames plot as pages with a paper
//! pause between them, each equal to `plotd render`'s frame.

use plotd::protocol::State;
use plotd::spool::{JobKind, PauseCause};
use plotd_e2e::{assert_drawn_once, assert_plotted, frames_for, recorded, repo_root, strokes_of, DaemonHandle, Rig};
use plotsim::SimConfig;
use std::path::{Path, PathBuf};
use std::time::Duration;

const LONG: Duration = Duration::from_secs(120);

/// An animated map (outline, places, labels, moving camera) in a fresh
/// directory, its data files in a subdirectory as `examples/` has them.
fn animated_map(dir: &Path, frames: usize) -> PathBuf {
    std::fs::create_dir_all(dir.join("map")).unwrap();
    for f in ["westmark.geojson", "towns.csv"] {
        std::fs::copy(repo_root().join("examples/map").join(f), dir.join("map").join(f)).unwrap();
    }
    let last = frames - 1;
    let text = format!(
        "[camera]\neye = [-9.0, -17.0, 10.0]\ntarget = [0.0, 0.0, 1.0]\nfov_deg = 32.0\nframe = \"fov\"\n\
         [[map]]\noutline = \"map/westmark.geojson\"\nprojection = \"mercator\"\noffset = [-15.0, -55.7]\n\
         [[symbols]]\ndata = \"map/towns.csv\"\nshape = \"hex_prism\"\nsize = 0.5\nheight_scale = 0.01\npen = 2\n\
         [[labels]]\nplacement = \"above\"\npen = 1\n\
         [animation]\nframes = {frames}\nfrom = \"pop1970\"\nto = \"pop2000\"\n\
         [[animation.camera]]\nframe = 0\neye = [-9.0, -17.0, 10.0]\n\
         [[animation.camera]]\nframe = {last}\neye = [12.0, -15.0, 6.0]\n"
    );
    let path = dir.join("movie.toml");
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn animated_map_submitted_with_its_files_plots_every_frame_as_a_page() {
    let rig = Rig::start(SimConfig::hp7475a().with_speed_scale(0.0).with_baud(0), "hp7475a", "escb", "");
    let work = tempfile::tempdir().unwrap();
    let path = animated_map(work.path(), 3);
    // The oracle: each frame rendered from disk, as `plotd render -o f-%04d.hpgl` does.
    let frames: Vec<_> = frames_for(&path, "hp7475a").iter().map(|t| strokes_of(t, "hp7475a")).collect();
    let n = frames.len();
    assert_ne!(frames[0], frames[n - 1], "values and camera move");

    // The client code path of `plotd submit`.
    let job = plotd::client::read_job_file(&path, None).unwrap();
    assert_eq!(job.files.keys().collect::<Vec<_>>(), ["map/towns.csv", "map/westmark.geojson"]);
    let id = rig.client().submit_job(job, None, "movie.toml").unwrap();
    // The daemon works from what it was sent, not from the user's directory.
    drop(work);

    for k in 1..n {
        let j = rig.wait_state(id, State::Paused, LONG);
        let reason = format!("load paper for frame {} of {n}", k + 1);
        assert_eq!((j.cause, j.reason, j.insert_pen, j.load_page), (Some(PauseCause::Load), Some(reason), None, Some(k)));
        rig.sim.wait_idle(LONG).unwrap();
        assert_drawn_once(&recorded(&rig.sim), &frames[..k].concat(), 0);
        rig.resume(id);
    }
    rig.wait_state(id, State::Done, LONG);
    rig.sim.wait_idle(LONG).unwrap();
    assert_plotted(&rig.sim, &frames.concat(), 0);
}

#[test]
fn a_map_scene_without_its_files_is_refused_at_submit() {
    let rig = Rig::start(SimConfig::hp7475a().with_speed_scale(0.0).with_baud(0), "hp7475a", "escb", "");
    let work = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(animated_map(work.path(), 2)).unwrap();
    // Sent bare (an old client, or a hand-written request): nothing to read.
    let e = rig.client().submit(JobKind::Scene, None, "movie.toml", text).unwrap_err().to_string();
    assert!(e.contains("map[0].outline") && e.contains("map/westmark.geojson") && e.contains("not sent with the job"), "{e}");
    assert!(rig.client().jobs().unwrap().is_empty(), "a refused job was queued");
}
