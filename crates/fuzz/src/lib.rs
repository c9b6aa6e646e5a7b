//! plotd's fuzz targets, runnable on the stable toolchain: a small mutation
//! harness of our own over committed seed corpora, with no coverage feedback
//! and no extra tooling.
//!
//! Each [`Target`](targets::Target) is one parser of outside bytes run on
//! the real path those bytes take: scene TOML with the files it names (three
//! targets: the TOML, the meshes (OBJ, STL), the data (CSV, GeoJSON); each
//! loaded as the daemon loads a job, from the bundle only, then rendered to a
//! device program when small), SVG, HP-GL, G-code, and the daemon's socket
//! request decoder. [`check`] runs one input and holds it to the promises
//! about bad input: no panic, no stack overflow (it runs on a 2 MiB stack, a
//! daemon worker's), no hang ([`Limits::time`] per input), bounded memory
//! ([`Limits::memory`], measured by the [`alloc::Counting`] allocator the
//! binaries install), and errors that are short and say where.
//! [`campaign`] mutates the corpus for a while and counts.
//!
//! Seeds live in `corpus/TARGET/` (a file per input; a scene bundle is a
//! directory holding `scene.toml` and the files it names); every input that
//! ever broke a promise is kept in `regressions/TARGET/` and replayed by the
//! tests. `cargo test -p fuzz` replays both and mutates for a bounded time
//! (`FUZZ_SECONDS` per target, default 6); a campaign is
//! `cargo run -p fuzz --release -- TARGET --seconds 600`.
//!
//! ```no_run
//! let target = fuzz::targets::target("hpgl").unwrap();
//! let report = fuzz::campaign(target, 1, std::time::Duration::from_secs(10), &fuzz::Limits::default());
//! println!("{} inputs, {} findings", report.inputs, report.findings.len());
//! ```
#![deny(missing_docs)]

pub mod alloc;
pub mod mutate;
pub mod targets;

use std::cell::Cell;
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::sync::Mutex;
use std::time::{Duration, Instant};
use targets::Target;

/// One input: a single file, or a scene bundle (the scene first, then the
/// files it names, by the names it uses).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Input {
    /// Name and bytes of each file; the first is the one the target reads.
    pub files: Vec<(String, Vec<u8>)>,
}

/// The first line of a saved bundle.
const BUNDLE_MAGIC: &str = "plotd-fuzz-bundle 1\n";

impl Input {
    /// One file.
    #[must_use]
    pub fn single(name: &str, bytes: Vec<u8>) -> Input {
        Input { files: vec![(name.to_owned(), bytes)] }
    }

    /// Reads a saved input: a directory (a bundle: `scene.toml` first, then
    /// every other file below it by relative name), a saved bundle file, or
    /// any other file as a single input.
    ///
    /// # Errors
    /// The path cannot be read, or a saved bundle is malformed.
    pub fn load(path: &Path) -> std::io::Result<Input> {
        if path.is_dir() {
            let mut files = Vec::new();
            collect(path, path, &mut files)?;
            files.sort_by(|a, b| (a.0 != "scene.toml", &a.0).cmp(&(b.0 != "scene.toml", &b.0)));
            return Ok(Input { files });
        }
        let bytes = std::fs::read(path)?;
        match bytes.strip_prefix(BUNDLE_MAGIC.as_bytes()) {
            Some(rest) => parse_bundle(rest).ok_or_else(|| std::io::Error::new(std::io::ErrorKind::InvalidData, "malformed bundle")),
            None => Ok(Input::single(&path.file_name().unwrap_or_default().to_string_lossy(), bytes)),
        }
    }

    /// The bytes to save: a single file as it is, a bundle in the bundle format.
    #[must_use]
    pub fn to_bytes(&self) -> Vec<u8> {
        if self.files.len() == 1 {
            return self.files[0].1.clone();
        }
        let mut out = BUNDLE_MAGIC.as_bytes().to_vec();
        for (name, bytes) in &self.files {
            out.extend_from_slice(format!("{} {}\n", bytes.len(), name).as_bytes());
            out.extend_from_slice(bytes);
            out.push(b'\n');
        }
        out
    }
}

fn collect(root: &Path, dir: &Path, out: &mut Vec<(String, Vec<u8>)>) -> std::io::Result<()> {
    let mut entries: Vec<_> = std::fs::read_dir(dir)?.collect::<Result<_, _>>()?;
    entries.sort_by_key(std::fs::DirEntry::path);
    for e in entries {
        let p = e.path();
        if p.is_dir() {
            collect(root, &p, out)?;
        } else {
            let name = p.strip_prefix(root).unwrap_or(&p).to_string_lossy().replace('\\', "/");
            out.push((name, std::fs::read(&p)?));
        }
    }
    Ok(())
}

fn parse_bundle(mut rest: &[u8]) -> Option<Input> {
    let mut files = Vec::new();
    while !rest.is_empty() {
        let nl = rest.iter().position(|&b| b == b'\n')?;
        let header = std::str::from_utf8(&rest[..nl]).ok()?;
        let (len, name) = header.split_once(' ')?;
        let len: usize = len.parse().ok()?;
        let body = rest.get(nl + 1..nl + 1 + len)?;
        files.push((name.to_owned(), body.to_vec()));
        rest = rest.get(nl + 2 + len..)?;
    }
    Some(Input { files })
}

/// Bounds on one input.
#[derive(Clone, Copy, Debug)]
pub struct Limits {
    /// Longest an input may run.
    pub time: Duration,
    /// Most heap bytes an input may hold at once.
    pub memory: usize,
}

impl Default for Limits {
    fn default() -> Self {
        Limits { time: Duration::from_secs(20), memory: 1 << 30 }
    }
}

/// A broken promise.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Broken {
    /// The target panicked.
    Panic(String),
    /// The input ran past [`Limits::time`]; it may still be running.
    Hang(Duration),
    /// The input held more than [`Limits::memory`] bytes at once.
    Memory(usize),
    /// A promise the target checks itself (a long error, one that names no place).
    Contract(String),
}

impl std::fmt::Display for Broken {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Broken::Panic(m) => write!(f, "panic: {m}"),
            Broken::Hang(t) => write!(f, "hang: still running after {:.1} s", t.as_secs_f64()),
            Broken::Memory(b) => write!(f, "memory: {} MiB held at once", b >> 20),
            Broken::Contract(m) => write!(f, "broken promise: {m}"),
        }
    }
}

/// What one input cost.
#[derive(Clone, Copy, Debug, Default)]
pub struct Cost {
    /// Wall time.
    pub time: Duration,
    /// Most heap bytes held at once (0 when the counting allocator is not installed).
    pub memory: usize,
}

/// The stack of a tokio worker (and of `spawn_blocking` threads), where the
/// daemon parses and renders jobs.
pub const WORKER_STACK: usize = 2 << 20;

thread_local! {
    static IN_TARGET: Cell<bool> = const { Cell::new(false) };
}
static LAST_PANIC: Mutex<String> = Mutex::new(String::new());

fn install_panic_hook() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let default = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            let message = match (info.payload().downcast_ref::<&str>(), info.payload().downcast_ref::<String>()) {
                (Some(s), _) => (*s).to_owned(),
                (_, Some(s)) => s.clone(),
                _ => "non-string panic".to_owned(),
            };
            let at = info.location().map(|l| format!(" at {}:{}", l.file(), l.line())).unwrap_or_default();
            *LAST_PANIC.lock().unwrap_or_else(std::sync::PoisonError::into_inner) = format!("{message}{at}");
            if !IN_TARGET.with(Cell::get) {
                default(info);
            }
        }));
    });
}

/// Runs one input through `target` on a [`WORKER_STACK`] thread and holds
/// it to the promises. A hung input's thread is left running: the caller
/// should stop soon after.
///
/// # Errors
/// The promise the input broke.
pub fn check(target: &'static Target, input: &Input, limits: &Limits) -> Result<Cost, Broken> {
    install_panic_hook();
    let input = input.clone();
    let (tx, rx) = mpsc::channel();
    let start = Instant::now();
    alloc::reset_peak();
    let base = alloc::live();
    std::thread::Builder::new()
        .name(format!("fuzz-{}", target.name))
        .stack_size(WORKER_STACK)
        .spawn(move || {
            IN_TARGET.with(|f| f.set(true));
            let result = std::panic::catch_unwind(|| (target.run)(&input));
            drop(input);
            let _ = tx.send(result);
        })
        .expect("spawn a worker thread");
    let result = rx.recv_timeout(limits.time).map_err(|_| Broken::Hang(start.elapsed()))?;
    let cost = Cost { time: start.elapsed(), memory: alloc::peak().saturating_sub(base) };
    match result {
        Err(_) => Err(Broken::Panic(LAST_PANIC.lock().unwrap_or_else(std::sync::PoisonError::into_inner).clone())),
        Ok(Err(m)) => Err(Broken::Contract(m)),
        Ok(Ok(())) if cost.memory > limits.memory => Err(Broken::Memory(cost.memory)),
        Ok(Ok(())) => Ok(cost),
    }
}

/// The crate's directory (corpora and regressions are found from it).
#[must_use]
pub fn crate_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The inputs in `dir` (sorted by name), or none when it does not exist.
///
/// # Panics
/// An entry that cannot be read: the committed corpus is broken.
#[must_use]
pub fn inputs_in(dir: &Path) -> Vec<(PathBuf, Input)> {
    let Ok(entries) = std::fs::read_dir(dir) else { return Vec::new() };
    let mut paths: Vec<PathBuf> = entries.map(|e| e.expect("corpus entry").path()).collect();
    paths.sort();
    paths.into_iter().map(|p| (p.clone(), Input::load(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display())))).collect()
}

/// The seed corpus of `target` (`corpus/NAME/`).
#[must_use]
pub fn corpus(target: &Target) -> Vec<(PathBuf, Input)> {
    inputs_in(&crate_dir().join("corpus").join(target.name))
}

/// The inputs that once broke a promise of `target` (`regressions/NAME/`).
#[must_use]
pub fn regressions(target: &Target) -> Vec<(PathBuf, Input)> {
    inputs_in(&crate_dir().join("regressions").join(target.name))
}

/// An input that broke a promise, and where it was saved.
#[derive(Clone, Debug)]
pub struct Finding {
    /// What broke.
    pub broken: Broken,
    /// The saved input (under `target/fuzz/NAME/`).
    pub saved: PathBuf,
}

/// What a campaign did.
#[derive(Clone, Debug, Default)]
pub struct Report {
    /// Inputs run.
    pub inputs: u64,
    /// Broken promises; a hang ends the campaign.
    pub findings: Vec<Finding>,
    /// The slowest input.
    pub slowest: Duration,
    /// The most memory one input held.
    pub peak_memory: usize,
    /// Wall time of the whole campaign.
    pub elapsed: Duration,
}

/// Where a campaign saves its current input (so an abort, such as a stack
/// overflow, leaves it behind) and every finding.
#[must_use]
pub fn out_dir(target: &Target) -> PathBuf {
    let target_dir = std::env::var_os("CARGO_TARGET_DIR").map_or_else(|| crate_dir().join("../../target"), PathBuf::from);
    target_dir.join("fuzz").join(target.name)
}

/// Mutates `target`'s corpus (seeds and regressions) for `duration` from
/// `seed`, running every input through [`check`]. Stops early at a hang
/// (its thread cannot be stopped).
///
/// # Panics
/// The target has no corpus, or the output directory cannot be written.
#[must_use]
pub fn campaign(target: &'static Target, seed: u64, duration: Duration, limits: &Limits) -> Report {
    let pool: Vec<Input> = corpus(target).into_iter().chain(regressions(target)).map(|(_, i)| i).collect();
    assert!(!pool.is_empty(), "target {} has no corpus", target.name);
    let all_bytes: Vec<&[u8]> = pool.iter().flat_map(|i| i.files.iter().map(|(_, b)| b.as_slice())).collect();
    let dir = out_dir(target);
    std::fs::create_dir_all(&dir).expect("create the fuzz output directory");
    let current = dir.join("current");
    let mut rng = mutate::Rng::new(seed);
    let mut report = Report::default();
    let start = Instant::now();
    while start.elapsed() < duration {
        let mut input = rng.pick(&pool).clone();
        let which: Vec<usize> = (0..input.files.len()).filter(|&k| !target.bundle || (target.mutates)(&input.files[k].0)).collect();
        let k = if which.is_empty() { 0 } else { *rng.pick(&which) };
        let max_len = (input.files[k].1.len() * 4).clamp(4096, 256 * 1024);
        mutate::mutate(&mut input.files[k].1, &mut rng, target.dictionary, &all_bytes, max_len);
        // Saved before it runs: an abort (a stack overflow) leaves it behind.
        // The directory is made again if something removed it meanwhile.
        if std::fs::write(&current, input.to_bytes()).is_err() {
            std::fs::create_dir_all(&dir).expect("create the fuzz output directory");
            std::fs::write(&current, input.to_bytes()).expect("save the current input");
        }
        report.inputs += 1;
        match check(target, &input, limits) {
            Ok(cost) => {
                report.slowest = report.slowest.max(cost.time);
                report.peak_memory = report.peak_memory.max(cost.memory);
            }
            Err(broken) => {
                let saved = dir.join(format!("finding-{seed}-{}", report.inputs));
                std::fs::write(&saved, input.to_bytes()).expect("save a finding");
                let hang = matches!(broken, Broken::Hang(_));
                report.findings.push(Finding { broken, saved });
                if hang {
                    break;
                }
            }
        }
    }
    report.elapsed = start.elapsed();
    report
}
