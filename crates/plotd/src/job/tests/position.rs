//! Position known or a person asked (`job/position.rs`), on the job's life
//! alone: a device reset mid-job, then the person's confirmation.

use super::*;
use crate::stream::Alarm;
use plotcode::control::grbl::Op;

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
    assert_eq!(desk.mark(None), lines(&["start mark 1", "stream 3..4 resume confirmed"]));
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

/// After a resume, the plotter takes job 1 again, renders it, and starts
/// its run from checkpoint `at`: the run's first actions.
fn run_again(desk: &mut Desk, at: usize) -> Vec<String> {
    assert_eq!(desk.take(), [format!("save 1 rendering @{at}"), "render 1".to_owned()]);
    assert_eq!(desk.rendered(two_pens(), 4), [format!("save 1 plotting @{at}"), "read mark 1".to_owned()]);
    desk.mark(None)
}

fn locked() -> StreamError {
    StreamError::Alarm(Alarm::NeedsHoming)
}

/// A board locked until homed (GRBL, `$22=1`) on a plotter without homing
/// switches: the job waits `needs-homing`, saying what to do; neither
/// `auto_resume` nor a plain `resume` goes on; with the position confirmed
/// the run's set-up may unlock the board, once.
#[test]
fn a_board_locked_until_homed_waits_for_a_person() {
    let mut desk = Desk::new(&plotters("cnc", "auto_resume = true"), Vec::new());
    let (id, span) = desk.plotting(two_pens(), 4);
    assert_eq!(span, lines(&["start mark 1", "stream 0..4"]), "nothing allowed unasked");
    assert_eq!(desk.ended(Err(locked())), lines(&["forget mark 1", "save 1 paused/needs-homing @0", "run ended"]));
    assert_eq!(
        desk.reason(id),
        format!(
            "needs homing: the board is locked until it is homed (GRBL with homing enabled, $22=1, starts locked); this \
             plotter has no homing switches (`homing = true`): park the pen at the paper's origin, then run `plotd resume \
             1 --position-confirmed` ({} unlocks it)",
            Op::Unlock
        )
    );
    assert_eq!(desk.link(), LinkState::Online, "the link is fine");
    assert_eq!(desk.probe(true), Vec::<String>::new(), "auto_resume went on");
    assert!(matches!(desk.poll(), Step::Wait(Some(_))), "watched, not taken");
    let refused = "refused: job 1 waits for its plotter to be homed, and it has no homing switches (`homing = true`): park \
                   the pen at the paper's origin, then run `plotd resume 1 --position-confirmed`";
    assert_eq!(desk.feed(|l, _| l.resume(Some(id), false)), [refused]);
    assert_eq!(desk.feed(|l, _| l.resume(Some(id), true)), lines(&["save 1 queued @0", "ok: resumed job(s) 1", "wake cnc"]));
    desk.now += IDLE_CHECK;
    assert_eq!(run_again(&mut desk, 0), lines(&["start mark 1", "stream 0..4 confirmed"]));
    // A resync later in the run does not unlock again.
    desk.confirm(2);
    assert_eq!(desk.ended(Err(StreamError::Stalled { unanswered: 1 })), lines(&["stream 2..4 resume"]));
}

/// On a plotter with homing switches (`homing = true`), a plain `resume`
/// of a job waiting `needs-homing` or `position-lost` homes the machine
/// first ([`Op::Home`], by the run's first span): the reason says so.
#[test]
fn a_plotter_with_homing_switches_homes_on_resume() {
    let mut desk = Desk::new(&plotters("cnc", "homing = true"), Vec::new());
    let (id, _) = desk.plotting(two_pens(), 4);
    assert_eq!(desk.ended(Err(locked())), lines(&["forget mark 1", "save 1 paused/needs-homing @0", "run ended"]));
    let home_to_go_on = format!("run `plotd resume 1` to home the machine ({}) and go on", Op::Home);
    assert!(desk.reason(id).ends_with(&format!("; {home_to_go_on}")), "{}", desk.reason(id));
    assert_eq!(desk.feed(|l, _| l.resume(Some(id), false)), lines(&["save 1 queued @0", "ok: resumed job(s) 1", "wake cnc"]));
    desk.now += IDLE_CHECK;
    assert_eq!(run_again(&mut desk, 0), lines(&["start mark 1", "stream 0..4 home"]));
    // Reset mid-job: position lost, and a plain resume homes again.
    desk.confirm(3);
    assert_eq!(desk.ended(Err(banner())), lines(&["forget mark 1", "save 1 paused/position-lost @3", "run ended, link lost"]));
    assert!(desk.reason(id).ends_with(&home_to_go_on), "{}", desk.reason(id));
    assert_eq!(desk.feed(|l, _| l.resume(Some(id), false)), lines(&["save 1 queued @3", "ok: resumed job(s) 1", "wake cnc"]));
    desk.now += BACKOFF_MIN;
    assert_eq!(run_again(&mut desk, 3), lines(&["start mark 1", "stream 3..4 resume home"]));
}

/// A GRBL alarm mid-job (a hard limit: the motors stopped at once) is
/// `position-lost`, the link kept, the mark forgotten: the board keeps its
/// idea of its place, so the person checks it rather than parks. Not a
/// device error a plain `resume` unlocks silently.
#[test]
fn an_alarm_mid_job_loses_the_position() {
    let mut desk = Desk::new(&plotters("cnc", "auto_resume = true\non_device_error = \"fail\""), Vec::new());
    let (id, _) = desk.plotting(two_pens(), 4);
    desk.confirm(3);
    let alarm = StreamError::Alarm(Alarm::Raised(1));
    assert_eq!(desk.ended(Err(alarm)), lines(&["forget mark 1", "save 1 paused/position-lost @3", "run ended"]));
    assert_eq!(
        desk.reason(id),
        "position lost: GRBL ALARM:1 (hard limit triggered); check that the pen is where the board stopped it (or home the \
         machine), then run `plotd resume 1 --position-confirmed`"
    );
    assert_eq!(desk.probe(true), Vec::<String>::new(), "auto_resume went on");
    assert!(matches!(desk.poll(), Step::Wait(Some(_))), "watched, not taken");
    assert!(desk.feed(|l, _| l.resume(Some(id), false))[0].starts_with("refused: job 1 lost the pen's position"));
    assert_eq!(desk.feed(|l, _| l.resume(Some(id), true)), lines(&["save 1 queued @3", "ok: resumed job(s) 1", "wake cnc"]));
    desk.now += IDLE_CHECK;
    assert_eq!(run_again(&mut desk, 3), lines(&["start mark 1", "stream 3..4 resume confirmed"]));
}

/// A board found in alarm when the job is located after a restart: the
/// job waits `position-lost`, keeping what the device confirmed before the
/// daemon died (the mark's confirmation, ahead of the saved checkpoint), so
/// that the confirmed resume does not draw those strokes again.
#[test]
fn an_alarm_found_by_the_locate_keeps_the_confirmed_strokes() {
    let mut desk = Desk::new(&plotters("cnc", ""), vec![record(1, "cnc", JobState::Plotting, 1)]);
    assert_eq!(desk.feed(|l, _| l.resume(Some(1), false)), lines(&["save 1 queued @1", "ok: resumed job(s) 1", "wake cnc"]));
    assert_eq!(desk.take(), lines(&["save 1 rendering @1", "render 1"]));
    assert_eq!(desk.rendered(two_pens(), 4), lines(&["save 1 plotting @1", "read mark 1"]));
    assert_eq!(desk.mark(Some(WrittenMark { mark: Written::Into(3), confirmed: 2 })), lines(&["locate from 2 in Into(3)"]));
    let found = desk.feed(|l, p| l.located(p, Err(StreamError::Alarm(Alarm::Unexplained))));
    assert_eq!(found, lines(&["forget mark 1", "save 1 paused/position-lost @2", "run ended"]));
    assert_eq!(desk.feed(|l, _| l.resume(Some(1), true)), lines(&["save 1 queued @2", "ok: resumed job(s) 1", "wake cnc"]));
    desk.now += IDLE_CHECK;
    assert_eq!(run_again(&mut desk, 2), lines(&["start mark 1", "stream 2..4 resume confirmed"]));
}
