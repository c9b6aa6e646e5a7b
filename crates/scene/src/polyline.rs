//! `[[polyline]]`: free 3-D lines, hidden by faces, hiding nothing.

use crate::builder::ModelBuilder;
use crate::mesh::default_pen;
use crate::points::{world_points, FieldError};
use crate::transform::Transform;
use glam::DVec3;
use serde::Deserialize;

/// A `[[polyline]]` table as written in the scene file.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PolylineSpec {
    /// At least two points, drawn in order.
    pub points: Vec<[f64; 3]>,
    /// Placement in the world.
    #[serde(default)]
    pub transform: Option<Transform>,
    /// Pen.
    #[serde(default = "default_pen")]
    pub pen: u32,
}

/// A validated free polyline in world space.
#[derive(Clone, Debug, PartialEq)]
pub struct Polyline3 {
    /// Vertices in drawing order.
    pub points: Vec<DVec3>,
    /// Pen.
    pub pen: u32,
}

impl Polyline3 {
    /// Validates a spec: finite coordinates, at least two points.
    ///
    /// # Errors
    /// The offending sub-field (`points[3]`) and what is wrong.
    pub fn from_spec(spec: &PolylineSpec) -> Result<Polyline3, FieldError> {
        let m = spec.transform.unwrap_or_default().matrix();
        Ok(Polyline3 { points: world_points("points", &spec.points, &m, 2)?, pen: spec.pen })
    }

    /// Adds its segments to `out`, lying on no face.
    pub fn lower(&self, out: &mut ModelBuilder) {
        for w in self.points.windows(2) {
            out.add_edge(w[0], w[1], self.pen, &[]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn segments_lie_on_no_face() {
        let spec = PolylineSpec { points: vec![[0., 0., 0.], [1., 0., 0.], [1., 0., 0.], [1., 1., 0.]], transform: None, pen: 3 };
        let p = Polyline3::from_spec(&spec).unwrap();
        let mut b = ModelBuilder::new();
        p.lower(&mut b);
        let m = b.finish();
        assert_eq!(m.edges.len(), 2, "the zero-length segment is dropped");
        assert!(m.edges.iter().all(|e| e.faces.is_empty() && e.pen == 3));
    }

    #[test]
    fn one_point_is_too_few() {
        let spec = PolylineSpec { points: vec![[0., 0., 0.]], transform: None, pen: 1 };
        assert!(Polyline3::from_spec(&spec).is_err());
    }
}
