//! The EiBotBoard personality: the controller of the AxiDraw, the EggBot and
//! their relatives, as firmware 2.8.1 or 3.0.2 behaves on its USB serial port.
//!
//! Sources, read to learn the behaviour (nothing is copied): the command
//! reference (evil-mad/EggBot `docs/ebb2.html` for 1.8.0..2.8.1,
//! `docs/ebb.html` for 3.x), the firmware source of both releases
//! (`EBB_firmware/app.X/source/`: `ebb.c`, `UBW.c`, `RCServo2.c`), the
//! firmware's own LM/LT regression data (`EBB_firmware/Analysis/
//! RegressionTests/`), plotink's `ebb_calc.py` and `ebb_serial.py`, the
//! AxiDraw driver's `axidraw_conf.py` and saxi's `ebb.ts`.
//!
//! The parts, one concept each: [`board`] (main loop, interrupts, blocking),
//! [`commands`], [`args`] and [`line`] (reading commands), [`reply`] (the
//! two syntaxes and the errors), [`motion`] (FIFO and stepper ISR),
//! [`rates`] (how SM/XM/HM/LM/LT become ISR rates), [`servo`] (RC servo
//! channels and power), [`pen`] (the servo as a mechanism), [`motors`]
//! (drivers, lost steps, geometry), [`trace`] (the record), [`clock`] (the
//! 40 µs tick and wall time), and [`device`] (the board as a simulator
//! device: wall time, faults, the record).

pub(crate) mod args;
pub(crate) mod board;
pub(crate) mod clock;
pub(crate) mod commands;
pub(crate) mod firmware;
pub(crate) mod line;
pub(crate) mod motion;
pub(crate) mod motors;
pub(crate) mod pen;
pub(crate) mod rates;
pub(crate) mod reply;
pub(crate) mod servo;
pub(crate) mod trace;

pub(crate) mod device;

pub(crate) use board::{NICKNAME_MAX, RX_CAPACITY};
pub use firmware::Firmware;
pub(crate) use pen::DEFAULT_CONTACT;

#[cfg(test)]
mod tests;
