//! Stutter on an EiBotBoard: strokes made of 2 ms moves streamed to plotsim's
//! virtual EBB in real time (speed scale 1), and the time its motion FIFO
//! stood empty between one command and the next (the record's
//! `starved_seconds`; target: none beyond what the board itself needs to
//! load a command). Each firmware twice: the program written whole to the
//! port (the board's USB flow control keeps its FIFO fed: the baseline),
//! and streamed by plotd's streamer (a window of commands in flight, each
//! `OK` letting the next go, with `QS`/`QG`/`QC` polls between). Prints a
//! table. Run: `cargo bench -p plotd --bench ebb_stutter`.

use plotcode::Handshake;
use plotd::stream::{SerialPort, Span, StreamSettings, Streamer};
use plotsim::{Firmware, SimConfig, Simulator};
use std::io::Write as _;
use std::time::{Duration, Instant};

/// Strokes of the job.
const STROKES: usize = 8;
/// 2 ms moves in each stroke.
const MOVES: usize = 150;

/// `STROKES` strokes of `MOVES` moves of 2 ms each (8 steps on each motor,
/// 4000 steps/s), the pen lowered before each and raised after.
fn job() -> String {
    let mut s = String::from("SC,4,20641\rSC,5,15248\rEM,1,1\r");
    for k in 0..STROKES {
        s += "SP,0,100\r";
        let dir = if k % 2 == 0 { 8 } else { -8 };
        for _ in 0..MOVES {
            s += &format!("SM,2,{dir},8\r");
        }
        s += "SP,1,100\r";
    }
    s
}

/// Seconds starved, seconds of motion, wall seconds.
fn run(fw: Firmware, streamed: bool, text: &str) -> (f64, f64, f64) {
    let sim = Simulator::start(SimConfig::ebb(fw).with_speed_scale(1.0)).expect("simulator");
    let path = sim.slave_path().expect("pty");
    let t = Instant::now();
    if streamed {
        let program = plotcode::cut(text.as_bytes(), &plotcode::DeviceProfile::builtin("axidraw").expect("profile")).expect("program");
        let rt = tokio::runtime::Runtime::new().expect("runtime");
        rt.block_on(async {
            let port = SerialPort::open(&path, 115_200, false).expect("port");
            let mut s = Streamer::new(port, StreamSettings::new(Handshake::Ebb));
            let (_tx, mut stop) = tokio::sync::watch::channel(plotd::stream::Stop::Continue);
            s.run(Span::all(&program), &mut stop, &mut |_: usize| {}).await.expect("streams");
        });
    } else {
        let mut port = std::fs::OpenOptions::new().read(true).write(true).open(&path).expect("port");
        // The OKs are read by no one: the pty holds them.
        port.write_all(text.as_bytes()).expect("written");
        sim.wait_received(text.len() as u64, Duration::from_secs(60)).expect("received");
    }
    sim.wait_idle(Duration::from_secs(60)).expect("idle");
    let wall = t.elapsed().as_secs_f64();
    let record = sim.record();
    assert!(record.errors.is_empty(), "{fw}: {:?}", record.errors);
    (record.starved_seconds, record.plot_seconds, wall)
}

/// Runs of each case: the simulator runs in real time, and a thread of it
/// held off the CPU counts as the FIFO standing empty too, so the median
/// and the worst of a few runs are shown (and the baseline says how much
/// of it the machine's load makes).
const RUNS: usize = 3;

fn main() {
    let text = job();
    let moves = STROKES * MOVES;
    println!("| firmware | how | 2 ms moves | FIFO empty between commands, ms: median (worst) of {RUNS} | per move, us (median) | motion s | wall s |");
    println!("|---|---|---|---|---|---|---|");
    for fw in Firmware::ALL {
        for (streamed, how) in [(false, "written whole (baseline)"), (true, "plotd streamer")] {
            let mut runs: Vec<(f64, f64, f64)> = (0..RUNS).map(|_| run(fw, streamed, &text)).collect();
            runs.sort_by(|a, b| a.0.total_cmp(&b.0));
            let (starved, motion, wall) = runs[RUNS / 2];
            println!(
                "| {fw} | {how} | {moves} | {:.2} ({:.2}) | {:.1} | {motion:.2} | {wall:.2} |",
                starved * 1e3,
                runs[RUNS - 1].0 * 1e3,
                starved * 1e6 / moves as f64
            );
        }
    }
}
