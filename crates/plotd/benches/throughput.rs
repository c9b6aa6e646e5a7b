//! Streaming throughput against plotsim with instant plotting (speed scale 0):
//! HP-GL at 9600 baud, `escb` handshake (target: job bytes, markers and
//! queries excluded, at least 90 % of the line rate), GRBL at 115200 baud with character counting (target: the 128-byte
//! receive buffer at least 90 % full on average). Prints a table.
//! Run: `cargo bench -p plotd --bench throughput`.

use plotcode::Handshake;
use plotd::stream::{SerialPort, Span, StreamSettings, Streamer};
use std::time::{Duration, Instant};

fn hpgl_job(bytes: usize) -> String {
    let mut s = String::from("IN;SP1;");
    let mut i = 0;
    while s.len() < bytes {
        s.push_str(&format!("PU{},{};PD{},{},{},{};", i % 9000, i % 6000, (i * 7) % 9000, (i * 3) % 6000, (i * 5) % 9000, i % 6000));
        i += 1;
    }
    s.push_str("PU;SP0;");
    s
}

fn gcode_job(bytes: usize) -> String {
    let mut s = String::from("G21 G90\nM5\n");
    let mut i = 0;
    while s.len() < bytes {
        s.push_str(&format!(
            "G0 X{} Y{}\nM3 S1000\nG1 X{} Y{} F3000\nG1 X{} Y{}\nM5\n",
            i % 200,
            i % 150,
            (i * 7) % 200,
            (i * 3) % 150,
            (i * 5) % 200,
            i % 150
        ));
        i += 1;
    }
    s
}

/// Seconds, the streamer's measurements, every byte written (markers
/// included, queries not), the device's overruns.
fn run(sim: plotsim::SimConfig, baud: u32, handshake: Handshake, device: &str, text: &str) -> (f64, plotd::stream::StreamStats, u64, u64) {
    let sim = plotsim::Simulator::start(sim.with_speed_scale(0.0)).expect("simulator");
    let path = sim.slave_path().expect("pty");
    let program = plotcode::cut(text.as_bytes(), &plotcode::DeviceProfile::builtin(device).expect("profile")).expect("program");
    let rt = tokio::runtime::Runtime::new().expect("runtime");
    let (secs, stats, written) = rt.block_on(async {
        let port = SerialPort::open(&path, baud, false).expect("port");
        let mut s = Streamer::new(port, StreamSettings::new(handshake));
        let (_tx, mut stop) = tokio::sync::watch::channel(plotd::stream::Stop::Continue);
        let t = Instant::now();
        s.run(Span::all(&program), &mut stop, &mut |_: usize| {}).await.expect("streams");
        (t.elapsed().as_secs_f64(), s.stats.clone(), s.link.written)
    });
    sim.wait_idle(Duration::from_secs(30)).expect("idle");
    (secs, stats, written, sim.record().overruns)
}

fn main() {
    let hp_text = hpgl_job(12_000);
    let (secs, stats, written, over) = run(plotsim::SimConfig::hp7475a().with_baud(9600), 9600, Handshake::Escb, "hp7475a", &hp_text);
    let line = 9600.0 / 10.0;
    let rate = stats.bytes as f64 / secs;
    let g_text = gcode_job(200_000);
    let (gsecs, gstats, _, gover) = run(plotsim::SimConfig::grbl().with_baud(115_200), 115_200, Handshake::Grbl, "grbl-servo", &g_text);
    println!("| case | bytes | seconds | result | target | overruns |");
    println!("|---|---|---|---|---|---|");
    println!(
        "| HP-GL 9600 baud, escb | {} | {secs:.2} | {:.1} % of line rate ({rate:.0} B/s of {line:.0}; line busy {:.1} %, markers included) | >= 90 % | {over} |",
        stats.bytes,
        100.0 * rate / line,
        100.0 * written as f64 / secs / line
    );
    println!(
        "| GRBL 115200 baud, char counting | {} | {gsecs:.2} | buffer {:.1} % full on average | >= 90 % | {gover} |",
        gstats.bytes,
        100.0 * gstats.average_fill().unwrap_or(0.0)
    );
}
