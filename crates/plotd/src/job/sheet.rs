//! Sheets: a plotter knows whether the sheet in it was drawn on. A run that
//! drew leaves it used (done, paused or cancelled after drawing); the next
//! job that has drawn nothing yet then waits, paused `load-sheet`, until a
//! person says a fresh one is in (`sheet-loaded`), unless it was submitted
//! to draw on the same sheet (an overlay, a second pass). A job that drew
//! already goes on on its own sheet. The plotter's sheet is saved in the
//! spool ([`Action::SavePlotter`]) before the job that waits for it is.
//!
//! A job of several copies (`--copies N`) is drawn N times, a sheet each:
//! a run that reaches its end with copies left starts the next copy, the
//! job queued again from its first chunk, and so waits for a fresh sheet as
//! any job that drew nothing yet. Its record says which copy it is on.

use super::action::{Action, Progress, Then};
use super::error::ControlError;
use super::life::JobLife;
use super::station::Head;
use crate::spool::{JobId, JobRecord, JobState, PauseCause, PlotterState, Sheet};

/// Why `job` waits for a fresh sheet on `plotter`, and what to do.
pub(super) fn reason(plotter: &str, job: &JobRecord) -> String {
    let copy = if job.copies > 1 { format!("copy {} of {}: ", job.copy, job.copies) } else { String::new() };
    format!("{copy}load a fresh sheet on plotter {plotter}, then: plotd sheet-loaded {plotter}")
}

/// How a run that ended in `state` leaves `job`: done with copies left is
/// its next copy, queued from the start.
pub(super) fn after_run(job: &mut JobRecord, state: JobState) {
    if state != JobState::Done || job.copy >= job.copies {
        job.state = state;
        return;
    }
    job.copy += 1;
    job.state = JobState::Queued;
    job.checkpoint = 0;
    job.strokes_done = 0;
    job.page_loaded = 0;
}

impl JobLife {
    /// Plotter `name`'s sheet.
    #[must_use]
    pub fn sheet(&self, name: &str) -> Option<Sheet> {
        self.station(name).map(|i| self.stations[i].state.sheet)
    }

    /// Plotter `name`'s state as the spool kept it (read at start).
    pub fn restore_plotter(&mut self, name: &str, state: PlotterState) {
        if let Some(i) = self.station(name) {
            self.stations[i].state = state;
        }
    }

    /// Sets station `i`'s sheet; the save that keeps it, when it changed.
    fn set_sheet(&mut self, i: usize, sheet: Sheet) -> Option<Action> {
        let station = &mut self.stations[i];
        if station.state.sheet == sheet {
            return None;
        }
        station.state.sheet = sheet;
        Some(Action::SavePlotter { plotter: station.name().to_owned(), state: station.state.clone() })
    }

    /// When station `i`'s `head` job, queued and never drawn, would draw
    /// over the last job's sheet: the save that makes it wait for a fresh
    /// one.
    pub(super) fn wait_for_sheet(&mut self, i: usize, head: Head) -> Option<Vec<Action>> {
        let Some((id, None)) = head else { return None };
        let job = &self.jobs.get(&id)?.record;
        if self.stations[i].state.sheet != Sheet::Used || job.same_sheet || job.checkpoint > 0 {
            return None;
        }
        let reason = reason(self.stations[i].name(), job);
        let save = self.change(id, Progress::default(), Then::Nothing, |j| j.state = JobState::paused(PauseCause::LoadSheet, reason))?;
        Some(vec![Action::Save(save)])
    }

    /// Station `i`'s run of `job` ended: when it drew, the sheet is used.
    pub(super) fn sheet_after_run(&mut self, i: usize, job: JobId) -> Option<Action> {
        let drew = self.jobs.get(&job).is_some_and(|e| e.record.strokes_done > 0);
        if drew {
            self.set_sheet(i, Sheet::Used)
        } else {
            None
        }
    }

    /// `sheet-loaded PLOTTER`: a fresh sheet is in; the job waiting for it
    /// is queued again.
    pub fn sheet_loaded(&mut self, plotter: &str) -> Vec<Action> {
        let Some(i) = self.station(plotter) else {
            return vec![Action::Reply(Err(ControlError::NoSuchPlotter(plotter.to_owned())))];
        };
        let mut out: Vec<Action> = self.set_sheet(i, Sheet::Fresh).into_iter().collect();
        let waiting: Vec<JobId> = self
            .jobs
            .values()
            .map(|e| &e.record)
            .filter(|j| j.plotter == plotter && j.state.pause_cause() == Some(PauseCause::LoadSheet))
            .map(|j| j.id)
            .collect();
        if waiting.is_empty() {
            out.push(Action::Reply(Ok(format!("a fresh sheet is in plotter {plotter}"))));
            // It may take a job waiting for any plotter of its class now.
            out.extend(self.wake(plotter));
        } else {
            out.extend(self.resume_next(Vec::new(), waiting));
        }
        out
    }
}
