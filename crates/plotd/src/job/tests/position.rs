//! Position known or a person asked (`job/position.rs`), on the job's life
//! alone: a device reset mid-job, then the person's confirmation.

use super::*;

fn banner() -> StreamError {
    StreamError::Reset(Reset::Banner(Excerpt::of("Grbl 1.1h ['$' for help]")))
}

/// A GRBL board reset mid-job (its new zero is wherever the carriage
/// stood): the job pauses `position-lost` with what happened and what to do,
/// the mark forgotten and the port closed. The plotter is watched, and once
/// it answers `auto_resume` does not go on; neither does a plain `resume`
/// (one job or all), which names `--position-confirmed`. With it, the job
/// goes on from its checkpoint, with the resume prefix.
#[test]
fn a_reset_mid_job_waits_for_a_person_to_confirm_the_position() {
    let mut desk = Desk::new(&plotters("cnc", "auto_resume = true"), Vec::new());
    let (id, span) = desk.plotting(two_pens(), 4);
    assert_eq!(span, lines(&["start mark 1", "stream 0..4"]));
    desk.confirm(3);
    assert_eq!(desk.ended(Err(banner())), lines(&["forget mark 1", "save 1 paused/position-lost @3", "run ended, link lost"]));
    assert_eq!(
        desk.reason(id),
        "position lost: the board restarted (Grbl 1.1h ['$' for help]); park the pen at the paper's origin (or home the \
         machine), then run `plotd resume 1 --position-confirmed`"
    );
    assert_eq!(desk.link(), LinkState::Offline);
    // Watched: asked at once, and again after the backoff; back, it stays paused.
    assert_eq!(desk.probe(false), Vec::<String>::new());
    desk.now += BACKOFF_MIN;
    assert_eq!(desk.probe(true), Vec::<String>::new(), "auto_resume went on after a reset");
    assert_eq!(desk.link(), LinkState::Online);
    assert!(matches!(desk.poll(), Step::Wait(Some(_))), "watched, not taken");
    let refused = "refused: job 1 lost the pen's position: park the pen at the paper's origin (or home the machine), then run \
                   `plotd resume 1 --position-confirmed`";
    assert_eq!(desk.feed(|l, _| l.resume(Some(id), false)), [refused]);
    assert_eq!(desk.feed(|l, _| l.resume(None, false)), [refused]);
    assert_eq!(desk.state(id).pause_cause(), Some(PauseCause::PositionLost));
    // The person parked the pen at the origin.
    assert_eq!(desk.feed(|l, _| l.resume(Some(id), true)), lines(&["save 1 queued @3", "ok: resumed job(s) 1", "wake cnc"]));
    assert_eq!(desk.take(), lines(&["save 1 rendering @3", "render 1"]));
    assert_eq!(desk.rendered(two_pens(), 4), lines(&["save 1 plotting @3", "read mark 1"]));
    assert_eq!(desk.mark(None), lines(&["start mark 1", "stream 3..4 resume"]));
}

/// `resume` of every paused job goes on with the others and leaves the one
/// whose position was lost; a restart keeps it waiting for the person.
#[test]
fn resume_all_leaves_a_lost_position_and_a_restart_keeps_it() {
    let lost = JobState::paused(PauseCause::PositionLost, "position lost: the board restarted");
    let records = vec![record(1, "cnc", lost.clone(), 3), record(2, "cnc", JobState::paused(PauseCause::Person, "paused by user"), 0)];
    let mut desk = Desk::new(&plotters("cnc", ""), records);
    assert_eq!(desk.state(1), lost, "a restart changed the pause");
    assert_eq!(desk.feed(|l, _| l.resume(None, false)), lines(&["save 2 queued @0", "ok: resumed job(s) 2", "wake cnc"]));
    assert_eq!(desk.state(1), lost);
    assert_eq!(desk.feed(|l, _| l.resume(None, true)), lines(&["save 1 queued @3", "ok: resumed job(s) 1", "wake cnc"]));
}
