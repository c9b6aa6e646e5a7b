//! What every emitter shares: options, the result, errors, and the mapping of a
//! drawing's polylines to checked device coordinates.

use crate::placement::Placement;
use crate::profile::{DeviceProfile, Protocol};
use strokes::{DVec2, Drawing, PlotStats, Polyline};

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
}

impl Default for EmitOptions {
    fn default() -> Self {
        EmitOptions { paper: None, margin_mm: 0.0, scale_to_fit: true, relative: false }
    }
}

/// An emitted file and how it was placed.
#[derive(Clone, Debug, PartialEq)]
pub struct Emitted {
    /// The bytes for the device (ASCII).
    pub text: String,
    /// Where the drawing went on the paper; `placement.scaled_down()` must be
    /// reported to the user.
    pub placement: Placement,
    /// Plot-time estimate for this device, in the emitted stroke order.
    pub stats: PlotStats,
}

/// Why a drawing cannot be emitted for a device.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum EmitError {
    /// The profile speaks another protocol than the emitter called.
    #[error("device {device:?} speaks {protocol:?}, not the format asked for")]
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
    /// Options that cannot work (such as a margin wider than the paper).
    #[error("{0}")]
    BadOptions(String),
}

/// Emits `drawing` in the profile's own protocol.
///
/// # Errors
/// See [`EmitError`].
pub fn emit(drawing: &Drawing, profile: &DeviceProfile, opts: &EmitOptions) -> Result<Emitted, EmitError> {
    match profile.protocol {
        Protocol::Hpgl => crate::hpgl::emit(drawing, profile, opts),
        Protocol::Gcode => crate::gcode::emit(drawing, profile, opts),
    }
}

/// One stroke ready to write: pen and device points (rounded,
/// consecutive duplicates removed; a single point is a dot).
pub(crate) struct DeviceStroke {
    pub pen: u32,
    pub points: Vec<DVec2>,
}

/// Maps every polyline with at least two points to device coordinates rounded
/// to `decimals` places (0 for whole units), checking the paper's range.
pub(crate) fn device_strokes(
    drawing: &Drawing,
    profile: &DeviceProfile,
    placement: &Placement,
    decimals: usize,
) -> Result<Vec<DeviceStroke>, EmitError> {
    let paper = profile.paper_named(&placement.paper).expect("placement names a paper of this profile");
    let k = 10f64.powi(decimals as i32);
    let round = |v: f64| (v * k).round() / k;
    // Half a rounding step of slack: a coordinate that rounds onto the limit is in range.
    let slack = 0.5 / k;
    let mut out = Vec::new();
    for layer in &drawing.layers {
        for (i, poly) in layer.polylines.iter().enumerate() {
            if poly.points.len() < 2 {
                continue;
            }
            let mut points: Vec<DVec2> = Vec::with_capacity(poly.points.len());
            for (j, &p) in poly.points.iter().enumerate() {
                if !p.is_finite() {
                    return Err(EmitError::NonFinite { pen: layer.pen, polyline: i, point: j });
                }
                let d = placement.to_device(p);
                let d = DVec2::new(round(d.x), round(d.y));
                let inside = |v: f64, r: [f64; 2]| v >= r[0] - slack && v <= r[1] + slack;
                if !inside(d.x, paper.x_range) || !inside(d.y, paper.y_range) {
                    return Err(EmitError::OutOfRange {
                        pen: layer.pen,
                        polyline: i,
                        point: j,
                        x: d.x,
                        y: d.y,
                        paper: paper.name.clone(),
                        x_range: paper.x_range,
                        y_range: paper.y_range,
                    });
                }
                if points.last() != Some(&d) {
                    points.push(d);
                }
            }
            out.push(DeviceStroke { pen: layer.pen, points });
        }
    }
    Ok(out)
}

/// Plot-time estimate of `drawing` as placed, from the device's lower-left
/// corner and back.
pub(crate) fn stats(drawing: &Drawing, profile: &DeviceProfile, placement: &Placement) -> PlotStats {
    let (w, h) = placement.page_mm();
    let mut placed = Drawing::new(w, h);
    for layer in &drawing.layers {
        let l = placed.layer_mut(layer.pen, layer.kind);
        for poly in &layer.polylines {
            l.polylines.push(Polyline::new(poly.points.iter().map(|&p| placement.to_area_mm(p)).collect()));
        }
    }
    profile.motion_model().plot_stats(&placed, DVec2::ZERO)
}
