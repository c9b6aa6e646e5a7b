//! Single-stroke text placed in 3-D: labels, tick numbers and titles that a
//! pen draws as lines and that surfaces and faces hide like any other edge.
//!
//! The glyphs are the Hershey fonts of [`strokes::font`] (simplex roman, one
//! stroke per line of the letter, unless a placement names another).
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
pub use strokes::font::{Font, MAX_TEXT_CHARS};

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

impl Align {
    /// Where the anchor lies along `extent`, from its start.
    #[must_use]
    pub fn offset(self, extent: f64) -> f64 {
        match self {
            Align::Start => 0.0,
            Align::Center => extent / 2.0,
            Align::End => extent,
        }
    }
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
    /// The font.
    pub font: Font,
}

impl TextPlacement {
    /// Text starting at `anchor` on its baseline, in simplex roman.
    #[must_use]
    pub fn new(anchor: DVec3, right: DVec3, up: DVec3, height: f64) -> TextPlacement {
        TextPlacement { anchor, right, up, height, halign: Align::Start, valign: Align::Start, font: Font::Simplex }
    }

    /// The same placement with other alignments.
    #[must_use]
    pub fn aligned(mut self, halign: Align, valign: Align) -> TextPlacement {
        self.halign = halign;
        self.valign = valign;
        self
    }
}

/// Width of `text` at cap height `height`, world units (simplex roman).
#[must_use]
pub fn text_width(text: &str, height: f64) -> f64 {
    strokes::font::shape(text, Font::Simplex).width * height
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
    let shaped = strokes::font::shape(text, place.font);
    let (dx, dy) = (place.halign.offset(shaped.width), place.valign.offset(1.0));
    let to_world = |p: &glam::DVec2| place.anchor + right * ((p.x - dx) * place.height) + up * ((p.y - dy) * place.height);
    shaped.lines.iter().map(|line| line.iter().map(to_world).collect()).collect()
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
