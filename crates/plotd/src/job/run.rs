//! One run of a job on its plotter, as the job's life keeps it: the
//! program once rendered with its running sums, how far the device
//! confirmed, the stalls resynced, a checkpoint that could not be saved.
//! What a run does is `plotting.rs`.

use super::action::Progress;
use crate::spool::JobId;
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
    /// The next span starts with the resume prefix.
    pub(super) resume: bool,
    /// The next span starts by telling the device the pen is at the origin
    /// (a person confirmed it after the position was lost).
    pub(super) home_here: bool,
    /// Stalls resynced in a row, and the bytes confirmed at the last one.
    pub(super) stalls: usize,
    pub(super) stalled_at: u64,
    /// Why the first checkpoint that could not be saved was not: the run
    /// stops at the next stroke boundary and the job pauses.
    pub(super) unsaved: Option<String>,
}

/// A program and the running sums progress is told in.
#[derive(Debug)]
pub(super) struct Tally {
    pub(super) program: Arc<Program>,
    /// `acked[k]`: bytes of chunks `..k`.
    pub(super) acked: Vec<u64>,
    /// `drawn[k]`: strokes among chunks `..k` (chunks that draw: the job's
    /// tail and pen changes are chunks too, but no strokes).
    pub(super) drawn: Vec<usize>,
}

impl Tally {
    pub(super) fn new(program: Program) -> Tally {
        let mut acked = vec![0u64; program.chunks.len() + 1];
        let mut drawn = vec![0usize; program.chunks.len() + 1];
        for (i, c) in program.chunks.iter().enumerate() {
            acked[i + 1] = acked[i] + c.bytes.len() as u64;
            drawn[i + 1] = drawn[i] + usize::from(c.draws);
        }
        Tally { program: Arc::new(program), acked, drawn }
    }

    pub(super) fn total(&self) -> usize {
        self.program.chunks.len()
    }

    /// Progress with chunks `..k` confirmed.
    pub(super) fn progress(&self, k: usize) -> Progress {
        Progress { bytes_acked: self.acked[k.min(self.total())], eta_s: Some(self.program.seconds_from(k)) }
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
            candidates_from: 0,
            resume: false,
            home_here: false,
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
