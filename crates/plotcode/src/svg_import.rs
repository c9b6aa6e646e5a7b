//! Plain SVG in: a 2-D drawing made elsewhere, to be chained, ordered and
//! plotted (no hidden-line removal).
//!
//! Parsing and geometry resolution (shapes to paths, transforms, `viewBox`,
//! units, `<use>`, CSS) are usvg's. We take every visible path (paths,
//! polylines, polygons, lines, rects, circles, ellipses), apply its full
//! transform, flatten curves to within
//! [`ImportOptions::flatness_mm`], and put it on a page of the SVG's own
//! physical size: user units are CSS pixels, 96 to the inch, after the
//! `viewBox` is mapped onto `width` x `height`. SVG's y axis points down, the
//! page's up, so y is mirrored about the page's middle: the picture looks the
//! same.
//!
//! Only the submitted bytes are read: images (`<image href>`, files or
//! `data:` URLs) are never loaded, fonts come from an empty database (so
//! usvg draws no text: `<text>` is set in Hershey strokes by `svg_text`,
//! on top of the shapes, and what it cannot draw is a warning naming the
//! element), and nothing else outside the text is opened, because the
//! daemon imports SVG jobs sent by clients and must never open a path one
//! names. Nesting is bounded ([`MAX_DEPTH`], counted through `<use>` and
//! `url(#...)` references as usvg follows them), since usvg and our own walk
//! recurse once per level.
//!
//! Pens: each Inkscape layer (`<g inkscape:groupmode="layer">`) is a pen: the
//! number its label starts with ("4 pen 4"), else the number of an id
//! `layerN` (Inkscape's and vpype's own naming, and [`crate::svg`]'s), else
//! the next pen in document order; without layers, each distinct stroke
//! colour (or fill colour for paths with no stroke) is a pen, in order of
//! first use. A dashed path is a hidden line ([`LineKind::Hidden`]), and the
//! first one's dash and gap are the drawing's `hidden_dash`, so a drawing
//! written by [`crate::svg::write`] reads back with its pens, line kinds and
//! dash pattern unchanged.

use crate::svg_text::{cut, excerpt};
use std::collections::HashMap;
use strokes::occult::{occult, Fill, FillRule, Occlusion, Shape};
use strokes::{DVec2, Drawing, LineKind, Polyline};
use thiserror::Error;
use usvg::tiny_skia_path::{PathSegment, Transform};

/// Millimetres per SVG user unit (CSS pixel, 96 per inch).
pub const MM_PER_PX: f64 = 25.4 / 96.0;

/// Default curve flattening tolerance, mm: finer than any pen line.
pub const DEFAULT_FLATNESS_MM: f64 = 0.02;

/// Most segments one curve is cut into, however tight the tolerance.
pub const MAX_SEGMENTS_PER_CURVE: usize = 4096;

/// Default limit on the points of one imported drawing.
pub const DEFAULT_MAX_POINTS: usize = 20_000_000;

/// Deepest nesting of elements an SVG may have, counting the levels a
/// `<use>` or a `url(#...)` reference adds where it is followed. Hand-made and
/// Inkscape drawings nest a few tens deep; each level costs several stack
/// frames in usvg and here, and this many fit the 2 MiB stack of a daemon
/// worker thread with room to spare.
pub const MAX_DEPTH: usize = 128;

/// Most XML nodes (elements, text, comments) an SVG may have.
pub const MAX_NODES: u32 = 1_000_000;

/// Largest distance of any drawn point from the page's origin, mm, after
/// every transform (a kilometre: no plotter draws further, and G-code input
/// has the same limit). Beyond it stroke ordering would work on numbers
/// whose gaps exceed a pen width: a circle of radius 1e12 took 106 s to
/// order, an ellipse of 9.2e18 1.3 GB.
pub const MAX_COORDINATE_MM: f64 = 1.0e6;

/// Largest magnitude of a number in path data (`d`) or a points list, in
/// user units.
pub const MAX_PATH_NUMBER: f64 = 1.0e9;

const INKSCAPE_NS: &str = "http://www.inkscape.org/namespaces/inkscape";

/// How [`read`] works.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImportOptions {
    /// Largest distance, mm, between a curve and the straight segments that
    /// replace it.
    pub flatness_mm: f64,
    /// Refuse drawings with more points than this.
    pub max_points: usize,
    /// Hide the parts of lines under later filled shapes, of the same layer
    /// (pen) or of any ([`strokes::occult`]); `None` draws every line.
    pub occlusion: Option<Occlusion>,
}

impl Default for ImportOptions {
    fn default() -> Self {
        ImportOptions { flatness_mm: DEFAULT_FLATNESS_MM, max_points: DEFAULT_MAX_POINTS, occlusion: None }
    }
}

/// An SVG read, and what of it could not be drawn.
#[derive(Clone, Debug, PartialEq)]
pub struct Imported {
    /// The drawing.
    pub drawing: Drawing,
    /// One line per element not drawn (or not drawn whole), naming it.
    pub warnings: Vec<String>,
}

/// Why an SVG could not be imported.
#[derive(Debug, Error)]
pub enum SvgImportError {
    /// Not well-formed XML, or not an SVG usvg can use.
    #[error("not a usable SVG{}: {message}", at.map(|(l, c)| format!(" (line {l}, column {c})")).unwrap_or_default())]
    Parse {
        /// What is wrong.
        message: String,
        /// Line and column (1-based) where the XML parser gave up, if known.
        at: Option<(u32, u32)>,
    },
    /// More points than [`ImportOptions::max_points`].
    #[error("the drawing has more than {limit} points after flattening curves")]
    TooLarge {
        /// The limit that was hit.
        limit: usize,
    },
    /// A flattening tolerance that is not a positive finite number.
    #[error("flatness_mm = {0} must be finite and > 0")]
    BadFlatness(f64),
    /// A drawn point farther than [`MAX_COORDINATE_MM`] from the page's origin.
    #[error("{} reaches {value:.3e} mm, beyond the limit of ±{MAX_COORDINATE_MM:e} mm", if element.is_empty() { "a path".to_owned() } else { format!("element `{element}`") })]
    TooFar {
        /// The id of the element drawing it, when it has one.
        element: String,
        /// The coordinate, mm.
        value: f64,
    },
    /// A number in path data or a points list beyond [`MAX_PATH_NUMBER`]: no
    /// drawing within [`MAX_COORDINATE_MM`] needs one, and the SVG library's
    /// arc conversion takes minutes on such numbers before any point exists
    /// to check.
    #[error("`{attribute}` at line {line} holds {value:.3e}, beyond the limit of ±{MAX_PATH_NUMBER:e}")]
    HugeNumber {
        /// The attribute (`d` or `points`).
        attribute: String,
        /// Line (1-based) of the element.
        line: u32,
        /// The number.
        value: f64,
    },
    /// Elements nested deeper than [`MAX_DEPTH`].
    #[error("elements are nested more than {limit} deep (line {line}, counting <use> and url(#...) references)")]
    TooDeep {
        /// The limit.
        limit: usize,
        /// Line (1-based) of the element where the limit is passed.
        line: u32,
    },
}

/// Reads SVG text into a drawing on the SVG's own page size.
///
/// # Errors
/// [`SvgImportError::Parse`] for malformed XML or SVG (with the line and
/// column where known), [`SvgImportError::TooLarge`] past the point limit,
/// [`SvgImportError::BadFlatness`] for a bad tolerance.
pub fn read(text: &str, options: &ImportOptions) -> Result<Drawing, SvgImportError> {
    let imported = import(text, options)?;
    for w in &imported.warnings {
        tracing::warn!("{w}");
    }
    Ok(imported.drawing)
}

/// Why a drawing the SVG library failed on is refused.
const UNCOMPUTABLE: &str = "the SVG library cannot compute this drawing (a degenerate arc or gradient: numbers at the ends of f64's range)";

/// [`read`], with its warnings handed back rather than logged.
///
/// # Errors
/// As [`read`].
pub fn import(text: &str, options: &ImportOptions) -> Result<Imported, SvgImportError> {
    if !(options.flatness_mm > 0.0 && options.flatness_mm.is_finite()) {
        return Err(SvgImportError::BadFlatness(options.flatness_mm));
    }
    check_markup_depth(text)?;
    let xml = usvg::roxmltree::ParsingOptions { allow_dtd: true, nodes_limit: MAX_NODES };
    let doc = usvg::roxmltree::Document::parse_with_options(text, xml)
        .map_err(|e| SvgImportError::Parse { message: cut_message(&e), at: Some((e.pos().row, e.pos().col)) })?;
    check_depth(&doc)?;
    check_path_numbers(&doc)?;
    let layers = inkscape_layers(&doc);
    // usvg and kurbo assert on a few degenerate values our checks let
    // through (an arc whose ends lie closer than f64 can square, a gradient
    // stop near -f64::MAX): such a drawing is refused as unreadable, never a
    // crash of the render or the daemon's worker.
    let tree = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| usvg::Tree::from_xmltree(&doc, &offline_options())))
        .map_err(|_| SvgImportError::Parse { message: UNCOMPUTABLE.into(), at: None })?
        .map_err(|e| SvgImportError::Parse { message: cut_message(&e), at: None })?;
    let size = tree.size();
    let (w, h) = (f64::from(size.width()) * MM_PER_PX, f64::from(size.height()) * MM_PER_PX);
    let mut reader =
        Reader { drawing: Drawing::new(w, h), layers, colours: HashMap::new(), options, points: 0, dash_read: false, shapes: Vec::new() };
    reader.group(tree.root(), None)?;
    // Text (which usvg leaves out: it has no fonts) in Hershey strokes, on
    // top of the shapes.
    let (texts, warnings) = crate::svg_text::texts(&doc, (f64::from(size.width()), f64::from(size.height())));
    for t in texts {
        let layer_pen = t.ancestors.iter().find_map(|id| reader.layers.get(id).copied());
        let pen = layer_pen.unwrap_or_else(|| reader.colour_pen(t.colour));
        let lines =
            t.lines.into_iter().map(|l| Polyline::new(l.into_iter().map(|p| DVec2::new(p.x * MM_PER_PX, h - p.y * MM_PER_PX)).collect()));
        reader.add(pen, LineKind::Visible, lines.collect(), None, "")?;
    }
    let Reader { mut drawing, shapes, .. } = reader;
    if let Some(occlusion) = options.occlusion {
        let (keys, shapes): (Vec<(u32, LineKind)>, Vec<Shape>) = shapes.into_iter().unzip();
        for ((pen, kind), kept) in keys.into_iter().zip(occult(&shapes, occlusion)) {
            drawing.layer_mut(pen, kind).polylines.extend(kept);
        }
    }
    Ok(Imported { drawing, warnings })
}

/// usvg options that read nothing but the text: no image is loaded (from a
/// path or a `data:` URL), no resources directory. usvg is built without
/// fonts (its `text` feature): `<text>` is drawn in single-stroke Hershey
/// letters by [`crate::svg_text`], never outlined from a system font.
fn offline_options() -> usvg::Options<'static> {
    usvg::Options {
        resources_dir: None,
        image_href_resolver: usvg::ImageHrefResolver { resolve_data: Box::new(|_, _, _| None), resolve_string: Box::new(|_, _| None) },
        ..usvg::Options::default()
    }
}

/// Refuses text whose elements nest deeper than [`MAX_DEPTH`], before any
/// XML parser sees it: roxmltree's tokenizer recurses once per level (about
/// 700 bytes of stack each), so 4,000 nested `<g>` in 28 KB overflow a 2 MiB
/// thread stack. A linear scan of the markup: comments, CDATA, processing
/// instructions and quoted attribute values are skipped; a DTD's entities
/// may not hold markup (their text would nest wherever it is referenced).
/// Malformed text that fools the scan is malformed for the parser too, which
/// then stops at the error rather than nesting deeper.
fn check_markup_depth(text: &str) -> Result<(), SvgImportError> {
    let b = text.as_bytes();
    let line_at = |i: usize| 1 + b[..i].iter().filter(|&&c| c == b'\n').count() as u32;
    let find = |from: usize, pat: &[u8]| {
        b[from.min(b.len())..].windows(pat.len()).position(|w| w == pat).map_or(b.len(), |p| from + p + pat.len())
    };
    // Index just past the `>` that ends a tag or declaration opened at `from`,
    // skipping quoted values; `dtd` also skips an internal subset `[...]` and
    // refuses markup inside its quoted literals.
    let tag_end = |from: usize, dtd: bool| -> Result<usize, SvgImportError> {
        let mut i = from;
        let mut bracket = false;
        while i < b.len() {
            match b[i] {
                q @ (b'"' | b'\'') => {
                    let close = b[i + 1..].iter().position(|&c| c == q).map_or(b.len(), |p| i + 1 + p);
                    if dtd && b[i + 1..close].contains(&b'<') {
                        let message = "a DTD entity holding markup is not supported".to_owned();
                        return Err(SvgImportError::Parse { message, at: Some((line_at(i), 1)) });
                    }
                    i = close;
                }
                b'[' if dtd => bracket = true,
                b']' if dtd => bracket = false,
                b'>' if !bracket => return Ok(i + 1),
                b'<' if dtd && bracket && b[i..].starts_with(b"<!--") => i = find(i, b"-->") - 1,
                _ => {}
            }
            i += 1;
        }
        Ok(b.len())
    };
    let mut depth = 0usize;
    let mut i = 0;
    while let Some(p) = b[i..].iter().position(|&c| c == b'<') {
        let at = i + p;
        let rest = &b[at..];
        i = if rest.starts_with(b"<!--") {
            find(at, b"-->")
        } else if rest.starts_with(b"<![CDATA[") {
            find(at, b"]]>")
        } else if rest.starts_with(b"<?") {
            find(at, b"?>")
        } else if rest.starts_with(b"<!") {
            tag_end(at, true)?
        } else if rest.starts_with(b"</") {
            depth = depth.saturating_sub(1);
            tag_end(at, false)?
        } else {
            let end = tag_end(at, false)?;
            if !b[..end].ends_with(b"/>") {
                depth += 1;
                if depth > MAX_DEPTH {
                    return Err(SvgImportError::TooDeep { limit: MAX_DEPTH, line: line_at(at) });
                }
            }
            end
        };
    }
    Ok(())
}

/// Refuses documents nested deeper than [`MAX_DEPTH`]. An element's height
/// is one more than the tallest of its child elements and of the elements
/// it references (`href="#id"`, `url(#id)` in any attribute), as usvg
/// expands them; a reference back into the elements being measured (a
/// cycle, which usvg drops) counts nothing. Iterative, so the check itself
/// cannot overflow the stack.
/// Every number of every `d` and `points` attribute within [`MAX_PATH_NUMBER`].
fn check_path_numbers(doc: &usvg::roxmltree::Document) -> Result<(), SvgImportError> {
    for node in doc.descendants().filter(usvg::roxmltree::Node::is_element) {
        for attribute in ["d", "points"] {
            let Some(text) = node.attribute(attribute) else { continue };
            if let Some(value) = path_numbers(text).find(|v| !(v.abs() <= MAX_PATH_NUMBER)) {
                let line = doc.text_pos_at(node.range().start).row;
                return Err(SvgImportError::HugeNumber { attribute: attribute.to_owned(), line, value });
            }
        }
    }
    Ok(())
}

/// The numbers of path data or a points list, as the SVG grammar runs them
/// together (`1-2`, `.5.5`, `1e3-4`); anything else separates them.
fn path_numbers(text: &str) -> impl Iterator<Item = f64> + '_ {
    let bytes = text.as_bytes();
    let mut at = 0;
    std::iter::from_fn(move || {
        while at < bytes.len() {
            let start = at;
            let (mut dot, mut exp) = (false, false);
            while at < bytes.len() {
                let c = bytes[at];
                let sign_ok = at == start || (exp && matches!(bytes[at - 1], b'e' | b'E'));
                let ok = c.is_ascii_digit()
                    || (matches!(c, b'+' | b'-') && sign_ok)
                    || (c == b'.' && !dot && !exp)
                    || (matches!(c, b'e' | b'E') && !exp && at > start);
                if !ok {
                    break;
                }
                dot |= c == b'.';
                exp |= matches!(c, b'e' | b'E');
                at += 1;
            }
            if at == start {
                at += 1;
                continue;
            }
            if let Ok(v) = text[start..at].trim_end_matches(['e', 'E', '+', '-']).parse::<f64>() {
                return Some(v);
            }
        }
        None
    })
}

fn check_depth(doc: &usvg::roxmltree::Document) -> Result<(), SvgImportError> {
    use usvg::roxmltree::Node;
    const UNSEEN: u32 = 0;
    const OPEN: u32 = u32::MAX;
    let ids: HashMap<&str, Node> = doc.descendants().filter_map(|n| n.attribute("id").map(|id| (id, n))).collect();
    let next = |n: Node<'_, '_>| -> Vec<usize> {
        let mut out: Vec<usize> = n.children().filter(Node::is_element).map(|c| c.id().get_usize()).collect();
        for a in n.attributes() {
            let v = a.value().trim();
            let target = if a.name() == "href" { v.strip_prefix('#') } else { None };
            let targets = target.into_iter().chain(v.split("url(#").skip(1).filter_map(|r| r.split(')').next()));
            out.extend(targets.filter_map(|id| ids.get(id.trim())).map(|t| t.id().get_usize()));
        }
        out
    };
    let nodes: Vec<Node> = doc.descendants().collect();
    let mut height = vec![UNSEEN; nodes.len()];
    let root = doc.root_element();
    let mut stack: Vec<(usize, Vec<usize>)> = vec![(root.id().get_usize(), next(root))];
    height[root.id().get_usize()] = OPEN;
    while let Some((node, pending)) = stack.last_mut() {
        let node = *node;
        match pending.pop() {
            Some(child) if height[child] == UNSEEN => {
                height[child] = OPEN;
                stack.push((child, next(nodes[child])));
            }
            Some(_) => {}
            None => {
                stack.pop();
                let tallest = next(nodes[node]).iter().map(|&c| if height[c] == OPEN { 0 } else { height[c] }).max().unwrap_or(0);
                height[node] = tallest + 1;
                if height[node] as usize > MAX_DEPTH {
                    let line = doc.text_pos_at(nodes[node].range().start).row;
                    return Err(SvgImportError::TooDeep { limit: MAX_DEPTH, line });
                }
            }
        }
        if stack.len() > MAX_DEPTH {
            let (deepest, _) = stack[stack.len() - 1];
            let line = doc.text_pos_at(nodes[deepest].range().start).row;
            return Err(SvgImportError::TooDeep { limit: MAX_DEPTH, line });
        }
    }
    Ok(())
}

/// Pen per Inkscape layer id, from the raw XML (usvg keeps group ids but not
/// Inkscape's attributes).
fn inkscape_layers(doc: &usvg::roxmltree::Document) -> HashMap<String, u32> {
    let mut pens = HashMap::new();
    let mut next = 1;
    for node in doc.descendants().filter(|n| n.has_tag_name("g")) {
        if node.attribute((INKSCAPE_NS, "groupmode")) != Some("layer") {
            continue;
        }
        let Some(id) = node.attribute("id") else { continue };
        let label = node.attribute((INKSCAPE_NS, "label")).unwrap_or("");
        let leading = |s: &str| s.chars().take_while(char::is_ascii_digit).collect::<String>().parse::<u32>().ok().filter(|&p| p > 0);
        let pen = leading(label.trim_start()).or_else(|| id.strip_prefix("layer").and_then(leading)).unwrap_or(next);
        next = next.max(pen + 1);
        pens.insert(id.to_string(), pen);
    }
    pens
}

struct Reader<'a> {
    drawing: Drawing,
    layers: HashMap<String, u32>,
    colours: HashMap<(u8, u8, u8), u32>,
    options: &'a ImportOptions,
    points: usize,
    /// Whether a dashed path has given the drawing its dash pattern.
    dash_read: bool,
    /// With occlusion, every shape in painting order and its layer, for
    /// [`occult`] once all are read.
    shapes: Vec<((u32, LineKind), Shape)>,
}

impl Reader<'_> {
    fn group(&mut self, g: &usvg::Group, layer_pen: Option<u32>) -> Result<(), SvgImportError> {
        let layer_pen = self.layers.get(g.id()).copied().or(layer_pen);
        for node in g.children() {
            match node {
                usvg::Node::Group(child) => self.group(child, layer_pen)?,
                usvg::Node::Path(path) => self.path(path, layer_pen)?,
                usvg::Node::Text(text) => self.group(text.flattened(), layer_pen)?,
                usvg::Node::Image(_) => {}
            }
        }
        Ok(())
    }

    fn pen_for(&mut self, path: &usvg::Path, layer_pen: Option<u32>) -> u32 {
        if let Some(p) = layer_pen {
            return p;
        }
        let paint = path.stroke().map(usvg::Stroke::paint).or_else(|| path.fill().map(usvg::Fill::paint));
        let rgb = match paint {
            Some(usvg::Paint::Color(c)) => (c.red, c.green, c.blue),
            _ => (0, 0, 0),
        };
        self.colour_pen(rgb)
    }

    /// The pen of a colour: the next pen for a colour not seen before.
    fn colour_pen(&mut self, rgb: (u8, u8, u8)) -> u32 {
        let next = self.colours.len() as u32 + 1;
        *self.colours.entry(rgb).or_insert(next)
    }

    /// Adds one element's lines (and, with occlusion, the region its fill
    /// paints) within the limits on points and coordinates.
    fn add(&mut self, pen: u32, kind: LineKind, lines: Vec<Polyline>, fill: Option<Fill>, id: &str) -> Result<(), SvgImportError> {
        let far = lines.iter().flat_map(|l| &l.points).flat_map(|p| [p.x, p.y]).find(|c| !(c.abs() <= MAX_COORDINATE_MM));
        if let Some(value) = far {
            return Err(SvgImportError::TooFar { element: excerpt(id), value });
        }
        self.points += lines.iter().map(|l| l.points.len()).sum::<usize>();
        if self.points > self.options.max_points {
            return Err(SvgImportError::TooLarge { limit: self.options.max_points });
        }
        if self.options.occlusion.is_some() {
            self.shapes.push(((pen, kind), Shape { group: pen as usize, lines, fill }));
        } else {
            self.drawing.layer_mut(pen, kind).polylines.extend(lines);
        }
        Ok(())
    }

    fn path(&mut self, path: &usvg::Path, layer_pen: Option<u32>) -> Result<(), SvgImportError> {
        if !path.is_visible() {
            return Ok(());
        }
        let pen = self.pen_for(path, layer_pen);
        let ts = path.abs_transform();
        let page_h = self.drawing.height_mm;
        let map = |p: usvg::tiny_skia_path::Point| to_page(ts, p, page_h);
        let tol = self.options.flatness_mm;
        let mut lines: Vec<Polyline> = Vec::new();
        let mut current: Vec<DVec2> = Vec::new();
        let mut start = DVec2::ZERO;
        for seg in path.data().segments() {
            let last = current.last().copied().unwrap_or(start);
            match seg {
                PathSegment::MoveTo(p) => {
                    flush(&mut current, &mut lines);
                    start = map(p);
                    current.push(start);
                }
                PathSegment::LineTo(p) => {
                    if current.is_empty() {
                        current.push(last);
                    }
                    current.push(map(p));
                }
                PathSegment::QuadTo(c, p) => {
                    if current.is_empty() {
                        current.push(last);
                    }
                    flatten_quad(last, map(c), map(p), tol, &mut current);
                }
                PathSegment::CubicTo(c1, c2, p) => {
                    if current.is_empty() {
                        current.push(last);
                    }
                    flatten_cubic(last, map(c1), map(c2), map(p), tol, &mut current);
                }
                PathSegment::Close => {
                    if current.len() >= 2 && current.last() != Some(&start) {
                        current.push(start);
                    }
                    flush(&mut current, &mut lines);
                }
            }
            if self.points + current.len() > self.options.max_points {
                return Err(SvgImportError::TooLarge { limit: self.options.max_points });
            }
        }
        flush(&mut current, &mut lines);
        let dasharray = path.stroke().and_then(usvg::Stroke::dasharray).filter(|d| !d.is_empty());
        let kind = if dasharray.is_some() { LineKind::Hidden } else { LineKind::Visible };
        // The first dashed path's dash and gap become the drawing's (in mm
        // on the page: user units through the path's scale), when plotd can
        // plot them.
        if let (Some(d), false) = (dasharray, self.dash_read) {
            self.dash_read = true;
            let scale = f64::from(ts.sx * ts.sy - ts.kx * ts.ky).abs().sqrt() * MM_PER_PX;
            let at = |i: usize| f64::from(d[i % d.len()]) * scale;
            let dash = strokes::Dash { dash_mm: at(0), gap_mm: at(1) };
            if dash.is_valid() {
                self.drawing.hidden_dash = dash;
            }
        }
        // The region the fill paints: every subpath, closed.
        let fill = self.options.occlusion.and(path.fill()).map(|f| Fill {
            rings: lines.iter().map(|l| l.points.clone()).collect(),
            rule: match f.rule() {
                usvg::FillRule::NonZero => FillRule::NonZero,
                usvg::FillRule::EvenOdd => FillRule::EvenOdd,
            },
        });
        self.add(pen, kind, lines, fill, path.id())
    }
}

/// A parser's message as an error quotes it: at most 200 characters (the
/// XML parser quotes the token it expected or found, which may be the
/// whole of a long malformed attribute).
fn cut_message(e: &impl std::fmt::Display) -> String {
    cut(&e.to_string(), 200)
}

fn to_page(ts: Transform, p: usvg::tiny_skia_path::Point, page_h: f64) -> DVec2 {
    let (x, y) = (f64::from(p.x), f64::from(p.y));
    let px = f64::from(ts.sx) * x + f64::from(ts.kx) * y + f64::from(ts.tx);
    let py = f64::from(ts.ky) * x + f64::from(ts.sy) * y + f64::from(ts.ty);
    DVec2::new(px * MM_PER_PX, page_h - py * MM_PER_PX)
}

fn flush(current: &mut Vec<DVec2>, lines: &mut Vec<Polyline>) {
    if current.len() >= 2 {
        lines.push(Polyline::new(std::mem::take(current)));
    }
    current.clear();
}

/// Segments for a curve whose second derivative is at most `d2` in length:
/// uniform steps deviate by at most `d2 / (8 n^2)`.
fn segments_for(d2: f64, tol: f64) -> usize {
    let n = (d2 / (8.0 * tol)).sqrt().ceil();
    if n.is_finite() {
        (n as usize).clamp(1, MAX_SEGMENTS_PER_CURVE)
    } else {
        MAX_SEGMENTS_PER_CURVE
    }
}

/// Appends the points after `p0` of a quadratic Bézier flattened to `tol`.
fn flatten_quad(p0: DVec2, c: DVec2, p1: DVec2, tol: f64, out: &mut Vec<DVec2>) {
    let n = segments_for(2.0 * (p0 - 2.0 * c + p1).length(), tol);
    for i in 1..=n {
        let t = i as f64 / n as f64;
        let u = 1.0 - t;
        out.push(p0 * (u * u) + c * (2.0 * u * t) + p1 * (t * t));
    }
}

/// Appends the points after `p0` of a cubic Bézier flattened to `tol`.
fn flatten_cubic(p0: DVec2, c1: DVec2, c2: DVec2, p1: DVec2, tol: f64, out: &mut Vec<DVec2>) {
    let d2 = 6.0 * (p0 - 2.0 * c1 + c2).length().max((c1 - 2.0 * c2 + p1).length());
    let n = segments_for(d2, tol);
    for i in 1..=n {
        let t = i as f64 / n as f64;
        let u = 1.0 - t;
        out.push(p0 * (u * u * u) + c1 * (3.0 * u * u * t) + c2 * (3.0 * u * t * t) + p1 * (t * t * t));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn svg(body: &str) -> String {
        format!(
            r#"<svg xmlns="http://www.w3.org/2000/svg" xmlns:inkscape="http://www.inkscape.org/namespaces/inkscape" width="100mm" height="50mm" viewBox="0 0 200 100">{body}</svg>"#
        )
    }

    fn read_ok(body: &str) -> Drawing {
        read(&svg(body), &ImportOptions::default()).expect("valid SVG")
    }

    fn close(a: DVec2, b: DVec2) -> bool {
        a.distance(b) < 1e-3
    }

    #[test]
    fn a_dash_pattern_is_read_in_millimetres() {
        // 0.5 mm per unit: a 5 4 dasharray is 2.5 mm on, 2 mm off.
        let d = read_ok(r#"<line x1="0" y1="0" x2="200" y2="0" stroke="black" stroke-dasharray="5 4"/>"#);
        assert_eq!(d.layers[0].kind, LineKind::Hidden);
        assert!((d.hidden_dash.dash_mm - 2.5).abs() < 1e-6 && (d.hidden_dash.gap_mm - 2.0).abs() < 1e-6, "{:?}", d.hidden_dash);
        // plotd's own SVG reads back with its pattern.
        let mut ours = Drawing::new(100.0, 100.0);
        ours.hidden_dash = strokes::Dash { dash_mm: 2.5, gap_mm: 1.25 };
        ours.layer_mut(2, LineKind::Hidden).polylines.push(Polyline::new(vec![DVec2::ZERO, DVec2::new(50.0, 0.0)]));
        let back = read(&crate::svg::write(&ours), &ImportOptions::default()).unwrap();
        assert!((back.hidden_dash.dash_mm - 2.5).abs() < 1e-6 && (back.hidden_dash.gap_mm - 1.25).abs() < 1e-6, "{:?}", back.hidden_dash);
        // A pattern plotd could not plot keeps the default.
        let d = read_ok(r#"<line x1="0" y1="0" x2="200" y2="0" stroke="black" stroke-dasharray="0.1 0.1"/>"#);
        assert_eq!(d.hidden_dash, strokes::Dash::default());
    }

    #[test]
    fn page_size_and_viewbox_mapping() {
        // viewBox 200 x 100 units on 100 x 50 mm: 0.5 mm per unit, y flipped.
        let d = read_ok(r#"<line x1="0" y1="0" x2="200" y2="100" stroke="black"/>"#);
        assert!((d.width_mm - 100.0).abs() < 1e-3 && (d.height_mm - 50.0).abs() < 1e-3);
        let p = &d.layers[0].polylines[0].points;
        assert!(close(p[0], DVec2::new(0.0, 50.0)) && close(p[1], DVec2::new(100.0, 0.0)), "{p:?}");
    }

    #[test]
    fn shapes_and_transforms() {
        let d = read_ok(
            r#"<g transform="translate(10 10)"><rect x="0" y="0" width="20" height="10" stroke="black" fill="none"/></g>
               <polyline points="0,0 10,0 10,10" stroke="black" fill="none"/>"#,
        );
        let polys = &d.layers[0].polylines;
        assert_eq!(polys.len(), 2);
        // Rect: closed, perimeter 2 * (20 + 10) units = 30 mm.
        assert!((polys[0].length() - 30.0).abs() < 1e-3);
        assert_eq!(polys[0].points.first(), polys[0].points.last());
        assert!(close(polys[0].points[0], DVec2::new(5.0, 45.0)));
        assert!((polys[1].length() - 10.0).abs() < 1e-3);
    }

    #[test]
    fn circles_are_flattened_within_tolerance() {
        let opts = ImportOptions { flatness_mm: 0.01, ..ImportOptions::default() };
        let d = read(&svg(r#"<circle cx="100" cy="50" r="40" stroke="black" fill="none"/>"#), &opts).expect("ok");
        let c = DVec2::new(50.0, 25.0);
        let pts = &d.layers[0].polylines[0].points;
        assert!(pts.len() > 16);
        for w in pts.windows(2) {
            // Vertices on the circle (usvg's own arc-to-cubic error included),
            // chord midpoints within the flatness.
            assert!((w[0].distance(c) - 20.0).abs() < 0.02);
            assert!(20.0 - w[0].midpoint(w[1]).distance(c) < 0.02 + 0.01);
        }
        assert!((d.drawn_length() - 2.0 * std::f64::consts::PI * 20.0).abs() < 0.05);
    }

    #[test]
    fn pens_by_colour_in_order_of_first_use() {
        let d = read_ok(
            r##"<line x1="0" y1="0" x2="1" y2="0" stroke="red"/><line x1="0" y1="1" x2="1" y2="1" stroke="blue"/>
               <line x1="0" y1="2" x2="1" y2="2" stroke="#ff0000"/><ellipse cx="50" cy="50" rx="10" ry="5" fill="blue"/>"##,
        );
        let pens: Vec<(u32, usize)> = d.layers.iter().map(|l| (l.pen, l.polylines.len())).collect();
        assert_eq!(pens, vec![(1, 2), (2, 2)]);
    }

    #[test]
    fn pens_by_inkscape_layer() {
        let d = read_ok(
            r#"<g inkscape:groupmode="layer" id="l1" inkscape:label="outline"><line x1="0" y1="0" x2="1" y2="0" stroke="red"/></g>
               <g inkscape:groupmode="layer" id="l2" inkscape:label="3 fine"><line x1="0" y1="1" x2="1" y2="1" stroke="red"/>
               <g><path d="M 0 5 L 5 5" stroke="blue"/></g></g>"#,
        );
        let pens: Vec<(u32, usize)> = d.layers.iter().map(|l| (l.pen, l.polylines.len())).collect();
        assert_eq!(pens, vec![(1, 1), (3, 2)]);
        // Without a number in the label, an id `layerN` names pen N (vpype's
        // and Inkscape's naming); dashed lines are hidden lines of that pen.
        let d = read_ok(
            r#"<g inkscape:groupmode="layer" id="layer4" inkscape:label="fine"><line x1="0" y1="0" x2="1" y2="0" stroke="red"/>
               <g stroke-dasharray="1 1"><line x1="0" y1="1" x2="1" y2="1" stroke="red"/></g></g>
               <g inkscape:groupmode="layer" id="layer2"><line x1="0" y1="2" x2="1" y2="2" stroke="red" stroke-dasharray="2"/></g>
               <g inkscape:groupmode="layer" id="outline"><line x1="0" y1="3" x2="1" y2="3" stroke="red"/></g>"#,
        );
        let pens: Vec<(u32, LineKind)> = d.layers.iter().map(|l| (l.pen, l.kind)).collect();
        assert_eq!(pens, vec![(4, LineKind::Visible), (4, LineKind::Hidden), (2, LineKind::Hidden), (5, LineKind::Visible)]);
    }

    #[test]
    fn curves_and_subpaths() {
        let d = read_ok(r#"<path d="M 0 0 Q 50 50 100 0 M 0 90 C 0 50 100 50 100 90 Z" stroke="black" fill="none"/>"#);
        let polys = &d.layers[0].polylines;
        assert_eq!(polys.len(), 2);
        assert!(polys.iter().all(|p| p.points.len() > 4));
        assert_eq!(polys[1].points.first(), polys[1].points.last());
    }

    fn bounds_of(lines: &[Polyline]) -> (DVec2, DVec2) {
        lines.iter().flat_map(|l| &l.points).fold((DVec2::INFINITY, DVec2::NEG_INFINITY), |(lo, hi), p| (lo.min(*p), hi.max(*p)))
    }

    /// Issue 40: `<text>` was dropped with no word (usvg has no fonts here).
    #[test]
    fn text_is_set_in_hershey_strokes_at_its_size_and_place() {
        // 0.5 mm per user unit: 20-unit type has capitals 20 x 21/32 x 0.5 mm
        // high, on the baseline y = 50 units (25 mm up from the page's foot).
        let d = read_ok(r#"<text x="20" y="50" font-size="20" fill="blue">HI</text>"#);
        let (lo, hi) = bounds_of(&d.layers[0].polylines);
        assert!((lo.y - 25.0).abs() < 1e-3 && (hi.y - 25.0 - 6.5625).abs() < 1e-3, "{lo} {hi}");
        assert!(lo.x >= 10.0 && hi.x < 20.0, "{lo} {hi}");
        // Centred on its x, in a tspan of another size, turned a quarter by
        // its group: it runs up the page from y = 50 units.
        let d = read_ok(
            r#"<g transform="rotate(-90 100 50)"><text x="100" y="50" text-anchor="middle" style="font-size:10px"><tspan font-size="2em">HH</tspan></text></g>"#,
        );
        let (lo, hi) = bounds_of(&d.layers[0].polylines);
        assert!((hi.x - 50.0).abs() < 1e-3 && (lo.x - (50.0 - 6.5625)).abs() < 1e-3, "{lo} {hi}");
        assert!(((lo.y + hi.y) / 2.0 - 25.0).abs() < 0.5, "{lo} {hi}");
        // In its layer's pen; Inkscape's style and tspan lines.
        let d = read_ok(
            r#"<g inkscape:groupmode="layer" id="layer3"><text xml:space="preserve" style="font-size:8px;font-family:'Hershey Script'" x="10" y="20"><tspan x="10" y="20">a b</tspan><tspan x="10" y="30">c</tspan></text></g>"#,
        );
        assert_eq!(d.layers.iter().map(|l| l.pen).collect::<Vec<_>>(), vec![3]);
        assert!(d.layers[0].polylines.len() >= 3);
    }

    #[test]
    fn text_that_cannot_be_drawn_is_a_warning_naming_it() {
        let imported = import(
            &svg(r##"<defs><path id="p" d="M0 0 L100 0"/><text id="used">x</text></defs><use href="#used"/>
                <text id="curved"><textPath href="#p">along</textPath></text><text id="gone" display="none">x</text>"##),
            &ImportOptions::default(),
        )
        .unwrap();
        assert_eq!(imported.drawing.stroke_count(), 0);
        assert_eq!(imported.warnings.len(), 2, "{:?}", imported.warnings);
        assert!(imported.warnings[0].starts_with("<text id=\"used\"> at line 1 is drawn through <use>"), "{:?}", imported.warnings);
        assert!(imported.warnings[1].contains("<text id=\"curved\"> at line 2 follows a <textPath>"), "{:?}", imported.warnings);
    }

    /// Issue 40: filled shapes did not hide what lies under them.
    #[test]
    fn occlusion_hides_lines_under_later_fills() {
        // Two 20 x 20 unit (10 x 10 mm) squares, the second over the first's
        // top right quarter; a line of another colour (pen) across both.
        let body = r#"<rect x="0" y="0" width="20" height="20" fill="white" stroke="black"/>
                      <rect x="10" y="10" width="20" height="20" fill="white" stroke="black"/>
                      <line x1="0" y1="15" x2="40" y2="15" stroke="red"/><rect x="35" y="0" width="10" height="30" fill="red"/>"#;
        let length =
            |d: &Drawing, pen: u32| d.layers.iter().filter(|l| l.pen == pen).flat_map(|l| &l.polylines).map(Polyline::length).sum::<f64>();
        let all = read_ok(body);
        assert!((length(&all, 1) - 80.0).abs() < 1e-3);
        let per_layer = read(&svg(body), &ImportOptions { occlusion: Some(Occlusion::PerGroup), ..ImportOptions::default() }).unwrap();
        // The first square loses 5 + 5 mm; the red line is cut by the red
        // rectangle after it (17.5 mm kept of 20), not by the black squares.
        assert!((length(&per_layer, 1) - 70.0).abs() < 1e-3, "{}", length(&per_layer, 1));
        assert!((length(&per_layer, 2) - (17.5 + 40.0)).abs() < 1e-3, "{}", length(&per_layer, 2));
        let across = read(&svg(body), &ImportOptions { occlusion: Some(Occlusion::Across), ..ImportOptions::default() }).unwrap();
        // Across layers the black squares' fills do not hide the red line,
        // which comes after them, and the red rectangle covers no black.
        assert!((length(&across, 2) - (17.5 + 40.0)).abs() < 1e-3);
        assert!((length(&across, 1) - 70.0).abs() < 1e-3);
    }

    #[test]
    fn hidden_and_empty_things_are_skipped() {
        let d = read_ok(r#"<line x1="0" y1="0" x2="1" y2="0" stroke="black" visibility="hidden"/><path d="M 5 5" stroke="black"/>"#);
        assert_eq!(d.stroke_count(), 0);
    }

    /// Reads on a thread with the 2 MiB stack of a tokio worker, as the daemon does.
    fn read_on_worker_stack(text: String) -> Result<Drawing, SvgImportError> {
        std::thread::Builder::new()
            .stack_size(2 << 20)
            .spawn(move || read(&text, &ImportOptions::default()))
            .expect("thread")
            .join()
            .expect("no panic")
    }

    /// Issue #20: 4,000 nested `<g>` (28 KB) overflowed a daemon worker's stack
    /// and aborted the process.
    #[test]
    fn deep_nesting_is_an_error_naming_the_limit() {
        let deep =
            |n: usize| format!("{}<line x1=\"0\" y1=\"0\" x2=\"9\" y2=\"9\" stroke=\"black\"/>{}", "<g>\n".repeat(n), "</g>".repeat(n));
        // The svg element and the first 127 groups (one a line) fit; the next is too deep.
        let e = read_on_worker_stack(svg(&deep(4000))).unwrap_err();
        assert!(matches!(e, SvgImportError::TooDeep { limit: MAX_DEPTH, line } if line == MAX_DEPTH as u32), "{e}");
        assert!(e.to_string().contains("nested more than 128 deep"), "{e}");
        // Just inside the limit (svg, then the groups, then the line) it draws.
        let d = read_on_worker_stack(svg(&deep(MAX_DEPTH - 2))).expect("within the limit");
        assert_eq!(d.stroke_count(), 1);
        // A chain of `<use>`, each of the one before, nests as deep in usvg.
        let mut chain = String::from(r#"<defs><path id="u0" d="M0 0 L9 9" stroke="black"/>"#);
        for i in 1..3000 {
            chain.push_str(&format!(r##"<use id="u{i}" href="#u{}"/>"##, i - 1));
        }
        chain.push_str(r##"</defs><use href="#u2999"/>"##);
        let e = read_on_worker_stack(svg(&chain)).unwrap_err();
        assert!(matches!(e, SvgImportError::TooDeep { .. }), "{e}");
        // Entities would nest their markup wherever they are used: refused.
        // Entities of plain text (Illustrator declares its namespaces so) are fine.
        let e = read(
            "<!DOCTYPE svg [<!ENTITY e \"<g><g/></g>\">]>\n<svg xmlns=\"http://www.w3.org/2000/svg\">&e;</svg>",
            &ImportOptions::default(),
        )
        .unwrap_err();
        assert!(e.to_string().contains("entity holding markup"), "{e}");
        let ok = "<!DOCTYPE svg [<!ENTITY ns \"http://www.w3.org/2000/svg\">]><svg xmlns=\"&ns;\" width=\"10\" height=\"10\"><line x1=\"0\" y1=\"0\" x2=\"9\" y2=\"9\" stroke=\"black\"/></svg>";
        assert_eq!(read(ok, &ImportOptions::default()).expect("text entity").stroke_count(), 1);
        // A `<use>` that refers to its own ancestor is a cycle, not a depth.
        let d = read_on_worker_stack(svg(r##"<g id="a"><line x1="0" y1="0" x2="9" y2="9" stroke="black"/><use href="#a"/></g>"##));
        assert!(d.is_ok(), "{:?}", d.err());
    }

    /// Issue #20: `<image href>` made the daemon open paths a client named
    /// (`/etc/shadow`, `/dev/zero`; a FIFO blocked a submit forever). A FIFO
    /// shows any attempt: opening it for reading blocks until a writer comes.
    #[test]
    fn nothing_outside_the_text_is_opened() {
        let dir = std::env::temp_dir().join(format!("plotcode-svg-fifo-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let fifo = dir.join("trap.png");
        let _ = std::fs::remove_file(&fifo);
        assert!(std::process::Command::new("mkfifo").arg(&fifo).status().expect("mkfifo runs").success());
        let f = fifo.display();
        let text = svg(&format!(
            r#"<image href="{f}" width="10" height="10"/><image xlink:href="{f}" xmlns:xlink="http://www.w3.org/1999/xlink" width="10" height="10"/>
               <image href="trap.png" width="10" height="10"/><line x1="0" y1="0" x2="9" y2="9" stroke="black"/>"#
        ));
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || tx.send(read(&text, &ImportOptions::default()).map(|d| d.stroke_count())));
        let got = rx.recv_timeout(std::time::Duration::from_secs(20));
        if got.is_err() {
            // Unblock the reader stuck in the FIFO before failing.
            let _ = std::fs::OpenOptions::new().write(true).open(&fifo);
        }
        let _ = std::fs::remove_dir_all(&dir);
        assert_eq!(got.expect("read returned: it did not block opening the FIFO").expect("valid SVG"), 1);
    }

    /// Issue #20: a circle of radius 1e12 took 106 s in stroke ordering (the
    /// k-d tree), an ellipse of 9.2e18 1.3 GB; now they are refused at import.
    #[test]
    fn coordinates_beyond_a_kilometre_are_errors() {
        let e = read(&svg(r#"<circle id="huge" r="1e12" stroke="black"/>"#), &ImportOptions::default()).unwrap_err();
        assert!(matches!(&e, SvgImportError::TooFar { element, .. } if element == "huge"), "{e}");
        assert!(e.to_string().contains("element `huge` reaches 5.000e11 mm"), "{e}");
        let e = read(&svg(r#"<ellipse rx="9.2e18" ry="1" stroke="black"/>"#), &ImportOptions::default()).unwrap_err();
        assert!(e.to_string().starts_with("a path reaches"), "{e}");
        let e =
            read(&svg(r#"<g transform="scale(1e9)"><line x1="0" y1="0" x2="1" y2="1" stroke="black"/></g>"#), &ImportOptions::default());
        assert!(matches!(e, Err(SvgImportError::TooFar { .. })), "{e:?}");
        // A kilometre is still a drawing (a large one).
        assert!(read(&svg(r#"<line x1="0" y1="0" x2="1000000" y2="0" stroke="black"/>"#), &ImportOptions::default()).is_ok());
    }

    #[test]
    fn bad_input_is_an_error_not_a_panic() {
        let e = read("<svg xmlns=\"http://www.w3.org/2000/svg\">\n<line x1=\"0\" <</svg>", &ImportOptions::default()).unwrap_err();
        assert!(matches!(e, SvgImportError::Parse { at: Some((2, _)), .. }), "{e}");
        assert!(e.to_string().contains("line 2"), "position in {e}");
        let e = read("<svg xmlns=\"http://www.w3.org/2000/svg\"><line", &ImportOptions::default()).unwrap_err();
        assert!(matches!(e, SvgImportError::Parse { .. }), "{e}");
        assert!(read("not xml at all", &ImportOptions::default()).is_err());
        let e = read(&svg(""), &ImportOptions { flatness_mm: 0.0, ..ImportOptions::default() }).unwrap_err();
        assert!(matches!(e, SvgImportError::BadFlatness(_)));
        let many = (0..50).map(|i| format!(r#"<line x1="{i}" y1="0" x2="{i}" y2="9" stroke="black"/>"#)).collect::<String>();
        let e = read(&svg(&many), &ImportOptions { max_points: 60, ..ImportOptions::default() }).unwrap_err();
        assert!(matches!(e, SvgImportError::TooLarge { limit: 60 }));
    }

    /// Numbers in path data are read as the SVG grammar runs them together;
    /// one beyond the limit is an error naming the line (the svg fuzz
    /// target found an arc from y = 3e38 that usvg took minutes over).
    #[test]
    fn huge_path_numbers_are_errors() {
        let numbers: Vec<f64> = path_numbers("M1-2.5.5e2 1e3-4L-.5,+7e-1z").collect();
        assert_eq!(numbers, [1.0, -2.5, 50.0, 1000.0, -4.0, -0.5, 0.7]);
        let arc = svg(r#"<path d="M 0 3e38 A 40 20 0 0 1 80 0" stroke="black"/>"#);
        let e = read(&arc, &ImportOptions::default()).unwrap_err();
        assert!(matches!(e, SvgImportError::HugeNumber { line: 1, .. }), "{e}");
        let points = svg(r#"<polyline points="0,0 1e10,5" stroke="black"/>"#);
        assert!(matches!(read(&points, &ImportOptions::default()), Err(SvgImportError::HugeNumber { .. })));
        assert!(read(&svg(r#"<path d="M 0 0 L 1e5 0" stroke="black"/>"#), &ImportOptions::default()).is_ok());
    }

    /// The XML parser quotes the entity or token it expected: a long
    /// malformed one is cut (the svg fuzz target found a 3,481-character
    /// message quoting a 3,400-character token).
    #[test]
    fn parse_errors_quote_a_short_excerpt() {
        let long = format!(
            "<!DOCTYPE svg [<!ENTITY a \"b\">]>\n<svg xmlns=\"http://www.w3.org/2000/svg\"><g fill=\"&{};\"/></svg>",
            "ar".repeat(2000)
        );
        let e = read(&long, &ImportOptions::default()).unwrap_err();
        assert!(matches!(e, SvgImportError::Parse { .. }), "{e}");
        assert!(e.to_string().len() < 300, "{} characters: {e}", e.to_string().len());
    }
}
