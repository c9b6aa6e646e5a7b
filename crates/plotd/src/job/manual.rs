//! A person at the plotter: the pen raised or lowered, the carriage moved
//! to a point or by a step, a GRBL board homed (only one with homing
//! switches, `homing = true`), a job's frame traced ([`Manual`]). Allowed while
//! the plotter is idle or its job paused; refused while a job plots on it
//! (from its render to its run's end), naming the job, and while another
//! manual request is being carried out. An accepted one waits in the
//! plotter's station until its task polls ([`Step::Manual`], before any
//! job), and the task reports with [`JobLife::manual_done`].
//!
//! A paused job whose plotter moved by hand no longer knows where the pen
//! rests from what it wrote: its written mark is forgotten, and it resumes
//! from its checkpoint (with the resume prefix, which puts the pen back).

use super::action::{Action, Manual, ManualWork, Step};
use super::error::ControlError;
use super::life::JobLife;

impl JobLife {
    /// A person's manual request for `plotter` (`None`: the only one; a
    /// frame goes to its job's plotter). Returns the plotter that carries
    /// it out, and what to do now (the plotter woken).
    ///
    /// # Errors
    /// [`ControlError`]: no such plotter or job, a plotter to name, a job
    /// plotting on it, a manual request already under way, a job finished,
    /// the daemon shutting down.
    pub fn manual(&mut self, plotter: Option<&str>, op: Manual) -> Result<(String, Vec<Action>), ControlError> {
        if self.shutting_down {
            return Err(ControlError::ShuttingDown);
        }
        let (mut kind, mut offset_mm) = (None, None);
        let name = match op {
            Manual::Frame { job } => {
                let record = &self.jobs.get(&job).ok_or(ControlError::NoJob(job))?.record;
                if record.state.is_final() {
                    return Err(ControlError::Finished { id: job, state: record.state.name() });
                }
                if record.unclaimed().is_some() {
                    return Err(ControlError::NotTaken { id: job, class: record.plotter.clone() });
                }
                kind = Some(record.kind);
                offset_mm = record.offset_mm;
                record.plotter.clone()
            }
            _ => self.manual_plotter(plotter)?,
        };
        let i = self.station(&name).ok_or_else(|| ControlError::NoSuchPlotter(name.clone()))?;
        let station = &mut self.stations[i];
        let gcode = station.config.profile.as_ref().is_some_and(|p| p.protocol == plotcode::Protocol::Gcode);
        if op == Manual::Home && !(station.config.homing && gcode) {
            return Err(ControlError::NoHoming(name));
        }
        if let Some(run) = &station.run {
            return Err(ControlError::Plotting { plotter: name, job: run.job });
        }
        if station.manual.is_some() || station.manual_busy {
            return Err(ControlError::ManualBusy(name));
        }
        // A job not yet started will take the plotter's offset.
        let offset_mm = offset_mm.unwrap_or(station.state.offset_mm);
        station.manual = Some(ManualWork { op, kind, offset_mm });
        // Nothing a paused job wrote says where the pen rests any more.
        let mut out: Vec<Action> = self
            .jobs
            .values()
            .map(|e| &e.record)
            .filter(|j| j.plotter == name && j.state.pause_cause().is_some())
            .map(|j| Action::ForgetWritten(j.id))
            .collect();
        out.extend(self.wake(&name));
        Ok((name, out))
    }

    /// `offset PLOTTER DX DY`: the plotter's origin offset, kept in the
    /// spool; the jobs that start from now on are drawn moved by it (one
    /// that started keeps its own: it goes on where it began). Refused when
    /// not a distance, or so large it leaves no room on the plotter's
    /// largest sheet: nothing could be drawn.
    pub fn set_offset(&mut self, plotter: &str, offset_mm: [f64; 2]) -> Vec<Action> {
        let Some(i) = self.station(plotter) else {
            return vec![Action::Reply(Err(ControlError::NoSuchPlotter(plotter.to_owned())))];
        };
        let [dx, dy] = offset_mm;
        let room = self.stations[i].config.profile.as_ref().map(plotcode::control::manual::reach_mm);
        let too_far = room.is_some_and(|(lo, hi)| dx.abs() >= (hi.x - lo.x) / 2.0 || dy.abs() >= (hi.y - lo.y) / 2.0);
        if !(dx.is_finite() && dy.is_finite()) || too_far {
            return vec![Action::Reply(Err(ControlError::BadOffset { plotter: plotter.to_owned(), offset: format!("({dx}, {dy})") }))];
        }
        let station = &mut self.stations[i];
        station.state.offset_mm = offset_mm;
        let reply = format!(
            "plotter {plotter}: origin offset ({dx}, {dy}) mm, for the jobs that start from now on (a job that started keeps its own)"
        );
        vec![Action::SavePlotter { plotter: plotter.to_owned(), state: station.state.clone() }, Action::Reply(Ok(reply))]
    }

    /// Plotter `name`'s origin offset, mm.
    #[must_use]
    pub fn offset(&self, name: &str) -> Option<[f64; 2]> {
        self.station(name).map(|i| self.stations[i].state.offset_mm)
    }

    /// The pen a person last put in plotter `name` (one-pen plotters).
    #[must_use]
    pub fn pen_loaded(&self, name: &str) -> Option<u32> {
        self.station(name).and_then(|i| self.stations[i].state.pen_loaded)
    }

    /// The plotter a request names, or the only one there is.
    fn manual_plotter(&self, plotter: Option<&str>) -> Result<String, ControlError> {
        match plotter {
            Some(p) => self.station(p).map(|_| p.to_owned()).ok_or_else(|| ControlError::NoSuchPlotter(p.to_owned())),
            None if self.stations.len() == 1 => Ok(self.stations[0].name().to_owned()),
            None => Err(ControlError::WhichPlotter(self.plotters().map(|p| p.name.clone()).collect())),
        }
    }

    /// Station `i`'s manual request, taken to be carried out (it is busy
    /// until [`JobLife::manual_done`]).
    pub(super) fn take_manual(&mut self, i: usize) -> Option<Step> {
        let work = self.stations[i].manual.take()?;
        self.stations[i].manual_busy = true;
        Some(Step::Manual(work))
    }

    /// Plotter `name`'s manual request was carried out (or failed): it
    /// takes requests again, and looks at its queue at once.
    pub fn manual_done(&mut self, name: &str) {
        if let Some(i) = self.station(name) {
            self.stations[i].manual_busy = false;
            self.stations[i].wake();
        }
    }
}
