//! A virtual pen plotter on a real pseudo-terminal.
//!
//! `plotsim` behaves as an HP 7475A (HP-GL) or a GRBL 1.1 board on the slave
//! side of a pty, with a finite input buffer that overflows the way real
//! hardware does, and faults on demand. The daemon's tests run against it.
#![deny(missing_docs)]
