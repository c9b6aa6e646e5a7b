//! The `plotsim` command line and its long-running entry point.

use crate::config::{Firmware, GrblPen, Personality, SimConfig};
use crate::control::{self, SaveTargets};
use crate::simulator::Simulator;
use crate::{Quirk, SimError};
use clap::Parser;
use std::future::Future;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use tokio::io::{AsyncBufReadExt, AsyncWriteExt, BufReader};
use tokio::net::{UnixListener, UnixStream};

/// A virtual HP-GL, GRBL or EiBotBoard (AxiDraw) pen plotter on a pseudo-terminal.
#[derive(Clone, Debug, Parser)]
#[command(name = "plotsim", version)]
pub struct Args {
    /// hp7475a, grbl or ebb.
    #[arg(long, value_parser = parse_personality)]
    pub personality: Personality,
    /// EBB firmware: 2.8.1 or 3.0.2.
    #[arg(long, default_value = "2.8.1", value_parser = parse_firmware)]
    pub firmware: Firmware,
    /// EBB: the nickname in the board's flash at start (QT).
    #[arg(long, default_value = "")]
    pub nickname: String,
    /// Make this a symlink to the pty slave (re-made after an unplug).
    #[arg(long)]
    pub link: Option<PathBuf>,
    /// Serial speed; bytes arrive at baud/10 per second (0: unpaced; EBB: USB, 640000).
    #[arg(long)]
    pub baud: Option<u32>,
    /// Multiplies motion time: 1 real time, 0 instant.
    #[arg(long, default_value_t = 1.0)]
    pub speed_scale: f64,
    /// Input buffer size in bytes (HP 7475A 1024, GRBL 128; an EBB's is fixed).
    #[arg(long)]
    pub buffer_size: Option<usize>,
    /// Model name reported by OI (HP) or $I (GRBL); EBB: the AxiDraw model (axidraw, axidraw-a3, ...).
    #[arg(long)]
    pub model: Option<String>,
    /// GRBL pen: "spindle" (servo on M3/M5) or "z:HEIGHT" (down below HEIGHT mm).
    #[arg(long, default_value = "spindle", value_parser = parse_pen)]
    pub pen: GrblPen,
    /// Write the JSON record here on exit and on `save`.
    #[arg(long)]
    pub record: Option<PathBuf>,
    /// Write an SVG picture of the record here on exit and on `save`.
    #[arg(long)]
    pub svg: Option<PathBuf>,
    /// Write a PNG picture of the record here on exit and on `save`.
    #[arg(long)]
    pub png: Option<PathBuf>,
    /// Unix socket taking fault commands, one per line.
    #[arg(long)]
    pub control: Option<PathBuf>,
    /// Quirks of real firmware, comma-separated. HP: no-esc-o, no-esc-l,
    /// no-esc-m, strict-separators, abort-keeps-partial; GRBL:
    /// homing-required, reset-on-open.
    #[arg(long, value_delimiter = ',', value_parser = Quirk::from_name)]
    pub quirks: Vec<Quirk>,
}

fn parse_personality(s: &str) -> Result<Personality, String> {
    Personality::from_name(s).ok_or_else(|| format!("unknown personality '{s}' (hp7475a, grbl or ebb)"))
}

fn parse_firmware(s: &str) -> Result<Firmware, String> {
    Firmware::from_name(s).ok_or_else(|| format!("unknown EBB firmware '{s}' (2.8.1 or 3.0.2)"))
}

fn parse_pen(s: &str) -> Result<GrblPen, String> {
    match s.split_once(':') {
        None if s == "spindle" => Ok(GrblPen::Spindle),
        Some(("z", h)) => h.parse().map(GrblPen::ZBelow).map_err(|_| format!("'{h}' is not a height in mm")),
        _ => Err(format!("unknown pen mode '{s}' (spindle or z:HEIGHT)")),
    }
}

impl Args {
    /// The simulator configuration these arguments ask for.
    #[must_use]
    pub fn sim_config(&self) -> SimConfig {
        let mut c = SimConfig::for_personality(self.personality);
        if let Some(b) = self.baud {
            c.baud = b;
        }
        c.speed_scale = self.speed_scale;
        c.buffer_size = self.buffer_size;
        c.model.clone_from(&self.model);
        c.link.clone_from(&self.link);
        c.grbl_pen = self.pen;
        c.ebb.firmware = self.firmware;
        c.ebb.nickname.clone_from(&self.nickname);
        c.with_quirks(self.quirks.iter().copied())
    }

    fn save_targets(&self) -> SaveTargets {
        SaveTargets { record: self.record.clone(), svg: self.svg.clone(), png: self.png.clone() }
    }
}

/// Runs the simulator until `shutdown` resolves: prints the pty path on
/// stdout, serves the control socket, and writes the record and pictures on
/// the way out.
///
/// # Errors
/// Starting the simulator, binding the socket, or writing the files failed.
pub async fn run(args: Args, shutdown: impl Future<Output = ()>) -> Result<(), SimError> {
    let sim = Arc::new(Simulator::start(args.sim_config())?);
    let targets = args.save_targets();
    // Listening before the pty path is printed: the line says the control
    // socket takes connections (printed first, a client that saw the
    // socket's file could connect between its bind and its listen and be
    // refused).
    let listener = match &args.control {
        Some(p) => Some(bind(p)?),
        None => None,
    };
    let path = sim.slave_path().expect("a fresh simulator is plugged in");
    println!("{}", path.display());
    let serve = async {
        match listener {
            Some(l) => serve_control(l, Arc::clone(&sim), targets.clone()).await,
            None => std::future::pending().await,
        }
    };
    tokio::select! {
        () = shutdown => {}
        () = serve => {}
    }
    if let Some(p) = &args.control {
        let _ = std::fs::remove_file(p);
    }
    sim.save(targets.record.as_deref(), targets.svg.as_deref(), targets.png.as_deref())?;
    match Arc::try_unwrap(sim) {
        Ok(sim) => sim.shutdown().map(|_| ()),
        // A control connection still holds it; dropping the last one stops it.
        Err(_) => Ok(()),
    }
}

fn bind(path: &Path) -> Result<UnixListener, SimError> {
    use std::os::unix::fs::FileTypeExt;
    // A socket left by a killed run is stale; anything else is not ours to remove.
    if std::fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_socket()) {
        let _ = std::fs::remove_file(path);
    }
    UnixListener::bind(path).map_err(|source| SimError::Write { path: path.into(), source })
}

async fn serve_control(listener: UnixListener, sim: Arc<Simulator>, targets: SaveTargets) {
    loop {
        let Ok((stream, _)) = listener.accept().await else { continue };
        tokio::spawn(connection(stream, Arc::clone(&sim), targets.clone()));
    }
}

/// Longest control line accepted; longer lines are answered with an error.
const MAX_CONTROL_LINE: usize = 256;

async fn connection(stream: UnixStream, sim: Arc<Simulator>, targets: SaveTargets) {
    let (rd, mut wr) = stream.into_split();
    let mut lines = BufReader::new(rd).lines();
    while let Ok(Some(line)) = lines.next_line().await {
        let reply = if line.len() > MAX_CONTROL_LINE {
            format!("error: line longer than {MAX_CONTROL_LINE} bytes")
        } else {
            let (sim, targets) = (Arc::clone(&sim), targets.clone());
            // Faults like unplug wait on the device thread: keep them off the reactor.
            tokio::task::spawn_blocking(move || control::answer(&sim, &line, &targets)).await.unwrap_or_else(|e| format!("error: {e}"))
        };
        if wr.write_all(format!("{reply}\n").as_bytes()).await.is_err() {
            return;
        }
    }
}
