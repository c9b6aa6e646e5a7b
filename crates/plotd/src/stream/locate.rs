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

#[cfg(test)]
mod tests {
    use super::super::grbl::GrblRun;
    use super::super::grbl_locate::GrblLocate;
    use super::super::machine::testing::{timing, Exchange};
    use super::super::plan::{Plan, Span};
    use super::*;
    use plotcode::control::grbl::MARKER;

    /// Four strokes on a servo pen; strokes 1 and 2 both pass (10, 10), the
    /// way neighbouring lattice strokes share a vertex.
    const GCODE: &str = "G21 G90\n\
        G0 X0 Y0\nM3 S1000\nG1 X10 Y0 F3000\nM5\n\
        G0 X0 Y10\nM3 S1000\nG1 X10 Y10 F3000\nG1 X20 Y10\nM5\n\
        G0 X10 Y0\nM3 S1000\nG1 X10 Y10 F3000\nG1 X10 Y20\nM5\n\
        G0 X30 Y0\nM3 S1000\nG1 X30 Y10 F3000\nM5\n";

    fn program() -> Program {
        plotcode::cut(GCODE.as_bytes(), &plotcode::DeviceProfile::builtin("grbl-servo").unwrap()).unwrap()
    }

    /// Streams with `rx` bytes of receive buffer, answering `ok` line by
    /// line, until the run has written chunk 2 as far as its move to
    /// (10, 10) and no further, chunk 1's marker answered. Returns the run's
    /// last confirmation and written mark: what a SIGKILL leaves.
    fn kill_inside_chunk_2() -> (usize, Written) {
        let g4p0_answered = true;
        let program = program();
        let plan = Plan::new(Span::all(&program), MARKER, None);
        // Room for chunk 2's lines up to the move to (10, 10), and for
        // chunk 1's marker beside them while its answer is due.
        let head = "G0 X10 Y0\nM3 S1000\nG4 P0.15\nG1 X10 Y10 F3000\n".len();
        let rx = if g4p0_answered { head } else { head + MARKER.bytes.len() };
        let mut x = Exchange::new(GrblRun::new(plan, rx, program.pen_up.clone(), timing(), std::time::Instant::now()));
        let mut answered = 0;
        loop {
            x.poll().unwrap();
            let text = String::from_utf8_lossy(&x.written).into_owned();
            let lines: Vec<&str> = text.lines().collect();
            let marker = String::from_utf8_lossy(MARKER.bytes);
            let marker_1 = lines.iter().enumerate().filter(|(_, l)| **l == marker.trim_end()).nth(1).map(|(i, _)| i);
            if text.contains("G0 X10 Y0") && lines.last() == Some(&"G1 X10 Y10 F3000") {
                let marker_1 = marker_1.expect("chunk 1's marker written before chunk 2");
                if (answered > marker_1) == g4p0_answered {
                    assert!(!text.contains("G1 X10 Y20"), "{text}");
                    return (x.confirmed, *x.marks.last().unwrap());
                }
            }
            assert!(answered < lines.len(), "the run waits for nothing: {text}");
            x.answer("ok").unwrap();
            answered += 1;
        }
    }

    /// Where the board rests after running every line it held: GRBL's
    /// answers after a restart, the `ok`s nobody read first.
    fn board_at_10_10() -> Rest {
        let mut x = Exchange::new(GrblLocate::new(timing(), 128));
        x.poll().unwrap();
        for line in ["ok", "ok", "ok", "ok", "[VER:1.1h.20190825:]", "[OPT:V,15,128]", "ok", "<Idle|MPos:10.000,10.000,0.000|FS:0,0>"] {
            assert_eq!(x.answer(line).unwrap(), None, "{line}");
        }
        x.answer("[GC:G1 G54 G17 G21 G90 G94 M3 M9 T0 F3000 S1000]").unwrap();
        x.answer("ok").unwrap().expect("over").expect("located")
    }

    /// The GRBL SIGKILL case that drew two strokes again (issue #15): the
    /// daemon knew chunk 0 confirmed and chunk 2 written into; the board
    /// drew the rest of stroke 1 and the start of stroke 2, and rested at
    /// (10, 10) with the pen down: a place stroke 1 passes too. Whether
    /// stroke 1 was finished is not known, so the first place decides
    /// (docs/protocol.md, "Where plotting resumes"): stroke 1 is drawn
    /// again, and stroke 2, interrupted; no stroke is skipped. (The GRBL
    /// run now writes a stroke only once the dwell before it is answered,
    /// so it confirms stroke 1 first; the rule stands for every device.)
    #[test]
    fn a_place_two_strokes_share_resumes_at_the_first_when_it_is_not_confirmed() {
        let program = program();
        assert_eq!(program.chunks.len(), 4);
        assert_eq!(first_match(&program, 1, Written::Into(2), &board_at_10_10()), Some(1));
    }

    /// The same kill after the dwell's `ok` came: stroke 1 is confirmed,
    /// the candidates start after it, and only the interrupted stroke is
    /// drawn again. The daemon keeps this confirmation in the written log at
    /// once, as the run hears it; the job's saved checkpoint (fsynced on a
    /// task of its own) may still say 1, and resuming from that drew stroke
    /// 1 again too.
    #[test]
    fn a_place_two_strokes_share_is_the_later_once_the_earlier_is_confirmed() {
        let program = program();
        let (confirmed, mark) = kill_inside_chunk_2();
        assert_eq!((confirmed, mark), (2, Written::Into(2)));
        assert_eq!(first_match(&program, confirmed, mark, &board_at_10_10()), Some(2));
        assert_eq!(first_match(&program, 1, mark, &board_at_10_10()), Some(1), "from the saved checkpoint");
    }
}
