//! Whole-module properties: nothing drawn changes, strokes meet the Euler
//! lower bound on graphs with known answers, ordering never loses to its
//! nearest-neighbour start.

use super::*;
use crate::{LineKind, Polyline};
use proptest::prelude::*;

fn seg(a: (f64, f64), b: (f64, f64)) -> Polyline {
    Polyline::new(vec![DVec2::new(a.0, a.1), DVec2::new(b.0, b.1)])
}

fn drawing(polylines: Vec<Polyline>) -> Drawing {
    let mut d = Drawing::new(297.0, 210.0);
    d.layer_mut(1, LineKind::Visible).polylines = polylines;
    d
}

/// Distance from `p` to the segment from `a` to `b`.
pub(crate) fn dist_to_segment(p: DVec2, a: DVec2, b: DVec2) -> f64 {
    let ab = b - a;
    let t = if ab.length_squared() == 0.0 { 0.0 } else { ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0) };
    p.distance(a + ab * t)
}

/// Every point of every segment of `from` lies within `tol` of `to`
/// (checked at 11 points per segment, brute force).
fn covered(from: &[Polyline], to: &[Polyline], tol: f64) -> bool {
    let to_segs: Vec<(DVec2, DVec2)> = to.iter().flat_map(|p| p.points.windows(2).map(|w| (w[0], w[1]))).collect();
    from.iter().flat_map(|p| p.points.windows(2)).all(|w| {
        (0..=10).all(|i| {
            let q = w[0].lerp(w[1], f64::from(i) / 10.0);
            to_segs.iter().any(|&(a, b)| dist_to_segment(q, a, b) <= tol)
        })
    })
}

/// The output draws the same lines as the input, each once.
fn assert_same_drawing(input: &[Polyline], output: &[Polyline], tol: f64) {
    let len_in: f64 = input.iter().map(Polyline::length).sum();
    let len_out: f64 = output.iter().map(Polyline::length).sum();
    let segments = input.iter().map(|p| p.points.len()).sum::<usize>() as f64;
    assert!((len_in - len_out).abs() <= 2.0 * tol * segments + 1e-9, "length {len_in} -> {len_out}");
    assert!(covered(input, output, tol + 1e-9), "an input segment is missing");
    assert!(covered(output, input, tol + 1e-9), "an output segment was not in the input");
}

fn strokes_of(input: Vec<Polyline>) -> Vec<Polyline> {
    let out = optimize(drawing(input.clone()), &StrokeOptions::default());
    let strokes = out.layers[0].polylines.clone();
    assert_same_drawing(&input, &strokes, DEFAULT_TOLERANCE_MM);
    strokes
}

#[test]
fn grid_needs_one_stroke_per_pair_of_odd_boundary_vertices() {
    // An n x m grid of unit cells as separate unit segments: the 2(n-1) +
    // 2(m-1) boundary vertices that are not corners have degree 3.
    for (n, m) in [(1, 1), (2, 1), (3, 4), (10, 7)] {
        let mut segs = Vec::new();
        for i in 0..=n {
            for j in 0..=m {
                let (x, y) = (f64::from(i) * 5.0, f64::from(j) * 5.0);
                if i < n {
                    segs.push(seg((x, y), (x + 5.0, y)));
                }
                if j < m {
                    segs.push(seg((x, y), (x, y + 5.0)));
                }
            }
        }
        let expected = ((n - 1) + (m - 1)).max(1) as usize;
        assert_eq!(strokes_of(segs).len(), expected, "{n} x {m} grid");
    }
}

#[test]
fn polylines_are_joined_at_their_ends_only() {
    // The rows and columns of a grid as whole polylines: they cross at inner
    // points shared by both, which are no vertices, so each inner one stays
    // a stroke of its own and the four outer ones, meeting at the corners by
    // their ends, one closed stroke (as separate unit segments the same grid
    // takes 2 + 3 strokes, above).
    let (n, m) = (3u32, 4u32);
    let mut polys = Vec::new();
    for i in 0..=n {
        polys.push(Polyline::new((0..=m).map(|j| DVec2::new(f64::from(i) * 5.0, f64::from(j) * 5.0)).collect()));
    }
    for j in 0..=m {
        polys.push(Polyline::new((0..=n).map(|i| DVec2::new(f64::from(i) * 5.0, f64::from(j) * 5.0)).collect()));
    }
    let out = strokes_of(polys);
    assert_eq!(out.len(), ((n - 1) + (m - 1) + 1) as usize);
    assert_eq!(out.iter().filter(|p| p.points.first() == p.points.last()).count(), 1);
    // One whose end meets another's end joins it; three ends at one vertex
    // make two strokes of the three lines.
    let out = strokes_of(vec![
        Polyline::new(vec![DVec2::new(0.0, 0.0), DVec2::new(5.0, 0.0), DVec2::new(10.0, 3.0)]),
        Polyline::new(vec![DVec2::new(10.0, 3.0), DVec2::new(12.0, 9.0)]),
        Polyline::new(vec![DVec2::new(20.0, 0.0), DVec2::new(15.0, 1.0), DVec2::new(10.004, 3.0)]),
    ]);
    assert_eq!(out.len(), 2);
}

#[test]
fn star_needs_half_its_odd_vertices() {
    for rays in [1, 2, 3, 8, 9, 40] {
        let segs: Vec<Polyline> = (0..rays)
            .map(|i| {
                let a = f64::from(i) / f64::from(rays) * std::f64::consts::TAU;
                seg((100.0 + 30.0 * a.cos(), 100.0 + 30.0 * a.sin()), (100.0, 100.0))
            })
            .collect();
        let expected = (rays as usize).div_ceil(2);
        assert_eq!(strokes_of(segs).len(), expected, "star with {rays} rays");
    }
}

fn circle(c: (f64, f64), r: f64, n: usize, offset: usize) -> Vec<Polyline> {
    let p = |i: usize| {
        let a = (i % n) as f64 / n as f64 * std::f64::consts::TAU;
        (c.0 + r * a.cos(), c.1 + r * a.sin())
    };
    (0..n).map(|i| seg(p(i + offset), p(i + offset + 1))).collect()
}

#[test]
fn disjoint_loops_are_one_closed_stroke_each() {
    let mut segs = Vec::new();
    for k in 0..6 {
        segs.extend(circle((20.0 + 40.0 * f64::from(k), 50.0), 10.0, 24, k as usize));
    }
    let out = strokes_of(segs);
    assert_eq!(out.len(), 6);
    assert!(out.iter().all(|p| p.points.first() == p.points.last()));
}

#[test]
fn figure_eight_is_one_closed_stroke() {
    // Two squares sharing a corner: the corner has degree 4.
    let sq = |x: f64| {
        vec![
            seg((x, 0.0), (x + 10.0, 0.0)),
            seg((x + 10.0, 0.0), (x + 10.0, 10.0)),
            seg((x + 10.0, 10.0), (x, 10.0)),
            seg((x, 10.0), (x, 0.0)),
        ]
    };
    let mut segs = sq(0.0);
    segs.extend(sq(-10.0).into_iter().map(|mut p| {
        p.points.iter_mut().for_each(|q| *q = DVec2::new(q.x, -q.y));
        p
    }));
    let out = strokes_of(segs);
    assert_eq!(out.len(), 1);
    assert_eq!(out[0].points.first(), out[0].points.last());
}

#[test]
fn near_misses_within_tolerance_are_joined_and_beyond_are_not() {
    let joined = strokes_of(vec![seg((0.0, 0.0), (10.0, 0.0)), seg((10.004, 0.003), (20.0, 5.0))]);
    assert_eq!(joined.len(), 1);
    let apart = strokes_of(vec![seg((0.0, 0.0), (10.0, 0.0)), seg((10.02, 0.0), (20.0, 5.0))]);
    assert_eq!(apart.len(), 2);
}

#[test]
fn collinear_pieces_become_one_segment() {
    let out = strokes_of((0..10).map(|i| seg((f64::from(i), 2.0), (f64::from(i + 1), 2.0))).collect());
    assert_eq!(out.len(), 1);
    assert_eq!(out[0].points.len(), 2);
}

/// A finely sampled line, as a fine surface's grid lines come from the
/// engine, is plotted with a vertex only where its chords need one, and
/// every input vertex lies within the simplification's tolerance of the
/// output. (The pairwise merge it replaced, at 1e-6 mm, kept 4,212 of the
/// arc's vertices and 13,334 of the line's.)
#[test]
fn fine_lines_are_plotted_with_the_vertices_they_need() {
    let arc: Vec<DVec2> = (0..=20_000).map(|k| DVec2::new(150.0, 100.0) + DVec2::from_angle(f64::from(k) * 1e-4) * 50.0).collect();
    let straight: Vec<DVec2> = (0..=20_000).map(|k| DVec2::new(10.0 + f64::from(k) * 1e-3, 5.0 + f64::from(k % 3) * 1e-4)).collect();
    let input = vec![Polyline::new(arc), Polyline::new(straight)];
    let out = strokes_of(input.clone());
    assert_eq!(out.len(), 2);
    let vertices: usize = out.iter().map(|p| p.points.len()).sum();
    // The arc: chords of sqrt(8 r tol) = 0.63 mm over 100 mm; the straight
    // line, jittering by a tenth of the tolerance: its two ends.
    assert!((159..=165).contains(&vertices), "{vertices} vertices");
    let segs: Vec<(DVec2, DVec2)> = out.iter().flat_map(|p| p.points.windows(2).map(|w| (w[0], w[1]))).collect();
    for q in input.iter().flat_map(|p| &p.points) {
        let d = segs.iter().map(|&(a, b)| dist_to_segment(*q, a, b)).fold(f64::MAX, f64::min);
        assert!(d <= SIMPLIFY_TOLERANCE_MM * (1.0 + 1e-9), "{q}: {d} mm from the output");
    }
}

#[test]
fn layers_stay_apart_in_order() {
    let mut d = Drawing::new(100.0, 100.0);
    d.layer_mut(2, LineKind::Visible).polylines.push(seg((0.0, 0.0), (1.0, 0.0)));
    d.layer_mut(1, LineKind::Hidden).polylines.push(seg((1.0, 0.0), (2.0, 0.0)));
    let out = optimize(d, &StrokeOptions::default());
    assert_eq!(out.layers.len(), 2);
    assert_eq!((out.layers[0].pen, out.layers[1].kind), (2, LineKind::Hidden));
    assert_eq!(out.stroke_count(), 2);
}

#[test]
fn ordering_beats_drawing_order_on_scattered_segments() {
    // Segments listed in a deliberately bad order: alternating far corners.
    let segs: Vec<Polyline> = (0..200)
        .map(|i| {
            let x = if i % 2 == 0 { f64::from(i) } else { 280.0 - f64::from(i) };
            seg((x, 10.0 + f64::from(i % 7)), (x + 0.5, 10.5 + f64::from(i % 7)))
        })
        .collect();
    let home = DVec2::ZERO;
    let raw = travel(&segs, home);
    let nn = travel(&order_nearest_neighbour(segs.clone(), home), home);
    let best = travel(&strokes_of(segs), home);
    assert!(nn < raw / 5.0, "nn {nn} raw {raw}");
    assert!(best <= nn + 1e-9, "improved {best} nn {nn}");
}

/// `n` segments 1-5 mm long at random on a 200 mm square (xorshift from
/// `seed`, so every run draws the same).
/// Uniform numbers in [0, 1) from a xorshift generator: the same for a seed.
fn unit_random(seed: u64) -> impl FnMut() -> f64 {
    let mut s = seed;
    move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn random_segments(n: usize, seed: u64) -> Vec<Polyline> {
    let mut next = unit_random(seed);
    (0..n)
        .map(|_| {
            let a = DVec2::new(5.0 + 190.0 * next(), 5.0 + 190.0 * next());
            let t = next() * std::f64::consts::TAU;
            Polyline::new(vec![a, a + DVec2::new(t.cos(), t.sin()) * (1.0 + 4.0 * next())])
        })
        .collect()
}

#[test]
fn improvement_reaches_strokes_far_along_the_tour() {
    // 20,000 random segments of 1-5 mm on a 200 mm square: the greedy tour
    // sweeps the page and comes back, so strokes side by side on the page
    // lie thousands of positions apart in it, and the moves that join them
    // are long. (With moves capped at 2,000 positions and every shifted
    // position charged a unit of the budget, the improver stopped 9 %
    // below the greedy tour; 2-opt with such moves gets some 25 %.)
    let segs = random_segments(20_000, 0x9E37_79B9_7F4A_7C15);
    let home = DVec2::ZERO;
    let nn = travel(&order_nearest_neighbour(segs.clone(), home), home);
    let best = travel(&order(segs, &StrokeOptions::default()), home);
    assert!(best < 0.8 * nn, "improved {best:.0} mm, greedy {nn:.0} mm");
}

#[test]
fn work_left_after_the_local_optimum_keeps_shortening_the_tour() {
    // 2,000 random segments: 2-opt and Or-opt reach a local optimum well
    // within 100 units a stroke. Before kicks, ten times that budget gave the
    // very same tour; now the rest goes to kicks, which find shorter tours.
    let segs = random_segments(2_000, 0x2545_F491_4F6C_DD1D);
    let home = DVec2::ZERO;
    let with = |units: u64| order(segs.clone(), &StrokeOptions { improve_budget: Some(units * 2_000), ..StrokeOptions::default() });
    let (local, kicked) = (with(100), with(1_000));
    assert_eq!(kicked.len(), segs.len());
    assert_same_drawing(&segs, &kicked, 1e-9);
    let (local, kicked) = (travel(&local, home), travel(&kicked, home));
    assert!(kicked < 0.98 * local, "kicked {kicked:.1} mm, local optimum {local:.1} mm");
}

#[test]
fn segments_drawn_in_part_over_others_are_still_drawn() {
    // Random segments 1-5 mm in a few directions, crowded into a small square
    // so that many run over one another for part of their length (what the
    // vpype bench's set a has some of). `dedupe` cuts such a segment where
    // the other already draws it, so it is no longer one output segment:
    // the vpype bench counted 21 such segments of set a "not found whole".
    // What must hold is that every point of every input segment is still
    // drawn, within twice the tolerance (removed near a kept segment, which
    // snapping may move by the tolerance again).
    let mut next = unit_random(0x0DDB_1A5E_5BAD_5EED);
    let segs: Vec<Polyline> = (0..1_500)
        .map(|_| {
            let a = DVec2::new(10.0 * next(), 10.0 * next());
            let t = (next() * 6.0).floor() * std::f64::consts::PI / 6.0 + (next() - 0.5) * 0.002;
            let b = a + DVec2::new(t.cos(), t.sin()) * (1.0 + 4.0 * next());
            // On a 0.005 mm lattice across, so that parallel ones often lie
            // within the tolerance of each other.
            let n = DVec2::new(-t.sin(), t.cos());
            let shift = n * ((a.dot(n) / 0.005).round() * 0.005 - a.dot(n));
            Polyline::new(vec![a + shift, b + shift])
        })
        .collect();
    let once = dedupe(segs.clone(), DEFAULT_TOLERANCE_MM);
    assert!(once.removed_mm > 50.0, "the case overlaps too little to test: {} mm", once.removed_mm);
    let out = optimize(drawing(segs.clone()), &StrokeOptions::default());
    let strokes: Vec<Polyline> = out.layers.iter().flat_map(|l| l.polylines.clone()).collect();
    assert!(covered(&segs, &strokes, 2.0 * DEFAULT_TOLERANCE_MM + 1e-6), "an input segment is no longer drawn");
    assert!(covered(&strokes, &segs, DEFAULT_TOLERANCE_MM + 1e-6), "an output segment was not in the input");
    assert!((out.drawn_length() - (segs.iter().map(Polyline::length).sum::<f64>() - once.removed_mm)).abs() < 1.0);
}

#[test]
fn budgets_are_deterministic() {
    let segs: Vec<Polyline> = (0..500)
        .map(f64::from)
        .map(|t| seg(((t * 37.1) % 290.0, (t * 53.7) % 200.0), ((t * 37.1) % 290.0 + 1.0, (t * 53.7) % 200.0 + 1.5)))
        .collect();
    let opts = StrokeOptions { improve_budget: Some(3_000), ..StrokeOptions::default() };
    let a = optimize(drawing(segs.clone()), &opts);
    let b = optimize(drawing(segs), &opts);
    assert_eq!(a, b);
}

/// A lattice point.
type Point = (i32, i32);

/// The unit lattice steps a segment covers (from one lattice point on it to
/// the next), each as an ordered pair.
fn unit_steps(&(a, b): &(Point, Point)) -> Vec<(Point, Point)> {
    fn gcd(a: i32, b: i32) -> i32 {
        if b == 0 {
            a.abs()
        } else {
            gcd(b, a % b)
        }
    }
    let g = gcd(b.0 - a.0, b.1 - a.1);
    if g == 0 {
        return Vec::new();
    }
    let d = ((b.0 - a.0) / g, (b.1 - a.1) / g);
    (0..g)
        .map(|k| {
            let p = (a.0 + k * d.0, a.1 + k * d.1);
            let q = (p.0 + d.0, p.1 + d.1);
            (p.min(q), p.max(q))
        })
        .collect()
}

/// `segs` without those that share some but not all of their unit steps
/// with an earlier one kept (exact duplicates stay).
fn without_partial_overlaps(segs: &[(Point, Point)]) -> Vec<(Point, Point)> {
    let mut kept: Vec<(Point, Point)> = Vec::new();
    for s in segs {
        let mine = unit_steps(s);
        let overlaps = kept.iter().any(|k| {
            let theirs = unit_steps(k);
            let same = (k.0.min(k.1), k.0.max(k.1)) == (s.0.min(s.1), s.0.max(s.1));
            !same && mine.iter().any(|m| theirs.contains(m))
        });
        if !overlaps {
            kept.push(*s);
        }
    }
    kept
}

/// The lower bound, computed independently: per connected component of the
/// segment graph (endpoints on an integer lattice, so no tolerance question),
/// max(1, odd vertices / 2).
fn euler_bound(segs: &[(Point, Point)]) -> usize {
    use std::collections::{BTreeMap, BTreeSet};
    let edges: BTreeSet<(Point, Point)> = segs.iter().filter(|(a, b)| a != b).map(|&(a, b)| (a.min(b), a.max(b))).collect();
    let mut parent: BTreeMap<Point, Point> = BTreeMap::new();
    let mut degree: BTreeMap<Point, usize> = BTreeMap::new();
    fn find(p: &mut BTreeMap<Point, Point>, v: Point) -> Point {
        let up = *p.entry(v).or_insert(v);
        if up == v {
            v
        } else {
            let r = find(p, up);
            p.insert(v, r);
            r
        }
    }
    for &(a, b) in &edges {
        *degree.entry(a).or_default() += 1;
        *degree.entry(b).or_default() += 1;
        let (ra, rb) = (find(&mut parent, a), find(&mut parent, b));
        parent.insert(ra, rb);
    }
    let mut odd: BTreeMap<Point, usize> = BTreeMap::new();
    for (&v, &d) in &degree {
        let r = find(&mut parent, v);
        *odd.entry(r).or_default() += d % 2;
    }
    odd.values().map(|&o| (o / 2).max(1)).sum()
}

/// Whether any two segments are parallel or at least twice
/// `dedupe::MAX_ANGLE` apart.
fn no_two_directions_nearly_parallel(raw: &[(Point, Point)]) -> bool {
    let dirs: Vec<(f64, f64)> = raw.iter().filter(|(a, b)| a != b).map(|(a, b)| (f64::from(b.0 - a.0), f64::from(b.1 - a.1))).collect();
    dirs.iter().enumerate().all(|(i, d)| {
        dirs[i + 1..].iter().all(|e| {
            let cross = d.0 * e.1 - d.1 * e.0;
            cross == 0.0 || cross.abs() / (d.0.hypot(d.1) * e.0.hypot(e.1)) > 2.0 * crate::dedupe::MAX_ANGLE.sin()
        })
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn random_lattice_segments(raw in proptest::collection::vec(((0..12i32, 0..9i32), (0..12i32, 0..9i32)), 0..60)) {
        // Crossing segments are fine: they are not joined (only endpoints
        // are), and exact duplicates are drawn once. Segments that overlap
        // another in part are cut by `dedupe` (a property of its own below).
        let raw: Vec<(Point, Point)> = without_partial_overlaps(&raw);
        let segs: Vec<Polyline> = raw
            .iter()
            .filter(|(a, b)| a != b)
            .map(|&(a, b)| seg((f64::from(a.0) * 3.0, f64::from(a.1) * 3.0), (f64::from(b.0) * 3.0, f64::from(b.1) * 3.0)))
            .collect();
        let mut unique: Vec<Polyline> = Vec::new();
        for s in &segs {
            let r = Polyline::new(s.points.iter().rev().copied().collect());
            if !unique.contains(s) && !unique.contains(&r) {
                unique.push(s.clone());
            }
        }
        // Two lattice directions can differ by less than `dedupe::MAX_ANGLE`
        // (7:1 and 8:1): crossing there they run within the tolerance for a
        // while and are cut. Also `dedupe`'s business.
        prop_assume!(dedupe(unique.clone(), DEFAULT_TOLERANCE_MM).removed_mm == 0.0);
        let out = optimize(drawing(segs), &StrokeOptions::default());
        let strokes: Vec<Polyline> = out.layers.iter().flat_map(|l| l.polylines.clone()).collect();
        assert_same_drawing(&unique, &strokes, 1e-9);
        prop_assert_eq!(strokes.len(), if unique.is_empty() { 0 } else { euler_bound(&raw) });
        let nn = travel(&order_nearest_neighbour(chain(&unique, &StrokeOptions::default()), DVec2::ZERO), DVec2::ZERO);
        prop_assert!(travel(&strokes, DVec2::ZERO) <= nn + 1e-9);
    }

    #[test]
    fn overlapping_lattice_segments_draw_their_union_once(raw in proptest::collection::vec(((0..8i32, 0..6i32), (0..8i32, 0..6i32)), 0..40)) {
        // On a lattice the union of the input is a set of unit steps,
        // computed without any geometry: the output draws exactly it.
        // Two lattice directions can differ by less than
        // `dedupe::MAX_ANGLE` (6:5 and 5:4): where they meet they run within
        // the tolerance for a while and are cut there, which the lattice
        // union does not know; such inputs are `dedupe`'s own tests' business.
        prop_assume!(no_two_directions_nearly_parallel(&raw));
        let steps: std::collections::BTreeSet<(Point, Point)> = raw.iter().flat_map(unit_steps).collect();
        let union: f64 = steps.iter().map(|(p, q)| 3.0 * f64::from((q.0 - p.0).pow(2) + (q.1 - p.1).pow(2)).sqrt()).sum();
        let segs: Vec<Polyline> = raw
            .iter()
            .filter(|(a, b)| a != b)
            .map(|&(a, b)| seg((f64::from(a.0) * 3.0, f64::from(a.1) * 3.0), (f64::from(b.0) * 3.0, f64::from(b.1) * 3.0)))
            .collect();
        let out = optimize(drawing(segs.clone()), &StrokeOptions::default());
        let strokes: Vec<Polyline> = out.layers.iter().flat_map(|l| l.polylines.clone()).collect();
        prop_assert!((out.drawn_length() - union).abs() < 1e-6, "drawn {} union {}", out.drawn_length(), union);
        prop_assert!(covered(&segs, &strokes, 1e-9));
        prop_assert!(covered(&strokes, &segs, 1e-9));
    }

    #[test]
    fn random_polylines_keep_their_lines(
        raw in proptest::collection::vec(proptest::collection::vec((0.0..50.0f64, 0.0..50.0f64), 2..6), 1..25),
        budget in 0u64..2000,
    ) {
        let polys: Vec<Polyline> = raw.iter().map(|v| Polyline::new(v.iter().map(|&(x, y)| DVec2::new(x, y)).collect())).collect();
        // Distinct points closer than the tolerance would be snapped together
        // (and near-identical segments drawn once): a different property.
        let all: Vec<DVec2> = polys.iter().flat_map(|p| p.points.clone()).collect();
        for (i, a) in all.iter().enumerate() {
            for b in &all[i + 1..] {
                prop_assume!(a == b || a.distance(*b) > 3.0 * DEFAULT_TOLERANCE_MM);
            }
        }
        // Random segments may run over each other at a shallow angle: cut by
        // `dedupe`, a different property.
        prop_assume!(dedupe(polys.clone(), DEFAULT_TOLERANCE_MM).removed_mm == 0.0);
        let opts = StrokeOptions { improve_budget: Some(budget), ..StrokeOptions::default() };
        let out = optimize(drawing(polys.clone()), &opts);
        let strokes = &out.layers[0].polylines;
        // A polyline may revisit its own vertices.
        prop_assert!(strokes.len() <= polys.len());
        prop_assert!((out.drawn_length() - polys.iter().map(Polyline::length).sum::<f64>()).abs() < 1e-6);
        prop_assert!(covered(&polys, strokes, 1e-9));
        prop_assert!(covered(strokes, &polys, 1e-9));
        let chained = chain(&polys, &opts);
        let nn = travel(&order_nearest_neighbour(chained, DVec2::ZERO), DVec2::ZERO);
        prop_assert!(travel(strokes, DVec2::ZERO) <= nn + 1e-9);
    }
}

/// The union of the intervals `[lo, hi]`, its total length.
fn union_length(mut intervals: Vec<(f64, f64)>) -> f64 {
    intervals.sort_by(|x, y| x.0.total_cmp(&y.0));
    let mut total = 0.0;
    let mut open: Option<(f64, f64)> = None;
    for (lo, hi) in intervals {
        match open {
            Some((s, e)) if lo <= e => open = Some((s, e.max(hi))),
            _ => {
                total += open.map_or(0.0, |(s, e)| e - s);
                open = Some((lo, hi));
            }
        }
    }
    total + open.map_or(0.0, |(s, e)| e - s)
}

#[test]
fn a_square_drawn_ten_thousand_times_is_one_square() {
    // Issue 42: an 830 KB HP-GL file drawing one square 10,000 times over
    // itself needed more than 8 GiB, as `dedupe` paired every copy of a
    // side with every other. Copies start at every corner, go either way
    // round, and the last thousand are one long polyline going round and
    // round.
    let corners = [DVec2::new(10.0, 10.0), DVec2::new(60.0, 10.0), DVec2::new(60.0, 60.0), DVec2::new(10.0, 60.0)];
    let mut input: Vec<Polyline> = (0..9_000)
        .map(|k| {
            let mut points: Vec<DVec2> = (0..=4).map(|i| corners[(i + k) % 4]).collect();
            if k % 3 == 0 {
                points.reverse();
            }
            Polyline::new(points)
        })
        .collect();
    input.push(Polyline::new((0..=4_000).map(|i| corners[i % 4]).collect()));
    let out = optimize(drawing(input.clone()), &StrokeOptions::default());
    let strokes = &out.layers[0].polylines;
    assert_eq!(strokes.len(), 1, "{} strokes", strokes.len());
    assert_eq!(strokes[0].points.first(), strokes[0].points.last());
    assert!((out.drawn_length() - 200.0).abs() < 1e-9, "drawn {} mm", out.drawn_length());
    assert!(covered(&input[..4], strokes, 1e-9) && covered(&input[9_000..], strokes, 1e-9) && covered(strokes, &input[..1], 1e-9));
}

#[test]
fn a_circle_drawn_a_thousand_times_is_one_circle() {
    // Issue 42: a 62 KB SVG of 1,000 identical circles took over 10 s.
    let circle: Vec<DVec2> =
        (0..=64).map(|k| DVec2::new(100.0, 80.0) + DVec2::from_angle(f64::from(k % 64) / 64.0 * std::f64::consts::TAU) * 25.0).collect();
    let one = Polyline::new(circle);
    let input = vec![one.clone(); 1_000];
    let out = optimize(drawing(input), &StrokeOptions::default());
    let strokes = &out.layers[0].polylines;
    assert_eq!(strokes.len(), 1, "{} strokes", strokes.len());
    assert!((out.drawn_length() - one.length()).abs() < 1e-9, "drawn {} mm of a {} mm circle", out.drawn_length(), one.length());
    assert!(covered(std::slice::from_ref(&one), strokes, 1e-9) && covered(strokes, &[one], 1e-9));
}

#[test]
fn a_stack_of_pieces_of_one_line_draws_their_union_once() {
    // 6,000 segments on one slanted line (and as many on a horizontal one),
    // of every length, overlapping each other in every way, some going
    // backwards: the output draws the union of each line once.
    let mut next = unit_random(0x5EED_0F57_AC4E_D5A1);
    let mut input = Vec::new();
    let mut slanted = Vec::new();
    let mut level = Vec::new();
    let (origin, way) = (DVec2::new(5.0, 7.0), DVec2::new(0.8, 0.6));
    for k in 0..12_000 {
        let (lo, hi) = {
            let a = next() * 150.0;
            let l = if k % 10 == 0 { 20.0 + next() * 60.0 } else { 0.05 + next() * 3.0 };
            (a, (a + l).min(150.0))
        };
        let (s, e) = if k % 4 == 1 { (hi, lo) } else { (lo, hi) };
        if k % 2 == 0 {
            input.push(Polyline::new(vec![origin + way * s, origin + way * e]));
            slanted.push((lo, hi));
        } else {
            input.push(Polyline::new(vec![DVec2::new(s, 120.0), DVec2::new(e, 120.0)]));
            level.push((lo, hi));
        }
    }
    let union = union_length(slanted) + union_length(level);
    let out = optimize(drawing(input.clone()), &StrokeOptions::default());
    let strokes: Vec<Polyline> = out.layers.iter().flat_map(|l| l.polylines.clone()).collect();
    // Gaps shorter than the tolerance between pieces may be left out.
    assert!((out.drawn_length() - union).abs() < 0.5, "drawn {} mm, the union is {union} mm", out.drawn_length());
    assert!(covered(&input, &strokes, 2.0 * DEFAULT_TOLERANCE_MM + 1e-6), "an input segment is no longer drawn");
    assert!(covered(&strokes, &input, 1e-9), "an output segment was not in the input");
}

/// The pen-up moves between consecutive strokes shorter than `tol` (the
/// trip from home and back aside).
fn lifts_to_nowhere(strokes: &[Polyline], tol: f64) -> usize {
    strokes.windows(2).filter(|w| w[0].points[w[0].points.len() - 1].distance(w[1].points[0]) <= tol).count()
}

#[test]
fn no_pen_lift_travels_nowhere() {
    // Issue 40: the lattice example lifted the pen 15 times of 101 to put
    // it down where it was. Closed loops touching other lines at a point
    // inside both stay strokes of their own, and ordering starts each where
    // the pen already is; a dot at a line's end likewise. A row of
    // squares, each with a line from a corner inside its outline and a dot
    // at that line's far end: every stroke that starts where the one before ended (within
    // the tolerance) is drawn on from it.
    let mut input = Vec::new();
    for k in 0..40 {
        let x = f64::from(k) * 10.0;
        let square = [(x + 2.0, 0.0), (x + 8.0, 0.0), (x + 8.0, 5.0), (x, 5.0), (x, 0.0), (x + 2.0, 0.0)];
        input.push(Polyline::new(square.iter().map(|&(x, y)| DVec2::new(x, y)).collect()));
        input.push(seg((x + 8.0, 5.0), (x + 9.0, 30.0)));
        input.push(seg((x + 9.0, 30.003), (x + 9.0, 30.003)));
    }
    let out = optimize(drawing(input.clone()), &StrokeOptions::default());
    let strokes = &out.layers[0].polylines;
    assert_eq!(lifts_to_nowhere(strokes, DEFAULT_TOLERANCE_MM), 0, "{} strokes", strokes.len());
    assert!(covered(&input, strokes, DEFAULT_TOLERANCE_MM) && covered(strokes, &input, DEFAULT_TOLERANCE_MM));
    assert!(strokes.len() <= 80, "{} strokes", strokes.len());
}

#[test]
fn a_line_folding_back_on_itself_is_one_stroke() {
    // A zigzag of two-point paths, each turning back 1.2 mm over the one
    // before at 0.4 degrees, then on: as a projected surface's grid line
    // folds behind a ridge. Cutting each tip (1.2 mm of ink) cost a pen
    // lift: 11 strokes before, one now, nothing lost or moved.
    let mut input = Vec::new();
    let mut at = DVec2::ZERO;
    for k in 0..10 {
        let y = f64::from(k) * 3.0;
        let (a, b, c) = (DVec2::new(0.0, y), DVec2::new(10.0, y), DVec2::new(8.8, y + 0.008));
        if k > 0 {
            input.push(Polyline::new(vec![at, a]));
        }
        input.push(Polyline::new(vec![a, b]));
        input.push(Polyline::new(vec![b, c]));
        at = c;
    }
    let out = optimize(drawing(input.clone()), &StrokeOptions::default());
    assert_eq!(out.stroke_count(), 1);
    let len: f64 = input.iter().map(Polyline::length).sum();
    assert!((out.drawn_length() - len).abs() < 1e-9, "{} of {len}", out.drawn_length());
}
