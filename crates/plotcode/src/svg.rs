//! SVG output: the drawing as Inkscape layers, one per (pen, line kind).
//!
//! The file is sized in millimetres (`width="297mm"`, `viewBox="0 0 297 210"`), so
//! one user unit is one millimetre and the drawing plots at its true size from
//! Inkscape, vpype or AxiDraw tools. Page space has y up and SVG has y down, so
//! every y is written as `height - y`; nothing else is transformed, which keeps
//! the coordinates readable and importers simple.
//!
//! Each pen is one top-level `<g inkscape:groupmode="layer">` whose id and
//! label number are the pen (`id="layer4"`, label "4 pen 4" for pen 4), as
//! vpype and the AxiDraw tools expect: they take a layer's number from its id
//! or label, and plot layer 4 with pen 4. A pen's hidden lines are in that
//! pen's layer, in a nested plain group that is dashed; hidden lines on a pen
//! of their own are therefore that pen's layer. Pens appear in the order they
//! are first plotted.
//!
//! Output is deterministic: the same drawing gives the same bytes.

use crate::decimal;
use crate::emit::Sink;
use rayon::prelude::*;
use std::fmt::Write as _;
use strokes::{Dash, Drawing, Layer, LineKind, Polyline};

/// Decimal places written for coordinates: 1 µm, far below any pen width.
const DECIMALS: u32 = 3;

/// Stroke width of every layer, mm (a typical fine-liner).
const STROKE_WIDTH_MM: f64 = 0.3;

/// Screen colours for pens 1..=8 (the order of an HP 7475A carousel's usual
/// black, red, green, blue, ...); higher pens wrap around. Only for viewing: the
/// plotter takes the pen number, not the colour.
const PEN_COLOURS: [&str; 8] = ["#000000", "#d62728", "#2ca02c", "#1f77b4", "#ff7f0e", "#9467bd", "#8c564b", "#17becf"];

/// How a pen looks on screen, from a plotter's pen table: its ink's colour
/// (as SVG names one) and its line width, mm. What is left out keeps the
/// screen colour of its number and [`STROKE_WIDTH_MM`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PenLook {
    /// The ink (`"#1f4e79"`, `"red"`).
    pub colour: Option<String>,
    /// The line width, mm.
    pub width_mm: Option<f64>,
}

/// Each pen's look, by pen number.
pub type PenLooks = std::collections::BTreeMap<u32, PenLook>;

/// The drawing as a standalone SVG document.
///
/// Polylines with fewer than two points draw nothing and are left out; so are
/// polylines containing a non-finite coordinate (they would make the file
/// invalid), with a warning.
#[must_use]
pub fn write(drawing: &Drawing) -> String {
    // About 14 bytes a point: one allocation instead of twenty doublings.
    let points: usize = drawing.layers.iter().flat_map(|l| &l.polylines).map(|p| p.points.len()).sum();
    let mut out = String::with_capacity(1024 + 14 * points);
    write_to(drawing, &mut |piece: String| out.push_str(&piece));
    out
}

/// [`write`], the text handed to `sink` piece by piece as it is written.
pub fn write_to(drawing: &Drawing, sink: &mut Sink<'_>) {
    write_with(drawing, &PenLooks::new(), sink);
}

/// [`write_to`], each pen drawn as `looks` says (a plotter's pen table).
pub fn write_with(drawing: &Drawing, looks: &PenLooks, sink: &mut Sink<'_>) {
    let (w, h) = (drawing.width_mm, drawing.height_mm);
    let mut out = Text { head: String::new(), sink };
    out.head.push_str("<?xml version=\"1.0\" encoding=\"UTF-8\" standalone=\"no\"?>\n");
    let _ = writeln!(
        out.head,
        "<svg xmlns=\"http://www.w3.org/2000/svg\" \
         xmlns:inkscape=\"http://www.inkscape.org/namespaces/inkscape\" \
         width=\"{}mm\" height=\"{}mm\" viewBox=\"0 0 {} {}\">",
        num(w),
        num(h),
        num(w),
        num(h)
    );
    let mut pens: Vec<u32> = Vec::new();
    for layer in &drawing.layers {
        if !pens.contains(&layer.pen) {
            pens.push(layer.pen);
        }
    }
    for pen in pens {
        write_pen(&mut out, pen, looks.get(&pen), drawing.layers.iter().filter(|l| l.pen == pen), h, drawing.hidden_dash);
    }
    out.head.push_str("</svg>\n");
    out.flush();
}

/// The text on its way to the sink: the short lines between polylines
/// gather in `head` and go ahead of the next piece of polylines.
struct Text<'a, 's> {
    head: String,
    sink: &'a mut Sink<'s>,
}

impl Text<'_, '_> {
    fn piece(&mut self, piece: String) {
        self.flush();
        if !piece.is_empty() {
            (self.sink)(piece);
        }
    }

    fn flush(&mut self) {
        if !self.head.is_empty() {
            (self.sink)(std::mem::take(&mut self.head));
        }
    }
}

/// The Inkscape label of pen `pen`'s layer: the pen number first (vpype
/// reads it), then what the layer holds.
#[must_use]
pub fn layer_label(pen: u32, visible: bool, hidden: bool) -> String {
    match (visible, hidden) {
        (true, true) => format!("{pen} pen {pen} (visible and hidden lines)"),
        (false, true) => format!("{pen} pen {pen} (hidden lines)"),
        _ => format!("{pen} pen {pen}"),
    }
}

/// `text` as an XML attribute value in double quotes.
fn attribute(text: &str) -> String {
    text.replace('&', "&amp;").replace('"', "&quot;").replace('<', "&lt;").replace('>', "&gt;")
}

/// One pen's layer: its visible lines, then its hidden ones in a dashed group.
fn write_pen<'a>(
    out: &mut Text<'_, '_>,
    pen: u32,
    look: Option<&PenLook>,
    layers: impl Iterator<Item = &'a Layer> + Clone,
    height: f64,
    dash: Dash,
) {
    let has = |kind| layers.clone().any(|l| l.kind == kind);
    let screen = PEN_COLOURS[(pen.max(1) as usize - 1) % PEN_COLOURS.len()];
    // The colour comes from a config file: escaped, it cannot end the attribute.
    let colour = look.and_then(|l| l.colour.as_deref()).map_or_else(|| screen.to_owned(), attribute);
    let width = look.and_then(|l| l.width_mm).filter(|w| w.is_finite() && *w > 0.0).unwrap_or(STROKE_WIDTH_MM);
    let _ = writeln!(
        out.head,
        "  <g inkscape:groupmode=\"layer\" id=\"layer{pen}\" inkscape:label=\"{}\" \
         fill=\"none\" stroke=\"{colour}\" stroke-width=\"{}\" \
         stroke-linecap=\"round\" stroke-linejoin=\"round\">",
        layer_label(pen, has(LineKind::Visible), has(LineKind::Hidden)),
        num(width)
    );
    for layer in layers.clone().filter(|l| l.kind == LineKind::Visible) {
        write_polylines(out, layer, height, "    ");
    }
    if has(LineKind::Hidden) {
        let _ = writeln!(out.head, "    <g id=\"layer{pen}-hidden\" stroke-dasharray=\"{} {}\">", num(dash.dash_mm), num(dash.gap_mm));
        for layer in layers.filter(|l| l.kind == LineKind::Hidden) {
            write_polylines(out, layer, height, "      ");
        }
        out.head.push_str("    </g>\n");
    }
    out.head.push_str("  </g>\n");
}

/// Formatting coordinates is nearly all of writing: polylines are formatted
/// in parallel, a batch at a time, and handed on in their order, so the file
/// is the same.
fn write_polylines(out: &mut Text<'_, '_>, layer: &Layer, height: f64, indent: &str) {
    for batch in layer.polylines.chunks(POLYLINES_PER_BATCH) {
        let texts: Vec<String> =
            batch.par_chunks(POLYLINES_PER_TASK).map(|polys| polylines_text(polys, layer.pen, height, indent)).collect();
        for t in texts {
            out.piece(t);
        }
    }
}

/// Polylines formatted per parallel task.
const POLYLINES_PER_TASK: usize = 64;
/// Polylines formatted before their text is handed on.
const POLYLINES_PER_BATCH: usize = 16 * POLYLINES_PER_TASK;

fn polylines_text(polylines: &[Polyline], pen: u32, height: f64, indent: &str) -> String {
    // A page coordinate takes 7 bytes or so, a point 15: sized so that the
    // text is not copied as it grows.
    let mut out = Vec::with_capacity(polylines.iter().map(|p| indent.len() + 24 + 16 * p.points.len()).sum());
    for poly in polylines {
        if poly.points.len() < 2 {
            continue;
        }
        if !poly.points.iter().all(|p| p.is_finite()) {
            tracing::warn!(pen, "svg: polyline with a non-finite coordinate left out");
            continue;
        }
        out.extend_from_slice(indent.as_bytes());
        out.extend_from_slice(b"<polyline points=\"");
        for (k, p) in poly.points.iter().enumerate() {
            if k > 0 {
                out.push(b' ');
            }
            decimal::push_pair::<DECIMALS>(&mut out, p.x, b',', height - p.y);
        }
        out.extend_from_slice(b"\"/>\n");
    }
    String::from_utf8(out).expect("numbers and ASCII markup")
}

/// A coordinate with [`DECIMALS`] places, trailing zeros and a negative zero
/// dropped, so files are small and byte-for-byte reproducible.
fn num(v: f64) -> String {
    let mut s = Vec::new();
    decimal::push::<DECIMALS>(&mut s, v);
    String::from_utf8(s).expect("a number is ASCII")
}

#[cfg(test)]
mod tests {
    use super::*;
    use strokes::{DVec2, Polyline};

    fn pl(pts: &[(f64, f64)]) -> Polyline {
        Polyline::new(pts.iter().map(|&(x, y)| DVec2::new(x, y)).collect())
    }

    /// The numbers of every `points="..."` attribute, in order.
    fn polylines(svg: &str) -> Vec<Vec<(f64, f64)>> {
        svg.split("points=\"")
            .skip(1)
            .map(|rest| {
                rest.split('"')
                    .next()
                    .unwrap()
                    .split(' ')
                    .map(|pair| {
                        let (x, y) = pair.split_once(',').unwrap();
                        (x.parse().unwrap(), y.parse().unwrap())
                    })
                    .collect()
            })
            .collect()
    }

    #[test]
    fn a_pen_look_gives_its_layer_colour_and_width_others_keep_the_screen_colours() {
        let mut d = Drawing::new(10.0, 10.0);
        d.layer_mut(1, LineKind::Visible).polylines.push(pl(&[(0.0, 0.0), (1.0, 1.0)]));
        d.layer_mut(2, LineKind::Visible).polylines.push(pl(&[(0.0, 1.0), (1.0, 0.0)]));
        let looks = PenLooks::from([(1, PenLook { colour: Some("#1f4e79\"&".into()), width_mm: Some(0.7) })]);
        let mut svg = String::new();
        write_with(&d, &looks, &mut |piece: String| svg.push_str(&piece));
        assert!(
            svg.contains("id=\"layer1\" inkscape:label=\"1 pen 1\" fill=\"none\" stroke=\"#1f4e79&quot;&amp;\" stroke-width=\"0.7\""),
            "{svg}"
        );
        assert!(svg.contains("stroke=\"#d62728\" stroke-width=\"0.3\""), "{svg}");
    }

    #[test]
    fn page_size_in_mm_and_y_flipped() {
        let mut d = Drawing::new(297.0, 210.0);
        d.layer_mut(1, LineKind::Visible).polylines.push(pl(&[(10.0, 20.0), (30.5, 200.25)]));
        let svg = write(&d);
        assert!(svg.contains("width=\"297mm\" height=\"210mm\" viewBox=\"0 0 297 210\""), "{svg}");
        assert_eq!(polylines(&svg), vec![vec![(10.0, 190.0), (30.5, 9.75)]]);
    }

    #[test]
    fn one_inkscape_layer_per_pen_numbered_by_pen_hidden_dashed() {
        let mut d = Drawing::new(100.0, 100.0);
        d.layer_mut(4, LineKind::Visible).polylines.push(pl(&[(0.0, 0.0), (1.0, 1.0)]));
        d.layer_mut(1, LineKind::Visible).polylines.push(pl(&[(5.0, 5.0), (6.0, 5.0)]));
        d.layer_mut(4, LineKind::Hidden).polylines.push(pl(&[(0.0, 1.0), (1.0, 0.0)]));
        d.layer_mut(2, LineKind::Hidden).polylines.push(pl(&[(2.0, 1.0), (3.0, 0.0)]));
        let svg = write(&d);
        let groups: Vec<&str> = svg.lines().filter(|l| l.starts_with("  <g ")).collect();
        assert_eq!(groups.len(), 3, "{svg}");
        assert!(groups.iter().all(|g| g.contains("inkscape:groupmode=\"layer\"") && !g.contains("dasharray")));
        assert!(groups[0].contains("id=\"layer4\" inkscape:label=\"4 pen 4 (visible and hidden lines)\""), "{}", groups[0]);
        assert!(groups[1].contains("id=\"layer1\" inkscape:label=\"1 pen 1\""));
        assert!(groups[2].contains("id=\"layer2\" inkscape:label=\"2 pen 2 (hidden lines)\""));
        // Hidden lines: a dashed plain group inside their pen's layer.
        let nested: Vec<&str> = svg.lines().filter(|l| l.starts_with("    <g ")).collect();
        assert_eq!(
            nested,
            ["    <g id=\"layer4-hidden\" stroke-dasharray=\"3.5 1.5\">", "    <g id=\"layer2-hidden\" stroke-dasharray=\"3.5 1.5\">"]
        );
        assert_eq!(svg.matches("<polyline").count(), 4);
        assert_eq!(svg.matches("</g>").count(), 5);
    }

    #[test]
    fn degenerate_polylines_left_out() {
        let mut d = Drawing::new(10.0, 10.0);
        let l = d.layer_mut(1, LineKind::Visible);
        l.polylines.push(pl(&[]));
        l.polylines.push(pl(&[(1.0, 1.0)]));
        l.polylines.push(pl(&[(1.0, 1.0), (f64::NAN, 2.0)]));
        l.polylines.push(pl(&[(1.0, 1.0), (2.0, 2.0)]));
        let svg = write(&d);
        assert_eq!(polylines(&svg), vec![vec![(1.0, 9.0), (2.0, 8.0)]]);
        assert!(!svg.contains("NaN"));
    }

    #[test]
    fn an_independent_svg_reader_accepts_it() {
        let mut d = Drawing::new(297.0, 210.0);
        d.layer_mut(1, LineKind::Visible).polylines.push(pl(&[(10.0, 10.0), (50.0, 10.0), (50.0, 60.0)]));
        d.layer_mut(2, LineKind::Hidden).polylines.push(pl(&[(100.0, 100.0), (120.0, 150.0)]));
        let tree = usvg::Tree::from_str(&write(&d), &usvg::Options::default()).expect("usvg parses it");
        // The viewBox maps 1 user unit to 1 mm; usvg reports the size in px at 96 dpi.
        assert!((tree.size().width() as f64 - 297.0 / 25.4 * 96.0).abs() < 0.5);
        fn count_paths(g: &usvg::Group) -> usize {
            g.children()
                .iter()
                .map(|n| match n {
                    usvg::Node::Group(g) => count_paths(g),
                    usvg::Node::Path(_) => 1,
                    _ => 0,
                })
                .sum()
        }
        assert_eq!(count_paths(tree.root()), 2);
    }

    #[test]
    fn empty_drawing_is_a_valid_page() {
        let svg = write(&Drawing::new(210.0, 297.0));
        assert!(svg.starts_with("<?xml") && svg.trim_end().ends_with("</svg>"));
        assert!(!svg.contains("<g "));
    }

    #[test]
    fn deterministic_and_compact_numbers() {
        let mut d = Drawing::new(100.0, 50.0);
        d.layer_mut(3, LineKind::Visible).polylines.push(pl(&[(1.0 / 3.0, 50.0), (-0.0000001, 49.9999999)]));
        let a = write(&d);
        assert_eq!(a, write(&d.clone()));
        assert_eq!(polylines(&a), vec![vec![(0.333, 0.0), (0.0, 0.0)]]);
        assert!(a.contains("points=\"0.333,0 0,0\""), "{a}");
        assert_eq!(num(-2.5), "-2.5");
        assert_eq!(num(12.0), "12");
    }
}
