//! A job's drawing for the page's preview: the program the daemon cut,
//! chunk by chunk, as the lines each one draws and where it leaves the pen,
//! in millimetres. The page colours the chunks before the job's checkpoint
//! as drawn and puts its pen marker at the end of the last of them: only
//! what the device confirmed, never a guess of where the pen is now.

use plotcode::{DeviceProfile, PenAt, Program};
use serde::Serialize;

/// The preview of one job.
#[derive(Debug, PartialEq, Serialize)]
pub struct Drawing {
    /// The job.
    pub job: u64,
    /// Whether y grows upwards on the device (HP-GL): the page flips it.
    pub y_up: bool,
    /// The smallest box around every point, mm: `[x0, y0, x1, y1]`.
    pub bounds: [f64; 4],
    /// The program's chunks, in order: the checkpoint counts them.
    pub chunks: Vec<ChunkLines>,
}

/// What one chunk draws.
#[derive(Debug, PartialEq, Serialize)]
pub struct ChunkLines {
    /// The sheet it draws on (an animation's frame).
    pub page: usize,
    /// The polylines drawn with the pen down, mm.
    pub lines: Vec<Vec<[f64; 2]>>,
    /// Where the chunk leaves the pen, mm, when that is known.
    pub end: Option<[f64; 2]>,
}

/// The drawing of job `job`'s `program` for `device`.
#[must_use]
pub fn of(job: u64, program: &Program, device: &DeviceProfile) -> Drawing {
    let mm = |p: &PenAt| [p.pos.x * device.unit_mm, p.pos.y * device.unit_mm];
    let mut bounds = [f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY];
    let mut grow = |[x, y]: [f64; 2]| {
        bounds = [bounds[0].min(x), bounds[1].min(y), bounds[2].max(x), bounds[3].max(y)];
    };
    // Where the pen is between chunks: a chunk's first move starts there.
    let mut at: Option<PenAt> = None;
    let mut chunks = Vec::with_capacity(program.chunks.len());
    for chunk in &program.chunks {
        let mut lines: Vec<Vec<[f64; 2]>> = Vec::new();
        let rests = chunk.path.as_deref().unwrap_or_default();
        for p in rests {
            grow(mm(p));
            // A move is drawn when the pen is down at both its ends.
            match at {
                Some(prev) if prev.down && p.down && prev.pos != p.pos => {
                    let continues = lines.last().and_then(|l| l.last()).is_some_and(|last| *last == mm(&prev));
                    if !continues {
                        lines.push(vec![mm(&prev)]);
                    }
                    lines.last_mut().expect("a line").push(mm(p));
                }
                _ => {}
            }
            at = Some(*p);
        }
        // A chunk whose path cannot be followed leaves the pen where its end says.
        if chunk.path.is_none() {
            at = chunk.end;
        }
        let end = chunk.end.as_ref().map(mm);
        if let Some(e) = end {
            grow(e);
        }
        chunks.push(ChunkLines { page: chunk.page, lines, end });
    }
    if bounds[0] > bounds[2] {
        bounds = [0.0; 4];
    }
    Drawing { job, y_up: device.y_up, bounds, chunks }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_chunk_its_lines_and_its_end_in_mm() {
        let device = DeviceProfile::builtin("hp7475a").unwrap();
        // Two strokes: an L, then one segment, in HP-GL units (about 0.025 mm).
        let text = b"IN;SP1;PU0,0;PD400,0,400,800;PU1200,0;PD1200,400;PU;SP0;";
        let program = plotcode::cut(text, &device).unwrap();
        let d = of(7, &program, &device);
        let u = device.unit_mm;
        assert!(d.y_up && (u - 0.025).abs() < 0.001, "{u}");
        assert_eq!(d.bounds, [0.0, 0.0, 1200.0 * u, 800.0 * u]);
        let drawn: Vec<&Vec<[f64; 2]>> = d.chunks.iter().flat_map(|c| &c.lines).collect();
        assert_eq!(drawn, [&vec![[0.0, 0.0], [400.0 * u, 0.0], [400.0 * u, 800.0 * u]], &vec![[1200.0 * u, 0.0], [1200.0 * u, 400.0 * u]]]);
        // The marker after the first drawing chunk: the L's last corner.
        let first = d.chunks.iter().position(|c| !c.lines.is_empty()).unwrap();
        assert_eq!(d.chunks[first].end, Some([400.0 * u, 800.0 * u]));
        assert_eq!(d.chunks.len(), program.chunks.len());
    }
}
