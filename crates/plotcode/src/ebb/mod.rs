//! EBB (EiBotBoard) commands for the AxiDraw and its kin.
//!
//! An EBB takes no coordinates: it steps two motors by given counts at
//! given rates. So plotd plans the motion itself and writes each
//! constant-acceleration block as the exact step counts and the firmware's
//! rate arithmetic:
//! - [`Motors`]: the two step counters and the CoreXY mixing of an AxiDraw;
//! - [`plan()`]: a polyline in whole steps to constant-acceleration
//!   [`Block`]s (trapezoids, junction speeds from the cornering tolerance);
//! - [`lm`]: a block as one `LM` and how many 40 µs ticks the firmware
//!   takes over it, or as `SM` time slices before firmware 2.7.0.
//!
//! Sources: EggBot `docs/ebb.html` (firmware 3.x) and `docs/ebb2.html`
//! (2.8.1), and the release notes beside them; evil-mad/plotink
//! (`ebb_calc.py`); evil-mad/axidraw (`motion.py`); nornagon/saxi
//! (`planning.ts`, `ebb.ts`).

pub mod lm;
mod motors;
mod plan;

pub use motors::Motors;
pub use plan::{plan, Block, Limits};
