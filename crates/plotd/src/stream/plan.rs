//! What one run streams ([`Span`]: which chunks of which program, how it
//! starts and ends), and its bytes ([`Plan`]): the resume prefix, then the
//! chunks, each followed by the protocol's [`Marker`], with where each
//! chunk ends.

use plotcode::control::Marker;
use plotcode::Program;

/// What one run streams: chunks `from..until` of `program`.
#[derive(Clone, Copy, Debug)]
pub struct Span<'a> {
    /// The job.
    pub program: &'a Program,
    /// The first chunk.
    pub from: usize,
    /// The chunk after the last one (a pen change or the program's end).
    pub until: usize,
    /// First give the device the state it had at chunk `from` (pen up,
    /// modal state, position): the run goes on after an interruption.
    pub resume: bool,
    /// Lift the pen after the last chunk: the run ends before the program
    /// does (a pen change follows).
    pub lift: bool,
    /// A person confirmed the pen at the program's home after the device
    /// lost its position: an EiBotBoard (no home switches) enables its
    /// motors there first, which makes it home.
    pub home_here: bool,
}

impl<'a> Span<'a> {
    /// Every chunk of `program`, from the start.
    #[must_use]
    pub fn all(program: &'a Program) -> Span<'a> {
        Span { program, from: 0, until: program.chunks.len(), resume: false, lift: false, home_here: false }
    }

    /// The same run with `until` and `from` inside the program.
    #[must_use]
    pub fn clamped(self) -> Span<'a> {
        let until = self.until.min(self.program.chunks.len());
        Span { until, from: self.from.min(until), ..self }
    }
}

/// The bytes of a run: an optional resume prefix, then the chunks, with each
/// chunk's end offset.
#[derive(Debug)]
pub(super) struct Plan {
    pub data: Vec<u8>,
    /// `ends[i]`: offset in `data` just past chunk `from + i` (and its marker).
    pub ends: Vec<usize>,
    /// `marks[i]`: length of chunk `from + i`'s marker.
    pub marks: Vec<usize>,
    /// `marked[i]`: marker bytes in chunks `from..from + i`.
    pub marked: Vec<usize>,
    /// The marker after each chunk.
    pub marker: Marker,
    /// `seconds[i]`: chunk `from + i`'s estimated plot time (the plot-time
    /// model's), what a device may take before answering its marker.
    pub seconds: Vec<f64>,
    pub from: usize,
    /// Lift the pen after the last chunk: the run ends before the program does
    /// (a pen change follows).
    pub lift: bool,
}

impl Plan {
    /// The bytes of `span`, clamped to its program (see
    /// [`Span::clamped`]). `marker` follows every chunk; with a `window`,
    /// its chained form instead follows a chunk whose successor in the run
    /// ends it ([`Marker::chained_before`]) and fits in `window` beside it.
    /// A successor that cannot share the window is written only once the
    /// marker is answered, so the marker must end on its own: a `;` written
    /// later would cost a round trip per stroke.
    pub fn new(span: Span<'_>, marker: Marker, window: Option<usize>) -> Plan {
        let Span { program, from, until, resume, lift, .. } = span.clamped();
        let mut data = Vec::new();
        if resume {
            if let Some(c) = program.chunks.get(from) {
                data.extend_from_slice(&c.resume);
            }
        }
        let (mut ends, mut marks, mut marked) = (Vec::new(), Vec::new(), vec![0]);
        let chunks = &program.chunks[from..until];
        for (i, c) in chunks.iter().enumerate() {
            data.extend_from_slice(&c.bytes);
            let chained = chunks.get(i + 1).zip(window).and_then(|(next, window)| {
                let m = marker.chained_before(&next.bytes)?;
                (c.bytes.len() + m.len() + next.bytes.len() + marker.bytes.len() <= window).then_some(m)
            });
            let m = chained.unwrap_or(marker.bytes);
            data.extend_from_slice(m);
            ends.push(data.len());
            marks.push(m.len());
            marked.push(marked[i] + m.len());
        }
        let seconds = chunks.iter().map(|c| c.seconds).collect();
        Plan { data, ends, marks, marked, marker, seconds, from, lift }
    }

    /// Whether chunk `i`'s marker waits for the next chunk's first letter.
    pub fn open_marker(&self, i: usize) -> bool {
        self.marks.get(i).is_some_and(|&m| m < self.marker.bytes.len())
    }

    /// Bytes of `data[..x]` that are job bytes, not markers.
    pub fn payload(&self, x: usize) -> usize {
        let full = self.ends.partition_point(|&e| e <= x);
        let partial = self.ends.get(full).map_or(0, |&e| x.saturating_sub(e - self.marks[full]));
        x - self.marked[full] - partial
    }

    /// Where writing must stop: the end, or on a stop request the end of the
    /// chunk being written.
    pub fn limit(&self, sent: usize, stopping: bool) -> usize {
        if !stopping {
            return self.data.len();
        }
        if sent == 0 {
            return 0;
        }
        self.ends.iter().copied().find(|&e| e >= sent).unwrap_or(self.data.len())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use plotcode::control::hpgl;

    fn hpgl_plan(text: &str, window: usize) -> Plan {
        let program = plotcode::cut(text.as_bytes(), &plotcode::DeviceProfile::builtin("hp7475a").unwrap()).unwrap();
        Plan::new(Span::all(&program), hpgl::MARKER, Some(window))
    }

    #[test]
    fn an_open_marker_only_before_a_stroke_that_can_share_the_window() {
        // Three 16-byte strokes: the first two markers are ended by the next
        // stroke's `PU`, the last by its own `;`.
        let short = "IN;SP1;PU0,0;PD10,10;PU20,0;PD30,10;PU40,0;PD50,10;";
        let plan = hpgl_plan(short, 256);
        assert_eq!(plan.marks.len(), 3, "{short}");
        assert_eq!(plan.marks, [2, 2, 3]);
        // The same strokes in a window one byte too small for any two
        // neighbours with their markers: every marker ends itself, or each
        // stroke would wait a round trip for its `;`.
        let len = |i: usize| plan.ends[i] - if i == 0 { 0 } else { plan.ends[i - 1] } - plan.marks[i];
        let tightest = (0..2).map(|i| len(i) + len(i + 1)).min().unwrap();
        let fits = |window| hpgl_plan(short, window).marks;
        assert_eq!(fits(tightest + 4), [3, 3, 3]);
        assert_eq!(hpgl_plan(short, tightest + 4).marked, [0, 3, 6, 9]);
        assert_ne!(fits(tightest + 5), [3, 3, 3]);
    }
}
