//! `[[polygon]]`: one planar polygon given inline, convex or concave, with
//! optional holes (Hedgley's faces with internal boundaries).

use crate::builder::ModelBuilder;
use crate::error::SceneErrorKind;
use crate::geometry::RingFit;
use crate::mesh::default_pen;
use crate::points::{world_points, FieldError};
use crate::transform::Transform;
use glam::DVec3;
use hiddenline::model::Face;
use serde::Deserialize;

/// A `[[polygon]]` table as written in the scene file.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PolygonSpec {
    /// Outer boundary, at least three points, implicitly closed.
    pub outer: Vec<[f64; 3]>,
    /// Holes, each a closed ring of at least three points.
    #[serde(default)]
    pub holes: Vec<Vec<[f64; 3]>>,
    /// Placement in the world.
    #[serde(default)]
    pub transform: Option<Transform>,
    /// Pen for its edges.
    #[serde(default = "default_pen")]
    pub pen: u32,
}

/// A validated planar polygon in world space.
#[derive(Clone, Debug, PartialEq)]
pub struct Polygon {
    /// Outer boundary.
    pub outer: Vec<DVec3>,
    /// Holes.
    pub holes: Vec<Vec<DVec3>>,
    /// Pen.
    pub pen: u32,
}

impl Polygon {
    /// Validates a spec: finite coordinates, enough points, planar within
    /// [`crate::tolerance::PLANARITY_REL`] (holes on the outer ring's plane).
    /// `Ok(None)` for a degenerate (zero-area) polygon, which is skipped.
    ///
    /// # Errors
    /// The offending sub-field (`outer[2]`, `holes[0]`) and what is wrong.
    pub fn from_spec(spec: &PolygonSpec) -> Result<Option<Polygon>, FieldError> {
        let m = spec.transform.unwrap_or_default().matrix();
        let outer = world_points("outer", &spec.outer, &m, 3)?;
        let holes =
            spec.holes.iter().enumerate().map(|(i, h)| world_points(&format!("holes[{i}]"), h, &m, 3)).collect::<Result<Vec<_>, _>>()?;
        let fit = RingFit::of(&outer);
        let Some(normal) = fit.normal() else {
            return Ok(None);
        };
        let centroid = outer.iter().copied().sum::<DVec3>() / outer.len() as f64;
        let tolerance = fit.planarity_tolerance();
        let off = |pts: &[DVec3]| pts.iter().map(|p| (*p - centroid).dot(normal).abs()).fold(0.0, f64::max);
        let deviation = off(&outer);
        if deviation > tolerance {
            return Err(("outer".into(), SceneErrorKind::NonPlanar { deviation, tolerance }));
        }
        for (i, h) in holes.iter().enumerate() {
            let deviation = off(h);
            if deviation > tolerance {
                return Err((format!("holes[{i}]"), SceneErrorKind::NonPlanar { deviation, tolerance }));
            }
        }
        Ok(Some(Polygon { outer, holes, pen: spec.pen }))
    }

    /// Adds the polygon's face and its edges (outer ring and holes) to `out`.
    pub fn lower(&self, out: &mut ModelBuilder) {
        let f = out.add_face(Face { outer: self.outer.clone(), holes: self.holes.clone(), pen: self.pen, outward: false });
        for ring in std::iter::once(&self.outer).chain(&self.holes) {
            for (i, &a) in ring.iter().enumerate() {
                out.add_edge(a, ring[(i + 1) % ring.len()], self.pen, &[f]);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(outer: Vec<[f64; 3]>, holes: Vec<Vec<[f64; 3]>>) -> PolygonSpec {
        PolygonSpec { outer, holes, transform: None, pen: 1 }
    }

    #[test]
    fn square_with_a_hole_lowers_to_one_face_eight_edges() {
        let s = spec(
            vec![[0., 0., 0.], [4., 0., 0.], [4., 4., 0.], [0., 4., 0.]],
            vec![vec![[1., 1., 0.], [2., 1., 0.], [2., 2., 0.], [1., 2., 0.]]],
        );
        let p = Polygon::from_spec(&s).unwrap().unwrap();
        let mut b = ModelBuilder::new();
        p.lower(&mut b);
        let m = b.finish();
        assert_eq!(m.faces.len(), 1);
        assert_eq!(m.faces[0].holes.len(), 1);
        assert_eq!(m.edges.len(), 8);
        assert!(m.edges.iter().all(|e| e.faces == vec![0]));
    }

    #[test]
    fn non_planar_outer_or_hole_is_an_error() {
        let e = Polygon::from_spec(&spec(vec![[0., 0., 0.], [1., 0., 0.], [1., 1., 0.2], [0., 1., 0.]], vec![])).unwrap_err();
        assert_eq!(e.0, "outer");
        assert!(matches!(e.1, SceneErrorKind::NonPlanar { .. }));
        let e = Polygon::from_spec(&spec(
            vec![[0., 0., 0.], [4., 0., 0.], [4., 4., 0.], [0., 4., 0.]],
            vec![vec![[1., 1., 0.], [2., 1., 0.], [2., 2., 1.]]],
        ))
        .unwrap_err();
        assert_eq!(e.0, "holes[0]");
    }

    #[test]
    fn degenerate_is_skipped_and_bad_numbers_are_errors() {
        assert_eq!(Polygon::from_spec(&spec(vec![[0., 0., 0.], [1., 1., 1.], [2., 2., 2.]], vec![])).unwrap(), None);
        let e = Polygon::from_spec(&spec(vec![[0., 0., 0.], [1., f64::INFINITY, 0.], [0., 1., 0.]], vec![])).unwrap_err();
        assert_eq!(e.0, "outer[1]");
        let e = Polygon::from_spec(&spec(vec![[0., 0., 0.], [1., 0., 0.]], vec![])).unwrap_err();
        assert!(matches!(e.1, SceneErrorKind::TooFewPoints { need: 3, got: 2 }));
    }
}
