//! `[[ridgeline]]`: profiles stacked in depth (Joy Division style). Each row
//! of a CSV file is one profile, drawn in the vertical plane `y = k spacing`;
//! under each profile hangs an opaque curtain down to the baseline, so a
//! profile hides what lies behind and below it.

use crate::builder::ModelBuilder;
use crate::error::SceneErrorKind;
use crate::mesh::default_pen;
use crate::points::FieldError;
use crate::table;
use glam::DVec3;
use hiddenline::model::Face;
use serde::Deserialize;
use std::path::Path;

/// A `[[ridgeline]]` table as written.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RidgelineSpec {
    /// CSV file, one profile per row (a header row, if any, holds x).
    pub data: String,
    /// Distance between consecutive profiles along y (default 1).
    #[serde(default = "one")]
    pub spacing: f64,
    /// Vertical scale of the values (default 1).
    #[serde(default = "one")]
    pub amplitude: f64,
    /// Spacing of the points along x when there is no header row (default 1).
    #[serde(default = "one")]
    pub x_step: f64,
    /// Pen.
    #[serde(default = "default_pen")]
    pub pen: u32,
}

fn one() -> f64 {
    1.0
}

/// Validated profiles in world space: profile `k` lies at `y = k spacing`.
#[derive(Clone, Debug, PartialEq)]
pub struct Ridgeline {
    /// Profiles, front (first row) to back.
    pub profiles: Vec<Vec<DVec3>>,
    /// Height of the curtains' lower edge.
    pub base: f64,
    /// Pen.
    pub pen: u32,
}

impl Ridgeline {
    /// Reads and validates a spec; `base` is the scene file's directory.
    ///
    /// # Errors
    /// Bad numbers (spacing, amplitude, x_step), an unreadable, ragged or
    /// non-numeric CSV (naming file, line and column), fewer than 2 points per
    /// profile, or header x not strictly increasing.
    pub fn from_spec(spec: &RidgelineSpec, base: &Path, files: &dyn crate::resolver::Resolver) -> Result<Ridgeline, FieldError> {
        let bad = |f: &str, m: String| (f.to_string(), SceneErrorKind::OutOfRange(m));
        for (name, v) in [("spacing", spec.spacing), ("amplitude", spec.amplitude), ("x_step", spec.x_step)] {
            if !(v.is_finite() && v > 0.0) {
                return Err(bad(name, format!("{name} = {v} must be a positive number")));
            }
        }
        let path = base.join(&spec.data);
        let bytes = crate::mesh_file::read_limited(files, &path, crate::tolerance::MAX_MESH_BYTES)
            .map_err(|e| bad("data", format!("{}: {}", crate::excerpt::shown_path(&path), e.kind)))?;
        let t = table::parse(&String::from_utf8_lossy(&bytes))
            .map_err(|e| bad("data", format!("{}:{}: column {}: {}", crate::excerpt::shown_path(&path), e.line, e.column, e.message)))?;
        let n = t.rows[0].len();
        if n < 2 {
            return Err(bad("data", format!("{}: profiles need at least 2 points, have {n}", path.display())));
        }
        let xs: Vec<f64> = match &t.xs {
            Some(h) => h.clone(),
            None => (0..n).map(|i| i as f64 * spec.x_step).collect(),
        };
        hiddenline::grid::check_axis("x", &xs).map_err(|e| bad("data", format!("{}: header: {e}", path.display())))?;
        let profiles: Vec<Vec<DVec3>> = t
            .rows
            .iter()
            .enumerate()
            .map(|(k, row)| {
                let y = k as f64 * spec.spacing;
                xs.iter().zip(row).map(|(&x, &v)| DVec3::new(x, y, v * spec.amplitude)).collect()
            })
            .collect();
        let zmin = profiles.iter().flatten().map(|p| p.z).fold(f64::INFINITY, f64::min);
        let zmax = profiles.iter().flatten().map(|p| p.z).fold(f64::NEG_INFINITY, f64::max);
        // The curtains reach a little below the lowest point so that no
        // profile touches its own lower edge.
        let base = zmin.min(0.0) - 1e-3 * (zmax - zmin + 1.0);
        Ok(Ridgeline { profiles, base, pen: spec.pen })
    }

    /// The ridgeline as the horizon method ([`hiddenline::grid::ridgeline`]) takes it.
    #[must_use]
    pub fn curtains(&self) -> hiddenline::grid::ridgeline::Curtains<'_> {
        hiddenline::grid::ridgeline::Curtains { profiles: &self.profiles, base: self.base, pen: self.pen }
    }

    /// Adds one curtain face per profile (profile plus baseline, a planar
    /// polygon in `y = const`) and the profile's segments, lying on it.
    pub fn lower(&self, out: &mut ModelBuilder) {
        for p in &self.profiles {
            let (first, last) = (p[0], p[p.len() - 1]);
            let mut outer = p.clone();
            outer.push(DVec3::new(last.x, last.y, self.base));
            outer.push(DVec3::new(first.x, first.y, self.base));
            let f = out.add_face(Face { outer, holes: Vec::new(), pen: self.pen, outward: false });
            for w in p.windows(2) {
                out.add_edge(w[0], w[1], self.pen, &[f]);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn profiles_and_curtains() {
        let temp = tempfile::Builder::new().prefix("plotd-ridge-").tempdir().unwrap();
        let dir = temp.path();
        std::fs::write(dir.join("r.csv"), "0,1,0\n0,2,0\n").unwrap();
        std::fs::write(dir.join("bad.csv"), "0,1,0\n0,2\n").unwrap();
        let spec: RidgelineSpec = toml::from_str("data = \"r.csv\"\nspacing = 2.0\namplitude = 3.0").unwrap();
        let r = Ridgeline::from_spec(&spec, dir, &crate::resolver::FileSystem).unwrap();
        assert_eq!(r.profiles[1][1], DVec3::new(1.0, 2.0, 6.0));
        let mut b = ModelBuilder::new();
        r.lower(&mut b);
        let m = b.finish();
        assert_eq!((m.faces.len(), m.edges.len()), (2, 4));
        assert!(m.faces.iter().all(|f| f.outer.iter().all(|p| p.y == f.outer[0].y)), "curtains are planar");
        let spec: RidgelineSpec = toml::from_str("data = \"bad.csv\"").unwrap();
        let e = Ridgeline::from_spec(&spec, dir, &crate::resolver::FileSystem).unwrap_err().1.to_string();
        assert!(e.contains("bad.csv:2: column 3"), "{e}");
        let spec: RidgelineSpec = toml::from_str("data = \"r.csv\"\nspacing = 0.0").unwrap();
        assert_eq!(Ridgeline::from_spec(&spec, dir, &crate::resolver::FileSystem).unwrap_err().0, "spacing");
    }
}
