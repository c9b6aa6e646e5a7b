//! Place-name labels: single-stroke text set in 3-D beside each symbol,
//! lying on the ground in front of it or standing upright above its top,
//! turned to face the camera horizontally. Labels are free lines: hidden by
//! every face in front of them, hiding nothing.
//!
//! The glyphs come from the single-stroke font (`crate::font`, owned by
//! the grid work); this module only places text already shaped into strokes.

use super::spec::LabelPlacement;
use crate::builder::ModelBuilder;
use glam::{DVec2, DVec3};
use hiddenline::camera::Camera;

/// Text shaped into strokes, in em units: baseline at y = 0, cap height 1,
/// starting at x = 0 and `advance` wide.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TextStrokes {
    /// Pen-down polylines.
    pub lines: Vec<Vec<DVec2>>,
    /// Total advance width.
    pub advance: f64,
}

/// `text` in the single-stroke Hershey font ([`crate::font`]), in the em units
/// of [`TextStrokes`]: the font laid out at cap height 1 on the plane z = 0.
#[must_use]
pub fn hershey(text: &str) -> TextStrokes {
    let unit = crate::font::TextPlacement::new(DVec3::ZERO, DVec3::X, DVec3::Y, 1.0);
    let lines =
        crate::font::text_polylines(text, &unit).into_iter().map(|line| line.into_iter().map(|p| DVec2::new(p.x, p.y)).collect()).collect();
    TextStrokes { lines, advance: crate::font::text_width(text, 1.0) }
}

/// Where and how large one label is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LabelFrame {
    /// Ground point of the place (symbol base centre), world space.
    pub anchor: DVec3,
    /// Ground or above.
    pub placement: LabelPlacement,
    /// Cap height, world units.
    pub height: f64,
    /// Space between symbol and text, world units.
    pub gap: f64,
    /// Half the symbol's footprint width, world units.
    pub half_width: f64,
    /// The symbol's height this frame, world units.
    pub symbol_height: f64,
}

/// Horizontal unit vectors (right, forward) of the view: screen-right and
/// away from the viewer, both in the ground plane. A view straight down uses
/// the camera's `up` as forward.
#[must_use]
pub fn ground_axes(camera: &Camera) -> (DVec3, DVec3) {
    let flat = |v: DVec3| DVec3::new(v.x, v.y, 0.0).try_normalize();
    let forward = flat(camera.direction()).or_else(|| flat(camera.up)).unwrap_or(DVec3::Y);
    (forward.cross(DVec3::Z), forward)
}

/// Adds `text` as free lines placed by `frame`, facing `camera`.
pub fn place(text: &TextStrokes, frame: &LabelFrame, camera: &Camera, pen: u32, out: &mut ModelBuilder) {
    let (right, forward) = ground_axes(camera);
    let h = frame.height;
    let x0 = -0.5 * text.advance * h;
    // Origin of the text's baseline, and the world direction of its "up".
    let (origin, up) = match frame.placement {
        LabelPlacement::Above => (frame.anchor + DVec3::Z * (frame.symbol_height + frame.gap), DVec3::Z),
        // In front of the footprint (towards the viewer), reading away from
        // them; the cap line nearest the symbol.
        LabelPlacement::Ground => (frame.anchor - forward * (frame.half_width + frame.gap + h), forward),
    };
    let at = |p: DVec2| origin + right * (x0 + p.x * h) + up * (p.y * h);
    for line in &text.lines {
        for w in line.windows(2) {
            out.add_edge(at(w[0]), at(w[1]), pen, &[]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use hiddenline::camera::Projection;

    fn cam(eye: [f64; 3]) -> Camera {
        Camera::new(DVec3::from(eye), DVec3::ZERO, DVec3::Z, Projection::Perspective { fov_deg: 30.0 }).unwrap()
    }

    /// A one-em square "glyph".
    fn square() -> TextStrokes {
        let pts = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0), (0.0, 0.0)];
        TextStrokes { lines: vec![pts.iter().map(|&(x, y)| DVec2::new(x, y)).collect()], advance: 1.0 }
    }

    #[test]
    fn axes_face_the_camera() {
        let (r, f) = ground_axes(&cam([0.0, -10.0, 5.0]));
        assert!((r - DVec3::X).length() < 1e-12 && (f - DVec3::Y).length() < 1e-12);
        let (r, f) = ground_axes(&cam([10.0, 0.0, 5.0]));
        assert!((r - DVec3::Y).length() < 1e-12 && (f + DVec3::X).length() < 1e-12);
        // Straight down: up decides.
        let c = Camera::new(DVec3::new(0.0, 0.0, 10.0), DVec3::ZERO, DVec3::Y, Projection::Perspective { fov_deg: 30.0 }).unwrap();
        let (r, f) = ground_axes(&c);
        assert!((r - DVec3::X).length() < 1e-12 && (f - DVec3::Y).length() < 1e-12);
    }

    #[test]
    fn above_and_ground_positions() {
        let c = cam([0.0, -10.0, 5.0]);
        let frame = LabelFrame {
            anchor: DVec3::new(2.0, 3.0, 0.0),
            placement: LabelPlacement::Above,
            height: 0.5,
            gap: 0.1,
            half_width: 0.4,
            symbol_height: 2.0,
        };
        let mut b = ModelBuilder::new();
        place(&square(), &frame, &c, 4, &mut b);
        let m = b.finish();
        assert_eq!(m.edges.len(), 4);
        let pts: Vec<DVec3> = m.edges.iter().flat_map(|e| [e.a, e.b]).collect();
        // Upright, centred on the place, from 2.1 to 2.6 high, facing -y.
        assert!(pts.iter().all(|p| p.y == 3.0 && (p.x - 2.0).abs() <= 0.25 + 1e-12));
        assert!(pts.iter().any(|p| (p.z - 2.1).abs() < 1e-12) && pts.iter().any(|p| (p.z - 2.6).abs() < 1e-12));
        assert!(m.edges.iter().all(|e| e.pen == 4 && e.faces.is_empty()));
        let mut b = ModelBuilder::new();
        place(&square(), &LabelFrame { placement: LabelPlacement::Ground, ..frame }, &c, 1, &mut b);
        let pts: Vec<DVec3> = b.finish().edges.iter().flat_map(|e| [e.a, e.b]).collect();
        // Flat on the ground, in front of the footprint (y < 3 - 0.4 - 0.1).
        assert!(pts.iter().all(|p| p.z == 0.0 && p.y <= 2.5 + 1e-12 && p.y >= 2.0 - 1e-12));
    }
}
