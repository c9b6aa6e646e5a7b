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
//! the other loose ends reachable along removed pieces within
//! [`REJOIN_MAX_MM`], and join pairs shortest first, each piece drawn again at
//! most once, while the length drawn again stays within [`REJOIN_SHARE`] of
//! the length kept. Each join makes both ends even: one stroke fewer (or, in
//! a piece of the drawing that had only those two ends, one closed stroke).

use crate::dedupe::Piece;
use crate::drawing::Polyline;
use crate::snap::{snap, NONE};
use glam::DVec2;
use std::cmp::Reverse;
use std::collections::{BinaryHeap, HashMap, HashSet};

/// Longest stretch (mm) drawn again to join two loose ends: a pen lift takes
/// as long as drawing 76 mm (the default motion model), and the pen-up move
/// between the two strokes is saved too.
pub const REJOIN_MAX_MM: f64 = 20.0;

/// Most that is drawn again over a layer, as a share of its kept length: a
/// pen drawn twice over a line wets the paper (and the drawing's checks hold
/// it to 0.1 %).
pub const REJOIN_SHARE: f64 = 0.01;

/// The pieces of `removed` to draw again (see the module doc), as two-point
/// polylines, and the indices into `removed` of those chosen. `kept` is what
/// overlap removal kept; `tol` the snapping tolerance.
pub(crate) fn rejoin(kept: &[Polyline], removed: &[Piece], tol: f64) -> (Vec<Polyline>, Vec<usize>) {
    let candidates: Vec<usize> = (0..removed.len()).filter(|&i| usable(removed[i], tol)).collect();
    if candidates.is_empty() {
        return (Vec::new(), Vec::new());
    }
    let tol = tol.max(1e-9);
    // Only kept ends near a removed piece's end can meet it: the cells
    // (twice the tolerance wide) of those ends and their neighbours.
    let cell_of = |p: DVec2| ((p.x / (2.0 * tol)).floor() as i64, (p.y / (2.0 * tol)).floor() as i64);
    let mut near: HashSet<(i64, i64)> = HashSet::new();
    for &i in &candidates {
        for p in [removed[i].0, removed[i].1] {
            let (x, y) = cell_of(p);
            for dx in -1..=1 {
                for dy in -1..=1 {
                    near.insert((x + dx, y + dy));
                }
            }
        }
    }
    let mut points: Vec<DVec2> = candidates.iter().flat_map(|&i| [removed[i].0, removed[i].1]).collect();
    let pieces = points.len();
    let mut kept_len = 0.0;
    for p in kept {
        // As chaining reads them: runs of finite points, each an edge.
        for run in p.points.split(|q| !q.is_finite()).filter(|run| run.len() >= 2) {
            kept_len += run.windows(2).map(|w| w[0].distance(w[1])).sum::<f64>();
            for end in [run[0], run[run.len() - 1]] {
                if near.contains(&cell_of(end)) {
                    points.push(end);
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
    // Every pair of loose ends within reach along removed pieces: (length,
    // from, to, the pieces of the shortest way).
    let mut pairs: Vec<(f64, u32, u32, Vec<u32>)> = Vec::new();
    for s in 0..n as u32 {
        if odd[s as usize] && !adj[s as usize].is_empty() {
            for (to, d, path) in within_reach(&adj, &length, s) {
                if to > s && odd[to as usize] {
                    pairs.push((d, s, to, path));
                }
            }
        }
    }
    pairs.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)).then(x.2.cmp(&y.2)));
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
        for k in path {
            used[k as usize] = true;
            chosen.push(candidates[k as usize]);
        }
    }
    chosen.sort_unstable();
    let again = chosen.iter().map(|&i| Polyline::new(vec![removed[i].0, removed[i].1])).collect();
    (again, chosen)
}

/// A piece worth considering: finite, longer than the tolerance (a shorter
/// gap is joined by snapping alone) and within [`REJOIN_MAX_MM`].
fn usable((a, b): Piece, tol: f64) -> bool {
    let d = a.distance(b);
    a.is_finite() && b.is_finite() && d > tol && d <= REJOIN_MAX_MM
}

/// The vertices reachable from `s` along the pieces of `adj` within
/// [`REJOIN_MAX_MM`], each with its distance and the pieces of its shortest
/// way (Dijkstra; ties to the lower piece index, so deterministic).
fn within_reach(adj: &[Vec<(u32, u32)>], length: &[f64], s: u32) -> Vec<(u32, f64, Vec<u32>)> {
    // Distances are finite and not negative: their bits order as they do.
    let mut best: HashMap<u32, (f64, u32)> = HashMap::from([(s, (0.0, NONE))]);
    let mut heap = BinaryHeap::from([Reverse((0u64, s))]);
    let mut done: Vec<u32> = Vec::new();
    let mut settled: HashSet<u32> = HashSet::new();
    while let Some(Reverse((bits, v))) = heap.pop() {
        if !settled.insert(v) {
            continue;
        }
        done.push(v);
        let d = f64::from_bits(bits);
        for &(w, k) in &adj[v as usize] {
            let dw = d + length[k as usize];
            if dw > REJOIN_MAX_MM || settled.contains(&w) {
                continue;
            }
            if best.get(&w).is_none_or(|&(old, _)| dw < old) {
                best.insert(w, (dw, k));
                heap.push(Reverse((dw.to_bits(), w)));
            }
        }
    }
    let other = |k: u32, v: u32| adj[v as usize].iter().find(|&&(_, e)| e == k).map_or(NONE, |&(w, _)| w);
    done.into_iter()
        .skip(1)
        .map(|t| {
            let mut path = Vec::new();
            let mut v = t;
            while v != s {
                let k = best[&v].1;
                path.push(k);
                v = other(k, v);
            }
            (t, best[&t].0, path)
        })
        .collect()
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
}
