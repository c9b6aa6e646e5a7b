//! [`JobLife`]: every job's record and every plotter's station, the one
//! path every record change takes (changed here, saved by the daemon, shown
//! once saved), and what a plotter's task does next ([`JobLife::poll`]).

use super::action::{Action, Progress, Removal, RunStep, Save, Step, StopReason, Then};
use super::ending::{self, Ending};
use super::error::ControlError;
use super::station::{Head, Next, Station};
use crate::config::PlotterConfig;
use crate::protocol::{JobInfo, LinkCause, LinkState, Reach};
use crate::spool::{JobId, JobRecord, JobState, SpoolError};
use crate::stream::Stop;
use std::collections::BTreeMap;
use std::time::Instant;

/// A job's record, and what of it has been shown.
#[derive(Debug)]
pub(super) struct Entry {
    /// The record every decision reads.
    pub record: JobRecord,
    /// Changes made to it.
    version: u64,
    /// The record as last saved (or tried to be): what clients see.
    pub shown: JobRecord,
    /// Which change `shown` is.
    shown_version: u64,
}

impl Entry {
    pub(super) fn new(record: JobRecord) -> Entry {
        Entry { shown: record.clone(), record, version: 0, shown_version: 0 }
    }
}

/// Every job's life, and every plotter's part in it. See the module doc.
#[derive(Debug)]
pub struct JobLife {
    /// Every job by id (finished ones kept up to `keep_finished`).
    pub(super) jobs: BTreeMap<JobId, Entry>,
    /// The plotters, in config order.
    pub(super) stations: Vec<Station>,
    /// The next job's id.
    pub(super) next_id: JobId,
    /// Set once shutdown has begun: no job starts, no job is submitted.
    pub(super) shutting_down: bool,
    /// Finished jobs kept (at least 1).
    pub(super) keep_finished: usize,
}

impl JobLife {
    /// The job's life after a start, with `records` as the spool has them
    /// (a restart changes some: [`super::after_restart`]), new ids after
    /// `highest_id` (the highest of any file in the spool), `plotters`, and
    /// the newest `keep_finished` finished jobs kept. Returns the records
    /// the restart changed, to save before anything else happens.
    #[must_use]
    pub fn new(records: Vec<JobRecord>, highest_id: JobId, plotters: &[PlotterConfig], keep_finished: usize) -> (JobLife, Vec<JobRecord>) {
        let mut changed = Vec::new();
        let mut jobs = BTreeMap::new();
        for mut record in records {
            if let Some(state) = super::after_restart(&record) {
                record.state = state;
                changed.push(record.clone());
            }
            jobs.insert(record.id, Entry::new(record));
        }
        let next_id = jobs.keys().copied().max().unwrap_or(0).max(highest_id) + 1;
        let life = JobLife {
            jobs,
            stations: plotters.iter().cloned().map(Station::new).collect(),
            next_id,
            shutting_down: false,
            keep_finished: keep_finished.max(1),
        };
        (life, changed)
    }

    /// Every job as clients see it: as last saved.
    pub fn shown_jobs(&self) -> impl Iterator<Item = &JobRecord> {
        self.jobs.values().map(|e| &e.shown)
    }

    /// Job `id` as clients see it.
    #[must_use]
    pub fn shown_job(&self, id: JobId) -> Option<&JobRecord> {
        self.jobs.get(&id).map(|e| &e.shown)
    }

    /// The plotters' configurations, in order.
    pub fn plotters(&self) -> impl Iterator<Item = &PlotterConfig> {
        self.stations.iter().map(|s| &s.config)
    }

    /// Plotter `name`'s configuration.
    #[must_use]
    pub fn plotter(&self, name: &str) -> Option<&PlotterConfig> {
        self.station(name).map(|i| &self.stations[i].config)
    }

    /// Plotter `name`'s link, and the job it runs.
    #[must_use]
    pub fn plotter_state(&self, name: &str) -> Option<(LinkState, Option<JobId>)> {
        self.station(name).map(|i| (self.stations[i].link, self.stations[i].run.as_ref().map(|r| r.job)))
    }

    /// What the daemon knows of plotter `name`'s port now: whether it
    /// answers, and why not.
    #[must_use]
    pub fn reach(&self, name: &str) -> Reach {
        self.station(name).map(|i| self.stations[i].reach()).unwrap_or_default()
    }

    /// Whether shutdown has begun.
    #[must_use]
    pub fn shutting_down(&self) -> bool {
        self.shutting_down
    }

    pub(super) fn station(&self, name: &str) -> Option<usize> {
        self.stations.iter().position(|s| s.name() == name)
    }

    /// The station running job `id`.
    pub(super) fn running(&self, id: JobId) -> Option<usize> {
        self.stations.iter().position(|s| s.run.as_ref().is_some_and(|r| r.job == id))
    }

    /// The head of plotter `name`'s queue: its oldest unfinished job, or one
    /// for a class it may take ([`JobLife::claimable`]), when that is older.
    fn head(&self, name: &str) -> Head {
        let own =
            self.jobs.values().map(|e| &e.record).find(|r| r.is_on(name) && !r.state.is_final()).map(|r| (r.id, r.state.pause_cause()));
        match self.station(name) {
            Some(i) => self.claimable(i, own),
            None => own,
        }
    }

    /// What plotter `name`'s task does next, at `now`.
    pub fn poll(&mut self, name: &str, now: Instant) -> Step {
        if self.shutting_down {
            return Step::Quit;
        }
        let head = self.head(name);
        let Some(i) = self.station(name) else { return Step::Quit };
        if self.stations[i].run.is_some() {
            return Step::Wait(None);
        }
        if let Some(manual) = self.take_manual(i) {
            return manual;
        }
        if let Some(actions) = self.wait_for_sheet(i, head) {
            return Step::Act(actions);
        }
        match self.stations[i].next(head, now) {
            Next::Probe => Step::Probe,
            Next::Wait(until) => Step::Wait(until),
            Next::Reset(program) => Step::Reset(program),
            Next::Take(job) => {
                self.stations[i].start(job);
                let offset = self.stations[i].state.offset_mm;
                let plotter = name.to_owned();
                let actions = self.run_save(i, Progress::default(), RunStep::Render, |j| {
                    JobLife::claim(j, &plotter);
                    j.state = JobState::Rendering;
                    // A job takes the plotter's offset as it starts; one
                    // that drew goes on where it began.
                    if j.checkpoint == 0 && j.strokes_done == 0 {
                        j.offset_mm = (offset != [0.0, 0.0]).then_some(offset);
                    }
                });
                Step::Run { job, actions }
            }
        }
    }

    /// Plotter `name`'s device answered, or why not, at `now`. When that
    /// changes what its waiting jobs say (they show their plotter's state),
    /// they are announced again.
    pub fn probed(&mut self, name: &str, answered: Result<(), LinkCause>, now: Instant) -> Vec<Action> {
        let head = self.head(name);
        let Some(i) = self.station(name) else { return Vec::new() };
        let ok = answered.is_ok();
        if let Err(cause) = &answered {
            if self.stations[i].cause.as_ref() != Some(cause) {
                tracing::warn!(plotter = name, cause = %cause, "plotter offline");
            }
        }
        let before = self.stations[i].reach();
        self.stations[i].set_reach(answered);
        let after = self.stations[i].reach();
        let resume = self.stations[i].probed(ok, head, now);
        // Watchers see the plotter go and come back, not each probe.
        let mut out: Vec<Action> = (before != after).then(|| Action::AnnouncePlotter(name.to_owned())).into_iter().collect();
        match head {
            Some((id, _)) if resume => {
                tracing::info!(job = id, "port back: resuming by config (auto_resume)");
                out.extend(self.change(id, Progress::default(), Then::Nothing, |j| j.state = JobState::Queued).map(Action::Save));
            }
            _ => out.extend(
                self.jobs
                    .values()
                    .map(|e| &e.shown)
                    .filter(|r| r.is_on(name) && JobInfo::waiting_on(r, &before) != JobInfo::waiting_on(r, &after))
                    .cloned()
                    .map(Action::Announce),
            ),
        }
        out
    }

    /// Plotter `name`'s device was reset as [`Step::Reset`] asked (`ok`),
    /// or could not be (it is asked again, backing off, and reset when it
    /// answers).
    pub fn reset_done(&mut self, name: &str, ok: bool, now: Instant) -> Vec<Action> {
        let Some(i) = self.station(name) else { return Vec::new() };
        if ok {
            tracing::info!(plotter = name, "device reset after a cancelled job: pen up, nothing held");
            self.stations[i].reset_owed = None;
            return self.wake(name);
        }
        tracing::warn!(plotter = name, "device not reset yet; asking it again");
        let before = self.stations[i].reach();
        self.stations[i].probed(false, None, now);
        (self.stations[i].reach() != before).then(|| Action::AnnouncePlotter(name.to_owned())).into_iter().collect()
    }

    /// Changes job `id`'s record with `f`; the [`Save`] that makes the
    /// change durable, or `None` when nothing changed (or there is no such
    /// job). The change holds at once, for every decision.
    pub(super) fn change(&mut self, id: JobId, progress: Progress, then: Then, f: impl FnOnce(&mut JobRecord)) -> Option<Save> {
        let entry = self.jobs.get_mut(&id)?;
        let mut next = entry.record.clone();
        f(&mut next);
        if next == entry.record {
            return None;
        }
        entry.record = next.clone();
        entry.version += 1;
        Some(Save { record: next, progress, version: entry.version, then })
    }

    /// A save was carried out (`Err`: why it failed). The record is shown
    /// either way: the daemon acts on it, and the disk catches up at the
    /// job's next change that can be saved (a restart meanwhile finds the
    /// older record, as after a power loss).
    pub fn saved(&mut self, save: &Save, result: Result<(), &SpoolError>) -> Vec<Action> {
        let id = save.record.id;
        if let Some(e) = self.jobs.get_mut(&id) {
            if save.version > e.shown_version {
                e.shown = save.record.clone();
                e.shown_version = save.version;
            }
        }
        let result = result.map_err(ToString::to_string);
        if let (Err(e), false) = (&result, save.then == Then::Checkpoint) {
            tracing::error!(job = id, error = %e, "cannot save the job's record; the change holds in memory");
        }
        let mut out = match (&save.then, result) {
            (Then::Nothing | Then::Checkpoint, Ok(())) | (Then::Nothing, Err(_)) => Vec::new(),
            (Then::Run(step), Ok(())) => self.running(id).map(|i| self.run_step(i, *step)).unwrap_or_default(),
            (Then::Run(_), Err(e)) => self.running(id).map(|i| self.end_run(i, Ending::State(ending::unsaved(&e)))).unwrap_or_default(),
            (Then::Checkpoint, Err(e)) => self.checkpoint_unsaved(id, e),
            (Then::Answer(answer), result) => self.answer(id, answer.clone(), result),
        };
        if save.record.state.is_final() {
            out.extend(self.prune());
        }
        out
    }

    /// A removal was carried out (`Err`: why it failed).
    pub fn removed(&mut self, job: JobId, why: &Removal, result: Result<(), &SpoolError>) -> Vec<Action> {
        match (why, result.map_err(ToString::to_string)) {
            (Removal::Pruned, _) => Vec::new(),
            (Removal::Cancelled { unsaved }, Ok(())) => {
                vec![Action::Reply(Ok(format!("job {job} cancelled (the spool cannot be written: {unsaved}; its files were deleted)")))]
            }
            (Removal::Cancelled { unsaved }, Err(e)) => {
                vec![Action::Reply(Err(ControlError::CancelUnrecorded { id: job, saving: unsaved.clone(), removing: e }))]
            }
        }
    }

    /// Forgets the oldest finished jobs beyond `keep_finished` (those shown
    /// finished: their last save is done). Unfinished jobs are never
    /// touched, and the newest id is always kept (an unfinished job, or a
    /// finished one among those kept), so ids are not reused after a
    /// restart.
    pub fn prune(&mut self) -> Vec<Action> {
        let mut finished: Vec<JobId> = self.jobs.values().filter(|e| e.shown.state.is_final()).map(|e| e.shown.id).collect();
        finished.truncate(finished.len().saturating_sub(self.keep_finished));
        for id in &finished {
            self.jobs.remove(id);
        }
        finished.into_iter().map(|job| Action::Remove { job, why: Removal::Pruned }).collect()
    }

    /// Asks station `i`'s run to stop for `why`, at least `how`.
    pub(super) fn ask_stop(&mut self, i: usize, why: StopReason, how: Stop) -> Vec<Action> {
        let how = self.stations[i].ask_stop(why, how);
        let plotter = self.stations[i].name().to_owned();
        vec![Action::Stop { plotter: plotter.clone(), how }, Action::Wake(plotter)]
    }

    /// Wakes plotter `name`: it looks at its queue again at once.
    pub(super) fn wake(&mut self, name: &str) -> Vec<Action> {
        match self.station(name) {
            Some(i) => {
                self.stations[i].wake();
                vec![Action::Wake(name.to_owned())]
            }
            None => Vec::new(),
        }
    }

    /// The daemon shuts down: no job starts or is submitted, and every run
    /// stops at its next stroke boundary.
    pub fn shut_down(&mut self) -> Vec<Action> {
        self.shutting_down = true;
        (0..self.stations.len()).flat_map(|i| self.ask_stop(i, StopReason::Shutdown, Stop::AfterStroke)).collect()
    }

    /// The config was reloaded: plotters are updated in place (a new port,
    /// rate or handshake takes effect when the port is next opened), new
    /// ones added (returned, for their tasks), and `keep_finished` applies
    /// at once. A plotter gone from the config keeps running until restart.
    pub fn reload(&mut self, plotters: &[PlotterConfig], keep_finished: usize) -> (Vec<Action>, Vec<String>) {
        self.keep_finished = keep_finished.max(1);
        let (mut out, mut added) = (Vec::new(), Vec::new());
        for p in plotters {
            match self.station(&p.name) {
                Some(i) => {
                    self.stations[i].config = p.clone();
                    out.extend(self.wake(&p.name));
                }
                None => {
                    self.stations.push(Station::new(p.clone()));
                    added.push(p.name.clone());
                }
            }
        }
        out.extend(self.prune());
        (out, added)
    }

    /// Carries on with the run of station `i`: with `step` once `f`'s change
    /// is saved, or at once when `f` changes nothing.
    pub(super) fn run_save(&mut self, i: usize, progress: Progress, step: RunStep, f: impl FnOnce(&mut JobRecord)) -> Vec<Action> {
        let Some(job) = self.stations[i].run.as_ref().map(|r| r.job) else { return Vec::new() };
        match self.change(job, progress, Then::Run(step), f) {
            Some(save) => vec![Action::Save(save)],
            None => self.run_step(i, step),
        }
    }
}
