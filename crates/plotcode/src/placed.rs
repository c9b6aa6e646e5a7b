//! A drawing placed on a device: its strokes in checked, rounded device
//! coordinates, and the emitted file with where it went on the paper and its
//! plot time. Every emitter writes from these.

use crate::emit::EmitError;
use crate::placement::Placement;
use crate::profile::DeviceProfile;
use rayon::prelude::*;
use strokes::{DVec2, Drawing, LineKind, PlotStats};

/// An emitted file, how it was placed and how long it takes to plot.
#[derive(Clone, Debug, PartialEq)]
pub struct Emitted {
    /// The bytes for the device (ASCII).
    pub text: String,
    /// Where the drawing went on the paper; `placement.scaled_down()` must be
    /// reported to the user.
    pub placement: Placement,
    /// Plot-time estimate for this device, of the file as written: what the
    /// seconds of [`crate::cut`]'s chunks of `text` (a daemon's ETA) add up
    /// to. A stroke is a pen drop (a dash of the device's line type is one).
    pub stats: PlotStats,
}

/// What an emitter that handed its text to a [`crate::emit::Sink`] tells
/// besides: an [`Emitted`] without the text.
#[derive(Clone, Debug, PartialEq)]
pub struct Written {
    /// Where the drawing went on the paper; `placement.scaled_down()` must be
    /// reported to the user.
    pub placement: Placement,
    /// Plot-time estimate for this device, of the text as written.
    pub stats: PlotStats,
}

impl Emitted {
    /// The text collected from a [`crate::emit::Sink`], with what the
    /// emitter told besides.
    pub(crate) fn of(text: String, written: Written) -> Emitted {
        Emitted { text, placement: written.placement, stats: written.stats }
    }
}

/// One stroke ready to write: pen and device points (rounded,
/// consecutive duplicates removed; a single point is a dot).
pub(crate) struct DeviceStroke {
    pub pen: u32,
    /// Whether it is a hidden line (dashed, whole or as one of its dashes).
    pub hidden: bool,
    pub points: Vec<DVec2>,
}

/// Maps every polyline with at least two points to device coordinates rounded
/// to `decimals` places (0 for whole units), checking the paper's range. With
/// `cut_dashes`, a hidden line becomes its dashes ([`strokes::Dash::cut`], at
/// their length on paper), one stroke each, in the line's order.
pub(crate) fn device_strokes(
    drawing: &Drawing,
    profile: &DeviceProfile,
    placement: &Placement,
    decimals: usize,
    cut_dashes: bool,
) -> Result<Vec<DeviceStroke>, EmitError> {
    let paper = profile.paper_named(&placement.paper).expect("placement names a paper of this profile");
    let k = 10f64.powi(decimals as i32);
    let round = |v: f64| (v * k).round() / k;
    let device = |p: DVec2| {
        let d = placement.to_device(p);
        DVec2::new(round(d.x), round(d.y))
    };
    // Half a rounding step of slack: a coordinate that rounds onto the limit is in range.
    let slack = 0.5 / k;
    // Each polyline on its own, in parallel; the first error in drawing
    // order is the one reported, as a pass in order would.
    let per_polyline: Vec<Result<Vec<DeviceStroke>, EmitError>> = drawing
        .layers
        .iter()
        .flat_map(|layer| layer.polylines.iter().enumerate().map(move |(i, poly)| (layer, i, poly)))
        .collect::<Vec<_>>()
        .into_par_iter()
        .map(|(layer, i, poly)| {
            let hidden = layer.kind == LineKind::Hidden;
            if poly.points.len() < 2 {
                return Ok(Vec::new());
            }
            let mut points: Vec<DVec2> = Vec::with_capacity(poly.points.len());
            for (j, &p) in poly.points.iter().enumerate() {
                if !p.is_finite() {
                    return Err(EmitError::NonFinite { pen: layer.pen, polyline: i, point: j });
                }
                let d = device(p);
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
            if !(hidden && cut_dashes) {
                return Ok(vec![DeviceStroke { pen: layer.pen, hidden, points }]);
            }
            // Dashes lie on the line's segments, so inside the range too.
            Ok(drawing
                .hidden_dash
                .cut(&poly.points, placement.scale)
                .into_iter()
                .map(|dash| {
                    let mut points: Vec<DVec2> = Vec::with_capacity(dash.len());
                    for &p in &dash {
                        let d = device(p);
                        if points.last() != Some(&d) {
                            points.push(d);
                        }
                    }
                    DeviceStroke { pen: layer.pen, hidden, points }
                })
                .collect())
        })
        .collect();
    let mut out: Vec<DeviceStroke> = Vec::with_capacity(per_polyline.len());
    for strokes in per_polyline {
        for stroke in strokes? {
            // Strokes that meet once rounded to device units are drawn as
            // one: a pen lift there would travel nowhere, an ink dot and a
            // third of a second on a real plotter (issue 40).
            match out.last_mut() {
                Some(last) if (last.pen, last.hidden) == (stroke.pen, stroke.hidden) && last.points.last() == stroke.points.first() => {
                    last.points.extend_from_slice(&stroke.points[1..]);
                }
                _ => out.push(stroke),
            }
        }
    }
    Ok(out)
}
