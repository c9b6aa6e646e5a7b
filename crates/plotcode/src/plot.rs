//! What a parsed HP-GL or G-code file draws: strokes per pen in device units.

use crate::placement::Placement;
use crate::profile::{DeviceProfile, Paper};
use std::fmt;
use strokes::{DVec2, Drawing, LineKind, Polyline};

/// The strokes a command file draws, in the order the device draws them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Plot {
    /// Pen-down strokes in drawing order.
    pub strokes: Vec<Stroke>,
    /// Things the reader skipped or did not understand, in file order.
    pub warnings: Vec<Warning>,
}

/// One pen-down stroke.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Stroke {
    /// The pen that drew it (0 when the file drew without selecting a pen).
    pub pen: u32,
    /// Points in device units; a single point is a dot.
    pub points: Vec<DVec2>,
}

/// Something skipped while reading a file.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Warning {
    /// Where in the file.
    pub at: Location,
    /// What was skipped and why.
    pub message: String,
}

/// A place in a command file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Location {
    /// Byte offset (HP-GL).
    Byte(u64),
    /// 1-based line number (G-code).
    Line(usize),
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Location::Byte(b) => write!(f, "byte {b}"),
            Location::Line(l) => write!(f, "line {l}"),
        }
    }
}

impl fmt::Display for Warning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.at, self.message)
    }
}

impl Plot {
    /// The pens used, in order of first use.
    #[must_use]
    pub fn pens(&self) -> Vec<u32> {
        let mut pens = Vec::new();
        for s in &self.strokes {
            if !pens.contains(&s.pen) {
                pens.push(s.pen);
            }
        }
        pens
    }

    /// The drawing on `paper` of `profile` (its default paper when `None`),
    /// the inverse of emitting at true size without rotation: re-emitting the
    /// result for the same device and paper gives the same device coordinates.
    /// Pen 0 (drawing without a selected pen) becomes pen 1; one-point strokes
    /// (dots) become zero-length segments so they survive as polylines.
    #[must_use]
    pub fn to_drawing(&self, profile: &DeviceProfile, paper: Option<&Paper>) -> Drawing {
        let paper = paper.unwrap_or_else(|| profile.paper_named(&profile.default_paper).expect("validated: default paper exists"));
        let placement = Placement::true_size(profile, paper);
        let (w, h) = placement.page_mm();
        let mut drawing = Drawing::new(w, h);
        for s in &self.strokes {
            let mut points: Vec<DVec2> = s.points.iter().map(|&p| placement.to_page(p)).collect();
            if points.len() == 1 {
                points.push(points[0]);
            }
            drawing.layer_mut(s.pen.max(1), LineKind::Visible).polylines.push(Polyline::new(points));
        }
        drawing
    }
}
