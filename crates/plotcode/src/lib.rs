//! HP-GL, G-code and SVG for pen plotters.
//!
//! `plotcode` turns an ordered [`hiddenline::Drawing`] into the exact bytes one
//! plotter model wants (device profiles say which), and reads such files back
//! into strokes. It does no I/O: callers hand it bytes and take bytes back.
#![deny(missing_docs)]

pub mod hpgl;
pub mod profile;

pub use profile::{DeviceProfile, Handshake, Origin, Paper, ProfileError, Protocol};
pub mod svg;
