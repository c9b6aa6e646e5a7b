//! Cutting a submitted G-code file into per-stroke chunks ([`cut`]), each
//! line read with [`parse_line`] and followed through [`BoardState`].
//!
//! A chunk ends before an XY rapid (`G0`) that follows feed moves. Chunks hold
//! the lines as GRBL reads them: comments and blank lines dropped, which also
//! keeps every line within the board's receive buffer for character counting.
//! Program pauses (`M0`, `M1`) are dropped too: the daemon pauses for a pen
//! change itself.

use super::line::{parse_line, Line};
use super::state::BoardState;
use crate::clock::Clock;
use crate::profile::{DeviceProfile, Protocol};
use crate::program::{rest, Chunk, CutError, Program};

fn err(offset: usize, message: impl Into<String>) -> CutError {
    CutError { protocol: Protocol::Gcode, offset, message: message.into() }
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

/// Cuts a G-code text into chunks for `profile`, timed by the [`Clock`]
/// (through [`BoardState::run`], as the emitter times what it writes).
///
/// # Errors
/// [`CutError`] for text that is not UTF-8 and at the first line
/// [`parse_line`] rejects.
pub fn cut(text: &[u8], profile: &DeviceProfile) -> Result<Program, CutError> {
    let text = std::str::from_utf8(text).map_err(|e| err(e.valid_up_to(), "not UTF-8 text"))?;
    let mut clock = Clock::new(profile);
    let mut chunks = Vec::new();
    let mut seconds = 0.0;
    let mut cur: Vec<u8> = Vec::new();
    let mut cur_draws = false;
    let mut resume = Vec::new();
    let mut pen_up: Option<Vec<u8>> = None;
    // Lines since the last feed move of the current chunk: the pen-up candidates.
    let mut tail: Vec<u8> = Vec::new();
    let mut tail_ended = false;
    let mut board = BoardState::new(profile);
    let mut chunk_pen = board.pen;
    let mut path = Some(Vec::new());
    let mut offset = 0;
    for raw in text.split_inclusive('\n') {
        let at = offset;
        offset += raw.len();
        let block = match parse_line(raw.trim_end_matches(['\n', '\r'])) {
            Ok(Line::Block(b)) => b,
            Ok(Line::System(_)) => Default::default(),
            Err(e) => return Err(err(at + e.column.saturating_sub(1), e.problem)),
        };
        let line = clean(raw);
        // A program pause (`M0`, `M1`: a one-pen device's pen change in a file
        // plotd wrote) is dropped: the daemon waits for people itself
        // (`pen-changed`), and a board held by it would wait for a cycle start.
        if line.is_empty() || block.has('M', 0.0) || block.has('M', 1.0) {
            continue;
        }
        if board.xy_motion(&block) == Some(0) && cur_draws {
            if pen_up.is_none() && !tail.is_empty() {
                pen_up = Some(tail.clone());
            }
            let end = board.pos_known.then_some(board.pen_at());
            chunks.push(Chunk {
                bytes: std::mem::take(&mut cur),
                resume: std::mem::take(&mut resume),
                pen: chunk_pen,
                draws: true,
                seconds: std::mem::take(&mut seconds),
                page: 0,
                end,
                path: std::mem::replace(&mut path, board.pos_known.then(Vec::new)),
            });
            cur_draws = false;
            resume = board.resume(pen_up.as_deref().unwrap_or_default());
        }
        let (moved, took) = board.run(&block, &mut clock);
        seconds += took;
        match moved {
            Some(m) if m.feed => {
                if !cur_draws {
                    chunk_pen = board.pen;
                }
                cur_draws = true;
                tail.clear();
                tail_ended = false;
            }
            Some(_) => {}
            // The pen-up lines end at a tool change or a program end: those
            // are not part of lifting.
            None if cur_draws && !tail_ended => {
                if block.get('T').is_some() || block.has('M', 2.0) || block.has('M', 30.0) {
                    tail_ended = true;
                } else {
                    tail.extend_from_slice(line.as_bytes());
                    tail.push(b'\n');
                }
            }
            None => {}
        }
        cur.extend_from_slice(line.as_bytes());
        cur.push(b'\n');
        rest(&mut path, board.pos_known, board.pen_at());
    }
    if !cur.is_empty() {
        chunks.push(Chunk {
            bytes: cur,
            resume,
            pen: if cur_draws { chunk_pen } else { board.pen },
            draws: cur_draws,
            seconds,
            page: 0,
            end: board.pos_known.then_some(board.pen_at()),
            path,
        });
    }
    Ok(Program { protocol: Protocol::Gcode, chunks, pen_up: pen_up.unwrap_or_default() })
}
