//! `[[axes]]`: a box or three axes around a surface, with ticks, numeric
//! labels and axis titles in a single-stroke font ([`crate::font`]), drawn in
//! perspective and hidden by the surface where it is behind it (Anderson,
//! section 7: secondary objects are lines like any other).

use crate::builder::ModelBuilder;
use crate::error::SceneErrorKind;
use crate::font::{text_polylines, Align, TextPlacement};
use crate::mesh::default_pen;
use crate::points::FieldError;
use crate::surface::Surface;
use glam::DVec3;
use serde::Deserialize;

/// `style = "box" | "axes"`.
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum AxesStyle {
    /// The twelve edges of the bounding box.
    #[default]
    Box,
    /// Three axes from the low corner.
    Axes,
}

/// The most ticks per axis.
pub const MAX_TICKS: usize = 50;

/// An `[[axes]]` table as written.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AxesSpec {
    /// Index of the `[[surface]]` it frames (default 0).
    #[serde(default)]
    pub surface: usize,
    /// Box or axes.
    #[serde(default)]
    pub style: AxesStyle,
    /// About how many ticks per axis (nice round values are chosen).
    #[serde(default = "default_ticks")]
    pub ticks: usize,
    /// Titles of the x, y and z axes.
    #[serde(default = "default_titles")]
    pub titles: [String; 3],
    /// Label height as a fraction of the box's largest side (default 0.04).
    #[serde(default = "default_label")]
    pub label_size: f64,
    /// Pen.
    #[serde(default = "default_pen")]
    pub pen: u32,
}

fn default_ticks() -> usize {
    5
}
fn default_titles() -> [String; 3] {
    ["x".into(), "y".into(), "z".into()]
}
fn default_label() -> f64 {
    0.04
}

/// Validated axes: the box and the lines to draw.
#[derive(Clone, Debug, PartialEq)]
pub struct Axes {
    /// Line segments (box, ticks, label and title strokes), world space.
    pub segments: Vec<(DVec3, DVec3)>,
    /// Pen.
    pub pen: u32,
}

/// Nice tick values (1, 2 or 5 times a power of ten) inside `[lo, hi]`,
/// about `n` of them.
#[must_use]
pub fn nice_ticks(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    if !(hi > lo) || n == 0 {
        return vec![lo];
    }
    let raw = (hi - lo) / n as f64;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0].iter().map(|m| m * mag).find(|s| *s >= raw).unwrap_or(10.0 * mag);
    // Round to the step's decimals so 3 x 0.1 prints and compares as 0.3.
    let scale = 10f64.powi((-step.log10().floor()).max(0.0) as i32 + 1);
    let first = (lo / step).ceil();
    let mut out = Vec::new();
    let mut k = first;
    while k * step <= hi + step * 1e-9 && out.len() <= MAX_TICKS {
        let v = (k * step * scale).round() / scale;
        out.push(if v.abs() < step * 1e-9 { 0.0 } else { v });
        k += 1.0;
    }
    out
}

/// A tick value as text: no more decimals than the step needs.
#[must_use]
pub fn tick_label(v: f64, step: f64) -> String {
    let decimals = if step >= 1.0 { 0 } else { (-step.log10().floor()) as usize };
    format!("{v:.decimals$}")
}

impl Axes {
    /// Builds the axes around `surfaces[spec.surface]`.
    ///
    /// # Errors
    /// No such surface, a tick count outside `1..=MAX_TICKS`, or a label size
    /// outside (0, 1].
    pub fn from_spec(spec: &AxesSpec, surfaces: &[Surface]) -> Result<Axes, FieldError> {
        let bad = |f: &str, m: String| (f.to_string(), SceneErrorKind::OutOfRange(m));
        let s = surfaces
            .get(spec.surface)
            .ok_or_else(|| bad("surface", format!("surface = {} but the scene has {} [[surface]] tables", spec.surface, surfaces.len())))?;
        if spec.ticks == 0 || spec.ticks > MAX_TICKS {
            return Err(bad("ticks", format!("ticks = {} is outside 1..={MAX_TICKS}", spec.ticks)));
        }
        if !(spec.label_size > 0.0 && spec.label_size <= 1.0) {
            return Err(bad("label_size", format!("label_size = {} is outside (0, 1]", spec.label_size)));
        }
        let g = &s.grid;
        let (z0, z1) = g.z_range();
        let z1 = if z1 > z0 { z1 } else { z0 + 1.0 };
        let lo = DVec3::new(g.xs[0], g.ys[0], z0);
        let hi = DVec3::new(g.xs[g.nx() - 1], g.ys[g.ny() - 1], z1);
        let size = (hi - lo).max_element();
        let h = spec.label_size * size;
        let tick = 0.5 * h;
        let mut seg: Vec<(DVec3, DVec3)> = Vec::new();
        let c = |x: f64, y: f64, z: f64| DVec3::new(x, y, z);
        match spec.style {
            AxesStyle::Box => {
                for &z in &[lo.z, hi.z] {
                    seg.push((c(lo.x, lo.y, z), c(hi.x, lo.y, z)));
                    seg.push((c(hi.x, lo.y, z), c(hi.x, hi.y, z)));
                    seg.push((c(hi.x, hi.y, z), c(lo.x, hi.y, z)));
                    seg.push((c(lo.x, hi.y, z), c(lo.x, lo.y, z)));
                }
                for &(x, y) in &[(lo.x, lo.y), (hi.x, lo.y), (hi.x, hi.y), (lo.x, hi.y)] {
                    seg.push((c(x, y, lo.z), c(x, y, hi.z)));
                }
            }
            AxesStyle::Axes => {
                seg.push((lo, c(hi.x, lo.y, lo.z)));
                seg.push((lo, c(lo.x, hi.y, lo.z)));
                seg.push((lo, c(lo.x, lo.y, hi.z)));
            }
        }
        let text = |t: &str, place: TextPlacement, seg: &mut Vec<(DVec3, DVec3)>| {
            for line in text_polylines(t, &place) {
                seg.extend(line.windows(2).map(|w| (w[0], w[1])));
            }
        };
        // x: ticks along the front edge (y = lo.y), pointing away from the box.
        let step = |v: &[f64]| if v.len() > 1 { v[1] - v[0] } else { 1.0 };
        let xt = nice_ticks(lo.x, hi.x, spec.ticks);
        for &x in &xt {
            seg.push((c(x, lo.y, lo.z), c(x, lo.y - tick, lo.z)));
            let p = TextPlacement::new(c(x, lo.y - tick * 1.5, lo.z), DVec3::X, DVec3::Y, h).aligned(Align::Center, Align::End);
            text(&tick_label(x, step(&xt)), p, &mut seg);
        }
        let p = TextPlacement::new(c((lo.x + hi.x) / 2.0, lo.y - tick * 2.0 - 2.5 * h, lo.z), DVec3::X, DVec3::Y, 1.2 * h)
            .aligned(Align::Center, Align::End);
        text(&spec.titles[0], p, &mut seg);
        // y: ticks along the left edge (x = lo.x).
        let yt = nice_ticks(lo.y, hi.y, spec.ticks);
        for &y in &yt {
            seg.push((c(lo.x, y, lo.z), c(lo.x - tick, y, lo.z)));
            let p = TextPlacement::new(c(lo.x - tick * 1.5, y, lo.z), DVec3::X, DVec3::Y, h).aligned(Align::End, Align::Center);
            text(&tick_label(y, step(&yt)), p, &mut seg);
        }
        let p = TextPlacement::new(c(lo.x - tick * 2.0 - 4.0 * h, (lo.y + hi.y) / 2.0, lo.z), DVec3::Y, -DVec3::X, 1.2 * h)
            .aligned(Align::Center, Align::Start);
        text(&spec.titles[1], p, &mut seg);
        // z: ticks up the front-left vertical edge.
        let zt = nice_ticks(lo.z, hi.z, spec.ticks);
        for &z in &zt {
            seg.push((c(lo.x, lo.y, z), c(lo.x - tick, lo.y, z)));
            let p = TextPlacement::new(c(lo.x - tick * 1.5, lo.y, z), DVec3::X, DVec3::Z, h).aligned(Align::End, Align::Center);
            text(&tick_label(z, step(&zt)), p, &mut seg);
        }
        let p = TextPlacement::new(c(lo.x - tick * 2.0 - 4.0 * h, lo.y, hi.z + 1.5 * h), DVec3::X, DVec3::Z, 1.2 * h)
            .aligned(Align::Center, Align::Start);
        text(&spec.titles[2], p, &mut seg);
        Ok(Axes { segments: seg, pen: spec.pen })
    }

    /// Adds its lines, lying on no face, to `out`.
    pub fn lower(&self, out: &mut ModelBuilder) {
        for &(a, b) in &self.segments {
            out.add_edge(a, b, self.pen, &[]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use hiddenline::grid::{Grid, GridLines};

    fn surface() -> Surface {
        let g = Grid::from_fn(Grid::linspace(0.0, 10.0, 10), Grid::linspace(-1.0, 1.0, 10), |x, y| x * 0.1 + y).unwrap();
        Surface { grid: g, lines: GridLines::Both, pen: 1 }
    }

    fn spec(text: &str) -> AxesSpec {
        toml::from_str(text).unwrap()
    }

    #[test]
    fn nice_ticks_are_round_and_inside() {
        assert_eq!(nice_ticks(0.0, 10.0, 5), vec![0.0, 2.0, 4.0, 6.0, 8.0, 10.0]);
        assert_eq!(nice_ticks(-1.0, 1.0, 4), vec![-1.0, -0.5, 0.0, 0.5, 1.0]);
        assert_eq!(nice_ticks(0.13, 0.41, 3), vec![0.2, 0.3, 0.4]);
        assert_eq!(nice_ticks(1.0, 1.0, 3), vec![1.0]);
        assert_eq!(tick_label(0.5, 0.5), "0.5");
        assert_eq!(tick_label(4.0, 2.0), "4");
        assert_eq!(tick_label(-0.25, 0.05), "-0.25");
    }

    #[test]
    fn box_ticks_and_labels() {
        let a = Axes::from_spec(&spec(""), &[surface()]).unwrap();
        let b = Axes::from_spec(&spec("style = \"axes\"\ntitles = [\"\", \"\", \"\"]"), &[surface()]).unwrap();
        // Box (12) + ticks + label strokes; the bare axes have 3 lines + ticks + labels.
        assert!(a.segments.len() > b.segments.len() + 9);
        // Everything stays near the surface's box (labels just outside it).
        for &(p, q) in &a.segments {
            for v in [p, q] {
                assert!(v.x > -3.0 && v.x < 10.5 && v.y > -4.0 && v.y < 1.5 && v.z > -1.5 && v.z < 3.5, "{v}");
            }
        }
        let mut mb = ModelBuilder::new();
        a.lower(&mut mb);
        let m = mb.finish();
        assert!(m.faces.is_empty() && m.edges.iter().all(|e| e.faces.is_empty()));
    }

    #[test]
    fn bad_axes() {
        let e = |t: &str| Axes::from_spec(&spec(t), &[surface()]).unwrap_err();
        assert_eq!(e("surface = 3").0, "surface");
        assert_eq!(e("ticks = 0").0, "ticks");
        assert_eq!(e("label_size = 2.0").0, "label_size");
    }
}
