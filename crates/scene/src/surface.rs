//! `[[surface]]`: a height field z = f(x, y), from an expression or a CSV file.
//!
//! Surfaces alone (with their secondary objects) are drawn by the fast grid
//! engine ([`hiddenline::grid`]); in a scene with other objects they are lowered to
//! two triangles per cell, split along `(x_i, y_j)-(x_i+1, y_j+1)` exactly as
//! the grid engine splits them, so both paths draw the same lines.

use crate::builder::ModelBuilder;
use crate::error::SceneErrorKind;
use crate::expr::Expr;
use crate::mesh::default_pen;
use crate::points::FieldError;
use crate::table;
use hiddenline::grid::{check_axis, DrawnLines, Grid, GridError, GridLines, MAX_GRID_POINTS};
use hiddenline::model::Face;
use serde::Deserialize;
use std::path::Path;

/// Grid steps along an axis when `steps` is not given.
pub const DEFAULT_STEPS: usize = 40;

/// A grid axis as written: `{ from, to, steps }` or `{ values = [...] }`.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(untagged, deny_unknown_fields)]
pub enum AxisSpec {
    /// Evenly spaced: `steps` intervals from `from` to `to`.
    Range {
        /// First value.
        from: f64,
        /// Last value, `> from`.
        to: f64,
        /// Number of intervals (points minus one); default [`DEFAULT_STEPS`],
        /// or the data's size.
        steps: Option<usize>,
    },
    /// Explicit, strictly increasing values (a non-uniform grid).
    Values {
        /// The coordinates.
        values: Vec<f64>,
    },
}

/// `lines = "x" | "y" | "both"`.
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum LinesChoice {
    /// Lines along x (y constant).
    X,
    /// Lines along y (x constant).
    Y,
    /// Both.
    #[default]
    Both,
}

impl From<LinesChoice> for GridLines {
    fn from(c: LinesChoice) -> GridLines {
        match c {
            LinesChoice::X => GridLines::X,
            LinesChoice::Y => GridLines::Y,
            LinesChoice::Both => GridLines::Both,
        }
    }
}

/// A `[[surface]]` table as written in the scene file.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SurfaceSpec {
    /// Height expression in `x` and `y`.
    pub z: Option<String>,
    /// CSV file of heights (rows = y, columns = x), relative to the scene.
    pub data: Option<String>,
    /// Grid along x.
    pub x: Option<AxisSpec>,
    /// Grid along y.
    pub y: Option<AxisSpec>,
    /// Which grid lines to draw.
    #[serde(default)]
    pub lines: LinesChoice,
    /// Draw every N-th grid line in each direction (and the last); the
    /// surface still hides with every cell. Default 1: all of them.
    #[serde(default = "every_line")]
    pub every: usize,
    /// Pen.
    #[serde(default = "default_pen")]
    pub pen: u32,
}

fn every_line() -> usize {
    1
}

/// A validated surface in world space.
#[derive(Clone, Debug, PartialEq)]
pub struct Surface {
    /// The heights.
    pub grid: Grid,
    /// Which grid lines are drawn.
    pub lines: GridLines,
    /// Every how many grid lines are drawn (1: all).
    pub every: usize,
    /// Pen.
    pub pen: u32,
}

fn bad(field: &str, msg: impl Into<String>) -> FieldError {
    (field.to_string(), SceneErrorKind::OutOfRange(msg.into()))
}

/// The coordinates of one axis; `count` is the data's size when heights come
/// from a file.
fn axis_values(name: &'static str, spec: Option<&AxisSpec>, count: Option<usize>) -> Result<Vec<f64>, FieldError> {
    let v = match (spec, count) {
        (None, None) => {
            return Err(bad(name, format!("give the grid along {name}: {name} = {{ from, to, steps }} or {{ values = [...] }}")))
        }
        (None, Some(n)) => (0..n).map(|i| i as f64).collect(),
        (Some(AxisSpec::Range { from, to, steps }), _) => {
            if !from.is_finite() || !to.is_finite() || !(to > from) {
                return Err(bad(name, format!("{name}.from = {from} must be finite and less than {name}.to = {to}")));
            }
            let steps = match (steps, count) {
                (Some(s), Some(n)) if s + 1 != n => {
                    return Err(bad(&format!("{name}.steps"), format!("steps = {s} gives {} points but the data has {n}", s + 1)))
                }
                (Some(s), _) => *s,
                (None, Some(n)) => n.saturating_sub(1),
                (None, None) => DEFAULT_STEPS,
            };
            if steps < 1 {
                return Err((format!("{name}.steps"), SceneErrorKind::TooFewPoints { need: 2, got: steps + 1 }));
            }
            if steps >= MAX_GRID_POINTS {
                return Err(bad(&format!("{name}.steps"), format!("steps = {steps} is more than the limit of {MAX_GRID_POINTS}")));
            }
            Grid::linspace(*from, *to, steps)
        }
        (Some(AxisSpec::Values { values }), count) => {
            if let Some(n) = count {
                if values.len() != n {
                    return Err(bad(&format!("{name}.values"), format!("{} values but the data has {n}", values.len())));
                }
            }
            values.clone()
        }
    };
    check_axis(name, &v).map_err(|e| match e {
        GridError::TooFewPoints { count, .. } => (name.to_string(), SceneErrorKind::TooFewPoints { need: 2, got: count }),
        GridError::NotIncreasing { index, .. } => (format!("{name}.values[{index}]"), SceneErrorKind::OutOfRange(e.to_string())),
        other => bad(name, other.to_string()),
    })?;
    Ok(v)
}

impl Surface {
    /// Validates a spec, reading its data file (relative to `base`) if any.
    ///
    /// # Errors
    /// The offending sub-field and what is wrong: both or neither of `z` and
    /// `data`, a bad axis, an expression that does not parse (pointing at the
    /// character) or is not finite at a grid point (naming it), a data file
    /// that cannot be read or is ragged or not numeric (naming file, line and
    /// column).
    pub fn from_spec(spec: &SurfaceSpec, base: &Path, files: &dyn crate::resolver::Resolver) -> Result<Surface, FieldError> {
        let grid = match (&spec.z, &spec.data) {
            (Some(z), None) => {
                let expr = Expr::parse(z).map_err(|e| bad("z", e.to_string()))?;
                let xs = axis_values("x", spec.x.as_ref(), None)?;
                let ys = axis_values("y", spec.y.as_ref(), None)?;
                if xs.len().saturating_mul(ys.len()) > MAX_GRID_POINTS {
                    return Err(bad("x", format!("the grid has {} x {} points; the limit is {MAX_GRID_POINTS}", xs.len(), ys.len())));
                }
                let z = expr.eval_grid(&xs, &ys);
                Grid::new(xs, ys, z).map_err(|e| match e {
                    GridError::NotFinite { x, y, z } => bad(
                        "z",
                        format!("`{}` is {z} at the grid point x = {x}, y = {y}", crate::excerpt::excerpt(spec.z.as_deref().unwrap_or(""))),
                    ),
                    other => bad("z", other.to_string()),
                })?
            }
            (None, Some(data)) => {
                let path = base.join(data);
                let text = crate::mesh_file::read_limited(files, &path, crate::tolerance::MAX_MESH_BYTES)
                    .map_err(|e| bad("data", format!("{}: {}", crate::excerpt::shown_path(&path), e.kind)))?;
                let text = String::from_utf8_lossy(&text);
                let t = table::parse(&text).map_err(|e| {
                    bad("data", format!("{}:{}: column {}: {}", crate::excerpt::shown_path(&path), e.line, e.column, e.message))
                })?;
                let (nx, ny) = (t.rows[0].len(), t.rows.len());
                let xs = match (&t.xs, spec.x.as_ref()) {
                    (Some(h), None) => h.clone(),
                    _ => axis_values("x", spec.x.as_ref(), Some(nx))?,
                };
                let ys = match (&t.ys, spec.y.as_ref()) {
                    (Some(h), None) => h.clone(),
                    _ => axis_values("y", spec.y.as_ref(), Some(ny))?,
                };
                let check = |name: &'static str, v: &[f64]| {
                    check_axis(name, v).map_err(|e| bad("data", format!("{}: header {name} coordinates: {e}", path.display())))
                };
                check("x", &xs)?;
                check("y", &ys)?;
                let z: Vec<f64> = t.rows.into_iter().flatten().collect();
                Grid::new(xs, ys, z).map_err(|e| bad("data", format!("{}: {e}", path.display())))?
            }
            _ => return Err(bad("z", "give exactly one of z (an expression) and data (a CSV file)")),
        };
        if spec.every == 0 {
            return Err(bad("every", "every = 0: draw every N-th grid line, N >= 1"));
        }
        Ok(Surface { grid, lines: spec.lines.into(), every: spec.every, pen: spec.pen })
    }

    /// The grid lines drawn, as the grid engine takes them.
    #[must_use]
    pub fn drawn(&self) -> DrawnLines {
        DrawnLines { directions: self.lines, every: self.every }
    }

    /// Faces the surface lowers to.
    #[must_use]
    pub fn face_count(&self) -> usize {
        2 * (self.grid.nx() - 1) * (self.grid.ny() - 1)
    }

    /// Adds two triangles per cell and the drawn grid lines (lying on their
    /// adjacent triangles) to `out`, for the general engine: every cell
    /// hides, whichever lines are drawn.
    pub fn lower(&self, out: &mut ModelBuilder) {
        let g = &self.grid;
        let (nx, ny) = (g.nx(), g.ny());
        let tri =
            |out: &mut ModelBuilder, a, b, c| out.add_face(Face { outer: vec![a, b, c], holes: Vec::new(), pen: self.pen, outward: false });
        // Face indices of the lower and upper triangle of each cell.
        let mut lower = vec![0u32; (nx - 1) * (ny - 1)];
        let mut upper = vec![0u32; (nx - 1) * (ny - 1)];
        for j in 0..ny - 1 {
            for i in 0..nx - 1 {
                let (p00, p10, p01, p11) = (g.point(i, j), g.point(i + 1, j), g.point(i, j + 1), g.point(i + 1, j + 1));
                lower[j * (nx - 1) + i] = tri(out, p00, p10, p11);
                upper[j * (nx - 1) + i] = tri(out, p00, p11, p01);
            }
        }
        let cell = |i: usize, j: usize| j * (nx - 1) + i;
        let drawn = self.drawn();
        if self.lines != GridLines::Y {
            for j in (0..ny).filter(|&j| drawn.draws_row(g, j)) {
                for i in 0..nx - 1 {
                    let mut faces = Vec::with_capacity(2);
                    if j > 0 {
                        faces.push(upper[cell(i, j - 1)]);
                    }
                    if j < ny - 1 {
                        faces.push(lower[cell(i, j)]);
                    }
                    out.add_edge(g.point(i, j), g.point(i + 1, j), self.pen, &faces);
                }
            }
        }
        if self.lines != GridLines::X {
            for i in (0..nx).filter(|&i| drawn.draws_column(g, i)) {
                for j in 0..ny - 1 {
                    let mut faces = Vec::with_capacity(2);
                    if i > 0 {
                        faces.push(lower[cell(i - 1, j)]);
                    }
                    if i < nx - 1 {
                        faces.push(upper[cell(i, j)]);
                    }
                    out.add_edge(g.point(i, j), g.point(i, j + 1), self.pen, &faces);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(toml_text: &str) -> SurfaceSpec {
        toml::from_str(toml_text).unwrap()
    }

    fn err(toml_text: &str) -> (String, String) {
        let (f, k) = Surface::from_spec(&spec(toml_text), Path::new("/nonexistent"), &crate::resolver::FileSystem).unwrap_err();
        (f, k.to_string())
    }

    #[test]
    fn expression_surface() {
        let s = Surface::from_spec(
            &spec("z = \"x + 10*y\"\nx = { from = 0.0, to = 1.0, steps = 2 }\ny = { values = [0.0, 1.0, 3.0] }\nlines = \"x\"\npen = 2"),
            Path::new("."),
            &crate::resolver::FileSystem,
        )
        .unwrap();
        assert_eq!(s.grid.xs, vec![0.0, 0.5, 1.0]);
        assert_eq!(s.grid.point(2, 2).z, 31.0);
        assert_eq!((s.lines, s.pen), (GridLines::X, 2));
        let mut b = ModelBuilder::new();
        s.lower(&mut b);
        let m = b.finish();
        assert_eq!(m.faces.len(), 8);
        assert_eq!(m.edges.len(), 6, "3 rows of 2 edges along x");
        // Every edge lies on the triangles that contain it.
        for e in &m.edges {
            assert!(!e.faces.is_empty());
            for &f in &e.faces {
                assert!(m.faces[f as usize].outer.contains(&e.a) && m.faces[f as usize].outer.contains(&e.b));
            }
        }
    }

    #[test]
    fn bad_surfaces_name_the_field() {
        let cases: &[(&str, &str, &str)] = &[
            ("z = \"x\"\ndata = \"a.csv\"\nx = { from = 0.0, to = 1.0 }\ny = { from = 0.0, to = 1.0 }", "z", "exactly one"),
            ("z = \"x +* y\"\nx = { from = 0.0, to = 1.0 }\ny = { from = 0.0, to = 1.0 }", "z", "at character 4"),
            (
                "z = \"ln(x)\"\nx = { from = -1.0, to = 1.0, steps = 2 }\ny = { from = 0.0, to = 1.0 }",
                "z",
                "at the grid point x = -1, y = 0",
            ),
            ("z = \"1/x\"\nx = { from = -1.0, to = 1.0, steps = 2 }\ny = { from = 0.0, to = 1.0 }", "z", "inf at the grid point x = 0"),
            ("z = \"x\"\nx = { from = 0.0, to = 1.0, steps = 0 }\ny = { from = 0.0, to = 1.0 }", "x.steps", "at least 2"),
            ("z = \"x\"\nx = { values = [0.0] }\ny = { from = 0.0, to = 1.0 }", "x", "at least 2"),
            ("z = \"x\"\nx = { values = [0.0, 2.0, 1.0] }\ny = { from = 0.0, to = 1.0 }", "x.values[2]", "strictly increasing"),
            ("z = \"x\"\nx = { from = 1.0, to = 1.0 }\ny = { from = 0.0, to = 1.0 }", "x", "less than"),
            ("z = \"x\"\nx = { from = 0.0, to = 1.0 }", "y", "give the grid along y"),
            ("data = \"missing.csv\"", "data", "missing.csv"),
        ];
        for &(text, field, msg) in cases {
            let (f, m) = err(text);
            assert_eq!(f, field, "{text}: {m}");
            assert!(m.contains(msg), "{text}: {m}");
        }
    }

    #[test]
    fn data_surfaces() {
        let temp = tempfile::Builder::new().prefix("plotd-surface-").tempdir().unwrap();
        let dir = temp.path();
        std::fs::write(dir.join("h.csv"), ",0,1,3\n0,1,2,3\n2,4,5,6\n").unwrap();
        std::fs::write(dir.join("plain.csv"), "1,2\n3,4\n5,6\n").unwrap();
        std::fs::write(dir.join("ragged.csv"), "1,2\n3\n").unwrap();
        std::fs::write(dir.join("text.csv"), "1,2\n3,x\n").unwrap();
        std::fs::write(dir.join("dec.csv"), ",0,1\n1,1,2\n0,3,4\n").unwrap();
        let s = Surface::from_spec(&spec("data = \"h.csv\""), dir, &crate::resolver::FileSystem).unwrap();
        assert_eq!((s.grid.xs.clone(), s.grid.ys.clone()), (vec![0.0, 1.0, 3.0], vec![0.0, 2.0]));
        assert_eq!(s.grid.point(2, 1).z, 6.0);
        let s = Surface::from_spec(&spec("data = \"plain.csv\"\nx = { from = 0.0, to = 2.0 }"), dir, &crate::resolver::FileSystem).unwrap();
        assert_eq!((s.grid.xs.clone(), s.grid.ys.clone()), (vec![0.0, 2.0], vec![0.0, 1.0, 2.0]));
        let e = |text: &str| Surface::from_spec(&spec(text), dir, &crate::resolver::FileSystem).unwrap_err().1.to_string();
        assert!(
            e("data = \"ragged.csv\"").contains("ragged.csv:2: column 2: row has 1 values, expected 2"),
            "{}",
            e("data = \"ragged.csv\"")
        );
        assert!(e("data = \"text.csv\"").contains("text.csv:2: column 2: `x` is not a number"));
        assert!(e("data = \"dec.csv\"").contains("strictly increasing"), "{}", e("data = \"dec.csv\""));
        assert!(e("data = \"plain.csv\"\nx = { from = 0.0, to = 1.0, steps = 5 }").contains("the data has 2"));
    }
}
