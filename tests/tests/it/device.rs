//! The device faults of issue #15 that live between the daemon and the
//! plotter, end to end: the daemon against plotsim over a real pty.

use plotd::protocol::{LinkState, Request, State};
use plotd::spool::{JobKind, PauseCause};
use plotd_e2e::{assert_plotted, hpgl_lines, strokes_of, wait_for, DaemonHandle, Rig};
use plotsim::SimConfig;
use std::time::Duration;

const LONG: Duration = Duration::from_secs(120);

/// Fault 5: a power cycle mid-job was noticed only at the motion timeout
/// (20 s in the rig, 120 s by default) when the whole job was already
/// written: nothing more went out to bring back an answer. Before: paused
/// "device offline: no answer to OE" after 20 s.
#[test]
fn power_cycle_after_the_last_write_is_noticed_within_seconds() {
    let rig = Rig::start(SimConfig::hp7475a().with_speed_scale(1.0).with_baud(9600), "hp7475a", "escb", "");
    // Slow long lines (VS1: 1 cm/s): all of it fits the window at once, and
    // drawing it takes a minute.
    let job = "IN;SP1;VS1;PU0,0;PD8000,0;PD8000,6000;PD0,6000;PD0,0;PU;";
    let id = rig.submit(JobKind::Hpgl, job);
    rig.wait_state(id, State::Plotting, LONG);
    wait_for("the device to start drawing", LONG, || rig.sim.status().device.pen_down);
    // The whole job (about 100 bytes with the set-up: 0.1 s at 9600 baud)
    // is in the device when the power goes: no answer is on its way. The
    // sign: the daemon, silent with nothing left to write, probes the device
    // (ESC.B after a second without an answer), and the device answers.
    let drawing = rig.sim.status().replies;
    rig.sim.wait_until(LONG, |s| s.replies > drawing && s.pending_input == 0).unwrap();
    assert!(rig.sim.status().device.pen_down, "still drawing the first line");
    rig.sim.power_cycle();
    let reason = rig.paused_reason(id, Duration::from_secs(10));
    assert!(reason.starts_with("position lost: ") && reason.contains("power-on terminator"), "{reason}");
    assert!(reason.ends_with(&format!("`plotd resume {id} --position-confirmed`")), "{reason}");
}

/// Fault 6: a power cycle between jobs paused the next job at stroke 0
/// ("device reset: the plotter lost its settings"). A job that has drawn
/// nothing sets the device up again and plots.
#[test]
fn power_cycle_between_jobs_then_the_next_job_plots() {
    let rig = Rig::start(SimConfig::hp7475a().with_speed_scale(0.0).with_baud(9600), "hp7475a", "escb", "");
    let (a, b) = (hpgl_lines(5, 1), hpgl_lines(5, 2));
    let first = rig.submit(JobKind::Hpgl, &a);
    rig.wait_state(first, State::Done, LONG);
    rig.sim.wait_idle(LONG).unwrap();
    rig.sim.power_cycle();
    let second = rig.submit(JobKind::Hpgl, &b);
    rig.wait_state(second, State::Done, LONG);
    rig.sim.wait_idle(LONG).unwrap();
    let want: Vec<_> = [a.as_str(), b.as_str()].iter().flat_map(|t| strokes_of(t, "hp7475a")).collect();
    assert_plotted(&rig.sim, &want, 0);
}

/// Fault 7: the first resume after a replug failed with EIO on the stale
/// file descriptor (the link was not noticed lost: the job was paused by
/// its user meanwhile); a second resume worked. The port is opened afresh.
#[test]
fn replug_while_paused_then_one_resume_plots() {
    let rig = Rig::start(SimConfig::hp7475a().with_speed_scale(0.0).with_baud(9600), "hp7475a", "escb", "");
    let text = hpgl_lines(60, 3);
    let id = rig.submit(JobKind::Hpgl, &text);
    wait_for("a few strokes", LONG, || rig.job(id).checkpoint >= 3);
    rig.client().call(&Request::Pause { id: Some(id), now: false }).expect("pause answered");
    assert_eq!(rig.paused_reason(id, LONG), "paused by user");
    rig.sim.unplug(Duration::from_millis(300)).unwrap();
    rig.sim.wait_connected(LONG).unwrap();
    rig.resume(id);
    let job = rig.wait_state(id, State::Done, LONG);
    assert_eq!(job.checkpoint, job.total.unwrap());
}

/// Fault 4: a dead idle port went unnoticed: `status` said online, and the
/// next job paused at 0/85 with "device offline: device offline: unexpected
/// end of file". The idle port is watched; a job for a plotter that is
/// offline stays queued and plots when it is back.
#[test]
fn dead_idle_port_shows_offline_and_a_job_waits_for_it() {
    let rig = Rig::start(SimConfig::hp7475a().with_speed_scale(0.0).with_baud(9600), "hp7475a", "escb", "");
    rig.wait_online(LONG);
    rig.sim.unplug(Duration::from_secs(12)).unwrap();
    wait_for("status to show the plotter offline", Duration::from_secs(10), || link(&rig) == LinkState::Offline);
    let text = hpgl_lines(5, 4);
    let id = rig.submit(JobKind::Hpgl, &text);
    // The job waits for the plotter, queued, never paused, and plots once it is back.
    let states: Vec<State> = rig.watch_job(id).until_end(LONG).into_iter().map(|e| e.state).collect();
    assert_eq!(states.first(), Some(&State::Queued), "{states:?}");
    assert!(!states.contains(&State::Paused), "the job paused while its plotter was offline: {states:?}");
    assert_eq!(states.last(), Some(&State::Done), "{states:?}");
    let job = rig.job(id);
    assert_eq!(job.checkpoint, job.total.unwrap());
    rig.sim.wait_idle(LONG).unwrap();
    assert_plotted(&rig.sim, &strokes_of(&text, "hp7475a"), 0);
}

/// Fault 10: with the paper lever up the job stayed "plotting" (and the
/// daemon did nothing with the device's ESC.O bit 5). The job shows paused
/// with the device's reason while the lever is up, `resume` is refused (the
/// plotter holds it, not a person), and it goes on by itself, drawing
/// nothing twice, once the lever is down.
#[test]
fn paper_lever_up_pauses_with_the_reason_and_lowering_it_goes_on() {
    let rig = Rig::start(SimConfig::hp7475a().with_speed_scale(0.0).with_baud(9600), "hp7475a", "escb", "");
    let text = hpgl_lines(200, 5);
    let id = rig.submit(JobKind::Hpgl, &text);
    wait_for("a few strokes", LONG, || rig.job(id).checkpoint >= 5);
    rig.sim.lever(true).unwrap();
    let reason = rig.paused_reason(id, Duration::from_secs(10));
    assert!(reason.contains("paper lever"), "{reason}");
    assert_eq!(rig.job(id).cause, Some(PauseCause::DeviceHold));
    let refused = rig.client().call(&Request::Resume { id: Some(id), position_confirmed: false }).expect_err("resume refused").to_string();
    assert!(refused.contains("held by the plotter"), "{refused}");
    // Held through several of the daemon's probes (ESC.B and ESC.O about
    // once a second, each answered "lever up"), longer than their reply
    // deadlines: still paused, still the run's.
    let held = rig.sim.status().replies;
    rig.sim.wait_until(LONG, |s| s.replies >= held + 6).unwrap();
    assert_eq!(rig.job(id).cause, Some(PauseCause::DeviceHold));
    rig.sim.lever(false).unwrap();
    let job = rig.wait_state(id, State::Done, LONG);
    assert_eq!(job.checkpoint, job.total.unwrap());
    rig.sim.wait_idle(LONG).unwrap();
    assert_plotted(&rig.sim, &strokes_of(&text, "hp7475a"), 0);
}

fn link(rig: &Rig) -> LinkState {
    match rig.client().call(&Request::Status {}) {
        Ok(plotd::protocol::Reply::Status { plotters, .. }) => plotters[0].link,
        other => panic!("{other:?}"),
    }
}

/// Issue 36: an HP-GL clone that ignores ESC.O and reads a bare `;` or a
/// line feed between instructions as error 1. Before: every stroke over
/// about two seconds paused the job "offline: no answer to ESC.O", and the
/// set-up's `;OI;` and the job's line feeds were HP-GL errors on the
/// device. Strokes of six seconds each (VS1: 1 cm/s) plot with no pause and
/// no error, every stroke drawn once.
#[test]
fn clone_without_esc_o_reading_separators_strictly_plots_long_strokes() {
    use plotsim::Quirk;
    let sim = SimConfig::hp7475a().with_speed_scale(1.0).with_baud(9600).with_quirks([Quirk::NoEscO, Quirk::StrictSeparators]);
    let rig = Rig::start(sim, "hp7475a", "escb", "");
    let job = "IN;\nSP1;VS1;\nPU0,0;PD2400,0;\nPU0,400;PD2400,400;\nPU;SP0;\n";
    let id = rig.submit(JobKind::Hpgl, job);
    let states: Vec<State> = rig.watch_job(id).until_end(LONG).into_iter().map(|e| e.state).collect();
    assert!(!states.contains(&State::Paused), "never paused: {states:?}");
    assert_eq!(rig.job(id).state.name(), "done", "{states:?}");
    assert_eq!(rig.sim.status().errors, 0, "no HP-GL error on the device");
    assert_plotted(&rig.sim, &strokes_of(job, "hp7475a"), 0);
}
