//! SVG `<text>` set in single-stroke Hershey letters ([`strokes::font`]).
//!
//! usvg draws text only with the fonts of its font database, and ours is
//! empty by design (nothing outside the submitted bytes is read), so usvg
//! leaves text out of its tree. It is read here from the XML instead: each
//! `<text>` and its `<tspan>`s, their `x`, `y`, `dx`, `dy` (the first value
//! of each), `font-size` (px, mm, pt and the other units, `em` and `%` of the
//! parent's; 16 px by default), `text-anchor`, the Hershey font its
//! `font-family` names (else duplex for bold, italic for italic, else
//! simplex), and the transforms of the element and its ancestors with the
//! root's `viewBox`. Attributes are read from `style` first, then as
//! presentation attributes, inherited. Capitals are 21/32 of the font size
//! high ([`CAP_HEIGHT_PER_EM`]), as in most typefaces.
//!
//! What cannot be drawn is a warning naming the element: text inside
//! `<textPath>`, a nested `<svg>`, or reached only through `<use>`;
//! per-character `rotate`.

use std::collections::HashSet;
use strokes::font::{shape, Font};
use strokes::DVec2;
use usvg::roxmltree::{Document, Node};
use usvg::tiny_skia_path::Transform;

/// Cap height as a share of the font size: the Hershey glyphs' 21 units
/// of cap height in their 32-unit body.
pub const CAP_HEIGHT_PER_EM: f64 = 21.0 / 32.0;

/// Font size, px, when none is given (CSS `medium`).
pub const DEFAULT_FONT_SIZE_PX: f64 = 16.0;

/// One `<text>` element's strokes.
pub(crate) struct TextStrokes {
    /// The element, for pens: its nearest ancestor's id that names a layer
    /// is looked up by the caller.
    pub ancestors: Vec<String>,
    /// Its fill (or stroke) colour, black when none.
    pub colour: (u8, u8, u8),
    /// Lines in user units of the root, transforms applied.
    pub lines: Vec<Vec<DVec2>>,
}

/// Every drawable `<text>` of `doc`, and warnings for those that are not.
pub(crate) fn texts(doc: &Document, size_px: (f64, f64)) -> (Vec<TextStrokes>, Vec<String>) {
    let root = doc.root_element();
    let root_ts = view_box_transform(root, size_px);
    let used: HashSet<&str> = doc
        .descendants()
        .filter(|n| n.has_tag_name("use"))
        .filter_map(|n| n.attributes().find(|a| a.name() == "href").map(|a| a.value().trim().trim_start_matches('#')))
        .collect();
    let (mut out, mut warnings) = (Vec::new(), Vec::new());
    for node in doc.descendants().filter(|n| n.has_tag_name("text")) {
        let name = describe(doc, node);
        let ancestors: Vec<Node> = node.ancestors().filter(Node::is_element).collect();
        if ancestors.iter().any(|a| matches!(a.tag_name().name(), "defs" | "symbol" | "clipPath" | "mask" | "pattern" | "marker")) {
            if ancestors.iter().chain([&node]).any(|a| a.attribute("id").is_some_and(|id| used.contains(id))) {
                warnings.push(format!("{name} is drawn through <use>, which plotd does not follow for text: not drawn"));
            }
            continue;
        }
        if ancestors.iter().chain([&node]).any(|a| style(*a, "display") == Some("none")) {
            continue;
        }
        if matches!(inherited(node, "visibility"), Some("hidden" | "collapse")) {
            continue;
        }
        if ancestors.iter().any(|a| a.has_tag_name("svg") && *a != root) {
            warnings.push(format!("{name} lies in a nested <svg>: not drawn"));
            continue;
        }
        if node.descendants().any(|d| d.has_tag_name("textPath")) {
            warnings.push(format!("{name} follows a <textPath>: not drawn"));
            continue;
        }
        if node.descendants().any(|d| d.attribute("rotate").is_some()) {
            warnings.push(format!("{name}: per-letter rotate is not drawn (the letters stand upright)"));
        }
        let mut ts = root_ts;
        for a in ancestors.iter().rev().chain([&node]).filter(|a| **a != root) {
            if let Some(t) = a.attribute("transform").and_then(|v| v.parse::<svgtypes::Transform>().ok()) {
                ts = ts.pre_concat(Transform::from_row(t.a as f32, t.b as f32, t.c as f32, t.d as f32, t.e as f32, t.f as f32));
            }
        }
        let mut layout = Layout::default();
        layout.element(node, font_size(node));
        layout.finish_chunk();
        let apply = |p: DVec2| {
            let (x, y) = (p.x as f32, p.y as f32);
            DVec2::new(f64::from(ts.sx * x + ts.kx * y + ts.tx), f64::from(ts.ky * x + ts.sy * y + ts.ty))
        };
        let lines: Vec<Vec<DVec2>> = layout.lines.into_iter().map(|l| l.into_iter().map(apply).collect()).collect();
        if lines.is_empty() {
            continue;
        }
        out.push(TextStrokes {
            ancestors: ancestors.iter().filter_map(|a| a.attribute("id").map(str::to_owned)).collect(),
            colour: colour(node),
            lines,
        });
    }
    (out, warnings)
}

/// `<text id="..."> at line N` (or without the id).
fn describe(doc: &Document, node: Node) -> String {
    let line = doc.text_pos_at(node.range().start).row;
    match node.attribute("id") {
        Some(id) => format!("<text id=\"{}\"> at line {line}", excerpt(id)),
        None => format!("<text> at line {line}"),
    }
}

/// The root's `viewBox` mapped onto its size (px), as SVG's
/// `preserveAspectRatio` says (default: uniform, centred).
fn view_box_transform(root: Node, (w, h): (f64, f64)) -> Transform {
    let Some(vb) = root.attribute("viewBox").and_then(|v| v.parse::<svgtypes::ViewBox>().ok()) else { return Transform::identity() };
    if !(vb.w > 0.0 && vb.h > 0.0) {
        return Transform::identity();
    }
    let aspect = root.attribute("preserveAspectRatio").and_then(|v| v.parse::<svgtypes::AspectRatio>().ok()).unwrap_or_default();
    let (mut sx, mut sy) = (w / vb.w, h / vb.h);
    if aspect.align != svgtypes::Align::None {
        let s = if aspect.slice { sx.max(sy) } else { sx.min(sy) };
        (sx, sy) = (s, s);
    }
    use svgtypes::Align::{XMaxYMax, XMaxYMid, XMaxYMin, XMidYMax, XMidYMid, XMidYMin, XMinYMax, XMinYMid};
    let (fx, fy) = match aspect.align {
        XMidYMin => (0.5, 0.0),
        XMaxYMin => (1.0, 0.0),
        XMinYMid => (0.0, 0.5),
        XMidYMid => (0.5, 0.5),
        XMaxYMid => (1.0, 0.5),
        XMinYMax => (0.0, 1.0),
        XMidYMax => (0.5, 1.0),
        XMaxYMax => (1.0, 1.0),
        _ => (0.0, 0.0),
    };
    let (tx, ty) = ((w - vb.w * sx) * fx - vb.x * sx, (h - vb.h * sy) * fy - vb.y * sy);
    Transform::from_row(sx as f32, 0.0, 0.0, sy as f32, tx as f32, ty as f32)
}

/// A property of `node` itself: its `style` declaration, else its
/// attribute.
fn style<'a>(node: Node<'a, 'a>, name: &str) -> Option<&'a str> {
    let declared = node
        .attribute("style")
        .and_then(|s| s.split(';').filter_map(|d| d.split_once(':')).find(|(k, _)| k.trim() == name).map(|(_, v)| v.trim()));
    declared.or_else(|| node.attribute(name).map(str::trim))
}

/// A property as inherited: from `node` or its nearest ancestor that sets it.
fn inherited<'a>(node: Node<'a, 'a>, name: &str) -> Option<&'a str> {
    node.ancestors().filter(Node::is_element).find_map(|n| style(n, name).filter(|v| *v != "inherit"))
}

/// The font size of `node`, px, resolved through its ancestors.
fn font_size(node: Node) -> f64 {
    let parent = node.ancestors().skip(1).find(Node::is_element).map_or(DEFAULT_FONT_SIZE_PX, font_size);
    let Some(v) = style(node, "font-size") else { return parent };
    let named = match v {
        "xx-small" => Some(9.0),
        "x-small" => Some(10.0),
        "small" => Some(13.0),
        "medium" => Some(16.0),
        "large" => Some(18.0),
        "x-large" => Some(24.0),
        "xx-large" => Some(32.0),
        "larger" => Some(parent * 1.2),
        "smaller" => Some(parent / 1.2),
        _ => None,
    };
    named.or_else(|| v.parse::<svgtypes::Length>().ok().map(|l| px(l, parent))).filter(|s| *s > 0.0 && s.is_finite()).unwrap_or(parent)
}

/// A length in px (`em` and `%` of `font_size`).
fn px(l: svgtypes::Length, font_size: f64) -> f64 {
    use svgtypes::LengthUnit as U;
    l.number
        * match l.unit {
            U::None | U::Px => 1.0,
            U::Mm => 96.0 / 25.4,
            U::Cm => 96.0 / 2.54,
            U::In => 96.0,
            U::Pt => 4.0 / 3.0,
            U::Pc => 16.0,
            U::Em => font_size,
            U::Ex => font_size / 2.0,
            U::Percent => font_size / 100.0,
        }
}

/// The first length of a list attribute (`x="10 20"`: 10), px.
fn first_length(node: Node, name: &str, font_size: f64) -> Option<f64> {
    let v = node.attribute(name)?;
    svgtypes::LengthListParser::from(v).next()?.ok().map(|l| px(l, font_size))
}

/// The Hershey font for an element: a family naming one of plotd's
/// (`font-family="Hershey Script"`, `script`), else duplex when bold,
/// italic when italic, else simplex.
fn font(node: Node) -> Font {
    let family = inherited(node, "font-family").unwrap_or("");
    let named = family.split(',').find_map(|f| {
        let f = f.trim().trim_matches(['"', '\'']).to_ascii_lowercase();
        Font::named(f.trim_start_matches("hershey").trim())
    });
    let bold = matches!(inherited(node, "font-weight"), Some("bold" | "bolder" | "600" | "700" | "800" | "900"));
    let italic = matches!(inherited(node, "font-style"), Some("italic" | "oblique"));
    named.unwrap_or(if bold {
        Font::Duplex
    } else if italic {
        Font::Italic
    } else {
        Font::Simplex
    })
}

/// The element's fill colour (else its stroke's), black when none.
fn colour(node: Node) -> (u8, u8, u8) {
    for name in ["fill", "stroke"] {
        if let Some(svgtypes::Paint::Color(c)) = inherited(node, name).and_then(|v| svgtypes::Paint::from_str(v).ok()) {
            return (c.red, c.green, c.blue);
        }
    }
    (0, 0, 0)
}

/// Text laid out along its chunks: a chunk starts at each absolute `x` or
/// `y` and is shifted as a whole by its `text-anchor`.
#[derive(Default)]
struct Layout {
    /// The pen's position for the next letter, user units (y down).
    at: DVec2,
    /// Where the current chunk started in `lines`, and its anchor.
    chunk_start: usize,
    chunk_x: f64,
    anchor: f64,
    lines: Vec<Vec<DVec2>>,
    /// Whether the last text ended with a space (collapsed into the next).
    space: bool,
}

impl Layout {
    fn element(&mut self, node: Node, size: f64) {
        let (x, y) = (first_length(node, "x", size), first_length(node, "y", size));
        if x.is_some() || y.is_some() {
            self.finish_chunk();
            self.at = DVec2::new(x.unwrap_or(self.at.x), y.unwrap_or(self.at.y));
            self.chunk_x = self.at.x;
            self.anchor = match inherited(node, "text-anchor") {
                Some("middle") => 0.5,
                Some("end") => 1.0,
                _ => 0.0,
            };
        }
        self.at += DVec2::new(first_length(node, "dx", size).unwrap_or(0.0), first_length(node, "dy", size).unwrap_or(0.0));
        let font = font(node);
        for child in node.children() {
            if child.is_text() {
                self.text(child.text().unwrap_or(""), size, font);
            } else if child.is_element() && matches!(child.tag_name().name(), "tspan" | "a") {
                self.element(child, font_size(child));
            }
        }
    }

    /// A run of text, its white space collapsed.
    fn text(&mut self, raw: &str, size: f64, font: Font) {
        let mut s = String::new();
        for c in raw.chars() {
            let c = if c.is_whitespace() { ' ' } else { c };
            if c == ' ' && (self.space || (s.is_empty() && self.lines.len() == self.chunk_start && self.at.x == self.chunk_x)) {
                continue;
            }
            self.space = c == ' ';
            s.push(c);
        }
        if s.is_empty() {
            return;
        }
        let shaped = shape(&s, font);
        let cap = size * CAP_HEIGHT_PER_EM;
        let at = self.at;
        self.lines.extend(shaped.lines.iter().map(|l| l.iter().map(|p| DVec2::new(at.x + p.x * cap, at.y - p.y * cap)).collect()));
        self.at.x += shaped.advance * cap;
    }

    /// Shifts the chunk just laid out by its anchor.
    fn finish_chunk(&mut self) {
        let shift = -(self.at.x - self.chunk_x) * self.anchor;
        for line in &mut self.lines[self.chunk_start..] {
            for p in line {
                p.x += shift;
            }
        }
        self.chunk_start = self.lines.len();
        self.space = false;
    }
}

/// An element id as an error quotes it: at most 40 characters.
pub(crate) fn excerpt(id: &str) -> String {
    cut(id, 40)
}

/// `text` cut to `chars` characters, `...` marking the cut.
pub(crate) fn cut(text: &str, chars: usize) -> String {
    match text.char_indices().nth(chars) {
        Some((at, _)) => format!("{}...", &text[..at]),
        None => text.to_owned(),
    }
}
