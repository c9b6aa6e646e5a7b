//! The bytes of one run: the resume prefix, then chunks `from..until`, each
//! followed by the handshake's marker, with where each chunk ends.

use plotcode::Program;

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
    pub from: usize,
    /// Lift the pen after the last chunk: the run ends before the program does
    /// (a pen change follows).
    pub lift: bool,
}

impl Plan {
    /// `marker` follows every chunk; `chained = (m, window)`, when given,
    /// instead follows a chunk whose successor in the run starts with a
    /// letter, which ends it (HP-GL's `OE` needs no `;` before the next
    /// mnemonic), and fits in `window` beside it. A successor that cannot
    /// share the window is written only once the marker is answered, so the
    /// marker must end on its own: a `;` written later would cost a round
    /// trip per stroke.
    pub fn new(program: &Program, from: usize, until: usize, resume: bool, marker: &[u8], chained: Option<(&[u8], usize)>) -> Plan {
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
            let m = match (chained, chunks.get(i + 1)) {
                (Some((m, window)), Some(next))
                    if next.bytes.first().is_some_and(u8::is_ascii_alphabetic)
                        && c.bytes.len() + m.len() + next.bytes.len() + marker.len() <= window =>
                {
                    m
                }
                _ => marker,
            };
            data.extend_from_slice(m);
            ends.push(data.len());
            marks.push(m.len());
            marked.push(marked[i] + m.len());
        }
        Plan { data, ends, marks, marked, from, lift: false }
    }

    /// Whether chunk `i`'s marker waits for the next chunk's first letter.
    pub fn open_marker(&self, i: usize, marker: &[u8]) -> bool {
        self.marks.get(i).is_some_and(|&m| m < marker.len())
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
