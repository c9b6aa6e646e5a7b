//! Work on outside bytes in a child process, under a budget.
//!
//! Reading and rendering what a client sent (a scene and the files it names,
//! SVG, HP-GL, G-code) can take any time or memory, overflow a stack or
//! panic, whatever the parsers' own limits. The daemon does none of it in
//! its own process: it runs its own binary again as `plotd job-worker`,
//! with the address space (`RLIMIT_AS`) and CPU time (`RLIMIT_CPU`) of a
//! [`Budget`] (`config.rs`), no core dumps, killed with the daemon (`PR_SET_PDEATHSIG`),
//! and kills it at the budget's wall-clock deadline, on `cancel` and on
//! shutdown. A job that fails there fails alone: the daemon goes on. Once
//! it has read its input, the worker forbids itself to open any file
//! (seccomp), so nothing a job names can make it open a path.
//!
//! The exchange is plain bytes on the child's stdin and stdout, so no
//! path of the client's is ever opened: stdin carries a JSON header line
//! ([`Header`]: the task, the job's kind, the device profile, the sizes),
//! then the content and each attached file; stdout carries frames (a tag
//! byte, a little-endian `u64` length, the payload): `P` one page of device
//! commands (pages are written as they are rendered, so an animation's
//! frames are never all held at once), `E` the job's error, `O` done.
//!
//! `plotd render` asked for a budget (`--time-limit`, `--memory-limit`)
//! runs itself under it the same way ([`run_cli_budgeted`]).

use crate::config::Budget;
use crate::pen_map::PenMap;
use crate::spool::{JobKind, Occult};
use plotcode::{DeviceProfile, PenSettings};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::future::Future;
use std::io::{Read, Write};
use std::path::PathBuf;
use std::process::ExitStatus;
use std::time::Duration;
use thiserror::Error;
use tokio::io::{AsyncRead, AsyncReadExt, AsyncWriteExt};

/// Bytes of the worker's stderr kept to explain a crash.
const STDERR_KEPT: usize = 4096;

/// The budget's limits, as the worker process is held to them.
impl Budget {
    /// Sets the budget's limits on a command, in the child between fork and exec.
    fn limit(&self, cmd: &mut std::process::Command) {
        use nix::sys::resource::{setrlimit, Resource};
        use std::os::unix::process::CommandExt;
        let memory = self.memory_mb.saturating_mul(1 << 20);
        let cores = std::thread::available_parallelism().map_or(1, std::num::NonZero::get) as f64;
        // CPU time backs the wall clock up (a stopped daemon's deadline
        // never fires): all cores busy for the whole time, and a second.
        let cpu = (self.seconds * cores).ceil() as u64 + 1;
        // SAFETY: only async-signal-safe system calls between fork and exec.
        unsafe {
            cmd.pre_exec(move || {
                setrlimit(Resource::RLIMIT_AS, memory, memory)?;
                setrlimit(Resource::RLIMIT_CPU, cpu, cpu + 1)?;
                setrlimit(Resource::RLIMIT_CORE, 0, 0)?;
                nix::sys::prctl::set_pdeathsig(nix::sys::signal::Signal::SIGKILL)?;
                Ok(())
            });
        }
        // Few malloc arenas: each reserves 64 MiB of address space. A render
        // frees vectors of tens of MB stage after stage and allocates the
        // next: glibc would hand each one over its (dynamic) mmap threshold,
        // and the heap top it trims, back to the kernel, and the next comes
        // as fresh pages, each faulted in and zeroed (about 1 ms a MB on a
        // VM). Up to 32 MiB on the heap and 128 MiB kept untrimmed: 8 % off a
        // 1000 x 1000 surface's whole render, 5 % at 2000 x 2000, for a peak
        // 10-30 MB higher.
        cmd.env("GLIBC_TUNABLES", "glibc.malloc.arena_max=2:glibc.malloc.mmap_threshold=33554432:glibc.malloc.trim_threshold=134217728")
            .env("RUST_BACKTRACE", "0");
    }

    fn deadline(&self) -> Duration {
        Duration::from_secs_f64(self.seconds)
    }

    /// Why a worker that did not finish stopped, from its exit status and
    /// the end of its stderr; `timed_out` when it was killed at the deadline.
    fn explain(&self, status: Option<ExitStatus>, stderr: &[u8], timed_out: bool) -> WorkerError {
        use std::os::unix::process::ExitStatusExt;
        let text = String::from_utf8_lossy(stderr);
        let last = text.lines().rev().find(|l| !l.trim().is_empty()).unwrap_or("").trim().to_owned();
        let signal = status.and_then(|s| s.signal());
        if timed_out || signal == Some(nix::libc::SIGXCPU) {
            return WorkerError::OverTime { seconds: self.seconds };
        }
        if text.contains("memory allocation of") || text.contains("capacity overflow") {
            return WorkerError::OverMemory { mb: self.memory_mb };
        }
        if text.contains("overflowed its stack") {
            return WorkerError::Crashed("stack overflow (input nested too deeply)".into());
        }
        let how = match (signal, status.and_then(|s| s.code())) {
            (Some(9), _) => "killed (SIGKILL: out of memory?)".to_owned(),
            (Some(s), _) => format!("killed by signal {s}"),
            (None, Some(c)) => format!("exit code {c}"),
            (None, None) => "no exit status".to_owned(),
        };
        WorkerError::Crashed(if last.is_empty() { how } else { format!("{how}: {last}") })
    }
}

/// Why a job's check or render did not give a result.
#[derive(Debug, Error)]
pub enum WorkerError {
    /// The job cannot be plotted: its own error (naming file, line, field).
    #[error("{0}")]
    Refused(String),
    /// It ran past the budget's time.
    #[error("it took longer than its budget of {seconds} s (render_seconds in the daemon's config; plotd render --time-limit)")]
    OverTime {
        /// The budget's seconds.
        seconds: f64,
    },
    /// It needed more memory than the budget.
    #[error("it needed more memory than its budget of {mb} MiB (render_memory_mb in the daemon's config; plotd render --memory-limit)")]
    OverMemory {
        /// The budget's memory.
        mb: u64,
    },
    /// The worker died (a panic, a stack overflow, a signal).
    #[error("the renderer crashed: {0}")]
    Crashed(String),
    /// Stopped on request (cancel, pause, shutdown).
    #[error("stopped")]
    Stopped,
    /// The worker could not be started or talked to.
    #[error("cannot run the job worker: {0}")]
    Io(#[from] std::io::Error),
}

/// What the worker is asked to do.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
enum Task {
    /// Everything short of rendering a scene: a scene is loaded and its
    /// work estimated; SVG, HP-GL and G-code are read through and cut.
    Check,
    /// The device commands, page by page.
    Render,
}

/// The first line of the worker's stdin.
#[derive(Debug, Serialize, Deserialize)]
struct Header {
    task: Task,
    kind: JobKind,
    device: DeviceProfile,
    content_len: u64,
    /// The budget's [`Budget::face_tests`].
    face_tests: u64,
    /// Attached files in order: name and length; their bytes follow the content.
    files: Vec<(String, u64)>,
    /// The plotter's pen for each pen of the job drawn with another.
    #[serde(default, with = "crate::pen_map::as_pairs")]
    pens: PenMap,
    /// The plotter's pen table: speed and force per pen.
    #[serde(default)]
    pen_table: PenSettings,
    /// For an SVG drawing: what its fills hide.
    #[serde(default)]
    occult: Option<Occult>,
}

/// A job as the worker gets it.
#[derive(Clone, Copy, Debug)]
pub struct JobInput<'a> {
    /// Its kind.
    pub kind: JobKind,
    /// The submitted bytes.
    pub content: &'a [u8],
    /// The files a scene names, by name.
    pub files: &'a BTreeMap<String, Vec<u8>>,
    /// The device it is for.
    pub device: &'a DeviceProfile,
    /// The plotter's pen for each pen of the job drawn with another.
    pub pens: &'a PenMap,
    /// The plotter's pen table: speed and force per pen.
    pub pen_table: &'a PenSettings,
    /// For an SVG drawing: what its fills hide.
    pub occult: Option<Occult>,
}

/// Runs jobs' checks and renders, in a child process or (without a binary
/// to run, as in the library's tests) on a thread of this one, unbounded.
#[derive(Clone, Debug)]
pub struct Worker {
    /// The `plotd` binary; `None`: in this process.
    pub exe: Option<PathBuf>,
    /// Each check and each render's budget.
    pub budget: Budget,
}

impl Worker {
    /// Checks a job before it is queued.
    ///
    /// # Errors
    /// [`WorkerError::Refused`] with the job's problem, or why the check did not finish.
    pub async fn check(&self, job: JobInput<'_>) -> Result<(), WorkerError> {
        self.run(Task::Check, job, &mut |_| Ok(()), std::future::pending()).await
    }

    /// Renders a job to device commands, giving each page to `page` as it
    /// comes; stops (killing the worker) when `stop` resolves.
    ///
    /// # Errors
    /// As [`Worker::check`]; [`WorkerError::Stopped`]; `page`'s error as [`WorkerError::Refused`].
    pub async fn render(
        &self,
        job: JobInput<'_>,
        page: &mut (dyn FnMut(Vec<u8>) -> Result<(), String> + Send),
        stop: impl Future<Output = ()>,
    ) -> Result<(), WorkerError> {
        self.run(Task::Render, job, page, stop).await
    }

    async fn run(
        &self,
        task: Task,
        job: JobInput<'_>,
        page: &mut (dyn FnMut(Vec<u8>) -> Result<(), String> + Send),
        stop: impl Future<Output = ()>,
    ) -> Result<(), WorkerError> {
        let header = Header {
            task,
            kind: job.kind,
            device: job.device.clone(),
            content_len: job.content.len() as u64,
            face_tests: self.budget.face_tests,
            files: job.files.iter().map(|(k, v)| (k.clone(), v.len() as u64)).collect(),
            pens: job.pens.clone(),
            pen_table: job.pen_table.clone(),
            occult: job.occult,
        };
        let Some(exe) = &self.exe else {
            // In-process: the same work on a blocking thread, its output read back.
            let (content, files) = (job.content.to_vec(), job.files.clone());
            let out = tokio::task::spawn_blocking(move || {
                let mut out = Vec::new();
                let _ = perform(&header, &content, &files, &mut out);
                out
            });
            tokio::pin!(stop);
            let out = tokio::select! {
                out = out => out.map_err(|e| WorkerError::Crashed(e.to_string()))?,
                () = &mut stop => return Err(WorkerError::Stopped),
            };
            return read_frames(&mut out.as_slice(), page).await?.ok_or_else(|| WorkerError::Crashed("no result".into()));
        };
        let mut cmd = std::process::Command::new(exe);
        cmd.arg("job-worker").stdin(std::process::Stdio::piped()).stdout(std::process::Stdio::piped()).stderr(std::process::Stdio::piped());
        self.budget.limit(&mut cmd);
        let mut cmd = tokio::process::Command::from(cmd);
        cmd.kill_on_drop(true);
        let mut child = cmd.spawn()?;
        let (mut stdin, mut stdout, mut stderr) =
            (child.stdin.take().expect("piped"), child.stdout.take().expect("piped"), child.stderr.take().expect("piped"));
        let feed = async move {
            let mut line = serde_json::to_vec(&header).expect("headers serialise");
            line.push(b'\n');
            stdin.write_all(&line).await?;
            stdin.write_all(job.content).await?;
            for bytes in job.files.values() {
                stdin.write_all(bytes).await?;
            }
            stdin.shutdown().await
        };
        let errors = async move {
            let mut kept = Vec::new();
            let mut buf = [0u8; 4096];
            while let Ok(n @ 1..) = stderr.read(&mut buf).await {
                kept.extend_from_slice(&buf[..n]);
                let excess = kept.len().saturating_sub(STDERR_KEPT);
                kept.drain(..excess);
            }
            kept
        };
        let work = async {
            // A worker that refuses early stops reading: a broken pipe here is its answer, not an error.
            let (_, result, kept) = tokio::join!(feed, read_frames(&mut stdout, page), errors);
            (result, kept)
        };
        tokio::pin!(stop);
        let outcome = tokio::select! {
            r = tokio::time::timeout(self.budget.deadline(), work) => r,
            () = &mut stop => {
                let _ = child.kill().await;
                return Err(WorkerError::Stopped);
            }
        };
        let Ok((result, kept)) = outcome else {
            let _ = child.kill().await;
            return Err(self.budget.explain(None, &[], true));
        };
        let status = child.wait().await?;
        match result {
            Ok(Some(())) if status.success() => Ok(()),
            Err(e @ WorkerError::Refused(_)) => {
                let _ = child.kill().await;
                Err(e)
            }
            _ => Err(self.budget.explain(Some(status), &kept, false)),
        }
    }
}

/// Reads the worker's frames: pages to `page`, then the result. `Ok(None)`
/// when the stream ends without one (the worker died).
async fn read_frames(
    out: &mut (impl AsyncRead + Unpin),
    page: &mut (dyn FnMut(Vec<u8>) -> Result<(), String> + Send),
) -> Result<Option<()>, WorkerError> {
    let mut total = 0usize;
    loop {
        let Ok(tag) = out.read_u8().await else { return Ok(None) };
        let Ok(len) = out.read_u64_le().await else { return Ok(None) };
        let len = usize::try_from(len).unwrap_or(usize::MAX);
        total = total.saturating_add(len);
        if total > crate::job_check::MAX_OUTPUT_BYTES + (1 << 20) {
            return Err(WorkerError::Refused(too_large()));
        }
        let mut payload = vec![0u8; len];
        if out.read_exact(&mut payload).await.is_err() {
            return Ok(None);
        }
        match tag {
            b'P' => page(payload).map_err(WorkerError::Refused)?,
            b'E' => return Err(WorkerError::Refused(String::from_utf8_lossy(&payload).into_owned())),
            b'O' => return Ok(Some(())),
            _ => return Ok(None),
        }
    }
}

fn too_large() -> String {
    format!("its device commands pass the limit of {} MiB", crate::job_check::MAX_OUTPUT_BYTES >> 20)
}

fn frame(out: &mut dyn Write, tag: u8, payload: &[u8]) -> std::io::Result<()> {
    out.write_all(&[tag])?;
    out.write_all(&(payload.len() as u64).to_le_bytes())?;
    out.write_all(payload)?;
    out.flush()
}

/// `plotd job-worker`: reads one job from stdin, writes its frames to stdout.
///
/// # Errors
/// Only when stdin or stdout fail; the job's own errors are frames.
pub fn job_worker_main() -> std::io::Result<()> {
    let mut input = std::io::BufReader::new(std::io::stdin().lock());
    let mut line = Vec::new();
    std::io::BufRead::read_until(&mut input, b'\n', &mut line)?;
    let header: Header = serde_json::from_slice(&line).map_err(std::io::Error::other)?;
    let read = |input: &mut dyn Read, n: u64| -> std::io::Result<Vec<u8>> {
        let mut v = Vec::new();
        Read::take(input, n).read_to_end(&mut v)?;
        if v.len() as u64 == n {
            Ok(v)
        } else {
            Err(std::io::ErrorKind::UnexpectedEof.into())
        }
    };
    let content = read(&mut input, header.content_len)?;
    let mut files = BTreeMap::new();
    for (name, len) in &header.files {
        files.insert(name.clone(), read(&mut input, *len)?);
    }
    // From here on the job's bytes are read: no file can be opened, so no
    // path they name is (an SVG `<image href>`, a font, a FIFO).
    if let Err(e) = forbid_opening_files() {
        eprintln!("job worker: cannot install its system call filter: {e}");
    }
    let mut out = std::io::BufWriter::new(std::io::stdout().lock());
    perform(&header, &content, &files, &mut out)
}

/// Installs a seccomp filter on this process: `open`, `openat`, `openat2`,
/// `creat`, `execve`, `execveat` and `socket` fail with `EACCES`; the
/// descriptors already open (stdin, stdout, stderr) go on working. The
/// worker needs nothing else from the file system once it has its input.
fn forbid_opening_files() -> std::io::Result<()> {
    use nix::libc::{self, sock_filter, sock_fprog};
    #[cfg(target_arch = "x86_64")]
    const ARCH: u32 = 0xC000_003E; // AUDIT_ARCH_X86_64
    #[cfg(target_arch = "aarch64")]
    const ARCH: u32 = 0xC000_00B7; // AUDIT_ARCH_AARCH64
    #[cfg(target_arch = "x86_64")]
    let denied =
        [libc::SYS_open, libc::SYS_creat, libc::SYS_openat, libc::SYS_openat2, libc::SYS_execve, libc::SYS_execveat, libc::SYS_socket];
    #[cfg(target_arch = "aarch64")]
    let denied = [libc::SYS_openat, libc::SYS_openat2, libc::SYS_execve, libc::SYS_execveat, libc::SYS_socket];
    let stmt = |code: u32, k: u32| sock_filter { code: code as u16, jt: 0, jf: 0, k };
    let jeq = |k: u32, jt: u8, jf: u8| sock_filter { code: (libc::BPF_JMP | libc::BPF_JEQ | libc::BPF_K) as u16, jt, jf, k };
    let load = |offset: u32| stmt(libc::BPF_LD | libc::BPF_W | libc::BPF_ABS, offset);
    let allow = stmt(libc::BPF_RET | libc::BPF_K, libc::SECCOMP_RET_ALLOW);
    let deny = stmt(libc::BPF_RET | libc::BPF_K, libc::SECCOMP_RET_ERRNO | libc::EACCES as u32);
    // seccomp_data: `nr` at offset 0, `arch` at 4. Another architecture's
    // calls (numbered differently) are denied outright.
    let n = denied.len();
    // x32 calls (numbers from 0x4000_0000 on x86_64) are denied too.
    let x32 = sock_filter {
        code: (libc::BPF_JMP | libc::BPF_JGE | libc::BPF_K) as u16,
        jt: u8::try_from(n + 1).expect("a short list"),
        jf: 0,
        k: 0x4000_0000,
    };
    let mut prog = vec![load(4), jeq(ARCH, 1, 0), deny, load(0), x32];
    for (i, nr) in denied.iter().enumerate() {
        // On a match jump to the `deny` after the list, else to the next test.
        let to_deny = u8::try_from(n - i).expect("a short list");
        prog.push(jeq(*nr as u32, to_deny, 0));
    }
    prog.extend([allow, deny]);
    let fprog = sock_fprog { len: u16::try_from(prog.len()).expect("a short program"), filter: prog.as_mut_ptr() };
    // SAFETY: prctl with a valid filter program that outlives the call.
    unsafe {
        if libc::prctl(libc::PR_SET_NO_NEW_PRIVS, 1, 0, 0, 0) != 0 {
            return Err(std::io::Error::last_os_error());
        }
        if libc::prctl(libc::PR_SET_SECCOMP, libc::SECCOMP_MODE_FILTER, &fprog as *const sock_fprog) != 0 {
            return Err(std::io::Error::last_os_error());
        }
    }
    Ok(())
}

/// The worker's task on one job, its frames written to `out`.
fn perform(header: &Header, content: &[u8], files: &BTreeMap<String, Vec<u8>>, out: &mut dyn Write) -> std::io::Result<()> {
    let device = header.device.clone();
    let attached = scene::Attached { files: files.clone() };
    let pens = crate::convert::Pens { map: Some(&header.pens), table: Some(&header.pen_table) };
    let mut written = 0usize;
    let mut emit = |out: &mut dyn Write, text: Vec<u8>| -> Result<(), String> {
        written += text.len();
        if written > crate::job_check::MAX_OUTPUT_BYTES {
            return Err(too_large());
        }
        match header.task {
            // A check cuts what would be plotted, as the plotter task will.
            Task::Check => plotcode::cut(&text, &device).map(drop).map_err(|e| e.to_string()),
            Task::Render => frame(out, b'P', &text).map_err(|e| e.to_string()),
        }
    };
    let result = match (header.task, header.kind) {
        (task, JobKind::Scene) => crate::convert::load_scene(content, &attached).and_then(|scene| {
            crate::job_check::scene_work(&scene.work())?;
            match task {
                // Rendering waits for the plotter.
                Task::Check => crate::job_check::engine_work(&scene, header.face_tests),
                Task::Render => crate::convert::render_scene(&scene, &device, pens, &mut |text| emit(out, text)),
            }
        }),
        (_, JobKind::Svg) => crate::convert::render_svg(content, &device, pens, header.occult).and_then(|text| emit(out, text)),
        (task, JobKind::Hpgl | JobKind::Gcode) => crate::convert::fits(header.kind, &device).and_then(|()| {
            if task == Task::Check {
                crate::job_check::device_text(content, &device)?;
            }
            emit(out, content.to_vec())
        }),
    };
    match result {
        Ok(()) => frame(out, b'O', b""),
        Err(e) => frame(out, b'E', e.as_bytes()),
    }
}

/// `plotd render` under a budget: runs this binary again with the same
/// arguments and `--budgeted`, with the budget's limits, and waits for it
/// up to the budget's time. Returns the exit code.
///
/// # Errors
/// The child could not be started, or it went past the budget or crashed
/// (the error says which).
pub fn run_cli_budgeted(budget: &Budget) -> Result<u8, WorkerError> {
    let mut cmd = std::process::Command::new(std::env::current_exe()?);
    cmd.args(std::env::args_os().skip(1)).arg("--budgeted").stderr(std::process::Stdio::piped());
    budget.limit(&mut cmd);
    let mut child = cmd.spawn()?;
    // The child's stderr is passed through, its end kept to explain a crash.
    let mut stderr = child.stderr.take().expect("piped");
    let relay = std::thread::spawn(move || {
        let mut kept = Vec::new();
        let mut buf = [0u8; 4096];
        while let Ok(n @ 1..) = stderr.read(&mut buf) {
            let _ = std::io::stderr().write_all(&buf[..n]);
            kept.extend_from_slice(&buf[..n]);
            let excess = kept.len().saturating_sub(STDERR_KEPT);
            kept.drain(..excess);
        }
        kept
    });
    // The child's end is waited for on a thread of its own, without reaping
    // it (`WNOWAIT`): so it is seen the moment it comes (a polling step was
    // a millisecond of every render on average), and its pid cannot be
    // reused until `child.wait()` below reaps it, so the kill at the
    // deadline can only reach it.
    let pid = nix::unistd::Pid::from_raw(i32::try_from(child.id()).unwrap_or(i32::MAX));
    let (ended, end) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        use nix::sys::wait::{waitid, Id, WaitPidFlag};
        while waitid(Id::Pid(pid), WaitPidFlag::WEXITED | WaitPidFlag::WNOWAIT) == Err(nix::errno::Errno::EINTR) {}
        let _ = ended.send(());
    });
    let timed_out = end.recv_timeout(budget.deadline()).is_err();
    if timed_out {
        let _ = child.kill();
    }
    let status = child.wait()?;
    let kept = relay.join().unwrap_or_default();
    match status.code() {
        Some(code) if !timed_out && (code == 0 || code == 1) => Ok(u8::try_from(code).unwrap_or(1)),
        _ => Err(budget.explain(Some(status), &kept, timed_out)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::os::unix::process::ExitStatusExt;

    fn hp() -> DeviceProfile {
        DeviceProfile::builtin("hp7475a").unwrap()
    }

    #[tokio::test]
    async fn a_job_is_checked_and_rendered_page_by_page() {
        let worker = Worker { exe: None, budget: Budget::default() };
        let device = hp();
        let (files, pens, pen_table) = (BTreeMap::new(), PenMap::new(), PenSettings::new());
        let job = |kind, content: &'static [u8]| JobInput {
            kind,
            content,
            files: &files,
            device: &device,
            pens: &pens,
            pen_table: &pen_table,
            occult: None,
        };
        worker.check(job(JobKind::Hpgl, b"IN;SP1;PU0,0;PD10,10;PU;")).await.unwrap();
        let e = worker.check(job(JobKind::Hpgl, b"IN;QQ;")).await.unwrap_err();
        assert!(matches!(&e, WorkerError::Refused(m) if m.contains("byte 3") && m.contains("QQ")), "{e}");
        let scene =
            b"[camera]\neye = [4.0, 3.0, 2.5]\ntarget = [0.0, 0.0, 0.0]\nfov_deg = 30.0\n[[polyline]]\npoints = [[0, 0, 0], [1, 0, 0]]\n";
        worker.check(job(JobKind::Scene, scene)).await.unwrap();
        let mut pages = Vec::new();
        worker
            .render(
                job(JobKind::Scene, scene),
                &mut |p| {
                    pages.push(p);
                    Ok(())
                },
                std::future::pending(),
            )
            .await
            .unwrap();
        assert_eq!(pages.len(), 1);
        assert!(pages[0].starts_with(b"IN;"), "{}", String::from_utf8_lossy(&pages[0]));
    }

    #[test]
    fn a_worker_that_did_not_finish_is_explained() {
        let budget = Budget { seconds: 2.0, memory_mb: 100, ..Budget::default() };
        let killed = |sig: i32| Some(ExitStatus::from_raw(sig));
        assert!(budget.explain(None, b"", true).to_string().contains("budget of 2 s"));
        assert!(budget.explain(killed(nix::libc::SIGXCPU), b"", false).to_string().contains("budget of 2 s"));
        let oom = budget.explain(killed(nix::libc::SIGABRT), b"memory allocation of 4096 bytes failed\n", false);
        assert!(oom.to_string().contains("budget of 100 MiB"), "{oom}");
        let deep = budget.explain(
            killed(nix::libc::SIGABRT),
            b"\nthread 'main' has overflowed its stack\nfatal runtime error: stack overflow\n",
            false,
        );
        assert!(deep.to_string().contains("stack overflow"), "{deep}");
        let panic =
            budget.explain(Some(ExitStatus::from_raw(101 << 8)), b"thread 'main' panicked at src/x.rs:1:1:\nindex out of bounds\n", false);
        assert_eq!(panic.to_string(), "the renderer crashed: exit code 101: index out of bounds");
    }
}
