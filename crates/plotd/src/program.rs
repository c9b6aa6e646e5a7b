//! A job's unit of work: the device's commands cut into per-stroke chunks.
//!
//! Whatever a client submits (a scene, HP-GL, G-code, SVG) becomes one command
//! text for the target device, and that text is cut here at stroke boundaries:
//! a chunk starts with the pen-up move to a stroke and ends with the stroke's
//! last pen-down move. A checkpoint is an index into the chunk list. With each
//! chunk goes a *resume prefix*: the bytes that put a device that lost its
//! state back where it was when the chunk starts (pen up, the modal state such
//! as `IN`/`SP`/`VS` or `G90`/`G21`/`F`, the pen position), so plotting can go
//! on from any confirmed chunk.
//!
//! The cutting reads the command stream only as far as it needs to: which
//! instruction lifts or lowers the pen, which ones are modal state, where the
//! pen is. Anything it cannot read is an error naming the byte offset.

use crate::device::{Device, Language};
use strokes::DVec2;
use thiserror::Error;

/// Longest instruction (parameters included) accepted; HP-GL labels count.
pub const MAX_INSTRUCTION_BYTES: usize = 64 * 1024;

/// Why a command text could not be cut into chunks.
#[derive(Debug, Error, PartialEq)]
#[error("{language} byte {offset}: {message}")]
pub struct ProgramError {
    /// "HP-GL" or "G-code".
    pub language: &'static str,
    /// Byte offset into the submitted text.
    pub offset: usize,
    /// What is wrong there.
    pub message: String,
}

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
    /// Where the chunk leaves the pen, when the cutter can tell (`None` after
    /// instructions whose motion it does not follow, such as labels or arcs,
    /// or under user scaling).
    pub end: Option<PenAt>,
    /// Every place the device can leave the pen at rest while it runs this
    /// chunk (after each move, each pen lift or drop), in order, `end` last;
    /// `None` when the cutter cannot follow it all. After an interruption it
    /// tells a stroke the device stopped inside from one it finished.
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
    /// The language of every chunk.
    pub language: Language,
    /// Chunks in plotting order.
    pub chunks: Vec<Chunk>,
    /// Bytes that lift the pen (HP-GL `PU;`, G-code the job's own pen-up lines).
    pub pen_up: Vec<u8>,
}

impl Program {
    /// Cuts a command text for `device` into chunks.
    ///
    /// # Errors
    /// [`ProgramError`] at the first byte that cannot be read.
    pub fn build(text: &[u8], device: &Device) -> Result<Program, ProgramError> {
        match device.language {
            Language::Hpgl => hpgl::cut(text, device),
            Language::Gcode => gcode::cut(text, device),
        }
    }

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
}

/// Plot-time bookkeeping while cutting, in device units.
struct Clock<'a> {
    device: &'a Device,
    seconds: f64,
}

impl Clock<'_> {
    fn travel(&mut self, from: DVec2, to: DVec2, down: bool) {
        let m = &self.device.motion;
        let len = from.distance(to) / self.device.units_per_mm;
        let v = if down { m.pen_down_speed } else { m.pen_up_speed };
        self.seconds += m.move_time(len, v);
    }
    fn pen(&mut self, down: bool) {
        let m = &self.device.motion;
        self.seconds += if down { m.pen_drop_time } else { m.pen_lift_time };
    }
    fn take(&mut self) -> f64 {
        std::mem::take(&mut self.seconds)
    }
}

/// Adds a rest of the pen to a chunk's path, which stays `None` once a rest
/// is not `known`.
fn rest(path: &mut Option<Vec<PenAt>>, known: bool, at: PenAt) {
    match path {
        Some(p) if known => {
            if p.last() != Some(&at) {
                p.push(at);
            }
        }
        _ => *path = None,
    }
}

fn fmt_num(v: f64) -> String {
    if v.fract() == 0.0 && v.abs() < 1e15 {
        format!("{}", v as i64)
    } else {
        let s = format!("{v:.4}");
        s.trim_end_matches('0').trim_end_matches('.').to_owned()
    }
}

mod hpgl {
    use super::*;

    const ESC: u8 = 0x1b;
    const ETX: u8 = 0x03;
    /// Instructions whose last occurrence is device state worth re-sending on resume.
    const MODAL: &[&[u8; 2]] = &[
        b"IP", b"SC", b"IW", b"RO", b"SP", b"VS", b"LT", b"SI", b"SR", b"DI", b"DR", b"CS", b"CA", b"SS", b"SA", b"DT", b"SL", b"FT",
        b"PT", b"TL", b"XT", b"YT", b"SM", b"CT", b"CP",
    ];

    fn err(offset: usize, message: impl Into<String>) -> ProgramError {
        ProgramError { language: "HP-GL", offset, message: message.into() }
    }

    /// One instruction: its bytes in the text and its parsed parts.
    struct Instr<'a> {
        start: usize,
        end: usize,
        mnemonic: [u8; 2],
        params: &'a [u8],
    }

    struct Lexer<'a> {
        text: &'a [u8],
        at: usize,
        label_end: u8,
    }

    impl<'a> Lexer<'a> {
        fn next(&mut self) -> Result<Option<Instr<'a>>, ProgramError> {
            let t = self.text;
            while self.at < t.len() && (t[self.at].is_ascii_whitespace() || matches!(t[self.at], b';' | b',' | 0)) {
                self.at += 1;
            }
            if self.at >= t.len() {
                return Ok(None);
            }
            let start = self.at;
            let c = t[start];
            if c == ESC {
                // Device-control instruction: ESC . letter, some with parameters up to ':'.
                if t.get(start + 1) != Some(&b'.') || start + 2 >= t.len() {
                    return Err(err(start, "ESC not followed by '.' and a letter"));
                }
                let letter = t[start + 2];
                let mut end = start + 3;
                if matches!(letter, b'@' | b'H' | b'I' | b'M' | b'N' | b'P' | b'S' | b'T') {
                    while end < t.len() && t[end] != b':' && t[end] != ESC && end - start < 64 {
                        end += 1;
                    }
                    if end < t.len() && t[end] == b':' {
                        end += 1;
                    }
                }
                self.at = end;
                return Ok(Some(Instr { start, end, mnemonic: [ESC, letter], params: &t[start + 3..end] }));
            }
            if !c.is_ascii_alphabetic() || !t.get(start + 1).is_some_and(u8::is_ascii_alphabetic) {
                return Err(err(start, format!("expected a two-letter instruction, found byte 0x{c:02x}")));
            }
            let mnemonic = [c.to_ascii_uppercase(), t[start + 1].to_ascii_uppercase()];
            let mut end = start + 2;
            match &mnemonic {
                b"LB" | b"WD" => {
                    let term = if &mnemonic == b"LB" { self.label_end } else { ETX };
                    while end < t.len() && t[end] != term {
                        end += 1;
                    }
                    if end >= t.len() {
                        return Err(err(start, "label not terminated"));
                    }
                    end += 1;
                }
                b"DT" | b"SM" => {
                    // One character argument (none: the default).
                    if end < t.len() && t[end] != b';' {
                        if &mnemonic == b"DT" {
                            self.label_end = t[end];
                        }
                        end += 1;
                    } else if &mnemonic == b"DT" {
                        self.label_end = ETX;
                    }
                }
                _ => {
                    while end < t.len() && !t[end].is_ascii_alphabetic() && t[end] != b';' && t[end] != ESC {
                        end += 1;
                    }
                }
            }
            if end - start > MAX_INSTRUCTION_BYTES {
                return Err(err(start, format!("instruction longer than {MAX_INSTRUCTION_BYTES} bytes")));
            }
            let params = &t[start + 2..end];
            if end < t.len() && t[end] == b';' {
                end += 1;
            }
            self.at = end;
            Ok(Some(Instr { start, end, mnemonic, params }))
        }
    }

    fn numbers(instr: &Instr<'_>) -> Result<Vec<f64>, ProgramError> {
        let s = std::str::from_utf8(instr.params).map_err(|_| err(instr.start, "parameters are not ASCII"))?;
        s.split(|c: char| c == ',' || c.is_ascii_whitespace())
            .filter(|w| !w.is_empty())
            .map(|w| {
                w.parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite())
                    .ok_or_else(|| err(instr.start, format!("{}: bad number {w:?}", String::from_utf8_lossy(&instr.mnemonic))))
            })
            .collect()
    }

    pub(super) fn cut(text: &[u8], device: &Device) -> Result<Program, ProgramError> {
        let mut lx = Lexer { text, at: 0, label_end: ETX };
        let mut chunks = Vec::new();
        let mut clock = Clock { device, seconds: 0.0 };
        let mut chunk_start = 0;
        let mut chunk_draws = false;
        // The pen the chunk draws with: an `SP` after its last stroke (as
        // `plotcode` emits a pen change) belongs to it, the pen to the next.
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
        while let Some(ins) = lx.next()? {
            let m = &ins.mnemonic;
            let end = (pos_known && !scaled).then_some(PenAt { pos, down: pen_down, z: None });
            if m == b"PU" && chunk_draws {
                chunks.push(Chunk {
                    bytes: text[chunk_start..ins.start].to_vec(),
                    resume: std::mem::take(&mut resume),
                    pen: chunk_pen,
                    draws: true,
                    seconds: clock.take(),
                    page: 0,
                    end,
                    path: std::mem::replace(&mut path, end.map(|_| Vec::new())),
                });
                chunk_start = ins.start;
                chunk_draws = false;
                resume = state_bytes(initialised, &modal, pos, absolute);
            }
            match m {
                b"IN" | b"DF" => {
                    modal.clear();
                    initialised |= m == b"IN";
                    absolute = true;
                    if m == b"IN" {
                        down = false;
                        pen_down = false;
                        scaled = false;
                    }
                }
                // The carousel lifts the pen to change it.
                b"SP" => pen_down = false,
                b"SC" | b"RO" => scaled = !ins.params.iter().all(|b| b.is_ascii_whitespace() || *b == b'0'),
                _ if !is_still(m) => pos_known = false,
                _ => {}
            }
            match m {
                b"SP" => {
                    let n = numbers(&ins)?;
                    pen = match n.first() {
                        Some(&v) if v >= 1.0 => Some(v as u32),
                        _ => None,
                    };
                }
                b"PA" => absolute = true,
                b"PR" => absolute = false,
                _ => {}
            }
            if matches!(m, b"PU" | b"PD") {
                let was = down;
                down = m == b"PD";
                pen_down = down;
                if was != down {
                    clock.pen(down);
                }
                // The pen moves up or down before the coordinates are read:
                // the device rests here when they are lost.
                rest(&mut path, pos_known && !scaled, PenAt { pos, down: pen_down, z: None });
            }
            if matches!(m, b"PU" | b"PD" | b"PA" | b"PR") {
                let n = numbers(&ins)?;
                if n.len() % 2 != 0 {
                    return Err(err(ins.start, format!("{}: odd number of coordinates", String::from_utf8_lossy(m))));
                }
                for xy in n.chunks(2) {
                    let to = if absolute { DVec2::new(xy[0], xy[1]) } else { pos + DVec2::new(xy[0], xy[1]) };
                    clock.travel(pos, to, down);
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
            if MODAL.contains(&m) {
                let bytes = text[ins.start..ins.end].to_vec();
                match modal.iter_mut().find(|(k, _)| k == m) {
                    Some(slot) => slot.1 = bytes,
                    None => modal.push((*m, bytes)),
                }
            }
        }
        if chunk_start < text.len() {
            chunks.push(Chunk {
                bytes: text[chunk_start..].to_vec(),
                resume,
                pen: if chunk_draws { chunk_pen } else { pen },
                draws: chunk_draws,
                seconds: clock.take(),
                page: 0,
                end: (pos_known && !scaled).then_some(PenAt { pos, down: pen_down, z: None }),
                path,
            });
        }
        Ok(Program { language: Language::Hpgl, chunks, pen_up: b"PU;".to_vec() })
    }

    /// Instructions that leave the pen where it is (moves are followed apart).
    fn is_still(m: &[u8; 2]) -> bool {
        const STILL: &[&[u8; 2]] = &[
            b"PU", b"PD", b"PA", b"PR", b"IN", b"DF", b"SP", b"VS", b"LT", b"IW", b"IP", b"SC", b"RO", b"SI", b"SR", b"DI", b"DR", b"CS",
            b"CA", b"SS", b"SA", b"DT", b"SL", b"TL", b"PT", b"FT", b"OA", b"OC", b"OD", b"OE", b"OF", b"OH", b"OI", b"OO", b"OP", b"OS",
            b"OW",
        ];
        m[0] == ESC || STILL.contains(&m)
    }

    fn state_bytes(initialised: bool, modal: &[([u8; 2], Vec<u8>)], pos: DVec2, absolute: bool) -> Vec<u8> {
        let mut out = b"PU;".to_vec();
        if initialised {
            out.extend_from_slice(b"IN;");
        }
        for (_, bytes) in modal {
            out.extend_from_slice(bytes);
            if bytes.last() != Some(&b';') {
                out.push(b';');
            }
        }
        out.extend_from_slice(format!("PA;PU{},{};", fmt_num(pos.x), fmt_num(pos.y)).as_bytes());
        if !absolute {
            out.extend_from_slice(b"PR;");
        }
        out
    }
}

mod gcode {
    use super::*;

    fn err(offset: usize, message: impl Into<String>) -> ProgramError {
        ProgramError { language: "G-code", offset, message: message.into() }
    }

    /// Letter-number words of one line, comments removed.
    fn words(line: &str, offset: usize) -> Result<Vec<(char, f64)>, ProgramError> {
        let mut out = Vec::new();
        let mut chars = line.char_indices().peekable();
        while let Some((i, c)) = chars.next() {
            match c {
                ';' => break,
                '(' => {
                    for (_, c) in chars.by_ref() {
                        if c == ')' {
                            break;
                        }
                    }
                }
                c if c.is_whitespace() => {}
                c if c.is_ascii_alphabetic() => {
                    let mut num = String::new();
                    while let Some(&(_, d)) = chars.peek() {
                        if d.is_ascii_digit() || matches!(d, '.' | '-' | '+') || (d == ' ' && num.is_empty()) {
                            if d != ' ' {
                                num.push(d);
                            }
                            chars.next();
                        } else {
                            break;
                        }
                    }
                    let v = num
                        .parse::<f64>()
                        .ok()
                        .filter(|v| v.is_finite())
                        .ok_or_else(|| err(offset + i, format!("word {c}: bad number {num:?}")))?;
                    out.push((c.to_ascii_uppercase(), v));
                }
                '$' | '%' if i == 0 => break,
                c => return Err(err(offset + i, format!("unexpected character {c:?}"))),
            }
        }
        Ok(out)
    }

    /// The line without comments and surrounding blanks.
    fn clean(line: &str) -> String {
        let mut out = String::new();
        let mut depth = 0;
        for c in line.chars() {
            match c {
                ';' if depth == 0 => break,
                '(' => depth += 1,
                ')' if depth > 0 => depth -= 1,
                c if depth == 0 => out.push(c),
                _ => {}
            }
        }
        out.trim().to_owned()
    }

    pub(super) fn cut(text: &[u8], device: &Device) -> Result<Program, ProgramError> {
        let text = std::str::from_utf8(text).map_err(|e| err(e.valid_up_to(), "not UTF-8 text"))?;
        let mut chunks = Vec::new();
        let mut clock = Clock { device, seconds: 0.0 };
        let mut cur: Vec<u8> = Vec::new();
        let mut cur_draws = false;
        let mut resume = Vec::new();
        let mut pen_up: Option<Vec<u8>> = None;
        // Lines since the last feed move of the current chunk: the pen-up candidates.
        let mut tail: Vec<u8> = Vec::new();
        let mut modal: Vec<(String, String)> = Vec::new();
        let mut motion = 0u32;
        // Tool number: `T{pen}` selects the pen; a single-pen board starts with pen 1.
        let mut pen = Some(1u32);
        let mut chunk_pen = pen;
        let mut absolute = true;
        let mut pos = DVec2::ZERO;
        let mut pos_known = true;
        // The pen as GRBL reports it: spindle on with a speed (`$G`), Z (`MPos`).
        let (mut spindle_on, mut spindle_s, mut z) = (false, 0.0, None);
        let mut path = Some(Vec::new());
        let mut offset = 0;
        for raw in text.split_inclusive('\n') {
            let at = offset;
            offset += raw.len();
            if raw.len() > MAX_INSTRUCTION_BYTES {
                return Err(err(at, format!("line longer than {MAX_INSTRUCTION_BYTES} bytes")));
            }
            let ws = words(raw, at)?;
            let line = clean(raw);
            if line.is_empty() {
                continue;
            }
            let mut g_motion = None;
            let (mut x, mut y) = (None, None);
            let at_start = PenAt { pos, down: spindle_on && spindle_s > 0.0, z };
            for &(l, v) in &ws {
                match l {
                    'M' if v == 3.0 || v == 4.0 => spindle_on = true,
                    'M' if v == 5.0 => spindle_on = false,
                    'S' => spindle_s = v,
                    'Z' => z = if absolute { Some(v) } else { z.map(|z| z + v) },
                    'G' if matches!(v as u32, 0..=3) && v.fract() == 0.0 => g_motion = Some(v as u32),
                    'G' if v == 90.0 => absolute = true,
                    'G' if v == 91.0 => absolute = false,
                    'T' if v >= 1.0 => pen = Some(v as u32),
                    // Inches, homing, machine or offset coordinates: the
                    // position GRBL reports is no longer `pos`.
                    'G' if matches!(v, 10.0 | 20.0 | 28.0 | 30.0 | 53.0 | 92.0) || (54.0..=59.0).contains(&v) => {
                        pos_known = false;
                    }
                    'X' => x = Some(v),
                    'Y' => y = Some(v),
                    _ => {}
                }
            }
            if let Some(g) = g_motion {
                motion = g;
            }
            let moves_xy = x.is_some() || y.is_some();
            if moves_xy && motion == 0 && cur_draws {
                if pen_up.is_none() && !tail.is_empty() {
                    pen_up = Some(tail.clone());
                }
                chunks.push(Chunk {
                    bytes: std::mem::take(&mut cur),
                    resume: std::mem::take(&mut resume),
                    pen: chunk_pen,
                    draws: true,
                    seconds: clock.take(),
                    page: 0,
                    end: pos_known.then_some(at_start),
                    path: std::mem::replace(&mut path, pos_known.then(Vec::new)),
                });
                cur_draws = false;
                resume = state_bytes(pen_up.as_deref().unwrap_or_default(), &modal, pos, absolute);
            }
            if moves_xy {
                let to = if absolute {
                    DVec2::new(x.unwrap_or(pos.x), y.unwrap_or(pos.y))
                } else {
                    pos + DVec2::new(x.unwrap_or(0.0), y.unwrap_or(0.0))
                };
                let feed = motion != 0;
                clock.travel(pos, to, feed);
                pos = to;
                if feed {
                    if !cur_draws {
                        chunk_pen = pen;
                    }
                    cur_draws = true;
                    tail.clear();
                }
            } else if cur_draws {
                tail.extend_from_slice(line.as_bytes());
                tail.push(b'\n');
            }
            // Modal state worth re-sending: units, distance mode, plane, feed rate.
            for &(l, v) in &ws {
                let key = match (l, v as i64) {
                    ('G', 20 | 21) => "units",
                    ('G', 90 | 91) => "distance",
                    ('G', 17..=19) => "plane",
                    ('G', 93 | 94) => "feedmode",
                    ('F', _) => "feed",
                    _ => continue,
                };
                let word = format!("{l}{}", fmt_num(v));
                match modal.iter_mut().find(|(k, _)| k == key) {
                    Some(slot) => slot.1 = word,
                    None => modal.push((key.to_owned(), word)),
                }
            }
            cur.extend_from_slice(line.as_bytes());
            cur.push(b'\n');
            rest(&mut path, pos_known, PenAt { pos, down: spindle_on && spindle_s > 0.0, z });
        }
        if !cur.is_empty() {
            chunks.push(Chunk {
                bytes: cur,
                resume,
                pen: if cur_draws { chunk_pen } else { pen },
                draws: cur_draws,
                seconds: clock.take(),
                page: 0,
                end: pos_known.then_some(PenAt { pos, down: spindle_on && spindle_s > 0.0, z }),
                path,
            });
        }
        Ok(Program { language: Language::Gcode, chunks, pen_up: pen_up.unwrap_or_default() })
    }

    fn state_bytes(pen_up: &[u8], modal: &[(String, String)], pos: DVec2, absolute: bool) -> Vec<u8> {
        let mut out = pen_up.to_vec();
        for (_, word) in modal {
            out.extend_from_slice(word.as_bytes());
            out.push(b'\n');
        }
        // The position too, in absolute mode as well: the chunk's travel line
        // may leave out an axis it did not change, and a board that lost
        // power is at zero.
        out.extend_from_slice(format!("G90\nG0 X{} Y{}\n", fmt_num(pos.x), fmt_num(pos.y)).as_bytes());
        if !absolute {
            out.extend_from_slice(b"G91\n");
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hp() -> Device {
        Device::lookup("hp7475a").unwrap()
    }
    fn grbl() -> Device {
        Device::lookup("grbl-servo").unwrap()
    }
    fn text(b: &[u8]) -> &str {
        std::str::from_utf8(b).unwrap()
    }

    #[test]
    fn hpgl_cuts_at_pen_up_after_drawing() {
        let src = b"IN;SP1;VS10;PU0,0;PD100,0,100,100;PU200,200;PD300,300;SP2;PU0,0;PD0,10;PU;SP0;";
        let p = Program::build(src, &hp()).unwrap();
        let parts: Vec<&str> = p.chunks.iter().map(|c| text(&c.bytes)).collect();
        assert_eq!(parts, ["IN;SP1;VS10;PU0,0;PD100,0,100,100;", "PU200,200;PD300,300;SP2;", "PU0,0;PD0,10;", "PU;SP0;"]);
        // Concatenated chunks are the input, byte for byte.
        assert_eq!(p.chunks.iter().flat_map(|c| c.bytes.clone()).collect::<Vec<_>>(), src.to_vec());
        // The `SP2;` ends the second chunk, which draws with pen 1.
        assert_eq!(p.chunks.iter().map(|c| c.pen).collect::<Vec<_>>(), [Some(1), Some(1), Some(2), None]);
        assert_eq!(p.chunks.iter().map(|c| c.draws).collect::<Vec<_>>(), [true, true, true, false]);
        assert_eq!(text(&p.chunks[1].resume), "PU;IN;SP1;VS10;PA;PU100,100;");
        assert_eq!(text(&p.chunks[2].resume), "PU;IN;SP2;VS10;PA;PU300,300;");
        assert!(p.chunks[0].seconds > 0.0);
    }

    #[test]
    fn hpgl_chunk_ends_are_where_the_device_leaves_the_pen() {
        let at = |x: f64, y: f64, down: bool| Some(PenAt { pos: DVec2::new(x, y), down, z: None });
        let p = Program::build(b"IN;PU0,0;PD100,0;PU;PR;PU5,5;PD10,0;SP2;PU;PA;PU7,7;PD8,8;LBab\x03PU;PU1,1;PD2,2;", &hp()).unwrap();
        let ends: Vec<_> = p.chunks.iter().map(|c| c.end).collect();
        // Relative moves add up; a pen change lifts the pen; a label moves the
        // pen where the cutter does not follow, until an absolute move.
        assert_eq!(ends, [at(100.0, 0.0, true), at(115.0, 5.0, false), None, at(2.0, 2.0, true)]);
        let p = Program::build(b"IN;SC0,10,0,10;PU0,0;PD1,1;PU;IN;PU0,0;PD3,3;", &hp()).unwrap();
        assert_eq!(p.chunks.iter().map(|c| c.end).collect::<Vec<_>>(), [None, at(3.0, 3.0, true)]);
    }

    #[test]
    fn chunk_paths_are_every_rest_in_order() {
        let at = |x: f64, y: f64, down: bool| PenAt { pos: DVec2::new(x, y), down, z: None };
        let p = Program::build(b"IN;PU0,0;PD100,0,100,100;PU;LBab\x03PU5,5;PD6,6;", &hp()).unwrap();
        // The pen goes down before it moves: a device that lost the
        // coordinates rests there.
        let want = [at(0.0, 0.0, false), at(0.0, 0.0, true), at(100.0, 0.0, true), at(100.0, 100.0, true)];
        assert_eq!(p.chunks[0].path.as_deref(), Some(&want[..]));
        assert_eq!(p.chunks[0].path.as_ref().unwrap().last(), p.chunks[0].end.as_ref());
        // A label moves the pen where the cutter does not follow.
        assert_eq!(p.chunks[1].path, None);
        let p = Program::build(b"G0 X1 Y1\nM3\nG1 X2 Y2\nG1 X3 Y2\nM5\nG0 X5 Y5\nG1 X6 Y6\n", &grbl()).unwrap();
        assert_eq!(p.chunks[0].path, Some(vec![at(1.0, 1.0, false), at(2.0, 2.0, false), at(3.0, 2.0, false)]));
        assert_eq!(p.chunks[1].path, Some(vec![at(5.0, 5.0, false), at(6.0, 6.0, false)]));
        // The pen as GRBL shows it: the spindle (a servo) and Z.
        let p = Program::build(b"M3 S0\nG0 X1 Y1\nM3 S900\nG1 X2 Y2\nM5\nG0 Z5\nG0 X3 Y3\nG1 Z0\nG91\nG1 X1 Y1 Z-1\n", &grbl()).unwrap();
        let z = |x: f64, down: bool, z: Option<f64>| PenAt { pos: DVec2::new(x, x), down, z };
        let want = [
            z(0.0, false, None),
            z(1.0, false, None),
            z(1.0, true, None),
            z(2.0, true, None),
            z(2.0, false, None),
            z(2.0, false, Some(5.0)),
        ];
        assert_eq!(p.chunks[0].path.as_deref(), Some(&want[..]));
        assert_eq!(p.chunks[1].path, Some(vec![z(3.0, false, Some(5.0)), z(3.0, false, Some(0.0)), z(4.0, false, Some(-1.0))]));
    }

    #[test]
    fn hpgl_relative_moves_resume_at_absolute_position() {
        let src = b"IN;PR;PU10,10;PD5,0;PU5,5;PD0,5;";
        let p = Program::build(src, &hp()).unwrap();
        assert_eq!(p.chunks.len(), 2);
        assert_eq!(text(&p.chunks[1].resume), "PU;IN;PA;PU15,10;PR;");
    }

    #[test]
    fn hpgl_labels_and_escapes() {
        let src = b"\x1b.@;0:IN;SP1;PU0,0;PD1,1;LBhi;PU there\x03PU5,5;PD6,6;DT#;LBa;b#PU;";
        let p = Program::build(src, &hp()).unwrap();
        assert_eq!(p.chunks.len(), 3);
        assert_eq!(text(&p.chunks[1].bytes), "PU5,5;PD6,6;DT#;LBa;b#");
    }

    #[test]
    fn hpgl_errors_name_the_offset() {
        let e = Program::build(b"IN;PU0,0;PD1,x;", &hp()).unwrap_err();
        assert_eq!(e.offset, 9);
        let e = Program::build(b"IN;\x01", &hp()).unwrap_err();
        assert_eq!(e.offset, 3);
        assert!(e.to_string().contains("byte 3"));
        let e = Program::build(b"IN;PD1,2,3;", &hp()).unwrap_err();
        assert!(e.message.contains("odd"), "{e}");
        let e = Program::build(b"IN;LBnever ends", &hp()).unwrap_err();
        assert!(e.message.contains("label"), "{e}");
    }

    #[test]
    fn empty_inputs() {
        assert!(Program::build(b"", &hp()).unwrap().chunks.is_empty());
        assert!(Program::build(b"  \n", &grbl()).unwrap().chunks.is_empty());
        let p = Program::build(b"IN;", &hp()).unwrap();
        assert_eq!(p.chunks.len(), 1);
        assert!(!p.chunks[0].draws);
    }

    #[test]
    fn gcode_cuts_at_rapid_after_feed() {
        let src = "G21\nG90 ; absolute\nM5\nG0 X0 Y0\nM3 S90\nG1 X10 Y0 F1000\nG1 X10 Y10\nM5\nG0 X20 Y20\nM3 S90\n(comment)\nG1 X30 Y20\nM5\n\nG0 X0 Y0\n";
        let p = Program::build(src.as_bytes(), &grbl()).unwrap();
        let parts: Vec<&str> = p.chunks.iter().map(|c| text(&c.bytes)).collect();
        assert_eq!(
            parts,
            ["G21\nG90\nM5\nG0 X0 Y0\nM3 S90\nG1 X10 Y0 F1000\nG1 X10 Y10\nM5\n", "G0 X20 Y20\nM3 S90\nG1 X30 Y20\nM5\n", "G0 X0 Y0\n"]
        );
        assert_eq!(text(&p.pen_up), "M5\n");
        assert_eq!(text(&p.chunks[1].resume), "M5\nG21\nG90\nF1000\nG90\nG0 X10 Y10\n");
        assert!(!p.chunks[2].draws);
        let at = |x: f64, y: f64| Some(PenAt { pos: DVec2::new(x, y), down: false, z: None });
        assert_eq!(p.chunks.iter().map(|c| c.end).collect::<Vec<_>>(), [at(10.0, 10.0), at(30.0, 20.0), at(0.0, 0.0)]);
        // Work offsets: the position GRBL reports is no longer the text's.
        let p = Program::build(b"G0 X1 Y1\nM3\nG1 X2 Y2\nG0 X5 Y5\nG92 X0 Y0\nG1 X6 Y6\n", &grbl()).unwrap();
        assert_eq!(p.chunks.iter().map(|c| c.end).collect::<Vec<_>>(), [at(2.0, 2.0), None]);
    }

    #[test]
    fn gcode_errors_name_the_offset() {
        let e = Program::build(b"G0 X1\nG1 X# Y2\n", &grbl()).unwrap_err();
        assert_eq!(e.offset, 9);
        let e = Program::build(b"G0 X1\nG1 Xabc\n", &grbl()).unwrap_err();
        assert!(e.to_string().contains("G-code byte"), "{e}");
    }
}
