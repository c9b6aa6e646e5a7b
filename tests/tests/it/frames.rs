//! An animated scene submitted to the daemon: its frames are plotted as
//! consecutive pages, with a pause for new paper before each frame after the
//! first ("load paper for frame k of N", continued by `resume`).

use plotd::protocol::{Request, State};
use plotd::spool::{JobKind, PauseCause};
use plotd_e2e::{assert_drawn_once, assert_plotted, recorded, repo_root, strokes_of, DaemonHandle, Rig};
use plotsim::SimConfig;
use std::time::Duration;

const LONG: Duration = Duration::from_secs(120);

#[test]
fn animated_scene_plots_one_page_per_frame_with_a_paper_pause_between() {
    let rig = Rig::start(SimConfig::hp7475a().with_speed_scale(0.0).with_baud(0), "hp7475a", "escb", "");
    let path = repo_root().join("examples/surface_orbit.toml");
    let scene = scene::Scene::load(&path).unwrap();
    let n = scene.frame_count();
    assert!(n > 2);
    // Each frame as its own single render for the device.
    let profile = plotcode::DeviceProfile::builtin("hp7475a").unwrap();
    let frames: Vec<_> = (0..n)
        .map(|i| {
            let drawing = plotd::pipeline::plotted_drawing(scene.frame(i).unwrap()).unwrap();
            strokes_of(&plotcode::emit(&drawing, &profile, &plotcode::EmitOptions::default()).unwrap().text, "hp7475a")
        })
        .collect();
    assert_ne!(frames[0], frames[n - 1], "the camera moves");

    let id = rig.submit(JobKind::Scene, &std::fs::read_to_string(&path).unwrap());
    for k in 1..n {
        let j = rig.wait_state(id, State::Paused, LONG);
        let reason = format!("load paper for frame {} of {n}", k + 1);
        assert_eq!((j.cause, j.reason, j.insert_pen, j.load_page), (Some(PauseCause::Load), Some(reason), None, Some(k)));
        let st = rig.sim.wait_idle(LONG).unwrap();
        assert!(!st.device.pen_down, "pen left down for the paper change");
        // Frames 0..k drawn, each exactly once, and nothing of frame k yet.
        let want: Vec<_> = frames[..k].concat();
        assert_drawn_once(&recorded(&rig.sim), &want, 0);
        assert_eq!(rig.job(id).state, State::Paused);
        assert_eq!(rig.sim.status().bytes_received, st.bytes_received, "bytes sent while paused");
        // A new pen is not new paper.
        assert!(rig.client().call(&Request::PenChanged { plotter: None }).is_err());
        rig.resume(id);
    }
    let j = rig.wait_state(id, State::Done, LONG);
    assert_eq!(j.page_loaded, n - 1);
    rig.sim.wait_idle(LONG).unwrap();
    assert_plotted(&rig.sim, &frames.concat(), 0);
}
