//! One run of a job on its plotter, as the job's life keeps it: the
//! program once rendered with its running sums, how far the device
//! confirmed, the stalls resynced, a checkpoint that could not be saved.
//! What a run does is `plotting.rs`.

use super::action::Progress;
use crate::spool::JobId;
use crate::stream::Restore;
use plotcode::Program;
use std::sync::Arc;

/// A run's own state.
#[derive(Debug)]
pub(super) struct Run {
    /// The job.
    pub job: JobId,
    /// The program, once rendered.
    pub(super) tally: Option<Tally>,
    /// Whether a pen change waits for a person.
    pub(super) pens_pause: bool,
    /// Chunks the device confirmed executing, as this run heard it: the
    /// saved checkpoint may lag it, never lead it.
    pub(super) confirmed: usize,
    /// The first chunk a locate looks at.
    pub(super) candidates_from: usize,
    /// The head was parked off the drawing for the pause that follows.
    pub(super) parked: bool,
    /// The next span starts with the resume prefix.
    pub(super) resume: bool,
    /// What a person's resume allowed the first span's set-up to do to a
    /// device whose position was lost.
    pub(super) restore: Restore,
    /// The chunks of the span under way, and the spans in a row that ended
    /// as finished having confirmed none of theirs.
    pub(super) span: (usize, usize),
    pub(super) idle_spans: usize,
    /// Stalls resynced in a row, and the bytes confirmed at the last one.
    pub(super) stalls: usize,
    pub(super) stalled_at: u64,
    /// Why the first checkpoint that could not be saved was not: the run
    /// stops at the next stroke boundary and the job pauses.
    pub(super) unsaved: Option<String>,
}

/// What a person takes to change the pen of a one-pen plotter once the job
/// asked (walk up, take the pen out, cap it, put the next one in, confirm
/// with `pen-changed`), seconds: added to a job's estimate per change.
pub const PEN_CHANGE_S: f64 = 30.0;

/// A program and the running sums progress is told in.
#[derive(Debug)]
pub(super) struct Tally {
    pub(super) program: Arc<Program>,
    /// `acked[k]`: bytes of chunks `..k`.
    pub(super) acked: Vec<u64>,
    /// `drawn[k]`: strokes among chunks `..k` (chunks that draw: the job's
    /// tail and pen changes are chunks too, but no strokes).
    pub(super) drawn: Vec<usize>,
    /// `changes[k]`: the pen changes a person makes from chunk `k` on
    /// (none where the plotter changes its own pens).
    pub(super) changes: Vec<usize>,
}

impl Tally {
    pub(super) fn new(program: Program) -> Tally {
        let mut acked = vec![0u64; program.chunks.len() + 1];
        let mut drawn = vec![0usize; program.chunks.len() + 1];
        for (i, c) in program.chunks.iter().enumerate() {
            acked[i + 1] = acked[i] + c.bytes.len() as u64;
            drawn[i + 1] = drawn[i] + usize::from(c.draws);
        }
        let changes = vec![0usize; program.chunks.len() + 1];
        Tally { program: Arc::new(program), acked, drawn, changes }
    }

    /// Counts the changes a person makes, `loaded` the pen in at the start:
    /// each drawing chunk whose pen is not the one before it.
    pub(super) fn count_changes(&mut self, loaded: Option<u32>) {
        let mut pen = loaded;
        let mut at = vec![0usize; self.changes.len()];
        for (i, c) in self.program.chunks.iter().enumerate() {
            if c.draws && c.pen.is_some() {
                at[i] = usize::from(pen.is_some() && c.pen != pen);
                pen = c.pen;
            }
        }
        for i in (0..self.program.chunks.len()).rev() {
            self.changes[i] = self.changes[i + 1] + at[i];
        }
    }

    pub(super) fn total(&self) -> usize {
        self.program.chunks.len()
    }

    /// Progress with chunks `..k` confirmed.
    pub(super) fn progress(&self, k: usize) -> Progress {
        let k = k.min(self.total());
        #[allow(clippy::cast_precision_loss)] // a count of pen changes
        let changing = self.changes[k] as f64 * PEN_CHANGE_S;
        Progress { bytes_acked: self.acked[k], eta_s: Some(self.program.seconds_from(k) + changing) }
    }

    /// Strokes among chunks `..k`.
    pub(super) fn strokes(&self, k: usize) -> usize {
        self.drawn[k.min(self.total())]
    }
}

impl Run {
    pub fn new(job: JobId) -> Run {
        Run {
            job,
            tally: None,
            pens_pause: false,
            confirmed: 0,
            span: (0, 0),
            idle_spans: 0,
            candidates_from: 0,
            parked: false,
            resume: false,
            restore: Restore::Nothing,
            stalls: 0,
            stalled_at: 0,
            unsaved: None,
        }
    }

    /// The run's progress as far as the device confirmed.
    pub(super) fn progress(&self) -> Progress {
        self.tally.as_ref().map_or_else(Progress::default, |t| t.progress(self.confirmed))
    }
}
