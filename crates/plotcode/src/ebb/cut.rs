//! EBB text into per-stroke chunks ([`cut`]), and into the strokes it draws
//! ([`parse`]): each command read with [`Command::parse`] and followed
//! through [`Board`].
//!
//! A chunk ends before a move made with the pen up that follows a lowered
//! pen, as G-code's do before a rapid, or before the pen is lowered again
//! where it was raised (a stroke that starts where the last one ended): it
//! holds the travel to its stroke, the pen lowered, the stroke, the pen
//! raised and what comes after it up to the next travel (the next stroke's
//! pen number). Its resume prefix sets
//! the servo up again as the text did (`SC`; it also undoes an `SP,3`, which
//! makes the down position the up one), raises the pen as the text does,
//! and goes to the chunk's start: `HM` to its step counters (firmware
//! 2.7.0), or `HM` home and planned `SM` travel from there (older
//! firmware). It never enables the motors again (`EM`), which would make
//! wherever the carriage stands the home; the first chunk's prefix goes
//! home, where its `EM` belongs.

use super::board::{Board, Effect};
use super::command::{Command, MAX_COMMAND_BYTES};
use super::emit::{block_commands, limits};
use super::motors::Motors;
use super::plan::plan;
use crate::clock::Clock;
use crate::plot::{Plot, Stroke};
use crate::profile::{DeviceProfile, Protocol};
use crate::program::{rest, Chunk, CutError, Program};
use std::fmt::Write as _;

/// The step rate of `HM` moves back to a chunk's start, steps/s (the
/// AxiDraw examples' `HM,3200`: 40 mm/s along an axis, gentle enough to
/// start without acceleration).
pub const RESUME_STEP_RATE: u32 = 3200;

/// Why EBB text cannot be read: the byte offset of the command, and what is
/// wrong with it.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("EBB byte {offset}: {message}")]
pub struct EbbError {
    /// Byte offset of the command.
    pub offset: usize,
    /// What is wrong.
    pub message: String,
}

/// The commands of `text` with their bytes (terminator included) and byte
/// offsets; blank pieces come as `None`.
fn commands(text: &[u8]) -> impl Iterator<Item = Result<(usize, &[u8], Option<Command>), EbbError>> {
    let mut offset = 0;
    text.split_inclusive(|&b| b == b'\r' || b == b'\n').map(move |piece| {
        let at = offset;
        offset += piece.len();
        let err = |message: String| EbbError { offset: at, message };
        let line = std::str::from_utf8(piece).map_err(|_| err("not ASCII text".to_owned()))?;
        let line = line.trim_end_matches(['\r', '\n']);
        if line.trim().is_empty() {
            return Ok((at, piece, None));
        }
        if line.len() + 1 > MAX_COMMAND_BYTES {
            return Err(err(format!("a command of {} bytes; the EBB takes at most {MAX_COMMAND_BYTES}", line.len() + 1)));
        }
        let cmd = Command::parse(line).map_err(err)?;
        Ok((at, piece, Some(cmd)))
    })
}

/// The strokes EBB text draws, in device units (steps along x and y from
/// home), pen by pen as `SL,128+pen` names them (0 before any): each the
/// pen's place when lowered and after every move while down (a stroke's
/// vertices and the points where its speed profile changes).
///
/// # Errors
/// [`EbbError`] at the first command that is not one of a plot, or a move
/// the firmware would never finish.
pub fn parse(text: &[u8]) -> Result<Plot, EbbError> {
    let mut board = Board::default();
    let mut plot = Plot::default();
    let mut stroke: Option<Stroke> = None;
    for c in commands(text) {
        let (at, _, Some(cmd)) = c? else { continue };
        let effect = board.apply(&cmd).map_err(|message| EbbError { offset: at, message })?;
        match (effect, &mut stroke) {
            (Effect::Pen { down: true, .. }, None) => {
                stroke = Some(Stroke { pen: board.pen.unwrap_or(0), points: vec![board.at.xy()] });
            }
            (Effect::Pen { down: false, .. }, Some(_)) => plot.strokes.extend(stroke.take()),
            (Effect::Move { .. }, Some(s)) => s.points.push(board.at.xy()),
            _ => {}
        }
    }
    plot.strokes.extend(stroke);
    Ok(plot)
}

/// Cuts EBB text written for `profile` into per-stroke chunks, timed by the
/// firmware's arithmetic (through `Board::run`, as the emitter times what
/// it writes).
///
/// # Errors
/// [`CutError`] for a profile without an `[ebb]` table, and at the first
/// command that is not one of a plot or a move the firmware would never
/// finish.
pub fn cut(text: &[u8], profile: &DeviceProfile) -> Result<Program, CutError> {
    let err = |e: EbbError| CutError { protocol: Protocol::Ebb, offset: e.offset, message: e.message };
    if profile.ebb.is_none() {
        return Err(err(EbbError { offset: 0, message: format!("device {} has no [ebb] table", profile.name) }));
    }
    let mut clock = Clock::new(profile);
    let mut board = Board::default();
    let mut chunks = Vec::new();
    let mut cur: Vec<u8> = Vec::new();
    let (mut seconds, mut draws, mut pen, mut start) = (0.0, false, None, Motors::default());
    let mut path = Some(Vec::new());
    for c in commands(text) {
        let (at, bytes, cmd) = c.map_err(err)?;
        if let Some(cmd) = cmd {
            // A stroke ends at the next move with the pen up, or at the next
            // lowering when the next stroke starts where this one ended.
            let moves = cmd.steps().is_some() || matches!(cmd, Command::Home { .. } | Command::Pen { up: false, .. });
            if moves && !board.pen_down && draws {
                chunks.push(Chunk {
                    bytes: std::mem::take(&mut cur),
                    resume: resume(&board, start, profile),
                    pen,
                    draws: true,
                    seconds: std::mem::take(&mut seconds),
                    page: 0,
                    end: Some(board.pen_at()),
                    path: path.replace(Vec::new()),
                });
                (draws, start) = (false, board.at);
            }
            seconds += board.run(&cmd, &mut clock).map_err(|message| err(EbbError { offset: at, message }))?;
            if matches!(cmd, Command::Pen { up: false, .. }) && !draws {
                (draws, pen) = (true, board.pen);
            }
            rest(&mut path, true, board.pen_at());
        }
        cur.extend_from_slice(bytes);
    }
    if !cur.is_empty() {
        chunks.push(Chunk {
            bytes: cur,
            resume: resume(&board, start, profile),
            pen: if draws { pen } else { board.pen },
            draws,
            seconds,
            page: 0,
            end: Some(board.pen_at()),
            path,
        });
    }
    Ok(Program { protocol: Protocol::Ebb, chunks, pen_up: pen_up(&board).into_bytes() })
}

/// The command that raised the pen last, or a plain `SP,1`.
fn pen_up(board: &Board) -> String {
    format!("{}\r", board.pen_up.unwrap_or(Command::Pen { up: true, ms: 0 }))
}

/// What puts a board that was interrupted back at `start` with the pen up,
/// set up as the text set it up so far.
fn resume(board: &Board, start: Motors, profile: &DeviceProfile) -> Vec<u8> {
    let ebb = profile.ebb.as_ref().expect("cut checked the [ebb] table");
    let mut out = String::new();
    for &(param, value) in &board.servo {
        let _ = write!(out, "{}\r", Command::ServoConfig { param, value });
    }
    out.push_str(&pen_up(board));
    let home = start == Motors::default();
    if ebb.firmware.low_level_moves() || home {
        let _ = write!(out, "{}\r", Command::Home { rate: RESUME_STEP_RATE, to: (!home).then_some(start) });
    } else {
        // `HM` goes only home before 2.7.0: from there, planned travel.
        let _ = write!(out, "{}\r", Command::Home { rate: RESUME_STEP_RATE, to: None });
        let (travel, _) = limits(profile, ebb);
        for block in plan(&[Motors::default(), start], &travel) {
            for cmd in block_commands(&block, ebb.firmware) {
                let _ = write!(out, "{cmd}\r");
            }
        }
    }
    out.into_bytes()
}
