//! plotcode's EBB program played on plotsim's virtual EiBotBoard (issue
//! 37): the firmware-exact step arithmetic of another implementation draws
//! the strokes plotcode's own reader says the program draws.

use plotd::protocol::State;
use plotd::spool::JobKind;
use plotd_e2e::{render_for, repo_root, strokes_of, DaemonHandle, Rig};
use plotsim::{Firmware, SimConfig, Simulator};
use std::io::Write as _;
use std::time::Duration;

const WAIT: Duration = Duration::from_secs(60);

/// Whether `p` is within a step of one of `points`.
fn near(p: &[f64; 2], points: &[[f64; 2]]) -> bool {
    points.iter().any(|q| (p[0] - q[0]).hypot(p[1] - q[1]) <= STEP_MM)
}

/// Whether a drawn stroke is a planned one: each point of either within a
/// step of a point of the other (the board may report a straight run of
/// blocks as one line).
fn same_stroke(drawn: &[[f64; 2]], planned: &[[f64; 2]]) -> bool {
    planned.iter().all(|p| near(p, drawn)) && drawn.iter().all(|p| near(p, planned))
}

/// The cube's program for the AxiDraw, and the strokes it draws in the
/// record's millimetres (y up).
fn cube() -> (String, Vec<Vec<[f64; 2]>>) {
    dry_run("examples/cube.toml")
}

/// The AxiDraw program of the scene at `path` (in the repository), and the
/// strokes it draws in the record's millimetres (y up).
fn dry_run(path: &str) -> (String, Vec<Vec<[f64; 2]>>) {
    let text = render_for(&repo_root().join(path), "axidraw");
    // Device steps (y from home towards the operator) to the record's mm (y up).
    let want = strokes_of(&text, "axidraw")
        .into_iter()
        .map(|(_, points)| points.iter().map(|p| [p[0] * STEP_MM, -p[1] * STEP_MM]).collect())
        .collect();
    (text, want)
}

/// A virtual EBB of `fw`, plotting at once, and a host's end of its port.
fn board(fw: Firmware) -> (Simulator, std::fs::File) {
    let sim = Simulator::start(SimConfig::ebb(fw).with_speed_scale(0.0)).unwrap();
    let port = std::fs::OpenOptions::new().read(true).write(true).open(sim.slave_path().unwrap()).unwrap();
    (sim, port)
}

/// One step of an AxiDraw at 1/16 microstepping, mm.
const STEP_MM: f64 = 0.0125;

/// The cube for `axidraw`, written whole to the board (its USB flow control
/// holds the rest in the pty while its FIFO is full), on 2.8.1 and 3.0.2:
/// every stroke, each point the program stops at within a step of a point
/// the board drew (and the other way round), nothing overrun, no error, and
/// the board's plot time the one plotcode's chunks add up to.
#[test]
fn the_cube_program_draws_its_strokes_on_the_virtual_ebb() {
    let (text, want) = cube();
    assert_eq!(want.len(), 2, "the cube's strokes");
    for fw in Firmware::ALL {
        let (sim, mut port) = board(fw);
        port.write_all(text.as_bytes()).unwrap();
        sim.wait_received(text.len() as u64, WAIT).unwrap();
        sim.wait_idle(WAIT).unwrap();
        let record = sim.record();
        assert_eq!(record.overruns, 0, "{fw}");
        assert!(record.errors.is_empty(), "{fw}: {:?}", record.errors);
        let got: Vec<&Vec<[f64; 2]>> = record.strokes.iter().map(|s| &s.points).collect();
        assert_eq!(got.len(), want.len(), "{fw}: {got:?}");
        for (k, (g, w)) in got.iter().zip(&want).enumerate() {
            assert!(same_stroke(g, w), "{fw} stroke {k}: drawn {g:?}, planned {w:?}");
        }
        let profile = plotcode::DeviceProfile::builtin("axidraw").unwrap();
        let estimate = plotcode::cut(text.as_bytes(), &profile).unwrap().seconds_from(0);
        // The board's time and the plan agree within 1 ms (both firmwares):
        // the estimate the daemon counts down is the board's time.
        assert!((record.plot_seconds - estimate).abs() <= 1e-3, "{fw}: board {} s, plotcode {estimate} s", record.plot_seconds);
    }
}

/// Plotting stops half way through the second stroke (its chunk's first
/// commands sent, the rest not); the daemon then sends that chunk's resume
/// prefix and every chunk from it on. The board draws the first stroke once,
/// the start of the second, then the second whole: the prefix
/// (servo set-up, pen up, `HM` to where the chunk starts) puts the carriage
/// where the chunk expects it, on both firmwares.
#[test]
fn a_chunk_resumed_after_an_interruption_draws_the_rest_on_the_virtual_ebb() {
    let (text, want) = cube();
    let profile = plotcode::DeviceProfile::builtin("axidraw").unwrap();
    let program = plotcode::cut(text.as_bytes(), &profile).unwrap();
    assert!(program.chunks[1].draws);
    let cut_short = &program.chunks[1].bytes;
    // Up to the carriage return that ends the command half way in.
    let half = cut_short[..cut_short.len() / 2].iter().rposition(|&b| b == b'\r').unwrap() + 1;
    for fw in Firmware::ALL {
        let (sim, mut port) = board(fw);
        let mut sent = program.chunks[0].bytes.clone();
        sent.extend_from_slice(&cut_short[..half]);
        sent.extend_from_slice(&program.chunks[1].resume);
        for c in &program.chunks[1..] {
            sent.extend_from_slice(&c.bytes);
        }
        port.write_all(&sent).unwrap();
        sim.wait_received(sent.len() as u64, WAIT).unwrap();
        sim.wait_idle(WAIT).unwrap();
        let record = sim.record();
        assert!(record.errors.is_empty(), "{fw}: {:?}", record.errors);
        let got: Vec<&Vec<[f64; 2]>> = record.strokes.iter().map(|s| &s.points).collect();
        assert_eq!(got.len(), 3, "{fw}: {got:?}");
        assert!(same_stroke(got[0], &want[0]), "{fw}: first stroke {:?}", got[0]);
        // The start of the second stroke, up to where it stopped.
        assert!(near(&got[1][0], &want[1][..1]) && got[1].iter().all(|p| near(p, &want[1])), "{fw}: {:?}", got[1]);
        assert!(same_stroke(got[2], &want[1]), "{fw}: {got:?}");
    }
}

/// A scene (the box with a hole: the cube's mesh is a file a job would
/// have to send beside it) submitted to a daemon whose plotter is the virtual
/// EBB, on 2.8.1 and 3.0.2: the job ends done with every chunk confirmed by
/// the step counters, and the board drew the dry run's strokes, in order,
/// each point within a step (0.0125 mm) of the other's.
#[test]
fn the_daemon_plots_a_scene_on_the_virtual_ebb_as_the_dry_run_draws_it() {
    let (_, want) = dry_run("examples/box_with_hole.toml");
    let scene = std::fs::read_to_string(repo_root().join("examples/box_with_hole.toml")).unwrap();
    for fw in Firmware::ALL {
        // The board ignores the baud rate; the config takes only standard ones.
        let rig = Rig::start(SimConfig::ebb(fw).with_speed_scale(0.0).with_baud(115_200), "axidraw", "ebb", "");
        let id = rig.submit(JobKind::Scene, &scene);
        let job = rig.wait_state(id, State::Done, WAIT);
        assert_eq!(Some(job.checkpoint), job.total, "{fw:?}");
        rig.sim.wait_idle(WAIT).unwrap();
        let record = rig.sim.record();
        assert!(record.errors.is_empty(), "{fw:?}: {:?}", record.errors);
        let drawn: Vec<_> = record.strokes.iter().map(|s| s.points.clone()).collect();
        assert_eq!(drawn.len(), want.len(), "{fw:?}: strokes drawn");
        for (i, (d, w)) in drawn.iter().zip(&want).enumerate() {
            assert!(same_stroke(d, w), "{fw:?}: stroke {i} drawn {d:?}, planned {w:?}");
        }
    }
}

/// The board's answers on `port` as plotcode reads them, up to the first
/// line `last` accepts.
fn answers_until(port: &mut std::fs::File, last: impl Fn(&str) -> bool) -> Vec<String> {
    use nix::poll::{poll, PollFd, PollFlags, PollTimeout};
    use std::io::Read as _;
    use std::os::fd::AsFd as _;
    let (mut lines, mut reader) = (Vec::new(), plotcode::answer::AnswerLines::default());
    let until = std::time::Instant::now() + WAIT;
    loop {
        while let Some(line) = reader.next_line() {
            let done = last(&line.text);
            lines.push(line.text);
            if done {
                return lines;
            }
        }
        let left = until.saturating_duration_since(std::time::Instant::now());
        assert!(!left.is_zero(), "no last answer; have {lines:?}");
        let mut fds = [PollFd::new(port.as_fd(), PollFlags::POLLIN)];
        if poll(&mut fds, PollTimeout::try_from(left).unwrap_or(PollTimeout::MAX)).unwrap() > 0 {
            let mut buf = [0; 1024];
            let n = port.read(&mut buf).unwrap();
            reader.feed(&buf[..n]);
        }
    }
}

/// The cable pulled inside `LM`'s last required number leaves the start of
/// the command in the board's line buffer; every session on the port
/// opened again begins with `V` (what [`Op::Version`] writes). The half
/// command must not run with it as its tail: `LM,...,-222,-2` then `V`
/// reads as an acceleration of -2 (the `V` is an extra character, refused
/// only after the move is queued), and the carriage went a millimetre off
/// its line with the pen down (seen in `axidraw_faults` on 2.8.1). On
/// 2.8.1 and 3.0.2: the first answer is the version, no step is made, the
/// board logs no error.
#[test]
fn a_half_command_left_by_an_unplug_never_runs_with_the_version_probe_as_its_tail() {
    use plotcode::answer::ebb::Steps;
    use plotcode::control::ebb::Op;
    for fw in Firmware::ALL {
        let (sim, mut port) = board(fw);
        let half = b"EM,1,1\rLM,460810063,665,-73736,153835397,-222,-2";
        port.write_all(half).unwrap();
        sim.wait_received(half.len() as u64, WAIT).unwrap();
        sim.unplug(Duration::from_millis(50)).unwrap();
        drop(port);
        let mut port = std::fs::OpenOptions::new().read(true).write(true).open(sim.wait_connected(WAIT).unwrap()).unwrap();
        port.write_all(&[Op::Version.bytes(), Op::Steps.bytes()].concat()).unwrap();
        let answers = answers_until(&mut port, |l| Steps::parse(l).is_some());
        assert_eq!(
            answers.first().and_then(|l| plotcode::ebb::Firmware::from_version_answer(l)).map(|v| v.to_string()),
            Some(fw.to_string()),
            "{fw}: {answers:?}"
        );
        assert_eq!(answers.last().and_then(|l| Steps::parse(l)).map(|s| (s.0.m1, s.0.m2)), Some((0, 0)), "{fw}: {answers:?}");
        sim.wait_idle(WAIT).unwrap();
        let record = sim.record();
        assert!(record.errors.is_empty() && record.travel.is_empty(), "{fw}: {:?}, moved to {:?}", record.errors, record.travel);
    }
}
