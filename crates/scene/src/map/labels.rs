//! Place-name labels: single-stroke text set in 3-D beside each symbol,
//! lying on the ground or standing upright at its top, turned to face the
//! camera horizontally. Labels are free lines: hidden by every face in
//! front of them, hiding nothing.
//!
//! **Placed where they can be read.** Each label has candidate places
//! around its symbol (on the ground: in front, right, left, behind and the
//! four corners, then the same further out; above: over the top and beside
//! it, then higher, up to 18 letter heights; a label that finds no place
//! where it was asked for tries the other), and takes the first where the hidden-line engine finds
//! every stroke visible against the map's symbols and its box on the
//! picture keeps clear of the labels placed before it, preferring places
//! no outline or symbol edge crosses either ([`place_all`]). Labels are
//! placed in the order of the data; one with no such place keeps its
//! first.
//!
//! The glyphs come from the single-stroke font (`crate::font`, owned by
//! the grid work); this module only places text already shaped into strokes.

use super::spec::LabelPlacement;
use crate::builder::ModelBuilder;
use glam::{DVec2, DVec3};
use hiddenline::camera::Camera;
use hiddenline::model::{Edge, LineSource, Model};

/// Text shaped into strokes, in em units: baseline at y = 0, cap height 1,
/// starting at x = 0 and `advance` wide.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TextStrokes {
    /// Pen-down polylines.
    pub lines: Vec<Vec<DVec2>>,
    /// Total advance width.
    pub advance: f64,
}

/// `text` in the single-stroke Hershey font ([`crate::font`]), in the em units
/// of [`TextStrokes`]: the font laid out at cap height 1 on the plane z = 0.
#[must_use]
pub fn hershey(text: &str) -> TextStrokes {
    let unit = crate::font::TextPlacement::new(DVec3::ZERO, DVec3::X, DVec3::Y, 1.0);
    let lines =
        crate::font::text_polylines(text, &unit).into_iter().map(|line| line.into_iter().map(|p| DVec2::new(p.x, p.y)).collect()).collect();
    TextStrokes { lines, advance: crate::font::text_width(text, 1.0) }
}

/// Where and how large one label is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LabelFrame {
    /// Ground point of the place (symbol base centre), world space.
    pub anchor: DVec3,
    /// Ground or above.
    pub placement: LabelPlacement,
    /// Cap height, world units.
    pub height: f64,
    /// Space between symbol and text, world units.
    pub gap: f64,
    /// Half the symbol's footprint width, world units.
    pub half_width: f64,
    /// The symbol's height this frame, world units.
    pub symbol_height: f64,
}

/// Horizontal unit vectors (right, forward) of the view: screen-right and
/// away from the viewer, both in the ground plane. A view straight down uses
/// the camera's `up` as forward.
#[must_use]
pub fn ground_axes(camera: &Camera) -> (DVec3, DVec3) {
    let flat = |v: DVec3| DVec3::new(v.x, v.y, 0.0).try_normalize();
    let forward = flat(camera.direction()).or_else(|| flat(camera.up)).unwrap_or(DVec3::Y);
    (forward.cross(DVec3::Z), forward)
}

/// Gap kept between two labels on the picture, as a fraction of the
/// smaller side of a label's box (as the axes keep theirs).
const LABEL_GAP: f64 = 0.3;

/// The candidate places of a label, in order of preference: how it lies
/// (on the ground, reading away from the viewer, or upright over the
/// symbol's top) and the offset of its baseline's start from the anchor
/// (the footprint's centre on the ground, the top's centre above), along
/// the view's right and along the text's up, for a text `w` wide and `h`
/// high beside a footprint `r` across its half, `g` apart. A label asked
/// for on the ground that no place there shows stands above its symbol
/// (behind a tall symbol the ground is out of sight), and one asked for
/// above that none there shows lies on the ground.
fn candidates(placement: LabelPlacement, w: f64, h: f64, r: f64, g: f64) -> Vec<(LabelPlacement, (f64, f64))> {
    // On the ground: in front, right, left, behind, the corners; then the
    // same ring further out.
    let mut ground: Vec<(LabelPlacement, (f64, f64))> = Vec::new();
    for k in 0..3 {
        let d = r + g + 1.5 * h * f64::from(k);
        let ring = [
            (-w / 2.0, -(d + h)),
            (d, -h / 2.0),
            (-(d + w), -h / 2.0),
            (-w / 2.0, d),
            (d - g, -(d + h)),
            (-(d - g + w), -(d + h)),
            (d - g, d),
            (-(d - g + w), d),
        ];
        ground.extend(ring.map(|o| (LabelPlacement::Ground, o)));
    }
    // Upright over the top, beside it, then higher.
    let mut above: Vec<(LabelPlacement, (f64, f64))> = Vec::new();
    for k in 0..12 {
        let rise = g + 1.5 * h * f64::from(k);
        above.push((LabelPlacement::Above, (-w / 2.0, rise)));
        above.push((LabelPlacement::Above, (r + g, rise - h)));
        above.push((LabelPlacement::Above, (-(r + g + w), rise - h)));
    }
    match placement {
        LabelPlacement::Ground => ground.into_iter().chain(above).collect(),
        LabelPlacement::Above => above.into_iter().chain(ground).collect(),
    }
}

/// The world segments of `text` placed by `frame` at candidate `offset`
/// (see [`candidates`]), facing `camera`.
fn segments_at(text: &TextStrokes, frame: &LabelFrame, camera: &Camera, place: (LabelPlacement, (f64, f64))) -> Vec<(DVec3, DVec3)> {
    let (placement, offset) = place;
    let (right, forward) = ground_axes(camera);
    let h = frame.height;
    let (anchor, up) = match placement {
        LabelPlacement::Above => (frame.anchor + DVec3::Z * frame.symbol_height, DVec3::Z),
        // Reading away from the viewer, lying on the ground.
        LabelPlacement::Ground => (frame.anchor, forward),
    };
    let origin = anchor + right * offset.0 + up * offset.1;
    let at = |p: DVec2| origin + right * (p.x * h) + up * (p.y * h);
    text.lines.iter().flat_map(|line| line.windows(2).map(|w| (at(w[0]), at(w[1])))).collect()
}

/// Adds `text` as free lines placed by `frame` at its first candidate
/// place, facing `camera`.
pub fn place(text: &TextStrokes, frame: &LabelFrame, camera: &Camera, pen: u32, out: &mut ModelBuilder) {
    let offset = candidates(frame.placement, text.advance * frame.height, frame.height, frame.half_width, frame.gap)[0];
    for (a, b) in segments_at(text, frame, camera, offset) {
        out.add_edge(a, b, pen, &[]);
    }
}

/// A label's strokes, world space.
pub type Segments = Vec<(DVec3, DVec3)>;

/// One label to place.
pub struct Label<'a> {
    /// Its text in strokes.
    pub text: &'a TextStrokes,
    /// Where and how large.
    pub frame: LabelFrame,
}

/// The segments of each label at the first of its candidate places where
/// every stroke is visible (by the hidden-line engine, against `faces`:
/// the symbols) and its picture box is apart from the labels placed
/// before it, preferring places that no segment of `lines` (outline,
/// symbol edges) crosses on the picture; the first candidate when none
/// is.
#[must_use]
pub fn place_all(labels: &[Label<'_>], faces: &Model, lines: &[(DVec3, DVec3)], camera: &Camera) -> Vec<Segments> {
    // Every candidate's strokes as edges of one model, so the engine runs once.
    let mut model = Model { faces: faces.faces.clone(), edges: Vec::new() };
    // Per label, per candidate: its edges' indices and its segments.
    let mut spans: Vec<Vec<(std::ops::Range<usize>, Segments)>> = Vec::with_capacity(labels.len());
    for l in labels {
        let f = &l.frame;
        let mut per = Vec::new();
        for offset in candidates(f.placement, l.text.advance * f.height, f.height, f.half_width, f.gap) {
            let segs = segments_at(l.text, f, camera, offset);
            let first = model.edges.len();
            model.edges.extend(segs.iter().map(|&(a, b)| Edge { a, b, pen: 1, faces: Vec::new() }));
            per.push((first..model.edges.len(), segs));
        }
        spans.push(per);
    }
    let mut whole = vec![false; model.edges.len()];
    for line in hiddenline::engine::visibility(&model, camera) {
        if let LineSource::Edge(k) = line.source {
            let covered = line.visible.iter().map(|&(t0, t1)| t1 - t0).sum::<f64>();
            whole[k as usize] = covered >= 1.0 - 1e-9;
        }
    }
    let picture = |p: DVec3| camera.project(p).map(|d| DVec2::new(d.x, d.y));
    let obstacles: Vec<(DVec2, DVec2)> = lines.iter().filter_map(|&(a, b)| Some((picture(a)?, picture(b)?))).collect();
    let mut boxes: Vec<(DVec2, DVec2)> = Vec::new();
    let mut out = Vec::with_capacity(labels.len());
    for per in spans {
        let judged: Vec<(Option<(DVec2, DVec2)>, bool)> =
            per.iter().map(|(range, segs)| (picture_box(segs, &picture), !range.is_empty() && range.clone().all(|k| whole[k]))).collect();
        let free = |k: usize, clear: bool| {
            let (Some(bx), true) = judged[k] else { return false };
            !boxes.iter().any(|b| overlap(*b, bx))
                && (!clear || !obstacles.iter().any(|&(a, b)| hiddenline::clip::clip_segment_t(a, b, bx.0, bx.1).is_some()))
        };
        let chosen = (0..per.len()).find(|&k| free(k, true)).or_else(|| (0..per.len()).find(|&k| free(k, false))).unwrap_or(0);
        if let (Some(bx), _) = judged[chosen] {
            boxes.push(bx);
        }
        out.push(per[chosen].1.clone());
    }
    out
}

/// The picture box of a label's segments, grown by half the gap kept
/// between labels; `None` when a point is behind the eye.
fn picture_box(segs: &[(DVec3, DVec3)], picture: &impl Fn(DVec3) -> Option<DVec2>) -> Option<(DVec2, DVec2)> {
    let mut lo = DVec2::INFINITY;
    let mut hi = DVec2::NEG_INFINITY;
    for &(a, b) in segs {
        for p in [a, b] {
            let q = picture(p)?;
            lo = lo.min(q);
            hi = hi.max(q);
        }
    }
    if !(lo.x <= hi.x) {
        return None;
    }
    let pad = 0.5 * LABEL_GAP * (hi - lo).min_element();
    Some((lo - DVec2::splat(pad), hi + DVec2::splat(pad)))
}

/// Whether two boxes share any point.
#[must_use]
pub fn overlap(a: (DVec2, DVec2), b: (DVec2, DVec2)) -> bool {
    a.0.x <= b.1.x && b.0.x <= a.1.x && a.0.y <= b.1.y && b.0.y <= a.1.y
}

#[cfg(test)]
mod tests {
    use super::*;
    use hiddenline::camera::Projection;

    fn cam(eye: [f64; 3]) -> Camera {
        Camera::new(DVec3::from(eye), DVec3::ZERO, DVec3::Z, Projection::Perspective { fov_deg: 30.0 }).unwrap()
    }

    /// A one-em square "glyph".
    fn square() -> TextStrokes {
        let pts = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0), (0.0, 0.0)];
        TextStrokes { lines: vec![pts.iter().map(|&(x, y)| DVec2::new(x, y)).collect()], advance: 1.0 }
    }

    #[test]
    fn axes_face_the_camera() {
        let (r, f) = ground_axes(&cam([0.0, -10.0, 5.0]));
        assert!((r - DVec3::X).length() < 1e-12 && (f - DVec3::Y).length() < 1e-12);
        let (r, f) = ground_axes(&cam([10.0, 0.0, 5.0]));
        assert!((r - DVec3::Y).length() < 1e-12 && (f + DVec3::X).length() < 1e-12);
        // Straight down: up decides.
        let c = Camera::new(DVec3::new(0.0, 0.0, 10.0), DVec3::ZERO, DVec3::Y, Projection::Perspective { fov_deg: 30.0 }).unwrap();
        let (r, f) = ground_axes(&c);
        assert!((r - DVec3::X).length() < 1e-12 && (f - DVec3::Y).length() < 1e-12);
    }

    #[test]
    fn above_and_ground_positions() {
        let c = cam([0.0, -10.0, 5.0]);
        let frame = LabelFrame {
            anchor: DVec3::new(2.0, 3.0, 0.0),
            placement: LabelPlacement::Above,
            height: 0.5,
            gap: 0.1,
            half_width: 0.4,
            symbol_height: 2.0,
        };
        let mut b = ModelBuilder::new();
        place(&square(), &frame, &c, 4, &mut b);
        let m = b.finish();
        assert_eq!(m.edges.len(), 4);
        let pts: Vec<DVec3> = m.edges.iter().flat_map(|e| [e.a, e.b]).collect();
        // Upright, centred on the place, from 2.1 to 2.6 high, facing -y.
        assert!(pts.iter().all(|p| p.y == 3.0 && (p.x - 2.0).abs() <= 0.25 + 1e-12));
        assert!(pts.iter().any(|p| (p.z - 2.1).abs() < 1e-12) && pts.iter().any(|p| (p.z - 2.6).abs() < 1e-12));
        assert!(m.edges.iter().all(|e| e.pen == 4 && e.faces.is_empty()));
        let mut b = ModelBuilder::new();
        place(&square(), &LabelFrame { placement: LabelPlacement::Ground, ..frame }, &c, 1, &mut b);
        let pts: Vec<DVec3> = b.finish().edges.iter().flat_map(|e| [e.a, e.b]).collect();
        // Flat on the ground, in front of the footprint (y < 3 - 0.4 - 0.1).
        assert!(pts.iter().all(|p| p.z == 0.0 && p.y <= 2.5 + 1e-12 && p.y >= 2.0 - 1e-12));
    }
}
