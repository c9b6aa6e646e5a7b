//! Grid engine benchmark: prints a table of time and memory per facet.
//!
//! `cargo bench -p scene --bench grid` (add `-- quick` to skip 2000 x 2000,
//! `-- size=N heights=smooth|random` for one grid).
//! Grids of 100^2 .. 2000^2 points, smooth and random heights, seen obliquely
//! in perspective from above. Memory is the peak of bytes allocated during
//! the run, counted by a wrapping global allocator. The first table compares
//! the engines on one thread each (CPU time of that thread); the second gives
//! the grid engine's wall time as a render runs it (the picture's two halves
//! swept at once) and the CPU time of all the process's threads (best of 5
//! timed blocks up to 300 x 300, of 3 above; a block runs a small grid
//! several times);
//! the summary lines give the spread of ns per facet across sizes, and the
//! load average is printed because the machine may be shared.

use hiddenline::grid::{visible_lines, Grid, GridLines};
use hiddenline::{Camera, DVec3, Projection};
use scene::{ModelBuilder, Surface};
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

struct Counting;
static CURRENT: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        let now = CURRENT.fetch_add(l.size(), Ordering::Relaxed) + l.size();
        PEAK.fetch_max(now, Ordering::Relaxed);
        unsafe { System.alloc(l) }
    }
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        CURRENT.fetch_sub(l.size(), Ordering::Relaxed);
        unsafe { System.dealloc(p, l) }
    }
    unsafe fn realloc(&self, p: *mut u8, l: Layout, new: usize) -> *mut u8 {
        if new > l.size() {
            let now = CURRENT.fetch_add(new - l.size(), Ordering::Relaxed) + new - l.size();
            PEAK.fetch_max(now, Ordering::Relaxed);
        } else {
            CURRENT.fetch_sub(l.size() - new, Ordering::Relaxed);
        }
        unsafe { System.realloc(p, l, new) }
    }
}

#[global_allocator]
static A: Counting = Counting;

/// Deterministic pseudo-random heights (xorshift).
fn random(n: usize) -> Grid {
    let mut s = 0x9E37_79B9_7F4A_7C15u64;
    let xs = Grid::linspace(-2.0, 2.0, n - 1);
    let z = (0..n * n)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64 * 0.6
        })
        .collect();
    Grid::new(xs.clone(), xs, z).expect("valid grid")
}

fn smooth(n: usize) -> Grid {
    let xs = Grid::linspace(-2.0, 2.0, n - 1);
    Grid::from_fn(xs.clone(), xs, |x, y| 0.6 * (-(x * x + y * y)).exp() + 0.15 * (3.0 * x).sin() * (2.0 * y).cos()).expect("valid grid")
}

fn camera() -> Camera {
    Camera::new(DVec3::new(5.0, -6.5, 4.0), DVec3::new(0.0, 0.0, 0.0), DVec3::Z, Projection::Perspective { fov_deg: 35.0 })
        .expect("valid camera")
}

/// Nanoseconds this thread has spent on a CPU (Linux `schedstat`): the
/// machine is shared, so wall time alone overstates the cost when other
/// processes compete for the cores. `None` where unavailable.
fn cpu_ns() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    s.split_whitespace().next()?.parse().ok()
}

/// Nanoseconds all of this process's threads have spent on a CPU (their
/// `schedstat`s summed): the grid engine sweeps the two halves of the
/// picture on two threads of rayon's pool. `None` where unavailable.
fn process_cpu_ns() -> Option<u64> {
    let mut sum = 0;
    for task in std::fs::read_dir("/proc/self/task").ok()? {
        let s = std::fs::read_to_string(task.ok()?.path().join("schedstat")).ok()?;
        sum += s.split_whitespace().next()?.parse::<u64>().ok()?;
    }
    Some(sum)
}

/// The machine's load average (`/proc/loadavg`), printed with the tables:
/// the machine is shared, and CPU time still suffers from what else runs.
fn load() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map_or_else(|_| "unknown".into(), |s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
}

/// Runs per timed block: the thread's CPU clock is only brought up to date
/// at scheduler events, so a block of a few milliseconds can read as zero;
/// small grids are run several times per block and the time divided.
fn reps_for(n: usize) -> usize {
    if n <= 150 {
        20
    } else if n <= 400 {
        3
    } else {
        1
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let quick = args.iter().any(|a| a == "quick");
    // `size=N` runs the grid engine on N x N only, `heights=smooth|random`
    // one kind of heights only (for profiling).
    let only: Option<usize> = args.iter().find_map(|a| a.strip_prefix("size=")?.parse().ok());
    let heights: Option<String> = args.iter().find_map(|a| Some(a.strip_prefix("heights=")?.to_string()));
    // The general engine on the same surfaces lowered to triangles, on one
    // thread (a one-worker rayon pool), against the grid engine: both as the
    // CPU time of the thread that ran them, so the ratio is CPU to CPU and
    // other processes on the machine do not count. Both give what the
    // renderer consumes, a `LineVisibility` (an interval list) per line, so
    // the grid engine's time here is `grid::visibility`'s, more than the
    // `visible_lines` (polylines) timed in the second table.
    println!("load average at start: {}", load());
    println!();
    println!("| grid | heights | general engine, 1 thread, CPU (s) | grid engine CPU (s) | speed-up |");
    println!("|---|---|---:|---:|---:|");
    let cam0 = camera();
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().expect("a one-thread pool");
    let secs = |a: Option<u64>, b: Option<u64>| match (a, b) {
        (Some(a), Some(b)) => (b - a) as f64 * 1e-9,
        _ => f64::NAN,
    };
    for &n in if only.is_some() { &[][..] } else { &[100usize, 300][..] } {
        for (name, make) in [("smooth", smooth as fn(usize) -> Grid), ("random", random)] {
            if heights.as_ref().is_some_and(|h| h != name) {
                continue;
            }
            let grid = make(n);
            let surface = Surface { grid, lines: GridLines::Both, every: 1, pen: 1 };
            let mut b = ModelBuilder::new();
            surface.lower(&mut b);
            let model = b.finish();
            // Best of three for both engines: the ratio is best to best.
            let g = one.install(|| {
                (0..3)
                    .map(|_| {
                        let c0 = cpu_ns();
                        let general = hiddenline::engine::visibility(&model, &cam0);
                        let c1 = cpu_ns();
                        drop(general);
                        secs(c0, c1)
                    })
                    .fold(f64::INFINITY, f64::min)
            });
            let mut f = f64::INFINITY;
            let reps = reps_for(n);
            for _ in 0..3 {
                f = f.min(one.install(|| {
                    let c0 = cpu_ns();
                    for _ in 0..reps {
                        drop(hiddenline::grid::visibility(&surface.grid, &cam0, GridLines::Both, 1));
                    }
                    secs(c0, cpu_ns()) / reps as f64
                }));
            }
            println!("| {n} x {n} | {name} | {g:.3} | {f:.4} | {:.0}x |", g / f);
        }
    }
    println!();
    let cam = camera();
    let one = [only.unwrap_or(0)];
    let sizes: &[usize] = if only.is_some() {
        &one
    } else if quick {
        &[100, 300, 1000]
    } else {
        &[100, 300, 1000, 2000]
    };
    // Per heights kind: (grid side, CPU ns per facet), for the flatness line.
    let mut per_facet: Vec<(&str, usize, f64)> = Vec::new();
    println!("| grid | heights | facets | wall (s) | CPU (s) | CPU ns / facet | peak memory (MB) | bytes / facet | visible polylines |");
    println!("|---|---|---:|---:|---:|---:|---:|---:|---:|");
    for &n in sizes {
        for (name, make) in [("smooth", smooth as fn(usize) -> Grid), ("random", random)] {
            if heights.as_ref().is_some_and(|h| h != name) {
                continue;
            }
            let grid = make(n);
            let facets = 2 * (n - 1) * (n - 1);
            // Best of a few runs at every size, so that the ns per facet of
            // small and large grids compare like with like.
            let runs = if n <= 300 { 5 } else { 3 };
            let mut best = f64::INFINITY;
            let mut best_cpu = f64::INFINITY;
            let mut peak = 0;
            let mut lines = 0;
            let reps = reps_for(n);
            for _ in 0..runs {
                let base = CURRENT.load(Ordering::Relaxed);
                PEAK.store(base, Ordering::Relaxed);
                let c0 = process_cpu_ns();
                let t = Instant::now();
                let mut out = visible_lines(&grid, &cam, GridLines::Both);
                for _ in 1..reps {
                    drop(out);
                    out = visible_lines(&grid, &cam, GridLines::Both);
                }
                let dt = t.elapsed().as_secs_f64() / reps as f64;
                let cpu = match (c0, process_cpu_ns()) {
                    (Some(a), Some(b)) => (b - a) as f64 * 1e-9 / reps as f64,
                    _ => dt,
                };
                best_cpu = best_cpu.min(cpu);
                peak = PEAK.load(Ordering::Relaxed) - base;
                lines = out.len();
                drop(out);
                best = best.min(dt);
            }
            per_facet.push((name, n, best_cpu * 1e9 / facets as f64));
            println!(
                "| {n} x {n} | {name} | {facets} | {best:.3} | {best_cpu:.3} | {:.0} | {:.1} | {:.0} | {lines} |",
                best_cpu * 1e9 / facets as f64,
                peak as f64 / 1e6,
                peak as f64 / facets as f64
            );
        }
    }
    println!();
    // Time per facet should not grow with the grid: max / min of the CPU ns
    // per facet over the sizes run, per kind of heights.
    for kind in ["smooth", "random"] {
        let v: Vec<f64> = per_facet.iter().filter(|r| r.0 == kind).map(|r| r.2).collect();
        if v.len() > 1 {
            let (lo, hi) = v.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), &x| (lo.min(x), hi.max(x)));
            println!("{kind}: CPU ns / facet from {lo:.0} to {hi:.0}, max / min = {:.2}", hi / lo);
        }
    }
    println!("load average at end: {}", load());
}
