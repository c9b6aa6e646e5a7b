//! Overlap removal: no place of one pen's drawing is drawn twice.
//!
//! Hidden-line output draws the same place more than once wherever distinct
//! lines project onto each other: the grid lines of a flat part of a surface
//! seen exactly edge-on all lie on the horizon, a T-junction's long edge lies
//! over the two short ones, a face written twice in a mesh draws its outline
//! twice; and 2-D inputs (SVG, HP-GL) often overlap themselves. A pen drawn
//! twice over one line wets the paper and tears it, and takes twice the time.
//!
//! [`dedupe`] removes, from each segment, the parts that lie within the
//! tolerance of a nearly parallel segment drawn before it (longest first), so
//! that what remains draws every place once. It runs before chaining
//! ([`crate::optimize`]) and serves every input.
//!
//! Promises (**what later stages may rely on**):
//! - **Nothing is added and nothing moves by more than the tolerance**: the
//!   output is a subset of the input's segments, cut where an overlap starts
//!   or ends; a cut at the end of the covering segment is put on that
//!   segment's end point (at most the tolerance away), so the pieces join
//!   exactly.
//! - **Every removed point lies within the tolerance of a kept, nearly
//!   parallel segment**: the drawing seen with a pen of any width at least
//!   twice the tolerance is unchanged.
//! - **Segments that only touch or cross are never cut**: an overlap counts
//!   when the two run within the tolerance of each other for longer than the
//!   tolerance, at an angle below [`MAX_ANGLE`].
//! - Deterministic, independent of the input order of equal-length segments
//!   (ties are broken by input position).
//!
//! How: every segment is put in a uniform grid keyed by cell and direction
//! (an angle bucket), so a segment meets only nearby, nearly parallel
//! candidates. A parallel first pass finds the segments that overlap any
//! other (usually few: engine output mostly meets only end to end); only
//! those go through the sequential pass that keeps the longest and cuts the
//! others against what is already kept.

use crate::drawing::Polyline;
use glam::DVec2;
use rayon::prelude::*;

/// Largest angle (radians, about 1.1 degrees) between two segments for one
/// to count as drawn over the other. Pieces of one line (engine output,
/// T-junctions, duplicate faces, the horizon seen edge-on) are parallel to
/// rounding; a wider angle would start cutting lines that merely cross at a
/// shallow angle into pieces (more pen lifts, nothing gained).
pub const MAX_ANGLE: f64 = 0.02;

/// Direction buckets over the half turn (each about 2.8 degrees): a segment
/// is compared only with segments in its own bucket, and in the one beside
/// it when its direction is within [`MAX_ANGLE`] of their border.
const ANGLE_BUCKETS: usize = 64;

/// A cut is put on the covering segment's end point only when that point
/// lies this close (mm) to the cut segment's line: then the pieces join
/// exactly and the cut piece keeps its direction.
const ANCHOR_MM: f64 = 1e-6;

/// What [`dedupe`] did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Deduped {
    /// The drawing with no place drawn twice.
    pub polylines: Vec<Polyline>,
    /// Length removed (mm): drawn over a kept segment within the tolerance.
    pub removed_mm: f64,
}

/// One straight segment of the input.
#[derive(Clone, Copy, Debug)]
struct Seg {
    a: DVec2,
    b: DVec2,
    /// Index of the polyline it came from.
    poly: u32,
    /// Its position among all segments of the input.
    orig: u32,
}

/// Removes from `polylines` every part that lies within `tol` mm of a nearly
/// parallel (below [`MAX_ANGLE`]) segment that is kept, longest segments kept
/// first; see the module doc. Polylines that overlap nothing come back as
/// they are; the pieces of the others take their place, in input order.
#[must_use]
pub fn dedupe(polylines: &[Polyline], tol: f64) -> Deduped {
    let mut segs: Vec<Seg> = Vec::new();
    for (pi, p) in polylines.iter().enumerate() {
        for w in p.points.windows(2) {
            segs.push(Seg { a: w[0], b: w[1], poly: pi as u32, orig: segs.len() as u32 });
        }
    }
    let tol = if tol > 0.0 { tol } else { 0.0 };
    let Some(mut grid) = Grid::layout(&segs, tol) else {
        return Deduped { polylines: polylines.to_vec(), removed_mm: 0.0 };
    };
    // Segments sorted by the cell of their midpoint: a segment's candidates
    // are then near it in memory too (a million segments in input order
    // would make every candidate a cache miss).
    segs.par_sort_by_cached_key(|s| {
        let m = s.a.lerp(s.b, 0.5);
        let key = if m.is_finite() { grid.cell_index(m) } else { usize::MAX };
        (key, s.orig)
    });
    grid.fill(&segs);
    // Pass 1, parallel: which segments overlap any other at all. Most
    // candidates are turned away by direction, offset or extent before the
    // exact test.
    let dirs: Vec<(DVec2, f64)> = segs
        .par_iter()
        .map(|s| {
            let len = s.a.distance(s.b);
            ((s.b - s.a) / len, len)
        })
        .collect();
    let sin_max = MAX_ANGLE.sin();
    let involved: Vec<u32> = (0..segs.len() as u32)
        .into_par_iter()
        .filter(|&i| {
            let s = &segs[i as usize];
            let (u, len) = dirs[i as usize];
            let mut hit = false;
            grid.candidates(s, |j| {
                if j == i {
                    return false;
                }
                let t = &segs[j as usize];
                if u.perp_dot(dirs[j as usize].0).abs() > sin_max + 1e-3 {
                    return false;
                }
                let (oa, ob) = (u.perp_dot(t.a - s.a), u.perp_dot(t.b - s.a));
                if (oa > tol && ob > tol) || (oa < -tol && ob < -tol) {
                    return false;
                }
                let (ta, tb) = (u.dot(t.a - s.a), u.dot(t.b - s.a));
                if ta.max(tb) <= tol || ta.min(tb) >= len - tol {
                    return false;
                }
                hit = cover(s.a, s.b, t.a, t.b, tol).is_some();
                hit
            });
            hit
        })
        .collect();
    if involved.is_empty() {
        return Deduped { polylines: polylines.to_vec(), removed_mm: 0.0 };
    }
    // Pass 2, sequential over the involved ones, longest first: each keeps
    // what the ones before it do not already draw.
    let mut order = involved.clone();
    order.sort_by(|&i, &j| {
        let (si, sj) = (&segs[i as usize], &segs[j as usize]);
        sj.a.distance_squared(sj.b).total_cmp(&si.a.distance_squared(si.b)).then(i.cmp(&j))
    });
    // rank[i]: position in `order` (u32::MAX: not involved).
    let mut rank = vec![u32::MAX; segs.len()];
    for (r, &i) in order.iter().enumerate() {
        rank[i as usize] = r as u32;
    }
    let mut kept: Vec<Vec<(DVec2, DVec2)>> = vec![Vec::new(); order.len()];
    let mut seen = vec![u32::MAX; segs.len()];
    let mut removed = 0.0;
    let mut covers: Vec<Cover> = Vec::new();
    for (r, &i) in order.iter().enumerate() {
        let s = segs[i as usize];
        covers.clear();
        grid.candidates(&s, |j| {
            let rj = rank[j as usize];
            if rj < r as u32 && seen[j as usize] != i {
                seen[j as usize] = i;
                for &(p, q) in &kept[rj as usize] {
                    covers.extend(cover(s.a, s.b, p, q, tol));
                }
            }
            false
        });
        let pieces = uncovered(s.a, s.b, &mut covers, tol);
        let length = s.a.distance(s.b);
        removed += length - pieces.iter().map(|(p, q)| p.distance(*q)).sum::<f64>();
        kept[r] = pieces;
    }
    // Output in input order: untouched polylines whole, a touched one as its
    // runs of untouched segments and the kept pieces of its involved ones.
    let mut touched = vec![false; polylines.len()];
    for &i in &involved {
        touched[segs[i as usize].poly as usize] = true;
    }
    // Back to input order: each segment's rank, and the segments.
    let mut rank_of = vec![u32::MAX; segs.len()];
    for (l, s) in segs.iter().enumerate() {
        rank_of[s.orig as usize] = rank[l];
    }
    segs.sort_unstable_by_key(|s| s.orig);
    let mut out: Vec<Polyline> = Vec::with_capacity(polylines.len() + involved.len());
    let mut first = 0;
    for (pi, p) in polylines.iter().enumerate() {
        let n = p.points.len().saturating_sub(1);
        if !touched[pi] {
            out.push(p.clone());
            first += n;
            continue;
        }
        let mut run: Vec<DVec2> = Vec::new();
        for (i, s) in segs[first..first + n].iter().enumerate() {
            match rank_of[first + i] {
                u32::MAX => {
                    if run.last() != Some(&s.a) {
                        flush(&mut run, &mut out);
                        run.push(s.a);
                    }
                    run.push(s.b);
                }
                r => {
                    flush(&mut run, &mut out);
                    out.extend(kept[r as usize].iter().map(|&(p, q)| Polyline::new(vec![p, q])));
                }
            }
        }
        flush(&mut run, &mut out);
        first += n;
    }
    Deduped { polylines: out, removed_mm: removed }
}

/// Moves a run of at least two points to `out` as a polyline.
fn flush(run: &mut Vec<DVec2>, out: &mut Vec<Polyline>) {
    if run.len() >= 2 {
        out.push(Polyline::new(std::mem::take(run)));
    }
    run.clear();
}

/// The part of segment `a`-`b` that segment `p`-`q` runs over: the parameter
/// range (distance from `a`) where `p`-`q` lies within `tol` of the line
/// `a`-`b`, inside `a`-`b`, when the two are nearly parallel and the range is
/// longer than `tol`. Each end carries the point a cut there should take.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Cover {
    t0: f64,
    t1: f64,
    at0: DVec2,
    at1: DVec2,
}

fn cover(a: DVec2, b: DVec2, p: DVec2, q: DVec2, tol: f64) -> Option<Cover> {
    let d = b - a;
    let len = d.length();
    let e = q - p;
    let le = e.length();
    if !(len > tol) || !(le > tol) {
        return None;
    }
    let u = d / len;
    // Nearly parallel (the slack lets through pieces whose ends were moved
    // onto a covering segment's end, at most `ANCHOR_MM` off their line).
    if u.perp_dot(e).abs() > MAX_ANGLE.sin() * le + 2.0 * ANCHOR_MM {
        return None;
    }
    let (mut p, mut q) = (p, q);
    if u.dot(e) < 0.0 {
        std::mem::swap(&mut p, &mut q);
    }
    let (tp, tq) = (u.dot(p - a), u.dot(q - a));
    let (op, oq) = (u.perp_dot(p - a), u.perp_dot(q - a));
    // Where along `a`-`b` the offset of `p`-`q` (linear in t) is within tol.
    let (mut t0, mut t1) = (tp, tq);
    if op != oq {
        let at = |o: f64| tp + (o - op) * (tq - tp) / (oq - op);
        let (x, y) = (at(tol), at(-tol));
        t0 = t0.max(x.min(y));
        t1 = t1.min(x.max(y));
    } else if op.abs() > tol {
        return None;
    }
    let (c0, c1) = (t0.max(0.0), t1.min(len));
    if !(c1 - c0 > tol) {
        return None;
    }
    // A cut where the cover ends at `p` (or `q`), when that point is on the
    // line to rounding (pieces of one line: engine output), goes onto it, so
    // the pieces meet exactly; otherwise it stays on `a`-`b`, within the
    // tolerance of the cover's end, where snapping joins them.
    let at0 = if c0 == tp && op.abs() <= ANCHOR_MM { p } else { a + u * c0 };
    let at1 = if c1 == tq && oq.abs() <= ANCHOR_MM { q } else { a + u * c1 };
    Some(Cover { t0: c0, t1: c1, at0, at1 })
}

/// The pieces of `a`-`b` outside every cover, each longer than `tol`.
fn uncovered(a: DVec2, b: DVec2, covers: &mut [Cover], tol: f64) -> Vec<(DVec2, DVec2)> {
    let len = a.distance(b);
    if covers.is_empty() {
        return vec![(a, b)];
    }
    covers.sort_by(|x, y| x.t0.total_cmp(&y.t0));
    let mut out = Vec::new();
    let (mut t, mut from) = (0.0, a);
    for c in covers.iter() {
        if c.t0 > t && c.t0 - t > tol {
            out.push((from, c.at0));
        }
        if c.t1 > t {
            t = c.t1;
            from = c.at1;
        }
    }
    if len - t > tol {
        out.push((from, b));
    }
    out
}

/// Segments bucketed by grid cell and direction; every segment is in each
/// cell its tolerance-wide strip touches.
struct Grid {
    lo: DVec2,
    cell: f64,
    nx: usize,
    ny: usize,
    tol: f64,
    /// The segments of key `k` (cell times [`ANGLE_BUCKETS`] plus bucket)
    /// are `items[start[k]..start[k + 1]]`, in input order.
    start: Vec<u32>,
    items: Vec<u32>,
}

impl Grid {
    /// An empty grid sized for `segs`, or `None` when there is nothing to
    /// compare (fewer than two segments with finite, distinct ends).
    fn layout(segs: &[Seg], tol: f64) -> Option<Grid> {
        let (mut lo, mut hi) = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
        let (mut count, mut total) = (0usize, 0.0);
        for s in segs.iter().filter(|s| drawable(s)) {
            lo = lo.min(s.a.min(s.b));
            hi = hi.max(s.a.max(s.b));
            count += 1;
            total += s.a.distance(s.b);
        }
        if count < 2 {
            return None;
        }
        let span = (hi - lo).max(DVec2::splat(tol.max(1e-9)));
        // Cells about a segment long (a segment touches a few), no finer than
        // the points' density needs, and a bounded number of keys.
        let mut cell = (total / count as f64).max((span.x * span.y / count as f64).sqrt()).max(4.0 * tol);
        if !(cell.is_finite() && cell > 0.0) {
            return None;
        }
        while (span.x / cell + 1.0) * (span.y / cell + 1.0) * ANGLE_BUCKETS as f64 > 8.0 * count as f64 + 1024.0 {
            cell *= 2.0;
        }
        let (nx, ny) = ((span.x / cell) as usize + 1, (span.y / cell) as usize + 1);
        Some(Grid { lo, cell, nx, ny, tol, start: Vec::new(), items: Vec::new() })
    }

    /// Puts `segs` (indices into it) in the grid.
    fn fill(&mut self, segs: &[Seg]) {
        let grid = &*self;
        let keyed: Vec<(u32, u32)> = segs
            .par_iter()
            .enumerate()
            .filter(|(_, s)| drawable(s))
            .flat_map_iter(|(i, s)| {
                let bucket = bucket(s.a, s.b).0;
                let mut keys: smallvec::SmallVec<[u32; 8]> = smallvec::SmallVec::new();
                grid.cells(s, |c| keys.push((c * ANGLE_BUCKETS + bucket) as u32));
                keys.sort_unstable();
                keys.dedup();
                keys.into_iter().map(move |k| (k, i as u32))
            })
            .collect();
        // Counting sort by key (keys are dense and bounded).
        let keys = self.nx * self.ny * ANGLE_BUCKETS;
        let mut start = vec![0u32; keys + 1];
        for &(k, _) in &keyed {
            start[k as usize + 1] += 1;
        }
        for k in 0..keys {
            start[k + 1] += start[k];
        }
        let mut fill = start.clone();
        let mut items = vec![0u32; keyed.len()];
        for &(k, i) in &keyed {
            items[fill[k as usize] as usize] = i;
            fill[k as usize] += 1;
        }
        self.start = start;
        self.items = items;
    }

    /// Calls `f` with the index of every cell the strip of half-width `tol`
    /// around `s` may touch (a cell may come more than once).
    fn cells(&self, s: &Seg, mut f: impl FnMut(usize)) {
        let steps = (s.a.distance(s.b) / self.cell).ceil().max(1.0) as usize;
        let pad = DVec2::splat(self.tol);
        for k in 0..steps {
            let (p, q) = (s.a.lerp(s.b, k as f64 / steps as f64), s.a.lerp(s.b, (k + 1) as f64 / steps as f64));
            let (c0, c1) = (self.cell_of(p.min(q) - pad), self.cell_of(p.max(q) + pad));
            for y in c0.1..=c1.1 {
                for x in c0.0..=c1.0 {
                    f(y * self.nx + x);
                }
            }
        }
    }

    fn cell_index(&self, p: DVec2) -> usize {
        let (x, y) = self.cell_of(p);
        y * self.nx + x
    }

    fn cell_of(&self, p: DVec2) -> (usize, usize) {
        let c = (p - self.lo) / self.cell;
        ((c.x.max(0.0) as usize).min(self.nx - 1), (c.y.max(0.0) as usize).min(self.ny - 1))
    }

    /// Calls `f` with every segment near `s` whose direction may be within
    /// [`MAX_ANGLE`] of it (some more than once) until `f` returns true.
    fn candidates(&self, s: &Seg, mut f: impl FnMut(u32) -> bool) {
        if !drawable(s) {
            return;
        }
        let (b, side) = bucket(s.a, s.b);
        let mut done = false;
        self.cells(s, |c| {
            for nb in [Some(b), side] {
                let Some(nb) = nb else { continue };
                let k = c * ANGLE_BUCKETS + nb;
                for &j in &self.items[self.start[k] as usize..self.start[k + 1] as usize] {
                    if done {
                        return;
                    }
                    done = f(j);
                }
            }
        });
    }
}

/// A segment the grid holds: finite ends, not a point.
fn drawable(s: &Seg) -> bool {
    s.a.is_finite() && s.b.is_finite() && s.a != s.b
}

/// Direction bucket of a segment over the half turn (either way round is the
/// same direction), and the bucket beside it when the direction is within
/// [`MAX_ANGLE`] (and some slack) of their border.
fn bucket(a: DVec2, b: DVec2) -> (usize, Option<usize>) {
    let d = b - a;
    let width = std::f64::consts::PI / ANGLE_BUCKETS as f64;
    let x = d.y.atan2(d.x).rem_euclid(std::f64::consts::PI) / width;
    let k = (x as usize).min(ANGLE_BUCKETS - 1);
    // Below half a bucket (0.43), so at most one side is ever near.
    let near = (MAX_ANGLE + 1e-3) / width;
    let side = if x - k as f64 <= near {
        Some((k + ANGLE_BUCKETS - 1) % ANGLE_BUCKETS)
    } else if (k + 1) as f64 - x <= near {
        Some((k + 1) % ANGLE_BUCKETS)
    } else {
        None
    };
    (k, side)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn seg(a: (f64, f64), b: (f64, f64)) -> Polyline {
        Polyline::new(vec![DVec2::new(a.0, a.1), DVec2::new(b.0, b.1)])
    }

    fn length(p: &[Polyline]) -> f64 {
        p.iter().map(Polyline::length).sum()
    }

    #[test]
    fn a_line_drawn_ten_times_in_pieces_is_drawn_once() {
        // The horizon case: ten lines, each in pieces, on one line.
        let mut input = Vec::new();
        for k in 0..10 {
            let off = k as f64 * 0.7;
            input.push(seg((off, 5.0), (100.0 - off, 5.0)));
            input.push(seg((100.0 - off, 5.0), (120.0, 5.0 + 1e-9)));
        }
        let d = dedupe(&input, 0.01);
        assert!((length(&d.polylines) - 120.0).abs() < 0.02, "{}", length(&d.polylines));
        assert!((d.removed_mm - (length(&input) - 120.0)).abs() < 0.02);
    }

    #[test]
    fn a_t_junction_draws_the_long_edge_only() {
        let input =
            vec![seg((0.0, 0.0), (4.0, 0.0)), seg((4.0, 0.0), (10.0, 0.0)), seg((0.0, 0.0), (10.0, 0.0)), seg((4.0, 0.0), (4.0, 5.0))];
        let d = dedupe(&input, 0.01);
        assert!((length(&d.polylines) - 15.0).abs() < 1e-9);
        assert!((d.removed_mm - 10.0).abs() < 1e-9);
    }

    #[test]
    fn partial_overlap_is_cut_at_the_covering_end() {
        let input = vec![seg((0.0, 0.0), (10.0, 0.0)), seg((6.0, 0.004), (13.0, 0.004))];
        let d = dedupe(&input, 0.01);
        assert_eq!(d.polylines.len(), 2);
        // The shorter one keeps 10..13, starting on its own line within the
        // tolerance of the long one's end (snapping joins them).
        let piece = &d.polylines[1].points;
        assert_eq!(piece[0], DVec2::new(10.0, 0.004));
        assert_eq!(piece[1], DVec2::new(13.0, 0.004));
        assert!((d.removed_mm - 4.0).abs() < 1e-4);
    }

    #[test]
    fn pieces_of_one_line_meet_exactly() {
        let input = vec![seg((0.0, 0.0), (10.0, 0.0)), seg((6.0, 0.0), (13.0, 0.0))];
        let d = dedupe(&input, 0.01);
        assert_eq!(d.polylines[1].points, vec![DVec2::new(10.0, 0.0), DVec2::new(13.0, 0.0)]);
    }

    #[test]
    fn touching_crossing_and_distant_lines_are_left_alone() {
        let input = vec![
            seg((0.0, 0.0), (10.0, 0.0)),
            seg((10.0, 0.0), (20.0, 0.0)),  // end to end
            seg((5.0, -5.0), (5.0, 5.0)),   // crossing
            seg((0.0, 0.05), (10.0, 0.05)), // parallel, beyond the tolerance
            seg((0.0, 0.0), (10.0, 1.0)),   // shallow angle, from a shared end
            seg((3.0, 0.0), (3.0, 0.015)),  // a stub across, shorter than two tolerances
        ];
        let d = dedupe(&input, 0.01);
        assert_eq!(d.polylines, input);
        assert_eq!(d.removed_mm, 0.0);
        // Non-finite points pass through untouched.
        let broken =
            vec![Polyline::new(vec![DVec2::new(0.0, 0.0), DVec2::new(f64::NAN, 1.0), DVec2::new(0.0, 0.0)]), seg((0.0, 0.0), (1.0, 0.0))];
        let d = dedupe(&broken, 0.01);
        assert_eq!(d.polylines.len(), 2);
        assert!(d.polylines[0].points[1].x.is_nan());
        assert_eq!(d.removed_mm, 0.0);
    }

    #[test]
    fn a_polyline_over_itself_keeps_one_pass() {
        // There and back along the same line, then off to the side.
        let input = vec![Polyline::new(vec![DVec2::new(0.0, 0.0), DVec2::new(10.0, 0.0), DVec2::new(2.0, 0.0), DVec2::new(2.0, 3.0)])];
        let d = dedupe(&input, 0.01);
        assert!((length(&d.polylines) - 13.0).abs() < 1e-9, "{:?}", d.polylines);
        assert!((d.removed_mm - 8.0).abs() < 1e-9);
    }

    #[test]
    fn every_removed_point_is_near_a_kept_parallel_segment() {
        // Many overlapping pieces at random offsets within the tolerance.
        let mut input = Vec::new();
        let mut x = 0.37_f64;
        for _ in 0..200 {
            x = (x * 7919.0 + 0.123).fract();
            let a = x * 50.0;
            x = (x * 7919.0 + 0.123).fract();
            let l = 1.0 + x * 20.0;
            x = (x * 7919.0 + 0.123).fract();
            input.push(seg((a, 3.0 + (x - 0.5) * 0.008), (a + l, 3.0 + (x - 0.5) * 0.008)));
        }
        let d = dedupe(&input, 0.01);
        let kept: Vec<(DVec2, DVec2)> = d.polylines.iter().flat_map(|p| p.points.windows(2).map(|w| (w[0], w[1]))).collect();
        let near = |p: DVec2| {
            kept.iter().any(|&(a, b)| {
                let ab = b - a;
                let t = ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0);
                p.distance(a + ab * t) <= 0.02
            })
        };
        for s in &input {
            for k in 0..=20 {
                assert!(near(s.points[0].lerp(s.points[1], k as f64 / 20.0)));
            }
        }
        // The union of the input on the line, drawn about once.
        let lo = input.iter().map(|s| s.points[0].x).fold(f64::INFINITY, f64::min);
        let hi = input.iter().map(|s| s.points[1].x).fold(f64::NEG_INFINITY, f64::max);
        assert!(length(&d.polylines) <= (hi - lo) + 0.5, "{} vs {}", length(&d.polylines), hi - lo);
    }
}
