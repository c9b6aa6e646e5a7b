//! `plotd render`: scene file to a drawing file, no plotter involved.

use crate::dryrun::{DeviceSummary, WriteSummary};
use anyhow::{bail, Context};
use clap::Args;
use rayon::prelude::*;
use scene::{Page, Scene};
use std::path::{Path, PathBuf};
use strokes::DVec2;
use strokes::{Drawing, MotionModel, PlotStats};

/// `plotd render SCENE -o OUT`.
#[derive(Debug, Args)]
pub struct RenderArgs {
    /// The scene file (TOML), or a plain drawing to re-order: SVG, HP-GL (.hpgl, .plt), G-code (.gcode, .nc) or EBB (.ebb).
    pub scene: PathBuf,
    /// Output file; its extension picks the format (.svg, .hpgl, .gcode, .ebb).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Device of the output .hpgl / .gcode / .ebb: a built-in profile name
    /// (hp7475a, hp7550a, hp7585b, roland-dxy1300, hpgl2-generic, grbl-servo,
    /// grbl-z, axidraw, axidraw-se-a3, axidraw-se-a1) or a path to a profile
    /// TOML. Default: hp7475a for HP-GL, grbl-servo for G-code, axidraw for
    /// EBB. With .svg, an AxiDraw places the drawing on its sheet.
    #[arg(long)]
    pub device: Option<String>,
    /// A plotter of the config (--config): render for its device (unless
    /// --device names one), and in an SVG draw each pen with the colour and
    /// width of its pen table (`[[plotter.pen]]`).
    #[arg(long, value_name = "NAME")]
    pub plotter: Option<String>,
    /// The config --plotter is read from.
    #[arg(long, value_name = "PATH", default_value = "config/plotd.toml")]
    pub config: std::path::PathBuf,
    /// HP-GL / G-code / EBB input: the device it was written for (its units
    /// and pen); default: --device when it speaks the input's language, else
    /// hpgl2-generic (0.025 mm units), grbl-servo or axidraw.
    #[arg(long)]
    pub input_device: Option<String>,
    /// Paper of the device profile (such as A3); default: the sheet of the
    /// drawing's page size if the device has it, else the profile's default paper.
    #[arg(long)]
    pub paper: Option<String>,
    /// HP-GL: relative coordinates (PR) after the first move; smaller files.
    #[arg(long)]
    pub relative: bool,
    /// Keep the strokes as rendered (raw order, no chaining), for comparison.
    #[arg(long)]
    pub no_optimize: bool,
    /// Width of the pens, mm: a pen whose lines lie closer together than
    /// this over much of their length gets a warning.
    #[arg(long, value_name = "MM", default_value_t = crate::ink::DEFAULT_PEN_WIDTH_MM)]
    pub pen_width: f64,
    /// SVG input: hide the parts of lines under later filled shapes of the
    /// same layer (pen), as vpype-occult does.
    #[arg(long)]
    pub occult: bool,
    /// SVG input: hide them under later filled shapes of any layer.
    #[arg(long)]
    pub occult_across: bool,
    /// SVG input: scale and centre the drawing on an A4 landscape page with a
    /// 10 mm margin instead of keeping its own size and position.
    #[arg(long)]
    pub fit: bool,
    /// Seconds the render may take (wall clock; CPU time is bounded by this
    /// times the cores), at most 86400; past it the render stops with an
    /// error. With this or --memory-limit the render runs in a child process
    /// under both (the other at its default); without either, in this one.
    #[arg(long, value_name = "SECONDS")]
    pub time_limit: Option<f64>,
    /// Memory (address space) the render may use, MiB (at least 64); see
    /// --time-limit.
    #[arg(long, value_name = "MIB")]
    pub memory_limit: Option<u64>,
    /// Internal: this process is the render under its budget.
    #[arg(long, hide = true)]
    pub budgeted: bool,
}

/// `--time-limit` of `plotd render` when only `--memory-limit` is given, seconds.
pub const DEFAULT_RENDER_SECONDS: f64 = 600.0;
/// `--memory-limit` of `plotd render` when only `--time-limit` is given, MiB.
pub const DEFAULT_RENDER_MEMORY_MB: u64 = 8192;
/// Largest `--time-limit` of `plotd render`, seconds: a day, as the
/// daemon's `render_seconds`.
pub const MAX_RENDER_SECONDS: f64 = 86_400.0;
/// Smallest `--memory-limit` of `plotd render`, MiB: room for the binary,
/// its libraries and stacks, a thread per core and a small scene (the
/// cube renders in 32 MiB; at 16 the threads could not start).
pub const MIN_RENDER_MEMORY_MB: u64 = 64;

/// `plotd render` as the binary runs it: with `--time-limit` or
/// `--memory-limit`, this binary again in a child under that budget (a
/// scene that would never end, or eat the machine, stops with an error);
/// without, in this process (no second process start, no budget to
/// watch). Returns the exit code.
///
/// # Errors
/// A budget out of range (naming the flag), the render's own errors, a
/// render past its budget.
pub fn run_as_binary(args: &RenderArgs) -> anyhow::Result<u8> {
    if args.budgeted {
        // The threads start here, where a budget too small for them is a
        // clear error, not a panic in the first parallel stage.
        if let Err(e) = rayon::ThreadPoolBuilder::new().build_global() {
            bail!(
                "--memory-limit {} MiB leaves no room to start the render's threads ({e}); give it more",
                args.memory_limit.unwrap_or(DEFAULT_RENDER_MEMORY_MB)
            );
        }
        return run(args).map(|()| 0);
    }
    match asked_budget(args)? {
        None => {
            tune_allocator();
            run(args).map(|()| 0)
        }
        Some(budget) => crate::worker::run_cli_budgeted(&budget).map_err(|e| anyhow::anyhow!("render stopped: {e}")),
    }
}

/// The budget `--time-limit` and `--memory-limit` ask for (the one not
/// given at its default), or `None` when neither is given.
///
/// # Errors
/// A limit out of range, naming its flag.
fn asked_budget(args: &RenderArgs) -> anyhow::Result<Option<crate::config::Budget>> {
    if let Some(t) = args.time_limit {
        if !(t > 0.0 && t <= MAX_RENDER_SECONDS) {
            bail!("--time-limit {t}: must be a number of seconds above 0 and at most {MAX_RENDER_SECONDS} (a day)");
        }
    }
    if let Some(m) = args.memory_limit {
        if m < MIN_RENDER_MEMORY_MB {
            bail!("--memory-limit {m}: must be at least {MIN_RENDER_MEMORY_MB} MiB");
        }
    }
    if args.time_limit.is_none() && args.memory_limit.is_none() {
        return Ok(None);
    }
    Ok(Some(crate::config::Budget {
        seconds: args.time_limit.unwrap_or(DEFAULT_RENDER_SECONDS),
        memory_mb: args.memory_limit.unwrap_or(DEFAULT_RENDER_MEMORY_MB),
        ..crate::config::Budget::default()
    }))
}

/// glibc's allocator set as the budgeted worker's is ([`crate::worker`]'s
/// `GLIBC_TUNABLES`): allocations up to 32 MiB on the heap and 128 MiB of
/// freed memory kept, so that a stage reuses the pages the one before it
/// freed instead of faulting in fresh ones (about 1 ms a MB).
fn tune_allocator() {
    use nix::libc::{mallopt, M_ARENA_MAX, M_MMAP_THRESHOLD, M_TRIM_THRESHOLD};
    // SAFETY: mallopt only sets allocator parameters; called before the
    // render's threads start.
    unsafe {
        mallopt(M_ARENA_MAX, 2);
        mallopt(M_MMAP_THRESHOLD, 32 << 20);
        mallopt(M_TRIM_THRESHOLD, 128 << 20);
    }
}

/// Loads the scene (or reads the SVG / HP-GL / G-code drawing), renders it,
/// chains and orders the strokes (unless `--no-optimize`), writes the output
/// file and prints the one-line summary to stderr.
///
/// # Errors
/// A bad scene (the message names the file, line and field), a bad input
/// drawing (file and line / byte offset), `--fit` with a scene, an unknown
/// output format or device, or an output file that cannot be written.
pub fn run(args: &RenderArgs) -> anyhow::Result<()> {
    // An unknown output extension is an error before any work.
    crate::dryrun::OutputFormat::from_path(&args.output)?;
    if !(args.pen_width > 0.0 && args.pen_width.is_finite()) {
        bail!("--pen-width {}: must be a width in mm above 0", args.pen_width);
    }
    let device = crate::dryrun::DeviceArgs {
        device: args.device.clone(),
        paper: args.paper.clone(),
        relative: args.relative,
        looks: plotcode::svg::PenLooks::new(),
    };
    let device = match &args.plotter {
        Some(name) => crate::dryrun::for_plotter(&args.config, name, device)?,
        None => device,
    };
    // Plain 2-D input (SVG, or HP-GL / G-code read back): no hidden-line
    // removal, only chaining, ordering and output.
    let flat = if is_svg(&args.scene) {
        Some(load_svg(args)?)
    } else if crate::dryrun::is_device_file(&args.scene) {
        if args.occult || args.occult_across {
            bail!("--occult and --occult-across are for SVG input: HP-GL and G-code draw no fills");
        }
        Some(crate::dryrun::read_device_file(&args.scene, args.input_device.as_deref(), &device)?)
    } else {
        None
    };
    if let Some(drawing) = flat {
        let finished = finish(drawing, args);
        eprintln!("{}", write_summed(&finished, &args.output, &device, args)?);
        return Ok(());
    }
    if args.fit || args.occult || args.occult_across {
        bail!("--fit, --occult and --occult-across are for SVG input; a scene is framed by its [camera] frame and [page], and hides by its faces");
    }
    let scene = Scene::load(&args.scene)?;
    let draw = |scene: Scene| -> anyhow::Result<Finished> { Ok(finish(scene::render(scene)?, args)) };
    if let Some(pattern) = crate::frames::FramePattern::parse(&args.output)? {
        // One file per frame of the `[animation]` (one for a still), in
        // parallel: SVG, or HP-GL / G-code for the device, as a single file is.
        let frames = crate::frames::render_all(&scene, &pattern, draw, |f: &Finished, path| write_summed(f, path, &device, args))?;
        for (_, _, line) in &frames {
            eprintln!("{line}");
        }
        return Ok(());
    }
    if scene.frame_count() > 1 {
        tracing::warn!(
            "{}: the animation has {} frames; rendering frame 0 only (name the output like frame-%04d.svg for all)",
            args.scene.display(),
            scene.frame_count()
        );
    }
    let finished = draw(scene)?;
    eprintln!("{}", write_summed(&finished, &args.output, &device, args)?);
    Ok(())
}

/// A drawing ready to write, how long its input was, and how crowded it is.
pub struct Finished {
    /// The strokes as the plotter draws them.
    pub drawing: Drawing,
    /// Length (mm) of the input: less the drawn length, what the input drew
    /// more than once and the stroke stage removed (overlapping collinear
    /// pieces, duplicates).
    pub input_mm: f64,
    /// The warnings for pens whose lines lie too close for their width
    /// ([`crate::ink::crowding_warnings`]).
    pub crowded: Vec<String>,
}

/// The strokes with overlaps removed, chained and ordered for the plotter,
/// unless `--no-optimize`, and the pens' crowding, measured on the other
/// core while the strokes are ordered.
fn finish(drawing: Drawing, args: &RenderArgs) -> Finished {
    let input_mm = drawing.drawn_length();
    let crowded = |d: &Drawing| crate::ink::crowding_warnings(d, |_| args.pen_width);
    if args.no_optimize {
        let crowded = crowded(&drawing);
        return Finished { drawing, input_mm, crowded };
    }
    let (drawing, crowded) = crate::pipeline::ordered_beside(drawing, crowded);
    Finished { drawing, input_mm, crowded }
}

/// Writes `finished` to `out` (SVG, HP-GL or G-code for the chosen device:
/// `dryrun`) and returns its summary line, the drawing measured for it while
/// the file is written (on a large drawing both take a while).
fn write_summed(finished: &Finished, out: &Path, device: &crate::dryrun::DeviceArgs, args: &RenderArgs) -> anyhow::Result<String> {
    let (written, totals) = rayon::join(|| crate::dryrun::write(&finished.drawing, out, device), || Totals::of(&finished.drawing));
    for warning in &finished.crowded {
        tracing::warn!("{}: {warning}", out.display());
    }
    Ok(summary_line(out, finished, &totals, args, &written?))
}

/// The summary, with what writing the output produced, marked at the end when
/// the strokes are in their raw order.
fn summary_line(out: &Path, finished: &Finished, totals: &Totals, args: &RenderArgs, written: &WriteSummary) -> String {
    let mut line = summary(out, totals, written.device.as_ref());
    // Never negative: snapping may lengthen a segment by a hair.
    let overlap_mm = (finished.input_mm - totals.stats.drawn_mm).max(0.0);
    if overlap_mm >= 0.05 {
        line.push_str(&format!(", {overlap_mm:.1} mm drawn twice removed"));
    }
    line.push_str(&crate::ink::per_pen(&finished.drawing));
    line.push_str(&crate::dryrun::summary_suffix(written));
    if args.no_optimize {
        line.push_str(" (raw order)");
    }
    line
}

fn is_svg(input: &Path) -> bool {
    input.extension().and_then(|e| e.to_str()).is_some_and(|e| e.eq_ignore_ascii_case("svg"))
}

/// An SVG file as it is (on its own page size), or fitted to a page with `--fit`.
fn load_svg(args: &RenderArgs) -> anyhow::Result<Drawing> {
    let text = std::fs::read_to_string(&args.scene).with_context(|| format!("cannot read {}", args.scene.display()))?;
    let occlusion = match (args.occult, args.occult_across) {
        (_, true) => Some(strokes::occult::Occlusion::Across),
        (true, false) => Some(strokes::occult::Occlusion::PerGroup),
        _ => None,
    };
    let imported = crate::pipeline::read_svg(&text, occlusion).with_context(|| format!("{}", args.scene.display()))?;
    for w in &imported.warnings {
        tracing::warn!("{}: {w}", args.scene.display());
    }
    let drawing = imported.drawing;
    Ok(if args.fit { fitted(&drawing, &Page::default()) } else { drawing })
}

/// `drawing` scaled (aspect kept) and centred on `page`'s drawable area.
fn fitted(drawing: &Drawing, page: &Page) -> Drawing {
    let placement = page.fit(drawing.bounds());
    let mut out = drawing.clone();
    out.width_mm = page.width_mm;
    out.height_mm = page.height_mm;
    for p in out.layers.iter_mut().flat_map(|l| &mut l.polylines).flat_map(|p| &mut p.points) {
        *p = placement.apply(*p);
    }
    out
}

/// What the summary line says of a drawing: its visible length (mm) and
/// its plot statistics on the generic plotter.
#[derive(Clone, Copy, Debug)]
struct Totals {
    visible: f64,
    stats: PlotStats,
}

impl Totals {
    fn of(drawing: &Drawing) -> Totals {
        // Measured in parallel, added in order.
        let lengths: Vec<f64> = drawing
            .layers
            .par_iter()
            .filter(|l| l.kind == strokes::LineKind::Visible)
            .flat_map(|l| l.polylines.par_iter().map(strokes::Polyline::length))
            .collect();
        // A float sum starts at -0.0: an empty drawing would say "-0.0 mm".
        let visible = lengths.into_iter().fold(0.0, |a, b| a + b);
        Totals { visible, stats: MotionModel::default().plot_stats(drawing, DVec2::ZERO) }
    }
}

/// `OUT: visible length L mm, N strokes, pen-up travel T mm, P pen lifts,
/// drawn D mm, est. plot time M:SS on DEV (PAPER)`: one time, the device's
/// (from its profile's motion model) when there is a device, else `M:SS
/// (generic plotter)` from the default motion model.
fn summary(out: &Path, totals: &Totals, device: Option<&DeviceSummary>) -> String {
    let Totals { visible, stats } = *totals;
    let (seconds, on) = match device {
        Some(d) => (d.stats.seconds, format!("on {} ({})", d.name, d.paper)),
        None => (stats.seconds, "(generic plotter)".to_string()),
    };
    let secs = seconds.round() as u64;
    format!(
        "{}: visible length {visible:.1} mm, {} strokes, pen-up travel {:.1} mm, {} pen lifts, drawn {:.1} mm, est. plot time {}:{:02} {on}",
        out.display(),
        stats.strokes,
        stats.travel_mm,
        stats.pen_lifts,
        stats.drawn_mm,
        secs / 60,
        secs % 60
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use strokes::{LineKind, Polyline};

    #[test]
    fn a_budget_only_when_asked_for() {
        use clap::Parser;
        let args = |extra: &[&str]| {
            let cli = crate::cli::Cli::try_parse_from([&["plotd", "render", "a.toml", "-o", "a.svg"], extra].concat()).unwrap();
            let crate::cli::Command::Render(args) = cli.command else { panic!("not render") };
            asked_budget(&args)
        };
        assert_eq!(args(&[]).unwrap(), None);
        let budget = |seconds, memory_mb| Some(crate::config::Budget { seconds, memory_mb, ..crate::config::Budget::default() });
        assert_eq!(args(&["--time-limit", "5"]).unwrap(), budget(5.0, DEFAULT_RENDER_MEMORY_MB));
        assert_eq!(args(&["--memory-limit", "64"]).unwrap(), budget(DEFAULT_RENDER_SECONDS, 64));
        assert_eq!(args(&["--memory-limit", "100", "--time-limit", "2"]).unwrap(), budget(2.0, 100));
        let e = args(&["--memory-limit", "16"]).unwrap_err().to_string();
        assert_eq!(e, "--memory-limit 16: must be at least 64 MiB");
        assert!(args(&["--time-limit", "0"]).unwrap_err().to_string().starts_with("--time-limit 0: "));
    }

    #[test]
    fn formats_by_extension() {
        use crate::dryrun::OutputFormat;
        assert_eq!(OutputFormat::from_path(Path::new("a.SVG")).unwrap(), OutputFormat::Svg);
        assert!(OutputFormat::from_path(Path::new("a.pdf")).unwrap_err().to_string().contains("a.pdf"));
        assert!(OutputFormat::from_path(Path::new("a")).is_err());
    }

    #[test]
    fn summary_counts_visible_length_and_strokes() {
        let mut d = Drawing::new(100.0, 100.0);
        d.layer_mut(1, LineKind::Visible).polylines.push(Polyline::new(vec![DVec2::ZERO, DVec2::new(30.0, 40.0)]));
        d.layer_mut(2, LineKind::Hidden).polylines.push(Polyline::new(vec![DVec2::ZERO, DVec2::new(10.0, 0.0)]));
        let s = summary(Path::new("o.svg"), &Totals::of(&d), None);
        assert!(s.starts_with("o.svg: visible length 50.0 mm, 2 strokes, pen-up travel "), "{s}");
        assert!(s.contains(", 2 pen lifts, drawn 60.0 mm, est. plot time 0:0"), "{s}");
        assert!(s.ends_with(" (generic plotter)"), "{s}");
    }

    #[test]
    fn an_empty_drawing_has_no_negative_zero() {
        let s = summary(Path::new("o.svg"), &Totals::of(&Drawing::new(100.0, 100.0)), None);
        assert!(s.starts_with("o.svg: visible length 0.0 mm, 0 strokes, pen-up travel 0.0 mm, 0 pen lifts, drawn 0.0 mm"), "{s}");
    }

    #[test]
    fn summary_shows_only_the_device_time_when_there_is_a_device() {
        let mut d = Drawing::new(100.0, 100.0);
        d.layer_mut(1, LineKind::Visible).polylines.push(Polyline::new(vec![DVec2::ZERO, DVec2::new(30.0, 40.0)]));
        let generic = MotionModel::default().plot_stats(&d, DVec2::ZERO);
        // A device ten minutes slower than the generic model, so the two
        // times cannot be confused.
        let slow = PlotStats { seconds: generic.seconds + 600.0, ..generic };
        let device = DeviceSummary { name: "hp7475a".into(), paper: "A4".into(), stats: slow, scale: 1.0 };
        let s = summary(Path::new("o.hpgl"), &Totals::of(&d), Some(&device));
        let secs = slow.seconds.round() as u64;
        assert!(s.ends_with(&format!("est. plot time {}:{:02} on hp7475a (A4)", secs / 60, secs % 60)), "{s}");
        assert_eq!(s.matches("plot time").count(), 1, "{s}");
    }

    #[test]
    fn fit_scales_and_centres_on_the_page() {
        let mut d = Drawing::new(1000.0, 1000.0);
        d.layer_mut(1, LineKind::Visible).polylines.push(Polyline::new(vec![DVec2::new(500.0, 500.0), DVec2::new(600.0, 550.0)]));
        let f = fitted(&d, &Page::default());
        assert_eq!((f.width_mm, f.height_mm), (297.0, 210.0));
        let (lo, hi) = f.bounds().unwrap();
        // 100 x 50 fills the 277 mm drawable width; centred on the page.
        assert!((hi.x - lo.x - 277.0).abs() < 1e-9 && ((lo + hi) * 0.5 - DVec2::new(148.5, 105.0)).length() < 1e-9);
    }
}
