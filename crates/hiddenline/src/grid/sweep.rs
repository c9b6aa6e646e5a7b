//! Facets and lines fed to the horizon in occlusion-compatible order.
//!
//! The caller (the grid engine, the ridgeline engine) decides the order; this
//! module turns each convex screen polygon into its far and near chains and
//! each line into its visible parameter intervals, splitting both at the line
//! through a finite pole so that keys never wrap.

use super::horizon::{Half, Horizon, KSeg, Piece, Pole};
use super::tolerance::{KEY_ROUNDOFF, ORIENTED, POLE_CONTAINS, RADIAL_SIN, SLIVER, STRAIGHT_DOWN};
use crate::camera::{Camera, Projection};
use glam::{DVec2, DVec3};

#[inline]
fn cross(a: DVec2, b: DVec2) -> f64 {
    a.x * b.y - a.y * b.x
}

/// The pole of a camera: the image of the world's vertical direction, or
/// `None` for an orthographic view straight down or up (then nothing can hide
/// anything on a height field).
#[must_use]
pub(crate) fn pole_of(camera: &Camera) -> Option<Pole> {
    let dv = camera.to_view(DVec3::Z) - camera.to_view(DVec3::ZERO);
    match camera.projection {
        Projection::Orthographic { .. } => {
            let d = DVec2::new(dv.x, dv.y);
            (d.length() > STRAIGHT_DOWN * dv.length()).then(|| Pole::Infinite { dir: d.normalize() })
        }
        Projection::Perspective { fov_deg } => {
            let s = 1.0 / (fov_deg.to_radians() * 0.5).tan();
            let d = DVec2::new(dv.x, dv.y);
            let c = if dv.z != 0.0 { d * (s / -dv.z) } else { DVec2::splat(f64::INFINITY) };
            if !c.is_finite() || c.length() > super::tolerance::FAR_POLE {
                // Verticals stay (nearly) parallel: rays point along them.
                Some(Pole::Infinite { dir: d.normalize() })
            } else {
                // Keys are measured from the direction towards the picture
                // centre, turned by an arbitrary angle so that the splitting
                // line is unlikely to coincide with grid lines of special views.
                let base = (-c).try_normalize().unwrap_or(DVec2::X);
                let (sn, cs) = 0.123_456_789_f64.sin_cos();
                let w = DVec2::new(base.x * cs - base.y * sn, base.x * sn + base.y * cs);
                Some(Pole::Finite { c, w })
            }
        }
    }
}

/// Splits a convex polygon by the line through a finite pole (sign of
/// `pole.side`), returning the part on the wanted side.
fn clip_half(pole: &Pole, poly: &[DVec2], half: Half, out: &mut Vec<DVec2>) {
    out.clear();
    let sgn = if half == Half::Left { 1.0 } else { -1.0 };
    let n = poly.len();
    for i in 0..n {
        let a = poly[i];
        let b = poly[(i + 1) % n];
        let da = sgn * pole.side(a);
        let db = sgn * pole.side(b);
        if da >= 0.0 {
            out.push(a);
        }
        if (da > 0.0 && db < 0.0) || (da < 0.0 && db > 0.0) {
            let t = da / (da - db);
            out.push(a + (b - a) * t);
        }
    }
}

/// What the sweep keeps between facets: the horizon and reusable buffers.
pub(crate) struct Sweep {
    pub horizon: Horizon,
    half_buf: Vec<DVec2>,
    keys: Vec<f64>,
    given_keys: Vec<f64>,
    /// Radii (see [`Pole::radius`]) of the polygon's vertices.
    radii: Vec<f64>,
    given_radii: Vec<f64>,
    chain_a: Vec<Piece>,
    chain_b: Vec<Piece>,
    far: Vec<Piece>,
    near: Vec<Piece>,
    hidden: Vec<(f64, f64)>,
    /// The one half of the picture this sweep keeps (`None`: both). The
    /// halves hold disjoint keys, so two sweeps, one per half, fed the same
    /// facets and lines in the same order, find between them what one
    /// sweep of both finds; they can run at once.
    only: Option<Half>,
}

impl Sweep {
    pub(crate) fn new(pole: Pole) -> Sweep {
        Sweep {
            only: None,
            horizon: Horizon::new(pole),
            half_buf: Vec::new(),
            keys: Vec::new(),
            given_keys: Vec::new(),
            radii: Vec::new(),
            given_radii: Vec::new(),
            chain_a: Vec::new(),
            chain_b: Vec::new(),
            far: Vec::new(),
            near: Vec::new(),
            hidden: Vec::new(),
        }
    }

    /// A sweep of one half of the picture of a finite pole (see `only`).
    pub(crate) fn of_half(pole: Pole, half: Half) -> Sweep {
        Sweep { only: Some(half), ..Sweep::new(pole) }
    }

    /// Whether this sweep leaves `half` to another.
    fn skips(&self, half: Half) -> bool {
        self.only.is_some_and(|o| o != half)
    }

    /// Whether every point of `pts` lies strictly in the half this sweep
    /// leaves to another: nothing there can change what it finds.
    pub(crate) fn leaves(&self, pts: &[DVec2]) -> bool {
        let Some(only) = self.only else { return false };
        let sign = if only == Half::Left { 1.0 } else { -1.0 };
        pts.iter().all(|&p| sign * self.horizon.pole.side(p) < 0.0)
    }

    fn halves(&self, pts: &[DVec2]) -> (bool, bool) {
        let pole = &self.horizon.pole;
        let mut l = false;
        let mut r = false;
        for &p in pts {
            let s = pole.side(p);
            l |= s > 0.0;
            r |= s < 0.0;
        }
        if !l && !r {
            // On the splitting line: either half will do.
            l = true;
        }
        (l, r)
    }

    /// Adds a convex screen polygon (any orientation, 3 or more vertices) to
    /// the horizon.
    pub(crate) fn add_polygon(&mut self, poly: &[DVec2]) {
        self.add_polygon_keyed(poly, None);
    }

    /// As [`Sweep::add_polygon`], with the raw keys and radii of the vertices
    /// when the caller has them already.
    pub(crate) fn add_polygon_keyed(&mut self, poly: &[DVec2], raw_keys: Option<(&[f64], &[f64])>) {
        let pole = self.horizon.pole;
        self.given_keys.clear();
        self.given_radii.clear();
        match pole {
            Pole::Infinite { .. } => {
                if let Some((k, r)) = raw_keys {
                    self.given_keys.extend_from_slice(k);
                    self.given_radii.extend_from_slice(r);
                }
                self.add_half(poly, Half::Left)
            }
            Pole::Finite { .. } => {
                let (l, r) = self.halves(poly);
                if l && r {
                    let mut buf = std::mem::take(&mut self.half_buf);
                    clip_half(&pole, poly, Half::Left, &mut buf);
                    let left = buf.clone();
                    clip_half(&pole, poly, Half::Right, &mut buf);
                    self.add_half(&left, Half::Left);
                    self.given_keys.clear();
                    self.given_radii.clear();
                    self.add_half(&buf, Half::Right);
                    self.half_buf = buf;
                } else {
                    if let Some((k, r)) = raw_keys {
                        self.given_keys.extend_from_slice(k);
                        self.given_radii.extend_from_slice(r);
                    }
                    self.add_half(poly, if l { Half::Left } else { Half::Right });
                }
            }
        }
    }

    /// Adds a convex screen triangle or quadrilateral (vertices in order)
    /// whose vertices all project, with their raw keys and radii. The common
    /// case, a polygon on one side of the splitting line and away from the
    /// pole, is built here without the general polygon path's buffers: its
    /// boundary splits at the smallest and largest key into the far and the
    /// near chain. Anything else goes to [`Sweep::add_polygon_keyed`], which
    /// gives the same chains.
    #[inline(never)]
    pub(crate) fn add_convex<const N: usize>(&mut self, p: &[DVec2; N], raw: &[f64; N], radii: &[f64; N]) {
        const { assert!(N == 3 || N == 4) };
        let n = N;
        let pole = self.horizon.pole;
        let half = match pole {
            Pole::Infinite { .. } => Half::Left,
            Pole::Finite { c, .. } => {
                let (mut l, mut r) = (false, false);
                let (mut lo, mut hi) = (p[0], p[0]);
                for &v in p {
                    let s = pole.side(v);
                    l |= s > 0.0;
                    r |= s < 0.0;
                    lo = lo.min(v);
                    hi = hi.max(v);
                }
                // Near the pole, or across the splitting line: the general
                // path (clipping, pole pieces) decides.
                let margin = (hi - lo).max_element() + 1.0;
                let near = !(c.x < lo.x - margin || c.y < lo.y - margin || c.x > hi.x + margin || c.y > hi.y + margin);
                if (l && r) || near {
                    self.add_polygon_keyed(p, Some((raw.as_slice(), radii.as_slice())));
                    return;
                }
                if r {
                    Half::Right
                } else {
                    Half::Left
                }
            }
        };
        if self.skips(half) {
            return;
        }
        let mut k = [0.0; 4];
        for i in 0..n {
            k[i] = pole.clamp_key(raw[i], half);
        }
        // First index of the smallest and of the largest key, as the general
        // path picks them.
        let (mut imin, mut imax) = (0, 0);
        for i in 1..n {
            if k[i] < k[imin] {
                imin = i;
            }
            if k[i] > k[imax] {
                imax = i;
            }
        }
        if !(k[imax] > k[imin]) {
            return;
        }
        let mut edge = [(0.0, 0.0); 4];
        let (mut rmin, mut rmax) = (f64::INFINITY, f64::NEG_INFINITY);
        for i in 0..n {
            let j = (i + 1) % n;
            edge[i] = pole.radius_range_known(p[i], p[j], radii[i], radii[j]);
            rmin = rmin.min(edge[i].0);
            rmax = rmax.max(edge[i].1);
        }
        // The two boundary chains from imin to imax (pieces along one ray
        // cover no keys and are left out, as the general path does), and the
        // first vertex strictly inside each.
        // Both chains in one array: the first from 0, the second after it.
        let blank = Piece { k0: 0.0, k1: 0.0, a: DVec2::ZERO, b: DVec2::ZERO, pole: false, rlo: 0.0, rhi: 0.0 };
        let mut pieces = [blank; N];
        let mut len = [0usize; 2];
        let mut mid = [None; 2];
        let mut at = 0;
        for (c, step) in [1, n - 1].into_iter().enumerate() {
            let mut i = imin;
            while i != imax {
                let j = (i + step) % n;
                if j != imax && mid[c].is_none() {
                    mid[c] = Some(j);
                }
                if k[j] > k[i] {
                    let (rlo, rhi) = edge[if step == 1 { i } else { j }];
                    if clearly_not_radial(&pole, p[i], p[j], k[j] - k[i], rlo, (raw[i], raw[j], radii[i], radii[j]))
                        || !radial(&pole, p[i], p[j])
                    {
                        pieces[at] = Piece { k0: k[i], k1: k[j], a: p[i], b: p[j], pole: false, rlo, rhi };
                        at += 1;
                        len[c] += 1;
                    }
                }
                i = j;
            }
        }
        let (a, b) = pieces[..at].split_at(len[0]);
        // Keys grow counter-clockwise about the pole (or, with parallel
        // rays, to the left of their direction) and radii outwards, so on a
        // cell on one side of the splitting line, away from the pole, the
        // chain running counter-clockwise from the smallest key is the far
        // one. Cells too thin to have a clear orientation compare radii.
        let mut area2 = 0.0;
        for i in 1..n - 1 {
            area2 += cross(p[i] - p[0], p[i + 1] - p[0]);
        }
        let size2 = (0..n).map(|i| (p[i] - p[0]).length_squared()).fold(0.0, f64::max);
        let a_far = if area2.abs() > ORIENTED * size2 {
            area2 > 0.0
        } else {
            match (mid[0], mid[1]) {
                (Some(m), _) => farther_at(&pole, p[m], b),
                (None, Some(m)) => !farther_at(&pole, p[m], a),
                (None, None) => true,
            }
        };
        let (far, near) = if a_far { (a, b) } else { (b, a) };
        if far.is_empty() || near.is_empty() {
            return;
        }
        self.horizon.add(far, near, rmin, rmax);
    }

    fn contains_pole(&self, poly: &[DVec2]) -> bool {
        let Pole::Finite { c, .. } = self.horizon.pole else { return false };
        // Most facets lie far from the pole: a box test settles them.
        let (mut lo, mut hi) = (poly[0], poly[0]);
        for &p in &poly[1..] {
            lo = lo.min(p);
            hi = hi.max(p);
        }
        let margin = (hi - lo).max_element() + 1.0;
        if c.x < lo.x - margin || c.y < lo.y - margin || c.x > hi.x + margin || c.y > hi.y + margin {
            return false;
        }
        let n = poly.len();
        let (mut pos, mut neg) = (false, false);
        for i in 0..n {
            let a = poly[i];
            let e = poly[(i + 1) % n] - a;
            let x = cross(e, c - a);
            let tol = POLE_CONTAINS * e.length() * (e.length() + (c - a).length());
            pos |= x > tol;
            neg |= x < -tol;
        }
        !(pos && neg)
    }

    fn add_half(&mut self, poly: &[DVec2], half: Half) {
        let n = poly.len();
        if n < 3 || self.skips(half) {
            return;
        }
        let pole = self.horizon.pole;
        let with_pole = self.contains_pole(poly);
        self.keys.clear();
        self.radii.clear();
        let mut at_pole = [false; 8];
        let mut any_pole_vertex = false;
        let given = self.given_keys.len() == n && self.given_radii.len() == n;
        for (i, &p) in poly.iter().enumerate() {
            let r = if given { self.given_radii[i] } else { pole.radius(p) };
            if let Pole::Finite { c, .. } = pole {
                if r <= POLE_CONTAINS * (1.0 + c.length()) {
                    if i < 8 {
                        at_pole[i] = true;
                    }
                    any_pole_vertex = true;
                }
            }
            let raw = if given { self.given_keys[i] } else { pole.raw_key(p) };
            self.keys.push(pole.clamp_key(raw, half));
            self.radii.push(r);
        }
        let is_pole_v = |i: usize| any_pole_vertex && i < 8 && at_pole[i];
        let (mut imin, mut imax) = (usize::MAX, usize::MAX);
        for i in 0..n {
            if is_pole_v(i) {
                continue;
            }
            if imin == usize::MAX || self.keys[i] < self.keys[imin] {
                imin = i;
            }
            if imax == usize::MAX || self.keys[i] > self.keys[imax] {
                imax = i;
            }
        }
        if imin == usize::MAX || !(self.keys[imax] > self.keys[imin]) {
            return;
        }
        // The two boundary chains from imin to imax.
        self.far.clear();
        self.near.clear();
        let mut chain_a = std::mem::take(&mut self.chain_a);
        let mut chain_b = std::mem::take(&mut self.chain_b);
        chain_a.clear();
        chain_b.clear();
        let mut mid_a: Option<DVec2> = None;
        let mut mid_b: Option<DVec2> = None;
        for (step, chain, mid) in [(1usize, &mut chain_a, &mut mid_a), (n - 1, &mut chain_b, &mut mid_b)] {
            let mut i = imin;
            while i != imax {
                let j = (i + step) % n;
                if j != imax && mid.is_none() && !is_pole_v(j) {
                    *mid = Some(poly[j]);
                }
                let (ki, kj) = (self.keys[i], self.keys[j]);
                let through_pole = with_pole && self.edge_through_pole(poly[i], poly[j]);
                // A piece along a single ray (an edge in a vertical plane
                // through the eye) covers no keys: it would only add an
                // ill-conditioned sliver, and its ends are on the
                // neighbouring pieces anyway.
                if kj > ki && !is_pole_v(i) && !is_pole_v(j) && !through_pole && !radial(&pole, poly[i], poly[j]) {
                    chain.push(Piece::with_radii(&pole, ki, kj, poly[i], poly[j], self.radii[i], self.radii[j]));
                }
                i = j;
            }
        }
        let (kmin, kmax) = (self.keys[imin], self.keys[imax]);
        if with_pole {
            // One chain runs through the pole; the other is the far one.
            self.far.extend(chain_a.iter().chain(chain_b.iter()).copied());
            self.far.sort_by(|x, y| x.k0.total_cmp(&y.k0));
            self.near.push(Piece::new(&pole, kmin, kmax, poly[imin], poly[imax], true));
        } else {
            // Which chain is farther: compare on the ray through an inner
            // vertex of one chain.
            let a_far = match (mid_a, mid_b) {
                (Some(m), _) => farther_at(&pole, m, &chain_b),
                (None, Some(m)) => !farther_at(&pole, m, &chain_a),
                (None, None) => true,
            };
            let (f, nr) = if a_far { (&chain_a, &chain_b) } else { (&chain_b, &chain_a) };
            self.far.extend_from_slice(f);
            self.near.extend_from_slice(nr);
        }
        self.chain_a = chain_a;
        self.chain_b = chain_b;
        if self.far.is_empty() || self.near.is_empty() {
            return;
        }
        let far = std::mem::take(&mut self.far);
        let near = std::mem::take(&mut self.near);
        let (mut rmin, mut rmax) = (f64::INFINITY, f64::NEG_INFINITY);
        if with_pole {
            rmin = 0.0;
        }
        for i in 0..n {
            let j = (i + 1) % n;
            let (lo, hi) = pole.radius_range_known(poly[i], poly[j], self.radii[i], self.radii[j]);
            rmin = rmin.min(lo);
            rmax = rmax.max(hi);
        }
        self.horizon.add(&far, &near, rmin, rmax);
        self.far = far;
        self.near = near;
    }

    fn edge_through_pole(&self, a: DVec2, b: DVec2) -> bool {
        let Pole::Finite { c, .. } = self.horizon.pole else { return false };
        let e = b - a;
        cross(e, c - a).abs() <= POLE_CONTAINS * e.length() * (e.length() + (c - a).length()) + 1e-300
    }

    /// Visible parameter intervals of the screen segment `p`-`q`, appended to
    /// `visible` in ascending order; `raw` holds the raw keys and the radii
    /// of the ends when the caller knows them.
    pub(crate) fn visible_keyed(&mut self, p: DVec2, q: DVec2, raw: Option<((f64, f64), (f64, f64))>, visible: &mut Vec<(f64, f64)>) {
        let mut hidden = std::mem::take(&mut self.hidden);
        hidden.clear();
        self.hidden_keyed(p, q, raw, &mut hidden);
        complement(&mut hidden, visible);
        self.hidden = hidden;
    }

    /// The hidden parameter intervals of the screen segment `p`-`q`, appended
    /// to `hidden` unsorted; `raw` as in [`Sweep::visible_keyed`].
    pub(crate) fn hidden_keyed(&mut self, p: DVec2, q: DVec2, raw: Option<((f64, f64), (f64, f64))>, hidden: &mut Vec<(f64, f64)>) {
        let pole = self.horizon.pole;
        match pole {
            Pole::Infinite { .. } => self.hidden_part(p, q, 0.0, 1.0, Half::Left, raw, hidden),
            Pole::Finite { c, .. } => {
                let (sp, sq) = (pole.side(p), pole.side(q));
                if (sp > 0.0 && sq > 0.0) || (sp < 0.0 && sq < 0.0) {
                    // Strictly on one side of the splitting line, which holds
                    // the pole: the common case, with nothing to split.
                    let half = if sp > 0.0 { Half::Left } else { Half::Right };
                    self.hidden_part(p, q, 0.0, 1.0, half, raw, hidden);
                } else if (sp > 0.0 && sq < 0.0) || (sp < 0.0 && sq > 0.0) {
                    let f = sp / (sp - sq);
                    let x = p + (q - p) * f;
                    let hp = if sp > 0.0 { Half::Left } else { Half::Right };
                    let hq = if sq > 0.0 { Half::Left } else { Half::Right };
                    self.hidden_part(p, x, 0.0, f, hp, None, hidden);
                    self.hidden_part(x, q, f, 1.0, hq, None, hidden);
                } else {
                    let half = if sp > 0.0 || sq > 0.0 {
                        Half::Left
                    } else if sp < 0.0 || sq < 0.0 {
                        Half::Right
                    } else {
                        Half::Left
                    };
                    // A radial segment through the pole lies on two opposite
                    // rays: split it there.
                    let e = q - p;
                    let through = {
                        let x = cross(e, c - p);
                        let f = (c - p).dot(e) / e.length_squared().max(f64::MIN_POSITIVE);
                        x.abs() <= POLE_CONTAINS * e.length() * (e.length() + (c - p).length()) && f > 0.0 && f < 1.0
                    };
                    if through {
                        let f = (c - p).dot(e) / e.length_squared();
                        self.hidden_part(p, c, 0.0, f, half, None, hidden);
                        self.hidden_part(c, q, f, 1.0, half, None, hidden);
                    } else {
                        self.hidden_part(p, q, 0.0, 1.0, half, raw, hidden);
                    }
                }
            }
        }
    }

    /// As [`Sweep::visible_keyed`] for a segment whose ends' raw keys and
    /// radii are known (a grid edge), except that a segment wholly visible,
    /// the common case, appends nothing and returns true.
    pub(crate) fn visible_known(&mut self, p: DVec2, q: DVec2, keys: (f64, f64), radii: (f64, f64), visible: &mut Vec<(f64, f64)>) -> bool {
        let mut hidden = std::mem::take(&mut self.hidden);
        hidden.clear();
        self.hidden_known(p, q, keys, radii, &mut hidden);
        let whole = hidden.is_empty();
        if !whole {
            complement(&mut hidden, visible);
        }
        self.hidden = hidden;
        whole
    }

    /// As [`Sweep::hidden_keyed`] for a segment whose ends' raw keys and
    /// radii are known.
    pub(crate) fn hidden_known(&mut self, p: DVec2, q: DVec2, keys: (f64, f64), radii: (f64, f64), hidden: &mut Vec<(f64, f64)>) {
        let half = match self.horizon.pole {
            Pole::Infinite { .. } => Half::Left,
            Pole::Finite { c, w } => {
                let (sp, sq) = (cross(w, p - c), cross(w, q - c));
                if sp > 0.0 && sq > 0.0 {
                    Half::Left
                } else if sp < 0.0 && sq < 0.0 {
                    Half::Right
                } else {
                    // Split by the line through the pole: the general path.
                    return self.hidden_keyed(p, q, Some((keys, radii)), hidden);
                }
            }
        };
        if self.skips(half) {
            return;
        }
        let pole = self.horizon.pole;
        let kp = pole.clamp_key(keys.0, half);
        let kq = pole.clamp_key(keys.1, half);
        let seg = if kp <= kq {
            KSeg { p, q, kp, kq, tp: 0.0, tq: 1.0, rp: radii.0, rq: radii.1 }
        } else {
            KSeg { p: q, q: p, kp: kq, kq: kp, tp: 1.0, tq: 0.0, rp: radii.1, rq: radii.0 }
        };
        self.horizon.hidden(&seg, hidden);
    }

    /// Appends the hidden parameter intervals of the part `p`-`q` (parameters
    /// `tp`, `tq`) of a tested segment lying in `half`; `raw` as in
    /// [`Sweep::visible_keyed`], for `p` and `q` themselves.
    #[inline]
    #[allow(clippy::too_many_arguments)]
    fn hidden_part(
        &mut self,
        p: DVec2,
        q: DVec2,
        tp: f64,
        tq: f64,
        half: Half,
        raw: Option<((f64, f64), (f64, f64))>,
        hidden: &mut Vec<(f64, f64)>,
    ) {
        if !(tq > tp) || self.skips(half) {
            return;
        }
        let pole = self.horizon.pole;
        let ((ka, kb), (ra, rb)) = raw.unwrap_or_else(|| ((pole.raw_key(p), pole.raw_key(q)), (pole.radius(p), pole.radius(q))));
        let kp = pole.clamp_key(ka, half);
        let kq = pole.clamp_key(kb, half);
        let seg = if kp <= kq {
            KSeg { p, q, kp, kq, tp, tq, rp: ra, rq: rb }
        } else {
            KSeg { p: q, q: p, kp: kq, kq: kp, tp: tq, tq: tp, rp: rb, rq: ra }
        };
        self.horizon.hidden(&seg, hidden);
    }
}

/// Appends to `visible` the visible parameter intervals of the screen
/// segment `p`-`q` against the picture `sweeps` hold between them (one
/// sweep of both halves, or one per half).
pub(crate) fn visible_among(sweeps: &mut [Sweep], p: DVec2, q: DVec2, visible: &mut Vec<(f64, f64)>) {
    let mut hidden = Vec::new();
    for sweep in sweeps {
        sweep.hidden_keyed(p, q, None, &mut hidden);
    }
    complement(&mut hidden, visible);
}

/// Appends to `visible` the parts of `[0, 1]` outside the intervals of
/// `hidden` (which it sorts), in ascending order.
pub(crate) fn complement(hidden: &mut [(f64, f64)], visible: &mut Vec<(f64, f64)>) {
    if hidden.is_empty() {
        visible.push((0.0, 1.0));
        return;
    }
    if hidden.len() > 1 {
        hidden.sort_by(|a, b| a.0.total_cmp(&b.0));
    }
    let mut t = 0.0;
    for &(h0, h1) in hidden.iter() {
        // Hidden intervals found on neighbouring horizon pieces meet on a ray
        // computed twice; a visible gap of round-off between them (or at an
        // end) is not a piece to draw.
        if h0 > t + SLIVER {
            visible.push((t, h0));
        }
        t = t.max(h1);
    }
    if t < 1.0 - SLIVER {
        visible.push((t, 1.0));
    }
}

/// True when the segment `a`-`b` lies along one ray from the pole (see
/// [`KSeg::is_radial`]).
fn radial(pole: &Pole, a: DVec2, b: DVec2) -> bool {
    KSeg { p: a, q: b, kp: 0.0, kq: 0.0, tp: 0.0, tq: 1.0, rp: pole.radius(a), rq: pole.radius(b) }.is_radial(pole)
}

/// True when the segment `a`-`b`, whose key grows by `dk > 0` along it and
/// whose radius is at least `rlo`, is certainly not radial, without the
/// exact test of [`radial`]; `ends` are the raw keys and radii of `a` and
/// `b`. Only for segments of a polygon well away from a finite pole (they
/// subtend less than a right angle there).
///
/// Finite pole: the exact test calls a segment radial when
/// `min(ra, rb) |sin t| <= RADIAL_SIN |b - a|`, `t` the angle it subtends. A
/// pseudo-angle grows at most as fast as the angle, so `|t| >= dk` (less the
/// keys' round-off), and `|sin t| >= 0.6 |t|` below a right angle; half of
/// that is claimed, leaving a factor two for the exact test's own round-off.
/// Infinite pole: `dk` is the segment's extent across the rays itself.
#[inline]
fn clearly_not_radial(pole: &Pole, a: DVec2, b: DVec2, dk: f64, rlo: f64, ends: (f64, f64, f64, f64)) -> bool {
    let len2 = (b - a).length_squared();
    let (ka, kb, ra, rb) = ends;
    let across = match pole {
        Pole::Finite { .. } => 0.3 * rlo * (dk - KEY_ROUNDOFF),
        Pole::Infinite { .. } => 0.5 * (dk - KEY_ROUNDOFF * (ka.abs() + kb.abs() + ra.abs() + rb.abs())),
    };
    across > 0.0 && across * across > RADIAL_SIN * RADIAL_SIN * len2
}

/// True when the chain holding `m` (a vertex strictly inside its key range) is
/// farther from the pole than `other` on the ray through `m`.
fn farther_at(pole: &Pole, m: DVec2, other: &[Piece]) -> bool {
    let own = pole.own_s();
    // The piece of `other` whose key range holds the ray (its raw key: the
    // pieces' keys may be clamped).
    let at = if other.len() == 1 {
        other.first()
    } else {
        let k = pole.raw_key(m);
        other.iter().find(|p| k >= p.k0.min(p.k1) && k <= p.k0.max(p.k1)).or(other.first())
    };
    at.is_none_or(|p| own > p.s_at(pole, m))
}
