//! The horizon: the picture of everything processed so far, seen along the rays
//! from the pole.
//!
//! In device space the images of world verticals all pass through one point,
//! the pole (the vanishing point of vertical lines; at infinity when they stay
//! parallel). A vertical half-plane through the eye images to one ray from the
//! pole. When facets are processed in an occlusion-compatible order, the
//! processed part of the grid is star-shaped from the eye's ground point, so on
//! every ray its picture is a single interval: `[inner, outer]` (Anderson's
//! inner and outer perimeter; Greenspun and Little's bottom and top horizon).
//! Each of the two bounds is a chain of straight screen segments ordered by the
//! ray they start on (the *key*: an angle around a finite pole, a coordinate
//! across parallel rays).
//!
//! A chain is stored as a gap buffer of [`Piece`]s: facets arrive in sweeps
//! whose keys move monotonically, so each edit happens next to the gap and a
//! whole sweep costs time linear in what it touches plus the horizon's size.

use super::tolerance::{RADIAL_EQ, RADIAL_SIN};
use glam::DVec2;

/// Where the rays come from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Pole {
    /// Rays leave the finite point `c`; keys are angles measured from the unit
    /// direction `w`, in `[-pi, 0]` right of the line through `c` along `w` and
    /// `[0, pi]` left of it.
    Finite {
        /// The pole.
        c: DVec2,
        /// Key-zero direction (unit).
        w: DVec2,
    },
    /// Parallel rays along the unit direction `dir`; the key is the coordinate
    /// across them.
    Infinite {
        /// Radial direction (unit).
        dir: DVec2,
    },
}

/// Which side of the splitting line a finite-pole primitive lies on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Half {
    /// Keys in `[0, pi]` (or the whole line for an infinite pole).
    Left,
    /// Keys in `[-pi, 0]`.
    Right,
}

/// The pseudo-angle of a half turn (see [`Pole::raw_key`]).
const HALF_TURN: f64 = 2.0;
/// The pseudo-angle of a quarter turn.
const QUARTER: f64 = 1.0;

/// A monotone stand-in for `y.atan2(x)`: in `[0, 2]` when `y` is positive
/// (or +0), in `[-2, -0]` when negative, `+-2` on the negative x axis, as
/// `atan2` is `+-pi` there.
#[inline]
fn pseudo_angle(x: f64, y: f64) -> f64 {
    let den = x.abs() + y.abs();
    if den == 0.0 {
        return 0.0;
    }
    let a = 1.0 - x / den;
    if y.is_sign_negative() {
        -a
    } else {
        a
    }
}

#[inline]
fn cross(a: DVec2, b: DVec2) -> f64 {
    a.x * b.y - a.y * b.x
}

impl Pole {
    /// The ray through `q`: origin and direction.
    #[inline]
    pub(crate) fn ray(&self, q: DVec2) -> (DVec2, DVec2) {
        match *self {
            Pole::Finite { c, .. } => (c, q - c),
            Pole::Infinite { dir } => (q, dir),
        }
    }

    /// Radial coordinate of `q` on its own ray [`Pole::ray`]`(q)`.
    #[inline]
    pub(crate) fn own_s(&self) -> f64 {
        match self {
            Pole::Finite { .. } => 1.0,
            Pole::Infinite { .. } => 0.0,
        }
    }

    /// Key of `p`, unclamped: a pseudo-angle in `[-2, 2]` for a finite pole
    /// (`0` along `w`, `1` a quarter turn left, `+-2` opposite `w`), which
    /// orders rays exactly as their angle does at the cost of one division
    /// instead of an `atan2`.
    #[inline]
    pub(crate) fn raw_key(&self, p: DVec2) -> f64 {
        match *self {
            Pole::Finite { c, w } => {
                let d = p - c;
                pseudo_angle(w.dot(d), cross(w, d))
            }
            Pole::Infinite { dir } => cross(dir, p),
        }
    }

    /// Signed side of `p` with respect to the splitting line (finite pole);
    /// positive is [`Half::Left`]. Always 1 for an infinite pole.
    #[inline]
    pub(crate) fn side(&self, p: DVec2) -> f64 {
        match *self {
            Pole::Finite { c, w } => cross(w, p - c),
            Pole::Infinite { .. } => 1.0,
        }
    }

    /// A raw key moved into the range of `half` (points on the splitting line
    /// belong to both halves; their raw key may carry the wrong sign).
    #[inline]
    pub(crate) fn clamp_key(&self, k: f64, half: Half) -> f64 {
        match self {
            Pole::Infinite { .. } => k,
            Pole::Finite { .. } => match half {
                Half::Left if k < 0.0 => {
                    if k < -QUARTER {
                        HALF_TURN
                    } else {
                        0.0
                    }
                }
                Half::Right if k > 0.0 => {
                    if k > QUARTER {
                        -HALF_TURN
                    } else {
                        0.0
                    }
                }
                _ => k,
            },
        }
    }

    /// Distance from the pole along the ray (finite pole), or the coordinate
    /// along the parallel rays: comparable across rays, unlike `s`.
    #[inline]
    pub(crate) fn radius(&self, p: DVec2) -> f64 {
        match *self {
            Pole::Finite { c, .. } => (p - c).length(),
            Pole::Infinite { dir } => p.dot(dir),
        }
    }

    /// Smallest and largest [`Pole::radius`] over the segment `a`-`b`.
    #[inline]
    pub(crate) fn radius_range(&self, a: DVec2, b: DVec2) -> (f64, f64) {
        self.radius_range_known(a, b, self.radius(a), self.radius(b))
    }

    /// As [`Pole::radius_range`], given the radii `ra`, `rb` of the ends: the
    /// square root is taken only when the nearest point is inside the
    /// segment.
    #[inline]
    pub(crate) fn radius_range_known(&self, a: DVec2, b: DVec2, ra: f64, rb: f64) -> (f64, f64) {
        let hi = ra.max(rb);
        let lo = match *self {
            Pole::Finite { c, .. } => {
                let d = b - a;
                if (c - a).dot(d) > 0.0 && (c - b).dot(d) < 0.0 {
                    let t = (c - a).dot(d) / d.length_squared();
                    (a + d * t - c).length().min(ra).min(rb)
                } else {
                    ra.min(rb)
                }
            }
            Pole::Infinite { .. } => ra.min(rb),
        };
        (lo, hi)
    }

    /// Key of a point known to lie between keys `lo` and `hi` of one half.
    #[inline]
    fn key_between(&self, p: DVec2, lo: f64, hi: f64) -> f64 {
        let mut k = self.raw_key(p);
        if let Pole::Finite { .. } = self {
            // The splitting ray opposite `w` has key +2 on the left, -2 on
            // the right; pick the representative nearest the interval.
            if k < lo - HALF_TURN {
                k += 2.0 * HALF_TURN;
            } else if k > hi + HALF_TURN {
                k -= 2.0 * HALF_TURN;
            }
        }
        k.clamp(lo, hi)
    }
}

/// Radial coordinate, relative to the ray `(o, u)`, of where the line through
/// `a` and `b` meets it.
#[inline]
pub(crate) fn line_s(a: DVec2, b: DVec2, o: DVec2, u: DVec2) -> f64 {
    let d = b - a;
    let den = cross(u, d);
    if den == 0.0 {
        // Parallel to the ray: only happens for pieces that are nearly radial,
        // which are never stored; answer with the nearer end.
        return (a - o).dot(u) / u.length_squared().max(f64::MIN_POSITIVE);
    }
    cross(a - o, d) / den
}

/// One straight piece of a horizon chain, over the keys `[k0, k1]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Piece {
    /// Key where the piece starts.
    pub k0: f64,
    /// Key where it ends, `> k0`.
    pub k1: f64,
    /// Point of the piece on the ray of `k0`.
    pub a: DVec2,
    /// Point of the piece on the ray of `k1`.
    pub b: DVec2,
    /// The piece is the pole itself (radius zero on every ray): the inner
    /// horizon of facets that contain the pole. `a` and `b` then only name
    /// the rays of `k0` and `k1`.
    pub pole: bool,
    /// Smallest radius (see [`Pole::radius`]) over the piece.
    pub rlo: f64,
    /// Largest radius over the piece.
    pub rhi: f64,
}

impl Piece {
    /// A piece over `[k0, k1]` from `a` to `b` (or the pole itself).
    #[inline]
    pub(crate) fn new(pole_: &Pole, k0: f64, k1: f64, a: DVec2, b: DVec2, pole: bool) -> Piece {
        let (rlo, rhi) = if pole { (0.0, 0.0) } else { pole_.radius_range(a, b) };
        Piece { k0, k1, a, b, pole, rlo, rhi }
    }

    /// A (non-pole) piece whose ends' radii are known.
    #[inline]
    pub(crate) fn with_radii(pole: &Pole, k0: f64, k1: f64, a: DVec2, b: DVec2, ra: f64, rb: f64) -> Piece {
        let (rlo, rhi) = pole.radius_range_known(a, b, ra, rb);
        Piece { k0, k1, a, b, pole: false, rlo, rhi }
    }

    /// Radial coordinate on the ray through `q`.
    #[inline]
    pub(crate) fn s_at(&self, pole: &Pole, q: DVec2) -> f64 {
        if self.pole {
            return 0.0;
        }
        if q == self.a || q == self.b {
            // On its own ray an end sits at the ray's own point: no division.
            return pole.own_s();
        }
        let (o, u) = pole.ray(q);
        line_s(self.a, self.b, o, u)
    }

    /// The point of the piece on the ray through `q`.
    #[inline]
    fn point_at(&self, pole: &Pole, q: DVec2) -> DVec2 {
        if self.pole {
            return q;
        }
        let (o, u) = pole.ray(q);
        o + u * line_s(self.a, self.b, o, u)
    }

    /// The piece restricted to keys `[k, k2]` with rays through `q`, `q2`.
    #[inline]
    fn restricted(&self, pole: &Pole, k: f64, q: DVec2, k2: f64, q2: DVec2) -> Piece {
        if k == self.k0 && k2 == self.k1 {
            return *self;
        }
        let a = if k == self.k0 { self.a } else { self.point_at(pole, q) };
        let b = if k2 == self.k1 { self.b } else { self.point_at(pole, q2) };
        Piece::new(pole, k, k2, a, b, self.pole)
    }
}

/// Appends `p`, joining it to the last piece when they continue one line
/// (Greenspun and Little's collapse of collinear horizon fragments: it keeps
/// the horizon short on smooth surfaces).
fn push_joined(out: &mut Vec<Piece>, p: Piece) {
    if !(p.k1 > p.k0) {
        return;
    }
    if let Some(last) = out.last_mut() {
        if last.k1 == p.k0 {
            if last.pole && p.pole {
                last.k1 = p.k1;
                last.b = p.b;
                return;
            }
            if !last.pole && !p.pole {
                // Squared forms of |gap| <= eps max(|d1|, |d2|, |b|) and
                // |d1 x d2| <= eps |d1| |d2|: no square roots on this path.
                let d1 = last.b - last.a;
                let d2 = p.b - last.a;
                let gap2 = (p.a - last.b).length_squared();
                let (l1, l2) = (d1.length_squared(), d2.length_squared());
                let scale2 = l1.max(l2).max(last.b.length_squared());
                let x = cross(d1, d2);
                let eps2 = RADIAL_EQ * RADIAL_EQ;
                if gap2 <= eps2 * scale2 && x * x <= eps2 * l1 * l2 && d1.dot(d2) > 0.0 {
                    last.k1 = p.k1;
                    last.b = p.b;
                    last.rlo = last.rlo.min(p.rlo);
                    last.rhi = last.rhi.max(p.rhi);
                    return;
                }
            }
        }
    }
    out.push(p);
}

/// True when `new` (bounded in radius by `rmin`, `rmax`) is nowhere beyond
/// the old piece `po` on the keys they share: then `po` stays whole, with no
/// cut and no re-join. Radius bounds settle most pieces; the rest compare on
/// the rays where a new piece starts or ends, as [`envelope`] does (two lines
/// cross at most once between two rays).
fn dominated(pole: &Pole, po: &Piece, new: &[Piece], outer: bool, rmin: f64, rmax: f64) -> bool {
    if outer && po.rlo >= rmax || !outer && po.rhi <= rmin {
        return true;
    }
    if outer && po.rhi < rmin || !outer && po.rlo > rmax {
        return false;
    }
    let sign = if outer { 1.0 } else { -1.0 };
    let behind = |pn: &Piece, q: DVec2| sign * (pn.s_at(pole, q) - po.s_at(pole, q)) <= 0.0;
    for pn in new {
        if pn.k1 <= po.k0 {
            continue;
        }
        if pn.k0 >= po.k1 {
            break;
        }
        let qa = if pn.k0 > po.k0 { pn.a } else { po.a };
        let qb = if pn.k1 < po.k1 { pn.b } else { po.b };
        if !behind(pn, qa) || !behind(pn, qb) {
            return false;
        }
    }
    true
}

/// True when the new piece `pn` is beyond (`outer`; nearer in for the inner
/// chain) or on every piece of `old` on the keys they share: then `pn` goes
/// in whole, not cut at each old breakpoint and joined again. The mirror of
/// [`dominated`], with the same comparisons as [`envelope`].
fn beats(pole: &Pole, pn: &Piece, old: &[Piece], outer: bool) -> bool {
    let sign = if outer { 1.0 } else { -1.0 };
    for po in old {
        if po.k1 <= pn.k0 {
            continue;
        }
        if po.k0 >= pn.k1 {
            break;
        }
        if outer && pn.rlo >= po.rhi || !outer && pn.rhi <= po.rlo {
            continue;
        }
        let qa = if po.k0 > pn.k0 { po.a } else { pn.a };
        let qb = if po.k1 < pn.k1 { po.b } else { pn.b };
        let ahead = |q: DVec2| sign * (pn.s_at(pole, q) - po.s_at(pole, q)) >= 0.0;
        if !ahead(qa) || !ahead(qb) {
            return false;
        }
    }
    true
}

/// The pointwise maximum (`outer`) or minimum (inner) along rays of two
/// sorted, non-overlapping piece lists, over the union of their key ranges;
/// `(rmin, rmax)` bound the radius of `new`.
pub(crate) fn envelope(pole: &Pole, old: &[Piece], new: &[Piece], outer: bool, rmin: f64, rmax: f64, out: &mut Vec<Piece>) {
    out.clear();
    let (mut i, mut j) = (0, 0);
    let (mut k, mut q) = match (old.first(), new.first()) {
        (Some(o), Some(n)) => {
            if o.k0 <= n.k0 {
                (o.k0, o.a)
            } else {
                (n.k0, n.a)
            }
        }
        (Some(o), None) => (o.k0, o.a),
        (None, Some(n)) => (n.k0, n.a),
        (None, None) => return,
    };
    loop {
        while i < old.len() && old[i].k1 <= k {
            i += 1;
        }
        while j < new.len() && new[j].k1 <= k {
            j += 1;
        }
        if i == old.len() && j == new.len() {
            break;
        }
        let o = old.get(i).filter(|p| p.k0 <= k);
        if let Some(po) = o {
            if k == po.k0 && dominated(pole, po, &new[j..], outer, rmin, rmax) {
                out.push(*po);
                k = po.k1;
                q = po.b;
                continue;
            }
        }
        let n = new.get(j).filter(|p| p.k0 <= k);
        if let Some(pn) = n {
            if k == pn.k0 && beats(pole, pn, &old[i..], outer) {
                out.push(*pn);
                k = pn.k1;
                q = pn.b;
                continue;
            }
        }
        // The next key where something starts or ends.
        let mut next: Option<(f64, DVec2)> = None;
        let mut consider = |kk: f64, qq: DVec2| {
            if next.is_none_or(|(nk, _)| kk < nk) {
                next = Some((kk, qq));
            }
        };
        match o {
            Some(p) => consider(p.k1, p.b),
            None => {
                if let Some(p) = old.get(i) {
                    consider(p.k0, p.a)
                }
            }
        }
        match n {
            Some(p) => consider(p.k1, p.b),
            None => {
                if let Some(p) = new.get(j) {
                    consider(p.k0, p.a)
                }
            }
        }
        let Some((k2, q2)) = next else { break };
        match (o, n) {
            (None, None) => {}
            (Some(p), None) | (None, Some(p)) => push_joined(out, p.restricted(pole, k, q, k2, q2)),
            (Some(po), Some(pn)) => {
                let sign = if outer { 1.0 } else { -1.0 };
                let dl = sign * (pn.s_at(pole, q) - po.s_at(pole, q));
                let dr = sign * (pn.s_at(pole, q2) - po.s_at(pole, q2));
                if dl >= 0.0 && dr >= 0.0 {
                    push_joined(out, pn.restricted(pole, k, q, k2, q2));
                } else if dl <= 0.0 && dr <= 0.0 {
                    push_joined(out, po.restricted(pole, k, q, k2, q2));
                } else {
                    let (first, second) = if dl > 0.0 { (pn, po) } else { (po, pn) };
                    match line_intersection(po, pn) {
                        Some(x) => {
                            let kx = pole.key_between(x, k, k2);
                            push_joined(out, first.restricted(pole, k, q, kx, x));
                            push_joined(out, second.restricted(pole, kx, x, k2, q2));
                        }
                        None => {
                            let p = if dl.abs() + dr.max(0.0) >= dr.abs() + dl.max(0.0) { first } else { second };
                            push_joined(out, p.restricted(pole, k, q, k2, q2));
                        }
                    }
                }
            }
        }
        k = k2;
        q = q2;
    }
}

/// Where the lines of two non-pole pieces meet.
fn line_intersection(p: &Piece, r: &Piece) -> Option<DVec2> {
    if p.pole || r.pole {
        return None;
    }
    let d1 = p.b - p.a;
    let d2 = r.b - r.a;
    let den = cross(d1, d2);
    if den == 0.0 {
        return None;
    }
    let t = cross(r.a - p.a, d2) / den;
    Some(p.a + d1 * t)
}

/// A straight screen segment with the keys of its ends, `kp <= kq`, all in one
/// half; `tp`, `tq` are the parameters of its ends on the line being tested,
/// `rp`, `rq` their radii (see [`Pole::radius`]).
#[derive(Clone, Copy, Debug)]
pub(crate) struct KSeg {
    pub p: DVec2,
    pub q: DVec2,
    pub kp: f64,
    pub kq: f64,
    pub tp: f64,
    pub tq: f64,
    pub rp: f64,
    pub rq: f64,
}

impl KSeg {
    /// Parameter on the tested line where this segment meets the ray `(o, u)`.
    #[inline]
    fn t_on_ray(&self, o: DVec2, u: DVec2) -> f64 {
        let d = self.q - self.p;
        let den = cross(d, u);
        let f = if den == 0.0 { 0.0 } else { (cross(o - self.p, u) / den).clamp(0.0, 1.0) };
        self.tp + (self.tq - self.tp) * f
    }

    /// True when the segment lies along a single ray.
    pub(crate) fn is_radial(&self, pole: &Pole) -> bool {
        let d = self.q - self.p;
        let len2 = d.length_squared();
        if len2 == 0.0 {
            return true;
        }
        // Measured on the ray through the end farther from a finite pole
        // (the well-conditioned one); the cross product is the same on both
        // ends' rays, only the ray's length differs, and that is the radius.
        let (x, ul2) = match *pole {
            Pole::Finite { c, .. } => {
                let r = self.rp.max(self.rq);
                (cross(d, self.p - c), r * r)
            }
            Pole::Infinite { dir } => (cross(d, dir), dir.length_squared()),
        };
        ul2 == 0.0 || x * x <= RADIAL_SIN * RADIAL_SIN * len2 * ul2
    }

    /// The end farther from a finite pole (a well-conditioned ray).
    fn mid_far(&self, pole: &Pole) -> DVec2 {
        match pole {
            Pole::Finite { c, .. } => {
                if self.p.distance_squared(*c) >= self.q.distance_squared(*c) {
                    self.p
                } else {
                    self.q
                }
            }
            Pole::Infinite { .. } => self.p,
        }
    }
}

/// One chain (outer or inner) as a gap buffer.
#[derive(Clone, Debug, Default)]
pub(crate) struct Chain {
    /// Pieces left of the gap, ascending.
    left: Vec<Piece>,
    /// Pieces right of the gap, descending (the top is the first after the gap).
    right: Vec<Piece>,
}

impl Chain {
    /// Moves the gap so that every piece ending before `k` is left of it and
    /// every other piece right of it.
    #[inline]
    fn seek(&mut self, k: f64) {
        while let Some(p) = self.left.last() {
            if p.k1 >= k {
                self.right.push(self.left.pop().expect("non-empty"));
            } else {
                break;
            }
        }
        while let Some(p) = self.right.last() {
            if p.k1 < k {
                self.left.push(self.right.pop().expect("non-empty"));
            } else {
                break;
            }
        }
    }

    /// Over the pieces overlapping keys `[k0, k1]`: whether they cover it
    /// without gaps, and their smallest and largest radius.
    #[inline]
    fn bounds(&mut self, k0: f64, k1: f64) -> (bool, f64, f64) {
        self.seek(k0);
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        let mut reach = f64::NEG_INFINITY;
        let mut covered = true;
        for (n, p) in self.right.iter().rev().enumerate() {
            if p.k0 >= k1 {
                break;
            }
            if (n == 0 && p.k0 > k0) || (n > 0 && p.k0 > reach) {
                covered = false;
            }
            reach = p.k1;
            lo = lo.min(p.rlo);
            hi = hi.max(p.rhi);
        }
        (covered && reach >= k1, lo, hi)
    }

    /// When the chain over the keys of `new` is exactly (same keys, same
    /// end points) `other`, the region's opposite chain, replaces it by `new`
    /// and returns true. The region lies between its two chains on every ray,
    /// so there the envelope is `new`: nothing to intersect. This is the
    /// common case of a smooth surface, where each cell's near chain is the
    /// far chain of the cells merged before it.
    #[inline]
    fn replace_exact(&mut self, new: &[Piece], other: &[Piece]) -> bool {
        let (Some(f), Some(l), Some(of), Some(ol)) = (new.first(), new.last(), other.first(), other.last()) else {
            return false;
        };
        if of.k0 != f.k0 || ol.k1 != l.k1 {
            return false;
        }
        let n = self.right.len();
        // After `seek(f.k0)` the top may be a piece ending exactly at `f.k0`.
        let skip = usize::from(self.right.last().is_some_and(|p| p.k1 == f.k0));
        let m = other.len();
        if n < skip + m {
            return false;
        }
        let top = n - skip;
        let same = |p: &Piece, q: &Piece| p.k0 == q.k0 && p.k1 == q.k1 && p.a == q.a && p.b == q.b && p.pole == q.pole;
        if !other.iter().enumerate().all(|(i, o)| same(&self.right[top - 1 - i], o)) {
            return false;
        }
        if new.len() == m {
            for (i, p) in new.iter().enumerate() {
                self.right[top - 1 - i] = *p;
            }
        } else {
            let touching = if skip == 1 { self.right.pop() } else { None };
            self.right.truncate(top - m);
            self.right.extend(new.iter().rev());
            self.right.extend(touching);
        }
        true
    }

    /// Replaces the chain over the keys of `new` by its envelope with `new`;
    /// `other` is the region's opposite chain, `(rmin, rmax)` bound its radius.
    // One call per facet on the hottest path; the radius bounds are the
    // caller's, computed once for both chains.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn merge(&mut self, pole: &Pole, new: &[Piece], other: &[Piece], outer: bool, scratch: &mut Scratch, rmin: f64, rmax: f64) {
        let (Some(first), Some(last)) = (new.first(), new.last()) else { return };
        self.seek(first.k0);
        // A surface seen from above mostly replaces the outer chain and
        // leaves the inner one alone: the likelier test first.
        if outer && self.replace_exact(new, other) {
            return;
        }
        // Most facets leave one of the two chains alone: decide that from
        // radius bounds before doing any intersection.
        let (covered, lo, hi) = self.bounds(first.k0, last.k1);
        if covered && ((outer && rmax <= lo) || (!outer && rmin >= hi)) {
            return;
        }
        if !outer && self.replace_exact(new, other) {
            return;
        }
        scratch.old.clear();
        while let Some(p) = self.right.last() {
            if p.k0 < last.k1 {
                scratch.old.push(self.right.pop().expect("non-empty"));
            } else {
                break;
            }
        }
        envelope(pole, &scratch.old, new, outer, rmin, rmax, &mut scratch.out);
        self.right.extend(scratch.out.drain(..).rev());
    }

    /// Appends to `out` the parameter intervals of `seg` strictly beyond this
    /// chain along the rays: farther out for the outer chain (`OUTER`), nearer
    /// in for the inner one ("beyond" = on the side where the processed
    /// picture lies), in key order. `(rlo, rhi)` bound the radius of `seg`.
    ///
    /// One walk decides and computes: radius bounds settle most pieces
    /// without a division (a segment wholly beyond the chain, the common case
    /// on a smooth surface, or wholly inside it, the common case on a rough
    /// one, costs a few comparisons per piece), the rest go to [`cut_piece`],
    /// and a parameter on the segment is computed only where an interval
    /// starts or ends, not where it runs on from one piece to the next.
    #[inline]
    fn inside<const OUTER: bool>(&mut self, pole: &Pole, seg: &KSeg, rlo: f64, rhi: f64, out: &mut Vec<(f64, f64)>) {
        // The gap is moved back to the segment, never forward: the pieces
        // between are only read. The edges of a cell are tested before the
        // cell is merged at its smallest key, so moving the gap forward for
        // an edge at the cell's far end would only move it back again.
        while let Some(p) = self.left.last() {
            if p.k1 >= seg.kp {
                self.right.push(self.left.pop().expect("non-empty"));
            } else {
                break;
            }
        }
        let t_left = |h: &Piece| {
            if h.k0 > seg.kp {
                let (o, u) = pole.ray(h.a);
                seg.t_on_ray(o, u)
            } else {
                seg.tp
            }
        };
        let t_right = |h: &Piece| {
            if h.k1 < seg.kq {
                let (o, u) = pole.ray(h.b);
                seg.t_on_ray(o, u)
            } else {
                seg.tq
            }
        };
        let rscale = rlo.abs().max(rhi.abs());
        // The interval being built: its start, and the last piece it runs to
        // the end of.
        let mut run: Option<(f64, &Piece)> = None;
        for h in self.right.iter().rev() {
            if h.k0 >= seg.kq {
                break;
            }
            // Pieces before the segment, or meeting it on one ray only (ending
            // where it starts), hold nothing of it; nor does a piece nowhere
            // beyond the segment's nearest point.
            if h.k1 > seg.kp {
                let (ahead_lo, ahead_hi) = if OUTER { (h.rlo - rhi, h.rhi - rlo) } else { (rlo - h.rhi, rhi - h.rlo) };
                let cut = if ahead_hi <= 0.0 {
                    Cut::None
                } else if ahead_lo > 0.0 && ahead_lo > RADIAL_EQ * rscale.max(h.rlo.abs()).max(h.rhi.abs()) {
                    Cut::Whole
                } else {
                    cut_piece::<OUTER>(pole, seg, h, rlo, rhi)
                };
                let joins = run.is_some_and(|(_, last)| last.k1 == h.k0);
                match cut {
                    Cut::Whole if joins => run = run.map(|(t0, _)| (t0, h)),
                    Cut::Left(tx) if joins => {
                        out.push((run.map_or(tx, |(t0, _)| t0), tx));
                        run = None;
                    }
                    _ => {
                        if let Some((t0, last)) = run.take() {
                            out.push((t0, t_right(last)));
                        }
                        match cut {
                            Cut::None => {}
                            Cut::Whole => run = Some((t_left(h), h)),
                            Cut::Left(tx) => out.push((t_left(h), tx)),
                            Cut::Right(tx) => run = Some((tx, h)),
                        }
                    }
                }
            }
            if h.k1 >= seg.kq {
                break;
            }
        }
        if let Some((t0, last)) = run {
            out.push((t0, t_right(last)));
        }
    }

    /// Extreme radial coordinate of the chain on the ray through `q` (key
    /// `k`): the largest (`outer`) or smallest over the pieces touching it.
    /// Pieces ending within [`RADIAL_SIN`] of the ray count as touching it:
    /// the ends of pieces on one ray (a vertical plane through the eye) get
    /// keys that differ by round-off.
    fn extreme_at(&mut self, pole: &Pole, k: f64, q: DVec2, outer: bool) -> Option<f64> {
        self.seek(k - RADIAL_SIN);
        let mut best: Option<f64> = None;
        for h in self.right.iter().rev() {
            if h.k0 > k + RADIAL_SIN {
                break;
            }
            let s = h.s_at(pole, q);
            best = Some(match best {
                None => s,
                Some(b) if outer => b.max(s),
                Some(b) => b.min(s),
            });
        }
        best
    }
}

/// Which part of a tested segment lies beyond one horizon piece, over the
/// piece's keys.
#[derive(Clone, Copy, Debug)]
enum Cut {
    /// None of it.
    None,
    /// All of it.
    Whole,
    /// From the piece's first key to the parameter given.
    Left(f64),
    /// From the parameter given to the piece's last key.
    Right(f64),
}

/// The part of [`Chain::inside`] for a piece `h` that radius bounds did not
/// settle at once: compares the segment and the piece on the rays through
/// the ends of their common keys, and where they cross.
#[inline(never)]
fn cut_piece<const OUTER: bool>(pole: &Pole, seg: &KSeg, h: &Piece, rlo: f64, rhi: f64) -> Cut {
    let sign = if OUTER { 1.0 } else { -1.0 };
    // How far the piece lies beyond the segment, at least and at most, with
    // the same tolerance as on a single ray.
    let ahead_hi = if OUTER { h.rhi - rlo } else { rhi - h.rlo };
    if ahead_hi <= RADIAL_EQ * rlo.abs().max(rhi.abs()).max(h.rlo.abs()).max(h.rhi.abs()) {
        return Cut::None;
    }
    let left_on_piece = h.k0 > seg.kp;
    let right_on_piece = h.k1 < seg.kq;
    // Whether the segment is beyond the piece on the ray through `q`, an end
    // of the piece (`rs` None) or of the segment (`rs` its radius).
    let side = |q: DVec2, rs: Option<f64>| {
        // A vertex shared by the segment and the piece lies on both: not
        // beyond (the segment that starts on the horizon, the common case, is
        // decided without any division).
        if !h.pole && (q == h.a || q == h.b) && (q == seg.p || q == seg.q) {
            return false;
        }
        let ss = match rs {
            Some(rs) => {
                let (lo, hi) = if OUTER { (h.rlo - rs, h.rhi - rs) } else { (rs - h.rhi, rs - h.rlo) };
                if hi <= 0.0 {
                    return false;
                }
                if lo > RADIAL_EQ * rs.abs().max(h.rlo.abs()).max(h.rhi.abs()) {
                    return true;
                }
                // On its own ray an end of the segment is at the ray's own
                // point.
                pole.own_s()
            }
            None => {
                let (o, u) = pole.ray(q);
                line_s(seg.p, seg.q, o, u)
            }
        };
        let sh = h.s_at(pole, q);
        sign * (sh - ss) > RADIAL_EQ * ss.abs().max(sh.abs())
    };
    let hl = if left_on_piece { side(h.a, None) } else { side(seg.p, Some(seg.rp)) };
    let hr = if right_on_piece { side(h.b, None) } else { side(seg.q, Some(seg.rq)) };
    if hl == hr {
        return if hl { Cut::Whole } else { Cut::None };
    }
    // The segment crosses the piece's line in between.
    let t_at = |on_piece: bool, q: DVec2, t: f64| {
        if on_piece {
            let (o, u) = pole.ray(q);
            seg.t_on_ray(o, u)
        } else {
            t
        }
    };
    let (t0, t1) = (t_at(left_on_piece, h.a, seg.tp), t_at(right_on_piece, h.b, seg.tq));
    let tx = if h.pole {
        if hl {
            t1
        } else {
            t0
        }
    } else {
        let d = seg.q - seg.p;
        let e = h.b - h.a;
        let den = cross(d, e);
        if den == 0.0 {
            (t0 + t1) * 0.5
        } else {
            let f = cross(h.a - seg.p, e) / den;
            (seg.tp + (seg.tq - seg.tp) * f).clamp(t0.min(t1), t0.max(t1))
        }
    };
    if hl {
        Cut::Left(tx)
    } else {
        Cut::Right(tx)
    }
}

/// Reusable buffers for [`Chain::merge`].
#[derive(Clone, Debug, Default)]
pub(crate) struct Scratch {
    old: Vec<Piece>,
    out: Vec<Piece>,
    a: Vec<(f64, f64)>,
    b: Vec<(f64, f64)>,
}

/// The outer and inner chains together.
#[derive(Clone, Debug)]
pub(crate) struct Horizon {
    pub pole: Pole,
    pub outer: Chain,
    pub inner: Chain,
    scratch: Scratch,
}

impl Horizon {
    /// An empty horizon (nothing processed yet).
    pub(crate) fn new(pole: Pole) -> Horizon {
        Horizon { pole, outer: Chain::default(), inner: Chain::default(), scratch: Scratch::default() }
    }

    /// Adds a region given by its far and near chains over the same keys;
    /// `(rmin, rmax)` bound the region's radius.
    pub(crate) fn add(&mut self, far: &[Piece], near: &[Piece], rmin: f64, rmax: f64) {
        self.outer.merge(&self.pole, far, near, true, &mut self.scratch, rmin, rmax);
        self.inner.merge(&self.pole, near, far, false, &mut self.scratch, rmin, rmax);
    }

    /// Appends to `hidden` the sorted parameter intervals of `seg` that lie
    /// strictly inside the processed picture.
    #[inline]
    pub(crate) fn hidden(&mut self, seg: &KSeg, hidden: &mut Vec<(f64, f64)>) {
        if seg.is_radial(&self.pole) {
            self.hidden_radial(seg, hidden);
            return;
        }
        let (rlo, rhi) = self.pole.radius_range_known(seg.p, seg.q, seg.rp, seg.rq);
        let Horizon { pole, outer, inner, scratch } = self;
        scratch.a.clear();
        outer.inside::<true>(pole, seg, rlo, rhi, &mut scratch.a);
        // The inner chain is looked at only when the segment reaches inside
        // the outer one.
        if !scratch.a.is_empty() {
            scratch.b.clear();
            inner.inside::<false>(pole, seg, rlo, rhi, &mut scratch.b);
            intersect_into(&scratch.a, &scratch.b, seg.tp <= seg.tq, hidden);
        }
    }

    /// A segment along one ray: compare radial coordinates on that ray.
    fn hidden_radial(&mut self, seg: &KSeg, hidden: &mut Vec<(f64, f64)>) {
        let q = seg.mid_far(&self.pole);
        let k = if q == seg.p { seg.kp } else { seg.kq };
        let (o, u) = self.pole.ray(q);
        let ul2 = u.length_squared();
        if ul2 == 0.0 {
            return;
        }
        let (Some(so), Some(si)) = (self.outer.extreme_at(&self.pole, k, q, true), self.inner.extreme_at(&self.pole, k, q, false)) else {
            return;
        };
        let sp = (seg.p - o).dot(u) / ul2;
        let sq = (seg.q - o).dot(u) / ul2;
        let scale = so.abs().max(si.abs()).max(sp.abs()).max(sq.abs());
        let lo = si + RADIAL_EQ * scale;
        let hi = so - RADIAL_EQ * scale;
        if !(hi > lo) || sp == sq {
            return;
        }
        // s runs linearly from sp to sq along the segment.
        let f0 = ((lo - sp) / (sq - sp)).clamp(0.0, 1.0);
        let f1 = ((hi - sp) / (sq - sp)).clamp(0.0, 1.0);
        let (f0, f1) = (f0.min(f1), f0.max(f1));
        if f1 > f0 {
            let t0 = seg.tp + (seg.tq - seg.tp) * f0;
            let t1 = seg.tp + (seg.tq - seg.tp) * f1;
            hidden.push((t0.min(t1), t0.max(t1)));
        }
    }
}

/// Intersection of two lists of intervals, each sorted along the segment
/// (ascending `t` when `ascending`, else descending); appended normalised.
fn intersect_into(a: &[(f64, f64)], b: &[(f64, f64)], ascending: bool, out: &mut Vec<(f64, f64)>) {
    // The n-th interval in ascending order, (lo, hi).
    let get = |v: &[(f64, f64)], n: usize| {
        let (x, y) = if ascending { v[n] } else { v[v.len() - 1 - n] };
        (x.min(y), x.max(y))
    };
    let (mut i, mut j) = (0, 0);
    while i < a.len() && j < b.len() {
        let (ai, bj) = (get(a, i), get(b, j));
        let lo = ai.0.max(bj.0);
        let hi = ai.1.min(bj.1);
        if hi > lo {
            out.push((lo, hi));
        }
        if ai.1 < bj.1 {
            i += 1;
        } else {
            j += 1;
        }
    }
}
