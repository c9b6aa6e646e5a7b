//! Loose ends joined again by drawing a removed overlap twice.
//!
//! Where [`crate::dedupe()`] cuts a line that ran over another for a while
//! (a surface's row and column edges where it folds out of sight project onto
//! one line; a line that turns back on itself), the cut line's kept parts end
//! on each side of the removed stretch: two loose ends, odd vertices of the
//! chaining graph, each the end of a stroke, so a pen lift and pen-up travel
//! between them. The removed stretch, drawn again with the pen down over the
//! line that already draws it, joins them instead.
//!
//! The choice is a Chinese-postman one, made greedily: among the removed
//! pieces (snapped at their ends within the tolerance, as chaining snaps),
//! find for every loose end (a place where an odd number of kept lines end)
//! its nearest [`PARTNERS`] loose ends along removed pieces within
//! [`REJOIN_MAX_MM`] (a bounded search, [`SEARCH_MAX`]), and join pairs
//! shortest first, each piece drawn again at
//! most once, while the length drawn again stays within [`REJOIN_SHARE`] of
//! the length kept. Each join makes both ends even: one stroke fewer (or, in
//! a piece of the drawing that had only those two ends, one closed stroke).

use crate::dedupe::Piece;
use crate::drawing::Polyline;
use crate::snap::{snap, NONE};
use glam::DVec2;
use rayon::prelude::*;
use rustc_hash::{FxHashMap, FxHashSet};
use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// Longest stretch (mm) drawn again to join two loose ends: a pen lift takes
/// as long as drawing 76 mm (the default motion model), and the pen-up move
/// between the two strokes is saved too.
pub const REJOIN_MAX_MM: f64 = 20.0;

/// Most that is drawn again over a layer, as a share of its kept length: a
/// pen drawn twice over a line wets the paper (and the drawing's checks hold
/// it to 0.1 %).
pub const REJOIN_SHARE: f64 = 0.01;

/// Most loose ends one loose end is weighed against: its nearest along
/// removed pieces. The pairing takes the shortest joins first, so a farther
/// partner matters only when every nearer one is taken; where folds leave a
/// dense web of removed pieces, every end within reach was millions of
/// pairs (a 2000 x 2000 surface filled 24 GB).
pub const PARTNERS: usize = 4;

/// Draws again the pieces of `removed` that join loose ends of `kept` (see
/// the module doc) and returns their indices into `removed`, ascending.
/// `kept` is what overlap removal kept; `tol` the snapping tolerance.
///
/// The way between two loose ends is drawn on from a kept line that ends
/// at one of them, as part of that polyline, not as pieces of its own: a
/// piece drawn again lies over a kept line, often between that line's very
/// vertices, and a straight segment between two vertices another straight
/// segment already joins is taken by chaining for the same line given
/// twice and drawn once, which would leave both ends loose (a 150 x 150
/// height field: 43 joins lost so, 328 strokes for some 300 lines). Only a
/// way with no whole polyline ending at either end (one cut by points that
/// cannot be drawn) is a polyline of its own.
pub(crate) fn rejoin(kept: &mut Vec<Polyline>, removed: &[Piece], tol: f64) -> Vec<usize> {
    let Reach { candidates, mut odd, pairs, kept_len, piece_vertex, mut kept_ends } = pairs_within_reach(kept, removed, tol);
    let budget = (REJOIN_SHARE * kept_len).max(REJOIN_MAX_MM);
    let mut spent = 0.0;
    let mut used = vec![false; candidates.len()];
    let mut chosen = Vec::new();
    for (d, s, t, path) in pairs {
        if spent + d > budget {
            break;
        }
        if !odd[s as usize] || !odd[t as usize] || path.iter().any(|&k| used[k as usize]) {
            continue;
        }
        odd[s as usize] = false;
        odd[t as usize] = false;
        spent += d;
        // The way's points from `s` to `t` (`path` runs from `t` back).
        let mut way: Vec<DVec2> = Vec::with_capacity(path.len() + 1);
        let mut at = s;
        for &k in path.iter().rev() {
            used[k as usize] = true;
            chosen.push(candidates[k as usize]);
            let (mut a, mut b) = removed[candidates[k as usize]];
            let [u, v] = piece_vertex[k as usize];
            if u != at {
                std::mem::swap(&mut a, &mut b);
            }
            at = if u == at { v } else { u };
            if way.last() != Some(&a) {
                way.push(a);
            }
            way.push(b);
        }
        if let Some(end) = kept_ends.take(s) {
            end.extend(kept, way);
        } else if let Some(end) = kept_ends.take(t) {
            way.reverse();
            end.extend(kept, way);
        } else {
            kept.push(Polyline::new(way));
        }
    }
    chosen.sort_unstable();
    chosen
}

/// One end of a kept polyline: its index, and whether it is the start.
#[derive(Clone, Copy)]
struct KeptEnd {
    line: u32,
    start: bool,
}

impl KeptEnd {
    /// `way` (from this end outwards) drawn on from this end of its line.
    fn extend(self, kept: &mut [Polyline], mut way: Vec<DVec2>) {
        let points = &mut kept[self.line as usize].points;
        if self.start {
            way.reverse();
            if way.last() == points.first() {
                way.pop();
            }
            way.extend_from_slice(points);
            *points = way;
        } else {
            let from = usize::from(points.last() == way.first());
            points.extend_from_slice(&way[from..]);
        }
    }
}

/// The ends of whole kept polylines at each snapped vertex, each to be
/// drawn on from once.
struct KeptEnds {
    /// (vertex, end), sorted by vertex.
    at: Vec<(u32, KeptEnd)>,
    taken: Vec<bool>,
}

impl KeptEnds {
    /// An end at vertex `v` not taken yet, now taken.
    fn take(&mut self, v: u32) -> Option<KeptEnd> {
        let from = self.at.partition_point(|&(w, _)| w < v);
        let i = (from..self.at.len()).take_while(|&i| self.at[i].0 == v).find(|&i| !self.taken[i])?;
        self.taken[i] = true;
        Some(self.at[i].1)
    }
}

/// The joins there are to choose from.
struct Reach {
    /// Indices into `removed` of the usable pieces (see [`usable`]); the
    /// pieces of a path are indices into this.
    candidates: Vec<usize>,
    /// Per snapped vertex: an odd number of kept lines end there.
    odd: Vec<bool>,
    /// `(length, from, to, pieces of the way)`, `from < to`, shortest first.
    pairs: Vec<(f64, u32, u32, Vec<u32>)>,
    /// The length of the kept lines.
    kept_len: f64,
    /// The snapped vertices of each candidate's two ends.
    piece_vertex: Vec<[u32; 2]>,
    /// The ends of whole kept polylines at the vertices.
    kept_ends: KeptEnds,
}

/// Each loose end's nearest loose ends along removed pieces (at most
/// [`PARTNERS`] of them, within [`REJOIN_MAX_MM`]).
fn pairs_within_reach(kept: &[Polyline], removed: &[Piece], tol: f64) -> Reach {
    let candidates: Vec<usize> = (0..removed.len()).filter(|&i| usable(removed[i], tol)).collect();
    if candidates.is_empty() {
        let kept_ends = KeptEnds { at: Vec::new(), taken: Vec::new() };
        return Reach { candidates, odd: Vec::new(), pairs: Vec::new(), kept_len: 0.0, piece_vertex: Vec::new(), kept_ends };
    }
    let tol = tol.max(1e-9);
    // Only kept ends near a removed piece's end can meet it: those in the
    // cells (twice the tolerance wide) of the pieces' ends or beside them.
    let cell_of = |p: DVec2| ((p.x / (2.0 * tol)).floor() as i64, (p.y / (2.0 * tol)).floor() as i64);
    let ends: FxHashSet<(i64, i64)> = candidates.iter().flat_map(|&i| [cell_of(removed[i].0), cell_of(removed[i].1)]).collect();
    let near = |p: DVec2| {
        let (x, y) = cell_of(p);
        (-1..=1).any(|dx| (-1..=1).any(|dy| ends.contains(&(x + dx, y + dy))))
    };
    let mut points: Vec<DVec2> = candidates.iter().flat_map(|&i| [removed[i].0, removed[i].1]).collect();
    let pieces = points.len();
    let mut kept_len = 0.0;
    // Per kept end pushed: the polyline's own end it is, if it is one.
    let mut whole_ends: Vec<Option<KeptEnd>> = Vec::new();
    for (line, p) in kept.iter().enumerate() {
        // As chaining reads them: runs of finite points, each an edge.
        for run in p.points.split(|q| !q.is_finite()).filter(|run| run.len() >= 2) {
            kept_len += run.windows(2).map(|w| w[0].distance(w[1])).sum::<f64>();
            let whole = run.len() == p.points.len();
            for (end, start) in [(run[0], true), (run[run.len() - 1], false)] {
                if near(end) {
                    points.push(end);
                    whole_ends.push(whole.then_some(KeptEnd { line: line as u32, start }));
                }
            }
        }
    }
    let snapped = snap(&points, tol);
    let n = snapped.vertices.len();
    let mut odd = vec![false; n];
    for &v in &snapped.vertex_of[pieces..] {
        if v != NONE {
            odd[v as usize] ^= true;
        }
    }
    let mut at: Vec<(u32, KeptEnd)> =
        snapped.vertex_of[pieces..].iter().zip(whole_ends).filter_map(|(&v, end)| Some((v, end?)).filter(|_| v != NONE)).collect();
    at.sort_by_key(|&(v, _)| v);
    let kept_ends = KeptEnds { taken: vec![false; at.len()], at };
    let piece_vertex: Vec<[u32; 2]> = (0..candidates.len()).map(|k| [snapped.vertex_of[2 * k], snapped.vertex_of[2 * k + 1]]).collect();
    // The removed pieces as a graph between the snapped vertices.
    let mut adj: Vec<Vec<(u32, u32)>> = vec![Vec::new(); n];
    let mut length = vec![0.0; candidates.len()];
    for (k, &i) in candidates.iter().enumerate() {
        let (u, v) = (snapped.vertex_of[2 * k], snapped.vertex_of[2 * k + 1]);
        if u == NONE || v == NONE || u == v {
            continue;
        }
        length[k] = removed[i].0.distance(removed[i].1);
        adj[u as usize].push((v, k as u32));
        adj[v as usize].push((u, k as u32));
    }
    let sources: Vec<u32> = (0..n as u32).filter(|&s| odd[s as usize] && !adj[s as usize].is_empty()).collect();
    let found: Vec<Vec<Join>> = sources
        .par_iter()
        .with_min_len(64)
        .map_init(Search::default, |search, &s| search.nearest_loose_ends(&adj, &length, &odd, s))
        .collect();
    // A pair found from both of its ends is weighed once, as its lower end
    // found it.
    let mut pairs: Vec<(f64, u32, u32, Vec<u32>)> = Vec::new();
    let mut seen: FxHashSet<(u32, u32)> = FxHashSet::default();
    for (&s, joins) in sources.iter().zip(found) {
        for (t, d, path) in joins {
            if seen.insert((s.min(t), s.max(t))) {
                pairs.push((d, s.min(t), s.max(t), path));
            }
        }
    }
    pairs.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)).then(x.2.cmp(&y.2)));
    Reach { candidates, odd, pairs, kept_len, piece_vertex, kept_ends }
}

/// A piece worth considering: finite, longer than the tolerance (a shorter
/// gap is joined by snapping alone) and within [`REJOIN_MAX_MM`].
fn usable((a, b): Piece, tol: f64) -> bool {
    let d = a.distance(b);
    a.is_finite() && b.is_finite() && d > tol && d <= REJOIN_MAX_MM
}

/// Most vertices one search settles: where removed pieces form a wide web
/// with few loose ends in it, the search stops there instead of covering
/// the web's every vertex within [`REJOIN_MAX_MM`].
pub const SEARCH_MAX: usize = 4096;

/// A loose end joined to another: `(other end, length, pieces of the way)`.
type Join = (u32, f64, Vec<u32>);

/// One thread's scratch for its searches, kept from one to the next.
#[derive(Default)]
struct Search {
    /// Per reached vertex: its distance and the piece and vertex it was
    /// reached by.
    best: FxHashMap<u32, (f64, u32, u32)>,
    heap: BinaryHeap<Reverse<(u64, u32)>>,
}

impl Search {
    /// The nearest loose ends (`odd`) to `s` along the pieces of `adj`, at
    /// most [`PARTNERS`] within [`REJOIN_MAX_MM`], each with its distance and
    /// the pieces of its shortest way (Dijkstra, at most [`SEARCH_MAX`]
    /// vertices settled; ties to the lower vertex, so deterministic).
    fn nearest_loose_ends(&mut self, adj: &[Vec<(u32, u32)>], length: &[f64], odd: &[bool], s: u32) -> Vec<Join> {
        self.best.clear();
        self.heap.clear();
        self.best.insert(s, (0.0, NONE, NONE));
        // Distances are finite and not negative: their bits order as they do.
        self.heap.push(Reverse((0, s)));
        let mut joins = Vec::new();
        let mut settled = 0;
        while let Some(Reverse((bits, v))) = self.heap.pop() {
            let d = f64::from_bits(bits);
            if self.best[&v].0 < d {
                continue; // reached again more cheaply since it was pushed
            }
            settled += 1;
            if v != s && odd[v as usize] {
                joins.push((v, d, self.way(s, v)));
                if joins.len() == PARTNERS {
                    break;
                }
            }
            if settled == SEARCH_MAX {
                break;
            }
            for &(w, k) in &adj[v as usize] {
                let dw = d + length[k as usize];
                if dw > REJOIN_MAX_MM {
                    continue;
                }
                if self.best.get(&w).is_none_or(|&(old, _, _)| dw < old) {
                    self.best.insert(w, (dw, k, v));
                    self.heap.push(Reverse((dw.to_bits(), w)));
                }
            }
        }
        joins
    }

    /// The pieces of the way found from `s` to `t`, from `t` back.
    fn way(&self, s: u32, t: u32) -> Vec<u32> {
        let mut path = Vec::new();
        let mut v = t;
        while v != s {
            let (_, k, from) = self.best[&v];
            path.push(k);
            v = from;
        }
        path
    }
}

#[cfg(test)]
mod tests {
    use crate::{optimize, DVec2, Drawing, LineKind, Polyline, StrokeOptions};

    fn drawing(lines: &[&[(f64, f64)]]) -> Drawing {
        let mut d = Drawing::new(100.0, 100.0);
        let l = d.layer_mut(1, LineKind::Visible);
        for line in lines {
            // Every edge its own path, as a wireframe is written.
            for w in line.windows(2) {
                l.polylines.push(Polyline::new(vec![DVec2::new(w[0].0, w[0].1), DVec2::new(w[1].0, w[1].1)]));
            }
        }
        d
    }

    fn drawn(d: &Drawing) -> f64 {
        d.layers.iter().flat_map(|l| &l.polylines).map(Polyline::length).sum()
    }

    /// A row and a column of a surface where it folds: the column comes up
    /// to the row, runs along it (within the tolerance) for two of its
    /// edges, 5.8 mm, and leaves it again. Overlap removal cuts the column's
    /// two edges on the row (longer than a fold's tip), which leaves the
    /// column in two pieces: three strokes for two lines. Drawn again, the
    /// 5.8 mm join them: two strokes.
    #[test]
    fn a_column_folded_onto_a_row_is_one_stroke_again() {
        let row: &[(f64, f64)] = &[(-5.0, 0.0), (0.0, 0.0), (3.0, 0.0), (6.0, 0.0), (9.0, 0.0)];
        let column: &[(f64, f64)] = &[(0.0, -5.0), (0.0, 0.0), (2.9, 0.003), (5.8, 0.004), (5.8, 5.0)];
        let d = drawing(&[row, column]);
        let input = drawn(&d);
        let out = optimize(d, &StrokeOptions::default());
        assert_eq!(out.stroke_count(), 2, "{:?}", out.layers[0].polylines);
        // Nothing removed: the overlap is drawn twice, as the input did.
        assert!((drawn(&out) - input).abs() < 1e-6, "{} of {input}", drawn(&out));
    }

    /// The fold where the overlap is one whole edge of each line: the
    /// column's edge along the row (0.004 mm off it, a hair longer) is kept,
    /// the row's edge under it removed, which leaves the row in two. Drawn
    /// again, that edge joins them, though it runs between the very
    /// vertices of the column's edge: it must not be taken for that edge
    /// given twice (which chaining draws once), or the row stays cut.
    #[test]
    fn a_rejoined_edge_over_a_kept_edge_with_the_same_ends_still_joins() {
        let row: &[(f64, f64)] = &[(-5.0, 0.0), (0.0, 0.0), (5.8, 0.0), (9.0, 0.0)];
        let column: &[(f64, f64)] = &[(0.0, -5.0), (0.0, 0.0), (5.8, 0.004), (5.8, 5.0)];
        let d = drawing(&[row, column]);
        let input = drawn(&d);
        let out = optimize(d, &StrokeOptions::default());
        assert_eq!(out.stroke_count(), 2, "{:?}", out.layers[0].polylines);
        assert!((drawn(&out) - input).abs() < 0.01, "{} of {input}", drawn(&out));
    }

    /// The same fold with the column's way along the row longer than
    /// REJOIN_MAX_MM: cut, three strokes, drawn once.
    #[test]
    fn a_fold_longer_than_the_limit_stays_cut() {
        let row: Vec<(f64, f64)> = (0..=12).map(|k| (f64::from(k) * 3.0 - 5.0, 0.0)).collect();
        let column: &[(f64, f64)] = &[(-2.0, -5.0), (-2.0, 0.0), (10.0, 0.003), (22.0, 0.004), (22.0, 5.0)];
        let d = drawing(&[&row, column]);
        let input = drawn(&d);
        let out = optimize(d, &StrokeOptions::default());
        assert_eq!(out.stroke_count(), 3, "{:?}", out.layers[0].polylines);
        assert!((input - drawn(&out) - 24.0).abs() < 0.01, "{} of {input}", drawn(&out));
    }

    /// A lattice of removed pieces 0.5 mm apart, 30 x 30 points, each point
    /// the loose end of a kept line: every end reaches hundreds of others
    /// within REJOIN_MAX_MM. The pairs weighed stay a few per end (the
    /// nearest), not every pair within reach (about 360,000 here; at a
    /// 2000 x 2000 surface's folds that filled 24 GB).
    #[test]
    fn a_dense_web_of_removed_pieces_weighs_a_few_partners_per_loose_end() {
        let n = 30;
        let at = |i: usize, j: usize| DVec2::new(i as f64 * 0.5, j as f64 * 0.5);
        let mut removed = Vec::new();
        let mut kept = Vec::new();
        for i in 0..n {
            for j in 0..n {
                if i + 1 < n {
                    removed.push((at(i, j), at(i + 1, j)));
                }
                if j + 1 < n {
                    removed.push((at(i, j), at(i, j + 1)));
                }
                kept.push(Polyline::new(vec![at(i, j), at(i, j) + DVec2::new(20.0, 46.0)]));
            }
        }
        let reach = super::pairs_within_reach(&kept, &removed, 0.05);
        let loose_ends = reach.odd.iter().filter(|&&odd| odd).count();
        assert_eq!(loose_ends, n * n);
        assert!(reach.pairs.len() <= super::PARTNERS * loose_ends, "{} pairs weighed for {loose_ends} loose ends", reach.pairs.len());
        // The nearest partners are enough: most loose ends are joined.
        let again = super::rejoin(&mut kept, &removed, 0.05);
        assert!(again.len() >= n * n * 2 / 5, "{} pieces drawn again", again.len());
    }
}
