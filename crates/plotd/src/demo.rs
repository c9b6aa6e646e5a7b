//! `plotd demo`: the whole path on a virtual plotter.
//!
//! Starts a `plotsim` HP 7475A on a pseudo-terminal, a daemon on a temporary
//! socket and spool (the same `serve` as in production), submits a bundled
//! scene over the socket, follows it with the progress bar, and writes what
//! the virtual plotter drew (SVG, PNG, and its record as JSON) beside the
//! dry-run render.

use crate::client::{self, Client};
use crate::config::Config;
use crate::spool::JobKind;
use anyhow::Context;
use clap::Args;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// The bundled scene: self-contained (no mesh files), so the daemon renders it.
const SCENE: &str = include_str!("../../../examples/box_with_hole.toml");

/// Options of `plotd demo`.
#[derive(Args, Clone, Debug)]
pub struct DemoArgs {
    /// Where to write the results (default: a new directory under the system temp dir).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Plotter speed relative to real time (0 = instant; the 9600-baud line still paces it).
    #[arg(long, default_value_t = 0.0)]
    pub speed: f64,
}

/// Runs the demo; returns the exit code.
///
/// # Errors
/// Anything that stops it: the simulator, the daemon, the job.
pub fn run(args: &DemoArgs) -> anyhow::Result<u8> {
    let out = match &args.out {
        Some(d) => d.clone(),
        None => std::env::temp_dir().join(format!("plotd-demo-{}", std::process::id())),
    };
    std::fs::create_dir_all(&out).with_context(|| format!("cannot create {}", out.display()))?;
    let run_dir = out.join("run");
    std::fs::create_dir_all(&run_dir)?;

    // The dry run: what `plotd render` makes of the scene.
    let scene = scene::Scene::from_toml(SCENE, Path::new("examples/box_with_hole.toml"))?;
    let drawing = crate::pipeline::plotted_drawing(&scene)?;
    let dry = out.join("dry-run.svg");
    std::fs::write(&dry, plotcode::svg::write(&drawing))?;

    // The virtual plotter, reached through a symlink as a real adapter would be.
    let link = run_dir.join("tty");
    let sim = plotsim::Simulator::start(plotsim::SimConfig::hp7475a().with_speed_scale(args.speed).with_link(&link))
        .context("starting the simulator")?;
    let text = format!(
        "socket = \"{d}/plotd.sock\"\nspool = \"{d}/spool\"\n[[plotter]]\nname = \"plotsim\"\nport = \"{l}\"\nbaud = 9600\ndevice = \"hp7475a\"\nhandshake = \"escb\"\n",
        d = run_dir.display(),
        l = link.display()
    );
    let config = Config::from_toml(&text, "demo")?;
    let socket = config.socket.clone();
    let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
    let daemon = std::thread::spawn(move || -> anyhow::Result<()> {
        let rt = tokio::runtime::Runtime::new()?;
        rt.block_on(crate::daemon::serve(config, crate::daemon::ServeOptions::default(), async {
            let _ = stopped.await;
        }))?;
        Ok(())
    });
    let mut client = None;
    for _ in 0..500 {
        if let Ok(c) = Client::connect(&socket) {
            client = Some(c);
            break;
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    let mut client = client.context("the daemon did not start listening")?;

    eprintln!("plotd demo: plotsim HP 7475A on {}, daemon on {}", link.display(), socket.display());
    let id = client.submit(JobKind::Scene, None, "box_with_hole.toml", SCENE.to_owned())?;
    let code = client::follow(&socket, id, false)?;
    sim.wait_idle(Duration::from_secs(60)).context("waiting for the plotter to finish")?;
    let _ = stop.send(());
    daemon.join().map_err(|_| anyhow::anyhow!("the daemon thread panicked"))??;

    let record = sim.record();
    let svg = out.join("plotted.svg");
    let png = out.join("plotted.png");
    let json = out.join("plotted.json");
    plotsim::export::save_svg(&record, &svg)?;
    plotsim::export::save_png(&record, &png, 1200)?;
    plotsim::export::save_json(&record, &json)?;
    println!("dry-run render:      {}", dry.display());
    println!("what plotsim drew:   {}  {}  {}", svg.display(), png.display(), json.display());
    println!("{} strokes, {} bytes over the line, {} overruns", record.strokes.len(), record.bytes_received, record.overruns);
    Ok(code)
}
