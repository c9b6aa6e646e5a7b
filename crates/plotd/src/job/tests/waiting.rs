//! What a job that cannot go on waits for (issue 36): computed from its
//! plotter's state each time it is shown, never stored, so never stale.

use super::*;
use crate::protocol::{LinkFault, Waiting};

fn no_such_port() -> LinkCause {
    LinkCause::new(LinkFault::NoSuchPort, "/dev/ttyUSB0: no such file")
}

/// A job for a plotter whose port is missing says so in `jobs`, `status`
/// and `watch` (`queued: waiting for plotter hp (offline: ...)`), typed;
/// told again when the cause changes, and no longer once the plotter
/// answers.
#[test]
fn a_queued_job_says_which_plotter_it_waits_for_and_why() {
    let mut desk = Desk::new(&plotters("hp", ""), Vec::new());
    let id = desk.submit();
    assert_eq!(desk.shown(id).waiting, None, "not asked yet: nothing to say");
    assert_eq!(desk.probe_as(Err(no_such_port())), lines(&["announce 1 queued"]));
    let shown = desk.shown(id);
    assert_eq!(shown.reason.as_deref(), Some("waiting for plotter hp (offline: /dev/ttyUSB0: no such file)"));
    assert_eq!(shown.waiting, Some(Waiting::Plotter { plotter: "hp".into(), cause: Some(no_such_port()) }));
    let json = serde_json::to_value(&shown).unwrap();
    assert_eq!(
        json["waiting"],
        serde_json::json!({"for": "plotter", "plotter": "hp",
        "cause": {"kind": "no-such-port", "message": "/dev/ttyUSB0: no such file"}})
    );
    // The same cause again: nothing new to tell.
    desk.now += BACKOFF_MIN;
    assert_eq!(desk.probe_as(Err(no_such_port())), Vec::<String>::new());
    // Plugged in, the device silent: told again, with the new cause.
    desk.now += BACKOFF_MIN * 2;
    assert_eq!(desk.probe(false), lines(&["announce 1 queued"]));
    assert_eq!(desk.shown(id).reason.as_deref(), Some("waiting for plotter hp (offline: no answer to ESC.B for 10 s)"));
    // It answers: the job is taken, and waits for nothing.
    desk.now += BACKOFF_MIN * 4;
    assert_eq!(desk.take(), lines(&["save 1 rendering @0", "render 1"]));
    assert_eq!((desk.shown(id).reason, desk.shown(id).waiting), (None, None));
}

/// `auto_resume = false`: a job paused because the link went kept "device
/// offline" while `status` said online. Back online, it says it waits for
/// `plotd resume`; offline again, why it is offline now.
#[test]
fn a_job_paused_offline_says_when_its_plotter_is_back() {
    let mut desk = Desk::new(&plotters("hp", ""), Vec::new());
    let (id, _) = desk.plotting(hpgl(4), 6);
    desk.confirm(2);
    desk.ended(Err(offline()));
    let paused = desk.reason(id);
    let shown = desk.shown(id);
    assert_eq!(shown.reason.as_deref(), Some(paused.as_str()));
    let Some(Waiting::Plotter { cause: Some(closed), .. }) = shown.waiting else { panic!("{:?}", shown.waiting) };
    assert_eq!(closed.kind, LinkFault::PortClosed, "{closed}");
    assert_eq!(desk.probe(true), lines(&["announce 1 paused/offline"]));
    let shown = desk.shown(id);
    assert_eq!(shown.cause, Some(PauseCause::Offline));
    assert_eq!(shown.reason.unwrap(), format!("plotter hp is back online: run `plotd resume 1` to go on (it paused: {paused})"));
    assert_eq!(shown.waiting, None);
    assert_eq!(desk.reason(id), paused, "the record is unchanged: only what is shown follows the plotter");
    desk.now += IDLE_CHECK;
    assert_eq!(desk.probe_as(Err(no_such_port())), lines(&["announce 1 paused/offline"]));
    assert_eq!(desk.shown(id).reason.unwrap(), paused);
    assert_eq!(desk.shown(id).waiting, Some(Waiting::Plotter { plotter: "hp".into(), cause: Some(no_such_port()) }));
}
