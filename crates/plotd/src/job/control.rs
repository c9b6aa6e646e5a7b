//! Submits and a person's requests (`cancel`, `pause`, `resume`,
//! `pen-changed`): which jobs they act on, what they change, what stops,
//! and the answer, each a typed refusal when it cannot be done.

use super::action::{Action, Answer, Progress, Removal, StopReason, Then};
use super::ending;
use super::error::{ControlError, SubmitError};
use super::life::{Entry, JobLife};
use super::position;
use crate::spool::{JobId, JobKind, JobRecord, JobState, PauseCause};
use crate::stream::{Restore, Stop};

/// A job being submitted, before it has an id.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct NewJob {
    /// Content kind.
    pub kind: JobKind,
    /// The plotter it goes to; for a class, the class's name.
    pub plotter: String,
    /// The class it was submitted for, and the plotters of it that can draw it.
    pub class: Option<crate::spool::PlotterClass>,
    /// A name for humans (`None`: `job-ID`).
    pub name: Option<String>,
    /// Submitter's uid and pid.
    pub uid: u32,
    /// (0 if unknown).
    pub pid: i32,
    /// Drawn on the sheet in the plotter: it never waits for a fresh one.
    pub same_sheet: bool,
    /// Sheets to draw it on, one after another (1 to [`MAX_COPIES`]).
    pub copies: u32,
    /// The plotter's pen for each pen of the job drawn with another.
    pub pens: crate::pen_map::PenMap,
    /// For an SVG drawing: what its fills hide.
    pub occult: Option<crate::spool::Occult>,
    /// Seconds since the Unix epoch.
    pub submitted_at: u64,
}

/// Most copies one job may plot (`--copies`), a sheet each.
pub const MAX_COPIES: u32 = 1000;

fn reply(r: Result<String, ControlError>) -> Vec<Action> {
    vec![Action::Reply(r)]
}

fn pausing(n: usize, now: bool) -> String {
    let when = if now { "now" } else { "at the next stroke boundary" };
    format!("{n} job(s) pausing {when}")
}

impl JobLife {
    /// Checks a job's `copies`: 1 to [`MAX_COPIES`].
    ///
    /// # Errors
    /// [`SubmitError::Refused`] naming the field and its range.
    pub fn check_copies(copies: u32) -> Result<(), SubmitError> {
        if (1..=MAX_COPIES).contains(&copies) {
            Ok(())
        } else {
            Err(SubmitError::Refused(format!("copies: {copies}; a job plots 1 to {MAX_COPIES} copies, a sheet each")))
        }
    }

    /// A new job's record, `queued`, under the next id. It joins the jobs
    /// once it is in the spool ([`JobLife::created`]): a client hears its id
    /// only then.
    pub fn new_job(&mut self, job: NewJob) -> JobRecord {
        let id = self.next_id;
        self.next_id += 1;
        JobRecord {
            id,
            kind: job.kind,
            plotter: job.plotter,
            class: job.class,
            name: job.name.unwrap_or_else(|| format!("job-{id}")),
            uid: job.uid,
            pid: job.pid,
            submitted_at: job.submitted_at,
            state: JobState::Queued,
            checkpoint: 0,
            total: None,
            strokes_done: 0,
            strokes_total: None,
            pen_loaded: None,
            page_loaded: 0,
            same_sheet: job.same_sheet,
            offset_mm: None,
            copies: job.copies,
            copy: 1,
            pens: job.pens,
            occult: job.occult,
        }
    }

    /// `record` is in the spool: the job is announced, and its plotter
    /// (every plotter that may take it) looks at its queue.
    pub fn created(&mut self, record: JobRecord) -> Vec<Action> {
        let id = record.id;
        self.jobs.insert(id, Entry::new(record.clone()));
        let mut out = vec![Action::Announce(record)];
        for plotter in self.plotters_of(id) {
            out.extend(self.wake(&plotter));
        }
        out
    }

    /// `cancel ID`: a running job stops at the end of its stroke, or `now`
    /// where the pen is, and ends cancelled whatever the device then does
    /// (a device that could not be told is reset when it answers again,
    /// before any job); one the device holds is cancelled at once and
    /// stopped now; any other unfinished job is
    /// cancelled at once. When its record cannot be rewritten, its files are
    /// deleted instead: a cancelled job needs nothing on disk, deleting
    /// takes no space, and it cannot come back queued after a restart.
    pub fn cancel(&mut self, id: JobId, now: bool) -> Vec<Action> {
        let Some(job) = self.jobs.get(&id).map(|e| &e.record) else { return reply(Err(ControlError::NoJob(id))) };
        if job.state.is_final() {
            return reply(Err(ControlError::Finished { id, state: job.state.name() }));
        }
        let plotter = job.plotter.clone();
        let held = job.state.pause_cause() == Some(PauseCause::DeviceHold);
        if let (Some(i), true) = (self.running(id), held) {
            // The device holds the job until a person acts (a paper lever
            // up): no stroke ends meanwhile. The job is cancelled here and
            // now; the device drops what it holds and lifts the pen when it
            // goes on (or is reset, if it never can be told).
            let mut out = self.ask_stop(i, StopReason::Cancel, Stop::Now);
            out.extend(
                self.change(id, Progress::default(), Then::Answer(Answer::Cancelled), |j| j.state = JobState::Cancelled).map(Action::Save),
            );
            return out;
        }
        if let Some(i) = self.running(id) {
            let mut out = self.ask_stop(i, StopReason::Cancel, Stop::asked(now));
            let when = if now { "now" } else { "at the end of the current stroke" };
            out.push(Action::Reply(Ok(format!("job {id} stops {when}"))));
            return out;
        }
        let save = self.change(id, Progress::default(), Then::Answer(Answer::Cancelled), |j| j.state = JobState::Cancelled);
        let mut out: Vec<Action> = save.map(Action::Save).into_iter().collect();
        out.extend(self.wake(&plotter));
        out
    }

    /// `pause [ID]`: a running job (one the device holds too) stops at the
    /// next stroke boundary, or `now`; a job named that is not running is
    /// paused at once (its plotter waits for it). Without an id, every
    /// running job.
    pub fn pause(&mut self, id: Option<JobId>, now: bool) -> Vec<Action> {
        let targets: Vec<JobId> = self
            .jobs
            .values()
            .map(|e| &e.record)
            .filter(|j| id.is_none_or(|i| i == j.id))
            .filter(|j| !j.state.is_final() && j.state.pause_cause().is_none_or(|c| c == PauseCause::DeviceHold))
            .map(|j| j.id)
            .collect();
        if let (Some(id), true) = (id, targets.is_empty()) {
            return reply(Err(ControlError::NotPausable(id)));
        }
        let (mut out, mut n) = (Vec::new(), 0);
        for job in targets {
            if let Some(i) = self.running(job) {
                out.extend(self.ask_stop(i, StopReason::Pause, Stop::asked(now)));
            } else if id.is_some() {
                // Held before it starts: the plotter waits for it. The
                // answer follows the save.
                let save = self.change(job, Progress::default(), Then::Answer(Answer::Paused { now }), |j| j.state = ending::by_person());
                out.extend(save.map(Action::Save));
                return out;
            } else {
                continue;
            }
            n += 1;
        }
        out.push(Action::Reply(Ok(pausing(n, now))));
        out
    }

    /// `resume [ID]`: paused jobs (one, or all) are queued again, from
    /// their checkpoint; a pen or a sheet asked for is taken to be loaded.
    /// A job the device holds is refused: it goes on by itself, in the run
    /// that holds it. A job whose position was lost, or whose board must be
    /// homed, goes on only with `position_confirmed` (a person parked the
    /// pen at the origin), or on a plotter with homing switches, which its
    /// run homes first.
    pub fn resume(&mut self, id: Option<JobId>, position_confirmed: bool) -> Vec<Action> {
        let restore = |j: &JobRecord| {
            let homing = self.station(&j.plotter).is_some_and(|i| self.stations[i].config.homing);
            position::may_resume(j.id, &j.state, position_confirmed, homing)
        };
        let unconfirmed = |j: &JobRecord| restore(j).err().filter(|_| id.is_none_or(|i| i == j.id));
        let refused = self.jobs.values().find_map(|e| unconfirmed(&e.record));
        let jobs = self.resumable(|j| id.is_none_or(|i| i == j.id) && unconfirmed(j).is_none(), false);
        let allowed: Vec<(JobId, String, Restore)> = jobs
            .iter()
            .filter_map(|id| self.jobs.get(id).map(|e| &e.record))
            .filter_map(|j| restore(j).ok().filter(|r| *r != Restore::Nothing).map(|r| (j.id, j.plotter.clone(), r)))
            .collect();
        for (job, plotter, r) in allowed {
            if let Some(i) = self.station(&plotter) {
                self.stations[i].restoring.insert(job, r);
            }
        }
        if jobs.is_empty() {
            let err = match (id, refused) {
                (Some(id), _) if self.jobs.get(&id).is_some_and(|e| e.record.state.pause_cause() == Some(PauseCause::DeviceHold)) => {
                    ControlError::HeldByPlotter(id)
                }
                (Some(id), None) if self.jobs.get(&id).is_some_and(|e| e.record.state.pause_cause() == Some(PauseCause::LoadSheet)) => {
                    ControlError::SheetAwaited { id, plotter: self.jobs[&id].record.plotter.clone() }
                }
                (_, Some(refused)) => refused,
                (Some(id), None) => ControlError::NotPaused(id),
                (None, None) => ControlError::NothingPaused,
            };
            return reply(Err(err));
        }
        self.resume_next(Vec::new(), jobs)
    }

    /// `pen-changed [PLOTTER]`: the jobs waiting for a pen (on that plotter,
    /// or any) go on.
    pub fn pen_changed(&mut self, plotter: Option<&str>) -> Vec<Action> {
        let jobs = self.resumable(|j| plotter.is_none_or(|p| p == j.plotter), true);
        if jobs.is_empty() {
            return reply(Err(ControlError::NoPenAwaited));
        }
        self.resume_next(Vec::new(), jobs)
    }

    /// Paused jobs that `pick` picks and a person may resume (`pen`: only
    /// those waiting for a pen).
    fn resumable(&self, pick: impl Fn(&JobRecord) -> bool, pen: bool) -> Vec<JobId> {
        let may = |s: &JobState| match s {
            JobState::Paused { cause: PauseCause::DeviceHold | PauseCause::LoadSheet, .. } => false,
            JobState::Paused { insert_pen, .. } => !pen || insert_pen.is_some(),
            _ => false,
        };
        self.jobs.values().map(|e| &e.record).filter(|j| may(&j.state) && pick(j)).map(|j| j.id).collect()
    }

    /// Resumes the first of `rest` (its save answers for the rest), or
    /// answers when none is left.
    pub(super) fn resume_next(&mut self, mut done: Vec<JobId>, mut rest: Vec<JobId>) -> Vec<Action> {
        if rest.is_empty() {
            let ids: Vec<String> = done.iter().map(ToString::to_string).collect();
            return reply(Ok(format!("resumed job(s) {}", ids.join(", "))));
        }
        let id = rest.remove(0);
        done.push(id);
        let Some(plotter) = self.jobs.get(&id).map(|e| e.record.plotter.clone()) else { return self.resume_next(done, rest) };
        let inserted = self.jobs.get(&id).and_then(|e| match e.record.state {
            JobState::Paused { insert_pen, .. } => insert_pen,
            _ => None,
        });
        let plotters = self.plotters_of(id);
        let save = self.change(id, Progress::default(), Then::Answer(Answer::Resumed { done, rest }), |j| {
            if let JobState::Paused { insert_pen, load_page, .. } = &j.state {
                j.pen_loaded = insert_pen.or(j.pen_loaded);
                j.page_loaded = load_page.unwrap_or(j.page_loaded);
            }
            j.state = JobState::Queued;
        });
        let mut out: Vec<Action> = Vec::new();
        // The pen the person put in stays the plotter's, for the next job too.
        if let (Some(pen), Some(i)) = (inserted, self.station(&plotter)) {
            let station = &mut self.stations[i];
            station.state.pen_loaded = Some(pen);
            out.push(Action::SavePlotter { plotter: plotter.clone(), state: station.state.clone() });
        }
        out.extend(save.map(Action::Save));
        for plotter in plotters {
            out.extend(self.wake(&plotter));
        }
        out
    }

    /// What follows the save of a person's request for job `id`.
    pub(super) fn answer(&mut self, id: JobId, answer: Answer, saved: Result<(), String>) -> Vec<Action> {
        match (answer, saved) {
            (Answer::Cancelled, Ok(())) => reply(Ok(format!("job {id} cancelled"))),
            (Answer::Cancelled, Err(unsaved)) => vec![Action::Remove { job: id, why: Removal::Cancelled { unsaved } }],
            (Answer::Paused { now }, Ok(())) => reply(Ok(pausing(1, now))),
            (Answer::Resumed { done, rest }, Ok(())) => self.resume_next(done, rest),
            (Answer::Paused { .. } | Answer::Resumed { .. }, Err(e)) => reply(Err(ControlError::Unsaved(e))),
        }
    }
}
