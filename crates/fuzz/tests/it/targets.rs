//! Every fuzz target: its seeds and past findings replayed, then a bounded
//! mutation run (`FUZZ_SECONDS` per target, default 6), as CI runs them.
//! The run's seed is fixed (`FUZZ_SEED` picks another) so that a test run
//! is a repeatable check, not a lottery: exploring with new seeds is what
//! campaigns (`cargo run -p fuzz --release`) are for, and what they find
//! comes here as regressions.

use std::time::Duration;

#[global_allocator]
static ALLOC: fuzz::alloc::Counting = fuzz::alloc::Counting;

/// The seed of a test run's mutations.
const DEFAULT_SEED: u64 = 19;

fn replay_then_mutate(name: &str) {
    let target = fuzz::targets::target(name).expect("known target");
    let limits = fuzz::Limits::default();
    let saved: Vec<_> = fuzz::corpus(target).into_iter().chain(fuzz::regressions(target)).collect();
    assert!(!fuzz::corpus(target).is_empty(), "{name} has a seed corpus");
    for (path, input) in &saved {
        if let Err(broken) = fuzz::check(target, input, &limits) {
            panic!("{}: {broken}", path.display());
        }
    }
    let seconds = std::env::var("FUZZ_SECONDS").ok().and_then(|s| s.parse().ok()).unwrap_or(6);
    let seed = std::env::var("FUZZ_SEED").ok().and_then(|s| s.parse().ok()).unwrap_or(DEFAULT_SEED);
    let report = fuzz::campaign(target, seed, Duration::from_secs(seconds), &limits);
    let findings: Vec<String> = report.findings.iter().map(|f| format!("{}: {}", f.saved.display(), f.broken)).collect();
    assert!(findings.is_empty(), "{name}, seed {seed}, {} inputs:\n{}", report.inputs, findings.join("\n"));
    assert!(report.inputs > 0);
}

#[test]
fn the_counting_allocator_is_installed() {
    // Without it nothing is counted and the memory bound would hold vacuously.
    let v = vec![0u8; 1 << 20];
    assert!(fuzz::alloc::live() >= v.len());
}

#[test]
fn scene() {
    replay_then_mutate("scene");
}

#[test]
fn mesh() {
    replay_then_mutate("mesh");
}

#[test]
fn data() {
    replay_then_mutate("data");
}

#[test]
fn svg() {
    replay_then_mutate("svg");
}

#[test]
fn hpgl() {
    replay_then_mutate("hpgl");
}

#[test]
fn gcode() {
    replay_then_mutate("gcode");
}

#[test]
fn request() {
    replay_then_mutate("request");
}
