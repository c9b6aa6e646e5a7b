//! The socket protocol: newline-delimited JSON, one request per line, one
//! reply per line (`watch` replies with a stream of event lines).
//!
//! The full description, with examples, is in `docs/protocol.md`. This module
//! holds the message types and the framing (bytes in, messages out, with
//! "incomplete" a normal outcome); `daemon/server.rs` owns the socket and its buffer.
//!
//! The wire types are their own: a job on the wire is a [`JobInfo`], made
//! from the spool's record ([`JobRecord`], the disk format) by
//! [`JobInfo::of`], so either can change without the other. Their enums
//! ([`State`], [`LinkState`], the record's [`PauseCause`] and [`JobKind`])
//! are written in kebab-case, the spellings clients have always read.

use crate::spool::{is_one, CorruptRecord, JobId, JobKind, JobRecord, JobState, Occult, PauseCause, Sheet};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use thiserror::Error;

/// A client's request.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "cmd", rename_all = "kebab-case", deny_unknown_fields)]
pub enum Request {
    /// Queue a job. The client sends the file's bytes; the daemon never opens
    /// paths named by a client.
    Submit {
        /// Content kind.
        kind: JobKind,
        /// Target plotter; `None`: the first configured one.
        #[serde(default)]
        plotter: Option<String>,
        /// Name for humans (usually the file name).
        #[serde(default)]
        name: Option<String>,
        /// The file's content.
        content: String,
        /// For a scene: every file it names (outlines, places, meshes, height
        /// tables), by the relative name written in the scene, content in
        /// base64 (standard alphabet, padded). The daemon renders the scene
        /// from these alone.
        #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
        files: BTreeMap<String, String>,
        /// Draw on the sheet already in the plotter (an overlay, a second
        /// pass): never wait for a fresh one.
        #[serde(default, skip_serializing_if = "is_false")]
        same_sheet: bool,
        /// Sheets to draw it on, one after another, each after a fresh one
        /// is loaded (1 to [`crate::job::MAX_COPIES`]; default 1).
        #[serde(default = "one", skip_serializing_if = "is_one")]
        copies: u32,
        /// The plotter's pen for each pen of the job drawn with another
        /// (`"1": 3`; scenes and SVG drawings only).
        #[serde(default, skip_serializing_if = "BTreeMap::is_empty", with = "crate::pen_map::as_pairs")]
        pens: BTreeMap<u32, u32>,
        /// For an SVG drawing: the parts of lines under later filled shapes
        /// are hidden, within each layer (`"layer"`) or across layers
        /// (`"across"`), as `plotd render --occult` does.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        occult: Option<Occult>,
    },
    /// List jobs. (Braces, not a unit variant: serde lets a unit variant of
    /// a tagged enum ignore unknown fields, and a request with one must be
    /// refused, as every other request's is.)
    Jobs {},
    /// Daemon and plotter status.
    Status {},
    /// Cancel a job: a plotting one stops at the end of its stroke, or
    /// with `now` where the pen is.
    Cancel {
        /// The job.
        id: JobId,
        /// Stop the pen now (the device's buffer dropped, the pen lifted).
        #[serde(default, skip_serializing_if = "is_false")]
        now: bool,
    },
    /// Pause a job (`None`: every active job) at the next stroke boundary,
    /// or with `now` where the pen is (resume draws that stroke again).
    Pause {
        /// The job.
        #[serde(default)]
        id: Option<JobId>,
        /// Stop the pen now (the device's buffer dropped, the pen lifted).
        #[serde(default, skip_serializing_if = "is_false")]
        now: bool,
    },
    /// Resume a paused job (`None`: every paused job).
    Resume {
        /// The job.
        #[serde(default)]
        id: Option<JobId>,
        /// A person parked the pen at the paper's origin: a job whose
        /// device's position was lost (`position-lost`) may go on.
        #[serde(default, skip_serializing_if = "is_false")]
        position_confirmed: bool,
    },
    /// The pen asked for has been inserted on `plotter` (`None`: every plotter).
    PenChanged {
        /// The plotter.
        #[serde(default)]
        plotter: Option<String>,
    },
    /// A fresh sheet is in `plotter`: the job waiting for one goes on, and
    /// the next job draws on it.
    SheetLoaded {
        /// The plotter.
        plotter: String,
    },
    // A person at the plotter (issue 38 item 2): each refused while a job
    // plots on the plotter, answered once the device has done it.
    /// Raise or lower the pen where it is.
    Pen {
        /// The plotter (`None`: the only one).
        #[serde(default)]
        plotter: Option<String>,
        /// Lower it.
        down: bool,
    },
    /// Raise the pen and go to a point, mm from the device's origin.
    Move {
        /// The plotter (`None`: the only one).
        #[serde(default)]
        plotter: Option<String>,
        /// mm.
        x_mm: f64,
        /// mm.
        y_mm: f64,
    },
    /// Raise the pen and move by a step, mm.
    Jog {
        /// The plotter (`None`: the only one).
        #[serde(default)]
        plotter: Option<String>,
        /// mm.
        dx_mm: f64,
        /// mm.
        dy_mm: f64,
    },
    /// Run a GRBL plotter's homing cycle (`homing = true`): its zero found
    /// again at its switches; answered once the board confirmed.
    Home {
        /// The plotter (`None`: the only one).
        #[serde(default)]
        plotter: Option<String>,
    },
    /// Trace a job's bounding box on its plotter with the pen up, pausing
    /// at each corner.
    Frame {
        /// The job.
        id: JobId,
    },
    /// Move the drawings of the jobs that start from now on by this much
    /// on `plotter`'s sheet, mm along the device's axes (kept in the spool).
    Offset {
        /// The plotter.
        plotter: String,
        /// mm.
        dx_mm: f64,
        /// mm.
        dy_mm: f64,
    },
    /// Stream progress events for one job (`None`: all jobs) until the client
    /// disconnects, or until that job ends.
    Watch {
        /// The job.
        #[serde(default)]
        id: Option<JobId>,
    },
}

#[allow(clippy::trivially_copy_pass_by_ref)] // serde's signature
fn is_false(b: &bool) -> bool {
    !*b
}

/// Where a job is in its life, as clients see it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum State {
    /// Waiting for its plotter.
    Queued,
    /// Being turned into device commands.
    Rendering,
    /// Streaming to the plotter.
    Plotting,
    /// Stopped until `resume` (or `pen-changed`), or held by the device
    /// until it goes on: the job's `cause` says which.
    Paused,
    /// Plotted to the end.
    Done,
    /// Cannot be plotted (`reason` says why).
    Failed,
    /// Cancelled by a user.
    Cancelled,
}

impl State {
    /// The state of a spool record.
    #[must_use]
    pub fn of(state: &JobState) -> State {
        match state {
            JobState::Queued => State::Queued,
            JobState::Rendering => State::Rendering,
            JobState::Plotting => State::Plotting,
            JobState::Paused { .. } => State::Paused,
            JobState::Done => State::Done,
            JobState::Failed { .. } => State::Failed,
            JobState::Cancelled => State::Cancelled,
        }
    }

    /// Whether a job in this state will never plot again.
    #[must_use]
    pub fn is_final(self) -> bool {
        matches!(self, State::Done | State::Failed | State::Cancelled)
    }

    /// The name on the wire: `queued`, `plotting`, ...
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            State::Queued => "queued",
            State::Rendering => "rendering",
            State::Plotting => "plotting",
            State::Paused => "paused",
            State::Done => "done",
            State::Failed => "failed",
            State::Cancelled => "cancelled",
        }
    }
}

impl std::fmt::Display for State {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// A job as clients see it (`jobs`, `status`). The same fields as the
/// spool's record, flat: what a paused job waits for (`cause`,
/// `insert_pen`, `load_page`) and why it is paused or failed (`reason`)
/// are there when they apply.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct JobInfo {
    /// The job's id.
    pub id: JobId,
    /// Content kind.
    pub kind: JobKind,
    /// The plotter that has it: the one named at submit, or the one that
    /// took it; until one takes a job submitted for a class, the class.
    pub plotter: String,
    /// The class of plotters it was submitted for (`any`, or a device
    /// name), kept once a plotter took it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub class: Option<String>,
    /// A name for humans (the submitted file's name; any character: print it escaped).
    pub name: String,
    /// Submitter's uid.
    pub uid: u32,
    /// Submitter's pid (0 if unknown).
    pub pid: i32,
    /// Submission time, seconds since the Unix epoch.
    pub submitted_at: u64,
    /// Where the job is.
    pub state: State,
    /// What lets a paused job go on.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cause: Option<PauseCause>,
    /// Why it is paused or failed, for humans.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reason: Option<String>,
    /// The pen a person must insert, when the pause is a pen change.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub insert_pen: Option<u32>,
    /// The page (animation frame, from 0) whose paper a person must load.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub load_page: Option<usize>,
    /// Chunks the device has confirmed executing.
    pub checkpoint: usize,
    /// Chunks in the job, once known.
    pub total: Option<usize>,
    /// Strokes among the confirmed chunks.
    #[serde(default)]
    pub strokes_done: usize,
    /// Strokes in the job, once known.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub strokes_total: Option<usize>,
    /// On a device whose pens a person changes: the pen put in.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pen_loaded: Option<u32>,
    /// For a job of several pages: the page whose paper is in the plotter.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub page_loaded: usize,
    /// Drawn on the sheet already in the plotter: it never waits for a fresh one.
    #[serde(default, skip_serializing_if = "is_false")]
    pub same_sheet: bool,
    /// The plotter's origin offset it is drawn with (mm), once it started.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub offset_mm: Option<[f64; 2]>,
    /// Sheets it is drawn on, one after another (`--copies`; 1 unless said).
    #[serde(default = "one", skip_serializing_if = "is_one")]
    pub copies: u32,
    /// Which of them is being drawn, from 1.
    #[serde(default = "one", skip_serializing_if = "is_one")]
    pub copy: u32,
    /// The plotter's pen for each pen of the job drawn with another (`--pens`).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty", with = "crate::pen_map::as_pairs")]
    pub pens: BTreeMap<u32, u32>,
    /// What it waits for, when its plotter keeps it from going on.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub waiting: Option<Waiting>,
}

fn one() -> u32 {
    1
}

#[allow(clippy::trivially_copy_pass_by_ref)] // serde's signature
fn is_zero(n: &usize) -> bool {
    *n == 0
}

impl JobInfo {
    /// The job `record` describes.
    #[must_use]
    pub fn of(record: &JobRecord) -> JobInfo {
        let (cause, reason) = why(&record.state);
        let (insert_pen, load_page) = match record.state {
            JobState::Paused { insert_pen, load_page, .. } => (insert_pen, load_page),
            _ => (None, None),
        };
        JobInfo {
            id: record.id,
            kind: record.kind,
            plotter: record.plotter.clone(),
            class: record.class.as_ref().map(|c| c.name.clone()),
            name: record.name.clone(),
            uid: record.uid,
            pid: record.pid,
            submitted_at: record.submitted_at,
            state: State::of(&record.state),
            cause,
            reason,
            insert_pen,
            load_page,
            checkpoint: record.checkpoint,
            total: record.total,
            strokes_done: record.strokes_done,
            strokes_total: record.strokes_total,
            pen_loaded: record.pen_loaded,
            page_loaded: record.page_loaded,
            same_sheet: record.same_sheet,
            offset_mm: record.offset_mm,
            copies: record.copies,
            copy: record.copy,
            pens: record.pens.clone(),
            waiting: None,
        }
    }

    /// The job `record` describes, on a plotter that is as `reach` says:
    /// what it waits for and why, as now.
    #[must_use]
    pub fn waiting_on(record: &JobRecord, reach: &Reach) -> JobInfo {
        let (cause, reason, waiting) = told(record, reach);
        JobInfo { cause, reason, waiting, ..JobInfo::of(record) }
    }
}

/// Why a job in `state` waits (its pause's cause) and why it is paused or
/// failed (its reason), where they apply.
fn why(state: &JobState) -> (Option<PauseCause>, Option<String>) {
    match state {
        JobState::Paused { cause, reason, .. } => (Some(*cause), Some(reason.clone())),
        JobState::Failed { reason } => (None, Some(reason.clone())),
        _ => (None, None),
    }
}

/// What the daemon last found at a plotter's port.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum LinkState {
    /// Not tried yet.
    #[default]
    Unknown,
    /// The port is open and the device answered.
    Online,
    /// The port cannot be opened, failed, or the device does not answer.
    Offline,
}

impl std::fmt::Display for LinkState {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            LinkState::Unknown => "unknown",
            LinkState::Online => "online",
            LinkState::Offline => "offline",
        })
    }
}

/// Why a plotter is offline, typed for scripts (`kind`) with the sentence a
/// person reads (`message`): `{"kind": "no-such-port", "message":
/// "/dev/ttyUSB0: no such file"}`. Device text in a message is quoted,
/// escaped and cut short.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct LinkCause {
    /// What kind of fault.
    pub kind: LinkFault,
    /// What happened, for a person.
    pub message: String,
}

/// The kinds of [`LinkCause`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum LinkFault {
    /// The port's path does not exist (the adapter is unplugged, or the
    /// path is wrong).
    NoSuchPort,
    /// Another plotter of this daemon, or another program, holds the port.
    PortHeld,
    /// The port exists and cannot be opened (permissions, not a tty, ...).
    CannotOpen,
    /// The port closed under us: the device was unplugged or switched off.
    PortClosed,
    /// The device does not answer.
    Silent,
    /// The device answers, with something that is not an answer (garbage,
    /// an empty line, the wrong line rate).
    Unreadable,
    /// The device restarted (reset, power cycle).
    Reset,
}

impl LinkCause {
    /// A cause of `kind` saying `message`.
    #[must_use]
    pub fn new(kind: LinkFault, message: impl Into<String>) -> LinkCause {
        LinkCause { kind, message: message.into() }
    }
}

impl std::fmt::Display for LinkCause {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

/// What a job that cannot go on now waits for, computed from its plotter's
/// state when it is shown (never stored, so never stale).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "for", rename_all = "kebab-case")]
pub enum Waiting {
    /// Its plotter, which is offline.
    Plotter {
        /// The plotter.
        plotter: String,
        /// Why it is offline, when known.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        cause: Option<LinkCause>,
    },
    /// Any idle plotter of the class it was submitted for, of those that
    /// can draw it: none has taken it yet.
    Class {
        /// `any`, or the device named.
        class: String,
        /// The plotters that may take it.
        plotters: Vec<String>,
    },
}

impl std::fmt::Display for Waiting {
    /// `waiting for plotter hp (offline: /dev/ttyUSB0: no such file)`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Waiting::Plotter { plotter, cause: Some(cause) } => write!(f, "waiting for plotter {plotter} (offline: {cause})"),
            Waiting::Plotter { plotter, cause: None } => write!(f, "waiting for plotter {plotter} (offline)"),
            Waiting::Class { class, plotters } => write!(f, "waiting for an idle plotter of {class}: {}", plotters.join(", ")),
        }
    }
}

/// What the daemon knows of a plotter's port now: what a job shown waiting
/// for it reads.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Reach {
    /// Whether it answers.
    pub link: LinkState,
    /// Why not, when it does not.
    pub cause: Option<LinkCause>,
}

/// What a job says about why it waits, from its record and its plotter's
/// [`Reach`] now: a queued job waits for an offline plotter (or, for a
/// class, an idle one of it); a job paused
/// because the link went says when the plotter is back that it waits for
/// `resume` (its stored reason would be stale); otherwise the record's
/// cause and reason.
fn told(record: &JobRecord, reach: &Reach) -> (Option<PauseCause>, Option<String>, Option<Waiting>) {
    let (cause, reason) = why(&record.state);
    let offline = || Waiting::Plotter { plotter: record.plotter.clone(), cause: reach.cause.clone() };
    if let (Some(fits), JobState::Queued) = (record.unclaimed(), &record.state) {
        let waiting = Waiting::Class { class: record.plotter.clone(), plotters: fits.to_vec() };
        return (cause, Some(waiting.to_string()), Some(waiting));
    }
    match (&record.state, reach.link) {
        (JobState::Queued, LinkState::Offline) => {
            let waiting = offline();
            (cause, Some(waiting.to_string()), Some(waiting))
        }
        (JobState::Paused { cause: PauseCause::Offline, .. }, LinkState::Offline) => (cause, reason, Some(offline())),
        (JobState::Paused { cause: PauseCause::Offline, reason: was, .. }, LinkState::Online) => {
            let back = format!("plotter {} is back online: run `plotd resume {}` to go on (it paused: {was})", record.plotter, record.id);
            (cause, Some(back), None)
        }
        _ => (cause, reason, None),
    }
}

/// One plotter's status.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PlotterInfo {
    /// Name from the config.
    pub name: String,
    /// Serial port path, or `nickname "NAME"` for an EiBotBoard found by its nickname.
    pub port: String,
    /// Device profile.
    pub device: String,
    /// Whether it answers.
    pub link: LinkState,
    /// Why it is offline, when it is.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cause: Option<LinkCause>,
    /// The job it is working on.
    pub job: Option<JobId>,
    /// Whether its sheet is fresh, or a job drew on it (the next job waits
    /// for `sheet-loaded`).
    #[serde(default)]
    pub sheet: Sheet,
    /// Its origin offset, mm (`offset`): the jobs that start from now on
    /// are drawn moved by it.
    #[serde(default)]
    pub offset_mm: [f64; 2],
    /// The pen a person last put in a one-pen plotter (`None`: not known
    /// yet); a job whose first pen is another asks for it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pen_loaded: Option<u32>,
}

/// The daemon's reply.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "reply", rename_all = "kebab-case")]
pub enum Reply {
    /// The job is in the spool (durably) under this id.
    Submitted {
        /// The new job's id.
        id: JobId,
    },
    /// The job list.
    Jobs {
        /// Jobs by id.
        jobs: Vec<JobInfo>,
        /// Job records the daemon found unreadable at start, kept aside
        /// with their content (absent when there are none).
        #[serde(default, skip_serializing_if = "Vec::is_empty")]
        corrupt: Vec<CorruptRecord>,
    },
    /// Daemon status.
    Status {
        /// Daemon version.
        version: String,
        /// Plotters.
        plotters: Vec<PlotterInfo>,
        /// Jobs not yet finished.
        active: Vec<JobInfo>,
    },
    /// The command was done.
    Ok {
        /// What was done.
        message: String,
    },
    /// The command failed; the connection stays usable.
    Error {
        /// What is wrong.
        message: String,
    },
    /// A progress event (replies to `watch`).
    Event(Event),
    /// What a person did at a plotter (replies to `watch` of all jobs).
    Plotter(PlotterEvent),
    /// A plotter's own state changed (replies to `watch` of all jobs).
    PlotterChanged(PlotterChange),
}

/// A plotter's state changed with no job's event to tell it: its link went
/// or came back (and why), its sheet was used or a fresh one loaded, its
/// offset was set, a pen was put in. It carries the plotter's state whole,
/// as `status` shows it, so a watcher replaces what it showed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PlotterChange {
    /// The plotter.
    pub plotter: String,
    /// Whether it answers.
    pub link: LinkState,
    /// Why it is offline, when it is.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cause: Option<LinkCause>,
    /// Whether its sheet is fresh, or a job drew on it.
    pub sheet: Sheet,
    /// Its origin offset, mm.
    pub offset_mm: [f64; 2],
    /// The pen a person last put in a one-pen plotter, when known.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pen_loaded: Option<u32>,
    /// The format's version, [`EVENT_VERSION`].
    #[serde(default = "event_version")]
    pub v: u32,
}

impl PlotterChange {
    /// The change that tells `info`'s state.
    #[must_use]
    pub fn of(info: &PlotterInfo) -> PlotterChange {
        PlotterChange {
            plotter: info.name.clone(),
            link: info.link,
            cause: info.cause.clone(),
            sheet: info.sheet,
            offset_mm: info.offset_mm,
            pen_loaded: info.pen_loaded,
            v: EVENT_VERSION,
        }
    }
}

/// What a person did at a plotter, as `watch` of all jobs tells it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PlotterEvent {
    /// The plotter.
    pub plotter: String,
    /// What was done.
    pub did: Manoeuvre,
    /// Where to (a move, and the first corner of a frame) or by how much
    /// (a jog), mm.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mm: Option<[f64; 2]>,
    /// The job framed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub job: Option<JobId>,
    /// The format's version, [`EVENT_VERSION`].
    #[serde(default = "event_version")]
    pub v: u32,
}

/// A manual request carried out.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Manoeuvre {
    /// The pen was raised.
    PenUp,
    /// The pen was lowered.
    PenDown,
    /// The carriage went to a point, pen up.
    Moved,
    /// The carriage moved by a step, pen up.
    Jogged,
    /// A job's frame was traced, pen up.
    Framed,
    /// The homing cycle ran: the carriage is at the machine's zero.
    Homed,
    /// The plotter's origin offset was set (`mm`: the new offset), for
    /// the jobs that start from then on.
    Offset,
}

/// The version of [`Event`]'s format, its `v` field: raised when a field
/// changes meaning or goes away (fields may be added within a version).
pub const EVENT_VERSION: u32 = 1;

fn event_version() -> u32 {
    EVENT_VERSION
}

/// Progress of a job, sent to watchers (`plotd watch` prints these).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Event {
    /// The job.
    pub job: JobId,
    /// Its state now.
    pub state: State,
    /// What lets it go on, when it is paused.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cause: Option<PauseCause>,
    /// Why it is paused or failed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reason: Option<String>,
    /// Strokes (chunks) the device has confirmed.
    pub strokes_done: usize,
    /// Strokes in the job, once known.
    pub strokes_total: Option<usize>,
    /// Bytes of the job the device has acknowledged.
    pub bytes_acked: u64,
    /// Estimated seconds left, from the plot-time model.
    pub eta_s: Option<f64>,
    /// For a job of several copies: which is being drawn (from 1), and how
    /// many there are.
    #[serde(default = "one", skip_serializing_if = "is_one")]
    pub copy: u32,
    /// (1 unless the job was submitted with `copies`.)
    #[serde(default = "one", skip_serializing_if = "is_one")]
    pub copies: u32,
    /// What it waits for, when its plotter keeps it from going on.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub waiting: Option<Waiting>,
    /// The format's version, [`EVENT_VERSION`]; written last, so that a line
    /// still begins with its job.
    #[serde(default = "event_version")]
    pub v: u32,
}

impl Event {
    /// The event that tells `record`'s state, with progress figures that are
    /// not in the record.
    #[must_use]
    pub fn of(record: &JobRecord, bytes_acked: u64, eta_s: Option<f64>) -> Event {
        Event::waiting_on(record, &Reach::default(), bytes_acked, eta_s)
    }

    /// [`Event::of`], on a plotter that is as `reach` says: what the job
    /// waits for and why, as now.
    #[must_use]
    pub fn waiting_on(record: &JobRecord, reach: &Reach, bytes_acked: u64, eta_s: Option<f64>) -> Event {
        let (cause, reason, waiting) = told(record, reach);
        Event {
            v: EVENT_VERSION,
            job: record.id,
            state: State::of(&record.state),
            cause,
            reason,
            strokes_done: record.strokes_done,
            strokes_total: record.strokes_total,
            bytes_acked,
            eta_s,
            copy: record.copy,
            copies: record.copies,
            waiting,
        }
    }
}

/// Why a line is not a request.
#[derive(Clone, Debug, PartialEq, Eq, Error)]
pub enum RequestError {
    /// Not JSON, or not a request: an unknown command or field, a missing
    /// or mistyped one (the decoder's message, cut short).
    #[error("malformed request: {0}")]
    Malformed(String),
}

/// What [`LineDecoder::next_frame`] found.
#[derive(Debug, PartialEq)]
pub enum Frame {
    /// A whole line was there: the request, or why it is not one.
    Line(Result<Request, RequestError>),
    /// A line longer than the limit was dropped; the bytes up to its end are consumed.
    TooLong,
    /// No whole line yet.
    Incomplete,
}

/// Cuts a connection's bytes into request lines: the transport hands it what
/// it reads ([`LineDecoder::extend`]) and takes whole lines off
/// ([`LineDecoder::next_frame`]). Each byte is searched for the line's end
/// once: a large submit arrives in thousands of reads, and searching the
/// whole buffer again after each was quadratic (a 30 MB request, seconds of
/// the daemon's CPU).
#[derive(Debug)]
pub struct LineDecoder {
    buf: Vec<u8>,
    /// The first `searched` bytes of `buf` hold no newline.
    searched: usize,
    /// The line being received is longer than `limit`: its bytes are
    /// dropped until its end, which is reported as [`Frame::TooLong`].
    skipping: bool,
    limit: usize,
}

impl LineDecoder {
    /// A decoder for lines of at most `limit` bytes.
    #[must_use]
    pub fn new(limit: usize) -> LineDecoder {
        LineDecoder { buf: Vec::new(), searched: 0, skipping: false, limit }
    }

    /// Bytes received.
    pub fn extend(&mut self, bytes: &[u8]) {
        self.buf.extend_from_slice(bytes);
    }

    /// Bytes received and not yet taken off as lines.
    #[must_use]
    pub fn held(&self) -> usize {
        self.buf.len()
    }

    /// Part of a line has been received (or dropped as too long).
    #[must_use]
    pub fn mid_line(&self) -> bool {
        !self.buf.is_empty() || self.skipping
    }

    /// Takes the next line off and decodes it. A line longer than the limit
    /// is dropped as it arrives: [`Frame::TooLong`] once its end is seen,
    /// [`Frame::Incomplete`] while it is not.
    pub fn next_frame(&mut self) -> Frame {
        match self.buf[self.searched..].iter().position(|&b| b == b'\n') {
            Some(at) => {
                let nl = self.searched + at;
                self.searched = 0;
                let frame = if std::mem::take(&mut self.skipping) || nl > self.limit {
                    Frame::TooLong
                } else {
                    let line = &self.buf[..nl];
                    Frame::Line(decode_request(line.strip_suffix(b"\r").unwrap_or(line)))
                };
                self.buf.drain(..=nl);
                frame
            }
            None => {
                self.searched = self.buf.len();
                if self.buf.len() > self.limit {
                    self.buf.clear();
                    self.searched = 0;
                    self.skipping = true;
                }
                Frame::Incomplete
            }
        }
    }

    /// Gives back the memory of a large request once it is answered, keeping
    /// `keep` bytes of capacity for the next.
    pub fn shrink(&mut self, keep: usize) {
        if self.buf.capacity() > keep && self.buf.len() <= keep {
            self.buf.shrink_to(keep);
        }
    }
}

/// One request line (without its newline) decoded.
///
/// # Errors
/// Not JSON or not a request: the decoder's message, cut short.
pub fn decode_request(line: &[u8]) -> Result<Request, RequestError> {
    // serde quotes unknown names whole: cut the message (issue #20).
    serde_json::from_slice(line).map_err(|e| RequestError::Malformed(excerpt(&e.to_string())))
}

/// `text` cut to 200 characters and `...` when longer.
fn excerpt(text: &str) -> String {
    match text.char_indices().nth(200) {
        Some((cut, _)) => format!("{}...", &text[..cut]),
        None => text.to_owned(),
    }
}

/// A message as one protocol line.
#[must_use]
pub fn encode<T: Serialize>(msg: &T) -> Vec<u8> {
    let mut v = serde_json::to_vec(msg).expect("protocol messages serialise");
    v.push(b'\n');
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn requests_round_trip() {
        let reqs = [
            Request::Submit {
                kind: JobKind::Hpgl,
                plotter: Some("hp".into()),
                name: None,
                content: "IN;".into(),
                files: BTreeMap::new(),
                same_sheet: false,
                copies: 1,
                pens: BTreeMap::new(),
                occult: None,
            },
            Request::Submit {
                kind: JobKind::Scene,
                plotter: None,
                name: Some("map.toml".into()),
                content: "[camera]".into(),
                files: BTreeMap::from([("map/places.csv".into(), "bmFtZQ==".into())]),
                same_sheet: true,
                copies: 3,
                pens: BTreeMap::from([(1, 3), (2, 1)]),
                occult: None,
            },
            Request::Jobs {},
            Request::Status {},
            Request::Cancel { id: 3, now: false },
            Request::Pause { id: None, now: true },
            Request::Resume { id: Some(2), position_confirmed: false },
            Request::Resume { id: Some(2), position_confirmed: true },
            Request::PenChanged { plotter: None },
            Request::SheetLoaded { plotter: "hp".into() },
            Request::Watch { id: Some(1) },
            Request::Pen { plotter: None, down: true },
            Request::Move { plotter: Some("hp".into()), x_mm: 10.0, y_mm: -5.5 },
            Request::Jog { plotter: None, dx_mm: 0.5, dy_mm: 0.0 },
            Request::Frame { id: 3 },
            Request::Offset { plotter: "hp".into(), dx_mm: 10.0, dy_mm: 5.0 },
        ];
        for r in reqs {
            let mut lines = LineDecoder::new(1 << 20);
            lines.extend(&encode(&r));
            assert_eq!(lines.next_frame(), Frame::Line(Ok(r)));
            assert!(!lines.mid_line());
        }
    }

    #[test]
    fn wire_names() {
        let line = br#"{"cmd":"pen-changed"}"#;
        assert_eq!(serde_json::from_slice::<Request>(line).unwrap(), Request::PenChanged { plotter: None });
        // Attachments are optional on the wire.
        let line = br#"{"cmd":"submit","kind":"scene","content":"x","files":{"a.csv":"eA=="}}"#;
        let Request::Submit { files, .. } = serde_json::from_slice::<Request>(line).unwrap() else { panic!() };
        assert_eq!(files["a.csv"], "eA==");
        // `now` is optional, and written only when set.
        let line = br#"{"cmd":"cancel","id":3}"#;
        assert_eq!(serde_json::from_slice::<Request>(line).unwrap(), Request::Cancel { id: 3, now: false });
        assert_eq!(
            serde_json::to_value(Request::Pause { id: None, now: true }).unwrap(),
            serde_json::json!({"cmd": "pause", "id": null, "now": true})
        );
        assert!(serde_json::from_slice::<Request>(br#"{"cmd":"pause","now":1}"#).is_err());
        let v = serde_json::to_value(Reply::Submitted { id: 4 }).unwrap();
        assert_eq!(v, serde_json::json!({"reply": "submitted", "id": 4}));
    }

    /// The wire's job is its own type now; clients and scripts read the
    /// same JSON the spool record gave them before, in every state.
    #[test]
    fn a_job_on_the_wire_reads_as_its_record_did() {
        use crate::spool::JobState;
        let states = [
            JobState::Queued,
            JobState::Rendering,
            JobState::Plotting,
            JobState::paused(PauseCause::DeviceHold, "held by the plotter: paper lever raised"),
            JobState::paused(PauseCause::LoadSheet, "load a fresh sheet on plotter hp, then: plotd sheet-loaded hp"),
            JobState::Paused { cause: PauseCause::Load, reason: "insert pen 2".into(), insert_pen: Some(2), load_page: None },
            JobState::Paused {
                cause: PauseCause::Load,
                reason: "load paper for frame 2 of 3".into(),
                insert_pen: None,
                load_page: Some(1),
            },
            JobState::Done,
            JobState::Failed { reason: "no".into() },
            JobState::Cancelled,
        ];
        for state in states {
            let record = JobRecord {
                id: 7,
                kind: JobKind::Scene,
                plotter: "hp".into(),
                class: None,
                name: "a.toml".into(),
                uid: 1000,
                pid: 42,
                submitted_at: 1_700_000_000,
                state,
                checkpoint: 3,
                total: Some(9),
                strokes_done: 2,
                strokes_total: Some(8),
                pen_loaded: Some(1),
                page_loaded: 1,
                same_sheet: false,
                offset_mm: Some([10.0, 5.0]),
                copies: 3,
                copy: 2,
                pens: BTreeMap::from([(1, 3)]),
                occult: None,
            };
            let info = JobInfo::of(&record);
            assert_eq!(serde_json::to_value(&info).unwrap(), serde_json::to_value(&record).unwrap(), "{:?}", record.state);
            let back: JobInfo = serde_json::from_value(serde_json::to_value(&record).unwrap()).unwrap();
            assert_eq!(back, info);
        }
    }

    /// Events carry their format's version, the state and the pause cause as
    /// the words scripts match.
    #[test]
    fn an_event_on_the_wire() {
        let record = JobRecord {
            state: crate::spool::JobState::paused(PauseCause::Offline, "device offline: the port failed"),
            checkpoint: 5,
            total: Some(9),
            strokes_done: 4,
            strokes_total: Some(8),
            ..JobRecord::queued(3, "hp", "a.hpgl")
        };
        let line = String::from_utf8(encode(&Event::of(&record, 120, Some(4.5)))).unwrap();
        assert!(line.starts_with("{\"job\":3,"), "a line still begins with its job: {line}");
        let v: serde_json::Value = serde_json::from_str(&line).unwrap();
        let want = serde_json::json!({"v": 1, "job": 3, "state": "paused", "cause": "offline", "reason": "device offline: the port failed",
            "strokes_done": 4, "strokes_total": 8, "bytes_acked": 120, "eta_s": 4.5});
        assert_eq!(v, want);
        // A job of copies says which is drawn.
        let copies = JobRecord { copies: 3, copy: 2, ..record };
        let v = serde_json::to_value(Event::of(&copies, 0, None)).unwrap();
        assert_eq!((v["copy"].as_u64(), v["copies"].as_u64()), (Some(2), Some(3)));
        // A line from before the version field reads as version 1.
        let old: Event =
            serde_json::from_str(r#"{"job":3,"state":"done","strokes_done":8,"strokes_total":8,"bytes_acked":9,"eta_s":null}"#).unwrap();
        assert_eq!((old.v, old.state), (1, State::Done));
        let link = serde_json::to_value([LinkState::Unknown, LinkState::Online, LinkState::Offline]).unwrap();
        assert_eq!(link, serde_json::json!(["unknown", "online", "offline"]));
    }

    #[test]
    fn unknown_fields_are_refused_in_every_request() {
        for line in [
            r#"{"cmd":"jobs","x":1}"#,
            r#"{"cmd":"status","verbose":true}"#,
            r#"{"cmd":"cancel","id":1,"force":true}"#,
            r#"{"cmd":"pause","id":1,"soon":true}"#,
            r#"{"cmd":"watch","job":1}"#,
            r#"{"cmd":"submit","kind":"hpgl","content":"IN;","priority":9}"#,
        ] {
            let Err(e) = decode_request(line.as_bytes()) else { panic!("{line} was accepted") };
            assert!(e.to_string().contains("unknown field"), "{line}: {e}");
        }
    }

    #[test]
    fn malformed_and_incomplete() {
        let mut lines = LineDecoder::new(100);
        lines.extend(b"{\"cmd\":\"jobs\"");
        assert_eq!(lines.next_frame(), Frame::Incomplete);
        assert!(lines.mid_line());
        lines.extend(b"}\r\nnot json\n{\"cmd\":\"fly\"}\n");
        assert_eq!(lines.next_frame(), Frame::Line(Ok(Request::Jobs {})));
        assert!(matches!(lines.next_frame(), Frame::Line(Err(_))));
        let Frame::Line(Err(e)) = lines.next_frame() else { panic!() };
        assert!(e.to_string().contains("fly"), "{e}");
        assert_eq!(lines.next_frame(), Frame::Incomplete);
        assert!(!lines.mid_line());
    }

    /// A large request comes in many reads: each read's bytes are searched
    /// for the line's end once, not the whole line again after every read
    /// (which made a 30 MB submit quadratic).
    #[test]
    fn a_line_in_many_reads_is_searched_once() {
        let mut lines = LineDecoder::new(1 << 30);
        let line = encode(&Request::Submit {
            kind: JobKind::Hpgl,
            plotter: None,
            name: None,
            content: "PD;".repeat(100_000),
            files: BTreeMap::new(),
            same_sheet: false,
            copies: 1,
            pens: BTreeMap::new(),
            occult: None,
        });
        let mut received = 0;
        for piece in line[..line.len() - 1].chunks(4096) {
            lines.extend(piece);
            assert_eq!(lines.next_frame(), Frame::Incomplete);
            received += piece.len();
            // Where the next search starts: after every byte received so far.
            assert_eq!(lines.searched, received);
        }
        lines.extend(b"\n");
        assert!(matches!(lines.next_frame(), Frame::Line(Ok(Request::Submit { .. }))));
        assert_eq!((lines.searched, lines.mid_line()), (0, false));
    }

    #[test]
    fn oversized_line_is_skipped_then_reported() {
        let mut lines = LineDecoder::new(20);
        lines.extend(&[b'x'; 50]);
        assert_eq!(lines.next_frame(), Frame::Incomplete);
        assert!(lines.buf.is_empty() && lines.skipping);
        lines.extend(b"yyy\n{\"cmd\":\"status\"}\n");
        assert_eq!(lines.next_frame(), Frame::TooLong);
        assert_eq!(lines.next_frame(), Frame::Line(Ok(Request::Status {})));
        // Exactly at the limit with its newline in the same read.
        let mut lines = LineDecoder::new(5);
        lines.extend(b"{\"cmd\":\"jobs\"}\n");
        assert_eq!(lines.next_frame(), Frame::TooLong);
        // Issue #20: serde quoted an unknown command whole; the reply is short.
        let Err(e) = decode_request(format!("{{\"cmd\":\"{}\"}}", "x".repeat(10_000)).as_bytes()) else { panic!() };
        let e = e.to_string();
        assert!(e.len() < 300 && e.starts_with("malformed request: unknown variant `xxx"), "{e}");
    }
}
