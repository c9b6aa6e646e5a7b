//! Overlap removal: no place of one pen's drawing is drawn twice.
//!
//! Hidden-line output draws the same place more than once wherever distinct
//! lines project onto each other: the grid lines of a flat part of a surface
//! seen exactly edge-on all lie on the horizon, a T-junction's long edge lies
//! over the two short ones, a face written twice in a mesh draws its outline
//! twice; and 2-D inputs (SVG, HP-GL) often overlap themselves. A pen drawn
//! twice over one line wets the paper and tears it, and takes twice the time.
//!
//! [`dedupe()`] removes, from each segment, the parts that lie within the
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
//! - **A fold's tip is drawn twice**: where two segments leave an end
//!   point they share (exactly) along each other, an overlap of up to
//!   [`FOLD_TIP_MM`] from it is left, since cutting it would cost a pen
//!   lift; in a stack on one line (`stacks`) only where nothing else of the
//!   stack ends there.
//! - **Segments that only touch or cross are never cut**: an overlap counts
//!   when the two run within the tolerance of each other for longer than the
//!   tolerance, at an angle below [`MAX_ANGLE`].
//! - Deterministic, independent of the input order of equal-length segments
//!   (ties are broken by input position).
//!
//! How: first, segments stacked on one line (a shape drawn many times over)
//! are cut against each other without pairs (`stacks`), so that `k` copies
//! cost a sort, not `k^2 / 2` pairs. Then a parallel first pass finds the
//! pairs of segments of which one runs
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

/// Longest fold tip (mm) left drawn twice: where two segments leave an end
/// point they share along each other (a line that turns back on itself; a
/// projected surface's row and column edges where the surface folds out of
/// sight, all its directions then projecting onto one), cutting the overlap
/// off one of them leaves a loose end, a pen lift (0.2 s in the default
/// motion model, the time to draw 76 mm). Up to this length the tip is
/// drawn again instead; a longer one is a line truly gone back over, and is
/// drawn once.
pub const FOLD_TIP_MM: f64 = 2.0;

/// What [`dedupe()`] did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Deduped {
    /// The drawing with no place drawn twice.
    pub polylines: Vec<Polyline>,
    /// Length removed (mm): drawn over a kept segment within the tolerance.
    pub removed_mm: f64,
    /// The parts removed from segments that overlapped (not those of
    /// stacked copies), each from its segment's start towards its end: what
    /// [`crate::rejoin`] may draw again to join loose ends.
    pub removed: Vec<Piece>,
}

/// Removes from `polylines` every part that lies within `tol` mm of a nearly
/// parallel (below [`MAX_ANGLE`]) segment that is kept, longest segments kept
/// first; see the module doc. Polylines that overlap nothing come back as
/// they are (moved, not copied: on a large drawing a copy is most of this
/// stage's memory); the pieces of the others take their place, in input
/// order.
#[must_use]
pub fn dedupe(polylines: Vec<Polyline>, tol: f64) -> Deduped {
    let tol = if tol > 0.0 { tol } else { 0.0 };
    let points = Points::new(&polylines);
    let pairs = overlapping(&points, tol);
    if pairs.is_empty() {
        return Deduped { polylines, removed_mm: 0.0, removed: Vec::new() };
    }
    // The involved segments (point indices) in rank order: longest first,
    // ties by position; rank[k]: one more than the position of segment k
    // in `order` (0: not involved; fresh zeroed memory, so that only the
    // involved segments' pages are written).
    let mut order: Vec<u32> = pairs.iter().flat_map(|&(i, j)| [i, j]).collect();
    order.par_sort_unstable();
    order.dedup();
    // Keyed once: the lengths of involved segments are finite and above 0,
    // so their bits order as they do, and inverted, longest first.
    let mut keyed: Vec<(u64, u32)> = order
        .par_iter()
        .map(|&i| {
            let (a, b) = points.segment(i);
            (!a.distance_squared(b).to_bits(), i)
        })
        .collect();
    keyed.par_sort_unstable();
    let order: Vec<u32> = keyed.into_iter().map(|(_, i)| i).collect();
    let mut rank: Vec<u32> = zeroed(points.len());
    for (r, &i) in order.iter().enumerate() {
        rank[i as usize] = r as u32 + 1;
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
            let (ri, rj) = (rank[i as usize] - 1, rank[j as usize] - 1);
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
    // Each cluster's kept pieces in one list, a span of it per segment
    // (rank, from, to): a million segments' pieces are not a million
    // allocations.
    let by_cluster: Vec<(Vec<[u32; 3]>, Vec<Piece>)> = members
        .par_chunk_by(|x, y| x.0 == y.0)
        .map(|cluster| {
            let mut spans: Vec<[u32; 3]> = Vec::with_capacity(cluster.len());
            let mut pieces: Vec<Piece> = Vec::with_capacity(cluster.len());
            let mut covers: Vec<Cover> = Vec::new();
            for &(_, r) in cluster {
                let (a, b) = points.segment(order[r as usize]);
                covers.clear();
                for &e in &earlier[from[r as usize] as usize..from[r as usize + 1] as usize] {
                    let [_, s, t] = spans[at[e as usize] as usize];
                    // A fold's tip is left where the two segments' own end
                    // points meet (not a cut anchored there).
                    let (ca, cb) = points.segment(order[e as usize]);
                    for &(p, q) in &pieces[s as usize..t as usize] {
                        covers.extend(cover(a, b, p, q, tol).filter(|c| c.fold_at(a, b, p, q, tol).is_none_or(|x| x != ca && x != cb)));
                    }
                }
                let s = pieces.len() as u32;
                uncovered(a, b, &mut covers, tol, &mut pieces);
                spans.push([r, s, pieces.len() as u32]);
            }
            (spans, pieces)
        })
        .collect();
    drop((members, earlier, from, at));
    // Where each rank's pieces are: (cluster, from, to).
    let mut kept = vec![[0u32; 3]; n];
    for (c, (spans, _)) in by_cluster.iter().enumerate() {
        for &[r, s, t] in spans {
            kept[r as usize] = [c as u32, s, t];
        }
    }
    let pieces_of = |r: usize| {
        let [c, s, t] = kept[r];
        &by_cluster[c as usize].1[s as usize..t as usize]
    };
    // Summed in rank order, in chunks of a fixed size (the same sum on
    // every run).
    let removed: f64 = order
        .par_chunks(REMOVED_CHUNK)
        .enumerate()
        .map(|(c, chunk)| {
            let mut sum = 0.0;
            for (k, &i) in chunk.iter().enumerate() {
                let (a, b) = points.segment(i);
                sum += a.distance(b) - pieces_of(c * REMOVED_CHUNK + k).iter().map(|(p, q)| p.distance(*q)).sum::<f64>();
            }
            sum
        })
        .collect::<Vec<f64>>()
        .into_iter()
        .sum();
    let gaps: Vec<Piece> = order
        .par_iter()
        .enumerate()
        .flat_map_iter(|(r, &i)| {
            let (a, b) = points.segment(i);
            gaps_of(a, b, pieces_of(r))
        })
        .collect();
    let Points { first, .. } = points;
    let out = rebuilt(polylines, &first, &rank, pieces_of);
    Deduped { polylines: out, removed_mm: removed, removed: gaps }
}

/// `polylines` with some of their segments cut: `marks[k]` is 0 for
/// segment `k` (a point index, as [`Points`] names it, `first` its
/// polylines' first points) kept whole, else one more than the index
/// `pieces_of` takes to give what is kept of it. A polyline with no cut
/// segment is moved whole; one with cut segments becomes its runs of whole
/// segments and kept pieces, a piece going on the run it continues (a
/// segment nothing covers, the pieces of one line). Each polyline on its
/// own, in parallel; in input order.
pub(crate) fn rebuilt<'p>(
    polylines: Vec<Polyline>,
    first: &[usize],
    marks: &[u32],
    pieces_of: impl Fn(usize) -> &'p [Piece] + Sync,
) -> Vec<Polyline> {
    polylines
        .into_par_iter()
        .enumerate()
        .flat_map_iter(|(pi, p)| {
            if marks[first[pi]..first[pi + 1]].iter().all(|&r| r == 0) {
                return vec![p];
            }
            let mut out = Vec::new();
            let mut run: Vec<DVec2> = Vec::new();
            for (k, w) in p.points.windows(2).enumerate() {
                match marks[first[pi] + k] {
                    0 => {
                        if run.last() != Some(&w[0]) {
                            flush(&mut run, &mut out);
                            run.push(w[0]);
                        }
                        run.push(w[1]);
                    }
                    r => {
                        for &(p, q) in pieces_of(r as usize - 1) {
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
            out
        })
        .collect()
}

/// A piece of a segment, from its start towards its end.
pub type Piece = (DVec2, DVec2);

/// What is not kept of segment `a`-`b` whose kept pieces are `kept` (in
/// order from `a`): the gaps before, between and after them.
fn gaps_of(a: DVec2, b: DVec2, kept: &[Piece]) -> Vec<Piece> {
    let mut out = Vec::new();
    let mut at = a;
    for &(p, q) in kept {
        if p != at {
            out.push((at, p));
        }
        at = q;
    }
    if at != b {
        out.push((at, b));
    }
    out
}

/// Involved segments per parallel task where the removed length is summed.
const REMOVED_CHUNK: usize = 1 << 14;

/// The drawing's points as one sequence, without a copy (on a surface's
/// long polylines a copy would be most of this stage's time and memory):
/// point `k` is point `k - first[p]` of the polyline `p` with `first[p] <= k
/// < first[p + 1]`, and segment `k` runs from point `k` to point `k + 1`
/// when both are of one polyline. Segments are named by that index.
pub(crate) struct Points<'a> {
    polylines: &'a [Polyline],
    pub(crate) first: Vec<usize>,
}

impl<'a> Points<'a> {
    pub(crate) fn new(polylines: &'a [Polyline]) -> Points<'a> {
        let mut first = Vec::with_capacity(polylines.len() + 1);
        let mut total = 0;
        for p in polylines {
            first.push(total);
            total += p.points.len();
        }
        first.push(total);
        Points { polylines, first }
    }

    /// How many points there are.
    pub(crate) fn len(&self) -> usize {
        self.first[self.polylines.len()]
    }

    /// The polyline point `k` is on (the last one starting at or before it:
    /// an empty polyline starts where the next one does).
    fn polyline_of(&self, k: usize) -> usize {
        self.first.partition_point(|&f| f <= k) - 1
    }

    /// The points of polyline `p`, and the index of its first.
    fn line(&self, p: usize) -> Line<'a> {
        Line { points: &self.polylines[p].points, first: self.first[p] as u32 }
    }

    /// The ends of segment `k`.
    pub(crate) fn segment(&self, k: u32) -> (DVec2, DVec2) {
        self.line(self.polyline_of(k as usize)).segment(k)
    }

    /// Where the comparable segments lie, each polyline in parallel.
    pub(crate) fn extent(&self) -> Extent {
        self.polylines
            .par_iter()
            .map(|p| p.points.windows(2).filter(|w| drawable(w[0], w[1])).fold(Extent::EMPTY, |e, w| e.add(w[0], w[1])))
            .reduce(|| Extent::EMPTY, Extent::join)
    }
}

/// One polyline's points, and the index of its first among all.
#[derive(Clone, Copy)]
struct Line<'a> {
    points: &'a [DVec2],
    first: u32,
}

impl Line<'_> {
    /// The ends of segment `k` (an index among all points) of this polyline.
    fn segment(&self, k: u32) -> (DVec2, DVec2) {
        let i = (k - self.first) as usize;
        (self.points[i], self.points[i + 1])
    }
}

/// The box, count and total length of the comparable segments.
#[derive(Clone, Copy)]
pub(crate) struct Extent {
    pub(crate) lo: DVec2,
    pub(crate) hi: DVec2,
    pub(crate) count: usize,
    pub(crate) total: f64,
}

impl Extent {
    const EMPTY: Extent = Extent { lo: DVec2::INFINITY, hi: DVec2::NEG_INFINITY, count: 0, total: 0.0 };

    fn add(self, a: DVec2, b: DVec2) -> Extent {
        Extent { lo: self.lo.min(a.min(b)), hi: self.hi.max(a.max(b)), count: self.count + 1, total: self.total + a.distance(b) }
    }

    fn join(self, o: Extent) -> Extent {
        Extent { lo: self.lo.min(o.lo), hi: self.hi.max(o.hi), count: self.count + o.count, total: self.total + o.total }
    }
}

/// `n` zero values in fresh zeroed memory: no page is touched before its
/// part is written, so that the pages (about 1 ms a MB to fault on a VM)
/// fault where they are first written, on every core.
pub(crate) fn zeroed<T: bytemuck::Zeroable>(n: usize) -> Vec<T> {
    bytemuck::allocation::try_zeroed_vec(n).unwrap_or_else(|()| std::alloc::handle_alloc_error(std::alloc::Layout::new::<T>()))
}

/// Pass 1: the pairs of segments (point indices, lower first, ascending)
/// of which one runs over the other ([`cover`]), in parallel.
///
/// Two segments that overlap are within the tolerance of each other and
/// nearly parallel, so they share a direction bucket (their own or the one
/// beside it) and, in that bucket's frame (axis along its middle
/// direction), a band of offsets 16 tolerances wide, where their extents
/// along the axis meet. Each segment is entered in the bands its offsets
/// (padded by half the tolerance) cross, in its bucket's frame and its side
/// bucket's, as part of a [`Run`]: the consecutive segments of a polyline
/// that go one way in one band are one entry. Sorted by band and then by
/// where along the axis they start, a sweep meets every pair of runs whose
/// extents come within the tolerance, and [`pairs_of`] every such pair of
/// their segments, and only those. The grid lines of a surface mostly lie
/// bands apart and never meet; lines drawn over each other do, and so do
/// lines the projection crowds together, which [`apart`] passes by cheaply.
fn overlapping(points: &Points<'_>, tol: f64) -> Vec<(u32, u32)> {
    let Extent { lo, hi, count, total } = points.extent();
    if count < 2 {
        return Vec::new();
    }
    // Offsets and positions are taken from `lo` and shifted by the diagonal,
    // so they are never negative.
    let diag = lo.distance(hi).max(1e-9);
    // Rounding of the rotated coordinates, with room to spare.
    let slack = diag * 1e-12;
    // Bands of 16 tolerances: narrower ones enter a segment in more bands,
    // as more runs, and where a projection crowds a surface's grid lines a
    // band holds several lines however narrow it is (at 2000 x 2000, with
    // 32 frames, pass 1 took 127 ms at 4 tolerances, about 190 at 2 and 100
    // at 16 or 32; `apart` makes the extra pairs cheap). A segment's
    // offsets in a frame span at most 0.07 of its length (its angle to the
    // axis is below half a frame plus NEAR); bands are widened until that
    // makes at most a few entries per segment.
    let mut band = (16.0 * tol).max(2.0 * diag / BAND_KEYS);
    while 0.07 * total / band > 4.0 * count as f64 {
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
    let per = ANGLE_BUCKETS / FRAMES;
    // Every segment goes through here: a product, not a division (any
    // rounding is the same for all, so bands stay in order of offset).
    let per_band = 1.0 / band;
    let band_of = |o: f64| ((o * per_band).max(0.0) as u64).min(BAND_KEYS as u64 - 1);
    let geometry = Geometry { points, lo, diag, frames: &frames };
    // Each task lists the runs of its share of the segments (a run cut at a
    // task's border is two runs: only more entries, the same pairs).
    let tasks: Vec<Vec<Vec<Run>>> = (0..points.len().div_ceil(TASK))
        .into_par_iter()
        .map(|t| {
            // The task's runs by frame.
            let mut out: Vec<Vec<Run>> = vec![Vec::new(); FRAMES];
            // Runs the previous segment extended (a few), extended in place.
            let mut open: Vec<Open> = Vec::new();
            // Whether the previous segment extended one run alone: then a
            // segment that goes on in that run's frame, band and way (most
            // along a grid line) extends it without a bucket or a search,
            // just as the general path below would.
            let mut alone = false;
            let (from, to) = (t * TASK, ((t + 1) * TASK).min(points.len()));
            let mut p = points.polyline_of(from);
            let mut line = points.line(p);
            for k in from..to {
                while k >= points.first[p + 1] {
                    p += 1;
                    line = points.line(p);
                }
                let i = k - line.first as usize;
                let segment = line.points.get(i + 1).map(|&b| (line.points[i], b)).filter(|&(a, b)| drawable(a, b));
                if let (true, Some((a, b))) = (alone, segment) {
                    let run = &open[0];
                    let seg = geometry.along(run.frame, a, b, k as u32);
                    if seg.ohi - seg.olo <= INSIDE_FRAME * (seg.end - seg.start)
                        && seg.forward == run.run.forward
                        && band_of(seg.olo - pad) == run.band
                        && band_of(seg.ohi + pad) == run.band
                    {
                        open[0].extend(&seg);
                        continue;
                    }
                }
                if let Some((a, b)) = segment {
                    // The frame of the segment's bucket, and the one beside
                    // it when its side bucket is across a frame border.
                    let (own, side) = bucket(a, b);
                    let own = own / per;
                    let side = side.map(|x| x / per).filter(|&f| f != own);
                    for f in std::iter::once(own).chain(side) {
                        let f = f as u8;
                        let seg = geometry.along(f, a, b, k as u32);
                        let forward = seg.forward;
                        // A segment enters each (frame, band) once, so it
                        // extends a run at most once.
                        for bd in band_of(seg.olo - pad)..=band_of(seg.ohi + pad) {
                            match open.iter_mut().find(|o| o.frame == f && o.band == bd && o.run.forward == forward) {
                                Some(o) => o.extend(&seg),
                                None => open.push(Open::new(f, bd, p as u32, k as u32, &seg)),
                            }
                        }
                    }
                }
                // What this segment did not extend ends before it (the
                // order runs are closed in does not matter: `by_group`
                // sorts each group).
                let mut i = 0;
                while i < open.len() {
                    if open[i].run.first + open[i].run.count == k as u32 + 1 {
                        i += 1;
                    } else {
                        let o = open.swap_remove(i);
                        out[o.frame as usize].push(o.closed(step));
                    }
                }
                alone = open.len() == 1;
            }
            for o in open.drain(..) {
                out[o.frame as usize].push(o.closed(step));
            }
            out
        })
        .collect();
    let entries = by_group(tasks, bands);
    let mut hits: Vec<(u32, u32)> = entries
        .par_iter()
        .flat_map(|runs| runs.par_chunk_by(|x, y| x.key >> 32 == y.key >> 32))
        .flat_map_iter(|group| {
            let mut hits = Vec::new();
            if group.len() < 2 {
                return hits;
            }
            // The segments of the group's runs that meet another, each run's
            // in order along the axis, found when first compared (most runs
            // of a band meet none): `segments[at[i]..at[i + 1]]` are run `i`'s.
            let frame = (group[0].key >> 58) as u8;
            let mut segments = Vec::new();
            let mut at: Vec<[u32; 2]> = vec![[u32::MAX; 2]; group.len()];
            let mut segments_of = |i: usize, segments: &mut Vec<Along>| {
                if at[i][0] == u32::MAX {
                    let from = segments.len() as u32;
                    geometry.run(frame, &group[i], segments);
                    at[i] = [from, segments.len() as u32];
                }
                at[i][0] as usize..at[i][1] as usize
            };
            // Runs whose extent may still meet what comes later.
            let mut active: Vec<usize> = Vec::new();
            for (i, run) in group.iter().enumerate() {
                // Every later run starts at or after this.
                let from = (run.key & u64::from(u32::MAX)) as f64 * step;
                active.retain(|&j| group[j].end + tol + slack >= from);
                for &j in &active {
                    let other = &group[j];
                    // A point within the tolerance of the other segment has
                    // an offset within the tolerance of that one's offsets.
                    if run.olo > other.ohi + tol + slack || other.olo > run.ohi + tol + slack {
                        continue;
                    }
                    let (mine, theirs) = (segments_of(i, &mut segments), segments_of(j, &mut segments));
                    let mine = (&segments[mine], points.line(run.poly as usize));
                    let theirs = (&segments[theirs], points.line(other.poly as usize));
                    pairs_of(mine, theirs, tol, tol + slack, &mut hits);
                }
                active.push(i);
            }
            hits
        })
        .collect();
    hits.par_sort_unstable();
    hits.dedup();
    hits
}

/// The pairs of one run's segments and another's (each in order along the
/// frame's axis) that come within `reach` of each other along the axis and
/// across it and of which one runs over the other, added to `hits`. Both
/// runs go one way along the axis, so their extents are in order: one pass
/// over the parts of the two that meet finds every such pair.
fn pairs_of(mine: (&[Along], Line<'_>), theirs: (&[Along], Line<'_>), tol: f64, reach: f64, hits: &mut Vec<(u32, u32)>) {
    let ((mine, my_line), (theirs, their_line)) = (mine, theirs);
    let (Some(first), Some(last)) = (theirs.first(), theirs.last()) else { return };
    let mut low = theirs.partition_point(|t| t.end + reach < mine[0].start);
    let upto = mine.partition_point(|s| s.start <= last.end + reach);
    let from = mine[..upto].partition_point(|s| s.end + reach < first.start);
    for s in &mine[from..upto] {
        while low < theirs.len() && theirs[low].end + reach < s.start {
            low += 1;
        }
        for t in theirs[low..].iter().take_while(|t| t.start <= s.end + reach) {
            if s.olo > t.ohi + reach || t.olo > s.ohi + reach {
                continue;
            }
            let (k, j) = (s.k, t.k);
            let ((a, b), (p, q)) = (my_line.segment(k), their_line.segment(j));
            // Consecutive segments of one polyline going on meet at one
            // point and cover nothing of each other; one that turns back is
            // compared.
            if (j + 1 == k || k + 1 == j) && (b - a).dot(q - p) > 0.0 {
                continue;
            }
            if apart(a, b, p, q, tol) && apart(p, q, a, b, tol) {
                continue;
            }
            if cover(a, b, p, q, tol).is_some() || cover(p, q, a, b, tol).is_some() {
                hits.push((k.min(j), k.max(j)));
            }
        }
    }
}

/// Where pass 1 looks at segments: the points and the frames, offsets and
/// positions taken from `lo` and shifted by the diagonal (never negative).
struct Geometry<'a> {
    points: &'a Points<'a>,
    lo: DVec2,
    diag: f64,
    frames: &'a [(DVec2, DVec2)],
}

/// Segment `k` in a frame: its extent along the axis, its offsets across.
#[derive(Clone, Copy)]
struct Along {
    k: u32,
    start: f64,
    end: f64,
    olo: f64,
    ohi: f64,
    /// Whether it goes up the axis from its first point.
    forward: bool,
}

impl Geometry<'_> {
    /// Segment `k`, from `a` to `b`, in `frame`.
    fn along(&self, frame: u8, a: DVec2, b: DVec2, k: u32) -> Along {
        let (u, n) = self.frames[frame as usize];
        let (a, b) = (a - self.lo, b - self.lo);
        let (sa, sb) = (u.dot(a) + self.diag, u.dot(b) + self.diag);
        let (oa, ob) = (n.dot(a) + self.diag, n.dot(b) + self.diag);
        Along { k, start: sa.min(sb), end: sa.max(sb), olo: oa.min(ob), ohi: oa.max(ob), forward: sb >= sa }
    }

    /// The segments of `run` added to `out`, in order along the frame's axis.
    fn run(&self, frame: u8, run: &Run, out: &mut Vec<Along>) {
        let from = out.len();
        let line = self.points.line(run.poly as usize);
        out.extend((run.first..run.first + run.count).map(|k| {
            let (a, b) = line.segment(k);
            self.along(frame, a, b, k)
        }));
        if !run.forward {
            out[from..].reverse();
        }
    }
}

/// A run of pass 1: consecutive segments of one polyline, all going the same
/// way along one frame's axis and all entered in one band of it; one entry
/// in place of each of its segments. Along a surface's long grid lines most
/// segments continue the run of the one before, so runs are several times
/// fewer than segments. Within a run segments only meet end to end (they go
/// one way, within a frame's angle), so a run is never compared with itself.
#[derive(Clone, Copy, Debug, Default)]
struct Run {
    /// (frame, band, start along the axis in steps), as in [`overlapping`].
    key: u64,
    /// Its polyline, its first segment (a point index) and how many.
    poly: u32,
    first: u32,
    count: u32,
    /// The end of its extent along the axis, and its offsets' range.
    end: f64,
    olo: f64,
    ohi: f64,
    forward: bool,
}

/// A run still being extended: its frame, band and start along the axis
/// (its key once closed).
struct Open {
    frame: u8,
    band: u64,
    start: f64,
    run: Run,
}

impl Open {
    fn new(frame: u8, band: u64, poly: u32, first: u32, s: &Along) -> Open {
        let run = Run { key: 0, poly, first, count: 1, end: s.end, olo: s.olo, ohi: s.ohi, forward: s.forward };
        Open { frame, band, start: s.start, run }
    }

    fn extend(&mut self, s: &Along) {
        self.start = self.start.min(s.start);
        let r = &mut self.run;
        (r.count, r.end, r.olo, r.ohi) = (r.count + 1, r.end.max(s.end), r.olo.min(s.olo), r.ohi.max(s.ohi));
    }

    fn closed(self, step: f64) -> Run {
        let start = (self.start / step).max(0.0).min(u32::MAX as f64) as u64;
        Run { key: (u64::from(self.frame) << 58) | (self.band << 32) | start, ..self.run }
    }
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

/// The runs of `tasks` (each task's by frame; keys as in [`overlapping`]:
/// frame, band, start) in key order, in lists no group straddles, given
/// that a frame holds at most `bands` bands: each frame's runs, from every
/// task, counted into their bands (the frames in parallel), then each
/// (frame, band) group sorted by start. Far cheaper than a sort of the
/// whole on millions of entries, since groups are small; a task's list is
/// freed once counted, so the entries are held twice over only for the
/// frames being counted (the memory peak of a large drawing's render). A
/// sort where the bands would outnumber the entries many times.
fn by_group(tasks: Vec<Vec<Vec<Run>>>, bands: u64) -> Vec<Vec<Run>> {
    let total: usize = tasks.iter().flatten().map(Vec::len).sum();
    if bands > 8 * total as u64 + 1024 {
        let mut entries: Vec<Run> = tasks.into_iter().flatten().flatten().collect();
        entries.par_sort_unstable_by_key(|r| (r.key, r.first));
        return vec![entries];
    }
    let mut frames: Vec<Vec<Vec<Run>>> = (0..FRAMES).map(|_| Vec::with_capacity(tasks.len())).collect();
    for task in tasks {
        for (frame, runs) in frames.iter_mut().zip(task) {
            frame.push(runs);
        }
    }
    frames
        .into_par_iter()
        .map(|parts| {
            let mut sorted = counted(parts, bands as usize, |key| ((key >> 32) & ((1 << 26) - 1)) as usize);
            sorted.chunk_by_mut(|x, y| x.key >> 32 == y.key >> 32).for_each(|g| g.sort_unstable_by_key(|r| (r.key, r.first)));
            sorted
        })
        .collect()
}

/// The entries of `parts` counted into `groups` groups by `group` of their
/// key, groups in order, each in its input order (a counting sort); each
/// part is freed once moved.
fn counted(parts: Vec<Vec<Run>>, groups: usize, group: impl Fn(u64) -> usize) -> Vec<Run> {
    let mut start = vec![0u32; groups + 1];
    for e in parts.iter().flatten() {
        start[group(e.key) + 1] += 1;
    }
    for g in 0..groups {
        start[g + 1] += start[g];
    }
    let mut sorted = vec![Run::default(); start[groups] as usize];
    for part in parts {
        for e in part {
            let g = group(e.key);
            sorted[start[g] as usize] = e;
            start[g] += 1;
        }
    }
    sorted
}

/// Segments per parallel task where pass 1 lists its entries.
const TASK: usize = 1 << 14;

/// Frames of pass 1 over the half turn (each about 5.6 degrees, two
/// direction buckets): wide enough that few segments need the frame beside
/// theirs too, narrow enough that a segment's offsets span few bands and
/// lines crossing within one band are few (with bands of 4 tolerances,
/// pass 1 at 2000 x 2000 took 188 ms at 16 frames, 127 at 32 and at 64).
const FRAMES: usize = 32;

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

/// Whether `p`-`q` lies wholly on one side of the line through `a`-`b`,
/// farther than `tol` from it (by a margin far above rounding): then
/// [`cover`]`(a, b, p, q, tol)` is `None`. No root and no division: most
/// pairs pass 1 meets on a dense surface are neighbouring grid lines where
/// the projection crowds them, nearly parallel and just apart (at 2000 x
/// 2000, 6 million pairs, 150,000 of them overlapping).
fn apart(a: DVec2, b: DVec2, p: DVec2, q: DVec2, tol: f64) -> bool {
    let d = b - a;
    let (op, oq) = (d.perp_dot(p - a), d.perp_dot(q - a));
    // `op / |d|` is p's offset from the line, as `cover` takes it.
    let reach = tol * tol * d.length_squared() * (1.0 + 1e-6);
    op * oq > 0.0 && op * op > reach && oq * oq > reach
}

/// The part of segment `a`-`b` that segment `p`-`q` runs over: the parameter
/// range (distance from `a`) where `p`-`q` lies within `tol` of the line
/// `a`-`b`, inside `a`-`b`, when the two are nearly parallel and the range is
/// longer than `tol`. Each end carries the point a cut there should take.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Cover {
    t0: f64,
    t1: f64,
    at0: DVec2,
    at1: DVec2,
}

impl Cover {
    /// The end point of `a`-`b` this cover, by the piece from `p` to `q`,
    /// is a fold's tip at ([`FOLD_TIP_MM`]), if it is one: short, from an
    /// end point of `a`-`b` that is one of the piece's, while the other ends
    /// are apart (copies of one segment, to the tolerance, are no fold).
    pub(crate) fn fold_at(&self, a: DVec2, b: DVec2, p: DVec2, q: DVec2, tol: f64) -> Option<DVec2> {
        let near = |x: DVec2, y: DVec2| x.distance(y) <= tol;
        let copies = (near(p, a) || near(q, a)) && (near(p, b) || near(q, b));
        if self.t1 - self.t0 > FOLD_TIP_MM || copies {
            None
        } else if (p == a || q == a) && self.t0 == 0.0 {
            Some(a)
        } else if (p == b || q == b) && self.t1 == a.distance(b) {
            Some(b)
        } else {
            None
        }
    }
}

pub(crate) fn cover(a: DVec2, b: DVec2, p: DVec2, q: DVec2, tol: f64) -> Option<Cover> {
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

/// The pieces of `a`-`b` outside every cover, each longer than `tol`,
/// added to `out` from `a` towards `b`.
pub(crate) fn uncovered(a: DVec2, b: DVec2, covers: &mut [Cover], tol: f64, out: &mut Vec<Piece>) {
    let len = a.distance(b);
    if covers.is_empty() {
        out.push((a, b));
        return;
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
}

/// A segment that can be compared: finite ends, not a point.
pub(crate) fn drawable(a: DVec2, b: DVec2) -> bool {
    a.is_finite() && b.is_finite() && a != b
}

/// Direction bucket of a segment over the half turn (either way round is the
/// same direction), and the bucket beside it when the direction is within
/// [`MAX_ANGLE`] (and some slack) of their border.
///
/// Found by the sign of the cross product with the buckets' borders rather
/// than by an arc tangent (the first pass takes every segment of the
/// drawing through here): a guess from a pseudo-angle, put right by the
/// borders on either side.
fn bucket(a: DVec2, b: DVec2) -> (usize, Option<usize>) {
    let mut d = b - a;
    // The half turn [0, pi): the same direction, pointing up.
    if d.y < 0.0 || (d.y == 0.0 && d.x < 0.0) {
        d = -d;
    }
    let borders = &*BORDERS;
    // 1 - cos-like pseudo-angle in [0, 2), monotone in the angle: within
    // two buckets of the true one.
    let pseudo = 1.0 - d.x / (d.x.abs() + d.y);
    let mut k = ((pseudo * 0.5 * ANGLE_BUCKETS as f64) as usize).min(ANGLE_BUCKETS - 1);
    // Direction at or after border k (counter-clockwise), and before k + 1.
    let after = |k: usize| borders[k].perp_dot(d) >= 0.0;
    while k > 0 && !after(k) {
        k -= 1;
    }
    while k + 1 < ANGLE_BUCKETS && after(k + 1) {
        k += 1;
    }
    // Within the angle `NEAR` of a border: the sine of the angle to it
    // against NEAR, squared (no square root); NEAR is a hair above its own
    // sine, so this errs towards the side bucket.
    let near = |border: DVec2| {
        let c = border.perp_dot(d);
        c * c <= NEAR * NEAR * d.length_squared()
    };
    let side = if near(borders[k]) {
        Some((k + ANGLE_BUCKETS - 1) % ANGLE_BUCKETS)
    } else if near(borders[k + 1]) {
        Some((k + 1) % ANGLE_BUCKETS)
    } else {
        None
    };
    (k, side)
}

/// How close (radians) to a bucket's border a direction gets the bucket
/// beside it too: [`MAX_ANGLE`] and room for rounding. Below half a bucket
/// (0.049), so at most one side is ever near.
const NEAR: f64 = MAX_ANGLE + 1e-3;

/// Largest slope (offset across over extent along) of a segment in its
/// frame for it to have that frame and no other ([`bucket`]): the tangent of
/// the frame's half width (pi/64) less [`NEAR`] and room for rounding
/// (0.002), 0.0261, rounded down.
const INSIDE_FRAME: f64 = 0.026;

/// The borders of the direction buckets over the half turn, `ANGLE_BUCKETS
/// + 1` unit vectors from angle 0 to pi.
static BORDERS: std::sync::LazyLock<Vec<DVec2>> = std::sync::LazyLock::new(|| {
    (0..=ANGLE_BUCKETS).map(|k| DVec2::from_angle(k as f64 * std::f64::consts::PI / ANGLE_BUCKETS as f64)).collect()
});

#[cfg(test)]
mod tests {
    use super::*;

    fn seg(a: (f64, f64), b: (f64, f64)) -> Polyline {
        Polyline::new(vec![DVec2::new(a.0, a.1), DVec2::new(b.0, b.1)])
    }

    /// A fixed sequence of numbers spread over [0, 1), from `seed`.
    fn numbers(seed: f64) -> impl FnMut() -> f64 {
        let mut x = seed;
        move || {
            x = (x * 7919.0 + 0.377).fract();
            x
        }
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
        let d = dedupe(input.clone(), 0.01);
        assert!((length(&d.polylines) - 120.0).abs() < 0.02, "{}", length(&d.polylines));
        assert!((d.removed_mm - (length(&input) - 120.0)).abs() < 0.02);
    }

    #[test]
    fn a_t_junction_draws_the_long_edge_only() {
        let input =
            vec![seg((0.0, 0.0), (4.0, 0.0)), seg((4.0, 0.0), (10.0, 0.0)), seg((0.0, 0.0), (10.0, 0.0)), seg((4.0, 0.0), (4.0, 5.0))];
        let d = dedupe(input.clone(), 0.01);
        assert!((length(&d.polylines) - 15.0).abs() < 1e-9);
        assert!((d.removed_mm - 10.0).abs() < 1e-9);
    }

    #[test]
    fn partial_overlap_is_cut_at_the_covering_end() {
        let input = vec![seg((0.0, 0.0), (10.0, 0.0)), seg((6.0, 0.004), (13.0, 0.004))];
        let d = dedupe(input.clone(), 0.01);
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
        let d = dedupe(input.clone(), 0.01);
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
        let d = dedupe(input.clone(), 0.01);
        assert_eq!(d.polylines, input);
        assert_eq!(d.removed_mm, 0.0);
        // Non-finite points pass through untouched.
        let broken =
            vec![Polyline::new(vec![DVec2::new(0.0, 0.0), DVec2::new(f64::NAN, 1.0), DVec2::new(0.0, 0.0)]), seg((0.0, 0.0), (1.0, 0.0))];
        let d = dedupe(broken.clone(), 0.01);
        assert_eq!(d.polylines.len(), 2);
        assert!(d.polylines[0].points[1].x.is_nan());
        assert_eq!(d.removed_mm, 0.0);
    }

    #[test]
    fn a_polyline_over_itself_keeps_one_pass() {
        // There and back along the same line, then off to the side.
        let input = vec![Polyline::new(vec![DVec2::new(0.0, 0.0), DVec2::new(10.0, 0.0), DVec2::new(2.0, 0.0), DVec2::new(2.0, 3.0)])];
        let d = dedupe(input.clone(), 0.01);
        assert!((length(&d.polylines) - 13.0).abs() < 1e-9, "{:?}", d.polylines);
        assert!((d.removed_mm - 8.0).abs() < 1e-9);
    }

    #[test]
    fn a_fold_tip_is_drawn_again_and_a_line_gone_back_over_is_not() {
        // A line that turns back on itself for 1.5 mm (at 0.2 degrees), then
        // goes off to the side: cutting the tip would leave a loose end on
        // each side of it, a pen lift for 1.5 mm of ink.
        let tip = vec![seg((0.0, 0.0), (10.0, 0.0)), seg((10.0, 0.0), (8.5, 0.005)), seg((8.5, 0.005), (8.5, 5.0))];
        let d = dedupe(tip.clone(), 0.01);
        assert_eq!(d.polylines, tip);
        assert_eq!(d.removed_mm, 0.0);
        // Past FOLD_TIP_MM the line has gone back over itself: drawn once.
        let back = vec![seg((0.0, 0.0), (10.0, 0.0)), seg((10.0, 0.0), (5.0, 0.005)), seg((5.0, 0.005), (5.0, 5.0))];
        let d = dedupe(back, 0.01);
        assert!((d.removed_mm - 5.0).abs() < 1e-4, "{}", d.removed_mm);
        // Copies of a short segment share both ends: no tip, drawn once.
        let copies = vec![seg((0.0, 0.0), (1.0, 0.0)), seg((1.0, 0.0), (0.0, 0.0)), seg((0.0, 0.0), (1.0, 0.004))];
        let d = dedupe(copies, 0.01);
        assert_eq!(d.polylines.len(), 1);
        assert!((d.removed_mm - 2.0).abs() < 1e-4, "{}", d.removed_mm);
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
        let d = dedupe(input.clone(), 0.01);
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
        let mut next = numbers(0.61);
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
        pass_one_finds_what_all_pairs_find(&input, tol, 300);
    }

    /// Pass 1 over `input` finds exactly the pairs of segments that
    /// comparing every pair finds, and there are more than `at_least`.
    fn pass_one_finds_what_all_pairs_find(input: &[Polyline], tol: f64, at_least: usize) {
        let view = Points::new(input);
        let found = overlapping(&view, tol);
        let first = &view.first;
        let points: Vec<DVec2> = input.iter().flat_map(|p| p.points.iter().copied()).collect();
        let segments: Vec<usize> = (0..input.len()).flat_map(|p| first[p]..first[p + 1] - 1).collect();
        let brute: Vec<(u32, u32)> = segments
            .iter()
            .enumerate()
            .flat_map(|(n, &i)| segments[n + 1..].iter().map(move |&j| (i, j)))
            .filter(|&(i, j)| {
                let ((a, b), (p, q)) = ((points[i], points[i + 1]), (points[j], points[j + 1]));
                cover(a, b, p, q, tol).is_some() || cover(p, q, a, b, tol).is_some()
            })
            .map(|(i, j)| (i as u32, j as u32))
            .collect();
        assert!(brute.len() > at_least, "the case overlaps too little to test: {}", brute.len());
        assert_eq!(found, brute);
    }

    #[test]
    fn a_segment_apart_from_a_line_is_never_covered_by_it() {
        // Segments of every direction, length and offset around the
        // tolerance, down to a relative 10^-9 of it: `apart` may say no
        // where a cover is missing, never yes where there is one.
        let tol = 0.01;
        let mut next = numbers(0.2718);
        let (mut said_apart, mut covered) = (0, 0);
        for _ in 0..200_000 {
            let angle = next() * std::f64::consts::TAU;
            let u = DVec2::from_angle(angle);
            let a = DVec2::new(next() * 100.0, next() * 100.0);
            let b = a + u * (next() * 3.0);
            let near = |x: f64| tol * (1.0 + (x - 0.5) * [2.0, 1e-3, 1e-9][(x * 3.0) as usize]);
            let along = |x: f64| (x - 0.3) * 4.0;
            let side = if next() < 0.5 { 1.0 } else { -1.0 };
            let p = a + u * along(next()) + u.perp() * side * near(next());
            let q = a + u * along(next()) + u.perp() * (if next() < 0.9 { side } else { -side }) * near(next());
            if apart(a, b, p, q, tol) {
                said_apart += 1;
                assert_eq!(cover(a, b, p, q, tol), None, "{a} {b} {p} {q}");
            }
            covered += usize::from(cover(a, b, p, q, tol).is_some());
        }
        assert!(said_apart > 3_000 && covered > 20_000, "{said_apart} apart, {covered} covered");
    }

    #[test]
    fn runs_along_long_polylines_find_every_overlapping_pair() {
        // Long, gently turning polylines (most segments continue the run of
        // the one before, across band borders, at every direction, some
        // turning back on themselves), each beside a copy within about the
        // tolerance that wanders off and back: pass 1 finds exactly the
        // pairs that comparing every pair of segments finds.
        let mut next = numbers(0.29);
        let tol = 0.01;
        let mut input: Vec<Polyline> = Vec::new();
        for k in 0..60 {
            let border = (k % 16) as f64 * std::f64::consts::PI / 16.0;
            let mut angle = if k % 2 == 0 { border + (next() - 0.5) * 0.05 } else { next() * std::f64::consts::PI };
            let mut at = DVec2::new(next() * 10.0, next() * 10.0);
            let mut line = vec![at];
            for i in 0..150 {
                angle += (next() - 0.5) * 0.03;
                // Now and then a step back along the way it came.
                let back = if k % 5 == 0 && i % 37 == 36 { -0.6 } else { 1.0 };
                at += DVec2::from_angle(angle) * back * (0.02 + next() * 0.3);
                line.push(at);
            }
            let side = DVec2::from_angle(angle).perp();
            let copy: Vec<DVec2> = line
                .iter()
                .enumerate()
                .map(|(i, &p)| p + side * (0.3 + 1.7 * ((i as f64) * 0.05).sin().abs()) * tol * if k % 3 == 0 { 1.0 } else { next() * 1.5 })
                .collect();
            input.push(Polyline::new(line));
            input.push(Polyline::new(copy));
        }
        pass_one_finds_what_all_pairs_find(&input, tol, 2000);
    }

    #[test]
    fn lines_turning_onto_a_frame_border_still_meet_across_it() {
        // Pairs of polylines of short segments, one from each side of a
        // frame border: each comes in well inside its frame (one run, in
        // that frame alone), then turns to run just beside the border,
        // crossing the other at a small angle. Both sides may not keep to
        // their own frame after the turn, or the two never meet; pass 1
        // finds exactly the pairs that comparing every pair finds.
        let mut next = numbers(0.43);
        let tol = 0.01;
        let mut input: Vec<Polyline> = Vec::new();
        for k in 0..64 {
            let border = (k % 16) as f64 * std::f64::consts::PI / 16.0;
            let centre = DVec2::new(next() * 10.0, next() * 10.0);
            let way = if k % 4 == 3 { -1.0 } else { 1.0 };
            for side in [-1.0, 1.0] {
                let inside = DVec2::from_angle(border + side * 0.04) * way;
                let beside = DVec2::from_angle(border + side * (0.004 + next() * 0.006)) * way;
                // The turn, a little before the crossing: a run goes on
                // until it leaves its band, a few tenths of a millimetre on.
                let turn = centre - beside * (0.1 + next() * 0.2) + beside.perp() * (next() - 0.5) * tol;
                let mut line: Vec<DVec2> = (0..10).map(|i| turn - inside * (1.0 - 0.1 * i as f64)).collect();
                let mut at = turn;
                while (at - centre).dot(beside) < 1.0 {
                    line.push(at);
                    at += beside * (0.03 + next() * 0.05);
                }
                input.push(Polyline::new(line));
            }
        }
        pass_one_finds_what_all_pairs_find(&input, tol, 1000);
    }

    /// How many pairs of segments pass 1 hands to pass 2 on `input`: the
    /// work and memory of `dedupe` beyond a pass over the segments.
    fn pairs_compared(input: Vec<Polyline>, tol: f64) -> usize {
        let (input, _) = crate::stacks::collapsed(input, tol);
        overlapping(&Points::new(&input), tol).len()
    }

    #[test]
    fn stacked_copies_cost_pairs_in_proportion_to_the_copies() {
        // Issue 42: a stack of k identical segments made k^2 / 2 pairs
        // (1,000 circles of 64 chords: 32 million; 10,000 squares: 200
        // million, more than 8 GiB). 1,000 circles, 2,000 squares (some
        // reversed) and 2,000 pieces of one line: at most a pair per copy.
        let circle: Vec<DVec2> =
            (0..=64).map(|k| DVec2::new(50.0, 50.0) + DVec2::from_angle(f64::from(k % 64) / 64.0 * std::f64::consts::TAU) * 20.0).collect();
        let mut input = vec![Polyline::new(circle); 1_000];
        let square = [(0.0, 0.0), (10.0, 0.0), (10.0, 10.0), (0.0, 10.0), (0.0, 0.0)].map(|(x, y)| DVec2::new(x + 100.0, y));
        for k in 0..2_000 {
            let mut points = square.to_vec();
            if k % 2 == 1 {
                points.reverse();
            }
            input.push(Polyline::new(points));
        }
        let mut next = numbers(0.17);
        for _ in 0..2_000 {
            let a = next() * 40.0;
            input.push(seg((a, 70.0), (a + 0.1 + next() * 30.0, 70.0)));
        }
        let copies = input.len();
        let pairs = pairs_compared(input, 0.01);
        assert!(pairs <= copies, "{pairs} pairs for {copies} copies");
    }

    #[test]
    fn direction_buckets_are_the_angle_over_the_half_turn() {
        // Against the arc tangent: the bucket is the angle's (either way
        // round), and the side bucket is there exactly when a border lies
        // within NEAR (a hair of rounding aside).
        let width = std::f64::consts::PI / ANGLE_BUCKETS as f64;
        let mut x = 0.123_f64;
        for i in 0..200_000 {
            x = (x * 7919.0 + 0.377).fract();
            // Half of them next to a border, on either side.
            let angle = if i % 2 == 0 { x * 2.0 * std::f64::consts::PI } else { (i % 129) as f64 * width + (x - 0.5) * 4.0 * NEAR };
            let d = DVec2::from_angle(angle) * (0.001 + 100.0 * x);
            let theta = d.y.atan2(d.x).rem_euclid(std::f64::consts::PI);
            let (k, side) = bucket(DVec2::new(3.0, -2.0), DVec2::new(3.0, -2.0) + d);
            let exact = theta / width;
            let nearest = exact.round();
            if (exact - nearest).abs() > 1e-9 {
                assert_eq!(k, (exact.floor() as usize).min(ANGLE_BUCKETS - 1), "angle {theta}");
            }
            let gap = (exact - nearest).abs() * width;
            if gap < NEAR - 1e-9 {
                let other = if nearest as usize > k { (k + 1) % ANGLE_BUCKETS } else { (k + ANGLE_BUCKETS - 1) % ANGLE_BUCKETS };
                assert_eq!(side, Some(other), "angle {theta}");
            } else if gap > NEAR + 1e-5 {
                assert_eq!(side, None, "angle {theta}");
            }
        }
    }
}
