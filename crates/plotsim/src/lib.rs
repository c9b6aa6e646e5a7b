//! A virtual pen plotter on a real pseudo-terminal.
//!
//! `plotsim` behaves as an HP 7475A (HP-GL), a GRBL 1.1 board or an
//! EiBotBoard (the AxiDraw's controller, firmware 2.8.1 or 3.0.2) on the
//! slave side of a pty, with the input buffering of the real device (a
//! serial buffer that overflows, a USB board that holds the host off), and
//! faults on demand. The daemon's tests run against it,
//! in-process through [`Simulator`] or as the `plotsim` binary.
//!
//! It is not a plotter-drawing library: it records what the pen did (strokes
//! per pen in device units, lost bytes, errors, faults, plot time) as a
//! [`Record`], exportable as JSON, SVG and PNG ([`export`]).
//!
//! The parts:
//! - [`SimConfig`]: personality, buffer size, baud, speed scale, link path,
//!   and the [`Quirk`]s of real firmware (HP-GL clones, GRBL boards).
//! - [`Simulator`]: the running device on its own thread; slave path, faults
//!   (unplug, stall, power-cycle, reset, park, paper lever, garbage reply,
//!   failing instruction; EBB motor power loss and PRG button), waits on
//!   device state, the record, shutdown.
//! - `hpgl`, `grbl` and `ebb`: the personalities, plain state machines
//!   driven by bytes and a clock (the EBB's is its own tick count, moved by
//!   hand in its tests).
//! - [`control`] and [`cli`]: the control-socket commands and the binary.
//!
//! ```no_run
//! use plotsim::{SimConfig, Simulator};
//! use std::time::Duration;
//! let sim = Simulator::start(SimConfig::hp7475a().with_speed_scale(0.0)).unwrap();
//! let port = sim.slave_path().unwrap();
//! std::fs::write(&port, b"IN;SP1;PD1000,1000;PU;").unwrap();
//! sim.wait_received(22, Duration::from_secs(5)).unwrap();
//! sim.wait_idle(Duration::from_secs(5)).unwrap();
//! assert_eq!(sim.record().strokes.len(), 1);
//! ```
#![deny(missing_docs)]

pub mod cli;
pub mod config;
pub mod control;
mod device;
mod ebb;
mod error;
pub mod export;
mod grbl;
mod hpgl;
mod open_watch;
mod personality;
mod pty;
mod quirks;
pub mod record;
mod simulator;

pub use config::{EbbOptions, Firmware, GrblPen, Paper, Personality, SimConfig};
pub use device::DeviceStatus;
pub use error::SimError;
pub use quirks::Quirk;
pub use record::{ErrorEvent, FaultEvent, Record, Stroke};
pub use simulator::{Simulator, Status, MAX_FAULT};
