//! Single-stroke text placed in 3-D: labels, tick numbers and titles that a
//! pen draws as lines and that surfaces and faces hide like any other edge.
//!
//! The glyphs are the Hershey "simplex roman" font (one stroke per line of the
//! letter, the plotter font of choice), taken from the `vector-text-hershey`
//! crate, which ships Paul Bourke's compilation of the Hershey data.
//! Acknowledgements required with the data: the Hershey Fonts were originally
//! created by Dr. A. V. Hershey while working at the U. S. National Bureau of
//! Standards; the format of the font data in that distribution was originally
//! created by James Hurt, Cognition, Inc.
//!
//! Text is laid out in a plane given by a baseline direction and an up
//! direction in world space, so it is drawn in perspective with the scene:
//!
//! ```
//! use scene::font::{text_polylines, Align, TextPlacement};
//! use hiddenline::DVec3;
//! let place = TextPlacement::new(DVec3::ZERO, DVec3::X, DVec3::Z, 0.5);
//! let lines = text_polylines("z = 1", &place.aligned(Align::Center, Align::Start));
//! assert!(!lines.is_empty());
//! ```

use glam::DVec3;
use vector_text_core::Renderer;
use vector_text_hershey::{HersheyFont, HersheyRenderer};

/// Font units from the baseline to the top of a capital letter in the
/// Hershey simplex roman glyphs (their y runs down, baseline at +9, cap tops
/// at -12).
const CAP_UNITS: f64 = 21.0;
/// Font y of the baseline.
const BASELINE_Y: f64 = 9.0;

/// The most characters one text may have: the glyph renderer lays text out in
/// 16-bit font units, and 500 of the widest glyphs stay well inside them.
pub const MAX_TEXT_CHARS: usize = 500;

/// Where the text sits relative to its anchor, along one direction.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Align {
    /// The anchor is at the start (left edge, or baseline).
    #[default]
    Start,
    /// The anchor is in the middle.
    Center,
    /// The anchor is at the end (right edge, or cap height).
    End,
}

/// A text's frame in world space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TextPlacement {
    /// The anchor point.
    pub anchor: DVec3,
    /// Baseline direction (normalised on use).
    pub right: DVec3,
    /// Up direction of the letters (made orthogonal to `right` on use).
    pub up: DVec3,
    /// Height of a capital letter, world units.
    pub height: f64,
    /// Horizontal alignment of the anchor.
    pub halign: Align,
    /// Vertical alignment: `Start` = baseline, `Center` = half cap height,
    /// `End` = cap height.
    pub valign: Align,
}

impl TextPlacement {
    /// Text starting at `anchor` on its baseline.
    #[must_use]
    pub fn new(anchor: DVec3, right: DVec3, up: DVec3, height: f64) -> TextPlacement {
        TextPlacement { anchor, right, up, height, halign: Align::Start, valign: Align::Start }
    }

    /// The same placement with other alignments.
    #[must_use]
    pub fn aligned(mut self, halign: Align, valign: Align) -> TextPlacement {
        self.halign = halign;
        self.valign = valign;
        self
    }
}

/// Width of `text` in font units.
fn width_units(text: &str) -> f64 {
    // The extent of the ink from the text's start: what alignment needs.
    let pts = HersheyRenderer::render_text(text, HersheyFont::Romans);
    let max_x = pts.iter().map(|p| p.x).max().unwrap_or(0);
    let min_x = pts.iter().map(|p| p.x).min().unwrap_or(0);
    f64::from(max_x.max(0) - min_x.min(0))
}

/// Width of `text` at cap height `height`, world units.
#[must_use]
pub fn text_width(text: &str, height: f64) -> f64 {
    width_units(text) * height / CAP_UNITS
}

/// The strokes of `text` as world-space polylines (each at least two points),
/// laid out by `place`. Characters the font lacks are skipped; text longer than
/// [`MAX_TEXT_CHARS`] is cut there. A degenerate frame (zero or parallel
/// directions, non-positive height) draws nothing.
#[must_use]
pub fn text_polylines(text: &str, place: &TextPlacement) -> Vec<Vec<DVec3>> {
    let Some(right) = place.right.try_normalize() else { return Vec::new() };
    let Some(up) = (place.up - right * place.up.dot(right)).try_normalize() else { return Vec::new() };
    if !(place.height > 0.0 && place.height.is_finite() && place.anchor.is_finite()) {
        return Vec::new();
    }
    let text: String = text.chars().take(MAX_TEXT_CHARS).collect();
    let pts = HersheyRenderer::render_text(&text, HersheyFont::Romans);
    let scale = place.height / CAP_UNITS;
    let width = width_units(&text);
    let dx = match place.halign {
        Align::Start => 0.0,
        Align::Center => -width / 2.0,
        Align::End => -width,
    };
    let dy = match place.valign {
        Align::Start => 0.0,
        Align::Center => -CAP_UNITS / 2.0,
        Align::End => -CAP_UNITS,
    };
    let to_world = |x: i16, y: i16| {
        let u = (f64::from(x) + dx) * scale;
        let v = (BASELINE_Y - f64::from(y) + dy) * scale;
        place.anchor + right * u + up * v
    };
    let mut out: Vec<Vec<DVec3>> = Vec::new();
    let mut cur: Vec<DVec3> = Vec::new();
    for p in &pts {
        if !p.pen {
            if cur.len() >= 2 {
                out.push(std::mem::take(&mut cur));
            }
            cur.clear();
        }
        cur.push(to_world(p.x, p.y));
    }
    if cur.len() >= 2 {
        out.push(cur);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bounds(lines: &[Vec<DVec3>]) -> (DVec3, DVec3) {
        let mut it = lines.iter().flatten();
        let f = *it.next().unwrap();
        it.fold((f, f), |(lo, hi), p| (lo.min(*p), hi.max(*p)))
    }

    #[test]
    fn capitals_have_the_asked_height_on_the_baseline() {
        let lines = text_polylines("HE", &TextPlacement::new(DVec3::ZERO, DVec3::X, DVec3::Z, 2.0));
        assert!(lines.len() >= 5, "H has 3 strokes, E 4");
        let (lo, hi) = bounds(&lines);
        assert!(lo.z.abs() < 1e-12 && (hi.z - 2.0).abs() < 1e-12, "{lo} {hi}");
        assert!(lo.y.abs() < 1e-12 && hi.y.abs() < 1e-12, "flat in the x-z plane");
        assert!(lo.x >= 0.0 && hi.x > 1.5);
    }

    #[test]
    fn alignment_and_orientation() {
        let w = text_width("123", 1.0);
        assert!(w > 1.0 && w < 3.0, "{w}");
        let p = TextPlacement::new(DVec3::new(5.0, 0.0, 0.0), DVec3::Y, DVec3::Z, 1.0).aligned(Align::Center, Align::Center);
        let (lo, hi) = bounds(&text_polylines("123", &p));
        // Centred on the anchor along the baseline (y) and between baseline and cap height (z).
        assert!(((lo.y + hi.y) / 2.0).abs() < 0.2 * w, "{lo} {hi}");
        assert!((lo.z + 0.5).abs() < 0.05 && (hi.z - 0.5).abs() < 0.05, "{lo} {hi}");
        assert!(lo.x == 5.0 && hi.x == 5.0);
        let end = TextPlacement::new(DVec3::ZERO, DVec3::X, DVec3::Z, 1.0).aligned(Align::End, Align::Start);
        let (_, hi) = bounds(&text_polylines("7", &end));
        assert!(hi.x <= 1e-9 && hi.x > -0.2, "{hi}");
    }

    #[test]
    fn degenerate_placements_and_unknown_characters_draw_nothing() {
        assert!(text_polylines("A", &TextPlacement::new(DVec3::ZERO, DVec3::X, DVec3::X, 1.0)).is_empty());
        assert!(text_polylines("A", &TextPlacement::new(DVec3::ZERO, DVec3::ZERO, DVec3::Z, 1.0)).is_empty());
        assert!(text_polylines("A", &TextPlacement::new(DVec3::ZERO, DVec3::X, DVec3::Z, 0.0)).is_empty());
        assert!(text_polylines("", &TextPlacement::new(DVec3::ZERO, DVec3::X, DVec3::Z, 1.0)).is_empty());
        assert!(text_polylines("\u{4e2d}", &TextPlacement::new(DVec3::ZERO, DVec3::X, DVec3::Z, 1.0)).is_empty());
        let long = "8".repeat(MAX_TEXT_CHARS * 2);
        let n = text_polylines(&long, &TextPlacement::new(DVec3::ZERO, DVec3::X, DVec3::Z, 1.0)).len();
        assert_eq!(n, text_polylines(&"8".repeat(MAX_TEXT_CHARS), &TextPlacement::new(DVec3::ZERO, DVec3::X, DVec3::Z, 1.0)).len());
    }
}
