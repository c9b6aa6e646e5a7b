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
//! How: a parallel first pass finds the pairs of segments of which one runs
//! over the other (usually few: engine output mostly meets only end to end)
//! by a sweep over bands of nearly parallel, nearly collinear segments (see
//! `overlapping`), so the neighbouring grid lines of a surface are never
//! even compared. Only those segments go through the second pass, which
//! keeps the longest and cuts each of the others against what its partners
//! ranked before it keep; clusters of partners are independent and run in
//! parallel.

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

/// Removes from `polylines` every part that lies within `tol` mm of a nearly
/// parallel (below [`MAX_ANGLE`]) segment that is kept, longest segments kept
/// first; see the module doc. Polylines that overlap nothing come back as
/// they are; the pieces of the others take their place, in input order.
#[must_use]
pub fn dedupe(polylines: &[Polyline], tol: f64) -> Deduped {
    let tol = if tol > 0.0 { tol } else { 0.0 };
    // Every point end to end, polyline `p` from `first[p]`: segment `k` (a
    // point index) runs from `points[k]` to `points[k + 1]` when both are of
    // one polyline. No copy of the segments: on a surface's long polylines
    // they would be several times the drawing's size.
    let mut first = Vec::with_capacity(polylines.len() + 1);
    let mut points = Vec::with_capacity(polylines.iter().map(|p| p.points.len()).sum());
    for p in polylines {
        first.push(points.len());
        points.extend_from_slice(&p.points);
    }
    first.push(points.len());
    let buckets = directions(&points, &first);
    let pairs = overlapping(&points, &buckets, tol);
    if pairs.is_empty() {
        return Deduped { polylines: polylines.to_vec(), removed_mm: 0.0 };
    }
    // The involved segments (point indices) in rank order: longest first,
    // ties by position; rank[k]: position of segment k in `order`
    // (u32::MAX: not involved).
    let mut order: Vec<u32> = pairs.iter().flat_map(|&(i, j)| [i, j]).collect();
    order.par_sort_unstable();
    order.dedup();
    let length_squared = |i: u32| points[i as usize].distance_squared(points[i as usize + 1]);
    order.par_sort_by(|&i, &j| length_squared(j).total_cmp(&length_squared(i)).then(i.cmp(&j)));
    let mut rank = vec![u32::MAX; first[polylines.len()]];
    for (r, &i) in order.iter().enumerate() {
        rank[i as usize] = r as u32;
    }
    // Pass 2, over the involved ones, longest first: each keeps what the
    // ones before it do not already draw. Only its partners from pass 1
    // can cover a segment (a kept piece lies on its segment; only a cut end
    // anchored on another's end may be off it, by ANCHOR_MM), so each
    // segment looks at its earlier partners' kept pieces alone, and the
    // clusters of partners are independent: done in parallel, each in rank
    // order. (later rank, earlier rank) of every pair, sorted: the earlier
    // partners of rank r are `earlier[from[r]..from[r + 1]]`.
    let mut by_rank: Vec<(u32, u32)> = pairs
        .par_iter()
        .map(|&(i, j)| {
            let (ri, rj) = (rank[i as usize], rank[j as usize]);
            (ri.max(rj), ri.min(rj))
        })
        .collect();
    drop(pairs);
    by_rank.par_sort_unstable();
    let n = order.len();
    let mut from = vec![0u32; n + 1];
    for &(r, _) in &by_rank {
        from[r as usize + 1] += 1;
    }
    for r in 0..n {
        from[r + 1] += from[r];
    }
    let earlier: Vec<u32> = by_rank.iter().map(|&(_, e)| e).collect();
    // Clusters: (root, rank), grouped by root, each in rank order.
    let mut parent: Vec<u32> = (0..n as u32).collect();
    for &(r, e) in &by_rank {
        let (a, b) = (root(&mut parent, r), root(&mut parent, e));
        if a != b {
            parent[a.max(b) as usize] = a.min(b);
        }
    }
    drop(by_rank);
    let mut members: Vec<(u32, u32)> = (0..n as u32).map(|r| (root(&mut parent, r), r)).collect();
    members.par_sort_unstable();
    // Position of each rank within its cluster.
    let mut at = vec![0u32; n];
    for cluster in members.chunk_by(|x, y| x.0 == y.0) {
        for (p, &(_, r)) in cluster.iter().enumerate() {
            at[r as usize] = p as u32;
        }
    }
    let kept_by_cluster: Vec<Vec<(u32, Pieces)>> = members
        .par_chunk_by(|x, y| x.0 == y.0)
        .map(|cluster| {
            let mut kept: Vec<(u32, Pieces)> = Vec::with_capacity(cluster.len());
            let mut covers: Vec<Cover> = Vec::new();
            for &(_, r) in cluster {
                let i = order[r as usize];
                let (a, b) = (points[i as usize], points[i as usize + 1]);
                covers.clear();
                for &e in &earlier[from[r as usize] as usize..from[r as usize + 1] as usize] {
                    for &(p, q) in &kept[at[e as usize] as usize].1 {
                        covers.extend(cover(a, b, p, q, tol));
                    }
                }
                kept.push((r, uncovered(a, b, &mut covers, tol)));
            }
            kept
        })
        .collect();
    drop((members, earlier, from, at));
    let mut kept: Vec<Vec<(DVec2, DVec2)>> = vec![Vec::new(); n];
    for (r, pieces) in kept_by_cluster.into_iter().flatten() {
        kept[r as usize] = pieces;
    }
    // Summed in rank order, as the sequential pass would.
    let removed: f64 = order
        .iter()
        .zip(&kept)
        .map(|(&i, pieces)| {
            let (a, b) = (points[i as usize], points[i as usize + 1]);
            a.distance(b) - pieces.iter().map(|(p, q)| p.distance(*q)).sum::<f64>()
        })
        .sum();
    drop(points);
    // Output in input order: untouched polylines whole, a touched one as its
    // runs of untouched segments and the kept pieces of its involved ones.
    let mut touched = vec![false; polylines.len()];
    for &i in &order {
        touched[first.partition_point(|&f| f <= i as usize) - 1] = true;
    }
    let mut out: Vec<Polyline> = Vec::with_capacity(polylines.len() + order.len());
    for (pi, p) in polylines.iter().enumerate() {
        if !touched[pi] {
            out.push(p.clone());
            continue;
        }
        let mut run: Vec<DVec2> = Vec::new();
        for (k, w) in p.points.windows(2).enumerate() {
            match rank[first[pi] + k] {
                u32::MAX => {
                    if run.last() != Some(&w[0]) {
                        flush(&mut run, &mut out);
                        run.push(w[0]);
                    }
                    run.push(w[1]);
                }
                r => {
                    // Pieces go on the run where they continue it (a
                    // segment nothing covers, the pieces of one line).
                    for &(p, q) in &kept[r as usize] {
                        if run.last() != Some(&p) {
                            flush(&mut run, &mut out);
                            run.push(p);
                        }
                        run.push(q);
                    }
                }
            }
        }
        flush(&mut run, &mut out);
    }
    Deduped { polylines: out, removed_mm: removed }
}

/// The kept pieces of one segment, from its start towards its end.
type Pieces = Vec<(DVec2, DVec2)>;

/// Per point: the direction bucket of the segment that starts there and the
/// bucket beside it (see [`bucket`]), or [`NO_BUCKET`] where no segment
/// starts (a polyline's last point) or it cannot be compared (a non-finite
/// or zero-length segment).
fn directions(points: &[DVec2], first: &[usize]) -> Vec<[u8; 2]> {
    let mut buckets: Vec<[u8; 2]> = (0..points.len())
        .into_par_iter()
        .map(|k| match points.get(k + 1) {
            Some(&b) if drawable(points[k], b) => {
                let (b, side) = bucket(points[k], b);
                [b as u8, side.map_or(NO_BUCKET, |x| x as u8)]
            }
            _ => [NO_BUCKET; 2],
        })
        .collect();
    for w in first.windows(2) {
        if w[1] > w[0] {
            buckets[w[1] - 1] = [NO_BUCKET; 2];
        }
    }
    buckets
}

/// No direction bucket: no segment, or no side bucket.
const NO_BUCKET: u8 = u8::MAX;

/// Pass 1: the pairs of segments (point indices, lower first, ascending)
/// of which one runs over the other ([`cover`]), in parallel.
///
/// Two segments that overlap are within the tolerance of each other and
/// nearly parallel, so they share a direction bucket (their own or the one
/// beside it) and, in that bucket's frame (axis along its middle
/// direction), a band of offsets a few tolerances wide, where their extents
/// along the axis meet. Each segment is entered in the bands its offsets
/// (padded by half the tolerance) cross, in its bucket's frame and its side
/// bucket's; sorted by band and then by where along the axis they start, a
/// sweep meets every pair whose extents come within the tolerance, and
/// only those. The grid lines of a surface lie several bands apart and
/// never meet; lines drawn over each other do.
fn overlapping(points: &[DVec2], buckets: &[[u8; 2]], tol: f64) -> Vec<(u32, u32)> {
    let held = |k: usize| buckets[k][0] != NO_BUCKET;
    let (lo, hi, count, total) = (0..points.len())
        .into_par_iter()
        .filter(|&k| held(k))
        .map(|k| {
            let (a, b) = (points[k], points[k + 1]);
            (a.min(b), a.max(b), 1usize, a.distance(b))
        })
        .reduce(
            || (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY), 0, 0.0),
            |x, y| (x.0.min(y.0), x.1.max(y.1), x.2 + y.2, x.3 + y.3),
        );
    if count < 2 {
        return Vec::new();
    }
    // Offsets and positions are taken from `lo` and shifted by the diagonal,
    // so they are never negative.
    let diag = lo.distance(hi).max(1e-9);
    // Rounding of the rotated coordinates, with room to spare.
    let slack = diag * 1e-12;
    // A segment's offsets in a frame span at most 0.12 of its length (its
    // angle to the axis is below half a frame plus MAX_ANGLE); bands are
    // widened until that makes at most a few entries per segment.
    let mut band = (4.0 * tol).max(2.0 * diag / BAND_KEYS);
    while 0.12 * total / band > 4.0 * count as f64 {
        band *= 2.0;
    }
    let step = 2.0 * diag / AXIS_KEYS;
    let pad = 0.5 * tol + slack;
    let frames: Vec<(DVec2, DVec2)> = (0..FRAMES)
        .map(|k| {
            let u = DVec2::from_angle((k as f64 + 0.5) * std::f64::consts::PI / FRAMES as f64);
            (u, u.perp())
        })
        .collect();
    // Bands a frame can hold (offsets run from 0 to twice the diagonal).
    let bands = ((2.0 * diag / band).ceil() as u64 + 2).min(BAND_KEYS as u64);
    // (frame, band, start along the axis) packed in one key, and the segment.
    let per = (ANGLE_BUCKETS / FRAMES) as u8;
    // In runs of segments, each run's entries in one vector: far cheaper than
    // an iterator per segment on millions of them.
    let runs: Vec<Vec<(u64, u32)>> = (0..points.len().div_ceil(RUN))
        .into_par_iter()
        .map(|r| {
            let mut out = Vec::with_capacity(2 * RUN);
            for k in r * RUN..((r + 1) * RUN).min(points.len()) {
                if !held(k) {
                    continue;
                }
                let (a, b) = (points[k] - lo, points[k + 1] - lo);
                // The frame of the segment's bucket, and the one beside it
                // when its side bucket is across a frame border.
                let [own, side] = buckets[k];
                let own = own / per;
                let side = if side != NO_BUCKET && side / per != own { side / per } else { NO_BUCKET };
                for f in [own, side] {
                    if f == NO_BUCKET {
                        continue;
                    }
                    let (u, n) = frames[f as usize];
                    let (oa, ob) = (n.dot(a) + diag, n.dot(b) + diag);
                    let start = ((u.dot(a).min(u.dot(b)) + diag) / step).max(0.0).min(u32::MAX as f64) as u64;
                    let band_of = |o: f64| ((o / band).max(0.0) as u64).min(BAND_KEYS as u64 - 1);
                    for bd in band_of(oa.min(ob) - pad)..=band_of(oa.max(ob) + pad) {
                        out.push(((u64::from(f) << 58) | (bd << 32) | start, k as u32));
                    }
                }
            }
            out
        })
        .collect();
    let entries = by_group(runs, bands);
    let mut hits: Vec<(u32, u32)> = entries
        .par_chunk_by(|x, y| x.0 >> 32 == y.0 >> 32)
        .flat_map_iter(|group| {
            let (u, n) = frames[(group[0].0 >> 58) as usize];
            // Segments whose extent may still meet what comes later: (end
            // along the axis, segment, its offsets' range).
            let mut active: Vec<(f64, u32, f64, f64)> = Vec::new();
            let mut hits = Vec::new();
            for &(key, k) in group {
                // Every later entry starts at or after this.
                let from = (key & u64::from(u32::MAX)) as f64 * step;
                active.retain(|&(end, ..)| end + tol + slack >= from);
                let (a, b) = (points[k as usize], points[k as usize + 1]);
                let (oa, ob) = (n.dot(a - lo), n.dot(b - lo));
                let (olo, ohi) = (oa.min(ob), oa.max(ob));
                for &(_, j, jlo, jhi) in &active {
                    // A point within the tolerance of the other segment has
                    // an offset within the tolerance of that one's offsets.
                    if olo > jhi + tol + slack || jlo > ohi + tol + slack {
                        continue;
                    }
                    let (p, q) = (points[j as usize], points[j as usize + 1]);
                    // Consecutive segments of one polyline going on (most
                    // pairs here) meet at one point and cover nothing of
                    // each other; one that turns back is compared.
                    if (j + 1 == k || k + 1 == j) && (b - a).dot(q - p) > 0.0 {
                        continue;
                    }
                    if cover(a, b, p, q, tol).is_some() || cover(p, q, a, b, tol).is_some() {
                        hits.push((k.min(j), k.max(j)));
                    }
                }
                let (s, e) = (u.dot(a - lo) + diag, u.dot(b - lo) + diag);
                active.push((s.max(e), k, olo, ohi));
            }
            hits
        })
        .collect();
    hits.par_sort_unstable();
    hits.dedup();
    hits
}

/// The root of `v`'s tree in a union-find forest, halving the path.
fn root(parent: &mut [u32], mut v: u32) -> u32 {
    while parent[v as usize] != v {
        let up = parent[parent[v as usize] as usize];
        parent[v as usize] = up;
        v = up;
    }
    v
}

/// The entries of `runs` (keys as in [`overlapping`]: frame, band, start)
/// in key order, given that a frame holds at most `bands` bands: counted
/// into their frames, then each frame's into its bands in parallel, then
/// each (frame, band) group sorted by start. Far cheaper than a sort of the
/// whole on millions of entries, since groups are small; each run is freed
/// once counted, so the entries are never held twice (the memory peak of a
/// large drawing's render). A sort where the bands would outnumber the
/// entries many times.
fn by_group(runs: Vec<Vec<(u64, u32)>>, bands: u64) -> Vec<(u64, u32)> {
    let total: usize = runs.iter().map(Vec::len).sum();
    if bands > 8 * total as u64 + 1024 {
        let mut entries = runs.concat();
        entries.par_sort_unstable();
        return entries;
    }
    let frame_of = |key: u64| (key >> 58) as usize;
    let mut start = [0usize; FRAMES + 1];
    for e in runs.iter().flatten() {
        start[frame_of(e.0) + 1] += 1;
    }
    for f in 0..FRAMES {
        start[f + 1] += start[f];
    }
    let mut sorted = vec![(0u64, 0u32); total];
    for run in runs {
        for e in run {
            let f = frame_of(e.0);
            sorted[start[f]] = e;
            start[f] += 1;
        }
    }
    sorted.par_chunk_by_mut(|x, y| x.0 >> 58 == y.0 >> 58).for_each(|frame| {
        let by_band = counted(frame, bands as usize, |key| ((key >> 32) & ((1 << 26) - 1)) as usize);
        frame.copy_from_slice(&by_band);
        frame.chunk_by_mut(|x, y| x.0 >> 32 == y.0 >> 32).for_each(<[(u64, u32)]>::sort_unstable);
    });
    sorted
}

/// `entries` counted into `groups` groups by `group` of their key, groups in
/// order, each in its input order (a counting sort).
fn counted(entries: &[(u64, u32)], groups: usize, group: impl Fn(u64) -> usize) -> Vec<(u64, u32)> {
    let mut start = vec![0u32; groups + 1];
    for e in entries {
        start[group(e.0) + 1] += 1;
    }
    for g in 0..groups {
        start[g + 1] += start[g];
    }
    let mut sorted = vec![(0u64, 0u32); entries.len()];
    for &e in entries {
        let g = group(e.0);
        sorted[start[g] as usize] = e;
        start[g] += 1;
    }
    sorted
}

/// Segments per parallel task where pass 1 lists its entries.
const RUN: usize = 1 << 14;

/// Frames of pass 1 over the half turn (each about 11 degrees, four
/// direction buckets): wide enough that few segments need the frame beside
/// theirs too, narrow enough that lines crossing within one band are few.
const FRAMES: usize = 16;

/// Bands of offsets per frame (the band takes 26 bits of a sort key).
const BAND_KEYS: f64 = (1u64 << 26) as f64;

/// Steps along a frame's axis (the start takes 32 bits of a sort key).
const AXIS_KEYS: f64 = 4_294_967_295.0;

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
    // A total order, so the result does not depend on the order the grid
    // found the covers in.
    covers.sort_by(|x, y| {
        x.t0.total_cmp(&y.t0)
            .then(x.t1.total_cmp(&y.t1))
            .then(x.at0.x.total_cmp(&y.at0.x))
            .then(x.at0.y.total_cmp(&y.at0.y))
            .then(x.at1.x.total_cmp(&y.at1.x))
            .then(x.at1.y.total_cmp(&y.at1.y))
    });
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

/// A segment that can be compared: finite ends, not a point.
fn drawable(a: DVec2, b: DVec2) -> bool {
    a.is_finite() && b.is_finite() && a != b
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
    #[test]
    fn the_band_sweep_finds_every_overlapping_pair_and_only_those() {
        // Segments at every direction (many on the borders of direction
        // buckets and frames), some long, many drawn over another within the
        // tolerance at a small angle, at offsets around the tolerance: the
        // pairs are what comparing every pair finds.
        let mut x = 0.61_f64;
        let mut next = || {
            x = (x * 7919.0 + 0.377).fract();
            x
        };
        let tol = 0.01;
        let mut input: Vec<Polyline> = Vec::new();
        for k in 0..1500 {
            let border = (k % 16) as f64 * std::f64::consts::PI / 16.0;
            let angle = if k % 3 == 0 { border + (next() - 0.5) * 0.06 } else { next() * std::f64::consts::PI };
            let u = DVec2::from_angle(angle);
            let a = DVec2::new(next() * 20.0, next() * 20.0);
            let len = if k % 50 == 0 { 30.0 } else { 0.05 + next() * 2.0 };
            input.push(Polyline::new(vec![a, a + u * len]));
            if k % 2 == 0 {
                // One over it: turned by up to 1.5 MAX_ANGLE, moved by up to
                // twice the tolerance, starting somewhere along it.
                let v = DVec2::from_angle(angle + (next() - 0.5) * 3.0 * MAX_ANGLE);
                let b = a + u * len * next() + u.perp() * (next() - 0.5) * 4.0 * tol;
                input.push(Polyline::new(vec![b, b + v * (0.05 + next() * 2.0)]));
            }
        }
        let points: Vec<DVec2> = input.iter().flat_map(|p| p.points.iter().copied()).collect();
        let first: Vec<usize> = (0..=input.len()).map(|p| 2 * p).collect();
        let buckets = directions(&points, &first);
        let found = overlapping(&points, &buckets, tol);
        let seg = |i: usize| (points[2 * i], points[2 * i + 1]);
        let brute: Vec<(u32, u32)> = (0..input.len())
            .flat_map(|i| (i + 1..input.len()).map(move |j| (i, j)))
            .filter(|&(i, j)| {
                let ((a, b), (p, q)) = (seg(i), seg(j));
                cover(a, b, p, q, tol).is_some() || cover(p, q, a, b, tol).is_some()
            })
            .map(|(i, j)| (2 * i as u32, 2 * j as u32))
            .collect();
        assert!(brute.len() > 300, "the case overlaps too little to test: {}", brute.len());
        assert_eq!(found, brute);
    }
}
