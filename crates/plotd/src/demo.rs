//! `plotd demo`: the whole path on a virtual plotter, as a showcase.
//!
//! Starts a `plotsim` HP 7475A on a pseudo-terminal, a daemon on a temporary
//! socket and spool (the same `serve` as in production), submits a bundled
//! scene over the socket and follows it with the progress bar. The showcase
//! plots a surface in a labelled box over its contour map at a visible
//! speed, unplugs the virtual cable partway and plugs it back, so the daemon
//! is seen to survive it and resume by itself; then it sums up what
//! ordering saved and how the estimate compares with the simulated plot.
//! `--quick` is the instant run of a small scene (no fault), for tests.
//! Both write what the virtual plotter drew (SVG, PNG, and its record as
//! JSON) beside the dry-run render. `--device axidraw` makes the virtual
//! plotter an AxiDraw's EiBotBoard (plotsim's EBB personality) instead.

use crate::client::{self, Client};
use crate::config::Config;
use crate::spool::JobKind;
use anyhow::Context;
use clap::{Args, ValueEnum};
use std::path::{Path, PathBuf};
use std::time::Duration;

/// The showcase's scene: a surface, its box with tick labels, and its
/// contour map on a base plane. Self-contained (no data files), so the
/// daemon renders it.
const SHOWCASE: (&str, &str) = ("surface_axes.toml", include_str!("../../../examples/surface_axes.toml"));
/// The device profile the demo's plotter is made from.
const HP7475A: &str = include_str!("../../../config/devices/hp7475a.toml");
/// `--quick`'s scene: a box with a hole, four strokes.
const QUICK: (&str, &str) = ("box_with_hole.toml", include_str!("../../../examples/box_with_hole.toml"));

/// How many times faster than a real 7475A the showcase plots: the surface
/// (about 80 s on a real one) in about 20 s, still paced by the 9600-baud line.
pub const SHOWCASE_SPEED: f64 = 4.0;
/// How many times faster than a real AxiDraw the showcase plots.
pub const AXIDRAW_SHOWCASE_SPEED: f64 = 8.0;
/// How far into the job (its bytes) the showcase unplugs the cable.
const FAULT_AT: f64 = 0.4;
/// How long the cable stays out.
const FAULT_DOWN: Duration = Duration::from_secs(2);

/// The plotters the demo can simulate.
#[derive(ValueEnum, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum DemoDevice {
    /// An HP 7475A on a 9600-baud serial line.
    #[default]
    Hp7475a,
    /// An AxiDraw: an EiBotBoard (firmware 2.8.1) on USB.
    Axidraw,
}

impl DemoDevice {
    /// The built-in device profile the daemon plots with.
    fn profile_name(self) -> &'static str {
        match self {
            DemoDevice::Hp7475a => "hp7475a",
            DemoDevice::Axidraw => "axidraw",
        }
    }

    /// How the demo's summary names the line to the plotter.
    fn line(self) -> &'static str {
        match self {
            DemoDevice::Hp7475a => "9600-baud line",
            DemoDevice::Axidraw => "USB line",
        }
    }

    /// How the demo's messages name the plotter.
    fn label(self) -> &'static str {
        match self {
            DemoDevice::Hp7475a => "HP 7475A",
            DemoDevice::Axidraw => "AxiDraw",
        }
    }
}

/// Options of `plotd demo`.
#[derive(Args, Clone, Debug)]
pub struct DemoArgs {
    /// Where to write the results (default: a new directory under the system temp dir).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// How many times faster than the real plotter the virtual one plots (0 =
    /// instant; the line still paces it); default 4 for the HP 7475A's
    /// showcase, 8 for the AxiDraw's, 0 with --quick.
    #[arg(long)]
    pub speed: Option<f64>,
    /// The virtual plotter: an HP 7475A or an AxiDraw (an EiBotBoard).
    #[arg(long, value_enum, default_value_t)]
    pub device: DemoDevice,
    /// The instant run: a small scene, no fault, no pauses (for tests).
    #[arg(long)]
    pub quick: bool,
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
    let showcase = !args.quick;
    let (name, text) = if showcase { SHOWCASE } else { QUICK };
    let showcase_speed = match args.device {
        DemoDevice::Hp7475a => SHOWCASE_SPEED,
        // The surface takes an AxiDraw about 5 minutes; half a minute shows it.
        DemoDevice::Axidraw => AXIDRAW_SHOWCASE_SPEED,
    };
    let speed = args.speed.unwrap_or(if showcase { showcase_speed } else { 0.0 });
    anyhow::ensure!(speed.is_finite() && speed >= 0.0, "--speed must be a number >= 0, not {speed}");

    // The dry run: what `plotd render` makes of the scene, and its estimate.
    let scene = scene::Scene::from_toml(text, &Path::new("examples").join(name))?;
    let unordered = scene::render(scene)?;
    let drawing = crate::pipeline::ordered(unordered.clone());
    let dry = out.join("dry-run.svg");
    std::fs::write(&dry, plotcode::svg::write(&drawing))?;
    let profile = plotcode::DeviceProfile::builtin(args.device.profile_name()).expect("built in");
    let emitted = plotcode::emit(&drawing, &profile, &plotcode::EmitOptions::default())?;
    let link = run_dir.join("tty");
    let (plotter, sim_config, estimate) = match args.device {
        DemoDevice::Hp7475a => hp7475a_plotter(&drawing, &profile, speed, &run_dir)?,
        DemoDevice::Axidraw => axidraw_plotter(emitted.stats.seconds, speed),
    };
    // The virtual plotter, reached through a symlink as a real adapter would be.
    let sim = plotsim::Simulator::start(sim_config.with_link(&link)).context("starting the simulator")?;
    // The showcase resumes by itself when the cable is back; a real
    // plotter's config leaves that to a person (`auto_resume` is off by default).
    let config_text = format!(
        "socket = \"{d}/plotd.sock\"\nspool = \"{d}/spool\"\n[[plotter]]\nname = \"plotsim\"\nport = \"{l}\"\n{plotter}\
         auto_resume = {showcase}\n[web]\nlisten = \"127.0.0.1:0\"\n",
        d = run_dir.display(),
        l = link.display()
    );

    let config = Config::from_toml(&config_text, "demo")?;
    let socket = config.socket.clone();
    let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
    // `plotd demo` is the plotd binary: jobs are rendered by its job worker, as under `serve`.
    let options = crate::daemon::ServeOptions { worker_exe: std::env::current_exe().ok(), ..Default::default() };
    let web = std::sync::Arc::clone(&options.web_address);
    let daemon = std::thread::spawn(move || -> anyhow::Result<()> {
        let rt = tokio::runtime::Runtime::new()?;
        rt.block_on(crate::daemon::serve(config, options, async {
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

    let sim_name = match args.device {
        DemoDevice::Hp7475a => "HP 7475A",
        DemoDevice::Axidraw => "EiBotBoard (AxiDraw)",
    };
    eprintln!("plotd demo: plotsim {sim_name} on {}, daemon on {}", link.display(), socket.display());
    // The page listens a moment after the socket.
    for _ in 0..500 {
        if web.get().is_some() {
            break;
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    if let Some(address) = web.get() {
        eprintln!("plotd demo: web page on http://{address}/");
    }
    let label = args.device.label();
    if showcase {
        eprintln!(
            "plotd demo: {name}: {} strokes, {} bytes of {}, est. {} on a real {label}; on an {label} {speed} times as fast, {}",
            emitted.stats.strokes,
            emitted.text.len(),
            profile.protocol,
            client::fmt_secs(emitted.stats.seconds),
            client::fmt_secs(estimate)
        );
    }
    let id = client.submit(JobKind::Scene, None, name, text.to_owned())?;
    let started = std::time::Instant::now();
    let fault_at = (emitted.text.len() as f64 * FAULT_AT) as u64;
    let (code, fault) = std::thread::scope(|s| -> anyhow::Result<(u8, Option<String>)> {
        // The cable comes out partway, and goes back in.
        let fault = showcase.then(|| {
            s.spawn(|| -> Result<String, plotsim::SimError> {
                let at = sim.wait_received(fault_at, Duration::from_secs(120))?.bytes_received;
                eprintln!("\nplotd demo: unplugging the cable at byte {at} for {} s", FAULT_DOWN.as_secs());
                sim.unplug(FAULT_DOWN)?;
                sim.wait_connected(Duration::from_secs(30))?;
                eprintln!("\nplotd demo: cable back; the daemon finds the plotter and resumes");
                Ok(format!("cable unplugged at byte {at} for {} s; the job resumed by itself", FAULT_DOWN.as_secs()))
            })
        });
        // An AxiDraw holds one pen: the person's part, swapping it when the
        // job asks, is played here.
        let pens = (args.device == DemoDevice::Axidraw).then(|| s.spawn(|| swap_pens_when_asked(&socket, id)));
        let code = client::follow(&socket, id, false)?;
        if let Some(p) = pens {
            p.join().map_err(|_| anyhow::anyhow!("the pen thread panicked"))??;
        }
        let fault = match fault.map(|f| f.join()) {
            Some(Ok(r)) => Some(r.context("the fault")?),
            Some(Err(_)) => anyhow::bail!("the fault thread panicked"),
            None => None,
        };
        Ok((code, fault))
    })?;
    let wall = started.elapsed();
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
    if showcase {
        let model = profile.motion_model();
        let (before, after) = (model.plot_stats(&unordered, strokes::DVec2::ZERO), model.plot_stats(&drawing, strokes::DVec2::ZERO));
        println!("strokes:             {} ({} pen lifts)", after.strokes, emitted.stats.pen_lifts);
        println!(
            "pen-up travel:       {:.0} mm, ordering saved {:.0} mm ({:.0} %) of the {:.0} mm in the engine's order",
            after.travel_mm,
            before.travel_mm - after.travel_mm,
            100.0 * (before.travel_mm - after.travel_mm) / before.travel_mm.max(f64::MIN_POSITIVE),
            before.travel_mm
        );
        println!(
            "plot time:           estimated {}, simulated {}, {} here with the fault and the {} (a real {label}: {})",
            // The EBB's record counts its own clock's time, a real AxiDraw's.
            client::fmt_secs(if args.device == DemoDevice::Axidraw { emitted.stats.seconds } else { estimate }),
            client::fmt_secs(record.plot_seconds),
            client::fmt_secs(wall.as_secs_f64()),
            args.device.line(),
            client::fmt_secs(emitted.stats.seconds)
        );
        if let Some(f) = fault {
            println!("fault:               {f}");
        }
    }
    println!("dry-run render:      {}", dry.display());
    println!("what plotsim drew:   {}  {}  {}", svg.display(), png.display(), json.display());
    println!("{} strokes, {} bytes over the line, {} overruns", record.strokes.len(), record.bytes_received, record.overruns);
    Ok(code)
}

/// Says `pen-changed` whenever job `id` waits for a pen, as the person at a
/// one-pen plotter would after swapping it, until the job ends.
fn swap_pens_when_asked(socket: &Path, id: crate::spool::JobId) -> anyhow::Result<()> {
    let mut watch = Client::connect(socket)?;
    watch.watch(Some(id))?;
    while let Some(e) = watch.next_event()? {
        if e.job != id {
            continue;
        }
        if e.state.is_final() {
            break;
        }
        if e.state == crate::protocol::State::Paused && e.cause == Some(crate::spool::PauseCause::Load) {
            eprintln!("\nplotd demo: {}: swapping the pen, as the person at the plotter would", e.reason.as_deref().unwrap_or("pen"));
            Client::connect(socket)?.call(&crate::protocol::Request::PenChanged { plotter: Some("plotsim".into()) })?;
        }
    }
    Ok(())
}

/// The HP 7475A: a 7475A `speed` times as fast (its profile's speeds and
/// times scaled), plotted in real time, so that the daemon's ETA counts down
/// the seconds the demo takes; at speed 0 the real one, instantly. Either way
/// plotsim moves as the daemon's profile says (speeds, acceleration, pen
/// lifts): the simulated time tests the estimate's sums and the streaming,
/// not two sets of numbers. Returns the plotter's config keys after `port`,
/// the simulator's config, and the plot's estimate at that speed.
fn hp7475a_plotter(
    drawing: &strokes::Drawing,
    profile: &plotcode::DeviceProfile,
    speed: f64,
    run_dir: &Path,
) -> anyhow::Result<(String, plotsim::SimConfig, f64)> {
    let device = if speed > 0.0 {
        let path = run_dir.join("hp7475a-fast.toml");
        std::fs::write(&path, faster(HP7475A, speed))?;
        path.display().to_string()
    } else {
        "hp7475a".to_owned()
    };
    let plotted_as = match speed > 0.0 {
        true => plotcode::DeviceProfile::from_toml(&faster(HP7475A, speed))?,
        false => profile.clone(),
    };
    let estimate = plotcode::emit(drawing, &plotted_as, &plotcode::EmitOptions::default())?.stats.seconds;
    let sim_config = plotsim::SimConfig { motion: plotted_as.motion_model(), ..plotsim::SimConfig::hp7475a() };
    let time_scale = if speed > 0.0 { 1.0 } else { 0.0 };
    let keys = format!("baud = 9600\ndevice = \"{device}\"\nhandshake = \"escb\"\n");
    Ok((keys, sim_config.with_speed_scale(time_scale), estimate))
}

/// The AxiDraw: plotsim's EiBotBoard, its clock run `speed` times as fast
/// (the board's own step arithmetic, so its program is the real AxiDraw's;
/// 0 = instantly). `seconds` is the real AxiDraw's plot time. Returns the
/// plotter's config keys after `port`, the simulator's config, and the
/// plot's estimate at that speed.
fn axidraw_plotter(seconds: f64, speed: f64) -> (String, plotsim::SimConfig, f64) {
    let (time_scale, estimate) = if speed > 0.0 { (1.0 / speed, seconds / speed) } else { (0.0, seconds) };
    // The board ignores the baud rate; the config takes only standard ones.
    let keys = "baud = 115200\ndevice = \"axidraw\"\nhandshake = \"ebb\"\n".to_owned();
    (keys, plotsim::SimConfig::ebb(plotsim::Firmware::V2_8_1).with_speed_scale(time_scale), estimate)
}

/// A device profile's text for a plotter `speed` times as fast: pen speeds
/// times `speed`, pen lifts and drops divided by it, acceleration times its
/// square (so every move takes 1/`speed` of the time), named for it.
fn faster(profile: &str, speed: f64) -> String {
    let mut out = String::new();
    // Keys before the first table are the device's (papers have names too).
    let mut top = true;
    for line in profile.lines() {
        top &= !line.trim_start().starts_with('[');
        let scaled = line.split_once('=').and_then(|(key, value)| {
            let v: f64 = value.trim().parse().ok()?;
            let v = match key.trim() {
                "pen_down_speed_mm_s" | "pen_up_speed_mm_s" => v * speed,
                "pen_lift_s" | "pen_drop_s" => v / speed,
                "acceleration_mm_s2" => v * speed * speed,
                _ => return None,
            };
            Some(format!("{} = {v:?}", key.trim()))
        });
        match scaled {
            Some(l) => out.push_str(&l),
            None if top && line.trim_start().starts_with("name") => out.push_str(&format!("name = \"hp7475a-{speed}x\"")),
            None => out.push_str(line),
        }
        out.push('\n');
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_faster_profile_takes_a_quarter_of_the_time_at_four_times_the_speed() {
        let real = plotcode::DeviceProfile::from_toml(HP7475A).unwrap();
        let fast = plotcode::DeviceProfile::from_toml(&faster(HP7475A, 4.0)).unwrap();
        assert_eq!(fast.name, "hp7475a-4x");
        let mut d = strokes::Drawing::new(297.0, 210.0);
        let pts = vec![strokes::DVec2::new(20.0, 20.0), strokes::DVec2::new(120.0, 20.0), strokes::DVec2::new(121.0, 90.0)];
        d.layer_mut(1, strokes::LineKind::Visible).polylines.push(strokes::Polyline::new(pts));
        let opts = plotcode::EmitOptions::default();
        let (a, b) = (plotcode::emit(&d, &real, &opts).unwrap(), plotcode::emit(&d, &fast, &opts).unwrap());
        assert!((a.stats.seconds / b.stats.seconds - 4.0).abs() < 1e-9, "{} vs {}", a.stats.seconds, b.stats.seconds);
        assert_eq!(a.text, b.text, "the same bytes");
    }
}
