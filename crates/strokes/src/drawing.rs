//! The 2-D result of rendering: polylines on a page, grouped by pen.
//!
//! Page space is millimetres with the origin at the bottom-left corner of the
//! paper, x to the right and y up. Every later stage (stroke ordering, HP-GL,
//! G-code, SVG) works on this type.

use crate::dash::Dash;
use glam::DVec2;
use rayon::prelude::*;

/// A drawing on one sheet of paper.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Drawing {
    /// Paper width in millimetres.
    pub width_mm: f64,
    /// Paper height in millimetres.
    pub height_mm: f64,
    /// Layers in plotting order; a plotter draws one layer (one pen) at a time.
    pub layers: Vec<Layer>,
    /// How the [`LineKind::Hidden`] layers are dashed on paper.
    pub hidden_dash: Dash,
}

/// Everything drawn with one pen in one line style.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Layer {
    /// Pen number, 1-based as plotters count them.
    pub pen: u32,
    /// Whether these are visible lines or the (optional) hidden ones.
    pub kind: LineKind,
    /// The strokes of this layer, in drawing order.
    pub polylines: Vec<Polyline>,
}

/// What a layer's lines are.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum LineKind {
    /// Lines the viewer sees.
    #[default]
    Visible,
    /// Lines behind a face, drawn only on request (engineering-drawing style).
    Hidden,
}

/// A connected chain of straight segments, drawn with the pen down throughout.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Polyline {
    /// Vertices in drawing order; at least two for anything that draws.
    pub points: Vec<DVec2>,
}

impl Polyline {
    /// A polyline through `points`.
    pub fn new(points: Vec<DVec2>) -> Self {
        Polyline { points }
    }

    /// Sum of segment lengths.
    #[must_use]
    pub fn length(&self) -> f64 {
        self.points.windows(2).map(|w| w[0].distance(w[1])).sum()
    }

    /// First vertex, if any.
    #[must_use]
    pub fn start(&self) -> Option<DVec2> {
        self.points.first().copied()
    }

    /// Last vertex, if any.
    #[must_use]
    pub fn end(&self) -> Option<DVec2> {
        self.points.last().copied()
    }

    /// Reverses the drawing direction in place.
    pub fn reverse(&mut self) {
        self.points.reverse();
    }
}

impl Drawing {
    /// An empty drawing on paper of the given size.
    pub fn new(width_mm: f64, height_mm: f64) -> Self {
        Drawing { width_mm, height_mm, layers: Vec::new(), hidden_dash: Dash::default() }
    }

    /// The layer for `(pen, kind)`, created at the end if it does not exist yet.
    pub fn layer_mut(&mut self, pen: u32, kind: LineKind) -> &mut Layer {
        match self.layers.iter().position(|l| l.pen == pen && l.kind == kind) {
            Some(i) => &mut self.layers[i],
            None => {
                self.layers.push(Layer { pen, kind, polylines: Vec::new() });
                self.layers.last_mut().expect("just pushed")
            }
        }
    }

    /// Total length of all polylines in millimetres (each measured in
    /// parallel, added in order: the same sum as one pass).
    #[must_use]
    pub fn drawn_length(&self) -> f64 {
        let lengths: Vec<f64> = self.layers.par_iter().flat_map(|l| l.polylines.par_iter().map(Polyline::length)).collect();
        lengths.into_iter().sum()
    }

    /// Number of polylines with at least one segment.
    #[must_use]
    pub fn stroke_count(&self) -> usize {
        self.layers.iter().flat_map(|l| &l.polylines).filter(|p| p.points.len() >= 2).count()
    }

    /// Smallest axis-aligned box holding every vertex, as (min, max); `None`
    /// when nothing is drawn.
    #[must_use]
    pub fn bounds(&self) -> Option<(DVec2, DVec2)> {
        // Each polyline's box in parallel (a large drawing has millions of
        // points), then the boxes' box.
        self.layers
            .par_iter()
            .flat_map(|l| l.polylines.par_iter())
            .filter_map(|p| {
                let mut pts = p.points.iter();
                let first = *pts.next()?;
                Some(pts.fold((first, first), |(lo, hi), p| (lo.min(*p), hi.max(*p))))
            })
            .reduce_with(|a, b| (a.0.min(b.0), a.1.max(b.1)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pl(pts: &[(f64, f64)]) -> Polyline {
        Polyline::new(pts.iter().map(|&(x, y)| DVec2::new(x, y)).collect())
    }

    #[test]
    fn length_and_counts() {
        let mut d = Drawing::new(297.0, 210.0);
        d.layer_mut(1, LineKind::Visible).polylines.push(pl(&[(0.0, 0.0), (3.0, 4.0), (3.0, 0.0)]));
        d.layer_mut(2, LineKind::Visible).polylines.push(pl(&[(1.0, 1.0)]));
        d.layer_mut(1, LineKind::Visible).polylines.push(pl(&[(0.0, 0.0), (0.0, 1.0)]));
        assert_eq!(d.layers.len(), 2);
        assert_eq!(d.stroke_count(), 2);
        assert!((d.drawn_length() - 10.0).abs() < 1e-12);
        assert_eq!(d.bounds(), Some((DVec2::new(0.0, 0.0), DVec2::new(3.0, 4.0))));
    }

    #[test]
    fn empty_drawing_has_no_bounds() {
        assert_eq!(Drawing::new(1.0, 1.0).bounds(), None);
    }
}
