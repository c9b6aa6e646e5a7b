//! The daemon's shared state: the job's life ([`JobLife`], which decides
//! everything about jobs) behind a lock, each plotter task's channels, the
//! spool and the event feed. It carries out what the machine decides that
//! is not a run's (saves, then announcements; removals; stops and wakes)
//! and brings the results back to it. Records are saved outside the lock:
//! fsync is slow, and other plotters and clients go on meanwhile.

use crate::config::PlotterConfig;
use crate::job::{Action, ControlError, JobLife, Manual, Progress, Save, Step};
use crate::protocol::{Event, JobInfo, PlotterChange, PlotterEvent, PlotterInfo};
use crate::spool::{CorruptRecord, JobId, JobRecord, Spool, SpoolError};
use crate::stream::Stop;
use std::collections::{BTreeMap, VecDeque};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Instant;
use tokio::sync::{broadcast, oneshot, watch, Notify};

/// Events kept for slow watchers before they start missing some.
const EVENT_BACKLOG: usize = 1024;

/// A plotter task's channels.
#[derive(Debug)]
struct Channels {
    /// Wakes the task: it polls the machine again.
    wake: Arc<Notify>,
    /// The stop asked of its run: the streamer reads it between writes.
    stop: watch::Sender<Stop>,
    /// Where the answer to the manual request it carries out goes: the
    /// connection that asked waits on it.
    manual_reply: Option<oneshot::Sender<Result<String, String>>>,
}

impl Channels {
    fn new() -> Channels {
        Channels { wake: Arc::new(Notify::new()), stop: watch::channel(Stop::Continue).0, manual_reply: None }
    }
}

/// What the lock holds.
#[derive(Debug)]
struct Shared {
    life: JobLife,
    /// By plotter name.
    channels: BTreeMap<String, Channels>,
}

/// What a plotter task does next ([`Registry::poll`]).
#[derive(Debug)]
pub struct Next {
    /// The machine's step.
    pub step: Step,
    /// What wakes the task while it waits.
    pub wake: Arc<Notify>,
    /// For a run: the stops asked of it, none asked yet.
    pub stop: Option<watch::Receiver<Stop>>,
}

/// Shared between the server, the plotter tasks and signal handling.
#[derive(Debug)]
pub struct Registry {
    /// The spool every change is written to first.
    pub spool: Spool,
    shared: Mutex<Shared>,
    /// Progress and state-change events for watchers.
    pub events: broadcast::Sender<Event>,
    /// What people did at the plotters, for watchers of every job.
    pub plotter_events: broadcast::Sender<PlotterEvent>,
    /// The plotters' states as they change (link, sheet, offset, pen), for
    /// watchers of every job.
    pub plotter_changes: broadcast::Sender<PlotterChange>,
    /// Held from id allocation until the job is in the spool and the
    /// machine, so a plotter never sees job N+1 before job N (jobs plot in
    /// id order).
    pub submit_lock: tokio::sync::Mutex<()>,
    /// Checks and renders jobs, in a process of its own.
    pub worker: crate::worker::Worker,
    /// Bounds the submit checks running at once: one per plotter (at start) plus one.
    pub checks: super::checks::CheckPool,
    /// Records found unreadable at start, kept aside in the spool.
    corrupt: Vec<CorruptRecord>,
}

impl Registry {
    /// A registry over `spool` and `life`, with `corrupt` records found at start.
    pub fn new(spool: Spool, life: JobLife, corrupt: Vec<CorruptRecord>, worker: crate::worker::Worker) -> Arc<Registry> {
        let channels: BTreeMap<String, Channels> = life.plotters().map(|p| (p.name.clone(), Channels::new())).collect();
        let checks = super::checks::CheckPool::new(channels.len() + 1);
        let (events, _) = broadcast::channel(EVENT_BACKLOG);
        let (plotter_events, _) = broadcast::channel(EVENT_BACKLOG);
        let (plotter_changes, _) = broadcast::channel(EVENT_BACKLOG);
        Arc::new(Registry {
            spool,
            shared: Mutex::new(Shared { life, channels }),
            events,
            plotter_events,
            plotter_changes,
            submit_lock: tokio::sync::Mutex::new(()),
            worker,
            checks,
            corrupt,
        })
    }

    /// Locks the state. Never held across an await.
    fn lock(&self) -> MutexGuard<'_, Shared> {
        self.shared.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// Calls the machine, under the lock.
    pub fn with<R>(&self, f: impl FnOnce(&mut JobLife) -> R) -> R {
        f(&mut self.lock().life)
    }

    /// What plotter `name`'s task does next. For a run, the stop channel is
    /// cleared and subscribed under the same lock that starts the run, so
    /// no stop asked of it is lost.
    pub fn poll(&self, name: &str, now: Instant) -> Option<Next> {
        let mut shared = self.lock();
        let step = shared.life.poll(name, now);
        let channels = shared.channels.get(name)?;
        let stop = matches!(step, Step::Run { .. }).then(|| {
            channels.stop.send_replace(Stop::Continue);
            channels.stop.subscribe()
        });
        Some(Next { step, wake: Arc::clone(&channels.wake), stop })
    }

    /// Channels for plotter `name`, added by a config reload.
    pub fn add_plotter(&self, name: &str) {
        self.lock().channels.entry(name.to_owned()).or_insert_with(Channels::new);
    }

    /// Carries out a request's actions and what follows them; its answer.
    ///
    /// # Errors
    /// The request's refusal.
    pub fn control(&self, f: impl FnOnce(&mut JobLife) -> Vec<Action>) -> Result<String, ControlError> {
        let actions = self.with(f);
        self.carry_out(actions).unwrap_or_else(|| Ok(String::new()))
    }

    /// A person's manual request, accepted by the machine and left for the
    /// plotter's task; the answer comes on the receiver once the device has
    /// done it (or failed to).
    ///
    /// # Errors
    /// The machine's refusal.
    pub fn manual(&self, plotter: Option<&str>, op: Manual) -> Result<oneshot::Receiver<Result<String, String>>, ControlError> {
        let (tx, rx) = oneshot::channel();
        let actions = {
            let mut shared = self.lock();
            let (name, actions) = shared.life.manual(plotter, op)?;
            if let Some(c) = shared.channels.get_mut(&name) {
                c.manual_reply = Some(tx);
            }
            actions
        };
        self.carry_out(actions);
        Ok(rx)
    }

    /// Plotter `name`'s task carried out its manual request: the machine is
    /// told, watchers hear what was done, and the connection that asked
    /// gets `result`.
    pub fn manual_done(&self, name: &str, result: Result<(String, PlotterEvent), String>) {
        let reply = {
            let mut shared = self.lock();
            shared.life.manual_done(name);
            shared.channels.get_mut(name).and_then(|c| c.manual_reply.take())
        };
        let answer = result.map(|(message, event)| {
            let _ = self.plotter_events.send(event);
            message
        });
        if let Some(reply) = reply {
            let _ = reply.send(answer);
        }
    }

    /// Carries out `actions` and what follows from each, before the next;
    /// returns the reply among them. Blocks on the disk.
    pub fn carry_out(&self, actions: Vec<Action>) -> Option<Result<String, ControlError>> {
        let mut todo: VecDeque<Action> = actions.into();
        let mut reply = None;
        while let Some(a) = todo.pop_front() {
            for next in self.carry_out_one(a, &mut reply).into_iter().rev() {
                todo.push_front(next);
            }
        }
        reply
    }

    /// Carries out one action that is not a run's own; returns what follows
    /// from it, and puts a reply in `reply`.
    pub fn carry_out_one(&self, action: Action, reply: &mut Option<Result<String, ControlError>>) -> Vec<Action> {
        match action {
            Action::Save(save) | Action::SaveCheckpoint(save) => {
                let result = self.persist(&save);
                self.settle(&save, result)
            }
            Action::SavePlotter { plotter, state } => {
                if let Err(e) = self.spool.save_plotter(&plotter, &state) {
                    tracing::error!(plotter, error = %e, "cannot save the plotter's state; it holds in memory");
                }
                self.announce_plotter(&plotter);
                Vec::new()
            }
            Action::AnnouncePlotter(plotter) => {
                self.announce_plotter(&plotter);
                Vec::new()
            }
            Action::Announce(record) => {
                self.emit(&record, Progress::default());
                Vec::new()
            }
            Action::Remove { job, why } => {
                let result = self.spool.remove(job);
                match &result {
                    Ok(()) => tracing::debug!(job, ?why, "job removed from the spool"),
                    Err(e) => tracing::warn!(job, error = %e, ?why, "cannot remove the job from the spool"),
                }
                self.with(|l| l.removed(job, &why, result.as_ref().map(|_| ())))
            }
            Action::ForgetWritten(job) => {
                self.spool.clear_written(job);
                Vec::new()
            }
            Action::Stop { plotter, how } => {
                if let Some(c) = self.lock().channels.get(&plotter) {
                    c.stop.send_replace(how);
                }
                Vec::new()
            }
            Action::Wake(plotter) => {
                if let Some(c) = self.lock().channels.get(&plotter) {
                    c.wake.notify_one();
                }
                Vec::new()
            }
            Action::Reply(r) => {
                *reply = Some(r);
                Vec::new()
            }
            run @ (Action::Render { .. }
            | Action::ReadMark(_)
            | Action::Locate { .. }
            | Action::StartMark(_)
            | Action::Stream { .. }
            | Action::Park { .. }
            | Action::RunEnded { .. }) => {
                tracing::error!(action = ?run, "a run's action outside its plotter's task: ignored");
                Vec::new()
            }
        }
    }

    /// Saves `save`'s record (blocks on the disk).
    ///
    /// # Errors
    /// [`SpoolError`] when it cannot be saved.
    pub fn persist(&self, save: &Save) -> Result<(), SpoolError> {
        self.spool.save(&save.record)
    }

    /// Tells the machine how `save` went, then announces its record; returns
    /// what follows.
    pub fn settle(&self, save: &Save, result: Result<(), SpoolError>) -> Vec<Action> {
        let next = self.with(|l| l.saved(save, result.as_ref().map(|_| ())));
        self.emit(&save.record, save.progress);
        next
    }

    /// Sends an event describing `record`, and what it waits for.
    pub fn emit(&self, record: &JobRecord, progress: Progress) {
        let reach = self.with(|l| l.reach(&record.plotter));
        let _ = self.events.send(Event::waiting_on(record, &reach, progress.bytes_acked, progress.eta_s));
    }

    /// Tells watchers plotter `name`'s state now.
    pub fn announce_plotter(&self, name: &str) {
        if let Some(info) = self.plotter_infos().iter().find(|p| p.name == name) {
            let _ = self.plotter_changes.send(PlotterChange::of(info));
        }
    }

    /// Every job, as clients see it.
    #[must_use]
    pub fn jobs(&self) -> Vec<JobInfo> {
        self.with(|l| l.shown_jobs().map(|j| JobInfo::waiting_on(j, &l.reach(&j.plotter))).collect())
    }

    /// Jobs not finished, as clients see them.
    #[must_use]
    pub fn active_jobs(&self) -> Vec<JobInfo> {
        self.with(|l| l.shown_jobs().filter(|j| !j.state.is_final()).map(|j| JobInfo::waiting_on(j, &l.reach(&j.plotter))).collect())
    }

    /// Another plotter whose port names the same device as plotter
    /// `name`'s (two paths to one tty, a link under `/dev/serial/by-id`
    /// and the name it points to): the one that holds it when `name`'s
    /// open finds it held. Reads the file system.
    #[must_use]
    pub fn sharing_port(&self, name: &str) -> Option<String> {
        let ports: Vec<(String, std::path::PathBuf)> = self.with(|l| l.plotters().map(|p| (p.name.clone(), p.port.clone())).collect());
        let device = |path: &std::path::Path| std::fs::canonicalize(path).ok();
        let (_, mine) = ports.iter().find(|(n, _)| n == name)?;
        let mine = device(mine)?;
        ports.iter().find(|(n, port)| n != name && device(port).as_ref() == Some(&mine)).map(|(n, _)| n.clone())
    }

    /// A job's record as clients see it.
    #[must_use]
    pub fn job(&self, id: JobId) -> Option<JobRecord> {
        self.with(|l| l.shown_job(id).cloned())
    }

    /// Records found unreadable at start.
    #[must_use]
    pub fn corrupt(&self) -> &[CorruptRecord] {
        &self.corrupt
    }

    /// Plotter `name`'s configuration.
    #[must_use]
    pub fn config(&self, name: &str) -> Option<PlotterConfig> {
        self.with(|l| l.plotter(name).cloned())
    }

    /// Plotter status for clients.
    #[must_use]
    pub fn plotter_infos(&self) -> Vec<PlotterInfo> {
        self.with(|l| {
            let configs: Vec<PlotterConfig> = l.plotters().cloned().collect();
            configs
                .into_iter()
                .map(|p| {
                    let (link, job) = l.plotter_state(&p.name).unwrap_or_default();
                    let cause = l.reach(&p.name).cause;
                    let sheet = l.sheet(&p.name).unwrap_or_default();
                    let offset_mm = l.offset(&p.name).unwrap_or_default();
                    let pen_loaded = l.pen_loaded(&p.name);
                    PlotterInfo { port: p.port_label(), device: p.device, link, cause, job, sheet, offset_mm, pen_loaded, name: p.name }
                })
                .collect()
        })
    }
}
