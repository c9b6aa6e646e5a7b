//! One line against its candidate faces: the events where its visibility may
//! change, one test per interval between events, and the union of what each
//! face hides.

use glam::{DVec2, DVec3};

use super::bvh::Bvh;
use super::faces::{device, Occluder, Occluders};
use super::intervals::IntervalSet;
use crate::camera::{Camera, Projection};
use crate::model::{LineSource, LineVisibility};
use crate::tolerance::SCREEN_EPS;

/// Faces that never hide a line: those it lies on.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Exclude<'a> {
    /// A model edge's own faces.
    Faces(&'a [u32]),
    /// The two faces whose penetration line this is.
    Pair(u32, u32),
}

impl Exclude<'_> {
    fn contains(&self, id: u32) -> bool {
        match *self {
            Exclude::Faces(f) => f.contains(&id),
            Exclude::Pair(i, j) => id == i || id == j,
        }
    }
}

/// A line clipped at the near plane, in world and device space.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Line<'a> {
    pub source: LineSource,
    pub pen: u32,
    pub exclude: Exclude<'a>,
    /// World-space ends of the part in front of the near plane.
    a: DVec3,
    b: DVec3,
    /// View depths of `a` and `b` (perspective), to map device parameters to
    /// world parameters.
    da: f64,
    db: f64,
    perspective: bool,
    /// Device-space ends.
    pub p0: DVec2,
    pub p1: DVec2,
    /// Farthest device depth of the line.
    zmax: f64,
}

impl<'a> Line<'a> {
    /// The visible-to-the-camera part of `a`-`b`, or `None` when it is behind
    /// the near plane or seen end-on (a point on screen).
    pub fn new(source: LineSource, pen: u32, exclude: Exclude<'a>, a: DVec3, b: DVec3, camera: &Camera) -> Option<Line<'a>> {
        let (s0, s1) = camera.clip_segment(a, b)?;
        let (a, b) = (a.lerp(b, s0), a.lerp(b, s1));
        let (ea, eb) = (device(camera, a), device(camera, b));
        let (p0, p1) = (ea.truncate(), eb.truncate());
        if !(p0.distance(p1) > SCREEN_EPS) || !p0.is_finite() || !p1.is_finite() {
            return None;
        }
        Some(Line {
            source,
            pen,
            exclude,
            a,
            b,
            da: (-camera.to_view(a).z).max(camera.near),
            db: (-camera.to_view(b).z).max(camera.near),
            perspective: matches!(camera.projection, Projection::Perspective { .. }),
            p0,
            p1,
            zmax: ea.z.max(eb.z),
        })
    }

    /// World parameter of the point at device parameter `t`: the perspective
    /// division makes them differ, by a homography of the line.
    fn s_of_t(&self, t: f64) -> f64 {
        if self.perspective {
            t * self.da / (t * self.da + (1.0 - t) * self.db)
        } else {
            t
        }
    }

    /// Device parameter of the point at world parameter `s`.
    fn t_of_s(&self, s: f64) -> f64 {
        if self.perspective {
            s * self.db / (s * self.db + (1.0 - s) * self.da)
        } else {
            s
        }
    }
}

/// Per-thread buffers, reused from line to line.
#[derive(Default)]
pub(crate) struct Scratch {
    candidates: Vec<u32>,
    stack: Vec<usize>,
    events: Vec<f64>,
    hidden: IntervalSet,
}

/// Whether device point `p` is inside `face` or within [`SCREEN_EPS`] of its
/// boundary (faces are closed sets); even-odd over all rings, so holes work.
fn covers(occ: &Occluders, face: &Occluder, p: DVec2) -> bool {
    if p.cmplt(face.lo - SCREEN_EPS).any() || p.cmpgt(face.hi + SCREEN_EPS).any() {
        return false;
    }
    let mut inside = false;
    for ring in occ.rings_of(face) {
        let mut a = ring[ring.len() - 1];
        for &b in ring {
            let ab = b - a;
            let l2 = ab.length_squared();
            let t = if l2 > 0.0 { ((p - a).dot(ab) / l2).clamp(0.0, 1.0) } else { 0.0 };
            if p.distance_squared(a + ab * t) <= SCREEN_EPS * SCREEN_EPS {
                return true;
            }
            if (a.y > p.y) != (b.y > p.y) && p.x < a.x + (p.y - a.y) * ab.x / ab.y {
                inside = !inside;
            }
            a = b;
        }
    }
    inside
}

/// Adds to `hidden` the parameter intervals of `line` that `face` hides.
///
/// Events: where the line crosses the face's projected boundary (and the
/// projections of boundary vertices lying on the line, which bound collinear
/// overlaps), and where it pierces the face's plane. Between two events
/// neither "inside the face on screen" nor "behind its plane" can change, so
/// the midpoint decides the whole interval (Hedgley's theorem).
fn hide_by(line: &Line, occ: &Occluders, face: &Occluder, eps: f64, gap: f64, s: &mut Scratch) {
    let fa = face.normal.dot(line.a) - face.offset;
    let fb = face.normal.dot(line.b) - face.offset;
    let behind = |v: f64| v * face.eye_side < 0.0 && v.abs() > eps;
    if !behind(fa) && !behind(fb) {
        return;
    }
    let ev = &mut s.events;
    ev.clear();
    ev.push(0.0);
    ev.push(1.0);
    if (fa > eps && fb < -eps) || (fa < -eps && fb > eps) {
        ev.push(line.t_of_s(fa / (fa - fb)));
    }
    let d = line.p1 - line.p0;
    let len2 = d.length_squared();
    let inv_len = 1.0 / len2.sqrt();
    for ring in occ.rings_of(face) {
        let mut q0 = ring[ring.len() - 1];
        let mut c0 = d.perp_dot(q0 - line.p0) * inv_len;
        for &q1 in ring {
            let c1 = d.perp_dot(q1 - line.p0) * inv_len;
            if c1.abs() <= SCREEN_EPS {
                ev.push(d.dot(q1 - line.p0) / len2);
            } else if (c0 > SCREEN_EPS && c1 < -SCREEN_EPS) || (c0 < -SCREEN_EPS && c1 > SCREEN_EPS) {
                let q = q0 + (q1 - q0) * (c0 / (c0 - c1));
                ev.push(d.dot(q - line.p0) / len2);
            }
            q0 = q1;
            c0 = c1;
        }
    }
    for t in ev.iter_mut() {
        *t = t.clamp(0.0, 1.0);
    }
    ev.sort_unstable_by(f64::total_cmp);
    for k in 1..ev.len() {
        let (ta, tb) = (ev[k - 1], ev[k]);
        if tb - ta <= gap {
            continue;
        }
        let tm = 0.5 * (ta + tb);
        let fm = fa + (fb - fa) * line.s_of_t(tm);
        if behind(fm) && covers(occ, face, line.p0 + d * tm) {
            s.hidden.insert(ta, tb, gap);
        }
    }
}

/// The visible intervals of one line.
pub(crate) fn visibility(line: &Line, occ: &Occluders, bvh: &Bvh, eps: f64, s: &mut Scratch) -> LineVisibility {
    s.candidates.clear();
    let candidates = &mut s.candidates;
    bvh.visit_segment(&occ.faces, line.p0, line.p1, line.zmax, SCREEN_EPS, &mut s.stack, |i| candidates.push(i));
    s.candidates.sort_unstable();
    s.hidden.clear();
    let gap = SCREEN_EPS / line.p0.distance(line.p1);
    let candidates = std::mem::take(&mut s.candidates);
    // Candidates come front to back: once a face starts behind the line's
    // farthest point, so do all the rest.
    for &i in &candidates {
        let face = &occ.faces[i as usize];
        if face.zmin > line.zmax {
            break;
        }
        if line.exclude.contains(face.id) {
            continue;
        }
        hide_by(line, occ, face, eps, gap, s);
        if s.hidden.covers_all(gap) {
            break;
        }
    }
    s.candidates = candidates;
    LineVisibility { source: line.source, pen: line.pen, a: line.p0, b: line.p1, visible: s.hidden.complement(gap) }
}
