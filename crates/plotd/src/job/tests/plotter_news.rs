//! A plotter's link is announced to watchers when it changes (the web page
//! shows it from the event stream), not at each probe.

use super::*;

/// An idle plotter is asked every few seconds: watchers hear it come
/// online, go offline (silent), change its cause (unplugged) and come
/// back, each once.
#[test]
fn an_idle_plotters_link_is_announced_when_it_changes_and_only_then() {
    let mut desk = Desk::new(&plotters("hp", ""), Vec::new());
    let announced = |desk: &Desk| desk.plotters_announced.iter().map(|(p, l)| format!("{p} {l}")).collect::<Vec<_>>();
    assert_eq!(desk.probe(true), Vec::<String>::new());
    assert_eq!(announced(&desk), ["hp online"]);
    desk.now += IDLE_CHECK;
    desk.probe(true);
    assert_eq!(announced(&desk), ["hp online"], "a probe that changes nothing is not told");
    desk.now += IDLE_CHECK;
    desk.probe(false);
    desk.now += IDLE_CHECK;
    desk.probe(false);
    assert_eq!(announced(&desk), ["hp online", "hp offline"], "the same cause again is not told");
    desk.now += IDLE_CHECK;
    desk.probe_as(Err(LinkCause::new(LinkFault::NoSuchPort, "/dev/ttyUSB0: no such file")));
    assert_eq!(announced(&desk), ["hp online", "hp offline", "hp offline"], "a new cause is");
    desk.now += IDLE_CHECK;
    desk.probe(true);
    assert_eq!(announced(&desk), ["hp online", "hp offline", "hp offline", "hp online"]);
}

/// A run that loses its link announces the plotter offline, with the
/// cause, before the job's pause is saved and announced.
#[test]
fn a_run_that_loses_its_link_announces_the_plotter_offline() {
    let mut desk = Desk::new(&plotters("hp", ""), Vec::new());
    desk.plotting(hpgl(8), 6);
    desk.confirm(3);
    let before = desk.plotters_announced.len();
    assert_eq!(desk.ended(Err(offline())), lines(&["save 1 paused/offline @3", "run ended, link lost"]));
    assert_eq!(desk.plotters_announced[before..], [("hp".to_owned(), LinkState::Offline)]);
    let cause = desk.life.reach("hp").cause.expect("a cause");
    assert_eq!(cause.kind, LinkFault::PortClosed, "{cause:?}");
}
