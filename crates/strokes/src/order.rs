//! Ordering: which stroke next, in which direction, and where a closed stroke
//! starts.
//!
//! The tour starts and ends at the home position. It begins as a greedy
//! nearest-neighbour tour over every possible entry point (both ends of an
//! open stroke, every vertex of a closed one), found with a cell grid (or a
//! k-d tree) from which taken strokes are removed; [`super::improve`] then
//! shortens it.

use super::cells::{bounds, morton};
use super::improve::{self, Tour};
use super::nearest::Nearest;
use super::{StrokeOptions, DEFAULT_BUDGET_CAP, DEFAULT_BUDGET_PER_STROKE};
use crate::drawing::Polyline;
use glam::DVec2;
use rayon::prelude::*;

/// Orders, directs and (for closed strokes) rotates `strokes` to shorten the
/// pen-up travel from `options.home` through all of them and back: a greedy
/// nearest-neighbour tour, then, if `options.improve`, 2-opt and Or-opt moves
/// within the work budget. The result is never longer than the
/// nearest-neighbour tour, and holds exactly the same strokes (some reversed,
/// closed ones possibly starting at another vertex), but that a stroke that
/// starts within `options.tolerance_mm` of where the one before it ends is
/// drawn on from it, one stroke with it (no pen lift travels nowhere).
/// Polylines with fewer than two points draw nothing and are dropped.
#[must_use]
pub fn order(strokes: Vec<Polyline>, options: &StrokeOptions) -> Vec<Polyline> {
    let strokes = drawable_in_page_order(strokes);
    let plan = plan(&strokes, options);
    applied(&plan, strokes, options)
}

/// The order [`order`] draws `strokes` in (drawable ones, in page order:
/// [`drawable_in_page_order`]), found without taking them, so that other
/// work may read them meanwhile ([`crate::optimize_beside`]).
pub(crate) fn plan(strokes: &[Polyline], options: &StrokeOptions) -> Plan {
    let home = options.home;
    if !options.improve || strokes.is_empty() {
        return nearest_neighbour(strokes, home);
    }
    // The improver's candidate lists depend only on where strokes end, and
    // an open stroke's ends are known before the tour is: then the lists
    // are found on the other core while the (sequential) greedy tour runs.
    // A closed stroke's end is the vertex the tour enters it by.
    let budget = options.improve_budget.unwrap_or(DEFAULT_BUDGET_PER_STROKE.saturating_mul(strokes.len() as u64).min(DEFAULT_BUDGET_CAP));
    let closed = strokes.iter().any(is_closed);
    let (mut plan, near) = if budget == 0 || closed {
        (nearest_neighbour(strokes, home), None)
    } else {
        let ends: Vec<DVec2> =
            std::iter::once([home, home]).chain(strokes.iter().map(|p| [p.points[0], p.points[p.points.len() - 1]])).flatten().collect();
        let (plan, near) = rayon::join(|| nearest_neighbour(strokes, home), || improve::candidates(&ends));
        (plan, Some(near))
    };
    let mut tour = plan.tour(strokes, home);
    let near = match near {
        Some(near) => near,
        None if budget > 0 => improve::candidates(&tour.end_points()),
        None => Vec::new(),
    };
    // Re-seating loops changes their entry points; one more round can use
    // that, so with loops about it the budget is shared between two rounds
    // (the improver spends all it is given).
    let first = if closed { budget / 2 } else { budget };
    let left = improve::improve(&mut tour, first, &near) + (budget - first);
    if plan.reseat(strokes, &mut tour) && left > 0 {
        let near = improve::candidates(&tour.end_points());
        improve::improve(&mut tour, left, &near);
        plan.reseat(strokes, &mut tour);
    }
    plan.read_back(&tour);
    plan
}

/// `strokes` (as [`plan`] was given them) in the order of `plan`, joined
/// where one starts where the last ends.
pub(crate) fn applied(plan: &Plan, strokes: Vec<Polyline>, options: &StrokeOptions) -> Vec<Polyline> {
    joined(plan.apply(strokes), options)
}

/// `strokes` in their order, each one that starts within the tolerance of
/// where the one before it ends drawn on from there, as one stroke: a pen
/// lift there would travel nowhere, put an ink dot on the paper and cost a
/// real plotter a third of a second. (A closed loop that touches another
/// line at a point inside both, or a dot on a line, is a stroke of its own
/// after chaining, and the tour enters it where the pen already is.)
/// Vertices are simplified again where strokes join, as [`super::chain`]
/// does, if `options.simplify`.
fn joined(strokes: Vec<Polyline>, options: &StrokeOptions) -> Vec<Polyline> {
    let mut out: Vec<Polyline> = Vec::with_capacity(strokes.len());
    let mut grown: Vec<usize> = Vec::new();
    for stroke in strokes {
        if let Some(last) = out.last_mut() {
            let end = last.points[last.points.len() - 1];
            if end.distance(stroke.points[0]) <= options.tolerance_mm {
                let from = usize::from(end == stroke.points[0]);
                last.points.extend_from_slice(&stroke.points[from..]);
                if grown.last() != Some(&(out.len() - 1)) {
                    grown.push(out.len() - 1);
                }
                continue;
            }
        }
        out.push(stroke);
    }
    if options.simplify {
        for i in grown {
            super::simplify::simplify(&mut out[i].points, super::simplify::SIMPLIFY_TOLERANCE_MM);
        }
    }
    out
}

/// Greedy nearest-neighbour order only (entry point of each stroke chosen
/// greedily, no improvement): the baseline [`order`] starts from.
#[must_use]
pub fn order_nearest_neighbour(strokes: Vec<Polyline>, home: DVec2) -> Vec<Polyline> {
    let strokes = drawable_in_page_order(strokes);
    nearest_neighbour(&strokes, home).apply(strokes)
}

/// The strokes that draw something (two points or more), sorted along a
/// Z-order curve by first point. The order of the input only breaks ties,
/// but every array below is indexed by stroke: with strokes near each other
/// on the page near each other in memory, the searches and the improver read
/// memory almost in sequence instead of at random (several times faster on
/// a million strokes).
pub(crate) fn drawable_in_page_order(strokes: Vec<Polyline>) -> Vec<Polyline> {
    let mut strokes: Vec<Polyline> = strokes.into_iter().filter(|p| p.points.len() >= 2).collect();
    let (lo, hi) = bounds(strokes.iter().map(|p| p.points[0]));
    let scale = 65535.0 / (hi - lo).max_element().max(f64::MIN_POSITIVE);
    strokes.par_sort_by_cached_key(|p| {
        let q = ((p.points[0] - lo) * scale).max(DVec2::ZERO);
        // `as` saturates, and sends NaN to 0.
        morton(q.x as u32, q.y as u32)
    });
    strokes
}

fn is_closed(p: &Polyline) -> bool {
    p.points.len() >= 3 && p.points.first() == p.points.last()
}

/// An order of strokes, with direction and start vertex.
pub(crate) struct Plan {
    /// Stroke indices in drawing order.
    seq: Vec<u32>,
    /// Open strokes: drawn from last point to first.
    flip: Vec<bool>,
    /// Closed strokes: the vertex they start and end at.
    seat: Vec<u32>,
}

fn nearest_neighbour(strokes: &[Polyline], home: DVec2) -> Plan {
    let n = strokes.len();
    // Candidate entry points: (stroke, vertex index).
    let mut cand: Vec<(u32, u32)> = Vec::with_capacity(2 * n);
    let mut positions = Vec::with_capacity(2 * n);
    let mut cand_start = Vec::with_capacity(n + 1);
    let mut closed = Vec::with_capacity(n);
    for (s, p) in strokes.iter().enumerate() {
        cand_start.push(cand.len() as u32);
        let last = p.points.len() - 1;
        closed.push(is_closed(p));
        if is_closed(p) {
            for (k, q) in p.points[..last].iter().enumerate() {
                cand.push((s as u32, k as u32));
                positions.push(*q);
            }
        } else {
            cand.push((s as u32, 0));
            positions.push(p.points[0]);
            cand.push((s as u32, last as u32));
            positions.push(p.points[last]);
        }
    }
    cand_start.push(cand.len() as u32);
    let mut nearest = Nearest::new(&positions, home);
    let mut plan = Plan { seq: Vec::with_capacity(n), flip: vec![false; n], seat: vec![0; n] };
    let mut at = home;
    for _ in 0..n {
        let entry = nearest.nearest(at).expect("a stroke is left, so a live entry point is");
        let (s, k) = cand[entry];
        plan.seq.push(s);
        // The exit from the candidate arrays, not the stroke: its points lie
        // elsewhere on the heap, one cache miss per stroke.
        if closed[s as usize] {
            plan.seat[s as usize] = k;
            at = positions[entry];
        } else {
            let flip = k != 0;
            plan.flip[s as usize] = flip;
            at = positions[cand_start[s as usize] as usize + usize::from(!flip)];
        }
        for c in cand_start[s as usize]..cand_start[s as usize + 1] {
            nearest.take(c as usize);
        }
    }
    plan
}

impl Plan {
    /// The tour as the improver sees it: node 0 is home, node `s + 1` is stroke `s`.
    fn tour(&self, strokes: &[Polyline], home: DVec2) -> Tour {
        let n = strokes.len() + 1;
        let mut a = Vec::with_capacity(n);
        let mut b = Vec::with_capacity(n);
        let mut closed = Vec::with_capacity(n);
        a.push(home);
        b.push(home);
        closed.push(false);
        for (s, p) in strokes.iter().enumerate() {
            if is_closed(p) {
                let q = p.points[self.seat[s] as usize];
                a.push(q);
                b.push(q);
                closed.push(true);
            } else {
                a.push(p.points[0]);
                b.push(p.points[p.points.len() - 1]);
                closed.push(false);
            }
        }
        let order: Vec<u32> = std::iter::once(0).chain(self.seq.iter().map(|&s| s + 1)).collect();
        let mut flip = vec![false; n];
        for (s, &f) in self.flip.iter().enumerate() {
            flip[s + 1] = f;
        }
        Tour::new(order, flip, a, b)
    }

    /// Moves every closed stroke's start to the vertex nearest its
    /// neighbours in the tour; true if any moved.
    fn reseat(&mut self, strokes: &[Polyline], tour: &mut Tour) -> bool {
        let mut moved = false;
        for p in 1..tour.len() {
            let node = tour.node(p);
            let stroke = &strokes[node - 1];
            if !is_closed(stroke) {
                continue;
            }
            let before = tour.exit(tour.node(tour.pred(p)));
            let after = tour.entry(tour.node(tour.succ(p)));
            let cost = |q: DVec2| before.distance(q) + q.distance(after);
            let pts = &stroke.points[..stroke.points.len() - 1];
            let current = self.seat[node - 1] as usize;
            let mut best = (cost(pts[current]), current);
            for (k, &q) in pts.iter().enumerate() {
                let c = cost(q);
                if c < best.0 - super::MIN_GAIN_MM {
                    best = (c, k);
                }
            }
            if best.1 != current {
                self.seat[node - 1] = best.1 as u32;
                tour.set_point(node, pts[best.1]);
                moved = true;
            }
        }
        moved
    }

    /// Takes order and directions from an improved tour.
    fn read_back(&mut self, tour: &Tour) {
        self.seq = (1..tour.len()).map(|p| tour.node(p) as u32 - 1).collect();
        // Home may have been moved in the cycle only by rotations, never
        // here: position 0 is fixed.
        for s in 0..self.flip.len() {
            self.flip[s] = tour.flipped(s + 1);
        }
    }

    /// The strokes in this plan's order, direction and start vertex.
    fn apply(&self, strokes: Vec<Polyline>) -> Vec<Polyline> {
        let mut slots: Vec<Option<Polyline>> = strokes.into_iter().map(Some).collect();
        self.seq
            .iter()
            .map(|&s| {
                let mut p = slots[s as usize].take().expect("each stroke once");
                if is_closed(&p) {
                    let k = self.seat[s as usize] as usize;
                    if k != 0 {
                        p.points.pop();
                        p.points.rotate_left(k);
                        p.points.push(p.points[0]);
                    }
                    if self.flip[s as usize] {
                        p.reverse();
                    }
                } else if self.flip[s as usize] {
                    p.reverse();
                }
                p
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::travel;

    fn pl(pts: &[(f64, f64)]) -> Polyline {
        Polyline::new(pts.iter().map(|&(x, y)| DVec2::new(x, y)).collect())
    }

    #[test]
    fn picks_nearest_end_and_reverses() {
        let out = order_nearest_neighbour(vec![pl(&[(10.0, 0.0), (1.0, 0.0)]), pl(&[(20.0, 0.0), (11.0, 0.0)])], DVec2::ZERO);
        assert_eq!(out, vec![pl(&[(1.0, 0.0), (10.0, 0.0)]), pl(&[(11.0, 0.0), (20.0, 0.0)])]);
    }

    #[test]
    fn closed_stroke_starts_at_nearest_vertex() {
        let sq = pl(&[(5.0, 5.0), (6.0, 5.0), (6.0, 6.0), (5.0, 6.0), (5.0, 5.0)]);
        let out = order_nearest_neighbour(vec![sq.clone()], DVec2::new(7.0, 7.0));
        assert_eq!(out[0].points[0], DVec2::new(6.0, 6.0));
        assert_eq!(out[0].points.first(), out[0].points.last());
        assert!((out[0].length() - sq.length()).abs() < 1e-12);
    }

    #[test]
    fn many_strokes_sharing_an_endpoint() {
        // 100 rays out of one point: too many for one k-d tree bucket.
        let rays: Vec<Polyline> = (0..100).map(|i| f64::from(i) * 0.0628).map(|a| pl(&[(0.0, 0.0), (a.cos(), a.sin())])).collect();
        let out = order(rays.clone(), &StrokeOptions::default());
        // Rays that meet end to start are drawn as one stroke.
        let len = |v: &[Polyline]| v.iter().map(Polyline::length).sum::<f64>();
        assert!(out.len() <= 100 && (len(&out) - len(&rays)).abs() < 1e-9);
        assert!(travel(&out, DVec2::ZERO) <= travel(&order_nearest_neighbour(rays, DVec2::ZERO), DVec2::ZERO) + 1e-9);
    }

    #[test]
    fn survives_failed_kd_tree_removals() {
        // Hexagon outlines on a grid with rounded corners: many endpoints
        // share coordinates exactly, which trips kiddo 5's removal.
        let s = 6.0;
        let mut segs = Vec::new();
        for row in 0..20 {
            for col in 0..40 {
                let c = DVec2::new(20.0 + s * 1.5 * f64::from(col), 20.0 + s * 3f64.sqrt() * (f64::from(row) + 0.5 * f64::from(col % 2)));
                let corner = |k: i32| {
                    let a = f64::from(k) * std::f64::consts::FRAC_PI_3;
                    let p = c + DVec2::new(a.cos(), a.sin()) * s;
                    ((p.x * 1e6).round() / 1e6, (p.y * 1e6).round() / 1e6)
                };
                for k in 0..6 {
                    segs.push(pl(&[corner(k), corner(k + 1)]));
                }
            }
        }
        // One segment far away crowds the rest into one grid cell, so the
        // k-d tree path does the search.
        segs.push(pl(&[(1e6, 1e6), (1e6 + 1.0, 1e6)]));
        let out = order_nearest_neighbour(segs.clone(), DVec2::ZERO);
        assert_eq!(out.len(), segs.len());
        let len = |v: &[Polyline]| v.iter().map(Polyline::length).sum::<f64>();
        assert!((len(&out) - len(&segs)).abs() < 1e-6);
        let improved = order(segs.clone(), &StrokeOptions::default());
        assert!((len(&improved) - len(&segs)).abs() < 1e-6);
        assert!(travel(&improved, DVec2::ZERO) <= travel(&out, DVec2::ZERO) + 1e-9);
    }

    /// Greedy nearest neighbour by brute force: from `home`, always the
    /// untaken open stroke with the nearest end, entered there.
    fn brute_force_nn(strokes: &[Polyline], home: DVec2) -> Vec<Polyline> {
        let mut left: Vec<Polyline> = strokes.to_vec();
        let mut at = home;
        let mut out = Vec::new();
        while !left.is_empty() {
            let (i, rev) = (0..left.len())
                .flat_map(|i| [(i, false), (i, true)])
                .min_by(|&(i, r), &(j, q)| {
                    let end = |k: usize, r: bool| if r { left[k].points[left[k].points.len() - 1] } else { left[k].points[0] };
                    at.distance(end(i, r)).total_cmp(&at.distance(end(j, q)))
                })
                .expect("strokes left");
            let mut p = left.swap_remove(i);
            if rev {
                p.reverse();
            }
            at = p.points[p.points.len() - 1];
            out.push(p);
        }
        out
    }

    fn scattered(n: usize, seed: u64, place: impl Fn(f64, f64) -> DVec2) -> Vec<Polyline> {
        let mut s = seed;
        let mut next = move || {
            s = s.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        (0..n)
            .map(|_| {
                let a = place(next(), next());
                let t = next() * std::f64::consts::TAU;
                Polyline::new(vec![a, a + DVec2::new(t.cos(), t.sin()) * (0.2 + next())])
            })
            .collect()
    }

    #[test]
    fn greedy_tour_is_the_brute_force_one_on_grid_and_tree_searches() {
        // Spread over a page: the cell grid answers.
        let spread = scattered(6000, 11, |x, y| DVec2::new(x * 280.0, y * 200.0));
        // All but one in a 2 mm speck, one far away: the grid is refused
        // and a k-d tree answers.
        let mut speck = scattered(3000, 12, |x, y| DVec2::new(100.0 + 2.0 * x, 100.0 + 2.0 * y));
        speck.push(Polyline::new(vec![DVec2::new(900.0, 900.0), DVec2::new(901.0, 900.0)]));
        for input in [spread, speck] {
            let want = brute_force_nn(&input, DVec2::ZERO);
            assert_eq!(order_nearest_neighbour(input, DVec2::ZERO), want);
        }
    }

    #[test]
    fn empty_and_pointless_input() {
        assert!(order(Vec::new(), &StrokeOptions::default()).is_empty());
        assert!(order(vec![pl(&[(1.0, 1.0)]), pl(&[])], &StrokeOptions::default()).is_empty());
    }
}
