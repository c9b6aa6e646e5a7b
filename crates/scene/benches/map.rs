//! Map benchmark (issue 7): one frame of 200 symbols on a 2,000-point
//! outline (target < 50 ms), and a 500-frame animation of it (target < 15 s,
//! frames in parallel with rayon). Prints a table; no timed assertions.
//!
//! `cargo bench -p scene --bench map` (add `-- --quick` for fewer runs).

use hiddenline::engine;

use rayon::prelude::*;
use scene::{render, Scene};
use std::time::{Duration, Instant};

/// Writes the scene's data files and loads it: a wobbly 2,000-point country,
/// 200 boxes on a jittered grid inside it (some close enough to intersect),
/// values moving between two columns, the camera swinging round.
fn scene(frames: usize) -> Scene {
    let dir = std::env::temp_dir().join(format!("plotd-map-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut outline = String::from("x,y,pen_up\n");
    let n = 2000;
    for i in 0..=n {
        let a = std::f64::consts::TAU * (i % n) as f64 / n as f64;
        let r = 10.0 * (1.0 + 0.15 * (5.0 * a).sin() + 0.05 * (23.0 * a).cos() + 0.02 * (97.0 * a).sin());
        outline.push_str(&format!("{},{},{}\n", r * a.cos(), 0.7 * r * a.sin(), u8::from(i == 0)));
    }
    std::fs::write(dir.join("outline.csv"), outline).unwrap();
    let mut places = String::from("name,x,y,v0,v1\n");
    let mut seed = 12345u64;
    let mut rnd = || {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (seed >> 11) as f64 / (1u64 << 53) as f64
    };
    for k in 0..200 {
        let (i, j) = (k % 20, k / 20);
        let x = -8.5 + 17.0 * i as f64 / 19.0 + 0.3 * (rnd() - 0.5);
        let y = 0.7 * (-8.0 + 16.0 * j as f64 / 9.0) + 0.3 * (rnd() - 0.5);
        places.push_str(&format!("P{k},{x:.4},{y:.4},{:.3},{:.3}\n", 1.0 + 20.0 * rnd(), 1.0 + 30.0 * rnd()));
    }
    std::fs::write(dir.join("places.csv"), places).unwrap();
    let toml = format!(
        "[camera]\neye = [-14.0, -22.0, 14.0]\ntarget = [0.0, 0.0, 1.0]\nfov_deg = 35.0\n\
         [[map]]\noutline = \"outline.csv\"\n\
         [[symbols]]\ndata = \"places.csv\"\nsize = 0.75\nheight_scale = 0.15\n\
         [animation]\nframes = {frames}\nfrom = \"v0\"\nto = \"v1\"\n\
         [[animation.camera]]\nframe = 0\neye = [-14.0, -22.0, 14.0]\n\
         [[animation.camera]]\nframe = {}\neye = [20.0, -16.0, 8.0]\n",
        frames - 1
    );
    Scene::from_toml(&toml, &dir.join("bench.toml")).unwrap()
}

/// This process's CPU time (user + system) from /proc, in seconds: the
/// machine is shared, so wall time alone overstates the cost. `None` off Linux.
fn cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the parenthesised command name; utime and stime are the
    // 14th and 15th fields of the whole line, in clock ticks (100 per second).
    let rest = &stat[stat.rfind(')')? + 2..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks: f64 = f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0)
}

fn median(mut v: Vec<Duration>) -> Duration {
    v.sort();
    v[v.len() / 2]
}

fn main() {
    let quick = std::env::args().any(|a| a == "--quick");
    let runs = if quick { 5 } else { 21 };
    let movie = scene(500);
    let frame = movie.frame(250).unwrap();
    let model = frame.lower();
    println!(
        "map bench: {} outline segments, {} symbols, {} faces, {} edges per frame; {} threads",
        model.edges.iter().filter(|e| e.faces.is_empty()).count(),
        200,
        model.faces.len(),
        model.edges.len(),
        rayon::current_num_threads()
    );
    let time = |f: &dyn Fn()| {
        median(
            (0..runs)
                .map(|_| {
                    let t = Instant::now();
                    f();
                    t.elapsed()
                })
                .collect(),
        )
    };
    let lower = time(&|| {
        std::hint::black_box(frame.lower());
    });
    let vis = time(&|| {
        std::hint::black_box(engine::visibility(&model, &frame.camera));
    });
    let full = time(&|| {
        std::hint::black_box(render(movie.frame(250).unwrap()).unwrap());
    });
    let opts = strokes::StrokeOptions::default();
    let drawing = render(movie.frame(250).unwrap()).unwrap();
    let ordered = time(&|| {
        std::hint::black_box(strokes::optimize(drawing.clone(), &opts));
    });
    let cpu0 = cpu_seconds();
    let t = Instant::now();
    let strokes: usize = (0..movie.frame_count()).into_par_iter().map(|i| render(movie.frame(i).unwrap()).unwrap().stroke_count()).sum();
    let all = t.elapsed();
    let cpu = cpu_seconds().zip(cpu0).map(|(b, a)| b - a);
    println!("| measurement                                   | time       | target   |");
    println!("|-----------------------------------------------|-----------:|----------|");
    println!("| lower one frame (median of {runs:>2})                | {:>7.2} ms |          |", lower.as_secs_f64() * 1e3);
    println!("| engine::visibility, one frame (median)        | {:>7.2} ms |          |", vis.as_secs_f64() * 1e3);
    println!("| one frame end to end: lower+engine+page (med.)| {:>7.2} ms | < 50 ms  |", full.as_secs_f64() * 1e3);
    println!("| 500 frames end to end, rayon                  | {:>7.2} s  | < 15 s   |", all.as_secs_f64());
    // What `plotd render -o f-%04d.hpgl` and the daemon add per frame.
    println!("| + strokes::optimize of one frame (median)     | {:>7.2} ms |          |", ordered.as_secs_f64() * 1e3);
    if let Some(cpu) = cpu {
        println!("| 500 frames: CPU time, all threads             | {cpu:>7.2} s  |          |");
    }
    println!("({strokes} strokes over all frames; load average shares the 2 cores with other jobs)");
}
