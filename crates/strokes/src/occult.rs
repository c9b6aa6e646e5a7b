//! 2-D occlusion: the parts of a drawing's lines that later filled shapes
//! cover are not drawn, as a printed picture shows them (what vpype's
//! `occult` does for SVG).
//!
//! A drawing made elsewhere (an SVG) is a sequence of shapes in painting
//! order, each its lines and, when filled, the region its fill covers. A
//! line survives where no later fill covers it; a shape's own fill never
//! hides its own lines (its outline is painted over it). Exact: each
//! segment is cut where it crosses the outline of a later fill, and each
//! piece kept or dropped by whether its middle lies inside that fill (by
//! the fill's rule), so what is kept ends on the outlines themselves,
//! nothing is sampled. Fills are found through a uniform grid of cells
//! over their bounding boxes, so a segment meets only the fills near it.

use crate::drawing::Polyline;
use glam::DVec2;
use rayon::prelude::*;

/// How a fill decides what is inside a region of several rings.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FillRule {
    /// Inside when the rings wind around the point a non-zero number of
    /// times (SVG's default).
    #[default]
    NonZero,
    /// Inside when a ray from the point crosses the rings an odd number of
    /// times.
    EvenOdd,
}

/// A filled region: closed rings (each implicitly closed) and its rule.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Fill {
    /// The rings; a ring of fewer than three points covers nothing.
    pub rings: Vec<Vec<DVec2>>,
    /// How the rings make a region.
    pub rule: FillRule,
}

/// One shape of a drawing, in painting order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Shape {
    /// Which group it belongs to (a layer): with [`Occlusion::PerGroup`],
    /// fills hide only lines of their own group.
    pub group: usize,
    /// The lines the pen draws.
    pub lines: Vec<Polyline>,
    /// The region it paints over what came before, if filled.
    pub fill: Option<Fill>,
}

/// Which lines later fills hide.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Occlusion {
    /// Lines of the same group only (a layer is a pen: one pen's fills do
    /// not hide another's lines).
    PerGroup,
    /// Every earlier line, whatever its group.
    Across,
}

impl Fill {
    fn bounds(&self) -> Option<(DVec2, DVec2)> {
        let mut pts = self.rings.iter().filter(|r| r.len() >= 3).flatten();
        let first = *pts.next()?;
        Some(pts.fold((first, first), |(lo, hi), p| (lo.min(*p), hi.max(*p))))
    }

    /// Whether `p` lies inside (by the rule; points on the outline may go
    /// either way).
    #[must_use]
    pub fn contains(&self, p: DVec2) -> bool {
        let mut winding = 0i32;
        for ring in self.rings.iter().filter(|r| r.len() >= 3) {
            for (k, &a) in ring.iter().enumerate() {
                let b = ring[(k + 1) % ring.len()];
                if (a.y <= p.y) != (b.y <= p.y) {
                    let side = (b - a).perp_dot(p - a);
                    if b.y > a.y && side > 0.0 {
                        winding += 1;
                    } else if b.y <= a.y && side < 0.0 {
                        winding -= 1;
                    }
                }
            }
        }
        match self.rule {
            FillRule::NonZero => winding != 0,
            FillRule::EvenOdd => winding % 2 != 0,
        }
    }

    /// The parameters (0 to 1) where segment `a`-`b` crosses the outline,
    /// appended to `out`.
    fn crossings(&self, a: DVec2, b: DVec2, out: &mut Vec<f64>) {
        let d = b - a;
        for ring in self.rings.iter().filter(|r| r.len() >= 3) {
            for (k, &p) in ring.iter().enumerate() {
                let q = ring[(k + 1) % ring.len()];
                let e = q - p;
                let den = d.perp_dot(e);
                if den == 0.0 {
                    continue;
                }
                let t = (p - a).perp_dot(e) / den;
                let u = (p - a).perp_dot(d) / den;
                if (0.0..=1.0).contains(&t) && (0.0..=1.0).contains(&u) {
                    out.push(t);
                }
            }
        }
    }
}

/// The most cells of the fills' grid.
const MAX_CELLS: usize = 1 << 20;

/// A uniform grid of cells, each listing the fills whose bounding box
/// meets it.
struct FillCells {
    origin: DVec2,
    size: f64,
    columns: usize,
    rows: usize,
    /// Per cell, `shapes[start[c]..start[c + 1]]`, in painting order.
    start: Vec<u32>,
    shapes: Vec<u32>,
    /// Each shape's fill box (empty boxes for shapes without a fill).
    boxes: Vec<Option<(DVec2, DVec2)>>,
}

impl FillCells {
    fn new(shapes: &[Shape]) -> Option<FillCells> {
        let boxes: Vec<Option<(DVec2, DVec2)>> = shapes.iter().map(|s| s.fill.as_ref().and_then(Fill::bounds)).collect();
        let all = boxes.iter().flatten().copied().reduce(|a, b| (a.0.min(b.0), a.1.max(b.1)))?;
        let filled = boxes.iter().flatten().count();
        let extent = (all.1 - all.0).max(DVec2::splat(1e-9));
        // About one fill per cell, within MAX_CELLS.
        let cells = (filled * 2).clamp(1, MAX_CELLS) as f64;
        let size = (extent.x * extent.y / cells).sqrt().max(extent.max_element() / 4096.0);
        let columns = (extent.x / size).floor() as usize + 1;
        let rows = (extent.y / size).floor() as usize + 1;
        let mut grid = FillCells { origin: all.0, size, columns, rows, start: vec![0; columns * rows + 1], shapes: Vec::new(), boxes };
        for pass in 0..2 {
            let mut fill = grid.start.clone();
            for (s, b) in grid.boxes.iter().enumerate() {
                let Some(b) = b else { continue };
                let ((i0, j0), (i1, j1)) = (grid.cell(b.0), grid.cell(b.1));
                for j in j0..=j1 {
                    for i in i0..=i1 {
                        let c = j * columns + i;
                        if pass == 0 {
                            fill[c + 1] += 1;
                        } else {
                            grid.shapes[fill[c] as usize] = s as u32;
                            fill[c] += 1;
                        }
                    }
                }
            }
            if pass == 0 {
                for c in 0..columns * rows {
                    fill[c + 1] += fill[c];
                }
                grid.shapes = vec![0; fill[columns * rows] as usize];
                grid.start = fill;
            }
        }
        Some(grid)
    }

    /// The cell holding `p`, clamped to the grid.
    fn cell(&self, p: DVec2) -> (usize, usize) {
        let q = ((p - self.origin) / self.size).floor();
        let clamp = |v: f64, n: usize| if v <= 0.0 { 0 } else { (v as usize).min(n - 1) };
        (clamp(q.x, self.columns), clamp(q.y, self.rows))
    }

    /// The shapes after `after` whose fill box meets the box `lo`-`hi`, in
    /// painting order, into `out`.
    fn later_fills(&self, after: usize, lo: DVec2, hi: DVec2, out: &mut Vec<u32>) {
        out.clear();
        let ((i0, j0), (i1, j1)) = (self.cell(lo), self.cell(hi));
        for j in j0..=j1 {
            for i in i0..=i1 {
                let c = j * self.columns + i;
                for &s in &self.shapes[self.start[c] as usize..self.start[c + 1] as usize] {
                    if s as usize > after {
                        let b = self.boxes[s as usize].expect("listed: filled");
                        if b.0.x <= hi.x && lo.x <= b.1.x && b.0.y <= hi.y && lo.y <= b.1.y {
                            out.push(s);
                        }
                    }
                }
            }
        }
        out.sort_unstable();
        out.dedup();
    }
}

/// Every shape's lines less what later fills cover (of its own group, or
/// of any with [`Occlusion::Across`]): the pieces kept, per shape, in
/// order. Shapes are worked in parallel.
#[must_use]
pub fn occult(shapes: &[Shape], occlusion: Occlusion) -> Vec<Vec<Polyline>> {
    let Some(grid) = FillCells::new(shapes) else {
        return shapes.iter().map(|s| s.lines.clone()).collect();
    };
    shapes
        .par_iter()
        .enumerate()
        .map(|(n, shape)| {
            let mut kept: Vec<Polyline> = Vec::new();
            let (mut candidates, mut cuts, mut hidden) = (Vec::new(), Vec::new(), Vec::new());
            for line in &shape.lines {
                let mut current: Vec<DVec2> = Vec::new();
                for w in line.points.windows(2) {
                    let (a, b) = (w[0], w[1]);
                    grid.later_fills(n, a.min(b), a.max(b), &mut candidates);
                    candidates.retain(|&s| occlusion == Occlusion::Across || shapes[s as usize].group == shape.group);
                    hidden.clear();
                    for &s in &candidates {
                        let fill = shapes[s as usize].fill.as_ref().expect("listed: filled");
                        cuts.clear();
                        cuts.push(0.0);
                        cuts.push(1.0);
                        fill.crossings(a, b, &mut cuts);
                        // Uncrossed and inside: this fill hides it all, no
                        // other needs asking (most segments, where fills
                        // pile up).
                        if cuts.len() == 2 && fill.contains(a.lerp(b, 0.5)) {
                            hidden.clear();
                            hidden.push((0.0, 1.0));
                            break;
                        }
                        cuts.sort_by(f64::total_cmp);
                        for c in cuts.windows(2) {
                            if c[1] > c[0] && fill.contains(a.lerp(b, 0.5 * (c[0] + c[1]))) {
                                hidden.push((c[0], c[1]));
                            }
                        }
                    }
                    for (t0, t1) in shown(&mut hidden) {
                        let (p, q) = (if t0 == 0.0 { a } else { a.lerp(b, t0) }, if t1 == 1.0 { b } else { a.lerp(b, t1) });
                        if current.last() != Some(&p) {
                            flush(&mut current, &mut kept);
                            current.push(p);
                        }
                        current.push(q);
                    }
                }
                flush(&mut current, &mut kept);
            }
            kept
        })
        .collect()
}

/// The parts of 0 to 1 outside the `hidden` intervals.
fn shown(hidden: &mut [(f64, f64)]) -> Vec<(f64, f64)> {
    hidden.sort_by(|x, y| x.0.total_cmp(&y.0));
    let mut out = Vec::new();
    let mut from = 0.0;
    for &(h0, h1) in hidden.iter() {
        if h0 > from {
            out.push((from, h0));
        }
        from = f64::max(from, h1);
    }
    if from < 1.0 {
        out.push((from, 1.0));
    }
    out
}

fn flush(current: &mut Vec<DVec2>, kept: &mut Vec<Polyline>) {
    if current.len() >= 2 {
        kept.push(Polyline::new(std::mem::take(current)));
    }
    current.clear();
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(x: f64, y: f64, side: f64) -> Vec<DVec2> {
        vec![DVec2::new(x, y), DVec2::new(x + side, y), DVec2::new(x + side, y + side), DVec2::new(x, y + side)]
    }

    fn outlined(group: usize, ring: Vec<DVec2>, filled: bool) -> Shape {
        let mut closed = ring.clone();
        closed.push(ring[0]);
        Shape { group, lines: vec![Polyline::new(closed)], fill: filled.then(|| Fill { rings: vec![ring], rule: FillRule::NonZero }) }
    }

    fn length(lines: &[Polyline]) -> f64 {
        lines.iter().map(Polyline::length).sum()
    }

    #[test]
    fn a_later_fill_hides_what_it_covers_and_not_its_own_outline() {
        // Square A (0,0)-(10,10), then B (5,5)-(15,15) on top: A's right
        // and top edges run under B for 5 mm each.
        let shapes = [outlined(0, square(0.0, 0.0, 10.0), true), outlined(0, square(5.0, 5.0, 10.0), true)];
        let out = occult(&shapes, Occlusion::PerGroup);
        // A keeps its perimeter less the 5 + 5 mm inside B.
        assert!((length(&out[0]) - 30.0).abs() < 1e-9, "{}", length(&out[0]));
        assert!((length(&out[1]) - 40.0).abs() < 1e-9);
        // Kept pieces end on B's outline.
        for p in out[0].iter().flat_map(|l| &l.points) {
            assert!(!(p.x > 5.0 && p.y > 5.0), "{p}");
        }
    }

    #[test]
    fn groups_unfilled_shapes_and_holes() {
        let a = outlined(0, square(0.0, 0.0, 10.0), false);
        // Another group's fill hides nothing per group, everything across.
        let b = outlined(1, square(-1.0, -1.0, 12.0), true);
        let shapes = [a.clone(), b];
        assert!((length(&occult(&shapes, Occlusion::PerGroup)[0]) - 40.0).abs() < 1e-9);
        assert_eq!(length(&occult(&shapes, Occlusion::Across)[0]), 0.0);
        // An unfilled later shape hides nothing.
        let shapes = [a.clone(), outlined(0, square(-1.0, -1.0, 12.0), false)];
        assert!((length(&occult(&shapes, Occlusion::PerGroup)[0]) - 40.0).abs() < 1e-9);
        // A ring with a hole (even-odd): the square shows through the hole.
        let hole = Fill { rings: vec![square(-5.0, -5.0, 20.0), square(-1.0, -1.0, 12.0)], rule: FillRule::EvenOdd };
        let shapes = [a, Shape { group: 0, lines: Vec::new(), fill: Some(hole) }];
        assert!((length(&occult(&shapes, Occlusion::PerGroup)[0]) - 40.0).abs() < 1e-9);
    }

    #[test]
    fn winding_rules() {
        let twice = Fill { rings: vec![square(0.0, 0.0, 10.0), square(2.0, 2.0, 2.0)], rule: FillRule::NonZero };
        assert!(twice.contains(DVec2::new(3.0, 3.0)) && twice.contains(DVec2::new(8.0, 8.0)));
        assert!(!Fill { rule: FillRule::EvenOdd, ..twice.clone() }.contains(DVec2::new(3.0, 3.0)));
        assert!(!twice.contains(DVec2::new(11.0, 3.0)));
    }

    /// A random convex polygon (a turned regular n-gon) and its centre and
    /// corners, from a seeded sequence.
    fn convex(next: &mut impl FnMut() -> f64) -> Vec<DVec2> {
        let c = DVec2::new(100.0 * next(), 100.0 * next());
        let r = 5.0 + 25.0 * next();
        let n = 3 + (next() * 30.0) as usize;
        let turn = next() * std::f64::consts::TAU;
        // Counter-clockwise, some in the other sense: winding must not matter.
        let sense = if next() < 0.5 { 1.0 } else { -1.0 };
        (0..n).map(|k| c + r * DVec2::from_angle(turn + sense * std::f64::consts::TAU * k as f64 / n as f64)).collect()
    }

    /// Strictly inside a convex polygon by more than `margin`: on the inner
    /// side of every edge (the test's own predicate, not [`Fill::contains`]).
    fn deep_inside(poly: &[DVec2], p: DVec2, margin: f64) -> bool {
        let sign = (poly[1] - poly[0]).perp_dot(poly[2] - poly[1]).signum();
        (0..poly.len()).all(|k| {
            let (a, b) = (poly[k], poly[(k + 1) % poly.len()]);
            sign * (b - a).perp_dot(p - a) / a.distance(b) > margin
        })
    }

    /// Issue 40: random overlapping filled convex shapes, in two groups,
    /// against dense sampling of every line: nothing drawn lies inside a
    /// later fill that may hide it, and the length kept is the length the
    /// samples find visible.
    #[test]
    fn agrees_with_dense_sampling_on_random_overlapping_shapes() {
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let polys: Vec<Vec<DVec2>> = (0..60).map(|_| convex(&mut next)).collect();
        let shapes: Vec<Shape> = polys.iter().map(|p| outlined(usize::from(next() < 0.3), p.clone(), next() < 0.8)).collect();
        for occlusion in [Occlusion::PerGroup, Occlusion::Across] {
            let out = occult(&shapes, occlusion);
            let hides = |i: usize, j: usize| {
                j > i && shapes[j].fill.is_some() && (occlusion == Occlusion::Across || shapes[j].group == shapes[i].group)
            };
            let (mut sampled, mut kept) = (0.0, 0.0);
            for (i, shape) in shapes.iter().enumerate() {
                let step = 0.005;
                for w in shape.lines[0].points.windows(2) {
                    let n = (w[0].distance(w[1]) / step).ceil() as usize;
                    for k in 0..n {
                        let p = w[0].lerp(w[1], (k as f64 + 0.5) / n as f64);
                        if !(0..shapes.len()).any(|j| hides(i, j) && deep_inside(&polys[j], p, 0.0)) {
                            sampled += w[0].distance(w[1]) / n as f64;
                        }
                    }
                }
                for line in &out[i] {
                    kept += line.length();
                    for w in line.points.windows(2) {
                        for k in 0..=20 {
                            let p = w[0].lerp(w[1], k as f64 / 20.0);
                            let hider = (0..shapes.len()).find(|&j| hides(i, j) && deep_inside(&polys[j], p, 1e-7));
                            assert!(hider.is_none(), "{occlusion:?}: shape {i} draws {p} inside shape {hider:?}");
                        }
                    }
                }
            }
            let total: f64 = shapes.iter().map(|s| length(&s.lines)).sum();
            assert!(kept < 0.8 * total, "{occlusion:?}: something must be hidden ({kept} of {total})");
            assert!((kept - sampled).abs() < 1e-3 * total, "{occlusion:?}: kept {kept} mm, sampling finds {sampled} mm visible");
        }
    }
}
