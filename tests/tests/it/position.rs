//! Position known or a person asked, end to end (issue 36): on GRBL a board
//! that requires homing, an alarm mid-job, a board that resets when its port
//! is opened; on an HP-GL clone without ESC.O, the pen found by `OA` after an
//! unplug. The daemon against plotsim over a real pty; plotsim's record
//! says whether `$X` unlocked a board that was never homed
//! (`unlocked_without_homing`), and where every stroke landed.

use plotd::protocol::{Reply, Request, State};
use plotd::spool::{JobKind, PauseCause};
use plotd_e2e::{assert_drawn_once, assert_plotted, hpgl_lines, recorded, render_for, repo_root, strokes_of, DaemonHandle, Rig};
use plotsim::{Quirk, SimConfig};
use std::time::Duration;

const LONG: Duration = Duration::from_secs(120);

fn lattice() -> String {
    render_for(&repo_root().join("examples/lattice.toml"), "grbl-servo")
}

fn rig(quirks: &[Quirk], extra: &str) -> Rig {
    let sim = SimConfig::grbl().with_speed_scale(0.0).with_baud(115_200).with_quirks(quirks.iter().copied());
    Rig::start(sim, "grbl-servo", "grbl", &format!("pen_change = \"ignore\"\n{extra}"))
}

/// Waits for job `id` to be done and the board idle, then checks every
/// stroke of `text` was drawn once, at most `repeats` drawn again.
fn drawn_once_when_done(rig: &Rig, id: u64, text: &str, repeats: usize) {
    rig.wait_state(id, State::Done, LONG);
    rig.sim.wait_idle(Duration::from_secs(20)).unwrap();
    assert_drawn_once(&recorded(&rig.sim), &strokes_of(text, "grbl-servo"), repeats);
}

/// `plotd resume ID` without the position confirmed: refused, the message.
fn refused(rig: &Rig, id: u64) -> String {
    rig.client().call(&Request::Resume { id: Some(id), position_confirmed: false }).expect_err("resume refused").to_string()
}

/// A board with homing enabled (`$22=1`) on a machine without switches in
/// the config: the job waits `needs-homing` and the board is never sent
/// `$X` unasked (before: `$X` at the job's start, and it plotted unhomed,
/// `status` online, an INFO line the only trace). A plain `resume` is
/// refused naming `--position-confirmed`; with it, every stroke is drawn once.
#[test]
fn a_board_locked_until_homed_waits_for_a_person_and_is_never_unlocked_unasked() {
    let rig = rig(&[Quirk::HomingRequired], "");
    let text = lattice();
    let id = rig.submit(JobKind::Gcode, &text);
    let reason = rig.paused_reason(id, LONG);
    assert_eq!(rig.job(id).cause, Some(PauseCause::NeedsHoming), "{reason}");
    assert!(reason.contains(&format!("plotd resume {id} --position-confirmed")), "{reason}");
    assert!(!rig.sim.record().unlocked_without_homing, "$X sent to a board that was never homed");
    assert_eq!(rig.sim.status().device.state, "Alarm");
    assert!(rig.sim.record().strokes.is_empty());
    let no = refused(&rig, id);
    assert!(no.contains("--position-confirmed"), "{no}");
    rig.resume_position_confirmed(id);
    drawn_once_when_done(&rig, id, &text, 0);
}

/// A machine with homing switches (`homing = true`): the job waits
/// `needs-homing`, and a plain `resume` homes it (`$H`), then plots every
/// stroke once, on the paper's frame; `$X` is never sent.
#[test]
fn a_board_locked_until_homed_is_homed_on_resume_never_unlocked() {
    let rig = rig(&[Quirk::HomingRequired], "homing = true");
    let text = lattice();
    let id = rig.submit(JobKind::Gcode, &text);
    let reason = rig.paused_reason(id, LONG);
    assert_eq!(rig.job(id).cause, Some(PauseCause::NeedsHoming), "{reason}");
    assert!(reason.contains(&format!("plotd resume {id}")) && reason.contains("$H"), "{reason}");
    rig.resume(id);
    drawn_once_when_done(&rig, id, &text, 0);
    assert!(!rig.sim.record().unlocked_without_homing, "$X sent before $H");
}

/// An alarm mid-job (a hard limit) is `position-lost`, not a pause a
/// plain `resume` clears with a silent `$X` (before: `device-error`, and
/// `resume` unlocked). The board stays in alarm until a person confirms;
/// then the stroke it was drawing is drawn again, and nothing else.
#[test]
fn an_alarm_mid_job_loses_the_position_until_a_person_confirms_it() {
    let rig = rig(&[], "auto_resume = true");
    let text = lattice();
    let id = rig.submit(JobKind::Gcode, &text);
    rig.sim.wait_received(text.len() as u64 / 3, LONG).unwrap();
    rig.sim.alarm(1).unwrap();
    let reason = rig.paused_reason(id, LONG);
    assert_eq!(rig.job(id).cause, Some(PauseCause::PositionLost), "{reason}");
    assert!(reason.contains("ALARM:1") && reason.contains("hard limit"), "{reason}");
    let no = refused(&rig, id);
    assert!(no.contains(&format!("plotd resume {id} --position-confirmed")), "{no}");
    assert_eq!(rig.sim.status().device.state, "Alarm", "unlocked unasked");
    rig.resume_position_confirmed(id);
    drawn_once_when_done(&rig, id, &text, 1);
}

/// A board that resets when its port is opened (an Arduino's DTR): unplugged
/// and plugged back mid-job, the reopened port resets it, so its zero is
/// where the carriage stood. The job pauses `position-lost` (before: the
/// sync took the banner for an earlier session's answer and `resume` drew
/// the rest shifted); parked and confirmed, every stroke lands on the
/// drawing, at most one drawn twice.
#[test]
fn a_reset_on_open_after_an_unplug_mid_job_loses_the_position() {
    // A real reply timeout (2 s): the Arduino's bootloader ignores the first second.
    let rig = rig(&[Quirk::ResetOnOpen], "reply_timeout_s = 3.0\nmotion_timeout_s = 20.0\nauto_resume = true");
    let text = lattice();
    let id = rig.submit(JobKind::Gcode, &text);
    rig.sim.wait_received(text.len() as u64 / 3, LONG).unwrap();
    rig.sim.unplug(Duration::from_millis(300)).unwrap();
    rig.sim.wait_connected(LONG).unwrap();
    let cause = || rig.job(id).cause;
    plotd_e2e::wait_for("the job to pause position-lost", LONG, || cause() == Some(PauseCause::PositionLost));
    rig.wait_online(LONG);
    assert_eq!(rig.job(id).state, State::Paused, "auto_resume went on after a reset");
    rig.sim.wait_idle(Duration::from_secs(20)).unwrap();
    rig.sim.park().unwrap();
    rig.resume_position_confirmed(id);
    drawn_once_when_done(&rig, id, &text, 1);
}

/// An HP-GL clone without ESC.O, its cable pulled mid-job while its buffer
/// holds strokes: on resume, `OA` (the pen's place) matched against the
/// chunks written finds how far it got, so at most the stroke it was drawing
/// is drawn twice (before: the locate's ESC.O went unanswered, the resume
/// went on from the checkpoint, and the buffer's strokes were drawn again).
#[test]
fn a_clone_without_esc_o_unplugged_mid_job_draws_at_most_one_stroke_twice() {
    let sim = SimConfig::hp7475a().with_speed_scale(1.0).with_baud(9600).with_quirks([Quirk::NoEscO]);
    let rig = Rig::start(sim, "hp7475a", "escb", "");
    let job = hpgl_lines(150, 3);
    let id = rig.submit(JobKind::Hpgl, &job);
    rig.sim.wait_received(job.len() as u64 / 3, LONG).unwrap();
    rig.sim.unplug(Duration::from_millis(300)).unwrap();
    rig.resume_after_replug(id, LONG);
    rig.wait_state(id, State::Done, LONG);
    rig.sim.wait_idle(Duration::from_secs(20)).unwrap();
    assert_plotted(&rig.sim, &strokes_of(&job, "hp7475a"), 1);
}

/// `plotd home` on a machine with homing switches (`homing = true`), its
/// board locked until homed: the homing cycle runs (`$H`, never `$X`) and
/// the answer comes once the board confirmed it: it is out of alarm, at
/// its home. A job then plots without waiting `needs-homing`.
#[test]
fn home_homes_a_board_locked_until_homed() {
    let rig = rig(&[Quirk::HomingRequired], "homing = true");
    rig.sim.wait_idle(LONG).unwrap();
    assert_eq!(rig.sim.status().device.state, "Alarm");
    let message = match rig.client().call(&Request::Home { plotter: None }).unwrap() {
        Reply::Ok { message } => message,
        other => panic!("{other:?}"),
    };
    assert_eq!(message, "plotter p homed");
    let st = rig.sim.status().device;
    // At the simulated machine's home: its switches, pulled off by `$27` = 1 mm.
    assert_eq!((st.state.as_str(), st.position, st.pen_down), ("Idle", [-1.0, -1.0], false));
    assert!(!rig.sim.record().unlocked_without_homing, "$X sent instead of $H");
    let text = lattice();
    let id = rig.submit(JobKind::Gcode, &text);
    drawn_once_when_done(&rig, id, &text, 0);
}
