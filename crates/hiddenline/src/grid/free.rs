//! Free lines with a grid surface: axes, ticks, labels and base-plane
//! contours, hidden by the surface without the general engine (Anderson,
//! section 7).
//!
//! A free line is tested against the complete picture of the surface, after
//! the grid engine's sweep, wherever that is exact: where every surface point
//! on the sight line through a point of the line lies between the eye and that
//! point, the point is hidden exactly when it is strictly inside the picture;
//! where every such surface point lies beyond it, it is visible. Which case
//! holds is read off the ground plan: the sight line's ground projection runs
//! from the eye's ground point through the point's, and meets the grid's
//! rectangle in one interval. So each line is cut where its ground projection
//! crosses the rectangle's sides or the lines from the eye's ground point
//! through the rectangle's corners, and each piece is
//! - with no part of the rectangle beyond it on its sight line (behind the
//!   rectangle, or on its far side): tested against the picture. The
//!   rectangle is closed: a sight line that only grazes a side or a corner
//!   meets the surface's boundary profile, which hides as any face's
//!   boundary does (the reference's tie rule), so the eye in a boundary
//!   plane of the grid is no special case;
//! - with the whole rectangle beyond it (in front, or on its near side):
//!   visible;
//! - over the rectangle with some of it beyond, at or below the surface's
//!   lowest point, seen from above it (a base plane under the surface):
//!   tested against the picture, since a surface point beyond it would lie
//!   lower still;
//! - over the rectangle, at or above the highest point, seen from above it:
//!   visible.
//!
//! Any other piece (a line through the surface's height range over the
//! rectangle, or seen from below) cannot be settled by the complete picture:
//! [`visibility_with_free`] answers `None` and the caller uses the general
//! engine. Contours on the surface lie in its facets and are tested like grid
//! edges instead: when their facet is visited, before it is merged.

use super::{clipped_ends, DrawnLines, Engine, Grid};
use crate::camera::{Camera, Projection};
use crate::model::{Intervals, LineSource, LineVisibility};
use glam::{DVec2, DVec3};

/// A segment drawn with the surface that lies on none of its facets.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FreeSegment {
    /// One end, world space.
    pub a: DVec3,
    /// The other end.
    pub b: DVec3,
    /// Pen.
    pub pen: u32,
    /// The facet the segment lies in, for a contour on the surface (numbered
    /// as `scene::contours::trace_facets` numbers them): it is then
    /// tested when its facet is visited, before the facet is merged.
    pub facet: Option<u32>,
}

/// How a piece of a free line is decided.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Mode {
    /// Hidden where strictly inside the surface's picture.
    Covered,
    /// Never hidden by the surface.
    Visible,
}

/// The grid lines' visibility as [`super::visibility`] numbers them, then one
/// [`LineVisibility`] per free segment (zero-length ones skipped, as
/// `scene::ModelBuilder::add_edge` skips them), numbered on from the
/// grid's edges in the order given; `None` when some piece of a free segment
/// cannot be decided exactly from the complete picture (see the module
/// documentation).
#[must_use]
pub fn visibility_with_free(
    grid: &Grid,
    camera: &Camera,
    lines: impl Into<DrawnLines>,
    pen: u32,
    free: &[FreeSegment],
) -> Option<Vec<LineVisibility>> {
    let lines = lines.into();
    // Classify first: an undecidable piece sends the whole scene to the
    // general engine before any sweeping is done.
    let pieces = classify(grid, camera, free)?;
    let in_facet: Vec<(u32, DVec3, DVec3)> = free.iter().filter_map(|s| Some((s.facet?, s.a, s.b))).collect();
    let mut engine = Engine::new(grid, camera, lines).with_in_facet(&in_facet).compute();
    let mut in_facet_results = std::mem::take(&mut engine.in_facet.result).into_iter();
    let first = lines.edge_count(grid) as u32;
    let mut picture = std::mem::take(&mut engine.picture);
    let mut out = engine.into_visibility(pen);
    let mut k = first;
    let mut vis = Vec::new();
    for (s, pieces) in free.iter().zip(pieces) {
        let tested = if s.facet.is_some() { in_facet_results.next() } else { None };
        if s.a == s.b {
            continue;
        }
        let e = k;
        k += 1;
        if s.facet.is_some() {
            if let Some(Some((a, b, visible))) = tested {
                out.push(LineVisibility { source: LineSource::Edge(e), pen: s.pen, a, b, visible: Intervals::from_slice(&visible) });
            }
            continue;
        }
        let Some((a, b)) = clipped_ends(camera, s.a, s.b) else { continue };
        let d = b - a;
        let l2 = d.length_squared();
        // Device parameter of a world point of the segment's image.
        let t_of = |p: DVec2| if l2 > 0.0 { ((p - a).dot(d) / l2).clamp(0.0, 1.0) } else { 0.0 };
        let mut visible: Vec<(f64, f64)> = Vec::new();
        for (s0, s1, mode) in pieces {
            let (w0, w1) = (s.a.lerp(s.b, s0), s.a.lerp(s.b, s1));
            let Some((p, q)) = clipped_ends(camera, w0, w1) else { continue };
            let (tp, tq) = (t_of(p), t_of(q));
            vis.clear();
            match mode {
                Mode::Covered if !picture.is_empty() => super::sweep::visible_among(&mut picture, p, q, &mut vis),
                _ => vis.push((0.0, 1.0)),
            }
            for &(u0, u1) in &vis {
                let (x, y) = (tp + (tq - tp) * u0, tp + (tq - tp) * u1);
                push_union(&mut visible, x.min(y), x.max(y));
            }
        }
        visible.sort_by(|x, y| x.0.total_cmp(&y.0));
        let mut merged = Intervals::with_capacity(visible.len());
        for (x, y) in visible {
            match merged.last_mut() {
                Some(last) if x <= last.1 + super::tolerance::SLIVER => last.1 = last.1.max(y),
                _ => merged.push((x, y)),
            }
        }
        out.push(LineVisibility { source: LineSource::Edge(e), pen: s.pen, a, b, visible: merged });
    }
    Some(out)
}

fn push_union(v: &mut Vec<(f64, f64)>, x: f64, y: f64) {
    if y > x {
        v.push((x, y));
    }
}

/// Whether [`visibility_with_free`] draws `free` with `grid` seen by
/// `camera` (rather than answering `None`): decided from the ground plan
/// alone, without sweeping, so a scene can tell at load time that the
/// surface never reaches the general engine.
#[must_use]
pub fn takes(grid: &Grid, camera: &Camera, free: &[FreeSegment]) -> bool {
    classify(grid, camera, free).is_some()
}

/// The ground-plan pieces of every free segment (none for segments lying in
/// facets), or `None` when one cannot be decided.
fn classify(grid: &Grid, camera: &Camera, free: &[FreeSegment]) -> Option<Vec<Vec<(f64, f64, Mode)>>> {
    let plan = Plan::new(grid, camera)?;
    free.iter().map(|s| if s.facet.is_some() { Some(Vec::new()) } else { plan.pieces(s.a, s.b) }).collect()
}

/// The ground plan: the grid's rectangle, its height range, and where the
/// eye is.
struct Plan {
    lo: DVec2,
    hi: DVec2,
    zmin: f64,
    zmax: f64,
    /// The eye's ground point (perspective), with its height.
    eye: Option<DVec3>,
    /// Ground direction of sight (orthographic), and its vertical part.
    dir: DVec3,
}

impl Plan {
    /// `None` when the view looks straight down or up (orthographic): then
    /// sight lines have no ground direction to decide by.
    fn new(grid: &Grid, camera: &Camera) -> Option<Plan> {
        let (zmin, zmax) = grid.z_range();
        let lo = DVec2::new(grid.xs[0], grid.ys[0]);
        let hi = DVec2::new(grid.xs[grid.nx() - 1], grid.ys[grid.ny() - 1]);
        let dir = camera.direction();
        let eye = match camera.projection {
            Projection::Perspective { .. } => Some(camera.eye),
            Projection::Orthographic { .. } => {
                if DVec2::new(dir.x, dir.y).length() <= super::tolerance::STRAIGHT_DOWN * dir.length() {
                    return None;
                }
                None
            }
        };
        Some(Plan { lo, hi, zmin, zmax, eye, dir })
    }

    /// The pieces `(s0, s1, mode)` of the world segment `a`-`b`, or `None`
    /// when one cannot be decided.
    fn pieces(&self, a: DVec3, b: DVec3) -> Option<Vec<(f64, f64, Mode)>> {
        let (ga, gb) = (DVec2::new(a.x, a.y), DVec2::new(b.x, b.y));
        let mut cuts = vec![0.0, 1.0];
        let mut cut_line = |p: DVec2, n: DVec2| {
            // Where the ground segment crosses the line through p with normal n.
            let (da, db) = ((ga - p).dot(n), (gb - p).dot(n));
            if (da < 0.0 && db > 0.0) || (da > 0.0 && db < 0.0) {
                cuts.push(da / (da - db));
            }
        };
        cut_line(self.lo, DVec2::X);
        cut_line(self.hi, DVec2::X);
        cut_line(self.lo, DVec2::Y);
        cut_line(self.hi, DVec2::Y);
        for c in [self.lo, self.hi, DVec2::new(self.lo.x, self.hi.y), DVec2::new(self.hi.x, self.lo.y)] {
            let along = match self.eye {
                Some(e) => c - DVec2::new(e.x, e.y),
                None => DVec2::new(self.dir.x, self.dir.y),
            };
            if along != DVec2::ZERO {
                cut_line(c, DVec2::new(-along.y, along.x));
            }
        }
        cuts.sort_by(f64::total_cmp);
        cuts.dedup();
        let mut out = Vec::with_capacity(cuts.len());
        for w in cuts.windows(2) {
            let (s0, s1) = (w[0], w[1]);
            if !(s1 > s0) {
                continue;
            }
            let (p0, p1) = (a.lerp(b, s0), a.lerp(b, s1));
            let m = a.lerp(b, 0.5 * (s0 + s1));
            let mode = self.mode(DVec2::new(m.x, m.y), p0.z.min(p1.z), p0.z.max(p1.z))?;
            match out.last_mut() {
                Some((_, end, last)) if *last == mode => *end = s1,
                _ => out.push((s0, s1, mode)),
            }
        }
        Some(out)
    }

    /// How a piece with ground midpoint `g` and heights in `[z0, z1]` is
    /// decided.
    fn mode(&self, g: DVec2, z0: f64, z1: f64) -> Option<Mode> {
        // The sight line's ground projection, from the eye's ground point
        // (parameter 0) through g (parameter 1), and where it runs over the
        // closed rectangle: touching a side or a corner counts, since faces
        // are closed sets and the boundary profile hides there too.
        let from = match self.eye {
            Some(e) => DVec2::new(e.x, e.y),
            None => {
                // The viewer is at infinity against the ground direction.
                let d = DVec2::new(self.dir.x, self.dir.y);
                let span = (self.hi - self.lo).length() + (g - self.lo).length() + 1.0;
                g - d.normalize() * span * 4.0
            }
        };
        let Some((t0, t1)) = line_span(from, g, self.lo, self.hi) else { return Some(Mode::Visible) };
        if t1 < 0.0 || t0 >= 1.0 {
            // The rectangle is behind the eye, or beyond the piece (a surface
            // point over g itself is not between the eye and the piece).
            return Some(Mode::Visible);
        }
        if t1 <= 1.0 {
            // Every surface point on the sight line is in front of the piece.
            return Some(Mode::Covered);
        }
        // Over the rectangle, with surface beyond the piece as well.
        let from_above = |z: f64| match self.eye {
            Some(e) => e.z > z,
            None => self.dir.z < 0.0,
        };
        if z1 <= self.zmin && from_above(z1) {
            return Some(Mode::Covered);
        }
        if z0 >= self.zmax && from_above(self.zmax) && self.eye.is_none_or(|e| e.z >= self.zmax) {
            return Some(Mode::Visible);
        }
        None
    }
}

/// The parameter interval over which the line through `p` (0) and `q` (1)
/// runs over the closed rectangle `[lo, hi]`, if it meets it (Liang-Barsky).
fn line_span(p: DVec2, q: DVec2, lo: DVec2, hi: DVec2) -> Option<(f64, f64)> {
    let d = q - p;
    let (mut t0, mut t1) = (f64::NEG_INFINITY, f64::INFINITY);
    for (den, num_lo, num_hi) in [(d.x, lo.x - p.x, hi.x - p.x), (d.y, lo.y - p.y, hi.y - p.y)] {
        if den == 0.0 {
            if !(num_lo <= 0.0 && num_hi >= 0.0) {
                return None;
            }
        } else {
            let (a, b) = (num_lo / den, num_hi / den);
            t0 = t0.max(a.min(b));
            t1 = t1.min(a.max(b));
        }
    }
    (t1 >= t0).then_some((t0, t1))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sight_line_over_the_closed_rectangle() {
        let (lo, hi) = (DVec2::ZERO, DVec2::ONE);
        let c = |p: [f64; 2], q: [f64; 2]| line_span(DVec2::from(p), DVec2::from(q), lo, hi);
        assert_eq!(c([-1.0, 0.5], [1.0, 0.5]), Some((0.5, 1.0)), "straight through, ends on the far side");
        assert_eq!(c([-1.0, 0.0], [3.0, 0.0]), Some((0.25, 0.5)), "along a side");
        assert_eq!(c([-1.0, -1.0], [0.0, 0.0]), Some((1.0, 2.0)), "through the diagonal");
        assert_eq!(c([-1.0, 1.0], [1.0, -1.0]), Some((0.5, 0.5)), "through a corner only");
        assert_eq!(c([2.0, 2.0], [3.0, 0.5]), None, "beside it");
        assert_eq!(c([-1.0, 1.5], [2.0, 1.5]), None, "above it");
    }

    #[test]
    fn pieces_are_cut_where_the_ground_plan_changes() {
        let g = Grid::from_fn(Grid::linspace(0.0, 1.0, 4), Grid::linspace(0.0, 1.0, 4), |x, y| 1.0 + x * y).unwrap();
        let cam = Camera::new(DVec3::new(0.5, -3.0, 3.0), DVec3::new(0.5, 0.5, 1.0), DVec3::Z, Projection::Perspective { fov_deg: 40.0 })
            .unwrap();
        let plan = Plan::new(&g, &cam).unwrap();
        // A line on the base plane across the grid and beyond it: in front,
        // under the surface, behind it.
        let p = plan.pieces(DVec3::new(0.5, -1.0, 0.0), DVec3::new(0.5, 2.0, 0.0)).unwrap();
        let modes: Vec<Mode> = p.iter().map(|x| x.2).collect();
        assert_eq!(modes, vec![Mode::Visible, Mode::Covered]);
        assert!((p[0].1 - 1.0 / 3.0).abs() < 1e-12, "{p:?}");
        // Over the grid within its height range: undecidable here.
        assert!(plan.pieces(DVec3::new(0.2, 0.5, 1.1), DVec3::new(0.8, 0.5, 1.1)).is_none());
        // Above the highest point, seen from above: visible.
        let top = plan.pieces(DVec3::new(0.2, 0.5, 2.5), DVec3::new(0.8, 0.5, 2.5)).unwrap();
        assert!(top.iter().all(|x| x.2 == Mode::Visible));
    }
}
