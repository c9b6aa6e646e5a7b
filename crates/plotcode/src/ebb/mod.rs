//! EBB (EiBotBoard) commands for the AxiDraw and its kin: device settings,
//! the motion planner and program text.
//!
//! An EBB takes no coordinates: it steps two motors by given counts at
//! given rates. So plotd plans the motion itself and writes each
//! constant-acceleration block as the exact step counts and the firmware's
//! rate arithmetic:
//! - [`EbbSettings`] (a profile's `[ebb]` table: firmware, step mode,
//!   accelerations, cornering, the pen servo) and [`Firmware`];
//! - [`Motors`]: the two step counters and the CoreXY mixing of an AxiDraw;
//! - [`plan()`]: a polyline in whole steps to constant-acceleration
//!   [`Block`]s (trapezoids, junction speeds from the cornering tolerance);
//! - [`lm`]: a block as one `LM` and how many 40 µs ticks the firmware
//!   takes over it, or as `SM` time slices before firmware 2.7.0;
//! - [`emit()`] (drawing to program text, timed by the same arithmetic),
//!   [`on_sheet`] (the drawing as the AxiDraw plots it, for an SVG),
//!   [`cut()`] (program text to per-stroke chunks with resume prefixes and
//!   the planner's durations) and [`parse()`] (program text to strokes);
//! - [`Command`]: the program vocabulary, written and read; the board's
//!   queries and controls are [`crate::control::ebb`], its answers
//!   [`crate::answer::ebb`].
//!
//! Sources: EggBot `docs/ebb.html` (firmware 3.x) and `docs/ebb2.html`
//! (2.8.1), and the release notes beside them; evil-mad/plotink
//! (`ebb_calc.py`, `ebb_motion.py`); evil-mad/axidraw (`axidraw_conf.py`,
//! `motion.py`, `pen_handling.py`); nornagon/saxi (`planning.ts`,
//! `ebb.ts`).

mod board;
pub mod command;
mod cut;
mod emit;
mod firmware;
pub mod lm;
mod motors;
mod plan;
mod settings;

pub use command::{Command, MAX_COMMAND_BYTES, MAX_PEN};
pub use cut::{cut, parse, EbbError, RESUME_STEP_RATE};
pub use emit::{emit, on_sheet};
pub use firmware::{BadVersion, Firmware, OLDEST_FIRMWARE};
pub use motors::Motors;
pub use plan::{plan, Block, Limits};
pub use settings::{EbbSettings, Servo};
