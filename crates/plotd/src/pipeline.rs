//! The one path from a scene (or an SVG drawing) to ordered strokes.
//!
//! `plotd render`, the daemon's scene and SVG jobs, `demo` and the
//! end-to-end tests' oracle all call these, so a dry run and a real plot
//! draw the same strokes in the same order.

use scene::Scene;
use strokes::{Drawing, StrokeOptions};

/// A scene as a plotter draws it: the visible lines, chained and ordered.
/// Everything that plots a scene (`render`, the daemon's scene jobs, `demo`)
/// goes through here, so a dry run and a real plot draw the same strokes in the
/// same order.
///
/// # Errors
/// The scene cannot be rendered (see [`scene::render`]).
pub fn plotted_drawing(scene: Scene) -> Result<Drawing, scene::RenderError> {
    Ok(ordered(scene::render(scene)?))
}

/// An SVG file's drawing as a plotter draws it (on its own page size, less
/// what its fills hide when `occlusion` asks, chained and ordered): what
/// `plotd render drawing.svg` writes and what the daemon plots for an SVG
/// job. What of it cannot be drawn is logged.
///
/// # Errors
/// The SVG cannot be read (the error says where).
pub fn plotted_svg(text: &str, occlusion: Option<strokes::occult::Occlusion>) -> Result<Drawing, plotcode::svg_import::SvgImportError> {
    let imported = read_svg(text, occlusion)?;
    for w in &imported.warnings {
        tracing::warn!("{w}");
    }
    Ok(ordered(imported.drawing))
}

/// An SVG file's drawing as it is: its own page size, its strokes in file
/// order, less what later fills hide when `occlusion` asks; and the
/// elements it could not draw.
///
/// # Errors
/// The SVG cannot be read (the error says where).
pub fn read_svg(
    text: &str,
    occlusion: Option<strokes::occult::Occlusion>,
) -> Result<plotcode::svg_import::Imported, plotcode::svg_import::SvgImportError> {
    plotcode::svg_import::import(text, &plotcode::svg_import::ImportOptions { occlusion, ..Default::default() })
}

/// The strokes chained and ordered for the plotter.
#[must_use]
pub fn ordered(drawing: Drawing) -> Drawing {
    strokes::optimize(drawing, &StrokeOptions::default())
}

/// [`ordered`], and `beside` run on the final lines while they are ordered
/// ([`strokes::optimize_beside`]).
pub fn ordered_beside<R: Send>(drawing: Drawing, beside: impl FnOnce(&Drawing) -> R + Send) -> (Drawing, R) {
    strokes::optimize_beside(drawing, &StrokeOptions::default(), beside)
}
