//! Turning the carriage's motion into the record's strokes.
//!
//! The record gets a vertex wherever the path can bend: at the end of every
//! motion command, where one axis finishes before the other, where an axis
//! reverses (3.0.2 LM/LT), where the pen touches or leaves the paper, and
//! where motion stops (ES, power loss). Between two vertices the path is
//! straight to within a step for moves whose axes run in proportion (SM, XM,
//! HM, and LM blocks as planners make them). A pen that comes down and goes
//! up without moving leaves a dot; the pen resting on the paper at power-on
//! does not.

use super::motors::mm;
use crate::record::Record;

/// The pen the record files EBB strokes under (the board has one).
const PEN: u32 = 1;

#[derive(Clone, Debug)]
pub(crate) struct Trace {
    on_paper: bool,
    /// The shaft positions where the open segment starts.
    from: [i64; 2],
    /// Something was drawn since the pen came down (no dot needed).
    drawn: bool,
    /// Direction of each axis's last step in this command.
    last_dir: [i8; 2],
}

impl Trace {
    pub fn new(on_paper: bool, shaft: [i64; 2]) -> Trace {
        Trace { on_paper, from: shaft, drawn: true, last_dir: [0; 2] }
    }

    /// Ends the open segment here (a corner).
    pub fn vertex(&mut self, shaft: [i64; 2], record: &mut Record) {
        if self.on_paper && shaft != self.from {
            record.segment(PEN, mm(self.from), mm(shaft));
            self.drawn = true;
        }
        self.from = shaft;
    }

    /// A step is about to move an axis: a reversal is a corner.
    pub fn before_step(&mut self, shaft: [i64; 2], axis: usize, dir: i8, record: &mut Record) {
        if self.last_dir[axis] != 0 && self.last_dir[axis] != dir {
            self.vertex(shaft, record);
        }
        self.last_dir[axis] = dir;
    }

    /// A command ended or an axis finished: a corner, and directions start afresh.
    pub fn boundary(&mut self, shaft: [i64; 2], record: &mut Record) {
        self.vertex(shaft, record);
        self.last_dir = [0; 2];
    }

    /// The pen touches or leaves the paper at `shaft`.
    pub fn contact(&mut self, on: bool, shaft: [i64; 2], record: &mut Record) {
        if on == self.on_paper {
            return;
        }
        if on {
            self.on_paper = true;
            self.from = shaft;
            self.drawn = false;
        } else {
            self.vertex(shaft, record);
            if !self.drawn {
                record.segment(PEN, mm(shaft), mm(shaft));
            }
            self.on_paper = false;
            record.lift();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn corners_and_dots() {
        let mut r = Record::default();
        let mut t = Trace::new(true, [0, 0]);
        // Resting on the paper at power-on, lifted without moving: no dot.
        t.contact(false, [0, 0], &mut r);
        assert!(r.strokes.is_empty());
        t.contact(true, [160, 0], &mut r);
        t.boundary([320, 0], &mut r);
        t.before_step([320, 0], 0, 1, &mut r);
        t.before_step([400, 0], 0, -1, &mut r);
        t.contact(false, [240, 0], &mut r);
        assert_eq!(r.strokes.len(), 1);
        assert_eq!(r.strokes[0].points, vec![[1.0, -1.0], [2.0, -2.0], [2.5, -2.5], [1.5, -1.5]]);
        // Down and up in place: a dot.
        t.contact(true, [0, 0], &mut r);
        t.contact(false, [0, 0], &mut r);
        assert_eq!(r.strokes[1].points, vec![[0.0, 0.0], [0.0, 0.0]]);
    }
}
