//! What every emitter is asked, where its text goes and how it can fail:
//! [`EmitOptions`], [`Sink`] and [`EmitError`]. The dispatch, [`crate::emit()`], is at the crate root; the
//! drawing placed on the device, which the emitters write, is
//! [`crate::placed`].

use crate::profile::Protocol;

/// Where a writer hands its text, piece by piece and in order, as it goes
/// (the `*_to` functions): a caller can write each piece to a file while the
/// next is formatted, and never holds the whole text. A large drawing's file
/// takes about as long to write as to format.
pub type Sink<'a> = dyn FnMut(String) + Send + 'a;

/// How to emit.
#[derive(Clone, Debug, PartialEq)]
pub struct EmitOptions {
    /// Paper to plot on; chosen from the drawing's page size when `None`.
    pub paper: Option<String>,
    /// Extra margin inside the plotting area (hard-clip limits), mm.
    pub margin_mm: f64,
    /// Scale a drawing down to fit the plotting area (else an oversized drawing
    /// is a [`EmitError::OutOfRange`] error).
    pub scale_to_fit: bool,
    /// HP-GL: relative coordinates after the first move (`PR`; smaller files).
    pub relative: bool,
    /// G-code for a one-pen device: stop the program at each pen change
    /// (`M0` with a comment naming the pen), so that a sender waits for the
    /// human. The daemon turns it off: it pauses the job itself, and a board
    /// held by `M0` would not run the lines it is sent after `pen-changed`.
    pub pen_change_pauses: bool,
    /// The plotter's pen table: speed and force per pen, where they differ
    /// from the profile's.
    pub pens: crate::pens::PenSettings,
}

impl Default for EmitOptions {
    fn default() -> Self {
        EmitOptions {
            paper: None,
            margin_mm: 0.0,
            scale_to_fit: true,
            relative: false,
            pen_change_pauses: true,
            pens: crate::pens::PenSettings::new(),
        }
    }
}

/// Why a drawing cannot be emitted for a device.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum EmitError {
    /// The profile speaks another protocol than the emitter called.
    #[error("device {device:?} speaks {protocol}, not the format asked for")]
    WrongProtocol {
        /// The profile's name.
        device: String,
        /// Its protocol.
        protocol: Protocol,
    },
    /// The paper asked for is not in the profile.
    #[error("device {device:?} has no paper {name:?}; its papers: {}", known.join(", "))]
    UnknownPaper {
        /// The name asked for.
        name: String,
        /// The profile's name.
        device: String,
        /// The profile's papers.
        known: Vec<String>,
    },
    /// A coordinate is NaN or infinite.
    #[error("pen {pen}, polyline {polyline}, point {point}: coordinate is not a finite number")]
    NonFinite {
        /// Pen of the layer.
        pen: u32,
        /// Index of the polyline in its layer.
        polyline: usize,
        /// Index of the point in the polyline.
        point: usize,
    },
    /// A point lands outside the device's range on the chosen paper.
    #[error(
        "pen {pen}, polyline {polyline}, point {point}: device coordinate ({x}, {y}) is outside \
         the range of paper {paper} (x {}..{}, y {}..{})",
        x_range[0], x_range[1], y_range[0], y_range[1]
    )]
    OutOfRange {
        /// Pen of the layer.
        pen: u32,
        /// Index of the polyline in its layer.
        polyline: usize,
        /// Index of the point in the polyline.
        point: usize,
        /// Device x.
        x: f64,
        /// Device y.
        y: f64,
        /// The paper.
        paper: String,
        /// Its x range.
        x_range: [f64; 2],
        /// Its y range.
        y_range: [f64; 2],
    },
    /// An HP-GL layer uses a pen the device does not have.
    #[error("pen {pen} is used but device {device:?} has {pens} pens")]
    NoSuchPen {
        /// The pen asked for.
        pen: u32,
        /// The profile's name.
        device: String,
        /// How many pens it has.
        pens: u32,
    },
    /// A pen number the device's text cannot carry (an EBB program names
    /// pens 0 to 127).
    #[error("pen {pen} is used but a program for device {device:?} can name pens 0 to {max}")]
    PenOutOfRange {
        /// The pen asked for.
        pen: u32,
        /// The profile's name.
        device: String,
        /// The highest pen number.
        max: u32,
    },
    /// Options that cannot work (such as a margin wider than the paper).
    #[error("{0}")]
    BadOptions(String),
}
