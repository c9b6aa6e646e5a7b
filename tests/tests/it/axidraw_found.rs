//! An EiBotBoard found rather than named by its port (issue 37): `port =
//! "auto"` and `nickname = "..."`, the daemon reading a sysfs tree of the
//! rig's own where the virtual EBB's pty is a USB device 04D8:FD92.

use plotd::protocol::{LinkState, Reply, Request, State};
use plotd::spool::JobKind;
use plotd_e2e::ebb::zigzags;
use plotd_e2e::{wait_for, DaemonHandle, Rig};
use plotsim::{Firmware, SimConfig};
use std::time::Duration;

const WAIT: Duration = Duration::from_secs(60);

/// The virtual EBB of `fw` named `nickname`, plotting at once.
fn board(fw: Firmware, nickname: &str) -> SimConfig {
    let mut sim = SimConfig::ebb(fw).with_speed_scale(0.0).with_baud(115_200);
    sim.ebb.nickname = nickname.to_owned();
    sim
}

/// A job on the plotter the rig's daemon found: done, every stroke drawn.
fn plots(rig: &Rig, what: &str) {
    let id = rig.submit(JobKind::Scene, &zigzags(3));
    let job = rig.wait_state(id, State::Done, WAIT);
    assert_eq!(Some(job.checkpoint), job.total, "{what}");
    rig.sim.wait_idle(WAIT).unwrap();
    let record = rig.sim.record();
    assert!(record.errors.is_empty(), "{what}: {:?}", record.errors);
    assert_eq!(record.strokes.len(), 3, "{what}: {:?}", record.strokes);
}

#[test]
fn auto_finds_the_one_ebb_among_the_usb_serial_ports() {
    let rig = Rig::start_found(board(Firmware::V2_8_1, ""), "port = \"auto\"", "");
    plots(&rig, "auto");
}

/// The board whose `QT` answers the nickname, on both firmwares (3.0.2's
/// nickname answered by a board asked in the legacy syntax, as a board
/// fresh from a reset is).
#[test]
fn a_nickname_finds_the_board_that_answers_it() {
    for fw in Firmware::ALL {
        let rig = Rig::start_found(board(fw, "left"), "nickname = \"left\"", "");
        plots(&rig, &format!("{fw}"));
    }
}

/// No board answers the nickname: the plotter is offline with a cause that
/// lists what each EiBotBoard answered (the FTDI adapter beside it is not
/// asked), and a job waits for it.
#[test]
fn a_nickname_no_board_answers_is_offline_saying_what_was_seen() {
    let rig = Rig::start_found(board(Firmware::V3_0_2, "left"), "nickname = \"right\"", "");
    let pty = rig.sim.slave_path().unwrap();
    let want = format!("no EiBotBoard with nickname \"right\" found (seen: {} (04d8:fd92 \"EiBotBoard\") named \"left\")", pty.display());
    let mut seen = None;
    wait_for("the plotter offline with its cause", WAIT, || {
        let Ok(Reply::Status { plotters, .. }) = rig.client().call(&Request::Status {}) else { return false };
        seen = plotters[0].cause.as_ref().map(|c| c.message.clone());
        plotters[0].link == LinkState::Offline && seen.is_some()
    });
    assert_eq!(seen.as_deref(), Some(want.as_str()));
    let id = rig.submit(JobKind::Scene, &zigzags(1));
    assert_ne!(rig.job(id).state, State::Done);
    assert!(rig.sim.record().strokes.is_empty());
}
