//! Single-stroke lettering: text as the pen draws it, in the Hershey fonts.
//!
//! A plotter draws text as lines, one pass of the pen per stroke of a
//! letter, and the Hershey fonts are made of such strokes: simplex roman,
//! the plotter font of choice, a pen line per stroke; duplex and triplex
//! with two and three lines where a printed letter is thicker; script,
//! italic and gothic. The glyph data are those of the `vector-text-hershey`
//! crate (Paul Bourke's compilation). Acknowledgements required with the
//! data: the Hershey Fonts were originally created by Dr. A. V. Hershey
//! while working at the U. S. National Bureau of Standards; the format of
//! the font data in that distribution was originally created by James
//! Hurt, Cognition, Inc.
//!
//! [`shape`] lays text out in units of the font's cap height, on a baseline
//! at y = 0 with y up; the scene (labels, `[[text]]`, in 3-D or on the
//! page) and SVG `<text>` place and scale it.
//!
//! ```
//! use strokes::font::{shape, Font};
//! let text = shape("Hi", Font::Simplex);
//! assert!(!text.lines.is_empty() && text.width > 0.5);
//! ```

use glam::DVec2;
use vector_text_core::Renderer;
use vector_text_hershey::{HersheyFont, HersheyRenderer};

/// The most characters one text may have: the glyph renderer lays text out
/// in 16-bit font units, and 500 of the widest glyphs stay well inside them.
pub const MAX_TEXT_CHARS: usize = 500;

/// A Hershey font.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Font {
    /// Simplex roman: one stroke per line of the letter.
    #[default]
    Simplex,
    /// Duplex roman: two strokes where the letter is heavy.
    Duplex,
    /// Complex roman: a serif letter.
    Complex,
    /// Triplex roman: heavy serif capitals.
    Triplex,
    /// Simplex script.
    Script,
    /// Complex italic.
    Italic,
    /// Gothic English.
    Gothic,
    /// Simplex Greek.
    Greek,
}

impl Font {
    /// Every font, with the name a scene file gives it.
    pub const NAMED: [(&'static str, Font); 8] = [
        ("simplex", Font::Simplex),
        ("duplex", Font::Duplex),
        ("complex", Font::Complex),
        ("triplex", Font::Triplex),
        ("script", Font::Script),
        ("italic", Font::Italic),
        ("gothic", Font::Gothic),
        ("greek", Font::Greek),
    ];

    /// The font of a name in [`Font::NAMED`] (case ignored).
    #[must_use]
    pub fn named(name: &str) -> Option<Font> {
        Font::NAMED.iter().find(|(n, _)| n.eq_ignore_ascii_case(name)).map(|&(_, f)| f)
    }

    /// Its name in [`Font::NAMED`].
    #[must_use]
    pub fn name(self) -> &'static str {
        Font::NAMED.iter().find(|(_, f)| *f == self).map_or("simplex", |&(n, _)| n)
    }

    fn hershey(self) -> HersheyFont {
        match self {
            Font::Simplex => HersheyFont::Romans,
            Font::Duplex => HersheyFont::Romand,
            Font::Complex => HersheyFont::Romanc,
            Font::Triplex => HersheyFont::Romant,
            Font::Script => HersheyFont::Scripts,
            Font::Italic => HersheyFont::Italicc,
            Font::Gothic => HersheyFont::Gotheng,
            Font::Greek => HersheyFont::Greeks,
        }
    }
}

/// Text in strokes, in units of the font's cap height: the baseline at
/// y = 0, capitals 1 high, y up, starting at x = 0.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Lettering {
    /// Pen-down polylines, each at least two points.
    pub lines: Vec<Vec<DVec2>>,
    /// Width from x = 0 to the far edge of the ink: what alignment needs.
    pub width: f64,
    /// Where the next letter would start: spaces and the letters' own
    /// margins included, what runs of text set one after another need.
    pub advance: f64,
}

/// The font units of the baseline and the cap line (the Hershey glyphs' y
/// runs down): the foot and the top of the font's `H`.
fn cap_lines(font: Font) -> (f64, f64) {
    let pts = HersheyRenderer::render_text("H", font.hershey());
    let foot = pts.iter().map(|p| p.y).max().unwrap_or(9);
    let top = pts.iter().map(|p| p.y).min().unwrap_or(-12);
    (f64::from(foot), f64::from(top).min(f64::from(foot) - 1.0))
}

/// `text` in strokes of `font` ([`Lettering`]). Characters the font lacks
/// (beyond Latin-1, or without a glyph) are skipped; text longer than
/// [`MAX_TEXT_CHARS`] is cut there.
#[must_use]
pub fn shape(text: &str, font: Font) -> Lettering {
    let text: String = text.chars().take(MAX_TEXT_CHARS).collect();
    let pts = HersheyRenderer::render_text(&text, font.hershey());
    let (baseline, cap) = cap_lines(font);
    let unit = 1.0 / (baseline - cap);
    let to_em = |x: i16, y: i16| DVec2::new(f64::from(x) * unit, (baseline - f64::from(y)) * unit);
    let max_x = pts.iter().map(|p| p.x).max().unwrap_or(0);
    let min_x = pts.iter().map(|p| p.x).min().unwrap_or(0);
    let width = f64::from(max_x.max(0) - min_x.min(0)) * unit;
    let mut lines: Vec<Vec<DVec2>> = Vec::new();
    let mut cur: Vec<DVec2> = Vec::new();
    for p in &pts {
        if !p.pen && cur.len() >= 2 {
            lines.push(std::mem::take(&mut cur));
        }
        if !p.pen {
            cur.clear();
        }
        cur.push(to_em(p.x, p.y));
    }
    if cur.len() >= 2 {
        lines.push(cur);
    }
    // An `H` after the text starts where the next letter would: its ink
    // ends there plus its own width.
    let far_x = |t: &str| HersheyRenderer::render_text(t, font.hershey()).iter().map(|p| p.x).max().map_or(0.0, f64::from);
    let advance = (far_x(&format!("{text}H")) - far_x("H")) * unit;
    Lettering { lines, width, advance }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bounds(l: &Lettering) -> (DVec2, DVec2) {
        l.lines.iter().flatten().fold((DVec2::INFINITY, DVec2::NEG_INFINITY), |(lo, hi), p| (lo.min(*p), hi.max(*p)))
    }

    #[test]
    fn capitals_stand_one_high_on_the_baseline_in_every_font() {
        for (name, font) in Font::NAMED {
            let (lo, hi) = bounds(&shape("HIE", font));
            assert!(lo.y.abs() < 1e-12 && (hi.y - 1.0).abs() < 1e-12, "{name}: {lo} {hi}");
            assert!(lo.x >= 0.0 && hi.x > 1.0, "{name}: {lo} {hi}");
            assert_eq!(Font::named(name), Some(font));
            assert_eq!(font.name(), name);
        }
        assert_eq!(Font::named("SIMPLEX"), Some(Font::Simplex));
        assert_eq!(Font::named("wingdings"), None);
    }

    #[test]
    fn descenders_go_below_and_width_grows_with_the_text() {
        let (lo, _) = bounds(&shape("gy", Font::Simplex));
        assert!(lo.y < -0.2, "{lo}");
        assert!(shape("HH", Font::Simplex).width > 1.8 * shape("H", Font::Simplex).width);
        // Spaces advance without ink.
        let (word, spaced) = (shape("A", Font::Simplex), shape("A  ", Font::Simplex));
        assert_eq!(word.width, spaced.width);
        assert!(spaced.advance > word.advance + 0.5 && word.advance >= word.width, "{} {}", word.advance, spaced.advance);
        // A heavier font draws more strokes for the same letter.
        assert!(shape("H", Font::Duplex).lines.len() > shape("H", Font::Simplex).lines.len());
    }

    #[test]
    fn unknown_characters_and_long_texts() {
        assert!(shape("\u{4e2d}", Font::Simplex).lines.is_empty());
        assert!(shape("", Font::Simplex).lines.is_empty());
        let long = shape(&"8".repeat(MAX_TEXT_CHARS * 2), Font::Simplex);
        assert_eq!(long.lines.len(), shape(&"8".repeat(MAX_TEXT_CHARS), Font::Simplex).lines.len());
    }
}
