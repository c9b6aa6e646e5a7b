//! Overlap removal, stroke chaining and ordering on generated drawings: pen
//! lifts and pen-up travel before, after chaining and after ordering, against
//! plain greedy nearest neighbour, with timings (and the length `dedupe`
//! removed). Prints a table; run with
//! `cargo bench -p strokes --bench strokes` (add `-- quick` to skip the
//! million-segment cases, or `-- 1M circles` for the drawings whose names
//! contain those words).
//!
//! `-- vpype` prints only the second table (`-- vpype d` only set d): the
//! three line sets vpype users benchmark ordering with and one of issue 41
//! (200 x 200 mm, fixed seeds), [`optimize`]d as
//! `plotd render` orders a drawing, beside vpype's figures on this machine
//! (`linemerge --tolerance 0.05mm linesort --two-opt` travel, plain
//! `linemerge linesort` time). With `VPYPE=path/to/vpype` set it also runs
//! that vpype on the very same sets and prints what it measures.
//!
//! [`optimize`]: strokes::optimize
//!
//! Baselines:
//! - "raw": the input in its given order and direction;
//! - "plain NN": greedy nearest neighbour over the raw input, each polyline
//!   entered at its first point (what a simple driver does);
//! - "NN": our starting tour: chained strokes, greedy over both ends of open
//!   strokes and every vertex of closed ones.

use kiddo::{KdTree, SquaredEuclidean};
use std::time::Instant;
use strokes::StrokeOptions;
use strokes::{DVec2, Polyline};

/// splitmix64: a small deterministic generator, so every run draws the same.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }
    fn shuffle<T>(&mut self, v: &mut [T]) {
        for i in (1..v.len()).rev() {
            v.swap(i, (self.next() % (i as u64 + 1)) as usize);
        }
    }
}

const A4: (f64, f64) = (297.0, 210.0);

fn seg(a: DVec2, b: DVec2) -> Polyline {
    Polyline::new(vec![a, b])
}

fn random_segments(n: usize, seed: u64) -> Vec<Polyline> {
    let mut r = Rng(seed);
    (0..n)
        .map(|_| {
            let a = DVec2::new(r.range(10.0, A4.0 - 10.0), r.range(10.0, A4.1 - 10.0));
            let t = r.range(0.0, std::f64::consts::TAU);
            seg(a, a + DVec2::new(t.cos(), t.sin()) * r.range(0.5, 3.0))
        })
        .collect()
}

fn random_circles(n: usize) -> Vec<Polyline> {
    let mut r = Rng(2);
    (0..n)
        .map(|_| {
            let c = DVec2::new(r.range(15.0, A4.0 - 15.0), r.range(15.0, A4.1 - 15.0));
            let rad = r.range(1.0, 8.0);
            let phase = r.range(0.0, 1.0);
            Polyline::new(
                (0..=48)
                    .map(|i| {
                        let a = (f64::from(i % 48) + phase) / 48.0 * std::f64::consts::TAU;
                        c + DVec2::new(a.cos(), a.sin()) * rad
                    })
                    .collect(),
            )
        })
        .collect()
}

/// A projected wavy z = f(x, y) surface, `n` x `n` grid lines, as the
/// hidden-line engine hands it over: separate visible segments, with gaps
/// where a smooth "occlusion" field says hidden, in scan order.
fn surface(n: usize) -> Vec<Polyline> {
    let f = |x: f64, y: f64| (x * 9.0).sin() * (y * 7.0).cos() * 0.08;
    let project = |i: usize, j: usize| {
        let (x, y) = (i as f64 / (n - 1) as f64, j as f64 / (n - 1) as f64);
        DVec2::new(20.0 + 200.0 * x + 50.0 * y, 20.0 + 110.0 * y + 160.0 * f(x, y) + 15.0 * x)
    };
    let hidden = |i: usize, j: usize| {
        let (x, y) = (i as f64 / n as f64, j as f64 / n as f64);
        ((x * 13.0).sin() + (y * 11.0 + x * 3.0).cos()) > 1.2
    };
    let mut out = Vec::new();
    for j in 0..n {
        for i in 0..n {
            if i + 1 < n && !hidden(i, j) {
                out.push(seg(project(i, j), project(i + 1, j)));
            }
            if j + 1 < n && !hidden(i, j) {
                out.push(seg(project(i, j), project(i, j + 1)));
            }
        }
    }
    out
}

/// A jittered triangulated mesh (every edge once, random direction), listed
/// in random order, as an "all edges" mesh render would be.
fn mesh(nx: usize, ny: usize) -> Vec<Polyline> {
    let mut r = Rng(3);
    let pts: Vec<DVec2> = (0..ny)
        .flat_map(|j| (0..nx).map(move |i| (i, j)))
        .map(|(i, j)| DVec2::new(15.0 + 265.0 * i as f64 / (nx - 1) as f64, 15.0 + 180.0 * j as f64 / (ny - 1) as f64))
        .map(|p| p + DVec2::new(r.range(-0.3, 0.3), r.range(-0.3, 0.3)))
        .collect();
    let id = |i: usize, j: usize| j * nx + i;
    let mut out = Vec::new();
    for j in 0..ny {
        for i in 0..nx {
            let mut edge = |a: usize, b: usize| out.push(if r.next() % 2 == 0 { seg(pts[a], pts[b]) } else { seg(pts[b], pts[a]) });
            if i + 1 < nx {
                edge(id(i, j), id(i + 1, j));
            }
            if j + 1 < ny {
                edge(id(i, j), id(i, j + 1));
            }
            if i + 1 < nx && j + 1 < ny {
                edge(id(i, j), id(i + 1, j + 1));
            }
        }
    }
    r.shuffle(&mut out);
    out
}

/// A statistical map: a hexagonal region outline (degree-3 vertices) and a
/// box symbol per region (seen from above at an angle: nine visible edges),
/// region by region.
fn map_like(cols: usize, rows: usize) -> Vec<Polyline> {
    let mut r = Rng(4);
    let s = 6.0;
    let mut out = Vec::new();
    for row in 0..rows {
        for col in 0..cols {
            let c = DVec2::new(20.0 + s * 1.5 * col as f64, 20.0 + s * 3f64.sqrt() * (row as f64 + 0.5 * (col % 2) as f64));
            let corner = |k: usize| {
                let a = k as f64 * std::f64::consts::FRAC_PI_3;
                // Round so that neighbouring hexagons share corners within the tolerance.
                let p = c + DVec2::new(a.cos(), a.sin()) * s;
                DVec2::new((p.x * 1e6).round() / 1e6, (p.y * 1e6).round() / 1e6)
            };
            for k in 0..6 {
                out.push(seg(corner(k), corner(k + 1)));
            }
            let h = r.range(0.5, 6.0);
            let w = 1.2;
            let (b0, b1, b2, b3) = (c + DVec2::new(-w, -w), c + DVec2::new(w, -w), c + DVec2::new(w, w), c + DVec2::new(-w, w));
            let up = DVec2::new(0.4 * h, h);
            for (a, b) in [(b0, b1), (b1, b2), (b0, b0 + up), (b1, b1 + up), (b2, b2 + up)] {
                out.push(seg(a, b));
            }
            for (a, b) in [(b0, b1), (b1, b2), (b2, b3), (b3, b0)] {
                out.push(seg(a + up, b + up));
            }
        }
    }
    out
}

/// Greedy nearest neighbour over the raw polylines, each entered at its first
/// point and drawn as given; returns the pen-up travel.
fn plain_nn_travel(polys: &[Polyline], home: DVec2) -> f64 {
    let mut tree: KdTree<f64, 2> = KdTree::with_capacity(polys.len());
    let mut by_point = std::collections::BTreeMap::new();
    for (i, p) in polys.iter().enumerate() {
        let s = p.points[0];
        let list: &mut Vec<usize> = by_point.entry((s.x.to_bits(), s.y.to_bits())).or_default();
        if list.is_empty() {
            tree.add(&[s.x, s.y], i as u64);
        }
        list.push(i);
    }
    let mut at = home;
    let mut travel = 0.0;
    let mut left = polys.len();
    while left > 0 {
        let i = tree.nearest_one::<SquaredEuclidean>(&[at.x, at.y]).item as usize;
        let s = polys[i].points[0];
        let list = by_point.get_mut(&(s.x.to_bits(), s.y.to_bits())).expect("indexed");
        let Some(j) = list.pop() else {
            // kiddo 5 failed to remove this point earlier: start afresh.
            tree = KdTree::with_capacity(left);
            for l in by_point.values().filter(|l| !l.is_empty()) {
                let p = polys[l[0]].points[0];
                tree.add(&[p.x, p.y], l[0] as u64);
            }
            continue;
        };
        if list.is_empty() {
            tree.remove(&[s.x, s.y], i as u64);
        }
        left -= 1;
        travel += at.distance(s);
        at = polys[j].points[polys[j].points.len() - 1];
    }
    travel + at.distance(home)
}

/// CPU seconds this process has used (user + system), from /proc: the
/// machine is shared, so wall-clock time overstates our cost.
fn cpu_seconds() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let after = stat.rsplit(')').next().unwrap_or("");
    let f: Vec<f64> = after.split_whitespace().map(|x| x.parse().unwrap_or(0.0)).collect();
    // Fields 14 and 15 of the file (utime, stime), in clock ticks of 1/100 s.
    if f.len() > 13 {
        (f[11] + f[12]) / 100.0
    } else {
        f64::NAN
    }
}

fn run(name: &str, input: Vec<Polyline>) {
    let opts = StrokeOptions::default();
    let home = opts.home;
    let segments: usize = input.iter().map(|p| p.points.len() - 1).sum();
    let raw = strokes::travel(&input, home);
    let plain = plain_nn_travel(&input, home);

    // As `optimize` does: simplified and overlaps out first, then chaining
    // and ordering.
    let mut copy = input.clone();
    let (td, cd) = (Instant::now(), cpu_seconds());
    strokes::simplify_polylines(&mut copy);
    let deduped = strokes::dedupe(copy, opts.tolerance_mm);
    let (t_dedupe, c_dedupe) = (td.elapsed().as_secs_f64(), cpu_seconds() - cd);
    let (t0, c0) = (Instant::now(), cpu_seconds());
    let chained = strokes::chain(&deduped.polylines, &opts);
    let (t_chain, c_chain) = (t0.elapsed().as_secs_f64(), cpu_seconds() - c0);
    let chained_travel = strokes::travel(&chained, home);
    let n_chained = chained.len();
    let nn = strokes::travel(&strokes::order_nearest_neighbour(chained.clone(), home), home);
    let (t1, c1) = (Instant::now(), cpu_seconds());
    let ordered = strokes::order(chained, &opts);
    let (t_order, c_order) = (t1.elapsed().as_secs_f64(), cpu_seconds() - c1);
    let final_travel = strokes::travel(&ordered, home);
    println!(
        "| {name:<22} | {segments:>9} | {:>9} / {raw:>10.0} | {plain:>9.0} | {n_chained:>8} / {chained_travel:>10.0} | {nn:>8.0} | {:>8} / {final_travel:>8.0} | {:>+6.1}% | {:>+6.1}% | {t_chain:>5.2} / {c_chain:>5.2} | {t_order:>5.2} / {c_order:>5.2} | {t_dedupe:>5.2} / {c_dedupe:>5.2} / {:>7.1} |",
        input.len(),
        ordered.len(),
        100.0 * (final_travel / plain - 1.0),
        100.0 * (final_travel / nn - 1.0),
        deduped.removed_mm,
    );
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).filter(|a| !a.starts_with("--")).collect();
    if args.iter().any(|a| a == "vpype") {
        // Other arguments pick sets by their letter.
        let picks: Vec<&str> = args.iter().map(String::as_str).filter(|a| *a != "vpype").collect();
        vpype_sets::run(&picks);
        return;
    }
    let quick = args.iter().any(|a| a == "quick");
    // Other arguments pick the drawings whose name contains one of them.
    let picks: Vec<&String> = args.iter().filter(|a| *a != "quick").collect();
    let run = |name: &str, make: &dyn Fn() -> Vec<Polyline>| {
        if picks.is_empty() || picks.iter().any(|p| name.contains(p.as_str())) {
            run(name, make());
        }
    };
    println!("pen lifts = strokes; travel in mm of pen-up movement from home (0, 0) through all strokes and back");
    println!("times: wall / CPU seconds (the machine is shared; CPU time is what the work costs)");
    println!("| drawing                | segments  | raw: lifts / travel     | plain NN  | chained: lifts / travel | NN       | ordered: lifts / travel | vs plain | vs NN   | chain: wall / CPU | order: wall / CPU | simplify + dedupe: wall / CPU / removed mm |");
    println!("|------------------------|-----------|-------------------------|-----------|-------------------------|----------|-------------------------|----------|---------|-------------------|-------------------|--------------------------------|");
    run("random 20k segments", &|| random_segments(20_000, 1));
    run("2k random circles", &|| random_circles(2_000));
    run("surface 300 x 300", &|| surface(300));
    run("mesh 200 x 140", &|| mesh(200, 140));
    run("map 40 x 20 regions", &|| map_like(40, 20));
    if !quick {
        run("random 1M segments", &|| random_segments(1_000_000, 5));
        run("surface 708 x 708 (1M)", &|| surface(708));
    }
}

/// The ordering-quality comparison with vpype (`-- vpype`).
mod vpype_sets {
    use super::{cpu_seconds, Rng};
    use std::time::Instant;
    use strokes::{DVec2, Drawing, LineKind, Polyline, StrokeOptions};

    /// Makes one line set.
    type MakeSet = fn() -> Vec<Polyline>;

    /// Side of the square page, mm.
    const PAGE: f64 = 200.0;

    /// vpype 1.15 on this machine (2 cores): pen-up travel (mm, between
    /// strokes) after `linemerge --tolerance 0.05mm linesort --two-opt`, and
    /// wall seconds of plain `linemerge linesort`; a-c from the issue (idle),
    /// d measured with `VPYPE` at load 12 (its time inflated by that).
    const TARGETS: [(&str, f64, f64); 4] = [("a", 13_377.0, 10.9), ("b", 311.0, 11.9), ("c", 6_278.0, 3.5), ("d", 287.0, 59.9)];

    /// a) 20,000 random segments, 1 to 5 mm long, anywhere on the page.
    pub fn segments() -> Vec<Polyline> {
        let mut r = Rng(19);
        (0..20_000)
            .map(|_| {
                let a = DVec2::new(r.range(5.0, PAGE - 5.0), r.range(5.0, PAGE - 5.0));
                let t = r.range(0.0, std::f64::consts::TAU);
                Polyline::new(vec![a, a + DVec2::new(t.cos(), t.sin()) * r.range(1.0, 5.0)])
            })
            .collect()
    }

    /// b) A 150 x 150 grid wireframe of a wavy surface seen in perspective,
    /// fitted to the page, as 44,700 two-point paths in scan order.
    pub fn grid() -> Vec<Polyline> {
        let n = 150;
        let eye = [3.0, -4.0, 3.0f64];
        let project = |i: usize, j: usize| {
            let (x, y) = (i as f64 / (n - 1) as f64 * 2.0 - 1.0, j as f64 / (n - 1) as f64 * 2.0 - 1.0);
            let z = 0.25 * (3.0 * x).sin() * (2.0 * y).cos();
            // Perspective onto the plane facing the eye, looking at the origin.
            let d = [x - eye[0], y - eye[1], z - eye[2]];
            let f = [-eye[0], -eye[1], -eye[2]];
            let fl = (f[0] * f[0] + f[1] * f[1] + f[2] * f[2]).sqrt();
            let f = [f[0] / fl, f[1] / fl, f[2] / fl];
            let right = [f[1], -f[0], 0.0];
            let rl = (right[0] * right[0] + right[1] * right[1]).sqrt();
            let right = [right[0] / rl, right[1] / rl, 0.0];
            let up = [right[1] * f[2], -right[0] * f[2], right[0] * f[1] - right[1] * f[0]];
            let depth = d[0] * f[0] + d[1] * f[1] + d[2] * f[2];
            let sx = (d[0] * right[0] + d[1] * right[1]) / depth;
            let sy = (d[0] * up[0] + d[1] * up[1] + d[2] * up[2]) / depth;
            DVec2::new(sx, sy)
        };
        let pts: Vec<DVec2> = (0..n).flat_map(|j| (0..n).map(move |i| (i, j))).map(|(i, j)| project(i, j)).collect();
        grid_edges(&pts, n)
    }

    /// d) A set plotd was never tuned on (issue 41): a 150 x 150 height
    /// field, a hill and ripples with noise (z += 0.01 N(0, 1)), seen in
    /// perspective from low enough that the far slopes fold behind the near
    /// ones, fitted to the page, every grid edge its own two-point path
    /// (44,700), in scan order with each point's row and column edges
    /// interleaved.
    pub fn height_field() -> Vec<Polyline> {
        let n = 150;
        let mut r = Rng(41);
        let mut normal = || {
            // Box-Muller.
            let (u, v) = (r.unit().max(f64::MIN_POSITIVE), r.unit());
            (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
        };
        let eye = glam::DVec3::new(2.6, -3.4, 1.5);
        let forward = (-eye).normalize();
        let right = forward.cross(glam::DVec3::Z).normalize();
        let up = right.cross(forward);
        let pts: Vec<DVec2> = (0..n * n)
            .map(|k| {
                let (i, j) = (k % n, k / n);
                let (x, y) = (i as f64 / (n - 1) as f64 * 2.0 - 1.0, j as f64 / (n - 1) as f64 * 2.0 - 1.0);
                let z = 0.5 * (-2.0 * (x * x + y * y)).exp() + 0.12 * (4.0 * x + 1.0).sin() * (3.0 * y).cos() + 0.01 * normal();
                let d = glam::DVec3::new(x, y, z) - eye;
                let depth = d.dot(forward);
                DVec2::new(d.dot(right) / depth, d.dot(up) / depth)
            })
            .collect();
        grid_edges(&pts, n)
    }

    /// The `n` x `n` projected grid points `pts` (row by row) fitted to the
    /// page with a 10 mm margin, every grid edge its own two-point path, in
    /// scan order with each point's row and column edges interleaved.
    fn grid_edges(pts: &[DVec2], n: usize) -> Vec<Polyline> {
        let (lo, hi) = pts.iter().fold((DVec2::INFINITY, DVec2::NEG_INFINITY), |(lo, hi), &p| (lo.min(p), hi.max(p)));
        let scale = (PAGE - 20.0) / (hi - lo).max_element();
        let place = |p: DVec2| (p - lo) * scale + DVec2::splat(10.0);
        let mut out = Vec::with_capacity(2 * n * (n - 1));
        for j in 0..n {
            for i in 0..n {
                let p = place(pts[j * n + i]);
                if i + 1 < n {
                    out.push(Polyline::new(vec![p, place(pts[j * n + i + 1])]));
                }
                if j + 1 < n {
                    out.push(Polyline::new(vec![p, place(pts[(j + 1) * n + i])]));
                }
            }
        }
        out
    }

    /// c) 2,000 circles of 65 points (64 chords, closed), radius 1 to 10 mm.
    pub fn circles() -> Vec<Polyline> {
        let mut r = Rng(20);
        (0..2_000)
            .map(|_| {
                let rad = r.range(1.0, 10.0);
                let c = DVec2::new(r.range(rad, PAGE - rad), r.range(rad, PAGE - rad));
                let phase = r.range(0.0, std::f64::consts::TAU);
                Polyline::new(
                    (0..=64)
                        .map(|k| {
                            let a = phase + f64::from(k % 64) / 64.0 * std::f64::consts::TAU;
                            c + DVec2::new(a.cos(), a.sin()) * rad
                        })
                        .collect(),
                )
            })
            .collect()
    }

    /// Pen-up travel between consecutive strokes (as vpype's `stat` counts
    /// it: no trip from or back to a home position).
    fn between(polys: &[Polyline]) -> f64 {
        polys.windows(2).map(|w| w[0].points[w[0].points.len() - 1].distance(w[1].points[0])).sum()
    }

    /// Every input segment is still drawn: every point of it (sampled at
    /// a tenth of the tolerance at most) lies within twice the snapping
    /// tolerance and the simplification's of the output, which is what the
    /// stages promise (a dropped vertex lies within the simplification's
    /// tolerance of its segment, a part `dedupe` removed within the
    /// snapping tolerance of a kept, nearly parallel segment, and snapping
    /// moves that by at most the tolerance again). An
    /// input segment that overlapped another is drawn partly by its own kept
    /// piece and partly by the other, so it need not match one output segment
    /// whole. Returns the segments with a point farther than that.
    fn missing(input: &[Polyline], output: &[Polyline]) -> usize {
        use std::collections::HashMap;
        let reach = 2.0 * strokes::DEFAULT_TOLERANCE_MM + strokes::SIMPLIFY_TOLERANCE_MM + 1e-6;
        // Output segments by 1 mm cell, each in every cell its box (padded by
        // the reach) touches.
        let cell = |p: DVec2| (p.x.floor() as i64, p.y.floor() as i64);
        let segs: Vec<(DVec2, DVec2)> = output.iter().flat_map(|p| p.points.windows(2).map(|w| (w[0], w[1]))).collect();
        let mut cells: HashMap<(i64, i64), Vec<u32>> = HashMap::new();
        for (i, &(a, b)) in segs.iter().enumerate() {
            let (lo, hi) = (cell(a.min(b) - DVec2::splat(reach)), cell(a.max(b) + DVec2::splat(reach)));
            for x in lo.0..=hi.0 {
                for y in lo.1..=hi.1 {
                    cells.entry((x, y)).or_default().push(i as u32);
                }
            }
        }
        let near = |p: DVec2| {
            cells.get(&cell(p)).is_some_and(|list| {
                list.iter().any(|&i| {
                    let (a, b) = segs[i as usize];
                    let d = b - a;
                    let t = ((p - a).dot(d) / d.length_squared().max(f64::MIN_POSITIVE)).clamp(0.0, 1.0);
                    p.distance(a + d * t) <= reach
                })
            })
        };
        input
            .iter()
            .flat_map(|p| p.points.windows(2).map(|w| (w[0], w[1])))
            .filter(|&(a, b)| {
                let n = (a.distance(b) / (0.1 * strokes::DEFAULT_TOLERANCE_MM)).ceil().max(1.0) as usize;
                !(0..=n).all(|k| near(a.lerp(b, k as f64 / n as f64)))
            })
            .count()
    }

    fn svg(polys: &[Polyline]) -> String {
        // plotcode is not a dependency of this crate: a minimal writer.
        let mut s =
            format!("<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{PAGE}mm\" height=\"{PAGE}mm\" viewBox=\"0 0 {PAGE} {PAGE}\">\n");
        for p in polys {
            s.push_str("<polyline fill=\"none\" stroke=\"black\" points=\"");
            for q in &p.points {
                s.push_str(&format!("{:.4},{:.4} ", q.x, PAGE - q.y));
            }
            s.push_str("\"/>\n");
        }
        s.push_str("</svg>\n");
        s
    }

    /// Runs vpype on `polys`: (pen-up mm after `linemerge --tolerance 0.05mm
    /// linesort --two-opt`, its wall seconds, wall seconds of plain
    /// `linemerge linesort`).
    fn vpype(exe: &str, name: &str, polys: &[Polyline]) -> Option<(f64, f64, f64)> {
        let path = std::env::temp_dir().join(format!("plotd-vpype-{}-{name}.svg", std::process::id()));
        std::fs::write(&path, svg(polys)).ok()?;
        let run = |args: &[&str]| -> Option<(String, f64)> {
            let t = Instant::now();
            let out = std::process::Command::new(exe).arg("read").arg(&path).args(args).arg("stat").output().ok()?;
            Some((String::from_utf8_lossy(&out.stdout).into_owned(), t.elapsed().as_secs_f64()))
        };
        let (stat, two_opt_s) = run(&["linemerge", "--tolerance", "0.05mm", "linesort", "--two-opt"])?;
        let (_, plain_s) = run(&["linemerge", "linesort"])?;
        let _ = std::fs::remove_file(&path);
        // `Pen-up length: X` in CSS pixels (96 per inch), first occurrence (the layer's).
        let px: f64 = stat.lines().find_map(|l| l.trim().strip_prefix("Pen-up length:"))?.trim().parse().ok()?;
        Some((px * 25.4 / 96.0, two_opt_s, plain_s))
    }

    /// The default options, or with `BUDGET=N` that improvement budget (to
    /// see what more work would buy).
    fn options() -> StrokeOptions {
        let budget = std::env::var("BUDGET").ok().and_then(|b| b.parse().ok());
        StrokeOptions { improve_budget: budget.or(StrokeOptions::default().improve_budget), ..StrokeOptions::default() }
    }

    pub fn run(picks: &[&str]) {
        let exe = std::env::var("VPYPE").ok();
        let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
        println!("ordering quality: 200 x 200 mm, travel = pen-up mm between strokes (vpype's `stat`); load average {}", load.trim());
        println!(
            "target travel: below vpype `linemerge --tolerance 0.05mm linesort --two-opt`; target time: below vpype `linemerge linesort`"
        );
        println!(
            "| set                            | strokes in / out | travel mm | target mm | wall s / CPU s | target s | segments lost |"
        );
        println!(
            "|--------------------------------|------------------|-----------|-----------|----------------|----------|---------------|"
        );
        let sets: [(&str, MakeSet); 4] = [
            ("a) 20k random segments 1-5 mm", segments),
            ("b) 150 x 150 grid, 44,700 paths", grid),
            ("c) 2,000 circles of 65 points", circles),
            ("d) noisy height field, 44,700", height_field),
        ];
        let mut live = Vec::new();
        for ((name, make), (letter, target_mm, target_s)) in sets.into_iter().zip(TARGETS) {
            if !picks.is_empty() && !picks.contains(&letter) {
                continue;
            }
            let input = make();
            let mut d = Drawing::new(PAGE, PAGE);
            d.layer_mut(1, LineKind::Visible).polylines = input.clone();
            let (t0, c0) = (Instant::now(), cpu_seconds());
            let out = strokes::optimize(d, &options());
            let (wall, cpu) = (t0.elapsed().as_secs_f64(), cpu_seconds() - c0);
            let polys = &out.layers[0].polylines;
            let travel = between(polys);
            let lost = missing(&input, polys);
            println!(
                "| {name:<30} | {:>7} / {:>6} | {travel:>9.0} | {target_mm:>9.0} | {wall:>6.2} / {cpu:>5.2} | {target_s:>8.1} | {lost:>13} |",
                input.len(),
                polys.len()
            );
            if let Some(exe) = &exe {
                live.push((name, vpype(exe, name.split(')').next().unwrap_or("x"), &input)));
            }
        }
        if !live.is_empty() {
            println!("\nvpype ({}) on the same sets:", exe.as_deref().unwrap_or(""));
            println!("| set                            | two-opt travel mm | two-opt wall s | plain wall s |");
            for (name, r) in live {
                match r {
                    Some((mm, two, plain)) => println!("| {name:<30} | {mm:>17.0} | {two:>14.1} | {plain:>12.1} |"),
                    None => println!("| {name:<30} | vpype failed |"),
                }
            }
        }
    }
}
