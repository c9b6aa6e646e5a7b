//! A job as a plotter runs it: the device's bytes cut into per-stroke chunks.
//!
//! A [`Program`] is what a daemon streams and checkpoints. Each [`Chunk`] is
//! one stroke's worth of bytes (the pen-up move to the stroke, the stroke, and
//! whatever follows it before the next stroke's move, such as a pen change),
//! with what a streamer needs to resume after an interruption: the *resume
//! prefix* (the bytes that put a device that lost its state back where it was
//! when the chunk starts: pen up, modal state such as `IN`/`SP`/`VS` or
//! `G21`/`G90`/`F`, the pen position), where the chunk leaves the pen and
//! every place it may rest on the way, its pen, its page and its plot time.
//!
//! Programs come from [`crate::cut`], which cuts an HP-GL or G-code file
//! with the crate's own lexer and line parser: a submitted one, or the text
//! an emitter wrote for a job. **The chunks of a program, concatenated, are
//! exactly the bytes of the file it was made from** (G-code less comments,
//! blank lines and program pauses; HP-GL less what lies between
//! instructions: line feeds, a bare `;`, blanks, which a strict device
//! reads as an unknown instruction). Chunk seconds come from the same plot-time
//! model the emitters' estimate does, so for an emitted file they add up to
//! its [`crate::Emitted::stats`].

use crate::profile::Protocol;
use strokes::DVec2;

/// One stroke's worth of device commands.
#[derive(Clone, Debug, PartialEq)]
pub struct Chunk {
    /// The commands, exactly as they go to the device.
    pub bytes: Vec<u8>,
    /// Bytes that restore the device state at this chunk's start after an
    /// interruption: pen up, modal state, pen position.
    pub resume: Vec<u8>,
    /// Pen selected while this chunk draws (`None`: no pen, or not known).
    pub pen: Option<u32>,
    /// Whether the chunk lowers the pen and draws.
    pub draws: bool,
    /// Estimated plot time of this chunk, seconds.
    pub seconds: f64,
    /// The sheet of paper it draws on: the frame of an animation plotted as
    /// consecutive pages (0 for a single drawing).
    pub page: usize,
    /// Where the chunk leaves the pen, when that is known (`None` after
    /// instructions whose motion is not followed, such as labels or arcs, or
    /// under user scaling).
    pub end: Option<PenAt>,
    /// Every place the device can leave the pen at rest while it runs this
    /// chunk (after each move, each pen lift or drop), in order, `end` last;
    /// `None` when it cannot all be followed. After an interruption it tells
    /// a stroke the device stopped inside from one it finished.
    pub path: Option<Vec<PenAt>>,
}

/// A pen position and state, in device units (HP-GL plotter units; G-code
/// millimetres).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PenAt {
    /// Position.
    pub pos: DVec2,
    /// Whether the pen is down: HP-GL `PD`; G-code the spindle on with a
    /// speed above 0 (`M3 S1000`: a pen on a servo).
    pub down: bool,
    /// G-code: the Z position the job last set (a pen on a Z axis); `None`
    /// before it sets one, and for HP-GL.
    pub z: Option<f64>,
}

/// A job ready to stream: chunks in order.
#[derive(Clone, Debug, PartialEq)]
pub struct Program {
    /// The protocol of every chunk.
    pub protocol: Protocol,
    /// Chunks in plotting order.
    pub chunks: Vec<Chunk>,
    /// Bytes that lift the pen (HP-GL `PU;`, G-code the job's own pen-up lines).
    pub pen_up: Vec<u8>,
}

impl Program {
    /// One program plotting `pages` one after the other, each on its own
    /// sheet: chunks keep their bytes and resume prefixes (each page's text
    /// starts by setting the device up) and are numbered with their page.
    /// `None` for no pages.
    #[must_use]
    pub fn paged(pages: Vec<Program>) -> Option<Program> {
        let mut pages = pages.into_iter().enumerate();
        let (_, mut out) = pages.next()?;
        for (k, page) in pages {
            out.chunks.extend(page.chunks.into_iter().map(|c| Chunk { page: k, ..c }));
        }
        Some(out)
    }

    /// Number of pages (sheets of paper).
    #[must_use]
    pub fn page_count(&self) -> usize {
        self.chunks.last().map_or(1, |c| c.page + 1)
    }

    /// Estimated seconds to plot chunks `from..`.
    #[must_use]
    pub fn seconds_from(&self, from: usize) -> f64 {
        self.chunks.iter().skip(from).map(|c| c.seconds).sum()
    }

    /// Total bytes of all chunks.
    #[must_use]
    pub fn len_bytes(&self) -> usize {
        self.chunks.iter().map(|c| c.bytes.len()).sum()
    }

    /// The box the pen draws in, device units (`min`, `max`): every point
    /// it rests at with the pen down, and where each stroke begins. `None`
    /// when nothing is drawn, or a chunk that draws cannot be followed
    /// (labels, arcs, user scaling: its `path` is `None`).
    #[must_use]
    pub fn inked_bounds(&self) -> Option<(DVec2, DVec2)> {
        let mut bounds: Option<(DVec2, DVec2)> = None;
        let mut add = |p: DVec2| bounds = Some(bounds.map_or((p, p), |(lo, hi)| (lo.min(p), hi.max(p))));
        let mut before: Option<PenAt> = None;
        for c in &self.chunks {
            let Some(path) = &c.path else {
                if c.draws {
                    return None;
                }
                before = c.end;
                continue;
            };
            for &at in path {
                if at.down {
                    add(at.pos);
                    if let Some(b) = before.filter(|b| !b.down) {
                        add(b.pos);
                    }
                }
                before = Some(at);
            }
        }
        bounds
    }

    /// Every chunk's bytes, in order: the file the program was made from.
    #[must_use]
    pub fn bytes(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(self.len_bytes());
        for c in &self.chunks {
            out.extend_from_slice(&c.bytes);
        }
        out
    }
}

/// Why a submitted command text could not be cut into chunks.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{protocol} byte {offset}: {message}")]
pub struct CutError {
    /// The language being read.
    pub protocol: Protocol,
    /// Byte offset into the submitted text.
    pub offset: usize,
    /// What is wrong there.
    pub message: String,
}

/// Accumulates a chunk's rests (its `path`), which stays `None` once a rest is
/// not known.
pub(crate) fn rest(path: &mut Option<Vec<PenAt>>, known: bool, at: PenAt) {
    match path {
        Some(p) if known => {
            if p.last() != Some(&at) {
                p.push(at);
            }
        }
        _ => *path = None,
    }
}

/// A number as HP-GL and G-code resume prefixes write it: whole numbers
/// without a point, others with at most four decimals.
pub(crate) fn resume_number(v: f64) -> String {
    if v.fract() == 0.0 && v.abs() < 1e15 {
        format!("{}", v as i64)
    } else {
        let s = format!("{v:.4}");
        s.trim_end_matches('0').trim_end_matches('.').to_owned()
    }
}

#[cfg(test)]
mod tests {
    use crate::profile::DeviceProfile;
    use strokes::DVec2;

    /// Where strokes begin and every pen-down rest count; travel before,
    /// between and after them does not.
    #[test]
    fn the_inked_box_holds_the_strokes_and_nothing_of_the_travel() {
        let hp = DeviceProfile::builtin("hp7475a").unwrap();
        let p = crate::cut(b"IN;SP1;PU100,100;PD400,100,400,300;PU9000,50;PD9000,60;PU0,0;SP0;", &hp).unwrap();
        assert_eq!(p.inked_bounds(), Some((DVec2::new(100.0, 50.0), DVec2::new(9000.0, 300.0))));
        let g = DeviceProfile::builtin("grbl-servo").unwrap();
        let p = crate::cut(b"G21 G90\nM5\nG0 X10 Y20\nM3 S1000\nG1 X30 Y25 F3000\nM5\nG0 X0 Y0\n", &g).unwrap();
        assert_eq!(p.inked_bounds(), Some((DVec2::new(10.0, 20.0), DVec2::new(30.0, 25.0))));
        let nothing = crate::cut(b"IN;PU100,100;PU0,0;", &hp).unwrap();
        assert_eq!(nothing.inked_bounds(), None);
    }
}
