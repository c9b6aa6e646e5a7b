//! The brute-force ray-casting reference every hidden-line test is judged by.
//!
//! It shares nothing with the engine ([`crate::engine`]) but the model, the
//! camera and the constants in [`crate::tolerance`]: no screen grid, no
//! events, no device-space polygons. It is slow on purpose and simple enough
//! to trust.
//!
//! # Sampling rule
//! Every line (each [`Edge`](crate::Edge), and every penetration line this
//! module finds itself with [`intersections`]) is clipped at the near plane
//! and projected. Its device-space length is cut into `n` equal pieces of at
//! most `spacing` (default [`REFERENCE_SPACING`] of the drawing diagonal, at
//! most [`REFERENCE_MAX_SAMPLES_PER_LINE`] pieces) and the midpoint of each
//! piece is one sample, standing for the piece's length. The sample's world
//! point is found by inverting the perspective division, so samples are
//! uniform on the page, not in world space.
//!
//! # Tie rules (the engine follows the same ones)
//! A sample `P` is hidden by face `F` when the sight ray from `P` to the eye
//! (for an orthographic camera: from `P` towards the camera along the view
//! direction) meets `F`'s plane at a point `X` that is
//! - in front of the near plane (geometry behind it does not exist),
//! - inside `F` or on its boundary (faces are closed sets: even-odd with
//!   holes, and within [`PLANE_REL`] times the scene size of the boundary
//!   counts as on it), and
//! - strictly between `P` and the eye: `P` farther than [`PLANE_REL`] times
//!   the scene size from `F`'s plane. A point in a face's plane is never hidden
//!   by that face, so **coplanar faces never hide each other's lines** (both
//!   outlines of two overlapping coplanar faces are drawn), and a face seen
//!   exactly edge-on hides nothing.
//!
//! Faces listed in [`Edge::faces`](crate::Edge::faces) never hide that edge;
//! faces `i` and `j` never hide their own penetration line.
//!
//! A penetration line of faces `i` and `j` is where the *interiors* of both
//! faces meet: contact along either face's boundary (a box standing on a
//! floor, two faces sharing an edge) is not a penetration line.
//!
//! # Scoring
//! [`compare`] measures an engine answer against the reference by drawn
//! length: precision is the share of drawn length within `tol` of a
//! reference-visible sample, recall the share of reference-visible length
//! within `tol` of a drawn point; `tol` defaults to [`COMPARE_TOL`] (0.1 %) of
//! the drawing diagonal (the bounding box of the reference-visible samples).
//!
//! [`retraced`] measures drawing the same place twice: the length of a
//! drawing (a list of segments, in drawing order) lying within `tol` of an
//! earlier segment that is nearly parallel to it ([`RETRACE_ANGLE`]). Scored
//! the same way on an engine answer ([`answer_segments`]) and on the
//! reference ([`Reference::segments`]), it says whether the engine draws
//! anything twice beyond what the scene itself puts on one line.
//!
//! # Faces that are not planar
//! A model face is planar: [`crate::Face`] says so, and the lowering keeps
//! it (a mesh face planar only within the rounding its file was written with
//! is lowered as triangles of its own vertices; a folded one as its fan
//! triangles). The reference takes each face's plane as the Newell plane
//! through its centroid, as the engine does, and checks nothing else.

use rayon::prelude::*;
use std::collections::HashMap;

use glam::{DVec2, DVec3};

use crate::camera::{Camera, Projection};
use crate::model::{LineSource, LineVisibility, Model};
use crate::tolerance::{COMPARE_TOL, PLANE_REL, REFERENCE_MAX_SAMPLES_PER_LINE, REFERENCE_SPACING};

/// How densely to sample, and which part of the picture to judge.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Options {
    /// Sample spacing as a fraction of the drawing diagonal.
    pub spacing: f64,
    /// Only judge the part of the picture inside this device-space box
    /// `(min, max)`: use it for views whose lines run off to the near plane
    /// (eye inside the scene), where the whole projected drawing is huge.
    pub window: Option<(DVec2, DVec2)>,
}

impl Default for Options {
    fn default() -> Self {
        Options { spacing: REFERENCE_SPACING, window: None }
    }
}

/// One sample of one line.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// The line sampled.
    pub source: LineSource,
    /// Device-space position.
    pub point: DVec2,
    /// Device-space length this sample stands for.
    pub length: f64,
    /// Whether the ray to the eye meets no face.
    pub visible: bool,
}

/// The reference's answer for a whole model.
#[derive(Clone, Debug, PartialEq)]
pub struct Reference {
    /// All samples of all lines.
    pub samples: Vec<Sample>,
    /// Device-space diagonal of the bounding box of the visible samples (of
    /// all samples when none is visible).
    pub diagonal: f64,
    /// Device-space sample spacing used.
    pub spacing: f64,
    /// The window judged, if any.
    pub window: Option<(DVec2, DVec2)>,
}

impl Reference {
    /// Total visible device-space length.
    #[must_use]
    pub fn visible_length(&self) -> f64 {
        self.samples.iter().filter(|s| s.visible).map(|s| s.length).sum()
    }

    /// Visible device-space length of one line.
    #[must_use]
    pub fn visible_length_of(&self, source: LineSource) -> f64 {
        self.samples.iter().filter(|s| s.visible && s.source == source).map(|s| s.length).sum()
    }
}

/// Precision and recall of an engine answer by drawn length.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Score {
    /// Share of the drawn length that the reference sees too (1 when nothing
    /// is drawn).
    pub precision: f64,
    /// Share of the reference-visible length that is drawn (1 when the
    /// reference sees nothing).
    pub recall: f64,
    /// Drawn device-space length (inside the window).
    pub drawn: f64,
    /// Reference-visible device-space length.
    pub expected: f64,
}

impl Score {
    /// Both precision and recall at least `min`.
    #[must_use]
    pub fn passes(&self, min: f64) -> bool {
        self.precision >= min && self.recall >= min
    }
}

/// A face as the reference sees it: world-space plane and rings.
struct RefFace {
    normal: DVec3,
    offset: f64,
    rings: Vec<Vec<DVec3>>,
    /// Axis dropped to get a 2-D polygon (the normal's largest component).
    axis: usize,
    lo: DVec3,
    hi: DVec3,
}

#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Where {
    Inside,
    Boundary,
    Outside,
}

fn newell(ring: &[DVec3]) -> DVec3 {
    let mut n = DVec3::ZERO;
    for (i, &p) in ring.iter().enumerate() {
        let q = ring[(i + 1) % ring.len()];
        n += DVec3::new((p.y - q.y) * (p.z + q.z), (p.z - q.z) * (p.x + q.x), (p.x - q.x) * (p.y + q.y));
    }
    n
}

fn ref_faces(model: &Model) -> Vec<Option<RefFace>> {
    model
        .faces
        .iter()
        .map(|f| {
            let normal = newell(&f.outer).try_normalize()?;
            let centroid = f.outer.iter().copied().sum::<DVec3>() / f.outer.len() as f64;
            let a = normal.abs();
            let axis = if a.x >= a.y && a.x >= a.z {
                0
            } else if a.y >= a.z {
                1
            } else {
                2
            };
            let mut rings = vec![f.outer.clone()];
            rings.extend(f.holes.iter().filter(|h| h.len() >= 3).cloned());
            let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
            for p in rings.iter().flatten() {
                lo = lo.min(*p);
                hi = hi.max(*p);
            }
            Some(RefFace { normal, offset: normal.dot(centroid), rings, axis, lo, hi })
        })
        .collect()
}

fn drop_axis(p: DVec3, axis: usize) -> DVec2 {
    match axis {
        0 => DVec2::new(p.y, p.z),
        1 => DVec2::new(p.z, p.x),
        _ => DVec2::new(p.x, p.y),
    }
}

fn seg_dist(p: DVec3, a: DVec3, b: DVec3) -> f64 {
    let ab = b - a;
    let l2 = ab.length_squared();
    let t = if l2 > 0.0 { ((p - a).dot(ab) / l2).clamp(0.0, 1.0) } else { 0.0 };
    p.distance(a + ab * t)
}

/// Where `x` (a point in the face's plane) lies: even-odd with holes, and
/// within `eps` of any boundary segment is the boundary.
fn locate(face: &RefFace, x: DVec3, eps: f64) -> Where {
    let q = drop_axis(x, face.axis);
    let mut inside = false;
    for ring in &face.rings {
        for i in 0..ring.len() {
            let (a3, b3) = (ring[i], ring[(i + 1) % ring.len()]);
            if seg_dist(x, a3, b3) <= eps {
                return Where::Boundary;
            }
            let (a, b) = (drop_axis(a3, face.axis), drop_axis(b3, face.axis));
            if (a.y > q.y) != (b.y > q.y) {
                let xc = a.x + (q.y - a.y) * (b.x - a.x) / (b.y - a.y);
                if q.x < xc {
                    inside = !inside;
                }
            }
        }
    }
    if inside {
        Where::Inside
    } else {
        Where::Outside
    }
}

/// Size of the scene: diagonal of the bounding box of all vertices and the eye.
fn scene_scale(model: &Model, camera: &Camera) -> f64 {
    let mut lo = camera.eye;
    let mut hi = camera.eye;
    let pts = model
        .faces
        .iter()
        .flat_map(|f| f.outer.iter().chain(f.holes.iter().flatten()))
        .chain(model.edges.iter().flat_map(|e| [&e.a, &e.b]));
    for p in pts {
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    lo.distance(hi).max(camera.eye.distance(camera.target))
}

/// The penetration lines of a model, `(i, j, a, b)` with `i < j`: where the
/// interiors of faces `i` and `j` meet. Brute force over all pairs of faces;
/// each candidate piece of the planes' common line is kept when its midpoint
/// lies strictly inside both faces.
#[must_use]
pub fn intersections(model: &Model) -> Vec<(u32, u32, DVec3, DVec3)> {
    let faces = ref_faces(model);
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for f in faces.iter().flatten() {
        lo = lo.min(f.lo);
        hi = hi.max(f.hi);
    }
    let eps = PLANE_REL * lo.distance(hi).max(1e-300);
    let mut out = Vec::new();
    for (i, fi) in faces.iter().enumerate() {
        let Some(fi) = fi else { continue };
        for (j, fj) in faces.iter().enumerate().skip(i + 1) {
            let Some(fj) = fj else { continue };
            if (fi.lo - eps).cmpgt(fj.hi).any() || (fj.lo - eps).cmpgt(fi.hi).any() {
                continue;
            }
            let u = fi.normal.cross(fj.normal);
            if u.length_squared() < 1e-18 {
                continue;
            }
            let x0 = (fi.offset * fj.normal.cross(u) + fj.offset * u.cross(fi.normal)) / u.length_squared();
            let un = u.normalize();
            let mut lambdas = Vec::new();
            for (face, other) in [(fi, fj), (fj, fi)] {
                for ring in &face.rings {
                    for k in 0..ring.len() {
                        let (a, b) = (ring[k], ring[(k + 1) % ring.len()]);
                        let (fa, fb) = (other.normal.dot(a) - other.offset, other.normal.dot(b) - other.offset);
                        if fa.abs() <= eps {
                            lambdas.push(un.dot(a - x0));
                        }
                        if (fa > eps && fb < -eps) || (fa < -eps && fb > eps) {
                            let p = a + (b - a) * (fa / (fa - fb));
                            lambdas.push(un.dot(p - x0));
                        }
                    }
                }
            }
            lambdas.sort_by(f64::total_cmp);
            let mut piece: Option<(f64, f64)> = None;
            for w in lambdas.windows(2) {
                let (la, lb) = (w[0], w[1]);
                if lb - la <= eps {
                    continue;
                }
                let m = x0 + un * (0.5 * (la + lb));
                let inside = locate(fi, m, eps) == Where::Inside && locate(fj, m, eps) == Where::Inside;
                match (&mut piece, inside) {
                    (Some((_, end)), true) if (la - *end).abs() <= eps => *end = lb,
                    (_, true) => {
                        if let Some((a, b)) = piece.take() {
                            out.push((i as u32, j as u32, x0 + un * a, x0 + un * b));
                        }
                        piece = Some((la, lb));
                    }
                    (_, false) => {}
                }
            }
            if let Some((a, b)) = piece {
                out.push((i as u32, j as u32, x0 + un * a, x0 + un * b));
            }
        }
    }
    out
}

/// Device-space image of a view-space point, with its depth clamped to the
/// near plane (clipped endpoints sit on it up to rounding).
fn device(camera: &Camera, world: DVec3) -> DVec2 {
    let mut v = camera.to_view(world);
    v.z = v.z.min(-camera.near);
    camera.view_to_device(v).truncate()
}

/// The parameter range of `a + t (b - a)`, `t` in `[0, 1]`, inside the box;
/// `None` if it misses (the page's own frame clipping).
fn clip_to_box(a: DVec2, b: DVec2, (lo, hi): (DVec2, DVec2)) -> Option<(f64, f64)> {
    crate::clip::clip_segment_t(a, b, lo, hi)
}

struct RefLine {
    source: LineSource,
    a: DVec3,
    b: DVec3,
    exclude: Vec<u32>,
}

fn is_hidden(p: DVec3, line: &RefLine, faces: &[Option<RefFace>], camera: &Camera, eps: f64) -> bool {
    let dir = camera.direction();
    faces.iter().enumerate().any(|(k, f)| {
        let Some(f) = f else { return false };
        if line.exclude.contains(&(k as u32)) {
            return false;
        }
        let fp = f.normal.dot(p) - f.offset;
        if fp.abs() <= eps {
            return false;
        }
        let x = match camera.projection {
            Projection::Perspective { .. } => {
                let fe = f.normal.dot(camera.eye) - f.offset;
                if fp * fe >= 0.0 {
                    return false;
                }
                p + (camera.eye - p) * (fp / (fp - fe))
            }
            Projection::Orthographic { .. } => {
                let nd = f.normal.dot(dir);
                if fp * nd <= 0.0 {
                    return false;
                }
                p - dir * (fp / nd)
            }
        };
        // Farther than `eps` outside the face's box, the point is farther
        // than `eps` from every side and outside: `locate` would say so,
        // only slower (it was 60 % of a judge's time on fine meshes).
        let beyond = (x - f.hi).cmpgt(DVec3::splat(eps)).any() || (f.lo - x).cmpgt(DVec3::splat(eps)).any();
        !beyond && camera.near_distance(x) >= 0.0 && locate(f, x, eps) != Where::Outside
    })
}

/// Samples every line of `model` seen through `camera` and ray-casts each
/// sample against every face.
#[must_use]
pub fn sample(model: &Model, camera: &Camera, options: &Options) -> Reference {
    let faces = ref_faces(model);
    let eps = PLANE_REL * scene_scale(model, camera);
    let mut lines: Vec<RefLine> = model
        .edges
        .iter()
        .enumerate()
        .map(|(i, e)| RefLine { source: LineSource::Edge(i as u32), a: e.a, b: e.b, exclude: e.faces.clone() })
        .collect();
    lines.extend(intersections(model).into_iter().map(|(i, j, a, b)| RefLine {
        source: LineSource::Intersection(i, j),
        a,
        b,
        exclude: vec![i, j],
    }));
    // Per line: world endpoints of the near-clipped part, their view depths,
    // and the device parameter range inside the window.
    let spans: Vec<_> = lines
        .iter()
        .map(|l| {
            let (s0, s1) = camera.clip_segment(l.a, l.b)?;
            let (a, b) = (l.a.lerp(l.b, s0), l.a.lerp(l.b, s1));
            let (pa, pb) = (device(camera, a), device(camera, b));
            let (u0, u1) = match options.window {
                Some(w) => clip_to_box(pa, pb, w)?,
                None => (0.0, 1.0),
            };
            Some((a, b, pa, pb, u0, u1))
        })
        .collect();
    let mut lo = DVec2::splat(f64::INFINITY);
    let mut hi = DVec2::splat(f64::NEG_INFINITY);
    for &(_, _, pa, pb, u0, u1) in spans.iter().flatten() {
        for p in [pa.lerp(pb, u0), pa.lerp(pb, u1)] {
            lo = lo.min(p);
            hi = hi.max(p);
        }
    }
    let all_diag = if lo.x <= hi.x { lo.distance(hi) } else { 0.0 };
    let run = |spacing: f64| -> Vec<Sample> {
        // Lines in parallel, samples kept in line order.
        let per_line: Vec<Vec<Sample>> = lines
            .par_iter()
            .zip(&spans)
            .map(|(line, span)| {
                let mut samples = Vec::new();
                let Some((a, b, pa, pb, u0, u1)) = *span else { return samples };
                let len = pa.distance(pb) * (u1 - u0);
                if len <= 0.0 || spacing <= 0.0 {
                    return samples;
                }
                let n = ((len / spacing).ceil() as usize).clamp(1, REFERENCE_MAX_SAMPLES_PER_LINE);
                let (da, db) = (-camera.to_view(a).z, -camera.to_view(b).z);
                for k in 0..n {
                    let t = u0 + (u1 - u0) * (k as f64 + 0.5) / n as f64;
                    let s = match camera.projection {
                        Projection::Perspective { .. } => t * da / (t * da + (1.0 - t) * db),
                        Projection::Orthographic { .. } => t,
                    };
                    let p = a.lerp(b, s);
                    samples.push(Sample {
                        source: line.source,
                        point: pa.lerp(pb, t),
                        length: len / n as f64,
                        visible: !is_hidden(p, line, &faces, camera, eps),
                    });
                }
                samples
            })
            .collect();
        per_line.concat()
    };
    let visible_diag = |samples: &[Sample]| {
        let mut lo = DVec2::splat(f64::INFINITY);
        let mut hi = DVec2::splat(f64::NEG_INFINITY);
        for s in samples.iter().filter(|s| s.visible) {
            lo = lo.min(s.point);
            hi = hi.max(s.point);
        }
        if lo.x <= hi.x {
            lo.distance(hi)
        } else {
            all_diag
        }
    };
    let mut spacing = all_diag * options.spacing;
    let mut samples = run(spacing);
    let mut diagonal = visible_diag(&samples);
    // The visible drawing may be much smaller than all lines together: sample
    // again, finely enough for its own diagonal.
    if diagonal > 0.0 && diagonal * options.spacing < 0.5 * spacing {
        spacing = diagonal * options.spacing;
        samples = run(spacing);
        diagonal = visible_diag(&samples);
    }
    Reference { samples, diagonal, spacing, window: options.window }
}

/// Largest angle (radians) between two segments for one to count as drawn
/// over the other in [`retraced`].
pub const RETRACE_ANGLE: f64 = 0.02;

impl Reference {
    /// The reference-visible parts of every line as device-space segments,
    /// one per run of consecutive visible samples of a line, in line order.
    #[must_use]
    pub fn segments(&self) -> Vec<(DVec2, DVec2)> {
        let mut out = Vec::new();
        let mut run: Option<(LineSource, DVec2, DVec2, f64)> = None;
        let finish = |run: Option<(LineSource, DVec2, DVec2, f64)>, out: &mut Vec<(DVec2, DVec2)>| {
            if let Some((_, first, last, half)) = run {
                // Extend by half a sample at each end: a sample stands for a
                // piece of its own length.
                let d = (last - first).normalize_or_zero();
                let d = if d == DVec2::ZERO { DVec2::X } else { d };
                out.push((first - d * half, last + d * half));
            }
        };
        for s in &self.samples {
            match (&mut run, s.visible) {
                (Some((src, _, last, _)), true) if *src == s.source => *last = s.point,
                (_, true) => {
                    finish(run.take(), &mut out);
                    run = Some((s.source, s.point, s.point, 0.5 * s.length));
                }
                (_, false) => finish(run.take(), &mut out),
            }
        }
        finish(run, &mut out);
        out
    }
}

/// The visible pieces of an engine answer as device-space segments, in
/// answer order.
#[must_use]
pub fn answer_segments(answer: &[LineVisibility]) -> Vec<(DVec2, DVec2)> {
    answer.iter().flat_map(|l| l.visible.iter().map(|&(t0, t1)| (l.a.lerp(l.b, t0), l.a.lerp(l.b, t1)))).collect()
}

/// Length of `segments` (in drawing order) lying within `tol` of an earlier
/// segment at most [`RETRACE_ANGLE`] away in direction: the pen over a place
/// it has already drawn. Sampled every `tol / 2`, brute force over the
/// earlier segments near each sample (a grid of cells of side `4 tol`).
#[must_use]
pub fn retraced(segments: &[(DVec2, DVec2)], tol: f64) -> f64 {
    let cell = 4.0 * tol;
    let key = |p: DVec2| ((p.x / cell).floor() as i64, (p.y / cell).floor() as i64);
    let mut cells: HashMap<(i64, i64), Vec<u32>> = HashMap::new();
    let near = |p: DVec2, a: DVec2, b: DVec2| {
        let ab = b - a;
        let l2 = ab.length_squared();
        let t = if l2 > 0.0 { ((p - a).dot(ab) / l2).clamp(0.0, 1.0) } else { 0.0 };
        p.distance(a + ab * t) <= tol
    };
    let mut total = 0.0;
    for (i, &(a, b)) in segments.iter().enumerate() {
        let len = a.distance(b);
        if !(len > 0.0) || !len.is_finite() {
            continue;
        }
        let u = (b - a) / len;
        let n = ((2.0 * len / tol).ceil() as usize).clamp(1, REFERENCE_MAX_SAMPLES_PER_LINE);
        for k in 0..n {
            let p = a.lerp(b, (k as f64 + 0.5) / n as f64);
            let (kx, ky) = key(p);
            let over = (-1..=1).any(|dx| {
                (-1..=1).any(|dy| {
                    cells.get(&(kx + dx, ky + dy)).is_some_and(|list| {
                        list.iter().any(|&j| {
                            let (c, d) = segments[j as usize];
                            let v = (d - c).normalize_or_zero();
                            u.perp_dot(v).abs() <= RETRACE_ANGLE.sin() && near(p, c, d)
                        })
                    })
                })
            });
            if over {
                total += len / n as f64;
            }
        }
        // Then this segment is drawn: file it in every cell it passes.
        let steps = ((len / cell).ceil() as usize).clamp(1, REFERENCE_MAX_SAMPLES_PER_LINE);
        let mut last = None;
        for k in 0..=steps {
            let c = key(a.lerp(b, k as f64 / steps as f64));
            if last != Some(c) {
                cells.entry(c).or_default().push(i as u32);
                last = Some(c);
            }
        }
    }
    total
}

/// Points bucketed in square cells of side `cell`, for "is any point within
/// `cell` of here?" queries.
struct PointGrid {
    cell: f64,
    cells: HashMap<(i64, i64), Vec<DVec2>>,
}

impl PointGrid {
    fn new(cell: f64, points: impl Iterator<Item = DVec2>) -> Self {
        let mut cells: HashMap<(i64, i64), Vec<DVec2>> = HashMap::new();
        for p in points {
            cells.entry(Self::key(p, cell)).or_default().push(p);
        }
        PointGrid { cell, cells }
    }

    fn key(p: DVec2, cell: f64) -> (i64, i64) {
        ((p.x / cell).floor() as i64, (p.y / cell).floor() as i64)
    }

    fn near(&self, p: DVec2) -> bool {
        let (kx, ky) = Self::key(p, self.cell);
        (-1..=1)
            .any(|dx| (-1..=1).any(|dy| self.cells.get(&(kx + dx, ky + dy)).is_some_and(|v| v.iter().any(|q| q.distance(p) <= self.cell))))
    }
}

/// Scores `answer` (the engine's) against `reference` by drawn length, with
/// matching tolerance `tol_fraction` of the reference's drawing diagonal.
#[must_use]
pub fn compare(answer: &[LineVisibility], reference: &Reference, tol_fraction: f64) -> Score {
    let tol = (tol_fraction * reference.diagonal).max(1e-300);
    let spacing = reference.spacing.min(tol * 0.25).max(tol * 1e-3);
    let mut drawn = Vec::new();
    for lv in answer {
        for &(t0, t1) in &lv.visible {
            let (mut a, mut b) = (lv.a.lerp(lv.b, t0), lv.a.lerp(lv.b, t1));
            if let Some(w) = reference.window {
                let Some((u0, u1)) = clip_to_box(a, b, w) else { continue };
                (a, b) = (a.lerp(b, u0), a.lerp(b, u1));
            }
            let len = a.distance(b);
            if len <= 0.0 {
                continue;
            }
            let n = ((len / spacing).ceil() as usize).clamp(1, REFERENCE_MAX_SAMPLES_PER_LINE);
            drawn.extend((0..n).map(|k| (a.lerp(b, (k as f64 + 0.5) / n as f64), len / n as f64)));
        }
    }
    let seen = PointGrid::new(tol, reference.samples.iter().filter(|s| s.visible).map(|s| s.point));
    let ink = PointGrid::new(tol, drawn.iter().map(|d| d.0));
    let drawn_len: f64 = drawn.iter().map(|d| d.1).sum();
    let good: f64 = drawn.iter().filter(|d| seen.near(d.0)).map(|d| d.1).sum();
    let expected = reference.visible_length();
    let found: f64 = reference.samples.iter().filter(|s| s.visible && ink.near(s.point)).map(|s| s.length).sum();
    Score {
        precision: if drawn_len > 0.0 { good / drawn_len } else { 1.0 },
        recall: if expected > 0.0 { found / expected } else { 1.0 },
        drawn: drawn_len,
        expected,
    }
}

/// [`sample`] with default options, then [`compare`] at [`COMPARE_TOL`].
#[must_use]
pub fn check(model: &Model, camera: &Camera, answer: &[LineVisibility]) -> Score {
    compare(answer, &sample(model, camera, &Options::default()), COMPARE_TOL)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{Edge, Face};

    fn cam() -> Camera {
        Camera::new(DVec3::new(0.0, -10.0, 0.0), DVec3::ZERO, DVec3::Z, Projection::Perspective { fov_deg: 40.0 }).unwrap()
    }

    fn square(y: f64, h: f64) -> Face {
        Face {
            outer: vec![DVec3::new(-h, y, -h), DVec3::new(h, y, -h), DVec3::new(h, y, h), DVec3::new(-h, y, h)],
            holes: vec![],
            pen: 1,
            outward: false,
        }
    }

    fn edge(a: DVec3, b: DVec3) -> Edge {
        Edge { a, b, pen: 1, faces: vec![] }
    }

    #[test]
    fn a_square_hides_the_middle_of_a_line_behind_it() {
        let model = Model { faces: vec![square(0.0, 1.0)], edges: vec![edge(DVec3::new(-3.0, 2.0, 0.0), DVec3::new(3.0, 2.0, 0.0))] };
        let r = sample(&model, &cam(), &Options::default());
        let total: f64 = r.samples.iter().map(|s| s.length).sum();
        let vis = r.visible_length();
        // The square spans |x| < 1 at y = 0; seen from y = -10 it covers
        // |x| < 1.2 at y = 2 out of |x| <= 3: 60 % visible.
        assert!((vis / total - 0.6).abs() < 1e-3, "{}", vis / total);
    }

    #[test]
    fn lines_in_front_and_in_the_plane_are_not_hidden() {
        let model = Model {
            faces: vec![square(0.0, 1.0)],
            edges: vec![
                edge(DVec3::new(-3.0, -1.0, 0.0), DVec3::new(3.0, -1.0, 0.0)),
                edge(DVec3::new(-0.5, 0.0, 0.0), DVec3::new(0.5, 0.0, 0.3)),
            ],
        };
        let r = sample(&model, &cam(), &Options::default());
        assert!(r.samples.iter().all(|s| s.visible));
    }

    #[test]
    fn hole_lets_the_line_through() {
        let mut f = square(0.0, 2.0);
        f.holes.push(vec![DVec3::new(-0.5, 0.0, -0.5), DVec3::new(0.5, 0.0, -0.5), DVec3::new(0.5, 0.0, 0.5), DVec3::new(-0.5, 0.0, 0.5)]);
        let model = Model { faces: vec![f], edges: vec![edge(DVec3::new(-1.0, 1.0, 0.0), DVec3::new(1.0, 1.0, 0.0))] };
        let r = sample(&model, &cam(), &Options::default());
        let total: f64 = r.samples.iter().map(|s| s.length).sum();
        // The hole covers |x| < 0.55 at y = 1: 55 % of the line.
        assert!((r.visible_length() / total - 0.55).abs() < 1e-3);
    }

    #[test]
    fn crossing_squares_meet_along_one_segment() {
        let a = square(0.0, 1.0);
        let b = Face {
            outer: vec![DVec3::new(-0.5, -1.0, 0.0), DVec3::new(0.5, -1.0, 0.0), DVec3::new(0.5, 1.0, 0.0), DVec3::new(-0.5, 1.0, 0.0)],
            holes: vec![],
            pen: 1,
            outward: false,
        };
        let model = Model { faces: vec![a, b], edges: vec![] };
        let x = intersections(&model);
        assert_eq!(x.len(), 1);
        let (i, j, p, q) = x[0];
        assert_eq!((i, j), (0, 1));
        assert!((p.distance(q) - 1.0).abs() < 1e-12);
        assert!(p.y.abs() < 1e-12 && p.z.abs() < 1e-12);
    }

    #[test]
    fn touching_faces_do_not_penetrate() {
        // A wall standing on a floor, and two faces sharing an edge.
        let floor = square(0.0, 1.0);
        let wall = Face {
            outer: vec![DVec3::new(-0.5, 0.0, 0.0), DVec3::new(0.5, 0.0, 0.0), DVec3::new(0.5, 1.0, 0.0), DVec3::new(-0.5, 1.0, 0.0)],
            holes: vec![],
            pen: 1,
            outward: false,
        };
        let side = Face {
            outer: vec![DVec3::new(1.0, 0.0, -1.0), DVec3::new(1.0, 1.0, -1.0), DVec3::new(1.0, 1.0, 1.0), DVec3::new(1.0, 0.0, 1.0)],
            holes: vec![],
            pen: 1,
            outward: false,
        };
        let model = Model { faces: vec![floor, wall, side], edges: vec![] };
        assert!(intersections(&model).is_empty());
    }

    #[test]
    fn retracing_counts_length_drawn_over_earlier_parallel_lines() {
        let p = |x: f64, y: f64| DVec2::new(x, y);
        let tol = 0.01;
        // Nothing twice: a square, and a line crossing it.
        let square = [(p(0.0, 0.0), p(1.0, 0.0)), (p(1.0, 0.0), p(1.0, 1.0)), (p(1.0, 1.0), p(0.0, 1.0)), (p(0.0, 1.0), p(0.0, 0.0))];
        let mut once = square.to_vec();
        once.push((p(-1.0, 0.5), p(2.0, 0.5)));
        assert!(retraced(&once, tol) < 4.0 * tol);
        // The bottom edge again, in two pieces and the other way round, a
        // hair off: all of it counts.
        let mut twice = square.to_vec();
        twice.push((p(0.6, 0.004), p(0.0, 0.004)));
        twice.push((p(1.0, 0.0), p(0.6, 0.0)));
        assert!((retraced(&twice, tol) - 1.0).abs() < 2.0 * tol, "{}", retraced(&twice, tol));
        // Parallel but beyond the tolerance, or within it but steep: nothing.
        let near = vec![(p(0.0, 0.0), p(1.0, 0.0)), (p(0.0, 0.05), p(1.0, 0.05)), (p(0.5, -0.5), p(0.5, 0.5))];
        assert!(retraced(&near, tol) < 2.0 * tol);
    }

    #[test]
    fn compare_scores_missing_and_extra_ink() {
        let model = Model { faces: vec![], edges: vec![edge(DVec3::new(-1.0, 0.0, 0.0), DVec3::new(1.0, 0.0, 0.0))] };
        let c = cam();
        let r = sample(&model, &c, &Options::default());
        let a = c.project(DVec3::new(-1.0, 0.0, 0.0)).unwrap().truncate();
        let b = c.project(DVec3::new(1.0, 0.0, 0.0)).unwrap().truncate();
        let lv = |visible: Vec<(f64, f64)>| LineVisibility { source: LineSource::Edge(0), pen: 1, a, b, visible: visible.into() };
        let full = compare(&[lv(vec![(0.0, 1.0)])], &r, COMPARE_TOL);
        assert!(full.passes(0.999), "{full:?}");
        let half = compare(&[lv(vec![(0.0, 0.5)])], &r, COMPARE_TOL);
        assert!((half.recall - 0.5).abs() < 0.01 && half.precision > 0.999, "{half:?}");
        // Extra ink far away from any visible line.
        let stray = LineVisibility {
            source: LineSource::Edge(0),
            pen: 1,
            a: a + DVec2::new(0.0, 0.3),
            b: b + DVec2::new(0.0, 0.3),
            visible: [(0.0, 1.0)].into_iter().collect(),
        };
        let extra = compare(&[lv(vec![(0.0, 1.0)]), stray], &r, COMPARE_TOL);
        assert!((extra.precision - 0.5).abs() < 0.01 && extra.recall > 0.999, "{extra:?}");
    }
}
