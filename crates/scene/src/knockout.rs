//! Knockout text: a `[[text]]` or `[[labels]]` table with `knockout = true`
//! is drawn whole over the picture, and every other line is cut where it
//! passes under the text, as a map printer knocks the linework out from
//! behind a name. Without it, text is placed where it can be seen and is
//! hidden by what stands in front of it like any line.
//!
//! **The region under a text** is the convex hull of its strokes' points,
//! each widened to a regular octagon (vertices at multiples of 45 degrees)
//! of radius [`MARGIN`] times the text's thickness: the hull's least width,
//! about its cap height whatever its angle or perspective. The cut is exact
//! ([`strokes::occult`]: lines end on the region's outline), and a later
//! knockout cuts an earlier one's strokes where the two meet.

use glam::DVec2;
use strokes::occult::{occult, Fill, FillRule, Occlusion, Shape};
use strokes::{Drawing, LineKind, Polyline};

/// The margin kept clear around a knockout text, as a fraction of its
/// thickness (about a third of a letter's height: room for the pen's width
/// and for the eye to tell the letters from the lines).
pub const MARGIN: f64 = 1.0 / 3.0;

/// A text to draw whole over the picture: its strokes on the page (mm) and
/// its pen.
#[derive(Clone, Debug, PartialEq)]
pub struct Knockout {
    /// Pen.
    pub pen: u32,
    /// Pen-down polylines, page millimetres.
    pub lines: Vec<Vec<DVec2>>,
}

impl Knockout {
    /// The region the text clears, as a closed ring (counter-clockwise);
    /// empty when the text has no points.
    #[must_use]
    pub fn region(&self) -> Vec<DVec2> {
        let points: Vec<DVec2> = self.lines.iter().flatten().copied().filter(|p| p.is_finite()).collect();
        let hull = convex_hull(points);
        let margin = MARGIN * least_width(&hull);
        let widened: Vec<DVec2> = hull
            .iter()
            .flat_map(|&p| (0..8).map(move |k| p + DVec2::from_angle(f64::from(k) * std::f64::consts::FRAC_PI_4) * margin))
            .collect();
        convex_hull(widened)
    }
}

/// Cuts every line of `drawing` where it passes under a knockout text, then
/// adds each text's strokes, whole, to its pen's visible layer. Texts in
/// order: a later one's region cuts an earlier one's strokes.
pub fn apply(drawing: &mut Drawing, knockouts: &[Knockout]) {
    if knockouts.is_empty() {
        return;
    }
    let layers = std::mem::take(&mut drawing.layers);
    let mut shapes: Vec<Shape> = layers.iter().map(|l| Shape { group: 0, lines: l.polylines.clone(), fill: None }).collect();
    for k in knockouts {
        let ring = k.region();
        shapes.push(Shape {
            group: 0,
            lines: k.lines.iter().map(|l| Polyline::new(l.clone())).collect(),
            fill: (ring.len() >= 3).then(|| Fill { rings: vec![ring], rule: FillRule::NonZero }),
        });
    }
    let kept = occult(&shapes, Occlusion::Across);
    let mut kept = kept.into_iter();
    for (layer, lines) in layers.into_iter().zip(kept.by_ref()) {
        drawing.layer_mut(layer.pen, layer.kind).polylines = lines;
    }
    for (k, lines) in knockouts.iter().zip(kept) {
        drawing.layer_mut(k.pen, LineKind::Visible).polylines.extend(lines);
    }
    drawing.layers.retain(|l| !l.polylines.is_empty());
}

/// The convex hull of `points`, counter-clockwise, without collinear
/// points (Andrew's monotone chain); fewer than three points come back as
/// they are, deduplicated.
fn convex_hull(mut points: Vec<DVec2>) -> Vec<DVec2> {
    points.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    points.dedup();
    if points.len() < 3 {
        return points;
    }
    let turn = |o: DVec2, a: DVec2, b: DVec2| (a - o).perp_dot(b - o);
    let mut hull: Vec<DVec2> = Vec::with_capacity(points.len() + 1);
    for pass in [&points[..], &points.iter().rev().copied().collect::<Vec<_>>()[..]] {
        let floor = hull.len();
        for &p in pass {
            while hull.len() >= floor + 2 && turn(hull[hull.len() - 2], hull[hull.len() - 1], p) <= 0.0 {
                hull.pop();
            }
            hull.push(p);
        }
        hull.pop();
    }
    hull
}

/// The least width of a convex polygon: over its edges, the greatest
/// distance of a vertex from the edge's line, least over the edges. Zero
/// for fewer than three vertices.
fn least_width(hull: &[DVec2]) -> f64 {
    if hull.len() < 3 {
        return 0.0;
    }
    (0..hull.len())
        .map(|i| {
            let (a, b) = (hull[i], hull[(i + 1) % hull.len()]);
            let d = (b - a).normalize_or_zero();
            hull.iter().map(|&p| d.perp_dot(p - a).abs()).fold(0.0, f64::max)
        })
        .fold(f64::INFINITY, f64::min)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hull_of_a_square_with_inner_and_edge_points() {
        let pts = vec![
            DVec2::new(0.0, 0.0),
            DVec2::new(2.0, 0.0),
            DVec2::new(1.0, 0.0),
            DVec2::new(2.0, 2.0),
            DVec2::new(0.0, 2.0),
            DVec2::new(1.0, 1.0),
        ];
        let h = convex_hull(pts);
        assert_eq!(h, vec![DVec2::new(0.0, 0.0), DVec2::new(2.0, 0.0), DVec2::new(2.0, 2.0), DVec2::new(0.0, 2.0)]);
        assert!((least_width(&h) - 2.0).abs() < 1e-12);
    }

    #[test]
    fn a_line_under_a_text_is_cut_at_the_region_and_the_text_is_whole() {
        // A "text" that is one 10 x 3 box outline; a line straight through it.
        let text =
            vec![vec![DVec2::new(0.0, 0.0), DVec2::new(10.0, 0.0), DVec2::new(10.0, 3.0), DVec2::new(0.0, 3.0), DVec2::new(0.0, 0.0)]];
        let mut d = Drawing::new(100.0, 100.0);
        d.layer_mut(1, LineKind::Visible).polylines.push(Polyline::new(vec![DVec2::new(-20.0, 1.5), DVec2::new(30.0, 1.5)]));
        apply(&mut d, &[Knockout { pen: 2, lines: text.clone() }]);
        let line: Vec<_> = d.layers.iter().find(|l| l.pen == 1).unwrap().polylines.clone();
        // Margin: a third of the least width (3): 1 mm; the octagon's
        // side point reaches exactly 1 mm left and right.
        assert_eq!(line.len(), 2, "{line:?}");
        let ends: Vec<f64> = line.iter().flat_map(|p| [p.points[0].x, p.points[p.points.len() - 1].x]).collect();
        let mut ends = ends;
        ends.sort_by(f64::total_cmp);
        assert!(
            (ends[0] + 20.0).abs() < 1e-9 && (ends[1] + 1.0).abs() < 1e-9 && (ends[2] - 11.0).abs() < 1e-9 && (ends[3] - 30.0).abs() < 1e-9,
            "{ends:?}"
        );
        let drawn: Vec<_> = d.layers.iter().find(|l| l.pen == 2).unwrap().polylines.iter().map(|p| p.points.clone()).collect();
        assert_eq!(drawn, text);
    }
}
