//! `[[contours]]`: contour lines of a surface, on the surface itself or on a
//! base plane below it (a contour map that the surface hides where it covers
//! it).
//!
//! Contours are traced on the same triangles the surface is drawn with (each
//! cell split along `(x_i, y_j)-(x_i+1, y_j+1)`), so on the surface they lie
//! exactly in its facets.

use crate::builder::ModelBuilder;
use crate::error::SceneErrorKind;
use crate::mesh::default_pen;
use crate::points::FieldError;
use crate::surface::Surface;
use glam::DVec3;
use hiddenline::grid::Grid;
use serde::Deserialize;

/// The most contour levels.
pub const MAX_LEVELS: usize = 1000;

/// `levels = 10` or `levels = [0.1, 0.5]`.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(untagged)]
pub enum LevelsSpec {
    /// This many levels evenly spaced strictly between the lowest and highest height.
    Count(usize),
    /// These heights.
    List(Vec<f64>),
}

/// `on = "surface" | "base"`.
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum ContourPlace {
    /// On a horizontal plane below the surface.
    #[default]
    Base,
    /// On the surface.
    Surface,
}

/// A `[[contours]]` table as written.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ContoursSpec {
    /// Index of the `[[surface]]` (default 0).
    #[serde(default)]
    pub surface: usize,
    /// Levels.
    pub levels: LevelsSpec,
    /// Where to draw them.
    #[serde(default)]
    pub on: ContourPlace,
    /// Height of the base plane; default: below the lowest point by a fifth of
    /// the height range. Must be below the surface.
    pub base_z: Option<f64>,
    /// Pen.
    #[serde(default = "default_pen")]
    pub pen: u32,
}

/// Validated contour segments, world space.
#[derive(Clone, Debug, PartialEq)]
pub struct Contours {
    /// Segments to draw.
    pub segments: Vec<(DVec3, DVec3)>,
    /// On the surface or on the base plane.
    pub on: ContourPlace,
    /// On the surface: the facet each segment lies in (see [`trace_facets`]);
    /// empty on the base plane.
    pub facets: Vec<u32>,
    /// Pen.
    pub pen: u32,
}

/// The segments where height `level` crosses the triangulated grid.
#[must_use]
pub fn trace(grid: &Grid, level: f64) -> Vec<(DVec3, DVec3)> {
    trace_facets(grid, level).into_iter().map(|(_, a, b)| (a, b)).collect()
}

/// As [`trace`], with the facet each segment lies in: `2 c` for the lower
/// triangle of cell `c = j (nx - 1) + i` (the one holding `(x_i+1, y_j)`),
/// `2 c + 1` for the upper one.
#[must_use]
pub fn trace_facets(grid: &Grid, level: f64) -> Vec<(u32, DVec3, DVec3)> {
    let mut out = Vec::new();
    let nx = grid.nx();
    for j in 0..grid.ny() - 1 {
        for i in 0..nx - 1 {
            let (p00, p10, p01, p11) = (grid.point(i, j), grid.point(i + 1, j), grid.point(i, j + 1), grid.point(i + 1, j + 1));
            for (t, tri) in [[p00, p10, p11], [p00, p11, p01]].into_iter().enumerate() {
                let mut pts: Vec<DVec3> = Vec::with_capacity(2);
                for k in 0..3 {
                    let (a, b) = (tri[k], tri[(k + 1) % 3]);
                    // Half-open rule: a vertex exactly at the level counts as
                    // above, so each crossing is found once.
                    let (ua, ub) = (a.z >= level, b.z >= level);
                    if ua != ub {
                        let t = (level - a.z) / (b.z - a.z);
                        pts.push(a.lerp(b, t));
                    }
                }
                if pts.len() == 2 && pts[0] != pts[1] {
                    out.push(((2 * (j * (nx - 1) + i) + t) as u32, pts[0], pts[1]));
                }
            }
        }
    }
    out
}

impl Contours {
    /// Traces the contours of `surfaces[spec.surface]`.
    ///
    /// # Errors
    /// No such surface, no levels or too many, a non-finite level, or a base
    /// plane that is not below the surface.
    pub fn from_spec(spec: &ContoursSpec, surfaces: &[Surface]) -> Result<Contours, FieldError> {
        let bad = |f: &str, m: String| (f.to_string(), SceneErrorKind::OutOfRange(m));
        let s = surfaces
            .get(spec.surface)
            .ok_or_else(|| bad("surface", format!("surface = {} but the scene has {} [[surface]] tables", spec.surface, surfaces.len())))?;
        let (z0, z1) = s.grid.z_range();
        let levels: Vec<f64> = match &spec.levels {
            LevelsSpec::Count(n) => {
                if *n == 0 || *n > MAX_LEVELS {
                    return Err(bad("levels", format!("levels = {n} is outside 1..={MAX_LEVELS}")));
                }
                (1..=*n).map(|k| z0 + (z1 - z0) * k as f64 / (*n + 1) as f64).collect()
            }
            LevelsSpec::List(v) => {
                if v.is_empty() || v.len() > MAX_LEVELS {
                    return Err(bad("levels", format!("{} levels; give 1 to {MAX_LEVELS}", v.len())));
                }
                if let Some(i) = v.iter().position(|x| !x.is_finite()) {
                    return Err((format!("levels[{i}]"), SceneErrorKind::NotFinite(v[i])));
                }
                v.clone()
            }
        };
        let base = match spec.base_z {
            Some(b) if !(b.is_finite() && b < z0) => {
                return Err(bad("base_z", format!("base_z = {b} must be below the surface's lowest point {z0}")))
            }
            Some(b) => b,
            None => z0 - 0.2 * (z1 - z0).max(1e-3 * (1.0 + z0.abs())),
        };
        let mut segments = Vec::new();
        let mut facets = Vec::new();
        for &l in &levels {
            for (f, a, b) in trace_facets(&s.grid, l) {
                match spec.on {
                    ContourPlace::Surface => {
                        segments.push((a, b));
                        facets.push(f);
                    }
                    ContourPlace::Base => segments.push((DVec3::new(a.x, a.y, base), DVec3::new(b.x, b.y, base))),
                }
            }
        }
        Ok(Contours { segments, on: spec.on, facets, pen: spec.pen })
    }

    /// Adds its lines, lying on no face, to `out` (a contour on the surface
    /// lies in a facet's plane, and a face never hides what lies in its plane).
    pub fn lower(&self, out: &mut ModelBuilder) {
        for &(a, b) in &self.segments {
            out.add_edge(a, b, self.pen, &[]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use hiddenline::grid::GridLines;

    fn cone() -> Surface {
        let g = Grid::from_fn(Grid::linspace(-1.0, 1.0, 20), Grid::linspace(-1.0, 1.0, 20), |x, y| 1.0 - (x * x + y * y).sqrt()).unwrap();
        Surface { grid: g, lines: GridLines::Both, every: 1, pen: 1 }
    }

    #[test]
    fn contour_of_a_cone_is_a_closed_ring_at_its_level() {
        let segs = trace(&cone().grid, 0.55);
        assert!(segs.len() > 20);
        for &(a, b) in &segs {
            assert!((a.z - 0.55).abs() < 1e-12 && (b.z - 0.55).abs() < 1e-12);
            // Linear interpolation on the facets: close to the true circle of radius 0.45.
            let r = DVec3::new(a.x, a.y, 0.0).length();
            assert!((r - 0.45).abs() < 0.06, "{r}");
        }
        // Closed: every endpoint is shared by exactly two segments.
        let key = |p: DVec3| ((p.x * 1e7).round() as i64, (p.y * 1e7).round() as i64);
        let mut count = std::collections::HashMap::new();
        for &(a, b) in &segs {
            *count.entry(key(a)).or_insert(0) += 1;
            *count.entry(key(b)).or_insert(0) += 1;
        }
        assert!(count.values().all(|&c| c == 2));
    }

    #[test]
    fn levels_and_base_plane() {
        let s = [cone()];
        let spec: ContoursSpec = toml::from_str("levels = 3").unwrap();
        let c = Contours::from_spec(&spec, &s).unwrap();
        let (z0, _) = s[0].grid.z_range();
        assert!(c.segments.iter().all(|(a, b)| a.z < z0 && a.z == b.z));
        let spec: ContoursSpec = toml::from_str("levels = [0.25, 0.75]\non = \"surface\"").unwrap();
        let c = Contours::from_spec(&spec, &s).unwrap();
        assert!(c.segments.iter().all(|(a, _)| (a.z - 0.25).abs() < 1e-12 || (a.z - 0.75).abs() < 1e-12));
        let e = |t: &str| Contours::from_spec(&toml::from_str(t).unwrap(), &s).unwrap_err().0;
        assert_eq!(e("levels = 0"), "levels");
        assert_eq!(e("levels = []"), "levels");
        assert_eq!(e("levels = 2\nbase_z = 0.5"), "base_z");
        assert_eq!(e("levels = 2\nsurface = 1"), "surface");
    }
}
