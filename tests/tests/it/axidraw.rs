//! plotcode's EBB program played on plotsim's virtual EiBotBoard (issue
//! 37): the firmware-exact step arithmetic of another implementation draws
//! the strokes plotcode's own reader says the program draws.

use plotd_e2e::{render_for, repo_root, strokes_of};
use plotsim::{Firmware, SimConfig, Simulator};
use std::io::Write as _;
use std::time::Duration;

const WAIT: Duration = Duration::from_secs(60);

/// One step of an AxiDraw at 1/16 microstepping, mm.
const STEP_MM: f64 = 0.0125;

/// The cube for `axidraw`, written whole to the board (its USB flow control
/// holds the rest in the pty while its FIFO is full), on 2.8.1 and 3.0.2:
/// every stroke, each point the program stops at within a step of a point
/// the board drew (and the other way round), nothing overrun, no error, and
/// the board's plot time the one plotcode's chunks add up to.
#[test]
fn the_cube_program_draws_its_strokes_on_the_virtual_ebb() {
    let text = render_for(&repo_root().join("examples/cube.toml"), "axidraw");
    // Device steps (y from home towards the operator) to the record's mm (y up).
    let want: Vec<Vec<[f64; 2]>> = strokes_of(&text, "axidraw")
        .into_iter()
        .map(|(_, points)| points.iter().map(|p| [p[0] * STEP_MM, -p[1] * STEP_MM]).collect())
        .collect();
    assert_eq!(want.len(), 3, "the cube's strokes");
    for fw in Firmware::ALL {
        let sim = Simulator::start(SimConfig::ebb(fw).with_speed_scale(0.0)).unwrap();
        let mut port = std::fs::OpenOptions::new().read(true).write(true).open(sim.slave_path().unwrap()).unwrap();
        port.write_all(text.as_bytes()).unwrap();
        sim.wait_received(text.len() as u64, WAIT).unwrap();
        sim.wait_idle(WAIT).unwrap();
        let record = sim.record();
        assert_eq!(record.overruns, 0, "{fw}");
        assert!(record.errors.is_empty(), "{fw}: {:?}", record.errors);
        let got: Vec<&Vec<[f64; 2]>> = record.strokes.iter().map(|s| &s.points).collect();
        assert_eq!(got.len(), want.len(), "{fw}: {got:?}");
        let near = |p: &[f64; 2], points: &[[f64; 2]]| points.iter().any(|q| (p[0] - q[0]).hypot(p[1] - q[1]) <= STEP_MM);
        for (k, (g, w)) in got.iter().zip(&want).enumerate() {
            assert!(w.iter().all(|p| near(p, g)), "{fw} stroke {k}: planned {w:?}, drawn {g:?}");
            assert!(g.iter().all(|p| near(p, w)), "{fw} stroke {k}: drawn {g:?}, planned {w:?}");
        }
        let profile = plotcode::DeviceProfile::builtin("axidraw").unwrap();
        let estimate = plotcode::cut(text.as_bytes(), &profile).unwrap().seconds_from(0);
        // 22.7951 s on the board, 22.7950 s planned (both firmwares): the
        // estimate the daemon counts down is the board's time.
        assert!((record.plot_seconds - estimate).abs() <= 1e-3, "{fw}: board {} s, plotcode {estimate} s", record.plot_seconds);
    }
}
