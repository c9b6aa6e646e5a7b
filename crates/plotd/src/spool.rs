//! The crash-safe spool: every job's content and state on disk.
//!
//! Layout under the spool directory:
//! - `jobs/<id>.json`: the job's record (who, what, where, state, checkpoint);
//! - `data/<id>`: the submitted bytes, never changed after submission;
//! - `data/<id>.files.json`: for a scene that names files, those files (the
//!   attachments, relative name -> base64), written before the record too;
//! - `written/<id>`: how far the streamer has written the job to the device
//!   ([`Written`]), overwritten in place before and after every write, and
//!   the last checkpoint the device confirmed ([`WrittenMark`]);
//! - `plotters/<name>.json`: what a plotter keeps between jobs and across
//!   restarts ([`PlotterState`]: whether its sheet is fresh), written as
//!   records are.
//!
//! Every write goes to a temporary file that is fsynced, renamed over the
//! target, and then the directory is fsynced, so after a crash (SIGKILL, power
//! loss) each file is either the old or the new version, never a torn one. A
//! job exists once its record is renamed into `jobs/`; the content is written
//! before that, so a record never points at missing content.
//!
//! Files are created mode 0600 and directories 0700 whatever the umask: jobs
//! are their submitters' drawings. One daemon at a time: [`Spool::lock`]
//! takes an exclusive `flock` on `lock` before anything reads or changes the
//! spool, and holds it until the daemon exits. The spool and each of its
//! directories must be the daemon's own (`crate::trusted_path`): owned by
//! its user, writable by no one else, not links; files are made with
//! `O_EXCL` and `O_NOFOLLOW` after removing whatever was at their name, and
//! read only when they are regular files of the daemon's user, so nothing
//! another user plants is written through, followed or waited on.
//!
//! A record that cannot be read is moved aside to `corrupt/<id>.json` with
//! its content left in `data/`, and shown as such ([`CorruptRecord`]); ids
//! come from every file name on disk, readable or not
//! ([`Spool::highest_id`]), so a new job never takes the id of one whose
//! record is damaged.
//!
//! Finished jobs beyond the configured number are deleted ([`Spool::remove`]):
//! the record first, then its files, so a crash in between leaves only
//! files without a record, which the next start deletes ([`Spool::recover`]).
//!
//! The written mark is the exception: it changes several times a second while
//! plotting, so it is written in place with no fsync. A SIGKILL does not lose
//! page-cache writes, so a restarted daemon reads the last mark; after a host
//! power loss it may be stale or missing, and the fsynced checkpoint decides.

use crate::trusted_path::read_own_file;
use crate::written::Written;
use base64::engine::general_purpose::STANDARD as BASE64;
use base64::Engine as _;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::fs::{self, File, OpenOptions};
use std::io::Write;
use std::os::unix::fs::{DirBuilderExt, FileExt, OpenOptionsExt};
use std::path::{Path, PathBuf};
use thiserror::Error;

/// A spool operation failed.
#[derive(Debug, Error)]
pub enum SpoolError {
    /// A file operation failed.
    #[error("spool {path}: {source}")]
    Io {
        /// The file or directory.
        path: PathBuf,
        /// What the OS said.
        source: std::io::Error,
    },
    /// A record could not be read back.
    #[error("spool {path}: corrupt record: {message}")]
    Corrupt {
        /// The record file.
        path: PathBuf,
        /// The decoder's message.
        message: String,
    },
    /// The spool, one of its directories or its lock is not the daemon's
    /// own (another user's, open to others, a link): nothing was read.
    #[error("spool {0}")]
    Untrusted(#[from] crate::trusted_path::UntrustedPath),
    /// Another process holds the spool's lock: a second daemon on the same spool.
    #[error("spool {path} is in use by another plotd (its lock file is held); stop that daemon first")]
    Locked {
        /// The spool directory.
        path: PathBuf,
    },
}

/// A job record that could not be read, moved aside (see the module doc).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct CorruptRecord {
    /// The job id its file name gives.
    pub id: JobId,
    /// Where the record is kept now.
    pub path: PathBuf,
    /// Why it could not be read.
    pub reason: String,
}

/// The spool's exclusive lock, held while this value lives ([`Spool::lock`]).
#[derive(Debug)]
pub struct SpoolLock {
    _file: nix::fcntl::Flock<File>,
}

/// Job identifier: increasing in submission order.
pub type JobId = u64;

/// What kind of content a job carries.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum JobKind {
    /// A scene file (TOML), rendered by the daemon.
    Scene,
    /// HP-GL, streamed as given.
    Hpgl,
    /// G-code, streamed as given.
    Gcode,
    /// SVG, converted to strokes by the daemon.
    Svg,
}

/// What an SVG job's filled shapes hide of the lines under them
/// (`submit --occult`, `--occult-across`), as `plotd render` does.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Occult {
    /// A fill hides the earlier lines of its own layer (pen).
    Layer,
    /// A fill hides the earlier lines of every layer.
    Across,
}

impl From<Occult> for strokes::occult::Occlusion {
    fn from(o: Occult) -> Self {
        match o {
            Occult::Layer => strokes::occult::Occlusion::PerGroup,
            Occult::Across => strokes::occult::Occlusion::Across,
        }
    }
}

impl JobKind {
    /// The kind a file name suggests, from its extension.
    #[must_use]
    pub fn from_path(path: &Path) -> Option<JobKind> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        match ext.as_str() {
            "toml" => Some(JobKind::Scene),
            "hpgl" | "hpg" | "plt" | "hgl" => Some(JobKind::Hpgl),
            "gcode" | "nc" | "ngc" | "gc" => Some(JobKind::Gcode),
            "svg" => Some(JobKind::Svg),
            _ => None,
        }
    }
}

/// Where a job is in its life.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "state", rename_all = "lowercase")]
pub enum JobState {
    /// Waiting for its plotter.
    Queued,
    /// Being turned into device commands.
    Rendering,
    /// Streaming to the plotter.
    Plotting,
    /// Stopped mid-job until `resume` (or `pen-changed`), or, held by the
    /// device, until it goes on by itself.
    Paused {
        /// Why, for the daemon: what lets the job go on. Records written
        /// before the cause was stored load as [`PauseCause::Person`].
        #[serde(default)]
        cause: PauseCause,
        /// Why, for humans.
        reason: String,
        /// The pen the user must insert, when the pause is a pen change.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        insert_pen: Option<u32>,
        /// The page (animation frame, from 0) whose paper the user must load,
        /// when the pause is a paper change.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        load_page: Option<usize>,
    },
    /// Plotted to the end.
    Done,
    /// Cannot be plotted.
    Failed {
        /// Why, for humans.
        reason: String,
    },
    /// Cancelled by a user.
    Cancelled,
}

impl JobState {
    /// Whether the job will never plot again.
    #[must_use]
    pub fn is_final(&self) -> bool {
        matches!(self, JobState::Done | JobState::Failed { .. } | JobState::Cancelled)
    }
    /// Short name: `queued`, `plotting`, ...
    #[must_use]
    pub fn name(&self) -> &'static str {
        match self {
            JobState::Queued => "queued",
            JobState::Rendering => "rendering",
            JobState::Plotting => "plotting",
            JobState::Paused { .. } => "paused",
            JobState::Done => "done",
            JobState::Failed { .. } => "failed",
            JobState::Cancelled => "cancelled",
        }
    }
    /// A paused state for `cause`, with `reason` for humans.
    #[must_use]
    pub fn paused(cause: PauseCause, reason: impl Into<String>) -> JobState {
        JobState::Paused { cause, reason: reason.into(), insert_pen: None, load_page: None }
    }

    /// Why the job is paused, when it is.
    #[must_use]
    pub fn pause_cause(&self) -> Option<PauseCause> {
        match self {
            JobState::Paused { cause, .. } => Some(*cause),
            _ => None,
        }
    }
}

/// Why a job is paused: what lets it go on. Stored in the record (`cause`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum PauseCause {
    /// A person paused it (`plotd pause`): `resume`. Also every record
    /// written before the cause was stored.
    #[default]
    Person,
    /// The daemon stopped or restarted mid-job: `resume`.
    Interrupted,
    /// The plotter's link was lost, or the plotter was power-cycled:
    /// `resume` once it answers again, or by itself with `auto_resume`.
    Offline,
    /// The device reported an error (`on_device_error = "pause"`): `resume`.
    DeviceError,
    /// A pen (`insert_pen`) or paper (`load_page`) must be loaded:
    /// `pen-changed` or `resume`.
    Load,
    /// The device holds the job itself (HP-GL: the paper lever raised) and
    /// goes on when it is lowered; the job is still the plotter's running
    /// job, so `resume` is refused.
    DeviceHold,
    /// A checkpoint could not be saved: `resume` once the spool can be written.
    Unsaved,
    /// The device's coordinates cannot be trusted (it was reset or
    /// power-cycled mid-job): `resume --position-confirmed` once a person
    /// has parked the pen at the origin.
    PositionLost,
    /// The job would draw over the last job's sheet: `sheet-loaded` once a
    /// fresh one is in.
    LoadSheet,
    /// The board is locked until it is homed (GRBL with homing enabled,
    /// `$22=1`, starts so): `resume` homes it where the plotter has
    /// switches (`homing = true`), else `resume --position-confirmed` once
    /// a person has parked the pen at the origin.
    NeedsHoming,
}

/// A job's persistent record.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct JobRecord {
    /// The job's id.
    pub id: JobId,
    /// Content kind.
    pub kind: JobKind,
    /// Target plotter name; for a job submitted for a class of plotters
    /// ([`JobRecord::class`]), the class's name until a plotter takes it.
    pub plotter: String,
    /// Submitted for a class of plotters (`any`, or a device) rather than
    /// one: kept across restarts, so the job still waits for any of them.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub class: Option<PlotterClass>,
    /// A name for humans (the submitted file's name).
    pub name: String,
    /// Submitter's uid, from the socket's peer credentials.
    pub uid: u32,
    /// Submitter's pid, from the socket's peer credentials (0 if unknown).
    pub pid: i32,
    /// Submission time, seconds since the Unix epoch.
    pub submitted_at: u64,
    /// Current state.
    #[serde(flatten)]
    pub state: JobState,
    /// Chunks the device has confirmed executing: plotting resumes at this index.
    pub checkpoint: usize,
    /// Number of chunks, once the job has been cut into them.
    pub total: Option<usize>,
    /// Strokes (chunks that draw) among the first `checkpoint` chunks: what
    /// progress reports count.
    #[serde(default)]
    pub strokes_done: usize,
    /// Strokes in the job, once it has been cut into chunks.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub strokes_total: Option<usize>,
    /// On a device whose pens a human changes: the pen the user has put in.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pen_loaded: Option<u32>,
    /// For a job of several pages (an animation's frames): the page whose
    /// paper is in the plotter.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub page_loaded: usize,
    /// Drawn on the sheet already in the plotter (an overlay, a second
    /// pass): it never waits for a fresh one.
    #[serde(default, skip_serializing_if = "is_false")]
    pub same_sheet: bool,
    /// The plotter's origin offset the job is drawn with, mm: taken when
    /// its first run starts, kept for every run after (a job goes on where
    /// it began).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub offset_mm: Option<[f64; 2]>,
    /// Sheets to draw the job on, one after another (`--copies`), each
    /// after a fresh one is loaded.
    #[serde(default = "one", skip_serializing_if = "is_one")]
    pub copies: u32,
    /// Which of them is being drawn, from 1.
    #[serde(default = "one", skip_serializing_if = "is_one")]
    pub copy: u32,
    /// The plotter's pen for each pen of the job that is drawn with
    /// another (`--pens`, [`crate::pen_map`]).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty", with = "crate::pen_map::as_pairs")]
    pub pens: BTreeMap<u32, u32>,
    /// For an SVG drawing: what its fills hide (`--occult`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub occult: Option<Occult>,
}

/// The plotters a job submitted for a class (`--plotter any`, or a device
/// name) may go to.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct PlotterClass {
    /// What the submit named: `any`, or a device profile's name.
    pub name: String,
    /// The plotters whose device, paper and pens can draw the job (found
    /// at submit), in config order; empty once one of them took it.
    pub fits: Vec<String>,
}

/// A record tests start from: an HP-GL job as submitted, queued, nothing
/// drawn; each test sets what it is about with `..JobRecord::queued(..)`.
#[cfg(test)]
impl JobRecord {
    pub(crate) fn queued(id: JobId, plotter: &str, name: &str) -> JobRecord {
        JobRecord {
            id,
            kind: JobKind::Hpgl,
            plotter: plotter.into(),
            class: None,
            name: name.into(),
            uid: 0,
            pid: 0,
            submitted_at: 0,
            state: JobState::Queued,
            checkpoint: 0,
            total: None,
            strokes_done: 0,
            strokes_total: None,
            pen_loaded: None,
            page_loaded: 0,
            same_sheet: false,
            offset_mm: None,
            copies: 1,
            copy: 1,
            pens: BTreeMap::new(),
            occult: None,
        }
    }
}

impl JobRecord {
    /// The plotters that may take the job, while none has: those its
    /// class fits.
    #[must_use]
    pub fn unclaimed(&self) -> Option<&[String]> {
        self.class.as_ref().map(|c| c.fits.as_slice()).filter(|fits| !fits.is_empty())
    }

    /// Whether plotter `name` runs the job: it was submitted to it, or
    /// it took it.
    #[must_use]
    pub fn is_on(&self, name: &str) -> bool {
        self.plotter == name && self.unclaimed().is_none()
    }
}

fn one() -> u32 {
    1
}

#[allow(clippy::trivially_copy_pass_by_ref)] // serde's signature
pub(crate) fn is_one(n: &u32) -> bool {
    *n == 1
}

#[allow(clippy::trivially_copy_pass_by_ref)] // serde's signature
fn is_false(b: &bool) -> bool {
    !*b
}

/// Whether the sheet in a plotter has been drawn on.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Sheet {
    /// Nothing drawn on it yet (also a plotter never used).
    #[default]
    Fresh,
    /// A job drew on it: the next job waits for a fresh one.
    Used,
}

/// What a plotter keeps between jobs, and across restarts.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PlotterState {
    /// Its sheet.
    pub sheet: Sheet,
    /// Its origin offset, mm along the device's axes (`plotd offset`): the
    /// jobs that start from then on are drawn moved by it.
    #[serde(default)]
    pub offset_mm: [f64; 2],
    /// The pen a person last put in a one-pen plotter (`None`: not known
    /// yet: the next job takes its first pen to be in). A job whose first
    /// pen is another asks for it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pen_loaded: Option<u32>,
}

#[allow(clippy::trivially_copy_pass_by_ref)] // serde's signature
fn is_zero(n: &usize) -> bool {
    *n == 0
}

/// Handle on a spool directory.
#[derive(Clone, Debug)]
pub struct Spool {
    root: PathBuf,
}

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> SpoolError + '_ {
    move |source| SpoolError::Io { path: path.to_owned(), source }
}

/// Mode of every file the spool creates.
const FILE_MODE: u32 = 0o600;
/// Mode of every directory the spool creates.
const DIR_MODE: u32 = 0o700;

/// A new file, mode [`FILE_MODE`]. Whatever was at `path` is removed first
/// and the file is made with `O_EXCL`: a link planted there is never
/// written through.
fn create_private(path: &Path) -> std::io::Result<File> {
    if let Err(e) = fs::remove_file(path) {
        if e.kind() != std::io::ErrorKind::NotFound {
            return Err(e);
        }
    }
    OpenOptions::new().write(true).create_new(true).custom_flags(nix::libc::O_NOFOLLOW).mode(FILE_MODE).open(path)
}

/// Creates `dir` and its missing parents (mode [`DIR_MODE`]), then checks it
/// is the daemon's own ([`crate::trusted_path::check_own_dir`]).
fn create_dirs(dir: &Path) -> Result<(), SpoolError> {
    fs::DirBuilder::new().recursive(true).mode(DIR_MODE).create(dir).map_err(io_err(dir))?;
    crate::trusted_path::check_own_dir(dir)?;
    Ok(())
}

/// Writes `bytes` to `path` atomically and durably: temp file, fsync, rename,
/// fsync dir. A temp file is removed when anything fails (a full disk leaves
/// no `.N.json.K.tmp` behind). Each write has a temp file of its own (`K`
/// counts the process's writes): two saves of one record at once once
/// shared one, and the later rename found it gone ("jobs/1.json: No such
/// file or directory", the job paused `unsaved`).
fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), SpoolError> {
    static WRITES: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let dir = path.parent().expect("spool files live in a directory");
    let name = path.file_name().and_then(|n| n.to_str()).expect("spool file names are ASCII");
    let k = WRITES.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let tmp = dir.join(format!(".{name}.{k}.tmp"));
    let written = (|| {
        let mut f = create_private(&tmp).map_err(io_err(&tmp))?;
        f.write_all(bytes).map_err(io_err(&tmp))?;
        f.sync_all().map_err(io_err(&tmp))?;
        drop(f);
        fs::rename(&tmp, path).map_err(io_err(path))
    })();
    if written.is_err() {
        let _ = fs::remove_file(&tmp);
    }
    written?;
    File::open(dir).and_then(|d| d.sync_all()).map_err(io_err(dir))
}

fn remove_if_there(path: &Path) -> Result<(), SpoolError> {
    match fs::remove_file(path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(SpoolError::Io { path: path.to_owned(), source: e }),
        _ => Ok(()),
    }
}

impl Spool {
    /// Opens (creating if needed) the spool at `root`.
    ///
    /// # Errors
    /// [`SpoolError::Io`] when the directories cannot be created;
    /// [`SpoolError::Untrusted`] when one is not the daemon's own.
    pub fn open(root: &Path) -> Result<Spool, SpoolError> {
        create_dirs(root)?;
        for sub in ["jobs", "data", "written", "corrupt", "plotters"] {
            create_dirs(&root.join(sub))?;
        }
        Ok(Spool { root: root.to_owned() })
    }

    /// Takes the exclusive lock on the spool at `root` (creating the
    /// directory and its `lock` file if needed), without waiting.
    ///
    /// # Errors
    /// [`SpoolError::Locked`] when another process holds it;
    /// [`SpoolError::Untrusted`] when the directory or the lock file is not
    /// the daemon's own; [`SpoolError::Io`] when the lock file cannot be opened.
    pub fn lock(root: &Path) -> Result<SpoolLock, SpoolError> {
        create_dirs(root)?;
        let path = root.join("lock");
        let file = crate::trusted_path::open_own_file_to_write(&path, FILE_MODE, true).map_err(io_err(&path))?;
        match nix::fcntl::Flock::lock(file, nix::fcntl::FlockArg::LockExclusiveNonblock) {
            Ok(file) => Ok(SpoolLock { _file: file }),
            Err((_, nix::errno::Errno::EWOULDBLOCK)) => Err(SpoolError::Locked { path: root.to_owned() }),
            Err((_, e)) => Err(SpoolError::Io { path, source: e.into() }),
        }
    }

    /// The spool directory.
    #[must_use]
    pub fn root(&self) -> &Path {
        &self.root
    }

    fn record_path(&self, id: JobId) -> PathBuf {
        self.root.join("jobs").join(format!("{id}.json"))
    }
    fn data_path(&self, id: JobId) -> PathBuf {
        self.root.join("data").join(id.to_string())
    }
    fn files_path(&self, id: JobId) -> PathBuf {
        self.root.join("data").join(format!("{id}.files.json"))
    }
    fn written_path(&self, id: JobId) -> PathBuf {
        self.root.join("written").join(id.to_string())
    }
    fn corrupt_path(&self, id: JobId) -> PathBuf {
        self.root.join("corrupt").join(format!("{id}.json"))
    }
    /// A plotter's state file: its name as it is when that is a plain
    /// word (letters, digits, `-`, `_`), else `%` and its bytes in hex
    /// (a name may hold any character but `/`).
    fn plotter_path(&self, name: &str) -> PathBuf {
        let plain = !name.is_empty() && name.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'-' || b == b'_');
        let file = if plain { name.to_owned() } else { name.bytes().fold(String::from("%"), |s, b| s + &format!("{b:02x}")) };
        self.root.join("plotters").join(format!("{file}.json"))
    }

    /// Plotter `name`'s state as last saved; the default (a fresh sheet)
    /// when none was.
    ///
    /// # Errors
    /// [`SpoolError`] when its file cannot be read or decoded.
    pub fn plotter_state(&self, name: &str) -> Result<PlotterState, SpoolError> {
        let path = self.plotter_path(name);
        match read_own_file(&path) {
            Ok(bytes) => serde_json::from_slice(&bytes).map_err(|e| SpoolError::Corrupt { path, message: e.to_string() }),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(PlotterState::default()),
            Err(source) => Err(SpoolError::Io { path, source }),
        }
    }

    /// Saves plotter `name`'s state, as a record is saved.
    ///
    /// # Errors
    /// [`SpoolError::Io`].
    pub fn save_plotter(&self, name: &str, state: &PlotterState) -> Result<(), SpoolError> {
        let json = serde_json::to_vec_pretty(state).expect("plotter states serialise");
        write_atomic(&self.plotter_path(name), &json)
    }

    /// The highest job id any file in the spool is named after (records,
    /// content, marks, records kept aside), readable or not; 0 for none.
    ///
    /// # Errors
    /// [`SpoolError::Io`] when a directory cannot be listed.
    pub fn highest_id(&self) -> Result<JobId, SpoolError> {
        let mut max = 0;
        for sub in ["jobs", "data", "written", "corrupt"] {
            let dir = self.root.join(sub);
            for entry in fs::read_dir(&dir).map_err(io_err(&dir))? {
                let name = entry.map_err(io_err(&dir))?.file_name();
                let Some(name) = name.to_str() else { continue };
                // `7.json`, `7`, `7.files.json`, `.7.json.3.tmp`.
                let digits = name.trim_start_matches('.').split('.').next().unwrap_or("");
                if let Ok(id) = digits.parse::<JobId>() {
                    max = max.max(id);
                }
            }
        }
        Ok(max)
    }

    /// Records moved aside because they could not be read.
    ///
    /// # Errors
    /// [`SpoolError::Io`] when the directory cannot be listed.
    pub fn corrupt_records(&self) -> Result<Vec<CorruptRecord>, SpoolError> {
        let dir = self.root.join("corrupt");
        let mut out = Vec::new();
        for entry in fs::read_dir(&dir).map_err(io_err(&dir))? {
            let path = entry.map_err(io_err(&dir))?.path();
            let Some(id) = path.file_name().and_then(|n| n.to_str()).and_then(|n| n.strip_suffix(".json")).and_then(|n| n.parse().ok())
            else {
                continue;
            };
            let reason = match read_own_file(&path) {
                Ok(bytes) => match serde_json::from_slice::<JobRecord>(&bytes) {
                    Ok(_) => "readable now; move it back to jobs/ to restore the job".to_owned(),
                    Err(e) => e.to_string(),
                },
                Err(e) => e.to_string(),
            };
            out.push(CorruptRecord { id, path, reason });
        }
        out.sort_by_key(|c| c.id);
        Ok(out)
    }

    /// Opens job `id`'s written mark for updating.
    ///
    /// # Errors
    /// [`SpoolError::Io`].
    pub fn written_log(&self, id: JobId) -> Result<WrittenLog, SpoolError> {
        let path = self.written_path(id);
        let file = crate::trusted_path::open_own_file_to_write(&path, FILE_MODE, false).map_err(io_err(&path))?;
        Ok(WrittenLog { file, path, last: None })
    }

    /// Job `id`'s last written mark; `None` when there is none or it cannot be
    /// read (then only the checkpoint counts).
    #[must_use]
    pub fn written(&self, id: JobId) -> Option<WrittenMark> {
        let text = String::from_utf8(read_own_file(&self.written_path(id)).ok()?).ok()?;
        let mut words = text.split_whitespace();
        let (kind, n) = (words.next()?, words.next()?.parse().ok()?);
        // Marks written before the confirmation was kept beside them have none.
        let confirmed = words.next().map_or(Some(0), |c| c.parse().ok())?;
        let mark = match kind {
            "through" => Written::Through(n),
            "into" => Written::Into(n),
            _ => return None,
        };
        Some(WrittenMark { mark, confirmed })
    }

    /// Forgets job `id`'s written mark: what the device holds is no longer
    /// known to be what was written (it was told to drop it, or reported an error).
    pub fn clear_written(&self, id: JobId) {
        let path = self.written_path(id);
        if let Err(e) = fs::remove_file(&path) {
            if e.kind() != std::io::ErrorKind::NotFound {
                tracing::warn!(path = %path.display(), error = %e, "cannot remove the written mark");
            }
        }
    }

    /// Deletes job `id` from the spool: its record first (made durable),
    /// then its content, attachments and written mark. Files already gone
    /// are not an error.
    ///
    /// # Errors
    /// [`SpoolError::Io`].
    pub fn remove(&self, id: JobId) -> Result<(), SpoolError> {
        let record = self.record_path(id);
        remove_if_there(&record)?;
        let jobs = self.root.join("jobs");
        File::open(&jobs).and_then(|d| d.sync_all()).map_err(io_err(&jobs))?;
        for path in [self.data_path(id), self.files_path(id), self.written_path(id)] {
            remove_if_there(&path)?;
        }
        Ok(())
    }

    /// Deletes content, attachments and written marks that no record names:
    /// left by a crash inside [`Spool::remove`] or [`Spool::create`]. Only
    /// safe while nothing is being created, so only at start.
    fn remove_orphans(&self) -> Result<(), SpoolError> {
        for sub in ["data", "written"] {
            let dir = self.root.join(sub);
            for entry in fs::read_dir(&dir).map_err(io_err(&dir))? {
                let path = entry.map_err(io_err(&dir))?.path();
                let Some(name) = path.file_name().and_then(|n| n.to_str()) else { continue };
                let id = name.strip_suffix(".files.json").unwrap_or(name);
                let Ok(id) = id.parse::<JobId>() else { continue };
                // A record kept aside keeps its content: it may be repaired.
                if !self.record_path(id).exists() && !self.corrupt_path(id).exists() {
                    tracing::info!(path = %path.display(), "removing a file no job record names");
                    remove_if_there(&path)?;
                }
            }
        }
        Ok(())
    }

    /// Stores a new job: content first, then its record. When this returns, the
    /// job survives a crash.
    ///
    /// # Errors
    /// [`SpoolError::Io`]; a half-written job leaves no record behind.
    pub fn create(&self, record: &JobRecord, content: &[u8]) -> Result<(), SpoolError> {
        self.create_with_files(record, content, &BTreeMap::new())
    }

    /// [`Spool::create`] for a job with attachments (the files a scene
    /// names): content and attachments first, then the record.
    ///
    /// # Errors
    /// As [`Spool::create`].
    pub fn create_with_files(&self, record: &JobRecord, content: &[u8], files: &BTreeMap<String, Vec<u8>>) -> Result<(), SpoolError> {
        write_atomic(&self.data_path(record.id), content)?;
        if !files.is_empty() {
            let encoded: BTreeMap<&str, String> = files.iter().map(|(k, v)| (k.as_str(), BASE64.encode(v))).collect();
            let json = serde_json::to_vec(&encoded).expect("attachments serialise");
            write_atomic(&self.files_path(record.id), &json)?;
        }
        self.save(record)
    }

    /// A job's attachments (empty when it has none).
    ///
    /// # Errors
    /// [`SpoolError::Io`], or [`SpoolError::Corrupt`] when the file does not decode.
    pub fn files(&self, id: JobId) -> Result<BTreeMap<String, Vec<u8>>, SpoolError> {
        let p = self.files_path(id);
        let bytes = match read_own_file(&p) {
            Ok(b) => b,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(BTreeMap::new()),
            Err(source) => return Err(SpoolError::Io { path: p, source }),
        };
        let corrupt = |message: String| SpoolError::Corrupt { path: p.clone(), message };
        let encoded: BTreeMap<String, String> = serde_json::from_slice(&bytes).map_err(|e| corrupt(e.to_string()))?;
        encoded
            .into_iter()
            .map(|(k, v)| BASE64.decode(v.as_bytes()).map(|b| (k.clone(), b)).map_err(|e| corrupt(format!("`{k}`: {e}"))))
            .collect()
    }

    /// Persists a record (new state or checkpoint).
    ///
    /// # Errors
    /// [`SpoolError::Io`].
    pub fn save(&self, record: &JobRecord) -> Result<(), SpoolError> {
        let json = serde_json::to_vec_pretty(record).expect("records serialise");
        write_atomic(&self.record_path(record.id), &json)
    }

    /// A job's submitted content.
    ///
    /// # Errors
    /// [`SpoolError::Io`].
    pub fn content(&self, id: JobId) -> Result<Vec<u8>, SpoolError> {
        let p = self.data_path(id);
        read_own_file(&p).map_err(io_err(&p))
    }

    /// Every job record in the spool, by id. Records that cannot be read are
    /// returned as errors beside the good ones, so one bad file loses no other job.
    ///
    /// # Errors
    /// [`SpoolError::Io`] when the directory cannot be listed.
    pub fn load_all(&self) -> Result<(Vec<JobRecord>, Vec<SpoolError>), SpoolError> {
        let dir = self.root.join("jobs");
        let mut jobs = Vec::new();
        let mut bad = Vec::new();
        for entry in fs::read_dir(&dir).map_err(io_err(&dir))? {
            let path = entry.map_err(io_err(&dir))?.path();
            let is_record = path.extension().is_some_and(|e| e == "json")
                && !path.file_name().and_then(|n| n.to_str()).is_some_and(|n| n.starts_with('.'));
            if !is_record {
                continue;
            }
            match read_own_file(&path) {
                Ok(bytes) => match serde_json::from_slice::<JobRecord>(&bytes) {
                    Ok(r) => jobs.push(r),
                    Err(e) => bad.push(SpoolError::Corrupt { path, message: e.to_string() }),
                },
                Err(source) => bad.push(SpoolError::Io { path, source }),
            }
        }
        jobs.sort_by_key(|j| j.id);
        Ok((jobs, bad))
    }

    /// Brings the spool back after a daemon stop or crash: every record
    /// that can be read, as it is (what a restart does to a job is the
    /// job's life's: `job::after_restart`), and the others moved to
    /// `corrupt/` (their content stays) and returned as errors; files no
    /// record names are deleted.
    ///
    /// # Errors
    /// [`SpoolError`] from listing or saving.
    pub fn recover(&self) -> Result<(Vec<JobRecord>, Vec<SpoolError>), SpoolError> {
        let (jobs, bad) = self.load_all()?;
        for e in &bad {
            let path = match e {
                SpoolError::Io { path, .. } | SpoolError::Corrupt { path, .. } => path,
                SpoolError::Locked { .. } | SpoolError::Untrusted(_) => continue,
            };
            let id = path.file_name().and_then(|n| n.to_str()).and_then(|n| n.strip_suffix(".json")).and_then(|n| n.parse().ok());
            let Some(id) = id else { continue };
            fs::rename(path, self.corrupt_path(id)).map_err(io_err(path))?;
            let dirs = [self.root.join("jobs"), self.root.join("corrupt")];
            for dir in &dirs {
                File::open(dir).and_then(|d| d.sync_all()).map_err(io_err(dir))?;
            }
        }
        self.remove_orphans()?;
        Ok((jobs, bad))
    }
}

/// Every mark has this length, so an overwrite in place leaves no tail of an
/// older, longer one.
const MARK_BYTES: usize = 32;

/// What a job's written log says (see [`Spool::written_log`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct WrittenMark {
    /// How far the job was handed to the device.
    pub mark: Written,
    /// The last checkpoint the run heard the device confirm. The job's
    /// record may be behind it (checkpoints are saved, with fsync, on a
    /// task of their own, so that reading the device never waits for the
    /// disk): after a SIGKILL this still says how far the device surely got.
    pub confirmed: usize,
}

/// An open written mark of one job (see [`Spool::written_log`]).
#[derive(Debug)]
pub struct WrittenLog {
    file: File,
    path: PathBuf,
    last: Option<WrittenMark>,
}

impl WrittenLog {
    /// Records `mark`, in place and without fsync (see the module doc); a
    /// mark equal to the last one costs nothing.
    ///
    /// # Errors
    /// [`SpoolError::Io`].
    pub fn set(&mut self, mark: Written) -> Result<(), SpoolError> {
        let confirmed = self.last.map_or(0, |l| l.confirmed);
        self.save(WrittenMark { mark, confirmed })
    }

    /// Records that the device confirmed chunks `..k`, beside the mark (no
    /// mark yet: chunks `..k` written).
    ///
    /// # Errors
    /// [`SpoolError::Io`].
    pub fn confirmed(&mut self, k: usize) -> Result<(), SpoolError> {
        let last = self.last.unwrap_or(WrittenMark { mark: Written::Through(k), confirmed: 0 });
        self.save(WrittenMark { confirmed: last.confirmed.max(k), ..last })
    }

    fn save(&mut self, w: WrittenMark) -> Result<(), SpoolError> {
        if self.last == Some(w) {
            return Ok(());
        }
        let (kind, n) = match w.mark {
            Written::Through(n) => ("through", n),
            Written::Into(n) => ("into", n),
        };
        let text = format!("{:<w$}\n", format!("{kind} {n} {}", w.confirmed), w = MARK_BYTES - 1);
        if text.len() != MARK_BYTES {
            return Err(SpoolError::Io { path: self.path.clone(), source: std::io::Error::other("written mark too long") });
        }
        self.file.write_all_at(text.as_bytes(), 0).map_err(io_err(&self.path))?;
        self.last = Some(w);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(id: JobId, state: JobState) -> JobRecord {
        JobRecord {
            uid: 1000,
            pid: 42,
            state,
            checkpoint: 3,
            total: Some(9),
            strokes_done: 2,
            strokes_total: Some(8),
            ..JobRecord::queued(id, "hp", "a.hpgl")
        }
    }

    /// A plotter's state survives a restart; one never saved is a fresh
    /// sheet, one unreadable an error naming its file; any name is a file.
    #[test]
    fn plotter_state_is_saved_and_read_back() {
        let dir = tempfile::tempdir().unwrap();
        let spool = Spool::open(dir.path()).unwrap();
        assert_eq!(spool.plotter_state("hp").unwrap(), PlotterState::default());
        let used = PlotterState { sheet: Sheet::Used, offset_mm: [10.0, -5.5], pen_loaded: Some(2) };
        for name in ["hp", "bench hp/2", "plotter é", "..", "%68"] {
            spool.save_plotter(name, &used).unwrap();
        }
        let spool = Spool::open(dir.path()).unwrap();
        for name in ["hp", "bench hp/2", "plotter é", "..", "%68"] {
            assert_eq!(spool.plotter_state(name).unwrap(), used, "{name}");
        }
        assert_eq!(spool.plotter_state("other").unwrap(), PlotterState::default());
        fs::write(dir.path().join("plotters/hp.json"), b"{").unwrap();
        let e = spool.plotter_state("hp").unwrap_err().to_string();
        assert!(e.contains("plotters/hp.json") && e.contains("corrupt"), "{e}");
    }

    #[test]
    fn written_mark_is_overwritten_in_place_and_read_back() {
        let dir = tempfile::tempdir().unwrap();
        let spool = Spool::open(dir.path()).unwrap();
        assert_eq!(spool.written(4), None);
        let mut log = spool.written_log(4).unwrap();
        log.set(Written::Into(123_456)).unwrap();
        assert_eq!(spool.written(4), Some(WrittenMark { mark: Written::Into(123_456), confirmed: 0 }));
        log.confirmed(123_455).unwrap();
        assert_eq!(spool.written(4), Some(WrittenMark { mark: Written::Into(123_456), confirmed: 123_455 }));
        // A shorter mark after a longer one leaves nothing of the old one.
        log.set(Written::Through(7)).unwrap();
        assert_eq!(spool.written(4), Some(WrittenMark { mark: Written::Through(7), confirmed: 123_455 }));
        assert_eq!(fs::read(dir.path().join("written/4")).unwrap().len(), MARK_BYTES);
        // A mark from before the confirmation was kept beside it.
        fs::write(dir.path().join("written/4"), format!("{:<31}\n", "into 12")).unwrap();
        assert_eq!(spool.written(4), Some(WrittenMark { mark: Written::Into(12), confirmed: 0 }));
        spool.clear_written(4);
        assert_eq!(spool.written(4), None);
        spool.clear_written(4);
    }

    /// A job of copies with a pen map and occlusion is read back as written
    /// (through the flattened state: pens as `[job, plotter]` pairs), and a
    /// record from before these fields loads as one copy with no map and
    /// nothing hidden.
    #[test]
    fn copies_and_a_pen_map_survive_a_restart() {
        let dir = tempfile::tempdir().unwrap();
        let spool = Spool::open(dir.path()).unwrap();
        let mut job = record(1, JobState::paused(PauseCause::LoadSheet, "copy 2 of 3: load a fresh sheet"));
        (job.copies, job.copy, job.pens, job.occult) = (3, 2, BTreeMap::from([(1, 3), (2, 1)]), Some(Occult::Across));
        spool.create(&job, b"<svg/>").unwrap();
        let written: serde_json::Value = serde_json::from_slice(&fs::read(dir.path().join("jobs/1.json")).unwrap()).unwrap();
        assert_eq!(written["pens"], serde_json::json!([[1, 3], [2, 1]]));
        assert_eq!(written["occult"], "across");
        spool.create(&record(2, JobState::Queued), b"IN;").unwrap();
        let (jobs, bad) = spool.recover().unwrap();
        assert!(bad.is_empty(), "{bad:?}");
        assert_eq!(jobs[0], job);
        assert_eq!((jobs[1].copies, jobs[1].copy, jobs[1].pens.len(), jobs[1].occult), (1, 1, 0, None));
        let old = fs::read_to_string(dir.path().join("jobs/2.json")).unwrap();
        assert!(!old.contains("copies") && !old.contains("occult"), "{old}");
    }

    /// Issue #15: the pause cause was a prefix of the reason text; it is a
    /// field now, and a record written before it loads (as a person's pause,
    /// which waits for `resume`).
    #[test]
    fn a_paused_record_without_a_cause_loads() {
        let dir = tempfile::tempdir().unwrap();
        let spool = Spool::open(dir.path()).unwrap();
        spool.create(&record(1, JobState::Queued), b"IN;").unwrap();
        let old = r#"{"id":1,"kind":"hpgl","plotter":"hp","name":"a.hpgl","uid":1000,"pid":42,"submitted_at":0,"state":"paused","reason":"device offline: the port failed: EIO","checkpoint":3,"total":9,"strokes_done":2,"strokes_total":8}"#;
        fs::write(dir.path().join("jobs/1.json"), old).unwrap();
        let (jobs, bad) = spool.recover().unwrap();
        assert!(bad.is_empty(), "{bad:?}");
        assert_eq!(jobs[0].state.pause_cause(), Some(PauseCause::Person));
        let JobState::Paused { reason, .. } = &jobs[0].state else { panic!("{:?}", jobs[0].state) };
        assert_eq!(reason, "device offline: the port failed: EIO");
        // Written again, the cause is stored.
        let v = serde_json::to_value(&jobs[0]).unwrap();
        assert_eq!(v["cause"], "person");
    }

    #[test]
    fn create_load_and_recover() {
        let dir = tempfile::tempdir().unwrap();
        let spool = Spool::open(dir.path()).unwrap();
        spool.create(&record(2, JobState::Plotting), b"IN;").unwrap();
        let mut fresh = record(1, JobState::Queued);
        fresh.checkpoint = 0;
        spool.create(&fresh, b"PU;").unwrap();
        spool.create(&record(3, JobState::Rendering), b"").unwrap();
        spool.create(&record(4, JobState::Done), b"").unwrap();
        // A torn temp file from a crash is ignored.
        fs::write(dir.path().join("jobs/.5.json.tmp"), b"{").unwrap();
        let (jobs, bad) = Spool::open(dir.path()).unwrap().recover().unwrap();
        assert!(bad.is_empty());
        // Records come back as they were saved, in id order.
        let states: Vec<&str> = jobs.iter().map(|j| j.state.name()).collect();
        assert_eq!(states, ["queued", "plotting", "rendering", "done"]);
        assert_eq!(jobs[1].checkpoint, 3);
        assert_eq!(spool.content(2).unwrap(), b"IN;");
        let (again, _) = spool.load_all().unwrap();
        assert_eq!(again, jobs);
    }

    #[test]
    fn removed_jobs_leave_nothing_and_orphans_go_at_recovery() {
        let dir = tempfile::tempdir().unwrap();
        let spool = Spool::open(dir.path()).unwrap();
        let files = BTreeMap::from([("a.csv".to_owned(), b"1".to_vec())]);
        spool.create_with_files(&record(1, JobState::Done), b"[camera]", &files).unwrap();
        spool.written_log(1).unwrap().set(Written::Through(2)).unwrap();
        spool.create(&record(2, JobState::Queued), b"IN;").unwrap();
        spool.remove(1).unwrap();
        spool.remove(1).unwrap();
        let left = |sub: &str| {
            let mut v: Vec<String> =
                fs::read_dir(dir.path().join(sub)).unwrap().map(|e| e.unwrap().file_name().into_string().unwrap()).collect();
            v.sort();
            v
        };
        assert_eq!((left("jobs"), left("data"), left("written")), (vec!["2.json".to_owned()], vec!["2".to_owned()], vec![]));
        // A crash between a removal's record and its content; a corrupt
        // record keeps its content (it may be repaired by hand).
        fs::write(dir.path().join("data/7"), b"x").unwrap();
        fs::write(dir.path().join("data/7.files.json"), b"{}").unwrap();
        fs::write(dir.path().join("written/7"), b"through 1").unwrap();
        fs::write(dir.path().join("jobs/8.json"), b"{not json").unwrap();
        fs::write(dir.path().join("data/8"), b"y").unwrap();
        let (jobs, bad) = spool.recover().unwrap();
        assert_eq!((jobs.len(), bad.len()), (1, 1));
        assert_eq!(left("data"), ["2", "8"]);
        assert!(left("written").is_empty());
    }

    fn mode(path: &Path) -> u32 {
        use std::os::unix::fs::PermissionsExt;
        fs::metadata(path).unwrap().permissions().mode() & 0o777
    }

    #[test]
    fn spool_files_are_private() {
        let dir = tempfile::tempdir().unwrap();
        let root = dir.path().join("spool");
        let spool = Spool::open(&root).unwrap();
        let files = BTreeMap::from([("a.csv".to_owned(), b"1".to_vec())]);
        spool.create_with_files(&record(1, JobState::Queued), b"[camera]", &files).unwrap();
        spool.written_log(1).unwrap().set(Written::Through(0)).unwrap();
        let _lock = Spool::lock(&root).unwrap();
        for f in ["jobs/1.json", "data/1", "data/1.files.json", "written/1", "lock"] {
            assert_eq!(mode(&root.join(f)), 0o600, "{f}");
        }
        for d in ["", "jobs", "data", "written", "corrupt"] {
            assert_eq!(mode(&root.join(d)), 0o700, "{d}/");
        }
    }

    #[test]
    fn a_spool_others_can_write_or_a_link_is_refused_before_it_is_read() {
        use std::os::unix::fs::PermissionsExt;
        // Issue #42: a spool another user made first (mode 0777) was taken as it was.
        let dir = tempfile::tempdir().unwrap();
        let root = dir.path().join("spool");
        fs::create_dir(&root).unwrap();
        fs::set_permissions(&root, fs::Permissions::from_mode(0o777)).unwrap();
        let e = Spool::lock(&root).unwrap_err();
        assert!(e.to_string().contains("can be written by other users"), "{e}");
        let e = Spool::open(&root).unwrap_err();
        assert!(e.to_string().contains("can be written by other users"), "{e}");
        // One of its directories open to others, or a link in its place.
        fs::set_permissions(&root, fs::Permissions::from_mode(0o700)).unwrap();
        Spool::open(&root).unwrap();
        fs::set_permissions(root.join("jobs"), fs::Permissions::from_mode(0o733)).unwrap();
        let e = Spool::open(&root).unwrap_err();
        assert!(e.to_string().contains("jobs") && e.to_string().contains("other users"), "{e}");
        fs::remove_dir(root.join("jobs")).unwrap();
        std::os::unix::fs::symlink(dir.path(), root.join("jobs")).unwrap();
        let e = Spool::open(&root).unwrap_err();
        assert!(e.to_string().contains("symbolic link"), "{e}");
    }

    #[test]
    fn planted_links_are_not_written_through_and_fifos_do_not_block() {
        let dir = tempfile::tempdir().unwrap();
        let spool = Spool::open(dir.path()).unwrap();
        let victim = dir.path().join("victim");
        fs::write(&victim, "precious").unwrap();
        // Links where the spool writes its temporary files and marks.
        for planted in ["jobs/.3.json.tmp", "data/.3.tmp", "written/3"] {
            std::os::unix::fs::symlink(&victim, dir.path().join(planted)).unwrap();
        }
        spool.create(&record(3, JobState::Queued), b"IN;").unwrap();
        assert!(spool.written_log(3).is_err(), "the mark's link is refused");
        assert_eq!(fs::read(&victim).unwrap(), b"precious");
        assert_eq!(spool.content(3).unwrap(), b"IN;");
        // A link or a FIFO where a record or content is read: refused, not
        // followed, never waited on.
        std::os::unix::fs::symlink(&victim, dir.path().join("jobs/4.json")).unwrap();
        nix::unistd::mkfifo(&dir.path().join("jobs/5.json"), nix::sys::stat::Mode::S_IRWXU).unwrap();
        std::os::unix::fs::symlink(&victim, dir.path().join("data/6")).unwrap();
        let (jobs, bad) = spool.recover().unwrap();
        assert_eq!(jobs.iter().map(|j| j.id).collect::<Vec<_>>(), [3]);
        assert_eq!(bad.len(), 2, "{bad:?}");
        assert!(spool.content(6).is_err());
        assert!(dir.path().join("corrupt/5.json").exists() && dir.path().join("corrupt/4.json").symlink_metadata().is_ok());
        assert_eq!(fs::read(&victim).unwrap(), b"precious");
    }

    #[test]
    fn one_lock_holder_at_a_time() {
        let dir = tempfile::tempdir().unwrap();
        let lock = Spool::lock(dir.path()).unwrap();
        let e = Spool::lock(dir.path()).unwrap_err();
        assert!(matches!(e, SpoolError::Locked { .. }) && e.to_string().contains("another plotd"), "{e}");
        drop(lock);
        Spool::lock(dir.path()).unwrap();
    }

    #[test]
    fn a_failed_write_leaves_no_temp_file() {
        let dir = tempfile::tempdir().unwrap();
        let spool = Spool::open(dir.path()).unwrap();
        // The rename cannot replace a directory: the write fails after its temp file.
        fs::create_dir_all(dir.path().join("jobs/5.json/x")).unwrap();
        assert!(spool.save(&record(5, JobState::Queued)).is_err());
        let names: Vec<_> = fs::read_dir(dir.path().join("jobs")).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert_eq!(names, ["5.json"]);
    }

    #[test]
    fn a_corrupt_record_is_kept_aside_with_its_content_and_its_id_stays_taken() {
        let dir = tempfile::tempdir().unwrap();
        let spool = Spool::open(dir.path()).unwrap();
        spool.create(&record(1, JobState::Queued), b"IN;").unwrap();
        spool.create(&record(2, JobState::Queued), b"IN;PU;").unwrap();
        // The newest job's record is torn.
        let torn = fs::read(dir.path().join("jobs/2.json")).unwrap();
        fs::write(dir.path().join("jobs/2.json"), &torn[..torn.len() / 2]).unwrap();
        let (jobs, bad) = spool.recover().unwrap();
        assert_eq!((jobs.len(), bad.len()), (1, 1));
        assert!(!dir.path().join("jobs/2.json").exists());
        assert_eq!(fs::read(dir.path().join("corrupt/2.json")).unwrap(), &torn[..torn.len() / 2]);
        assert_eq!(spool.content(2).unwrap(), b"IN;PU;");
        assert_eq!(spool.highest_id().unwrap(), 2);
        let corrupt = spool.corrupt_records().unwrap();
        assert_eq!(corrupt.len(), 1);
        assert_eq!((corrupt[0].id, corrupt[0].path.clone()), (2, dir.path().join("corrupt/2.json")));
        assert!(corrupt[0].reason.contains("EOF"), "{}", corrupt[0].reason);
        // Recovered again, nothing changes: the content is not an orphan.
        spool.recover().unwrap();
        assert_eq!(spool.content(2).unwrap(), b"IN;PU;");
        // Only content left of a job, or only a mark: its id is taken too.
        fs::write(dir.path().join("data/9.files.json"), b"{}").unwrap();
        assert_eq!(spool.highest_id().unwrap(), 9);
    }

    #[test]
    fn attachments_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let spool = Spool::open(dir.path()).unwrap();
        let files = BTreeMap::from([("map/a.csv".to_owned(), b"x,y\n".to_vec()), ("s.stl".to_owned(), vec![0, 255, 10])]);
        spool.create_with_files(&record(1, JobState::Queued), b"[camera]", &files).unwrap();
        spool.create(&record(2, JobState::Queued), b"IN;").unwrap();
        let again = Spool::open(dir.path()).unwrap();
        assert_eq!(again.files(1).unwrap(), files);
        assert!(again.files(2).unwrap().is_empty());
        fs::write(dir.path().join("data/2.files.json"), b"{\"a\":\"!!\"}").unwrap();
        assert!(again.files(2).unwrap_err().to_string().contains("`a`"));
    }

    #[test]
    fn corrupt_record_loses_no_other_job() {
        let dir = tempfile::tempdir().unwrap();
        let spool = Spool::open(dir.path()).unwrap();
        spool.create(&record(1, JobState::Queued), b"x").unwrap();
        fs::write(dir.path().join("jobs/2.json"), b"{not json").unwrap();
        let (jobs, bad) = spool.load_all().unwrap();
        assert_eq!(jobs.len(), 1);
        assert_eq!(bad.len(), 1);
        assert!(bad[0].to_string().contains("2.json"), "{}", bad[0]);
    }

    #[test]
    fn state_json_shape() {
        let r =
            record(7, JobState::Paused { cause: PauseCause::Load, reason: "insert pen 2".into(), insert_pen: Some(2), load_page: None });
        let v: serde_json::Value = serde_json::to_value(&r).unwrap();
        assert_eq!(v["state"], "paused");
        assert_eq!(v["reason"], "insert pen 2");
        assert_eq!(v["insert_pen"], 2);
    }

    #[test]
    fn kind_from_extension() {
        assert_eq!(JobKind::from_path(Path::new("a/b.TOML")), Some(JobKind::Scene));
        assert_eq!(JobKind::from_path(Path::new("x.plt")), Some(JobKind::Hpgl));
        assert_eq!(JobKind::from_path(Path::new("x.nc")), Some(JobKind::Gcode));
        assert_eq!(JobKind::from_path(Path::new("x")), None);
    }
}
