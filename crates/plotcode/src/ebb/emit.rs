//! EBB output: a drawing as the commands an AxiDraw runs, and the drawing
//! as the AxiDraw plots it, on its sheet, for an SVG.
//!
//! ```text
//! SC,4,20641  SC,5,15248  SC,11,1618  SC,12,1079   servo: up and down positions, rates
//! SP,1,130                                          pen up (and wait until it is)
//! EM,1,1                                            motors on, 1/16 steps: home is (0, 0)
//! SL,129                                            the strokes after it are pen 1's
//! LM,0,1523,7862,0,-277,1430,3 ...                  pen-up travel to the stroke
//! SP,0,146                                          pen down
//! LM,... LM,...                                     the stroke, one LM a block
//! SP,1,130                                          pen up
//! ...                                               next strokes
//! LM,...                                            travel home
//! ```
//!
//! Every command ends with a carriage return. Below firmware 2.7.0 each
//! block is `SM` time slices instead of one `LM`. The same input gives the
//! same bytes.

use super::board::Board;
use super::command::{Command, MAX_PEN, PEN_MARK};
use super::lm::{sm_slices, Lm};
use super::motors::Motors;
use super::plan::{plan, Block, Limits};
use super::settings::EbbSettings;
use super::Firmware;
use crate::clock::Clock;
use crate::emit::{EmitError, EmitOptions};
use crate::placed::{device_strokes, DeviceStroke, Emitted};
use crate::placement::{place, Placement};
use crate::profile::{DeviceProfile, Protocol};
use std::fmt::Write as _;
use strokes::{DVec2, Drawing, LineKind, Polyline};

/// The commands that carry out `block` on `firmware`: one `LM`, or `SM`
/// slices before 2.7.0.
pub(crate) fn block_commands(block: &Block, firmware: Firmware) -> Vec<Command> {
    if firmware.low_level_moves() {
        vec![Command::Lm(Lm::of(block))]
    } else {
        sm_slices(block).into_iter().map(Command::Sm).collect()
    }
}

/// The planner's limits for pen-up travel and for drawing, in steps.
pub(crate) fn limits(profile: &DeviceProfile, ebb: &EbbSettings) -> (Limits, Limits) {
    let steps = 1.0 / profile.unit_mm;
    let cornering = ebb.cornering_mm * steps;
    let up = Limits { speed: profile.pen_up_speed_mm_s * steps, acceleration: ebb.pen_up_acceleration_mm_s2 * steps, cornering };
    let down = Limits { speed: profile.pen_down_speed_mm_s * steps, acceleration: ebb.pen_down_acceleration_mm_s2 * steps, cornering };
    (up, down)
}

/// The profile's `[ebb]` table, if it is an EBB profile.
fn settings(profile: &DeviceProfile) -> Result<&EbbSettings, EmitError> {
    match (&profile.ebb, profile.protocol) {
        (Some(s), Protocol::Ebb) => Ok(s),
        _ => Err(EmitError::WrongProtocol { device: profile.name.clone(), protocol: profile.protocol }),
    }
}

/// The drawing's strokes on the device, whole steps, a hidden line's dashes
/// each a stroke (the EBB has no line types), every pen one a program can
/// name.
fn strokes_on_device(drawing: &Drawing, profile: &DeviceProfile, opts: &EmitOptions) -> Result<(Placement, Vec<DeviceStroke>), EmitError> {
    settings(profile)?;
    let placement = place(drawing, profile, opts)?;
    let strokes = device_strokes(drawing, profile, &placement, 0, true)?;
    if let Some(s) = strokes.iter().find(|s| s.pen > MAX_PEN) {
        return Err(EmitError::PenOutOfRange { pen: s.pen, device: profile.name.clone(), max: MAX_PEN });
    }
    Ok((placement, strokes))
}

/// Emits `drawing` as EBB commands for `profile`, timed by the firmware's
/// own arithmetic as it writes (through `Board`, as a cutter of the file
/// times it).
///
/// # Errors
/// [`EmitError::WrongProtocol`] for a profile that is not an EBB's,
/// [`EmitError::PenOutOfRange`] for pens above [`MAX_PEN`], and the
/// placement and range errors of [`EmitError`].
pub fn emit(drawing: &Drawing, profile: &DeviceProfile, opts: &EmitOptions) -> Result<Emitted, EmitError> {
    let ebb = settings(profile)?;
    let (placement, strokes) = strokes_on_device(drawing, profile, opts)?;
    let (travel, draw) = limits(profile, ebb);
    let servo = &ebb.servo;
    let (raise, lower) = (Command::Pen { up: true, ms: servo.raise_ms() }, Command::Pen { up: false, ms: servo.lower_ms() });
    let mut w = Writer { out: String::new(), board: Board::default(), clock: Clock::new(profile), firmware: ebb.firmware };
    for (param, value) in [(4, servo.up_position()), (5, servo.down_position()), (11, servo.raise_rate()), (12, servo.lower_rate())] {
        w.run(Command::ServoConfig { param, value })?;
    }
    w.run(raise)?;
    w.run(Command::EnableMotors { mode: ebb.microstep_mode, mode2: ebb.microstep_mode })?;
    let mut pen = None;
    for s in &strokes {
        if pen != Some(s.pen) {
            w.run(Command::PenNumber(PEN_MARK + s.pen))?;
            pen = Some(s.pen);
        }
        let points: Vec<Motors> = s.points.iter().map(|&p| Motors::nearest(p)).collect();
        w.moves(&[w.board.at, points[0]], &travel)?;
        w.run(lower)?;
        w.moves(&points, &draw)?;
        w.run(raise)?;
    }
    w.moves(&[w.board.at, Motors::default()], &travel)?;
    Ok(Emitted { text: w.out, placement, stats: w.clock.stats() })
}

/// The text written so far, the board's state and the plot time.
struct Writer {
    out: String,
    board: Board,
    clock: Clock,
    firmware: Firmware,
}

impl Writer {
    fn run(&mut self, cmd: Command) -> Result<(), EmitError> {
        self.board.run(&cmd, &mut self.clock).map_err(|e| EmitError::BadOptions(format!("{cmd}: {e}")))?;
        let _ = write!(self.out, "{cmd}\r");
        Ok(())
    }

    fn moves(&mut self, points: &[Motors], limits: &Limits) -> Result<(), EmitError> {
        for block in plan(points, limits) {
            for cmd in block_commands(&block, self.firmware) {
                self.run(cmd)?;
            }
        }
        Ok(())
    }
}

/// The drawing as `profile`'s EBB plots it, on its sheet: the strokes
/// [`emit`] writes (whole steps, hidden lines as their dashes), in
/// millimetres on a page the size of the paper, whose top-left corner is
/// the pen's home. Written as SVG, it is a file the AxiDraw software
/// plots the same way; each pen's strokes are one layer.
///
/// # Errors
/// As [`emit`].
pub fn on_sheet(drawing: &Drawing, profile: &DeviceProfile, opts: &EmitOptions) -> Result<(Drawing, Placement), EmitError> {
    let (placement, strokes) = strokes_on_device(drawing, profile, opts)?;
    let paper = profile.paper_named(&placement.paper).expect("placement names a paper of this profile");
    let sheet = Placement::true_size(profile, paper);
    let (w, h) = sheet.page_mm();
    let u = profile.unit_mm;
    // Device y grows down the sheet from home; the page's grows up.
    let page = |p: DVec2| DVec2::new((p.x - paper.x_range[0]) * u, h - (p.y - paper.y_range[0]) * u);
    let mut out = Drawing::new(w, h);
    for s in &strokes {
        let mut points: Vec<DVec2> = s.points.iter().map(|&p| page(p)).collect();
        if points.len() == 1 {
            points.push(points[0]);
        }
        out.layer_mut(s.pen, LineKind::Visible).polylines.push(Polyline::new(points));
    }
    Ok((out, placement))
}
