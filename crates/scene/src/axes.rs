//! `[[axes]]`: a box or three axes around a surface, with ticks, numeric
//! labels and axis titles in a single-stroke font ([`crate::font`]), drawn in
//! perspective and hidden by the surface where it is behind it (Anderson,
//! section 7: secondary objects are lines like any other).

use crate::builder::ModelBuilder;
use crate::error::SceneErrorKind;
use crate::font::{text_polylines, text_width, Align, TextPlacement};
use crate::mesh::default_pen;
use crate::points::FieldError;
use crate::surface::Surface;
use glam::{DVec2, DVec3};
use hiddenline::camera::{Camera, Projection};
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

/// Validated axes: the box, what to label, and the lines drawn for the
/// scene's camera.
#[derive(Clone, Debug, PartialEq)]
pub struct Axes {
    /// Low corner of the box (its floor is the base contour plane, if any).
    lo: DVec3,
    /// High corner of the box.
    hi: DVec3,
    style: AxesStyle,
    ticks: usize,
    titles: [String; 3],
    /// Cap height of tick labels, world units.
    label_height: f64,
    /// Line segments (box, ticks, label and title strokes), world space, laid
    /// out for the camera last given ([`Axes::facing`]).
    pub segments: Vec<(DVec3, DVec3)>,
    /// Which of [`Axes::segments`] draw each tick label and title.
    pub labels: Vec<Label>,
    /// Pen.
    pub pen: u32,
}

/// The strokes of one tick label or axis title.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Label {
    /// 0, 1, 2 for the x, y, z axis.
    pub axis: usize,
    /// True for the axis title, false for a tick label.
    pub title: bool,
    /// The text.
    pub text: String,
    /// Its segments: a range of [`Axes::segments`].
    pub segments: std::ops::Range<usize>,
}

/// Gap kept between two labels on the picture, as a fraction of the
/// projected label height.
const LABEL_GAP: f64 = 0.3;

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
    /// Builds the axes around `surfaces[spec.surface]`, down to `base_z` (the
    /// plane of a contour map under it, if any), laid out for `camera`.
    ///
    /// # Errors
    /// No such surface, a tick count outside `1..=MAX_TICKS`, or a label size
    /// outside (0, 1].
    pub fn from_spec(spec: &AxesSpec, surfaces: &[Surface], base_z: Option<f64>, camera: &Camera) -> Result<Axes, FieldError> {
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
        let z0 = base_z.map_or(z0, |b| b.min(z0));
        let lo = DVec3::new(g.xs[0], g.ys[0], z0);
        let hi = DVec3::new(g.xs[g.nx() - 1], g.ys[g.ny() - 1], z1);
        let axes = Axes {
            lo,
            hi,
            style: spec.style,
            ticks: spec.ticks,
            titles: spec.titles.clone(),
            label_height: spec.label_size * (hi - lo).max_element(),
            segments: Vec::new(),
            labels: Vec::new(),
            pen: spec.pen,
        };
        Ok(axes.facing(camera))
    }

    /// The same axes laid out for `camera` (an animation's frame): each axis
    /// on the box edge that faces the viewer, as gnuplot and matplotlib put
    /// them. The x axis runs along the bottom edge on the side of the box
    /// nearer the eye in y, the y axis along the one nearer in x, their ticks
    /// pointing out of those faces; the z axis stands at the one of the two
    /// corners beside them that is leftmost on the picture, its ticks
    /// pointing left. These edges lie on box faces turned towards the eye,
    /// and labels stand outside them, so a surface inside the box cannot hide
    /// them (whenever the eye is outside the box's x and y ranges; from
    /// inside a range the nearer side is still taken). Labels face the
    /// viewer (in the picture plane) and never overlap: an axis whose tick
    /// labels would touch each other or an earlier axis's gets fewer ticks,
    /// down to two, and then loses the labels that still collide.
    #[must_use]
    pub fn facing(&self, camera: &Camera) -> Axes {
        let mut out = Layout::new(self, camera);
        out.lay_out();
        Axes { segments: out.segments, labels: out.labels, ..self.clone_config() }
    }

    fn clone_config(&self) -> Axes {
        Axes { segments: Vec::new(), labels: Vec::new(), titles: self.titles.clone(), ..*self }
    }

    /// Adds its lines, lying on no face, to `out`.
    pub fn lower(&self, out: &mut ModelBuilder) {
        for &(a, b) in &self.segments {
            out.add_edge(a, b, self.pen, &[]);
        }
    }
}

/// The work of [`Axes::facing`]: the camera's picture frame, and the lines
/// and labels placed so far with their boxes on the picture.
struct Layout<'a> {
    axes: &'a Axes,
    camera: &'a Camera,
    /// Right and up of the picture, world space (labels lie in this plane).
    right: DVec3,
    up: DVec3,
    segments: Vec<(DVec3, DVec3)>,
    labels: Vec<Label>,
    /// Picture-space boxes of the labels placed, grown by half the gap.
    boxes: Vec<(DVec2, DVec2)>,
}

/// One axis to draw: along `dir` from `start` to `start + dir * length`,
/// ticks pointing `out` (unit, world space).
struct AxisLine {
    index: usize,
    start: DVec3,
    dir: DVec3,
    out: DVec3,
    from: f64,
    to: f64,
}

impl<'a> Layout<'a> {
    fn new(axes: &'a Axes, camera: &'a Camera) -> Layout<'a> {
        let dir = camera.direction();
        let right = dir.cross(camera.up).try_normalize().unwrap_or(DVec3::X);
        let up = right.cross(dir).normalize();
        Layout { axes, camera, right, up, segments: Vec::new(), labels: Vec::new(), boxes: Vec::new() }
    }

    /// Towards the eye from `p` (the eye is at infinity for a parallel view).
    fn to_eye(&self, p: DVec3) -> DVec3 {
        match self.camera.projection {
            Projection::Perspective { .. } => self.camera.eye - p,
            Projection::Orthographic { .. } => -self.camera.direction(),
        }
    }

    /// Picture position of a point (device x, y), if in front of the eye.
    fn picture(&self, p: DVec3) -> Option<DVec2> {
        self.camera.project(p).map(|d| DVec2::new(d.x, d.y))
    }

    fn lay_out(&mut self) {
        let (lo, hi) = (self.axes.lo, self.axes.hi);
        let c = (lo + hi) / 2.0;
        let e = self.to_eye(c);
        // The sides nearer the eye, and the outward normals of those faces.
        let (y_near, y_far, oy) = if e.y < 0.0 { (lo.y, hi.y, -DVec3::Y) } else { (hi.y, lo.y, DVec3::Y) };
        let (x_near, x_far, ox) = if e.x < 0.0 { (lo.x, hi.x, -DVec3::X) } else { (hi.x, lo.x, DVec3::X) };
        let at = |x: f64, y: f64, z: f64| DVec3::new(x, y, z);
        // z stands at the corner beside the near corner that is leftmost on
        // the picture; its ticks point left on the picture, level, so that
        // its labels stand outside the box's outline there.
        let a = at(x_far, y_near, lo.z);
        let b = at(x_near, y_far, lo.z);
        let left = |p: DVec3| self.picture(p).map_or(f64::INFINITY, |q| q.x);
        let (zx, zy) = if left(a) <= left(b) { (x_far, y_near) } else { (x_near, y_far) };
        let oz = DVec3::new(-self.right.x, -self.right.y, 0.0).try_normalize().unwrap_or(-ox);
        match self.axes.style {
            AxesStyle::Box => {
                for &z in &[lo.z, hi.z] {
                    self.segments.push((at(lo.x, lo.y, z), at(hi.x, lo.y, z)));
                    self.segments.push((at(hi.x, lo.y, z), at(hi.x, hi.y, z)));
                    self.segments.push((at(hi.x, hi.y, z), at(lo.x, hi.y, z)));
                    self.segments.push((at(lo.x, hi.y, z), at(lo.x, lo.y, z)));
                }
                for &(x, y) in &[(lo.x, lo.y), (hi.x, lo.y), (hi.x, hi.y), (lo.x, hi.y)] {
                    self.segments.push((at(x, y, lo.z), at(x, y, hi.z)));
                }
            }
            AxesStyle::Axes => {
                self.segments.push((at(lo.x, y_near, lo.z), at(hi.x, y_near, lo.z)));
                self.segments.push((at(x_near, lo.y, lo.z), at(x_near, hi.y, lo.z)));
                self.segments.push((at(zx, zy, lo.z), at(zx, zy, hi.z)));
            }
        }
        let lines = [
            AxisLine { index: 0, start: at(0.0, y_near, lo.z), dir: DVec3::X, out: oy, from: lo.x, to: hi.x },
            AxisLine { index: 1, start: at(x_near, 0.0, lo.z), dir: DVec3::Y, out: ox, from: lo.y, to: hi.y },
            AxisLine { index: 2, start: at(zx, zy, 0.0), dir: DVec3::Z, out: oz, from: lo.z, to: hi.z },
        ];
        // z first: its labels have the least room (a flat surface's box is
        // low), and the x and y axes can spare the label at a shared corner.
        for line in [&lines[2], &lines[0], &lines[1]] {
            self.axis(line);
        }
    }

    /// Ticks, tick labels and title of one axis.
    fn axis(&mut self, line: &AxisLine) {
        let h = self.axes.label_height;
        let tick = 0.5 * h;
        let point = |v: f64| line.start + line.dir * v;
        // The picture direction of `out` says how labels hang off the ticks.
        let align = self.alignment(point((line.from + line.to) / 2.0), line.out);
        // Fewer ticks until the labels keep apart; then drop the ones that do not.
        let mut chosen = Vec::new();
        for n in (2..=self.axes.ticks.max(2)).rev() {
            let values = nice_ticks(line.from, line.to, n);
            let step = if values.len() > 1 { values[1] - values[0] } else { 1.0 };
            let labels: Vec<(f64, Vec<Vec<DVec3>>)> =
                values.iter().map(|&v| (v, self.text(&tick_label(v, step), point(v) + line.out * (tick * 1.5), h, align))).collect();
            let apart = self.all_apart(labels.iter().map(|(_, t)| t.as_slice()));
            chosen = labels.into_iter().map(|(v, t)| (v, tick_label(v, step), t)).collect();
            if apart {
                break;
            }
        }
        let mut block = 0.0f64;
        for (v, text, strokes) in chosen {
            let Some(bx) = self.picture_box(&strokes) else { continue };
            if self.collides(bx) {
                continue;
            }
            self.segments.push((point(v), point(v) + line.out * tick));
            block = block.max(self.extent(&text, h, align));
            self.place(line.index, false, text, strokes, bx);
        }
        // The title beyond the tick labels, in the middle of the axis.
        let title = &self.axes.titles[line.index];
        if title.is_empty() {
            return;
        }
        let anchor = point((line.from + line.to) / 2.0) + line.out * (tick * 1.5) + self.away(align) * (block + 0.6 * h);
        let strokes = self.text(title, anchor, 1.2 * h, align);
        if let Some(bx) = self.picture_box(&strokes) {
            self.place(line.index, true, title.clone(), strokes, bx);
        }
    }

    /// How a label hangs off a point whose outward direction is `out`:
    /// below, above, left of or right of it on the picture.
    fn alignment(&self, p: DVec3, out: DVec3) -> (Align, Align) {
        let (Some(a), Some(b)) = (self.picture(p), self.picture(p + out)) else { return (Align::Center, Align::End) };
        let d = b - a;
        if d.y.abs() >= d.x.abs() {
            (Align::Center, if d.y < 0.0 { Align::End } else { Align::Start })
        } else {
            (if d.x < 0.0 { Align::End } else { Align::Start }, Align::Center)
        }
    }

    /// The picture-plane direction a label block grows in for `align`.
    fn away(&self, align: (Align, Align)) -> DVec3 {
        match align {
            (Align::End, _) => -self.right,
            (Align::Start, Align::Center) => self.right,
            (_, Align::End) => -self.up,
            _ => self.up,
        }
    }

    /// The size of a label across its block: its width when labels stand
    /// beside the axis, its height when they hang below or above it.
    fn extent(&self, text: &str, h: f64, align: (Align, Align)) -> f64 {
        match align {
            (Align::Center, _) => h,
            _ => text_width(text, h),
        }
    }

    /// `text` at `anchor` in the picture plane.
    fn text(&self, text: &str, anchor: DVec3, h: f64, align: (Align, Align)) -> Vec<Vec<DVec3>> {
        text_polylines(text, &TextPlacement::new(anchor, self.right, self.up, h).aligned(align.0, align.1))
    }

    /// The picture-space box of some strokes, grown by half the label gap.
    fn picture_box(&self, strokes: &[Vec<DVec3>]) -> Option<(DVec2, DVec2)> {
        let mut lo = DVec2::splat(f64::INFINITY);
        let mut hi = DVec2::splat(f64::NEG_INFINITY);
        for p in strokes.iter().flatten() {
            let q = self.picture(*p)?;
            lo = lo.min(q);
            hi = hi.max(q);
        }
        if !(lo.x <= hi.x) {
            return None;
        }
        let pad = 0.5 * LABEL_GAP * (hi - lo).min_element().max(0.0);
        Some((lo - DVec2::splat(pad), hi + DVec2::splat(pad)))
    }

    fn collides(&self, bx: (DVec2, DVec2)) -> bool {
        self.boxes.iter().any(|b| overlap(*b, bx))
    }

    /// No two of these labels, and none of them and a label placed before, overlap.
    fn all_apart<'t>(&self, labels: impl Iterator<Item = &'t [Vec<DVec3>]>) -> bool {
        let mut boxes: Vec<(DVec2, DVec2)> = Vec::new();
        for strokes in labels {
            let Some(bx) = self.picture_box(strokes) else { continue };
            if self.collides(bx) || boxes.iter().any(|b| overlap(*b, bx)) {
                return false;
            }
            boxes.push(bx);
        }
        true
    }

    fn place(&mut self, axis: usize, title: bool, text: String, strokes: Vec<Vec<DVec3>>, bx: (DVec2, DVec2)) {
        let first = self.segments.len();
        for line in strokes {
            self.segments.extend(line.windows(2).map(|w| (w[0], w[1])));
        }
        self.labels.push(Label { axis, title, text, segments: first..self.segments.len() });
        self.boxes.push(bx);
    }
}

/// Whether two boxes share any point.
fn overlap(a: (DVec2, DVec2), b: (DVec2, DVec2)) -> bool {
    a.0.x <= b.1.x && b.0.x <= a.1.x && a.0.y <= b.1.y && b.0.y <= a.1.y
}

#[cfg(test)]
mod tests {
    use super::*;
    use hiddenline::grid::{Grid, GridLines};

    fn surface() -> Surface {
        let g = Grid::from_fn(Grid::linspace(0.0, 10.0, 10), Grid::linspace(-1.0, 1.0, 10), |x, y| x * 0.1 + y).unwrap();
        Surface { grid: g, lines: GridLines::Both, every: 1, pen: 1 }
    }

    fn spec(text: &str) -> AxesSpec {
        toml::from_str(text).unwrap()
    }

    fn camera(eye: [f64; 3]) -> Camera {
        Camera::new(DVec3::from(eye), DVec3::new(5.0, 0.0, 0.5), DVec3::Z, Projection::Perspective { fov_deg: 35.0 }).unwrap()
    }

    fn axes(text: &str, eye: [f64; 3]) -> Axes {
        Axes::from_spec(&spec(text), &[surface()], None, &camera(eye)).unwrap()
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
        let a = axes("", [-8.0, -12.0, 6.0]);
        let b = axes("style = \"axes\"\ntitles = [\"\", \"\", \"\"]", [-8.0, -12.0, 6.0]);
        // Box (12) + ticks + label strokes; the bare axes have 3 lines + ticks + labels.
        assert!(a.segments.len() > b.segments.len() + 9);
        // Everything stays near the surface's box (labels just outside it).
        for &(p, q) in &a.segments {
            for v in [p, q] {
                assert!(v.x > -4.0 && v.x < 14.0 && v.y > -5.0 && v.y < 5.0 && v.z > -3.0 && v.z < 4.0, "{v}");
            }
        }
        let mut mb = ModelBuilder::new();
        a.lower(&mut mb);
        let m = mb.finish();
        assert!(m.faces.is_empty() && m.edges.iter().all(|e| e.faces.is_empty()));
    }

    #[test]
    fn axes_move_to_the_edges_facing_the_eye() {
        // From the -x, -y side the x axis is on y = -1 and the y axis on x = 0;
        // from the +x, +y side on y = 1 and x = 10.
        let mid_of = |a: &Axes, axis: usize| {
            let l = a.labels.iter().find(|l| l.axis == axis && !l.title).expect("a tick label");
            let pts: Vec<DVec3> = a.segments[l.segments.clone()].iter().flat_map(|s| [s.0, s.1]).collect();
            pts.iter().copied().sum::<DVec3>() / pts.len() as f64
        };
        let front = axes("", [-8.0, -12.0, 6.0]);
        let back = axes("", [18.0, 12.0, 6.0]);
        assert!(mid_of(&front, 0).y < -1.0 && mid_of(&back, 0).y > 1.0);
        assert!(mid_of(&front, 1).x < 0.0 && mid_of(&back, 1).x > 10.0);
        // Every axis has a title and tick labels. Not always two: the 2-unit
        // y side of this 10-unit box is foreshortened to about 2.5 label
        // heights on the picture, so from the front its "-1" and "0" labels
        // overlap each other and its "1" takes the corner z's "-1" holds,
        // leaving one; from the back it keeps "0" and "1".
        for a in [&front, &back] {
            for axis in 0..3 {
                assert_eq!(a.labels.iter().filter(|l| l.axis == axis && l.title).count(), 1);
                assert!(a.labels.iter().filter(|l| l.axis == axis && !l.title).count() >= 1, "axis {axis}: {:?}", a.labels);
            }
        }
    }

    #[test]
    fn bad_axes() {
        let e = |t: &str| Axes::from_spec(&spec(t), &[surface()], None, &camera([-8.0, -12.0, 6.0])).unwrap_err();
        assert_eq!(e("surface = 3").0, "surface");
        assert_eq!(e("ticks = 0").0, "ticks");
        assert_eq!(e("label_size = 2.0").0, "label_size");
    }
}
