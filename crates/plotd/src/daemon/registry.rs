//! The daemon's shared state: every job's record (mirrored in the spool), each
//! plotter's live status and control channels, and the event feed watchers
//! listen to. Every state change goes through here so that it is persisted
//! before anyone is told about it.

use crate::config::PlotterConfig;
use crate::protocol::{Event, LinkState, PlotterInfo};
use crate::spool::{CorruptRecord, JobId, JobRecord, Spool, SpoolError};
use crate::stream::Stop;
use std::collections::BTreeMap;
use std::sync::{Arc, Mutex, MutexGuard};
use tokio::sync::{broadcast, watch, Notify};

/// Events kept for slow watchers before they start missing some.
const EVENT_BACKLOG: usize = 1024;

/// Why a plotter is asked to stop at the next stroke boundary.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StopReason {
    /// `plotd pause`.
    Pause,
    /// `plotd cancel`.
    Cancel,
    /// The daemon is shutting down (SIGTERM).
    Shutdown,
    /// A confirmed checkpoint could not be persisted: the job pauses rather
    /// than run ahead of its record.
    Unsaved,
}

/// One plotter's live state.
#[derive(Debug)]
pub struct PlotterSlot {
    /// Its configuration (replaced on SIGHUP).
    pub config: PlotterConfig,
    /// Whether the plotter answers.
    pub link: LinkState,
    /// The job it is plotting.
    pub job: Option<JobId>,
    /// Wakes the plotter task: a job was queued, resumed, cancelled.
    pub wake: Arc<Notify>,
    /// Set to ask the running job to stop at the next stroke boundary or
    /// now; the reason says what to do then.
    pub stop: watch::Sender<Stop>,
    /// Why `stop` was set.
    pub stop_reason: Option<StopReason>,
}

/// Mutable state behind the registry's lock.
#[derive(Debug, Default)]
pub struct State {
    /// Every job by id (finished ones included).
    pub jobs: BTreeMap<JobId, JobRecord>,
    /// Records found unreadable at start, kept aside in the spool.
    pub corrupt: Vec<CorruptRecord>,
    /// Plotters by name, in config order.
    pub plotters: Vec<PlotterSlot>,
    /// Next job id.
    pub next_id: JobId,
    /// Set once shutdown has begun: no new jobs start.
    pub shutting_down: bool,
    /// Finished jobs kept (the config's `keep_finished`, at least 1).
    pub keep_finished: usize,
}

impl State {
    /// The plotter slot called `name`.
    pub fn plotter_mut(&mut self, name: &str) -> Option<&mut PlotterSlot> {
        self.plotters.iter_mut().find(|p| p.config.name == name)
    }
}

/// Shared between the server, the plotter tasks and signal handling.
#[derive(Debug)]
pub struct Registry {
    /// The spool every change is written to first.
    pub spool: Spool,
    state: Mutex<State>,
    /// Progress and state-change events for watchers.
    pub events: broadcast::Sender<Event>,
    /// Held from id allocation until the job is in the spool and the map, so
    /// a plotter never sees job N+1 before job N (jobs plot in id order).
    pub submit_lock: tokio::sync::Mutex<()>,
    /// Checks and renders jobs, in a process of its own.
    pub worker: crate::worker::Worker,
}

impl Registry {
    /// A registry over `spool` holding `jobs` (recovered) and `plotters`,
    /// keeping the newest `keep_finished` finished jobs (older ones are
    /// deleted now and whenever a job finishes). New ids follow the highest
    /// id of any file in the spool (`highest_id`), readable or not.
    pub fn new(
        spool: Spool,
        jobs: Vec<JobRecord>,
        highest_id: JobId,
        plotters: &[PlotterConfig],
        keep_finished: usize,
        worker: crate::worker::Worker,
    ) -> Arc<Registry> {
        let corrupt = spool.corrupt_records().unwrap_or_else(|e| {
            tracing::error!(error = %e, "cannot list the records kept aside");
            Vec::new()
        });
        let next_id = jobs.iter().map(|j| j.id).chain(corrupt.iter().map(|c| c.id)).max().unwrap_or(0).max(highest_id) + 1;
        let state = State {
            jobs: jobs.into_iter().map(|j| (j.id, j)).collect(),
            corrupt,
            plotters: plotters.iter().cloned().map(PlotterSlot::new).collect(),
            next_id,
            shutting_down: false,
            keep_finished: keep_finished.max(1),
        };
        let (events, _) = broadcast::channel(EVENT_BACKLOG);
        let reg = Arc::new(Registry { spool, state: Mutex::new(state), events, submit_lock: tokio::sync::Mutex::new(()), worker });
        reg.prune();
        reg
    }

    /// Deletes the oldest finished jobs beyond `keep_finished`, from the map
    /// and the spool. Unfinished jobs are never touched, and the newest id
    /// is always kept (an unfinished job, or a finished one among those
    /// kept), so ids are not reused after a restart.
    pub fn prune(&self) {
        let gone: Vec<JobId> = {
            let mut st = self.lock();
            // Oldest first (the map is ordered by id): keep only those to delete.
            let mut finished: Vec<JobId> = st.jobs.values().filter(|j| j.state.is_final()).map(|j| j.id).collect();
            finished.truncate(finished.len().saturating_sub(st.keep_finished));
            for id in &finished {
                st.jobs.remove(id);
            }
            finished
        };
        for id in gone {
            match self.spool.remove(id) {
                Ok(()) => tracing::debug!(job = id, "finished job removed from the spool"),
                Err(e) => tracing::warn!(job = id, error = %e, "cannot remove a finished job from the spool"),
            }
        }
    }

    /// Locks the state. Never held across an await.
    pub fn lock(&self) -> MutexGuard<'_, State> {
        self.state.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// Applies `change` to job `id`, persists the record, then tells watchers.
    /// `done`/`total`/`acked`/`eta` feed the event.
    ///
    /// The change is made in memory even when it cannot be persisted: the
    /// daemon acts on what is in memory, and a checkpoint there that fell
    /// back to the one on disk would send strokes to the device again. The
    /// record on disk catches up at the job's next change that can be saved;
    /// a restart meanwhile finds the older one (and resumes from it, as after
    /// a power loss).
    ///
    /// # Errors
    /// [`SpoolError`] if the record cannot be persisted.
    pub fn update(&self, id: JobId, progress: Progress, change: impl FnOnce(&mut JobRecord)) -> Result<(), SpoolError> {
        let record = {
            let st = self.lock();
            let Some(job) = st.jobs.get(&id) else { return Ok(()) };
            let mut next = job.clone();
            change(&mut next);
            if next == *job {
                None
            } else {
                Some(next)
            }
        };
        let Some(record) = record else { return Ok(()) };
        // Persist outside the lock: fsync is slow and other plotters go on meanwhile.
        let saved = self.spool.save(&record);
        self.lock().jobs.insert(id, record.clone());
        self.emit(&record, progress);
        if record.state.is_final() {
            self.prune();
        }
        saved
    }

    /// Sends an event describing `record`.
    pub fn emit(&self, record: &JobRecord, progress: Progress) {
        let _ = self.events.send(Event::of(record, progress.bytes_acked, progress.eta_s));
    }

    /// A job's record.
    #[must_use]
    pub fn job(&self, id: JobId) -> Option<JobRecord> {
        self.lock().jobs.get(&id).cloned()
    }

    /// Plotter status for clients.
    #[must_use]
    pub fn plotter_infos(&self) -> Vec<PlotterInfo> {
        self.lock()
            .plotters
            .iter()
            .map(|p| PlotterInfo {
                name: p.config.name.clone(),
                port: p.config.port.display().to_string(),
                device: p.config.device.clone(),
                link: p.link,
                job: p.job,
            })
            .collect()
    }

    /// Wakes the task of plotter `name`.
    pub fn wake(&self, name: &str) {
        if let Some(p) = self.lock().plotter_mut(name) {
            p.wake.notify_one();
        }
    }

    /// Asks plotter `name` to stop its job at the next stroke boundary, or
    /// now ([`Stop::Now`]).
    pub fn request_stop(&self, name: &str, reason: StopReason, how: Stop) {
        let mut st = self.lock();
        if let Some(p) = st.plotter_mut(name) {
            // A shutdown outranks a pause or cancel already asked for.
            if p.stop_reason != Some(StopReason::Shutdown) {
                p.stop_reason = Some(reason);
            }
            p.stop.send_modify(|s| *s = (*s).max(how));
            p.wake.notify_one();
        }
    }
}

/// Progress figures that go with an event but are not persisted.
#[derive(Clone, Copy, Debug, Default)]
pub struct Progress {
    /// Job bytes the device has confirmed.
    pub bytes_acked: u64,
    /// Estimated seconds left.
    pub eta_s: Option<f64>,
}

impl PlotterSlot {
    fn new(config: PlotterConfig) -> PlotterSlot {
        PlotterSlot {
            config,
            link: LinkState::Unknown,
            job: None,
            wake: Arc::new(Notify::new()),
            stop: watch::channel(Stop::Continue).0,
            stop_reason: None,
        }
    }

    /// A slot for a plotter added by a config reload.
    #[must_use]
    pub fn added(config: PlotterConfig) -> PlotterSlot {
        PlotterSlot::new(config)
    }
}
