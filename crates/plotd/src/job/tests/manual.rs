//! A person's manual requests (`job/manual.rs`), on the job's life alone:
//! allowed while idle or paused, refused while a job plots, one at a time.

use super::*;

/// `manual` as lines: the plotter and each action, or the refusal.
fn ask(desk: &mut Desk, plotter: Option<&str>, op: Manual) -> Vec<String> {
    match desk.life.manual(plotter, op) {
        Ok((name, actions)) => {
            let mut out = vec![format!("to {name}")];
            out.extend(desk.carry(actions));
            out
        }
        Err(e) => vec![format!("refused: {e}")],
    }
}

const DOWN: Manual = Manual::Pen { down: true };

/// Idle: the request goes to the only plotter, which carries it out before
/// anything else, then is asked again whether it is there; a second
/// request while one is carried out is refused.
#[test]
fn an_idle_plotter_takes_one_manual_request_at_a_time() {
    let mut desk = Desk::new(&plotters("hp", ""), Vec::new());
    assert_eq!(desk.probe(true), Vec::<String>::new());
    assert_eq!(ask(&mut desk, None, DOWN), lines(&["to hp", "wake hp"]));
    assert_eq!(
        ask(&mut desk, Some("hp"), Manual::Pen { down: false }),
        lines(&["refused: plotter hp is still carrying out a manual request"])
    );
    // A job submitted meanwhile waits behind it.
    desk.submit();
    assert_eq!(desk.poll(), Step::Manual(ManualWork { op: DOWN, kind: None, offset_mm: [0.0, 0.0] }));
    let jog = Manual::Jog { dx_mm: 1.0, dy_mm: -2.0 };
    assert_eq!(ask(&mut desk, None, jog), lines(&["refused: plotter hp is still carrying out a manual request"]));
    desk.life.manual_done("hp");
    assert_eq!(ask(&mut desk, None, jog), lines(&["to hp", "wake hp"]));
    assert_eq!(desk.poll(), Step::Manual(ManualWork { op: jog, kind: None, offset_mm: [0.0, 0.0] }));
    desk.life.manual_done("hp");
    // Then the job, once the plotter answered.
    assert_eq!(desk.take(), lines(&["save 1 rendering @0", "render 1"]));
    assert_eq!(ask(&mut desk, Some("cnc"), DOWN), lines(&["refused: no plotter \"cnc\""]));
}

/// From its render to its run's end a job holds the plotter: manual
/// requests are refused naming it and how to go on.
#[test]
fn a_plotting_job_refuses_manual_requests_naming_itself() {
    let mut desk = Desk::new(&plotters("hp", ""), Vec::new());
    let id = desk.submit();
    desk.take();
    let refused = format!("refused: plotter hp is plotting job {id}: pause it first (plotd pause {id}), or wait for it to end");
    assert_eq!(ask(&mut desk, None, DOWN), std::slice::from_ref(&refused), "rendering");
    desk.rendered(hpgl(3), 6);
    desk.mark(None);
    desk.confirm(1);
    for op in [DOWN, Manual::MoveTo { x_mm: 10.0, y_mm: 5.0 }, Manual::Jog { dx_mm: 1.0, dy_mm: 0.0 }, Manual::Frame { job: id }] {
        assert_eq!(ask(&mut desk, None, op), std::slice::from_ref(&refused), "{op:?}");
    }
    // Paused, the plotter is the person's: the job's mark is forgotten (the
    // pen will not rest where it wrote), and it resumes from its checkpoint.
    desk.feed(|l, _| l.pause(Some(id), false));
    desk.ended(Ok(Outcome::Stopped));
    assert_eq!(ask(&mut desk, None, Manual::Frame { job: id }), lines(&["to hp", "forget mark 1", "wake hp"]));
    assert_eq!(desk.poll(), Step::Manual(ManualWork { op: Manual::Frame { job: id }, kind: Some(JobKind::Hpgl), offset_mm: [0.0, 0.0] }));
    desk.life.manual_done("hp");
    assert_eq!(desk.poll(), Step::Wait(None), "the paused job still waits for its person");
    desk.feed(|l, _| l.resume(Some(id), false));
    desk.take();
    desk.rendered(hpgl(3), 6);
    assert_eq!(desk.mark(None), lines(&["start mark 1", "stream 1..4 resume"]));
}

/// A frame is of a job not yet finished, on its own plotter; with several
/// plotters, the others name theirs; a shutdown refuses them all.
#[test]
fn frames_need_a_live_job_and_several_plotters_need_a_name() {
    let mut desk = Desk::new(&plotters("hp", ""), vec![record(3, "hp", JobState::Done, 4)]);
    assert_eq!(ask(&mut desk, None, Manual::Frame { job: 3 }), lines(&["refused: job 3 is already done"]));
    assert_eq!(ask(&mut desk, None, Manual::Frame { job: 9 }), lines(&["refused: no job 9"]));

    let text = "socket = \"/s/plotd.sock\"\nspool = \"/s\"\n\
                [[plotter]]\nname = \"hp\"\nport = \"/dev/ttyUSB0\"\ndevice = \"hp7475a\"\n\
                [[plotter]]\nname = \"cnc\"\nport = \"/dev/ttyUSB1\"\ndevice = \"grbl-servo\"\nhandshake = \"grbl\"\n";
    let two = Config::from_toml(text, "test").unwrap().plotters;
    let mut desk = Desk::new(&two, vec![record(5, "cnc", JobState::Queued, 0)]);
    assert_eq!(ask(&mut desk, None, DOWN), lines(&["refused: name the plotter: hp, cnc"]));
    assert_eq!(ask(&mut desk, None, Manual::Frame { job: 5 }), lines(&["to cnc", "wake cnc"]));
    assert_eq!(ask(&mut desk, Some("hp"), DOWN), lines(&["to hp", "wake hp"]), "each plotter takes its own");
    desk.life.shut_down();
    assert_eq!(ask(&mut desk, Some("hp"), DOWN), lines(&["refused: the daemon is shutting down"]));
}

/// An offset is kept for the plotter and taken by each job as it starts:
/// rendered with it, and kept by a job that drew when the offset changes
/// again before it goes on; a frame uses the offset its job is drawn with.
#[test]
fn a_job_takes_the_plotters_offset_as_it_starts_and_keeps_it() {
    let mut desk = Desk::new(&plotters("hp", ""), Vec::new());
    assert_eq!(
        desk.feed(|l, p| l.set_offset(p, [10.0, 5.0])),
        lines(&["ok: plotter hp: origin offset (10, 5) mm, for the jobs that start from now on (a job that started keeps its own)"])
    );
    assert_eq!(desk.plotters_disk["hp"].offset_mm, [10.0, 5.0], "kept in the spool");
    let id = desk.submit();
    assert_eq!(desk.take(), lines(&["save 1 rendering @0", "render 1 offset [10.0, 5.0]"]));
    assert_eq!(desk.disk[&id].offset_mm, Some([10.0, 5.0]));
    desk.rendered(hpgl(3), 6);
    desk.mark(None);
    desk.confirm(1);
    desk.feed(|l, _| l.pause(Some(id), false));
    desk.ended(Ok(Outcome::Stopped));
    desk.feed(|l, p| l.set_offset(p, [-3.0, 0.0]));
    ask(&mut desk, None, Manual::Frame { job: id });
    let Step::Manual(work) = desk.poll() else { panic!("no frame") };
    assert_eq!(work.offset_mm, [10.0, 5.0], "the frame of a started job is where it draws");
    desk.life.manual_done("hp");
    desk.feed(|l, _| l.resume(Some(id), false));
    assert_eq!(desk.take(), lines(&["save 1 rendering @1", "render 1 offset [10.0, 5.0]"]), "it goes on where it began");
    // A job not yet started is framed, and drawn, with the plotter's offset now.
    let (_, _) = (desk.rendered(hpgl(3), 6), desk.mark(None));
    desk.confirm(4);
    desk.ended(Ok(Outcome::Finished));
    let next = desk.submit_on(true);
    ask(&mut desk, None, Manual::Frame { job: next });
    let Step::Manual(work) = desk.poll() else { panic!("no frame") };
    assert_eq!(work.offset_mm, [-3.0, 0.0]);
    desk.life.manual_done("hp");
    assert_eq!(desk.take(), lines(&["save 2 rendering @0", "render 2 offset [-3.0, 0.0]"]));
    // An offset that leaves no room, or is no distance, is refused.
    for bad in [[300.0, 0.0], [0.0, f64::NAN]] {
        let got = desk.feed(|l, p| l.set_offset(p, bad));
        assert!(got[0].starts_with("refused: plotter hp: an origin offset of (") && got[0].contains("leaves no room"), "{got:?}");
    }
    assert_eq!(desk.life.offset("hp"), Some([-3.0, 0.0]));
}

/// `home`: taken by a GRBL plotter with `homing = true`; refused on one
/// without homing switches, saying how to set the origin instead.
#[test]
fn home_is_for_plotters_with_homing_switches() {
    let mut desk = Desk::new(&plotters("cnc", "homing = true"), Vec::new());
    assert_eq!(ask(&mut desk, None, Manual::Home), lines(&["to cnc", "wake cnc"]));
    let mut desk = Desk::new(&plotters("cnc", ""), Vec::new());
    assert_eq!(
        ask(&mut desk, None, Manual::Home),
        lines(&["refused: plotter cnc has no homing switches (`homing = true` in its [[plotter]] table is for a GRBL board with them): \
                 park the carriage at the origin by hand, or `plotd move 0 0`"])
    );
    let mut desk = Desk::new(&plotters("hp", "homing = true"), Vec::new());
    assert!(ask(&mut desk, None, Manual::Home)[0].starts_with("refused: plotter hp has no homing switches"));
}
