//! A cancel always ends the job `cancelled` (issue #42 item 4), on the
//! job's life alone: the run asked to stop, then a device that stalls, is
//! unplugged or holds the job with its paper lever up; a device that could
//! not be told is reset when it answers again, before any other job.

use super::*;

/// A GRBL board that stalls after the cancel is not resynced (that would
/// stream the cancelled job again): the job ends `cancelled`.
#[test]
fn a_cancel_then_a_stall_ends_cancelled() {
    let mut desk = Desk::new(&plotters("cnc", "pen_change = \"ignore\""), Vec::new());
    let (id, _) = desk.plotting(hpgl(8), 1);
    desk.confirm(2);
    assert_eq!(
        desk.feed(|l, _| l.cancel(id, false)),
        lines(&["stop cnc AfterStroke", "wake cnc", "ok: job 1 stops at the end of the current stroke"])
    );
    assert_eq!(desk.ended(Err(StreamError::Stalled { unanswered: 3 })), lines(&["forget mark 1", "save 1 cancelled @2", "run ended"]));
    assert_eq!(desk.state(id), JobState::Cancelled);
}

/// Unplugged after the cancel (the stop never reached the device): the job
/// ends `cancelled`, not paused offline, and the port is opened afresh.
#[test]
fn a_cancel_then_an_unplug_ends_cancelled() {
    for now in [false, true] {
        let mut desk = Desk::new(&plotters("hp", ""), Vec::new());
        let (id, _) = desk.plotting(hpgl(8), 6);
        desk.confirm(3);
        desk.feed(|l, _| l.cancel(id, now));
        assert_eq!(desk.ended(Err(offline())), lines(&["forget mark 1", "save 1 cancelled @3", "run ended, link lost"]));
        assert_eq!(desk.state(id), JobState::Cancelled);
        assert_eq!(desk.link(), LinkState::Offline);
        assert_eq!(desk.feed(|l, _| l.resume(Some(id), false)), lines(&["refused: job 1 is not paused"]));
    }
}

/// The paper lever up holds the job: no stroke ends until a person lowers
/// it. The cancel ends the job at once on the daemon's side and asks the
/// run to stop now (the device drops what it holds and lifts the pen when
/// it goes on); what the device reports afterwards changes nothing.
#[test]
fn a_cancel_of_a_job_the_lever_holds_ends_cancelled_at_once() {
    let mut desk = Desk::new(&plotters("hp", ""), Vec::new());
    let (id, _) = desk.plotting(hpgl(8), 6);
    desk.confirm(3);
    let lever = |l: &mut JobLife, p: &str, up: bool| l.held(p, up.then_some(Hold::PaperLever));
    assert_eq!(desk.feed(|l, p| lever(l, p, true)), lines(&["checkpoint 1 paused/device-hold @3"]));
    assert_eq!(desk.feed(|l, _| l.cancel(id, false)), lines(&["stop hp Now", "wake hp", "save 1 cancelled @3", "ok: job 1 cancelled"]));
    assert_eq!(desk.state(id), JobState::Cancelled);
    assert_eq!(desk.feed(|l, p| lever(l, p, true)), Vec::<String>::new(), "still held: the job stays cancelled");
    assert_eq!(desk.feed(|l, p| lever(l, p, false)), Vec::<String>::new());
    assert_eq!(desk.ended(Ok(Outcome::Stopped)), lines(&["forget mark 1", "run ended"]));
    assert_eq!(desk.state(id), JobState::Cancelled);
}

/// A device the cancel could not reach is reset as soon as it answers
/// again: before the next job is taken, and asked again (backing off) while
/// the reset fails. A device told to stop (it confirmed the stop) is not.
#[test]
fn a_device_that_could_not_be_told_is_reset_before_the_next_job() {
    let mut desk = Desk::new(&plotters("hp", ""), Vec::new());
    let (id, _) = desk.plotting(hpgl(8), 6);
    desk.confirm(3);
    desk.feed(|l, _| l.cancel(id, false));
    desk.ended(Err(offline()));
    // On the same sheet: it does not wait for a fresh one.
    let next = desk.submit_on(true);
    // Still unplugged: asked again after the backoff, nothing taken (the
    // queued job told what it waits for).
    assert_eq!(desk.probe(false), lines(&["announce 2 queued"]));
    assert_eq!(desk.poll(), Step::Wait(Some(desk.now + BACKOFF_MIN)));
    desk.now += BACKOFF_MIN;
    // Back: the reset comes first, with the cancelled job's program.
    assert_eq!(desk.probe(true), lines(&["announce 2 queued"]));
    assert_eq!(desk.poll(), Step::Reset(std::sync::Arc::new(hpgl(8))));
    assert_eq!(desk.state(next), JobState::Queued);
    // The reset fails: asked again later, and the reset comes first again.
    assert_eq!(desk.feed(|l, p| l.reset_done(p, false, desk_now())), Vec::<String>::new());
    assert_eq!(desk.link(), LinkState::Offline);
    assert!(matches!(desk.poll(), Step::Wait(Some(_))));
    desk.now += BACKOFF_MAX;
    assert_eq!(desk.probe(true), lines(&["announce 2 queued"]));
    assert!(matches!(desk.poll(), Step::Reset(_)));
    // Reset: the next job runs, and no reset is owed after it.
    assert_eq!(desk.feed(|l, p| l.reset_done(p, true, desk_now())), lines(&["wake hp"]));
    assert_eq!(desk.take(), lines(&["save 2 rendering @0", "render 2"]));
    desk.rendered(hpgl(2), 6);
    desk.mark(None);
    desk.feed(|l, _| l.cancel(next, false));
    assert_eq!(desk.ended(Ok(Outcome::Stopped)), lines(&["forget mark 2", "save 2 cancelled @0", "run ended"]));
    assert_eq!(desk.probe(true), Vec::<String>::new());
    assert!(matches!(desk.poll(), Step::Wait(_) | Step::Probe), "told to stop: no reset");
}

/// A cancel during the render ends the job cancelled even when the render
/// then fails, and owes no reset (nothing was written).
#[test]
fn a_cancel_during_the_render_ends_cancelled_and_owes_no_reset() {
    let mut desk = Desk::new(&plotters("hp", ""), Vec::new());
    let id = desk.submit();
    desk.take();
    desk.feed(|l, _| l.cancel(id, false));
    let stopped = desk.feed(|l, p| l.rendered(p, Rendered::Failed("no".into())));
    assert_eq!(stopped, lines(&["forget mark 1", "save 1 cancelled @0", "run ended"]));
    desk.submit();
    assert_eq!(desk.take(), lines(&["save 2 rendering @0", "render 2"]));
}

/// The clock a reset's result is reported at (only its backoff reads it).
fn desk_now() -> Instant {
    Instant::now()
}
