//! `fuzz TARGET|all [--seconds N] [--seed S] [--time-limit S] [--memory-mb M]`:
//! a fuzz campaign, one target after another; prints a table and exits 1
//! when any promise broke (the inputs are saved under `target/fuzz/`).
//! `fuzz replay TARGET FILE...` runs saved inputs once each and says what
//! they cost or broke.

use std::time::Duration;

#[global_allocator]
static ALLOC: fuzz::alloc::Counting = fuzz::alloc::Counting;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let flag = |name: &str, default: u64| -> u64 {
        args.iter().position(|a| a == name).and_then(|i| args.get(i + 1)).map_or(default, |v| v.parse().expect("a number"))
    };
    if args.first().map(String::as_str) == Some("replay") {
        replay(&args[1..]);
        return;
    }
    let which = args.first().map_or("all", String::as_str);
    let targets: Vec<_> = fuzz::targets::TARGETS.iter().filter(|t| which == "all" || t.name == which).collect();
    if targets.is_empty() {
        let names: Vec<_> = fuzz::targets::TARGETS.iter().map(|t| t.name).collect();
        eprintln!("fuzz: unknown target {which}; known: all, {}", names.join(", "));
        std::process::exit(2);
    }
    let limits = fuzz::Limits { time: Duration::from_secs(flag("--time-limit", 20)), memory: (flag("--memory-mb", 1024) as usize) << 20 };
    let (seconds, seed) = (flag("--seconds", 60), flag("--seed", 1));
    println!("{:<8} {:>9} {:>8} {:>9} {:>11} {:>9}", "target", "inputs", "seconds", "inputs/s", "slowest ms", "peak MiB");
    let mut broken = 0;
    for t in targets {
        let r = fuzz::campaign(t, seed, Duration::from_secs(seconds), &limits);
        let secs = r.elapsed.as_secs_f64();
        println!(
            "{:<8} {:>9} {:>8.0} {:>9.0} {:>11.1} {:>9.1}",
            t.name,
            r.inputs,
            secs,
            r.inputs as f64 / secs,
            r.slowest.as_secs_f64() * 1e3,
            r.peak_memory as f64 / f64::from(1 << 20)
        );
        for f in &r.findings {
            println!("  {}: {}", f.saved.display(), f.broken);
        }
        broken += r.findings.len();
    }
    std::process::exit(i32::from(broken > 0));
}

fn replay(args: &[String]) {
    let Some(target) = args.first().and_then(|n| fuzz::targets::target(n)) else {
        eprintln!("fuzz: replay TARGET FILE...");
        std::process::exit(2);
    };
    let limits = fuzz::Limits { time: Duration::from_secs(600), memory: usize::MAX };
    for path in &args[1..] {
        let input = fuzz::Input::load(std::path::Path::new(path)).expect("a saved input");
        match fuzz::check(target, &input, &limits) {
            Ok(cost) => {
                println!("{path}: ok in {:.1} ms, {:.1} MiB", cost.time.as_secs_f64() * 1e3, cost.memory as f64 / f64::from(1 << 20))
            }
            Err(broken) => println!("{path}: {broken}"),
        }
    }
}
