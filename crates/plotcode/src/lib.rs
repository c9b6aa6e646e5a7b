//! HP-GL, G-code, EBB (AxiDraw) and SVG for pen plotters.
//!
//! `plotcode` turns an ordered [`strokes::Drawing`] (page millimetres, origin
//! bottom-left, y up) into the exact bytes one plotter model wants, and reads
//! such files back into strokes. It does no I/O: callers hand it bytes and take
//! bytes back; a user's profile file is read by the caller and given to
//! [`DeviceProfile::from_toml`]. It does not reorder strokes (that is
//! `strokes`) and does not talk to ports (that is `plotd`).
//!
//! The main pieces:
//! - [`DeviceProfile`]: one plotter model (units, papers, speeds, buffer,
//!   handshake, G-code templates, an EBB's motion and servo); ten are built
//!   in ([`DeviceProfile::builtin`]).
//! - [`emit`] (or [`hpgl::emit`], [`gcode::emit`], [`ebb::emit`]): drawing -> device text, with
//!   the page fitted to the paper ([`Placement`]) and a plot-time estimate;
//!   [`emit_to`] hands the text on piece by piece as it is written.
//! - [`ebb`]: the AxiDraw's EiBotBoard: a motion planner whose blocks are
//!   written as the exact step counts and rates of `LM` commands.
//! - [`cut`]: an HP-GL or G-code file (submitted, or emitted for a job), or
//!   the EBB text emitted for a job, ->
//!   [`Program`]: per-stroke [`Chunk`]s a daemon streams and checkpoints,
//!   each with its resume prefix and plot time, read with the crate's own
//!   lexer and line parser. The chunks of an emitted file add up to its
//!   estimate: both are timed by one clock run along the commands.
//! - [`control`]: what a host sends a device besides the job (HP-GL
//!   device-control and output instructions, GRBL's real-time and `$`
//!   commands, the marker after every chunk), as typed operations; and
//!   [`answer`]: what a device says back (HP-GL output instructions and
//!   device-control replies, GRBL's `ok`/`error:`/`ALARM:`/status lines), as
//!   typed values. Together, every byte a daemon exchanges with a device.
//! - [`hpgl::Lexer`] (incremental: feed bytes, get instructions) and
//!   [`hpgl::Interpreter`] / [`hpgl::parse`]; [`gcode::parse_line`] and
//!   [`gcode::parse`]: device text -> [`Plot`] (strokes per pen, device units).
//! - [`svg::write`] (and [`svg::write_to`], piece by piece): drawing -> SVG
//!   with Inkscape layers.
//!
//! ```
//! use strokes::{DVec2, Drawing, LineKind, Polyline};
//! let mut d = Drawing::new(297.0, 210.0);
//! d.layer_mut(1, LineKind::Visible)
//!     .polylines
//!     .push(Polyline::new(vec![DVec2::new(20.0, 20.0), DVec2::new(100.0, 80.0)]));
//! let hp = plotcode::DeviceProfile::builtin("hp7475a").unwrap();
//! let out = plotcode::emit(&d, &hp, &plotcode::EmitOptions::default()).unwrap();
//! assert!(out.text.starts_with("IN;"));
//! let back = plotcode::hpgl::parse(out.text.as_bytes()).unwrap();
//! assert_eq!(back.strokes.len(), 1);
//! ```
#![deny(missing_docs)]

pub mod answer;
pub mod control;
pub mod ebb;
pub mod emit;
pub mod gcode;
pub mod hpgl;
pub mod pens;
pub mod placed;
pub mod placement;
pub mod plot;
pub mod profile;
pub mod program;
pub mod svg;
pub mod svg_import;
mod svg_text;

mod clock;
mod decimal;

pub use emit::{EmitError, EmitOptions, Sink};
pub use pens::{PenSetting, PenSettings};
pub use placed::{Emitted, Written};
pub use placement::Placement;
pub use plot::{Location, Plot, Stroke, Warning};
pub use profile::{DeviceProfile, Handshake, Origin, Paper, ProfileError, Protocol};
pub use program::{Chunk, CutError, PenAt, Program};

/// Emits `drawing` in the profile's own protocol.
///
/// # Errors
/// See [`EmitError`].
pub fn emit(drawing: &strokes::Drawing, profile: &DeviceProfile, opts: &EmitOptions) -> Result<Emitted, EmitError> {
    match profile.protocol {
        Protocol::Hpgl => hpgl::emit(drawing, profile, opts),
        Protocol::Gcode => gcode::emit(drawing, profile, opts),
        Protocol::Ebb => ebb::emit(drawing, profile, opts),
    }
}

/// [`emit()`], the text handed to `sink` piece by piece as it is written
/// (HP-GL as it is formatted, G-code and EBB whole); nothing reaches `sink` when the
/// drawing cannot be emitted.
///
/// # Errors
/// See [`EmitError`].
pub fn emit_to(drawing: &strokes::Drawing, profile: &DeviceProfile, opts: &EmitOptions, sink: &mut Sink<'_>) -> Result<Written, EmitError> {
    match profile.protocol {
        Protocol::Hpgl => hpgl::emit_to(drawing, profile, opts, sink),
        Protocol::Gcode | Protocol::Ebb => {
            let e = emit(drawing, profile, opts)?;
            sink(e.text);
            Ok(Written { placement: e.placement, stats: e.stats })
        }
    }
}

/// Cuts a submitted command text in the profile's protocol into per-stroke
/// chunks; plot times come from the profile's motion model.
///
/// # Errors
/// [`CutError`] at the first byte that cannot be read.
pub fn cut(text: &[u8], profile: &DeviceProfile) -> Result<Program, CutError> {
    match profile.protocol {
        Protocol::Hpgl => hpgl::cut(text, profile),
        Protocol::Gcode => gcode::cut(text, profile),
        Protocol::Ebb => ebb::cut(text, profile),
    }
}
