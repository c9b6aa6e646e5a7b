//! The HP 7475A personality over a real pty: flow control, overflow, faults.

use crate::common;

use common::{hpgl_zigzag, Port, WAIT};
use plotsim::{SimConfig, Simulator};
use std::time::Duration;

fn instant_hp() -> Simulator {
    Simulator::start(SimConfig::hp7475a().with_speed_scale(0.0).with_baud(115_200)).unwrap()
}

#[test]
fn a_plot_arrives_whole_and_is_recorded() {
    let sim = instant_hp();
    let mut port = Port::open(&sim.slave_path().unwrap());
    port.send(b"IN;SP2;PU100,100;PD200,100,200,200;PU;");
    assert_eq!(port.ask(b"OA;"), "200,200,0");
    let r = sim.record();
    assert_eq!(r.strokes.len(), 1);
    assert_eq!(r.strokes[0].pen, 2);
    assert_eq!(r.strokes[0].points, vec![[100.0, 100.0], [200.0, 100.0], [200.0, 200.0]]);
    assert_eq!(r.overruns, 0);
    sim.wait_idle(WAIT).unwrap();
}

#[test]
fn a_writer_that_ignores_flow_control_overflows_the_buffer() {
    let sim = instant_hp();
    let mut port = Port::open(&sim.slave_path().unwrap());
    // Paper lever up: nothing drains, so the outcome does not depend on timing.
    sim.lever(true).unwrap();
    let job = vec![b' '; 2000];
    port.send(&job);
    sim.wait_received(2000, WAIT).unwrap();
    let s = sim.status();
    assert_eq!(s.overruns, 2000 - 1024);
    assert_eq!(s.device.buffer_used, 1024);
    assert_eq!(port.ask(b"\x1b.B"), "0");
    assert_eq!(port.ask(b"\x1b.E"), "16");
    assert_eq!(port.ask(b"\x1b.O"), "32");
    assert_eq!(sim.record().overruns, 976);
}

/// The replies count what the device answered: a query or output
/// instruction each, not the instructions that answer nothing.
#[test]
fn replies_count_each_answer() {
    let sim = instant_hp();
    let mut port = Port::open(&sim.slave_path().unwrap());
    let job = b"IN;SP1;PU100,100;PD200,100;PU;";
    port.send(job);
    sim.wait_received(job.len() as u64, WAIT).unwrap();
    sim.wait_idle(WAIT).unwrap();
    assert_eq!(sim.status().replies, 0);
    assert_eq!(port.ask(b"\x1b.B"), "1024");
    assert_eq!(port.ask(b"OE;"), "0");
    assert_eq!(port.ask(b"OA;"), "200,100,0");
    assert_eq!(sim.status().replies, 3);
}

#[test]
fn a_naive_writer_overflows_a_plotter_that_is_slower_than_the_line() {
    // Plotting at a twentieth of real time is still far slower than 115200 baud.
    let sim = Simulator::start(SimConfig::hp7475a().with_speed_scale(0.05).with_baud(115_200)).unwrap();
    let mut port = Port::open(&sim.slave_path().unwrap());
    let job = hpgl_zigzag(400, 800);
    port.send(&job);
    sim.wait_received(job.len() as u64, WAIT).unwrap();
    assert!(sim.status().overruns > 0);
    assert_eq!(port.ask(b"\x1b.E"), "16");
}

#[test]
fn a_writer_that_polls_esc_b_never_overflows() {
    let sim = Simulator::start(SimConfig::hp7475a().with_speed_scale(0.05).with_baud(115_200)).unwrap();
    let mut port = Port::open(&sim.slave_path().unwrap());
    let job = hpgl_zigzag(400, 800);
    let mut sent = 0;
    let mut min_free = usize::MAX;
    while sent < job.len() {
        let free: usize = port.ask(b"\x1b.B").parse().unwrap();
        min_free = min_free.min(free);
        let n = free.min(job.len() - sent).min(256);
        port.send(&job[sent..sent + n]);
        sent += n;
    }
    sim.wait_idle(WAIT).unwrap();
    let r = sim.record();
    assert_eq!(r.overruns, 0);
    assert!(r.errors.is_empty(), "{:?}", r.errors);
    assert_eq!(r.strokes.len(), 1);
    assert_eq!(r.strokes[0].points.len(), 401);
    assert!(min_free < 64, "the buffer really filled: {min_free} bytes free at the lowest");
    assert_eq!(port.ask(b"\x1b.E"), "0");
}

#[test]
fn a_writer_that_honours_xon_xoff_never_overflows() {
    let sim = Simulator::start(SimConfig::hp7475a().with_speed_scale(0.05).with_baud(115_200)).unwrap();
    let mut port = Port::open(&sim.slave_path().unwrap());
    port.send(b"\x1b.I80;;17:\x1b.N;19:");
    let mut received = sim.wait_received(10, WAIT).unwrap().bytes_received;
    let job = hpgl_zigzag(400, 800);
    // The lever holds the pen until the first XOFF, so the buffer fills
    // however slowly a loaded machine runs this writer (else the plotter
    // could drain as fast as it writes and never ask it to stop).
    sim.lever(true).unwrap();
    let (mut sent, mut xoffs, mut stopped) = (0, 0, false);
    while sent < job.len() {
        // Like a UART: a few bytes at a time, each chunk on the wire before the next.
        port.poll_in(Duration::ZERO).unwrap();
        for b in std::mem::take(&mut port.inbox) {
            match b {
                0x13 => {
                    stopped = true;
                    xoffs += 1;
                    if xoffs == 1 {
                        sim.lever(false).unwrap();
                    }
                }
                0x11 => stopped = false,
                other => panic!("unexpected byte {other:#x}"),
            }
        }
        if stopped {
            port.poll_in(Duration::from_millis(50)).unwrap();
            continue;
        }
        let n = 8.min(job.len() - sent);
        port.send(&job[sent..sent + n]);
        sent += n;
        received = sim.wait_received(received + n as u64, WAIT).unwrap().bytes_received;
    }
    sim.wait_idle(WAIT).unwrap();
    let r = sim.record();
    assert!(xoffs > 0, "the buffer filled and XOFF was sent");
    assert_eq!(r.overruns, 0);
    assert_eq!(r.strokes[0].points.len(), 401);
}

#[test]
fn lever_up_pauses_and_lever_down_resumes() {
    let sim = instant_hp();
    let mut port = Port::open(&sim.slave_path().unwrap());
    sim.lever(true).unwrap();
    port.send(b"SP1;PD0,0,100,0;PU;");
    sim.wait_received(19, WAIT).unwrap();
    assert_eq!(port.ask(b"\x1b.O"), "32");
    assert!(sim.record().strokes.is_empty());
    assert!(sim.wait_idle(Duration::from_millis(300)).is_err(), "a paused plotter is not idle");
    sim.lever(false).unwrap();
    sim.wait_idle(WAIT).unwrap();
    assert_eq!(port.ask(b"\x1b.O"), "8");
    assert_eq!(sim.record().strokes.len(), 1);
}

#[test]
fn stall_stops_draining_for_a_while() {
    let sim = instant_hp();
    let mut port = Port::open(&sim.slave_path().unwrap());
    sim.stall(Duration::from_millis(400)).unwrap();
    port.send(b"SP1;PD0,0,100,0;PU;");
    let s = sim.wait_received(19, WAIT).unwrap();
    assert!(s.stalled);
    assert_eq!(s.device.buffer_used, 19, "bytes wait in the buffer");
    assert_eq!(port.ask(b"\x1b.B"), (1024 - 19).to_string(), "device control still answers");
    sim.wait_idle(WAIT).unwrap();
    assert_eq!(sim.record().strokes.len(), 1);
}

#[test]
fn garbage_and_injected_errors() {
    let sim = instant_hp();
    let mut port = Port::open(&sim.slave_path().unwrap());
    sim.garbage();
    let g = port.ask(b"\x1b.B");
    assert!(g.parse::<u32>().is_err(), "garbage, not a number: {g:?}");
    assert_eq!(port.ask(b"\x1b.B"), "1024");
    sim.fail_next(None);
    port.send(b"SP1;");
    assert_eq!(port.ask(b"OE;"), "1");
    assert_eq!(sim.record().faults.len(), 2);
}

#[test]
fn power_cycle_loses_the_buffer_and_state() {
    let sim = instant_hp();
    let mut port = Port::open(&sim.slave_path().unwrap());
    sim.lever(true).unwrap();
    port.send(b"SP1;PD0,0,100,0;ZZ;");
    sim.wait_received(19, WAIT).unwrap();
    sim.power_cycle();
    sim.lever(false).unwrap();
    assert_eq!(port.ask(b"\x1b.B"), "1024");
    assert_eq!(port.ask(b"OS;"), "24", "initialized, ready, no error");
    assert!(sim.record().strokes.is_empty());
}

#[test]
fn unplug_hangs_up_the_host_and_replugs_at_the_same_link() {
    let dir = std::env::temp_dir().join(format!("plotsim-unplug-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let link = dir.join("ttyPLOT");
    let sim = Simulator::start(SimConfig::hp7475a().with_speed_scale(0.0).with_link(&link)).unwrap();
    let first = sim.slave_path().unwrap();
    assert_eq!(std::fs::read_link(&link).unwrap(), first);
    let mut port = Port::open(&link);
    assert_eq!(port.ask(b"OI;"), "7475A");
    sim.unplug(Duration::from_millis(300)).unwrap();
    assert!(std::fs::symlink_metadata(&link).is_err(), "the device node is gone while unplugged");
    // The host sees a hang-up: EOF or EIO.
    let mut hung_up = false;
    for _ in 0..100 {
        if port.poll_in(Duration::from_millis(50)).is_err() {
            hung_up = true;
            break;
        }
    }
    assert!(hung_up);
    let second = sim.wait_connected(WAIT).unwrap();
    assert_eq!(std::fs::read_link(&link).unwrap(), second);
    let mut port = Port::open(&link);
    assert_eq!(port.ask(b"OI;"), "7475A");
    assert_eq!(sim.record().faults[0].kind, "unplug");
    drop(sim);
    assert!(std::fs::symlink_metadata(&link).is_err(), "shutdown removes the link");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bytes_arrive_at_the_baud_rate() {
    // 960 bytes at 9600 baud take about a second on the wire.
    let sim = Simulator::start(SimConfig::hp7475a().with_speed_scale(0.0).with_baud(9600)).unwrap();
    let mut port = Port::open(&sim.slave_path().unwrap());
    let t0 = std::time::Instant::now();
    port.send(&[b' '; 960]);
    sim.wait_received(960, WAIT).unwrap();
    let took = t0.elapsed();
    assert!(took >= Duration::from_millis(950), "{took:?}");
}
