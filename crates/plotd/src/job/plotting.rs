//! One run of a job on its plotter: the program rendered, the pen located
//! after an interruption, then spans of chunks streamed, each up to the next
//! thing a person must load (a pen, a sheet), until the job is done or the
//! run stops: asked to, the link lost, the device reset or in error, or a
//! checkpoint that cannot be saved.

use super::action::{Action, RunStep, StopReason, Then};
use super::ending::{self, Ending};
use super::life::JobLife;
use super::park;
use super::run::Tally;
use super::sheet;
use crate::config::PenChangePolicy;
use crate::spool::{JobId, JobState, PauseCause, WrittenMark};
use crate::stream::{Hold, Outcome, Stop, StreamError};
use plotcode::Program;
use std::sync::Arc;

/// What rendering a job gave ([`JobLife::rendered`]).
#[derive(Debug)]
pub enum Rendered {
    /// Its program, for a device with `pens` pens.
    Program {
        /// The program.
        program: Program,
        /// Pens the device holds (one: a person changes them).
        pens: u32,
    },
    /// It cannot be rendered: the reason, for its `failed` state.
    Failed(String),
    /// Stopped on request before it was done.
    Stopped,
}

impl JobLife {
    /// The station of plotter `name`, while it runs a job.
    fn run_of(&self, name: &str) -> Option<usize> {
        self.station(name).filter(|&i| self.stations[i].run.is_some())
    }

    /// What station `i`'s run does once `step`'s save is done.
    pub(super) fn run_step(&mut self, i: usize, step: RunStep) -> Vec<Action> {
        let Some(run) = self.stations[i].run.as_mut() else { return Vec::new() };
        let job = run.job;
        match step {
            RunStep::Render => self
                .jobs
                .get(&job)
                .map(|e| vec![Action::Render { job, kind: e.record.kind, offset_mm: e.record.offset_mm.unwrap_or_default() }])
                .unwrap_or_default(),
            RunStep::ReadMark => vec![Action::ReadMark(job)],
            RunStep::Stream => {
                run.resume = run.confirmed > 0;
                // From here on the mark describes this run's writes only.
                let mut out = vec![Action::StartMark(job)];
                out.extend(self.next_span(i));
                out
            }
        }
    }

    /// Plotter `name`'s job was rendered, or not.
    pub fn rendered(&mut self, name: &str, rendered: Rendered) -> Vec<Action> {
        let Some(i) = self.run_of(name) else { return Vec::new() };
        match rendered {
            Rendered::Failed(reason) => self.end_run(i, Ending::State(JobState::Failed { reason: crate::text::message(&reason) })),
            // Nothing was drawn: a shutdown leaves the job queued for the next start.
            Rendered::Stopped if self.stations[i].stop_reason == Some(StopReason::Shutdown) => {
                self.end_run(i, Ending::State(JobState::Queued))
            }
            Rendered::Stopped => self.end_run(i, Ending::Stopped { forget_mark: false }),
            Rendered::Program { program, pens } => {
                let pens_pause = match self.stations[i].config.pen_change {
                    PenChangePolicy::Pause => true,
                    PenChangePolicy::Ignore => false,
                    PenChangePolicy::Auto => pens <= 1,
                };
                let mut tally = Tally::new(program);
                let (total, strokes_total) = (tally.total(), tally.strokes(usize::MAX));
                let first_pen = tally.program.chunks.iter().find(|c| c.draws).and_then(|c| c.pen);
                // A person changes the pens: the job starts with the pen in
                // the plotter, asking for its first when that is another.
                let in_plotter = pens_pause.then_some(self.stations[i].state.pen_loaded).flatten();
                let job_pen = self.stations[i].run.as_ref().and_then(|r| self.jobs.get(&r.job)).and_then(|e| e.record.pen_loaded);
                let pen_loaded = job_pen.or(in_plotter).or(first_pen);
                if pens_pause {
                    tally.count_changes(pen_loaded);
                }
                let mut out = Vec::new();
                if pens_pause && pen_loaded.is_some() && self.stations[i].state.pen_loaded != pen_loaded {
                    let station = &mut self.stations[i];
                    station.state.pen_loaded = pen_loaded;
                    out.push(Action::SavePlotter { plotter: station.name().to_owned(), state: station.state.clone() });
                }
                let Some(run) = self.stations[i].run.as_mut() else { return Vec::new() };
                let checkpoint = self.jobs.get(&run.job).map_or(0, |e| e.record.checkpoint);
                let (progress, done) = (tally.progress(checkpoint), tally.strokes(checkpoint));
                run.tally = Some(tally);
                run.pens_pause = pens_pause;
                out.extend(self.run_save(i, progress, RunStep::ReadMark, |j| {
                    j.state = JobState::Plotting;
                    j.total = Some(total);
                    j.checkpoint = j.checkpoint.min(total);
                    j.strokes_total = Some(strokes_total);
                    j.strokes_done = done;
                    j.pen_loaded = pen_loaded;
                }));
                out
            }
        }
    }

    /// The job's written mark, as plotter `name`'s run read it (`None`:
    /// there is none, or it cannot be read: only the checkpoint counts).
    /// When it says more was written than confirmed, the device is asked
    /// how far it got ([`Action::Locate`]).
    pub fn mark_read(&mut self, name: &str, mark: Option<WrittenMark>) -> Vec<Action> {
        let Some(i) = self.run_of(name) else { return Vec::new() };
        let Some(run) = self.stations[i].run.as_mut() else { return Vec::new() };
        let Some(tally) = &run.tally else { return Vec::new() };
        let checkpoint = self.jobs.get(&run.job).map_or(0, |e| e.record.checkpoint);
        let Some(w) = mark else { return self.located_at(i, checkpoint) };
        // The candidates start at the last confirmation the run heard, which
        // the mark keeps: the saved checkpoint lags it (saved with fsync on a
        // task of its own), and under load by many strokes, each a candidate
        // for a place the pen rests at (issue #15: a GRBL job drew two
        // strokes again after a SIGKILL).
        let from = checkpoint.max(w.confirmed.min(tally.total()));
        if w.mark.resume_at() <= from {
            return self.located_at(i, from);
        }
        run.candidates_from = from;
        vec![Action::Locate { program: Arc::clone(&tally.program), from, mark: w.mark }]
    }

    /// Where plotter `name`'s device got: the chunk to resume from (`None`:
    /// it could not tell, resume from the candidates' first), or the error
    /// that ends the run.
    pub fn located(&mut self, name: &str, found: Result<Option<usize>, StreamError>) -> Vec<Action> {
        let Some(i) = self.run_of(name) else { return Vec::new() };
        match found {
            Err(e) => {
                // What the device confirmed before the interruption (the
                // mark keeps it) was drawn, whatever it says now: a board
                // found in alarm or restarted goes on from there once a
                // person confirms.
                if let Some(run) = self.stations[i].run.as_mut() {
                    run.confirmed = run.confirmed.max(run.candidates_from);
                }
                self.end_run(i, Ending::Failed(e))
            }
            Ok(found) => {
                let Some(run) = self.stations[i].run.as_ref() else { return Vec::new() };
                let (from, total) = (run.candidates_from, run.tally.as_ref().map_or(0, Tally::total));
                self.located_at(i, found.map_or(from, |k| k.clamp(from, total)))
            }
        }
    }

    /// Station `i`'s run goes on from chunk `k`, at or past its checkpoint.
    fn located_at(&mut self, i: usize, k: usize) -> Vec<Action> {
        let Some(run) = self.stations[i].run.as_mut() else { return Vec::new() };
        let Some(tally) = &run.tally else { return Vec::new() };
        let checkpoint = self.jobs.get(&run.job).map_or(k, |e| e.record.checkpoint.max(k));
        let (progress, done) = (tally.progress(k), tally.strokes(checkpoint));
        run.confirmed = checkpoint;
        self.run_save(i, progress, RunStep::Stream, |j| {
            j.checkpoint = checkpoint;
            j.strokes_done = done;
        })
    }

    /// Plotter `name`'s device confirmed executing chunks `..k`.
    pub fn confirmed(&mut self, name: &str, k: usize) -> Vec<Action> {
        let Some(i) = self.run_of(name) else { return Vec::new() };
        let Some(run) = self.stations[i].run.as_mut() else { return Vec::new() };
        let Some(tally) = &run.tally else { return Vec::new() };
        let k = k.min(tally.total());
        if k <= run.confirmed {
            return Vec::new();
        }
        run.confirmed = k;
        let checkpoint = self.jobs.get(&run.job).map_or(k, |e| e.record.checkpoint.max(k));
        let (job, progress, done) = (run.job, tally.progress(k), tally.strokes(checkpoint));
        self.change(job, progress, Then::Checkpoint, |j| {
            j.checkpoint = checkpoint;
            j.strokes_done = done;
        })
        .map(Action::SaveCheckpoint)
        .into_iter()
        .collect()
    }

    /// Plotter `name`'s device holds the job until a person acts (`Some`:
    /// the job shows paused with the device's reason, and stays the run's),
    /// or goes on (`None`: plotting again).
    pub fn held(&mut self, name: &str, why: Option<Hold>) -> Vec<Action> {
        let Some(i) = self.run_of(name) else { return Vec::new() };
        let Some(run) = self.stations[i].run.as_ref() else { return Vec::new() };
        let (job, progress) = (run.job, run.progress());
        // A job cancelled while held is over, whatever the device says next.
        let Some(state) = self.jobs.get(&job).filter(|e| !e.record.state.is_final()).and_then(|e| ending::held(&e.record.state, why))
        else {
            return Vec::new();
        };
        self.change(job, progress, Then::Checkpoint, |j| j.state = state).map(Action::SaveCheckpoint).into_iter().collect()
    }

    /// A checkpoint of job `id` could not be saved (`error`): the run stops
    /// at the next stroke boundary, and keeps its checkpoint in memory, so
    /// nothing is streamed twice.
    pub(super) fn checkpoint_unsaved(&mut self, id: JobId, error: String) -> Vec<Action> {
        let Some(i) = self.running(id) else { return Vec::new() };
        let Some(run) = self.stations[i].run.as_mut() else { return Vec::new() };
        if run.unsaved.is_some() {
            return Vec::new();
        }
        tracing::error!(job = id, error = %error, "cannot save the checkpoint: stopping the job at the next stroke boundary");
        run.unsaved = Some(error);
        self.ask_stop(i, StopReason::Unsaved, Stop::AfterStroke)
    }

    /// Plotter `name`'s span ended: every chunk streamed and confirmed, a
    /// stop as asked (the device holds nothing of the job then), or an error.
    pub fn span_ended(&mut self, name: &str, outcome: Result<Outcome, StreamError>) -> Vec<Action> {
        let Some(i) = self.run_of(name) else { return Vec::new() };
        // A run asked to stop is not resynced after a stall: it ends there.
        let asked = self.stations[i].asked;
        let Some(run) = self.stations[i].run.as_mut() else { return Vec::new() };
        // The device stopped at a stroke boundary (the run asked it to); the
        // checkpoint in memory is where it stands.
        if let Some(e) = run.unsaved.take() {
            let ending = match outcome {
                Err(err) => Ending::Failed(err),
                Ok(_) => Ending::State(ending::unsaved(&e)),
            };
            return self.end_run(i, ending);
        }
        let acked = run.progress().bytes_acked;
        match outcome {
            Ok(Outcome::Finished) => {
                let (from, until) = run.span;
                if run.confirmed <= from && from < until {
                    run.idle_spans += 1;
                    if run.idle_spans >= 2 {
                        return self.end_run(i, Ending::Failed(StreamError::Unconfirmed { from, until }));
                    }
                } else {
                    run.idle_spans = 0;
                }
                run.resume = false;
                run.stalls = 0;
                self.next_span(i)
            }
            // The device holds nothing of the job (a stop now dropped what it
            // had not run): no write is left to locate.
            // The button of a device nobody asked to stop: a person's pause.
            Ok(Outcome::ButtonPressed) if asked == Stop::Continue => self.end_run(i, Ending::State(ending::by_button())),
            Ok(Outcome::Stopped | Outcome::ButtonPressed) => self.end_run(i, Ending::Stopped { forget_mark: true }),
            // The board lost lines it was sent: resync (the next span asks
            // for the build info first, which every stale answer precedes) and go on from
            // the confirmed chunk, once per checkpoint; a second stall
            // without progress ends the run with the error.
            Err(e @ StreamError::Stalled { .. }) if asked == Stop::Continue && (run.stalls == 0 || acked > run.stalled_at) => {
                tracing::warn!(job = run.job, error = %e, "resyncing and resuming from the checkpoint: strokes will be drawn again");
                run.stalls += 1;
                run.stalled_at = acked;
                run.resume = true;
                self.next_span(i)
            }
            Err(e) => self.end_run(i, Ending::Failed(e)),
        }
    }

    /// Plotter `name`'s head was parked for a pen change (or the link
    /// failed on the way): the job pauses for the pen.
    pub fn parked(&mut self, name: &str, result: Result<(), StreamError>) -> Vec<Action> {
        let Some(i) = self.run_of(name) else { return Vec::new() };
        match result {
            Ok(()) => self.next_span(i),
            Err(e) => self.end_run(i, Ending::Failed(e)),
        }
    }

    /// Station `i`'s next span: from the checkpoint to the next thing a
    /// person loads, or the end; or the run's end when it is there.
    fn next_span(&mut self, i: usize) -> Vec<Action> {
        let station = &mut self.stations[i];
        let device = station.config.profile.as_ref();
        let Some(run) = station.run.as_mut() else { return Vec::new() };
        let Some(tally) = &run.tally else { return Vec::new() };
        let Some(record) = self.jobs.get(&run.job).map(|e| &e.record) else { return Vec::new() };
        let total = tally.total();
        let from = run.confirmed.min(total);
        if from >= total {
            return self.end_run(i, Ending::State(JobState::Done));
        }
        let until = ending::next_load(&tally.program, from, record, run.pens_pause);
        if until == from {
            let state = ending::load(&tally.program, from, record);
            // A person's pen change: the head waits off the drawing first.
            let pen_change = matches!(state, JobState::Paused { insert_pen: Some(_), .. });
            if let (true, Some(device)) = (pen_change && run.pens_pause && !run.parked, device) {
                let at_mm = park::point(&tally.program, device);
                run.parked = true;
                return vec![Action::Park { at_mm }];
            }
            return self.end_run(i, Ending::State(state));
        }
        // What a person allowed is done once, by the run's first span.
        let restore = std::mem::take(&mut run.restore);
        run.span = (from, until);
        vec![Action::Stream { program: Arc::clone(&tally.program), from, until, resume: run.resume, lift: until < total, restore }]
    }

    /// Station `i`'s run is over, as `ending` says: the job's state saved,
    /// the mark forgotten when the device holds nothing known of it, and
    /// the port closed when the link was lost.
    pub(super) fn end_run(&mut self, i: usize, ending: Ending) -> Vec<Action> {
        let Some(run) = self.stations[i].run.as_ref() else { return Vec::new() };
        let (job, progress, confirmed) = (run.job, run.progress(), run.confirmed);
        let why = self.stations[i].why_stopped(self.shutting_down);
        let end = ending.end(job, why, &self.stations[i].config);
        let lost = end.lost.is_some();
        if end.reset {
            // Nothing was written before the program was made: nothing to undo.
            let program = self.stations[i].run.as_ref().and_then(|r| r.tally.as_ref()).map(|t| Arc::clone(&t.program));
            self.stations[i].reset_owed = self.stations[i].reset_owed.take().or(program);
        }
        let reach = self.stations[i].reach();
        self.stations[i].end_run(end.lost);
        let link_changed = self.stations[i].reach() != reach;
        // A job that waits for a person, or will never plot, is theirs to act on.
        match &end.state {
            JobState::Paused {
                cause:
                    PauseCause::Offline | PauseCause::DeviceError | PauseCause::Unsaved | PauseCause::PositionLost | PauseCause::NeedsHoming,
                reason,
                ..
            }
            | JobState::Failed { reason } => {
                tracing::warn!(job, state = end.state.name(), reason = %reason, "job stopped running");
            }
            _ => tracing::info!(job, state = end.state.name(), "job stopped running"),
        }
        let mut out = Vec::new();
        if end.forget_mark || end.state.is_final() {
            out.push(Action::ForgetWritten(job));
        }
        // The sheet first: it reads what the run drew, and is saved before
        // a next copy that waits for a fresh one.
        out.extend(self.sheet_after_run(i, job));
        if link_changed {
            out.push(Action::AnnouncePlotter(self.stations[i].name().to_owned()));
        }
        let state = end.state;
        out.extend(
            self.change(job, progress, Then::Nothing, |j| {
                // What the device confirmed, even when locating it failed.
                j.checkpoint = j.checkpoint.max(confirmed);
                sheet::after_run(j, state);
            })
            .map(Action::Save),
        );
        out.push(Action::RunEnded { lost });
        out
    }
}
