//! `plotd render`: scene file to a drawing file, no plotter involved.

use crate::cli::RenderArgs;
use anyhow::bail;
use hiddenline::{Drawing, MotionModel, PlotStats, Scene};
use hiddenline::DVec2;
use std::path::Path;

/// Loads the scene, renders it, writes the output file and prints the one-line
/// summary to stderr.
///
/// # Errors
/// A bad scene (the message names the file, line and field), an unknown
/// output format, or an output file that cannot be written.
pub fn run(args: &RenderArgs) -> anyhow::Result<()> {
    let format = output_format(&args.output)?;
    let device = crate::dryrun::DeviceArgs { device: args.device.clone(), paper: args.paper.clone(), relative: args.relative };
    // An HP-GL / G-code input is read back into a drawing and re-emitted.
    if crate::dryrun::is_device_file(&args.scene) {
        let drawing = crate::dryrun::read_device_file(&args.scene, &device)?;
        let written = crate::dryrun::write(&drawing, &args.output, &device)?;
        eprintln!("{}{}", summary(&args.output, &drawing), crate::dryrun::summary_suffix(&written));
        return Ok(());
    }
    let scene = Scene::load(&args.scene)?;
    if let Some(pattern) = crate::frames::FramePattern::parse(&args.output)? {
        if format != Format::Svg {
            bail!("{}: frame sequences are written as .svg only", args.output.display());
        }
        // One file per frame of the `[animation]` (one for a still), in parallel.
        let frames = crate::frames::render_all(&scene, &pattern, draw, |d| encode(format, d))?;
        for (path, drawing) in &frames {
            eprintln!("{}", summary(path, drawing));
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
    let drawing = draw(&scene)?;
    // SVG, HP-GL or G-code for the chosen device (`dryrun`).
    let written = crate::dryrun::write(&drawing, &args.output, &device)?;
    eprintln!("{}{}", summary(&args.output, &drawing), crate::dryrun::summary_suffix(&written));
    Ok(())
}

/// One scene (or one frame of an animation) to a drawing.
fn draw(scene: &Scene) -> anyhow::Result<Drawing> {
    Ok(hiddenline::render(scene)?)
}

/// A drawing as the bytes of `format`.
fn encode(format: Format, drawing: &Drawing) -> Vec<u8> {
    match format {
        Format::Svg => plotcode::svg::write(drawing).into_bytes(),
        // Frame sequences are SVG only (checked before rendering).
        Format::Hpgl | Format::Gcode => Vec::new(),
    }
}

/// Output formats, by file extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Format {
    Svg,
    Hpgl,
    Gcode,
}

fn output_format(path: &Path) -> anyhow::Result<Format> {
    Ok(match crate::dryrun::OutputFormat::from_path(path)? {
        crate::dryrun::OutputFormat::Svg => Format::Svg,
        crate::dryrun::OutputFormat::Hpgl => Format::Hpgl,
        crate::dryrun::OutputFormat::Gcode => Format::Gcode,
    })
}

/// `OUT: visible length L mm, N strokes, pen-up travel T mm, est. plot time M:SS`.
fn summary(out: &Path, drawing: &Drawing) -> String {
    let visible: f64 = drawing
        .layers
        .iter()
        .filter(|l| l.kind == hiddenline::LineKind::Visible)
        .flat_map(|l| &l.polylines)
        .map(hiddenline::Polyline::length)
        .sum();
    let stats: PlotStats = MotionModel::default().plot_stats(drawing, DVec2::ZERO);
    let secs = stats.seconds.round() as u64;
    format!(
        "{}: visible length {visible:.1} mm, {} strokes, pen-up travel {:.1} mm, est. plot time {}:{:02}",
        out.display(),
        stats.strokes,
        stats.travel_mm,
        secs / 60,
        secs % 60
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use hiddenline::{LineKind, Polyline};

    #[test]
    fn formats_by_extension() {
        assert_eq!(output_format(Path::new("a.SVG")).unwrap(), Format::Svg);
        assert!(output_format(Path::new("a.pdf")).unwrap_err().to_string().contains("a.pdf"));
        assert!(output_format(Path::new("a")).is_err());
    }

    #[test]
    fn summary_counts_visible_length_and_strokes() {
        let mut d = Drawing::new(100.0, 100.0);
        d.layer_mut(1, LineKind::Visible).polylines.push(Polyline::new(vec![DVec2::ZERO, DVec2::new(30.0, 40.0)]));
        d.layer_mut(2, LineKind::Hidden).polylines.push(Polyline::new(vec![DVec2::ZERO, DVec2::new(10.0, 0.0)]));
        let s = summary(Path::new("o.svg"), &d);
        assert!(s.starts_with("o.svg: visible length 50.0 mm, 2 strokes, pen-up travel "), "{s}");
    }
}
