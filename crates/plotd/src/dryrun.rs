//! The device side of `plotd render`: choosing the output format and device
//! profile, writing SVG / HP-GL / G-code / EBB, and reading `.hpgl` /
//! `.gcode` / `.ebb` files back into a drawing so they can be re-optimised
//! and re-emitted.

use anyhow::{bail, Context};
use plotcode::{DeviceProfile, EmitOptions, Protocol};
use std::io::Write as _;
use std::path::Path;
use strokes::{Drawing, PlotStats};

/// The device used when `--device` is not given, per format.
pub const DEFAULT_HPGL_DEVICE: &str = "hp7475a";
/// The G-code device used when `--device` is not given.
pub const DEFAULT_GCODE_DEVICE: &str = "grbl-servo";
/// The EBB device used when `--device` is not given.
pub const DEFAULT_EBB_DEVICE: &str = "axidraw";

/// Output file formats, by extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OutputFormat {
    /// `.svg`: Inkscape layers; with an EBB device (`--device axidraw`),
    /// the drawing on its sheet as the AxiDraw plots it.
    Svg,
    /// `.hpgl`, `.plt`, `.hgl`: HP-GL for an HP-GL device.
    Hpgl,
    /// `.gcode`, `.nc`, `.gc`: G-code for a GRBL device.
    Gcode,
    /// `.ebb`: EiBotBoard commands for an AxiDraw.
    Ebb,
}

impl OutputFormat {
    /// The format of `path`, from its extension.
    ///
    /// # Errors
    /// An unknown or missing extension, naming the file.
    pub fn from_path(path: &Path) -> anyhow::Result<OutputFormat> {
        match extension(path).as_deref() {
            Some("svg") => Ok(OutputFormat::Svg),
            Some("hpgl" | "plt" | "hgl") => Ok(OutputFormat::Hpgl),
            Some("gcode" | "nc" | "gc") => Ok(OutputFormat::Gcode),
            Some("ebb") => Ok(OutputFormat::Ebb),
            _ => bail!("{}: unknown output format (expected .svg, .hpgl, .gcode or .ebb)", path.display()),
        }
    }
}

fn extension(path: &Path) -> Option<String> {
    path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase)
}

/// Whether `path` is an HP-GL, G-code or EBB file (rather than a scene).
#[must_use]
pub fn is_device_file(path: &Path) -> bool {
    matches!(OutputFormat::from_path(path), Ok(OutputFormat::Hpgl | OutputFormat::Gcode | OutputFormat::Ebb))
}

/// The profile `spec` names: a built-in name, or a path to a TOML profile
/// (anything containing a path separator or ending in `.toml`). Without a spec,
/// the default device of the format.
///
/// # Errors
/// Unknown names (listing the known ones), unreadable or invalid profile files
/// (naming the file and field), a profile of the wrong protocol for `format`.
pub fn load_profile(spec: Option<&str>, format: OutputFormat) -> anyhow::Result<DeviceProfile> {
    let spec = match (spec, format) {
        (Some(s), _) => s,
        (None, OutputFormat::Gcode) => DEFAULT_GCODE_DEVICE,
        (None, OutputFormat::Ebb) => DEFAULT_EBB_DEVICE,
        (None, _) => DEFAULT_HPGL_DEVICE,
    };
    let profile = if crate::config::names_a_profile_file(spec) {
        let text = std::fs::read_to_string(spec).with_context(|| format!("cannot read device profile {spec}"))?;
        DeviceProfile::from_toml(&text).with_context(|| format!("{spec}: bad device profile"))?
    } else {
        DeviceProfile::builtin(spec)?
    };
    let wanted = match format {
        OutputFormat::Hpgl => Some(Protocol::Hpgl),
        OutputFormat::Gcode => Some(Protocol::Gcode),
        OutputFormat::Ebb => Some(Protocol::Ebb),
        OutputFormat::Svg => None,
    };
    if let Some(w) = wanted {
        if profile.protocol != w {
            let a = if w == Protocol::Ebb { "an" } else { "a" };
            bail!("device {} speaks {}, but the file is {w}; pick {a} {w} device with --device", profile.name, profile.protocol);
        }
    }
    Ok(profile)
}

/// What writing an output produced, for the summary line.
#[derive(Clone, Debug, PartialEq)]
pub struct WriteSummary {
    /// Bytes written.
    pub bytes: usize,
    /// The device, its paper, its plot-time estimate and the scale applied
    /// (device files, and an SVG on an EBB device's sheet).
    pub device: Option<DeviceSummary>,
}

/// The device part of [`WriteSummary`].
#[derive(Clone, Debug, PartialEq)]
pub struct DeviceSummary {
    /// Profile name.
    pub name: String,
    /// Paper used.
    pub paper: String,
    /// Plot-time estimate for that device.
    pub stats: PlotStats,
    /// Scale applied to fit (1 = true size).
    pub scale: f64,
}

/// Options of the device outputs.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DeviceArgs {
    /// `--device`: built-in name or profile path.
    pub device: Option<String>,
    /// `--paper`: paper name of the profile.
    pub paper: Option<String>,
    /// `--relative`: HP-GL relative coordinates.
    pub relative: bool,
    /// An SVG's pens as the plotter's pen table draws them (`--plotter`).
    pub looks: plotcode::svg::PenLooks,
}

/// `args` for plotter `name` of the config at `config`: its device (unless
/// `args` names one) and, for an SVG, its pens' colours and widths.
///
/// # Errors
/// A config that cannot be loaded; no plotter of that name (the message
/// lists those there are).
pub fn for_plotter(config: &Path, name: &str, args: DeviceArgs) -> anyhow::Result<DeviceArgs> {
    let cfg = crate::config::Config::load(config).with_context(|| format!("--plotter {name}: config {}", config.display()))?;
    let Some(plotter) = cfg.plotter(Some(name)) else {
        let names: Vec<&str> = cfg.plotters.iter().map(|p| p.name.as_str()).collect();
        bail!("--plotter: no plotter {name:?} in {} (it has: {})", config.display(), names.join(", "));
    };
    // A profile file is named relative to the config's directory.
    let own = match Path::new(&plotter.device) {
        d if crate::config::names_a_profile_file(&plotter.device) && d.is_relative() => {
            config.parent().unwrap_or(Path::new(".")).join(d).display().to_string()
        }
        _ => plotter.device.clone(),
    };
    let device = args.device.or(Some(own));
    Ok(DeviceArgs { device, looks: crate::pen_table::looks(&plotter.pen), ..args })
}

/// Writes `drawing` to `out` in the format its extension names. An SVG for
/// an EBB device (`--device axidraw`) is the drawing placed on the device's
/// sheet as it plots it (home at the top-left corner), with the planner's
/// plot time; for other devices an SVG is the drawing as it is.
///
/// # Errors
/// Unknown formats and devices, drawings the device cannot take (out of
/// range, too many pens), unwritable files.
pub fn write(drawing: &Drawing, out: &Path, args: &DeviceArgs) -> anyhow::Result<WriteSummary> {
    let format = OutputFormat::from_path(out)?;
    let profile = match (format, args.device.as_deref()) {
        (OutputFormat::Svg, None) => None,
        (OutputFormat::Svg, Some(spec)) => Some(load_profile(Some(spec), format)?).filter(|p| p.protocol == Protocol::Ebb),
        _ => Some(load_profile(args.device.as_deref(), format)?),
    };
    let (device, bytes) = streamed(out, |sink| {
        let Some(profile) = &profile else {
            plotcode::svg::write_with(drawing, &args.looks, sink);
            return Ok(None);
        };
        let opts = EmitOptions { paper: args.paper.clone(), relative: args.relative, ..EmitOptions::default() };
        let cannot = || format!("{}: cannot emit for device {}", out.display(), profile.name);
        let w = if format == OutputFormat::Svg {
            let (sheet, _) = plotcode::ebb::on_sheet(drawing, profile, &opts).with_context(cannot)?;
            let e = plotcode::emit(drawing, profile, &opts).with_context(cannot)?;
            plotcode::svg::write_with(&sheet, &args.looks, sink);
            plotcode::Written { placement: e.placement, stats: e.stats }
        } else {
            plotcode::emit_to(drawing, profile, &opts, sink).with_context(cannot)?
        };
        Ok(Some(DeviceSummary { name: profile.name.clone(), paper: w.placement.paper.clone(), stats: w.stats, scale: w.placement.scale }))
    })?;
    Ok(WriteSummary { bytes, device })
}

/// Runs `produce`, writing the pieces of text it hands its sink to `out` as
/// they come, from a thread of its own: on a large drawing the file takes
/// about as long to write as to format, and so the two overlap. The file is
/// created with the first piece, so a drawing the device cannot take leaves
/// no file behind (and an existing one as it was). Returns what `produce`
/// did and the bytes written.
fn streamed<T>(out: &Path, produce: impl FnOnce(&mut plotcode::Sink<'_>) -> anyhow::Result<T>) -> anyhow::Result<(T, usize)> {
    let (pieces, received) = std::sync::mpsc::sync_channel::<String>(PIECES_IN_FLIGHT);
    std::thread::scope(|scope| {
        let writer = scope.spawn(move || -> std::io::Result<usize> {
            let mut file: Option<std::fs::File> = None;
            let mut bytes = 0;
            for piece in received {
                let f = match &mut file {
                    Some(f) => f,
                    None => file.insert(std::fs::File::create(out)?),
                };
                f.write_all(piece.as_bytes())?;
                bytes += piece.len();
            }
            Ok(bytes)
        });
        // A failed writer drops its end: the rest is formatted for nothing,
        // and its error is reported below.
        let mut sink = move |piece: String| {
            let _ = pieces.send(piece);
        };
        let made = produce(&mut sink);
        drop(sink);
        let written = writer.join().expect("the file writer does not panic");
        let made = made?;
        let bytes = written.with_context(|| format!("cannot write {}", out.display()))?;
        if bytes == 0 {
            std::fs::write(out, "").with_context(|| format!("cannot write {}", out.display()))?;
        }
        Ok((made, bytes))
    })
}

/// Pieces of text formatted ahead of the file writer: a few megabytes.
const PIECES_IN_FLIGHT: usize = 16;

/// `, N bytes written` and, for devices, a scale notice when the drawing was
/// scaled down to fit (the device's plot time is in the summary itself).
#[must_use]
pub fn summary_suffix(w: &WriteSummary) -> String {
    let mut s = format!(", {} bytes written", w.bytes);
    if let Some(d) = w.device.as_ref().filter(|d| d.scale < 1.0) {
        s.push_str(&format!(", SCALED to {:.1}% to fit the plotting area", d.scale * 100.0));
    }
    s
}

/// The device an HP-GL input is read for when neither `--input-device` nor
/// `--device` names an HP-GL device: HP-GL's standard plotter unit, 0.025 mm.
pub const GENERIC_HPGL_INPUT: &str = "hpgl2-generic";

/// Reads an `.hpgl` / `.gcode` / `.ebb` file into a drawing, as written for
/// `input_device` (`--input-device`), else for the output's device
/// (`args.device`) when it speaks the file's language (so re-ordering a
/// plotter's own file keeps its coordinates), else for a generic device of
/// that language ([`GENERIC_HPGL_INPUT`], or the format's default device:
/// G-code is in millimetres, EBB in the AxiDraw's steps). On `--paper` when
/// that device has it, else on its default paper. Skipped instructions are
/// reported on stderr.
///
/// # Errors
/// Unreadable files, and malformed ones naming the file and the byte offset
/// (HP-GL, EBB) or line (G-code); an `--input-device` of another language.
pub fn read_device_file(path: &Path, input_device: Option<&str>, args: &DeviceArgs) -> anyhow::Result<Drawing> {
    let format = OutputFormat::from_path(path)?;
    let profile = match input_device {
        Some(spec) => {
            let profile = load_profile(Some(spec), OutputFormat::Svg)?;
            let language = match format {
                OutputFormat::Hpgl => Protocol::Hpgl,
                OutputFormat::Ebb => Protocol::Ebb,
                _ => Protocol::Gcode,
            };
            if profile.protocol != language {
                bail!("--input-device {} speaks {}, but the file is {language}", profile.name, profile.protocol);
            }
            profile
        }
        None => match args.device.as_deref().map(|spec| load_profile(Some(spec), format)) {
            Some(Ok(output_device)) => output_device,
            _ if format == OutputFormat::Hpgl => load_profile(Some(GENERIC_HPGL_INPUT), format)?,
            _ => load_profile(None, format)?,
        },
    };
    let bytes = std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))?;
    let plot = match format {
        OutputFormat::Hpgl => plotcode::hpgl::parse(&bytes).with_context(|| format!("{}", path.display()))?,
        OutputFormat::Gcode => {
            let text = std::str::from_utf8(&bytes)
                .map_err(|e| anyhow::anyhow!("{}: not text: invalid UTF-8 at byte {}", path.display(), e.valid_up_to()))?;
            plotcode::gcode::parse(text, &plotcode::gcode::ParseOptions::for_profile(&profile))
                .with_context(|| format!("{}", path.display()))?
        }
        OutputFormat::Ebb => plotcode::ebb::parse(&bytes).with_context(|| format!("{}", path.display()))?,
        OutputFormat::Svg => bail!("{}: not an HP-GL, G-code or EBB file", path.display()),
    };
    for w in &plot.warnings {
        eprintln!("plotd: warning: {}: {w}", path.display());
    }
    let paper = args.paper.as_deref().and_then(|name| profile.paper_named(name));
    Ok(plot.to_drawing(&profile, paper))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formats_and_profiles() {
        assert_eq!(OutputFormat::from_path(Path::new("a.HPGL")).unwrap(), OutputFormat::Hpgl);
        assert_eq!(OutputFormat::from_path(Path::new("a.gcode")).unwrap(), OutputFormat::Gcode);
        assert!(OutputFormat::from_path(Path::new("a.pdf")).unwrap_err().to_string().contains("a.pdf"));
        assert!(is_device_file(Path::new("x.plt")) && !is_device_file(Path::new("x.toml")));
        assert_eq!(load_profile(None, OutputFormat::Gcode).unwrap().name, "grbl-servo");
        let e = load_profile(Some("hp7475a"), OutputFormat::Gcode).unwrap_err().to_string();
        // In the words of the user, not the type names of the code.
        assert_eq!(e, "device hp7475a speaks HP-GL, but the file is G-code; pick a G-code device with --device");
        let e = load_profile(Some("nope"), OutputFormat::Hpgl).unwrap_err().to_string();
        assert!(e.contains("known devices: hp7475a"), "{e}");
        let e = format!("{:#}", load_profile(Some("/nonexistent/p.toml"), OutputFormat::Hpgl).unwrap_err());
        assert!(e.contains("/nonexistent/p.toml"), "{e}");
        assert_eq!(OutputFormat::from_path(Path::new("a.EBB")).unwrap(), OutputFormat::Ebb);
        assert!(is_device_file(Path::new("x.ebb")));
        assert_eq!(load_profile(None, OutputFormat::Ebb).unwrap().name, "axidraw");
        let e = load_profile(Some("grbl-z"), OutputFormat::Ebb).unwrap_err().to_string();
        assert_eq!(e, "device grbl-z speaks G-code, but the file is EBB; pick an EBB device with --device");
    }

    /// A drawing of `n` short strokes on pens 1 and 2, many batches of text.
    fn many_strokes(n: usize, pen_count: u32) -> Drawing {
        let mut d = Drawing::new(297.0, 210.0);
        for k in 0..n {
            let (x, y) = (10.0 + (k % 250) as f64, 10.0 + (k / 250) as f64 * 0.5);
            let pen = 1 + (k as u32 / 97) % pen_count;
            d.layer_mut(pen, strokes::LineKind::Visible)
                .polylines
                .push(strokes::Polyline::new(vec![strokes::DVec2::new(x, y), strokes::DVec2::new(x + 0.7, y + 0.3)]));
        }
        d
    }

    #[test]
    fn files_are_written_as_they_are_formatted_and_are_the_whole_text() {
        let dir = tempfile::tempdir().unwrap();
        let d = many_strokes(20_000, 2);
        for name in ["a.svg", "a.hpgl", "a.gcode", "a.ebb"] {
            let out = dir.path().join(name);
            let args = DeviceArgs { device: name.ends_with("gcode").then(|| "grbl-z".to_string()), ..DeviceArgs::default() };
            let written = write(&d, &out, &args).unwrap();
            let file = std::fs::read_to_string(&out).unwrap();
            let whole = match OutputFormat::from_path(&out).unwrap() {
                OutputFormat::Svg => plotcode::svg::write(&d),
                f => {
                    let profile = load_profile(args.device.as_deref(), f).unwrap();
                    let e = plotcode::emit(&d, &profile, &EmitOptions::default()).unwrap();
                    assert_eq!(written.device.as_ref().unwrap().stats, e.stats, "{name}");
                    e.text
                }
            };
            assert_eq!(written.bytes, file.len(), "{name}");
            assert!(file == whole, "{name}: the file is not the text the writer makes whole");
        }
    }

    /// `--device axidraw` with an SVG: the strokes the AxiDraw draws, on its
    /// sheet, timed by its planner; another device's SVG is the drawing.
    #[test]
    fn an_svg_for_a_configured_plotter_draws_each_pen_as_its_pen_table_says() {
        let dir = tempfile::tempdir().unwrap();
        let config = dir.path().join("plotd.toml");
        std::fs::write(
            &config,
            "socket = \"/s/plotd.sock\"\nspool = \"/s\"\n[[plotter]]\nname = \"hp\"\nport = \"/dev/ttyUSB0\"\ndevice = \"hp7475a\"\n\
             [[plotter.pen]]\nnumber = 2\ncolour = \"#1f4e79\"\nwidth = 0.7\n",
        )
        .unwrap();
        let args = for_plotter(&config, "hp", DeviceArgs::default()).unwrap();
        assert_eq!(args.device.as_deref(), Some("hp7475a"), "the plotter's device");
        let out = dir.path().join("a.svg");
        write(&many_strokes(200, 2), &out, &args).unwrap();
        let svg = std::fs::read_to_string(&out).unwrap();
        assert!(svg.contains("id=\"layer2\" inkscape:label=\"2 pen 2\" fill=\"none\" stroke=\"#1f4e79\" stroke-width=\"0.7\""), "{svg}");
        assert!(svg.contains("id=\"layer1\" inkscape:label=\"1 pen 1\" fill=\"none\" stroke=\"#000000\" stroke-width=\"0.3\""), "{svg}");
        let no = for_plotter(&config, "cnc", DeviceArgs::default()).unwrap_err().to_string();
        assert!(no.contains("no plotter \"cnc\"") && no.contains("hp"), "{no}");
    }

    #[test]
    fn an_svg_for_an_ebb_device_is_the_drawing_on_its_sheet() {
        let dir = tempfile::tempdir().unwrap();
        let d = many_strokes(300, 2);
        let out = dir.path().join("a.svg");
        let axidraw = DeviceArgs { device: Some("axidraw".to_string()), ..DeviceArgs::default() };
        let written = write(&d, &out, &axidraw).unwrap();
        let profile = DeviceProfile::builtin("axidraw").unwrap();
        let (sheet, _) = plotcode::ebb::on_sheet(&d, &profile, &EmitOptions::default()).unwrap();
        assert!(std::fs::read_to_string(&out).unwrap() == plotcode::svg::write(&sheet), "not the sheet's drawing");
        let e = plotcode::emit(&d, &profile, &EmitOptions::default()).unwrap();
        let device = written.device.unwrap();
        assert_eq!((device.name.as_str(), device.paper.as_str(), device.stats), ("axidraw", "A4", e.stats));
        let hp = DeviceArgs { device: Some("hp7475a".to_string()), ..DeviceArgs::default() };
        assert_eq!(write(&d, &out, &hp).unwrap().device, None);
        assert!(std::fs::read_to_string(&out).unwrap() == plotcode::svg::write(&d), "an HP-GL device's SVG is the drawing");
    }

    /// An `.ebb` file reads back as the strokes it draws, on the AxiDraw's
    /// sheet: every stroke, each vertex within a step (0.0125 mm).
    #[test]
    fn an_ebb_file_reads_back_as_its_strokes() {
        let dir = tempfile::tempdir().unwrap();
        let d = many_strokes(300, 2);
        let out = dir.path().join("a.ebb");
        write(&d, &out, &DeviceArgs::default()).unwrap();
        let back = read_device_file(&out, None, &DeviceArgs::default()).unwrap();
        assert_eq!((back.width_mm, back.height_mm), (297.0, 210.0));
        let polylines = |d: &Drawing, pen: u32| -> Vec<Vec<strokes::DVec2>> {
            d.layers.iter().filter(|l| l.pen == pen).flat_map(|l| l.polylines.iter().map(|p| p.points.clone())).collect()
        };
        for pen in [1, 2] {
            let (want, got) = (polylines(&d, pen), polylines(&back, pen));
            assert_eq!(want.len(), got.len(), "pen {pen}");
            for (w, g) in want.iter().zip(&got) {
                // The planner's phase points lie on the line between the ends.
                for (a, b) in [(w[0], g[0]), (w[1], *g.last().unwrap())] {
                    assert!((a - b).length() <= 0.0125, "{a} vs {b}");
                }
            }
        }
        std::fs::write(&out, "SP,1\rQS\r").unwrap();
        let e = format!("{:#}", read_device_file(&out, None, &DeviceArgs::default()).unwrap_err());
        assert!(e.contains("a.ebb") && e.contains("byte 5") && e.contains("QS"), "{e}");
    }

    #[test]
    fn a_drawing_the_device_cannot_take_leaves_the_file_as_it_was() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("a.hpgl");
        std::fs::write(&out, "an earlier plot").unwrap();
        // Pens up to 9 on a device of six.
        let e = write(&many_strokes(2_000, 9), &out, &DeviceArgs::default()).unwrap_err();
        assert!(format!("{e:#}").contains("has 6 pens"), "{e:#}");
        assert_eq!(std::fs::read_to_string(&out).unwrap(), "an earlier plot");
        let missing = dir.path().join("b.hpgl");
        assert!(write(&many_strokes(2_000, 9), &missing, &DeviceArgs::default()).is_err());
        assert!(!missing.exists());
    }

    /// Issue 40: `render old-plot.hpgl -o old-plot.gcode --device grbl-z`
    /// read the HP-GL as if written for grbl-z ("device grbl-z speaks
    /// G-code, but the file is HP-GL"): `--device` names the output's device.
    #[test]
    fn a_device_file_is_read_for_a_device_of_its_own_language() {
        let dir = tempfile::tempdir().unwrap();
        let hpgl = dir.path().join("old-plot.hpgl");
        // Two strokes 4000 plotter units (100 mm of HP-GL's 0.025 mm unit) long.
        std::fs::write(&hpgl, "IN;SP1;PU0,0;PD4000,0;PU0,400;PD0,4400;PU;").unwrap();
        let grbl = DeviceArgs { device: Some("grbl-z".into()), ..DeviceArgs::default() };
        let d = read_device_file(&hpgl, None, &grbl).expect("read with a generic HP-GL device");
        assert!((d.drawn_length() - 200.0).abs() < 1e-9, "{}", d.drawn_length());
        let out = dir.path().join("old-plot.gcode");
        write(&d, &out, &grbl).expect("written for grbl-z");
        assert!(std::fs::read_to_string(&out).unwrap().contains("G1 Z0"));
        // `--input-device` names the device the file was written for; the
        // output device, when it speaks the file's language, is the default.
        let d = read_device_file(&hpgl, Some("hp7475a"), &grbl).unwrap();
        assert!((d.drawn_length() - 8000.0 * 0.02488).abs() < 1e-9, "{}", d.drawn_length());
        let hp = DeviceArgs { device: Some("hp7475a".into()), ..DeviceArgs::default() };
        assert!((read_device_file(&hpgl, None, &hp).unwrap().drawn_length() - 8000.0 * 0.02488).abs() < 1e-9);
        let e = format!("{:#}", read_device_file(&hpgl, Some("grbl-z"), &grbl).unwrap_err());
        assert!(e.contains("--input-device grbl-z speaks G-code, but the file is HP-GL"), "{e}");
    }

    #[test]
    fn an_unwritable_file_is_an_error_naming_it() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("no-such-dir").join("a.svg");
        let e = format!("{:#}", write(&many_strokes(5_000, 1), &out, &DeviceArgs::default()).unwrap_err());
        assert!(e.starts_with(&format!("cannot write {}", out.display())), "{e}");
    }
}
