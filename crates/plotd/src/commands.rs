//! The daemon-side subcommands of `plotd`: `serve`, `demo`, and the client
//! commands. `cli.rs` flattens [`DaemonCommand`] into the top-level command
//! list; [`run`] carries one out and returns the process exit code.

use crate::client::{self, Client};
use crate::config::Config;
use crate::console::print;
use crate::protocol::{Reply, Request};
use crate::spool::{JobId, JobKind, Sheet};
use anyhow::Context;
use clap::{Args, Subcommand};
use std::path::PathBuf;

/// Where the daemon is.
#[derive(Args, Clone, Debug, Default)]
pub struct SocketArg {
    /// The daemon's socket (default: $PLOTD_SOCKET, else $XDG_RUNTIME_DIR/plotd.sock if it
    /// exists, else /run/plotd/plotd.sock, the system daemon's).
    #[arg(long, value_name = "PATH")]
    pub socket: Option<PathBuf>,
}

/// `plotd serve`, `plotd demo` and the client commands.
#[derive(Subcommand, Clone, Debug)]
pub enum DaemonCommand {
    /// Run the daemon: spool jobs and stream them to the configured plotters.
    Serve {
        /// Configuration file.
        #[arg(long, default_value = "config/plotd.toml")]
        config: PathBuf,
    },
    /// The whole path on a virtual plotter: simulator, daemon, a bundled scene.
    #[cfg(feature = "demo")]
    Demo(crate::demo::DemoArgs),
    /// Queue a scene (.toml), HP-GL (.hpgl/.plt), G-code (.gcode/.nc) or SVG file.
    Submit {
        /// The file; its bytes are sent to the daemon.
        file: PathBuf,
        /// Target plotter (default: the first configured), or `any`, or a
        /// device (e.g. hp7475a): the first idle plotter of those that can draw it.
        #[arg(long)]
        plotter: Option<String>,
        /// Content kind when the extension does not say.
        #[arg(long, value_parser = parse_kind)]
        kind: Option<JobKind>,
        /// Draw on the sheet already in the plotter (an overlay, a second
        /// pass), at once: without it, a job after one that drew waits for
        /// `plotd sheet-loaded PLOTTER`.
        #[arg(long)]
        same_sheet: bool,
        /// Draw it on N sheets, one after another: after each, the job waits
        /// for `plotd sheet-loaded PLOTTER` (1 to 1000).
        #[arg(long, value_name = "N", default_value_t = 1)]
        copies: u32,
        /// Draw the job's pens with other pens of the plotter: JOB=PLOTTER
        /// pairs, such as 1=3,2=1 (scenes and SVG drawings).
        #[arg(long, value_name = "MAP", value_parser = parse_pens)]
        pens: Option<crate::pen_map::PenMap>,
        /// SVG drawings: hide the parts of lines under later filled shapes
        /// of the same layer (pen), as `plotd render --occult` does.
        #[arg(long)]
        occult: bool,
        /// SVG drawings: hide them under later filled shapes of any layer.
        #[arg(long, conflicts_with = "occult")]
        occult_across: bool,
        /// Show a progress bar until the job ends; the exit code says how it ended
        /// (0 done, 4 failed, 3 cancelled).
        #[arg(long)]
        follow: bool,
        /// Where the daemon is.
        #[command(flatten)]
        socket: SocketArg,
    },
    /// List jobs.
    Jobs {
        /// Where the daemon is.
        #[command(flatten)]
        socket: SocketArg,
    },
    /// Show plotters and unfinished jobs.
    Status {
        /// Where the daemon is.
        #[command(flatten)]
        socket: SocketArg,
    },
    /// Cancel a job (a plotting job stops at the end of its current stroke,
    /// or with --now where the pen is).
    Cancel {
        /// Job id.
        id: JobId,
        /// Stop the pen now, mid-stroke: the device's buffer is dropped and
        /// the pen lifted.
        #[arg(long)]
        now: bool,
        /// Where the daemon is.
        #[command(flatten)]
        socket: SocketArg,
    },
    /// Pause plotting at the next stroke boundary (one job, or all), or with
    /// --now where the pen is.
    Pause {
        /// Job id (default: every plotting job).
        id: Option<JobId>,
        /// Stop the pen now, mid-stroke: the device's buffer is dropped and
        /// the pen lifted; resume draws the interrupted stroke again.
        #[arg(long)]
        now: bool,
        /// Where the daemon is.
        #[command(flatten)]
        socket: SocketArg,
    },
    /// Resume paused jobs (one, or all) from their last confirmed stroke.
    Resume {
        /// Job id (default: every paused job).
        id: Option<JobId>,
        /// The pen is parked at the paper's origin: a job whose plotter lost
        /// its position (reset or power-cycled mid-job) may go on.
        #[arg(long)]
        position_confirmed: bool,
        /// Where the daemon is.
        #[command(flatten)]
        socket: SocketArg,
    },
    /// Tell the daemon the pen it asked for is in.
    PenChanged {
        /// Plotter (default: all).
        #[arg(long)]
        plotter: Option<String>,
        /// Where the daemon is.
        #[command(flatten)]
        socket: SocketArg,
    },
    /// Tell the daemon a fresh sheet is in the plotter: the job waiting for
    /// one goes on.
    SheetLoaded {
        /// The plotter.
        plotter: String,
        /// Where the daemon is.
        #[command(flatten)]
        socket: SocketArg,
    },
    // A person at the plotter: each answered once the device has done it,
    // refused while a job plots on the plotter (allowed while it is paused).
    /// Raise or lower the pen where it is.
    Pen {
        /// `up` or `down`.
        position: PenPosition,
        /// The plotter (default: the only one configured).
        plotter: Option<String>,
        /// Where the daemon is.
        #[command(flatten)]
        socket: SocketArg,
    },
    /// Raise the pen and move to X Y, millimetres from the device's origin
    /// (an HP plotter's lower-left corner, a GRBL board's zero, an
    /// AxiDraw's home).
    #[command(allow_negative_numbers = true)]
    Move {
        /// mm.
        x: f64,
        /// mm.
        y: f64,
        /// The plotter (default: the only one configured).
        plotter: Option<String>,
        /// Where the daemon is.
        #[command(flatten)]
        socket: SocketArg,
    },
    /// Raise the pen and move by DX DY millimetres.
    #[command(allow_negative_numbers = true)]
    Jog {
        /// mm.
        dx: f64,
        /// mm.
        dy: f64,
        /// The plotter (default: the only one configured).
        plotter: Option<String>,
        /// Where the daemon is.
        #[command(flatten)]
        socket: SocketArg,
    },
    /// Home a GRBL plotter with homing switches (`homing = true`): its
    /// homing cycle, answered once the board confirmed.
    Home {
        /// The plotter (default: the only one configured).
        plotter: Option<String>,
        /// Where the daemon is.
        #[command(flatten)]
        socket: SocketArg,
    },
    /// Trace a job's bounding box on its plotter with the pen up, stopping
    /// a moment at each corner: see where it will land on the sheet.
    Frame {
        /// The job (queued or paused).
        id: JobId,
        /// Where the daemon is.
        #[command(flatten)]
        socket: SocketArg,
    },
    /// Move the drawings of the jobs that start from now on by DX DY
    /// millimetres on the plotter's sheet (kept across restarts; a job that
    /// started keeps its own; device files are plotted as written).
    #[command(allow_negative_numbers = true)]
    Offset {
        /// The plotter.
        plotter: String,
        /// mm.
        dx: f64,
        /// mm.
        dy: f64,
        /// Where the daemon is.
        #[command(flatten)]
        socket: SocketArg,
    },
    /// Internal: the daemon's job worker (reads one job on stdin, writes
    /// its result on stdout; see `worker.rs`).
    #[command(hide = true)]
    JobWorker,
    /// Print progress events as JSON lines (one job, or all).
    Watch {
        /// Job id.
        id: Option<JobId>,
        /// Where the daemon is.
        #[command(flatten)]
        socket: SocketArg,
    },
}

/// Where `plotd pen` puts the pen.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum PenPosition {
    /// Raised.
    Up,
    /// Lowered, where the carriage is.
    Down,
}

fn parse_pens(s: &str) -> Result<crate::pen_map::PenMap, String> {
    crate::pen_map::parse(s).map_err(|e| e.to_string())
}

fn parse_kind(s: &str) -> Result<JobKind, String> {
    serde_json::from_value(serde_json::Value::String(s.to_ascii_lowercase()))
        .map_err(|_| format!("{s:?} is not one of scene, hpgl, gcode, svg"))
}

/// Runs a daemon-side command; returns the exit code.
///
/// # Errors
/// Anything that stops the command, with context for the user.
pub fn run(cmd: DaemonCommand) -> anyhow::Result<u8> {
    match cmd {
        DaemonCommand::Serve { config } => {
            let cfg = Config::load(&config)?;
            let rt = tokio::runtime::Runtime::new().context("starting the runtime")?;
            rt.block_on(crate::daemon::serve(
                cfg,
                crate::daemon::ServeOptions {
                    config_path: Some(config),
                    socket_activation: true,
                    worker_exe: Some(std::env::current_exe().context("finding the plotd binary (for its job worker)")?),
                    ..Default::default()
                },
                shutdown_signal(),
            ))?;
            Ok(0)
        }
        #[cfg(feature = "demo")]
        DaemonCommand::Demo(args) => crate::demo::run(&args),
        DaemonCommand::JobWorker => {
            crate::worker::job_worker_main().context("job worker")?;
            Ok(0)
        }
        DaemonCommand::Submit { file, plotter, kind, same_sheet, copies, pens, occult, occult_across, follow, socket } => {
            let occult = match (occult, occult_across) {
                (_, true) => Some(crate::spool::Occult::Across),
                (true, false) => Some(crate::spool::Occult::Layer),
                (false, false) => None,
            };
            let path = client::socket_path(socket.socket.as_deref());
            let job = client::read_job_file(&file, kind)?;
            let name = file.file_name().map_or_else(|| file.display().to_string(), |n| n.to_string_lossy().into_owned());
            let id = Client::connect(&path)?.submit_job(
                job,
                &client::Placing { plotter: plotter.as_deref(), same_sheet, copies, pens: pens.as_ref(), occult },
                &name,
            )?;
            print(id)?;
            if follow {
                return Ok(client::follow(&path, id, false)?);
            }
            Ok(0)
        }
        DaemonCommand::Jobs { socket } => {
            let mut c = Client::connect(&client::socket_path(socket.socket.as_deref()))?;
            let (jobs, corrupt) = c.job_list()?;
            let mut lines: Vec<(JobId, String)> = jobs.iter().map(|j| (j.id, client::format_job(j))).collect();
            lines.extend(corrupt.iter().map(|c| (c.id, client::format_corrupt(c))));
            lines.sort_by_key(|(id, _)| *id);
            for (_, line) in lines {
                print(line)?;
            }
            Ok(0)
        }
        DaemonCommand::Status { socket } => {
            let mut c = Client::connect(&client::socket_path(socket.socket.as_deref()))?;
            if let Reply::Status { version, plotters, active } = c.call(&Request::Status {})? {
                print(format_args!("plotd {version}"))?;
                for p in plotters {
                    let job = p.job.map(|j| format!(", job {j}")).unwrap_or_default();
                    let (name, port) = (crate::text::escaped(&p.name), crate::text::escaped(&p.port));
                    let sheet = match p.sheet {
                        Sheet::Fresh => "fresh sheet",
                        Sheet::Used => "sheet drawn on",
                    };
                    // `offline: /dev/ttyUSB0: no such file`: the cause quotes device text.
                    let link = match &p.cause {
                        Some(cause) => format!("{}: {}", p.link, crate::text::escaped(&cause.message)),
                        None => p.link.to_string(),
                    };
                    let offset = match p.offset_mm {
                        [0.0, 0.0] => String::new(),
                        [dx, dy] => format!(", offset ({dx}, {dy}) mm"),
                    };
                    let pen = p.pen_loaded.map(|n| format!(", pen {n} in")).unwrap_or_default();
                    print(format_args!(
                        "plotter {name}: {} on {port} ({link}, {sheet}{offset}{pen}){job}",
                        crate::text::escaped(&p.device)
                    ))?;
                }
                for j in active {
                    print(client::format_job(&j))?;
                }
            }
            Ok(0)
        }
        DaemonCommand::Cancel { id, now, socket } => simple(socket, Request::Cancel { id, now }),
        DaemonCommand::Pause { id, now, socket } => simple(socket, Request::Pause { id, now }),
        DaemonCommand::Resume { id, position_confirmed, socket } => simple(socket, Request::Resume { id, position_confirmed }),
        DaemonCommand::PenChanged { plotter, socket } => simple(socket, Request::PenChanged { plotter }),
        DaemonCommand::SheetLoaded { plotter, socket } => simple(socket, Request::SheetLoaded { plotter }),
        DaemonCommand::Pen { position, plotter, socket } => simple(socket, Request::Pen { plotter, down: position == PenPosition::Down }),
        DaemonCommand::Move { x, y, plotter, socket } => simple(socket, Request::Move { plotter, x_mm: x, y_mm: y }),
        DaemonCommand::Jog { dx, dy, plotter, socket } => simple(socket, Request::Jog { plotter, dx_mm: dx, dy_mm: dy }),
        DaemonCommand::Home { plotter, socket } => simple(socket, Request::Home { plotter }),
        DaemonCommand::Frame { id, socket } => simple(socket, Request::Frame { id }),
        DaemonCommand::Offset { plotter, dx, dy, socket } => simple(socket, Request::Offset { plotter, dx_mm: dx, dy_mm: dy }),
        DaemonCommand::Watch { id, socket } => {
            let mut c = Client::connect(&client::socket_path(socket.socket.as_deref()))?;
            c.watch(id)?;
            while let Some(watched) = c.next_watched()? {
                match watched {
                    client::Watched::Job(mut ev) => {
                        // JSON escapes C0 controls but not C1 ones or bidi marks.
                        ev.reason = ev.reason.map(|r| crate::text::escaped(&r).into_owned());
                        print(serde_json::to_string(&ev)?)?;
                    }
                    client::Watched::Plotter(mut ev) => {
                        ev.plotter = crate::text::escaped(&ev.plotter).into_owned();
                        print(serde_json::to_string(&ev)?)?;
                    }
                    client::Watched::PlotterChanged(mut ev) => {
                        ev.plotter = crate::text::escaped(&ev.plotter).into_owned();
                        if let Some(cause) = ev.cause.as_mut() {
                            cause.message = crate::text::escaped(&cause.message).into_owned();
                        }
                        print(serde_json::to_string(&ev)?)?;
                    }
                }
            }
            Ok(0)
        }
    }
}

fn simple(socket: SocketArg, req: Request) -> anyhow::Result<u8> {
    let mut c = Client::connect(&client::socket_path(socket.socket.as_deref()))?;
    if let Reply::Ok { message } = c.call(&req)? {
        print(crate::text::message(&message))?;
    }
    Ok(0)
}

/// Resolves on SIGTERM or SIGINT.
pub async fn shutdown_signal() {
    use tokio::signal::unix::{signal, SignalKind};
    let mut term = signal(SignalKind::terminate()).expect("SIGTERM handler");
    tokio::select! {
        _ = term.recv() => tracing::info!("SIGTERM"),
        _ = tokio::signal::ctrl_c() => tracing::info!("SIGINT"),
    }
}
