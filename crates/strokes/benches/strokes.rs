//! Stroke chaining and ordering on generated drawings: pen lifts and pen-up
//! travel before, after chaining and after ordering, against plain greedy
//! nearest neighbour, with timings. Prints a table; run with
//! `cargo bench -p strokes --bench strokes` (add `-- quick` to skip the
//! million-segment cases, or `-- 1M circles` for the drawings whose names
//! contain those words).
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

    let (t0, c0) = (Instant::now(), cpu_seconds());
    let chained = strokes::chain(&input, &opts);
    let (t_chain, c_chain) = (t0.elapsed().as_secs_f64(), cpu_seconds() - c0);
    let chained_travel = strokes::travel(&chained, home);
    let n_chained = chained.len();
    let nn = strokes::travel(&strokes::order_nearest_neighbour(chained.clone(), home), home);
    let (t1, c1) = (Instant::now(), cpu_seconds());
    let ordered = strokes::order(chained, &opts);
    let (t_order, c_order) = (t1.elapsed().as_secs_f64(), cpu_seconds() - c1);
    let final_travel = strokes::travel(&ordered, home);
    println!(
        "| {name:<22} | {segments:>9} | {:>9} / {raw:>10.0} | {plain:>9.0} | {n_chained:>8} / {chained_travel:>10.0} | {nn:>8.0} | {:>8} / {final_travel:>8.0} | {:>+6.1}% | {:>+6.1}% | {t_chain:>5.2} / {c_chain:>5.2} | {t_order:>5.2} / {c_order:>5.2} |",
        input.len(),
        ordered.len(),
        100.0 * (final_travel / plain - 1.0),
        100.0 * (final_travel / nn - 1.0),
    );
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).filter(|a| !a.starts_with("--")).collect();
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
    println!("| drawing                | segments  | raw: lifts / travel     | plain NN  | chained: lifts / travel | NN       | ordered: lifts / travel | vs plain | vs NN   | chain: wall / CPU | order: wall / CPU |");
    println!("|------------------------|-----------|-------------------------|-----------|-------------------------|----------|-------------------------|----------|---------|-------------------|-------------------|");
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
