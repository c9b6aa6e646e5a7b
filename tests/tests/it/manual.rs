//! A person at the plotter (issue 38 item 2), the daemon against plotsim
//! over a real pty: the pen lowered and raised, the carriage moved and
//! stepped while the plotter is idle, a job's frame traced with the pen up,
//! each told to watchers; refused while a job plots, allowed once it is
//! paused.

use plotd::client::{ClientError, JobFile, Placing, Watched};
use plotd::protocol::{Manoeuvre, Reply, Request, State};
use plotd::spool::{JobKind, PauseCause};
use plotd_e2e::{hpgl_lines, recorded, strokes_of, DaemonHandle, Rig};
use plotsim::SimConfig;
use std::collections::BTreeMap;
use std::time::Duration;

const LONG: Duration = Duration::from_secs(60);

fn hp_rig(speed_scale: f64) -> Rig {
    Rig::start(SimConfig::hp7475a().with_speed_scale(speed_scale).with_baud(9600), "hp7475a", "escb", "")
}

fn grbl_rig() -> Rig {
    let sim = SimConfig::grbl().with_speed_scale(0.0).with_baud(115_200);
    Rig::start(sim, "grbl-servo", "grbl", "pen_change = \"ignore\"")
}

/// The device's units per millimetre on `rig`'s plotter.
fn unit_mm(rig: &Rig) -> f64 {
    plotcode::DeviceProfile::builtin(&rig.device).unwrap().unit_mm
}

fn ok(rig: &Rig, req: &Request) -> String {
    match rig.client().call(req).unwrap() {
        Reply::Ok { message } => message,
        other => panic!("{req:?}: {other:?}"),
    }
}

fn refused(rig: &Rig, req: &Request) -> String {
    match rig.client().call(req) {
        Err(ClientError::Refused(message)) => message,
        other => panic!("{req:?} was not refused: {other:?}"),
    }
}

/// Idle, the pen goes down and up where it is, the carriage to a point
/// and by a step, with the pen up: the device's own state after each
/// answer, nothing drawn, and each a plotter event for watchers.
#[test]
fn pen_move_and_jog_on_an_idle_plotter() {
    for rig in [hp_rig(0.0), grbl_rig()] {
        let u = unit_mm(&rig);
        let mut watcher = rig.client();
        watcher.watch(None).unwrap();
        let down = ok(&rig, &Request::Pen { plotter: None, down: true });
        assert_eq!(down, "pen down on plotter p");
        assert!(rig.sim.status().device.pen_down, "{}: the pen is down once the answer comes", rig.device);
        ok(&rig, &Request::Pen { plotter: Some("p".into()), down: false });
        assert!(!rig.sim.status().device.pen_down, "{}", rig.device);

        ok(&rig, &Request::Move { plotter: None, x_mm: 40.0, y_mm: 30.0 });
        let at = rig.sim.status().device.position;
        assert!((at[0] * u - 40.0).abs() <= 0.1 && (at[1] * u - 30.0).abs() <= 0.1, "{}: at {at:?}", rig.device);
        ok(&rig, &Request::Jog { plotter: None, dx_mm: -10.0, dy_mm: 5.0 });
        let at = rig.sim.status().device.position;
        assert!((at[0] * u - 30.0).abs() <= 0.1 && (at[1] * u - 35.0).abs() <= 0.1, "{}: at {at:?}", rig.device);
        assert!(!rig.sim.status().device.pen_down && recorded(&rig.sim).is_empty(), "{}: nothing drawn", rig.device);
        let e = refused(&rig, &Request::Move { plotter: None, x_mm: 5000.0, y_mm: 0.0 });
        assert!(e.contains("(5000.00, 0.00) mm is outside"), "{e}");
        let e = refused(&rig, &Request::Pen { plotter: Some("q".into()), down: true });
        assert_eq!(e, "no plotter \"q\"");

        let mut did = Vec::new();
        while did.len() < 4 {
            if let Some(Watched::Plotter(e)) = watcher.next_watched().unwrap() {
                assert_eq!(e.plotter, "p");
                did.push((e.did, e.mm));
            }
        }
        assert_eq!(
            did,
            [
                (Manoeuvre::PenDown, None),
                (Manoeuvre::PenUp, None),
                (Manoeuvre::Moved, Some([40.0, 30.0])),
                (Manoeuvre::Jogged, Some([-10.0, 5.0]))
            ]
        );
    }
}

/// A job waiting for a fresh sheet is framed: the pen goes, raised, to the
/// four corners of the box its strokes are drawn in and back to the first
/// (within 0.1 mm), and nothing is drawn.
#[test]
fn frame_goes_round_the_jobs_box_with_the_pen_up() {
    let jobs = [
        (hp_rig(0.0), JobKind::Hpgl, "IN;SP1;PU1000,1000;PD2000,1000;PU;", "IN;SP1;PU1200,800;PD2400,1000,2000,1600;PU;PA0,0;SP0;"),
        (
            grbl_rig(),
            JobKind::Gcode,
            "G21 G90\nM5\nG0 X10 Y10\nM3 S1000\nG1 X20 Y10 F3000\nM5\n",
            "G21 G90\nM5\nG0 X20 Y30\nM3 S1000\nG1 X60 Y30 F3000\nG1 X50 Y45\nM5\nG0 X0 Y0\n",
        ),
    ];
    for (rig, kind, first, framed) in jobs {
        let a = rig.submit(kind, first);
        rig.wait_state(a, State::Done, LONG);
        let job = JobFile { kind, content: framed.into(), files: BTreeMap::new() };
        let b = rig.client().submit_job(job, &Placing::default(), "b").unwrap();
        let waiting = rig.wait_state(b, State::Paused, LONG);
        assert_eq!(waiting.cause, Some(PauseCause::LoadSheet));
        rig.sim.wait_idle(LONG).unwrap();
        let (drawn, travelled) = (recorded(&rig.sim), rig.sim.record().travel.len());

        let message = ok(&rig, &Request::Frame { id: b });
        assert!(message.starts_with(&format!("traced job {b}'s frame on plotter p")), "{message}");
        let points: Vec<[f64; 2]> = strokes_of(framed, &rig.device).into_iter().flat_map(|(_, p)| p).collect();
        let lo = points.iter().fold([f64::MAX; 2], |m, p| [m[0].min(p[0]), m[1].min(p[1])]);
        let hi = points.iter().fold([f64::MIN; 2], |m, p| [m[0].max(p[0]), m[1].max(p[1])]);
        let corners = [lo, [hi[0], lo[1]], hi, [lo[0], hi[1]], lo];
        let record = rig.sim.record();
        let went = &record.travel[travelled..];
        let u = unit_mm(&rig);
        assert_eq!(went.len(), corners.len(), "{}: {went:?}", rig.device);
        for (got, want) in went.iter().zip(corners) {
            assert!((got[0] - want[0]).abs() * u <= 0.1 && (got[1] - want[1]).abs() * u <= 0.1, "{}: {went:?} vs {corners:?}", rig.device);
        }
        assert_eq!(recorded(&rig.sim), drawn, "{}: a frame draws nothing", rig.device);
        assert!(!rig.sim.status().device.pen_down);
        assert_eq!(rig.job(b).cause, Some(PauseCause::LoadSheet), "the job still waits for its sheet");
    }
}

/// While a job plots, every manual request is refused naming it; paused,
/// the plotter is the person's; resumed, the job ends done.
#[test]
fn manual_control_is_refused_while_a_job_plots_and_allowed_once_paused() {
    // At real speed: the job is still plotting when asked.
    let rig = hp_rig(1.0);
    let text = hpgl_lines(40, 7);
    let id = rig.submit(JobKind::Hpgl, &text);
    rig.sim.wait_until(LONG, |s| s.device.pen_down).unwrap();
    assert_eq!(rig.job(id).state, State::Plotting);
    let want = format!("plotter p is plotting job {id}: pause it first (plotd pause {id}), or wait for it to end");
    for req in [
        Request::Pen { plotter: None, down: false },
        Request::Move { plotter: None, x_mm: 10.0, y_mm: 10.0 },
        Request::Jog { plotter: None, dx_mm: 1.0, dy_mm: 0.0 },
        Request::Frame { id },
    ] {
        assert_eq!(refused(&rig, &req), want, "{req:?}");
    }
    rig.client().call(&Request::Pause { id: Some(id), now: false }).unwrap();
    rig.wait_state(id, State::Paused, LONG);
    ok(&rig, &Request::Jog { plotter: None, dx_mm: 5.0, dy_mm: 5.0 });
    ok(&rig, &Request::Pen { plotter: None, down: false });
    rig.client().call(&Request::Cancel { id, now: true }).unwrap();
    rig.wait_state(id, State::Cancelled, LONG);
}

/// A small SVG drawing: the offset moves what plotd places on the sheet.
const SQUARES: &str = r##"<svg xmlns="http://www.w3.org/2000/svg" width="200mm" height="150mm" viewBox="0 0 200 150">
  <rect x="20" y="20" width="50" height="30" fill="none" stroke="#000"/>
  <polyline points="100,100 140,80 180,120" fill="none" stroke="#000"/>
</svg>
"##;

/// An offset of (10, 5) mm, set with `offset` and shown in `status`, moves
/// every stroke of the next job by that much (within 0.1 mm) on HP and
/// GRBL, and survives a restart of nothing else: the same drawing plotted
/// before and after it.
#[test]
fn an_offset_moves_every_stroke_of_the_jobs_after_it() {
    for rig in [hp_rig(0.0), grbl_rig()] {
        let u = unit_mm(&rig);
        let before = rig.submit(JobKind::Svg, SQUARES);
        rig.wait_state(before, State::Done, LONG);
        rig.sim.wait_idle(LONG).unwrap();
        let first = recorded(&rig.sim);
        assert!(first.len() >= 2, "{first:?}");

        let mut watcher = rig.client();
        watcher.watch(None).unwrap();
        let said = ok(&rig, &Request::Offset { plotter: "p".into(), dx_mm: 10.0, dy_mm: 5.0 });
        assert!(said.starts_with("plotter p: origin offset (10, 5) mm"), "{said}");
        // Watchers (the web page) hear it as the plotter's event.
        let set = loop {
            if let Some(Watched::Plotter(e)) = watcher.next_watched().unwrap() {
                break e;
            }
        };
        assert_eq!((set.plotter.as_str(), set.did, set.mm), ("p", Manoeuvre::Offset, Some([10.0, 5.0])));
        let Reply::Status { plotters, .. } = rig.client().call(&Request::Status {}).unwrap() else { panic!("status") };
        assert_eq!(plotters[0].offset_mm, [10.0, 5.0]);
        let after = rig.submit(JobKind::Svg, SQUARES);
        rig.wait_state(after, State::Done, LONG);
        rig.sim.wait_idle(LONG).unwrap();
        assert_eq!(rig.job(after).offset_mm, Some([10.0, 5.0]));
        let second = &recorded(&rig.sim)[first.len()..];
        assert_eq!(second.len(), first.len(), "{}: {second:?}", rig.device);
        for ((_, a), (_, b)) in first.iter().zip(second) {
            assert_eq!(a.len(), b.len());
            for (p, q) in a.iter().zip(b) {
                let shift = [(q[0] - p[0]) * u, (q[1] - p[1]) * u];
                assert!((shift[0] - 10.0).abs() <= 0.1 && (shift[1] - 5.0).abs() <= 0.1, "{}: {p:?} -> {q:?}", rig.device);
            }
        }
        let e = refused(&rig, &Request::Offset { plotter: "p".into(), dx_mm: 1000.0, dy_mm: 0.0 });
        assert!(e.contains("leaves no room"), "{e}");
    }
}
