//! Finding how far the device got after an interruption, from where its
//! pen rests: the rule that turns a resting place into the chunk to resume
//! from ([`first_match`]). Asking the device where it rests is the locate
//! machines' part (`hpgl_locate.rs`, `grbl_locate.rs`).

use super::Written;
use plotcode::{PenAt, Program};
use strokes::DVec2;

/// Largest difference, in device units, between where the device says its
/// pen is and where a chunk leaves it, for the two to agree: HP-GL `OA`
/// answers whole plotter units, and chunk ends may be fractional.
pub(super) const POSITION_TOLERANCE: f64 = 1.0;
/// The same for G-code, in millimetres: GRBL reports three decimals.
pub(super) const GCODE_POSITION_TOLERANCE: f64 = 0.01;

/// Where the device says its pen is at rest.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Rest {
    pub pos: DVec2,
    /// Whether the pen is down, when the device tells.
    pub down: Option<bool>,
    /// G-code: the Z position (compared when the job set one).
    pub z: Option<f64>,
    /// Largest difference per axis for a position to agree with it.
    pub tolerance: f64,
}

impl Rest {
    fn is(&self, p: &PenAt) -> bool {
        (p.pos - self.pos).abs().max_element() <= self.tolerance
            && self.down.is_none_or(|d| d == p.down)
            && p.z.is_none_or(|z| self.z.is_some_and(|at| (at - z).abs() <= self.tolerance))
    }
}

/// The chunk to resume from when the device, which ran whatever it received
/// of what `mark` says was written, has its pen at `rest`: going through the
/// chunks from `checkpoint` on in the order the device runs them, the first
/// place that agrees. Where chunk `i` leaves the pen: chunks `..=i` drawn,
/// resume at `i + 1`; a place before that in chunk `i`: it stopped inside,
/// resume at `i` (drawn again). The first, so that when several agree no
/// chunk is skipped that was not provably drawn. `None` when none agrees, or
/// a chunk is reached whose moves are not known.
pub(super) fn first_match(program: &Program, checkpoint: usize, mark: Written, rest: &Rest) -> Option<usize> {
    let chunks = &program.chunks;
    let written = mark.reached().min(chunks.len());
    if let Some(before) = checkpoint.checked_sub(1) {
        if rest.is(chunks.get(before)?.end.as_ref()?) {
            return Some(checkpoint);
        }
    }
    for (i, c) in chunks.iter().enumerate().take(written).skip(checkpoint) {
        let end = c.end?;
        let path = c.path.as_deref()?;
        if path.strip_suffix(&[end]).unwrap_or(path).iter().any(|p| rest.is(p)) {
            return Some(i);
        }
        if rest.is(&end) {
            return Some(i + 1);
        }
    }
    None
}
