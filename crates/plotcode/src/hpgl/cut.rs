//! Cutting a submitted HP-GL file into per-stroke chunks ([`cut`]), read with
//! the crate's own [`Lexer`].
//!
//! A chunk ends where a `PU` follows pen-down drawing. The cutter follows the
//! instructions only as far as chunks need: which lift or lower the pen,
//! which are modal state worth re-sending on resume, where the pen is (`PA`,
//! `PR`, `PU`, `PD`; anything else that moves it, such as a label or an arc,
//! or user scaling, makes the position unknown until the next absolute move).
//! Plot times come from the [`Clock`], told the pen moves, the moves and the
//! line type (`LT`, with `IP` for its length) as they come.

use super::lexer::{Lexer, Token};
use crate::clock::Clock;
use crate::profile::{DeviceProfile, Protocol};
use crate::program::{rest, resume_number, Chunk, CutError, PenAt, Program};
use strokes::{DVec2, Dash};

/// Instructions whose last occurrence is device state worth re-sending on resume.
const MODAL: &[&[u8; 2]] = &[
    b"IP", b"SC", b"IW", b"RO", b"SP", b"VS", b"LT", b"SI", b"SR", b"DI", b"DR", b"CS", b"CA", b"SS", b"SA", b"DT", b"SL", b"FT", b"PT",
    b"TL", b"XT", b"YT", b"SM", b"CT", b"CP", b"FS",
];

/// Instructions that leave the pen where it is (moves are followed apart).
const STILL: &[&[u8; 2]] = &[
    b"PU", b"PD", b"PA", b"PR", b"IN", b"DF", b"SP", b"VS", b"LT", b"IW", b"IP", b"SC", b"RO", b"SI", b"SR", b"DI", b"DR", b"CS", b"CA",
    b"SS", b"SA", b"DT", b"SL", b"TL", b"PT", b"FT", b"FS", b"OA", b"OC", b"OD", b"OE", b"OF", b"OH", b"OI", b"OO", b"OP", b"OS", b"OW",
];

/// Bytes fed to the lexer at a time: it keeps what it has not consumed, so
/// small feeds keep its work linear in the file.
const FEED_BYTES: usize = 4096;

/// The resume prefix HP-GL chunks share: pen up, `IN;` when the job
/// initialised the device, the modal instructions as last given, the pen
/// position (absolute), then `PR;` when the job plots relative.
fn resume_prefix<'a>(initialised: bool, modal: impl IntoIterator<Item = &'a [u8]>, pos: DVec2, absolute: bool) -> Vec<u8> {
    let mut out = b"PU;".to_vec();
    if initialised {
        out.extend_from_slice(b"IN;");
    }
    for bytes in modal {
        let bytes = bytes.trim_ascii_end();
        out.extend_from_slice(bytes);
        if bytes.last() != Some(&b';') {
            out.push(b';');
        }
    }
    out.extend_from_slice(format!("PA;PU{},{};", resume_number(pos.x), resume_number(pos.y)).as_bytes());
    if !absolute {
        out.extend_from_slice(b"PR;");
    }
    out
}

/// The dashes of HP-GL line type `kind` with a pattern `percent` of the
/// P1-P2 diagonal long, in millimetres on paper: types 2 (50 % drawn) and
/// 3 (70 %), the ones plotd writes. `None` for the others, which the plot
/// time counts as solid, and for a pattern of no length.
pub(super) fn line_type_dash(kind: f64, percent: f64, p1p2: [DVec2; 2], unit_mm: f64) -> Option<Dash> {
    let drawn = match kind {
        2.0 => 0.5,
        3.0 => 0.7,
        _ => return None,
    };
    let period = percent / 100.0 * p1p2[0].distance(p1p2[1]) * unit_mm;
    (period > 0.0 && period.is_finite()).then_some(Dash { dash_mm: period * drawn, gap_mm: period * (1.0 - drawn) })
}

/// What decides the dashes a file's line type draws: P1 and P2, and the
/// last `LT` with a pattern (its type and length in percent).
struct LineType {
    p1p2: [DVec2; 2],
    /// P1 and P2 after `IN`. The device's own depend on the paper loaded;
    /// the default paper's hard-clip corners stand in for them.
    initial: [DVec2; 2],
    pattern: Option<(f64, f64)>,
    unit_mm: f64,
}

impl LineType {
    fn new(profile: &DeviceProfile) -> LineType {
        let paper = profile.paper_named(&profile.default_paper).expect("validated: default paper exists");
        let initial = [DVec2::new(paper.x_range[0], paper.y_range[0]), DVec2::new(paper.x_range[1], paper.y_range[1])];
        LineType { p1p2: initial, initial, pattern: None, unit_mm: profile.unit_mm }
    }

    /// Follows `IN`, `DF`, `IP` and `LT`; the dashes in force after it, or
    /// `None` for any other instruction.
    fn follow(&mut self, mnemonic: &[u8; 2], params: &[f64]) -> Option<Option<Dash>> {
        match (mnemonic, params) {
            (b"IN", _) => (self.p1p2, self.pattern) = (self.initial, None),
            (b"DF", _) | (b"LT", []) => self.pattern = None,
            // HP-GL's default pattern length is 4 % of the diagonal.
            (b"LT", [kind, rest @ ..]) => self.pattern = Some((*kind, rest.first().copied().unwrap_or(4.0))),
            (b"IP", []) => self.p1p2 = self.initial,
            // P2 follows P1.
            (b"IP", [x, y]) => {
                let p1 = DVec2::new(*x, *y);
                self.p1p2 = [p1, p1 + self.p1p2[1] - self.p1p2[0]];
            }
            (b"IP", [x1, y1, x2, y2, ..]) => self.p1p2 = [DVec2::new(*x1, *y1), DVec2::new(*x2, *y2)],
            _ => return None,
        }
        Some(self.pattern.and_then(|(kind, percent)| line_type_dash(kind, percent, self.p1p2, self.unit_mm)))
    }
}

fn err(offset: usize, message: impl Into<String>) -> CutError {
    CutError { protocol: Protocol::Hpgl, offset, message: message.into() }
}

/// The tokens of a whole text with their byte ranges.
struct Tokens<'a> {
    text: &'a [u8],
    fed: usize,
    ended: bool,
    lexer: Lexer,
}

impl Tokens<'_> {
    fn next(&mut self) -> Result<Option<(Token, usize, usize)>, CutError> {
        loop {
            match self.lexer.next_token() {
                Err(e) => return Err(err(e.offset as usize, e.kind.to_string())),
                Ok(Some(t)) => {
                    let start = match &t {
                        Token::Instruction(i) => i.offset,
                        Token::Escape(e) => e.offset,
                    } as usize;
                    return Ok(Some((t, start, self.lexer.offset() as usize)));
                }
                Ok(None) if self.fed < self.text.len() => {
                    let n = (self.text.len() - self.fed).min(FEED_BYTES);
                    self.lexer.feed(&self.text[self.fed..self.fed + n]);
                    self.fed += n;
                }
                Ok(None) if !self.ended => {
                    self.lexer.end();
                    self.ended = true;
                }
                Ok(None) => return Ok(None),
            }
        }
    }
}

/// Appends one instruction as the file wrote it, ended by `;` where the
/// file ended it by a line feed: what goes between instructions (line feeds,
/// a bare `;`, blanks, padding) is left out, as a strict device reads it as
/// an instruction it does not know (HP-GL error 1).
fn push_instruction(out: &mut Vec<u8>, instruction: &[u8]) {
    match instruction.strip_suffix(b"\n") {
        Some(body) => {
            out.extend_from_slice(body.trim_ascii_end());
            out.push(b';');
        }
        None => out.extend_from_slice(instruction),
    }
}

/// Cuts an HP-GL text into chunks for `profile`, timed by the [`Clock`] (as
/// the emitter times what it writes).
///
/// # Errors
/// [`CutError`] at the first byte that cannot be read, or at a `PU`/`PD`/
/// `PA`/`PR` with an odd number of coordinates.
pub fn cut(text: &[u8], profile: &DeviceProfile) -> Result<Program, CutError> {
    let mut clock = Clock::new(profile);
    let mut line_type = LineType::new(profile);
    let mut tokens = Tokens { text, fed: 0, ended: false, lexer: Lexer::new() };
    let mut chunks = Vec::new();
    let mut seconds = 0.0;
    // The current chunk's instructions, as written, with nothing between them.
    let mut bytes = Vec::new();
    let mut chunk_draws = false;
    // The pen the chunk draws with: an `SP` after its last stroke (as the
    // emitter writes a pen change) belongs to it, the pen to the next.
    let mut chunk_pen: Option<u32> = None;
    let mut resume = b"PU;".to_vec();
    // Device state as of the current instruction.
    let mut modal: Vec<([u8; 2], Vec<u8>)> = Vec::new();
    let mut initialised = false;
    let mut pen: Option<u32> = None;
    let mut down = false;
    let mut absolute = true;
    let mut pos = DVec2::ZERO;
    // What the device reports for the pen (OA): its position is `pos` unless
    // an instruction not followed here moved it or user units are on.
    let mut pos_known = true;
    let mut scaled = false;
    let mut pen_down = false;
    // The current chunk's rests, while every one is known.
    let mut path = Some(Vec::new());
    while let Some((token, start, end_offset)) = tokens.next()? {
        let (m, params) = match &token {
            Token::Instruction(i) => (i.mnemonic, i.params.as_slice()),
            Token::Escape(_) => {
                bytes.extend_from_slice(&text[start..end_offset]);
                rest(&mut path, pos_known && !scaled, PenAt { pos, down: pen_down, z: None });
                continue;
            }
        };
        let end = (pos_known && !scaled).then_some(PenAt { pos, down: pen_down, z: None });
        if &m == b"PU" && chunk_draws {
            chunks.push(Chunk {
                bytes: std::mem::take(&mut bytes),
                resume: std::mem::take(&mut resume),
                pen: chunk_pen,
                draws: true,
                seconds: std::mem::take(&mut seconds),
                page: 0,
                end,
                path: std::mem::replace(&mut path, end.map(|_| Vec::new())),
            });
            chunk_draws = false;
            resume = resume_prefix(initialised, modal.iter().map(|(_, b)| b.as_slice()), pos, absolute);
        }
        match &m {
            b"IN" | b"DF" => {
                modal.clear();
                initialised |= &m == b"IN";
                absolute = true;
                if &m == b"IN" {
                    down = false;
                    pen_down = false;
                    scaled = false;
                    seconds += clock.pen(false);
                }
            }
            b"SP" => {
                // The carousel lifts the pen to change it.
                pen_down = false;
                pen = match params.first() {
                    Some(&v) if v >= 1.0 => Some(v as u32),
                    _ => None,
                };
            }
            b"SC" | b"RO" => scaled = params.iter().any(|&v| v != 0.0),
            b"PA" => absolute = true,
            b"PR" => absolute = false,
            m if !STILL.contains(&m) => pos_known = false,
            _ => {}
        }
        if let Some(dash) = line_type.follow(&m, params) {
            clock.line_type(dash);
        }
        if matches!(&m, b"PU" | b"PD") {
            down = &m == b"PD";
            pen_down = down;
            seconds += clock.pen(down);
            // The pen moves up or down before the coordinates are read:
            // the device rests here when they are lost.
            rest(&mut path, pos_known && !scaled, PenAt { pos, down: pen_down, z: None });
        }
        if matches!(&m, b"PU" | b"PD" | b"PA" | b"PR") {
            if params.len() % 2 != 0 {
                return Err(err(start, format!("{}: odd number of coordinates", String::from_utf8_lossy(&m))));
            }
            for xy in params.chunks(2) {
                let to = if absolute { DVec2::new(xy[0], xy[1]) } else { pos + DVec2::new(xy[0], xy[1]) };
                seconds += clock.move_to(to, down);
                pos = to;
                pos_known |= absolute;
                if down && !chunk_draws {
                    chunk_pen = pen;
                }
                chunk_draws |= down;
                rest(&mut path, pos_known && !scaled, PenAt { pos, down: pen_down, z: None });
            }
        }
        rest(&mut path, pos_known && !scaled, PenAt { pos, down: pen_down, z: None });
        push_instruction(&mut bytes, &text[start..end_offset]);
        if MODAL.contains(&&m) {
            let bytes = text[start..end_offset].to_vec();
            match modal.iter_mut().find(|(k, _)| *k == m) {
                Some(slot) => slot.1 = bytes,
                None => modal.push((m, bytes)),
            }
        }
    }
    if !bytes.is_empty() {
        chunks.push(Chunk {
            bytes,
            resume,
            pen: if chunk_draws { chunk_pen } else { pen },
            draws: chunk_draws,
            seconds,
            page: 0,
            end: (pos_known && !scaled).then_some(PenAt { pos, down: pen_down, z: None }),
            path,
        });
    }
    Ok(Program { protocol: Protocol::Hpgl, chunks, pen_up: b"PU;".to_vec() })
}
