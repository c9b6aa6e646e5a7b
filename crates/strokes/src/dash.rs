//! How hidden lines are dashed on paper, and cutting a line into its dashes.
//!
//! A [`Dash`] is the pattern (dash and gap lengths in millimetres on paper).
//! It travels with the [`crate::Drawing`] from the scene's `[render]` table to
//! every writer: the SVG preview writes it as a `stroke-dasharray`, an HP-GL
//! device draws it with its own line type, and where the device cannot,
//! [`Dash::cut`] cuts each hidden line into dashes that are plotted as
//! strokes. Cutting happens after ordering, so **a dashed line's dashes are
//! plotted one after the other**, in the line's direction.

use glam::DVec2;

/// Shortest dash or gap, mm: below this a pen's own width fills the gaps.
pub const MIN_DASH_MM: f64 = 0.2;
/// Longest dash or gap, mm.
pub const MAX_DASH_MM: f64 = 50.0;

/// A dash pattern: `dash_mm` drawn, `gap_mm` skipped, repeated; the line
/// starts with a dash.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dash {
    /// Length of a dash, mm on paper.
    pub dash_mm: f64,
    /// Length of a gap, mm on paper.
    pub gap_mm: f64,
}

impl Default for Dash {
    /// 3.5 mm dashes, 1.5 mm gaps: about the hidden line of technical drawing
    /// (ISO 128) for a 0.3 mm pen, and exactly an HP-GL line type 3 (70 %
    /// drawn) of a 5 mm pattern.
    fn default() -> Self {
        Dash { dash_mm: 3.5, gap_mm: 1.5 }
    }
}

impl Dash {
    /// Length of one dash and one gap, mm.
    #[must_use]
    pub fn period_mm(&self) -> f64 {
        self.dash_mm + self.gap_mm
    }

    /// The part of a period that is drawn, in (0, 1).
    #[must_use]
    pub fn drawn_fraction(&self) -> f64 {
        self.dash_mm / self.period_mm()
    }

    /// Whether both lengths are within [`MIN_DASH_MM`]..=[`MAX_DASH_MM`].
    #[must_use]
    pub fn is_valid(&self) -> bool {
        let ok = |v: f64| (MIN_DASH_MM..=MAX_DASH_MM).contains(&v);
        ok(self.dash_mm) && ok(self.gap_mm)
    }

    /// The dashes of the polyline through `points`, drawn at `scale` paper
    /// millimetres per unit of `points` (a drawing scaled down to fit keeps
    /// its dashes their length on paper). The pattern runs on across
    /// vertices, starting with a dash at the first point; the last dash may
    /// be short. Each dash keeps the polyline's vertices it passes, so a
    /// dash round a corner turns it.
    #[must_use]
    pub fn cut(&self, points: &[DVec2], scale: f64) -> Vec<Vec<DVec2>> {
        let (dash, gap) = (self.dash_mm / scale, self.gap_mm / scale);
        let mut out = Vec::new();
        let mut current: Vec<DVec2> = Vec::new();
        // Inside a dash (else a gap), and how much of it is left.
        let mut drawing = true;
        let mut left = dash;
        if let Some(&first) = points.first() {
            current.push(first);
        }
        for w in points.windows(2) {
            let (a, b) = (w[0], w[1]);
            let len = a.distance(b);
            let mut done = 0.0;
            while len - done > left {
                done += left;
                let p = a.lerp(b, done / len);
                if drawing {
                    current.push(p);
                    out.push(std::mem::take(&mut current));
                    left = gap;
                } else {
                    current.push(p);
                    left = dash;
                }
                drawing = !drawing;
            }
            left -= len - done;
            if drawing {
                current.push(b);
            }
        }
        if drawing && current.len() >= 2 {
            out.push(current);
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn length(p: &[DVec2]) -> f64 {
        p.windows(2).map(|w| w[0].distance(w[1])).sum()
    }

    #[test]
    fn a_straight_line_is_cut_into_dashes_and_gaps_of_the_pattern() {
        let d = Dash { dash_mm: 3.0, gap_mm: 2.0 };
        let cut = d.cut(&[DVec2::ZERO, DVec2::new(12.0, 0.0)], 1.0);
        let xs: Vec<(f64, f64)> = cut.iter().map(|p| (p[0].x, p[p.len() - 1].x)).collect();
        assert_eq!(xs, vec![(0.0, 3.0), (5.0, 8.0), (10.0, 12.0)]);
        // Scaled down by half on paper: twice as many units per dash.
        let half = d.cut(&[DVec2::ZERO, DVec2::new(12.0, 0.0)], 0.5);
        assert_eq!(half.iter().map(|p| (p[0].x, p[1].x)).collect::<Vec<_>>(), vec![(0.0, 6.0), (10.0, 12.0)]);
    }

    #[test]
    fn the_pattern_runs_on_round_corners() {
        let d = Dash { dash_mm: 3.0, gap_mm: 1.0 };
        // An L of 2 + 6: the first dash turns the corner.
        let cut = d.cut(&[DVec2::ZERO, DVec2::new(2.0, 0.0), DVec2::new(2.0, 6.0)], 1.0);
        assert_eq!(cut[0], vec![DVec2::ZERO, DVec2::new(2.0, 0.0), DVec2::new(2.0, 1.0)]);
        assert_eq!(cut[1], vec![DVec2::new(2.0, 2.0), DVec2::new(2.0, 5.0)]);
        assert_eq!(cut.len(), 2, "the tail, 7..8, is a gap");
        let drawn: f64 = cut.iter().map(|p| length(p)).sum();
        assert!((drawn - 6.0).abs() < 1e-12, "{drawn}: {cut:?}");
    }

    #[test]
    fn a_line_shorter_than_a_dash_is_one_dash_and_no_points_none() {
        let d = Dash::default();
        let p = vec![DVec2::ZERO, DVec2::new(1.0, 1.0)];
        assert_eq!(d.cut(&p, 1.0), vec![p]);
        assert!(d.cut(&[], 1.0).is_empty());
        assert!(d.cut(&[DVec2::ZERO], 1.0).is_empty());
        assert!(d.is_valid() && (d.drawn_fraction() - 0.7).abs() < 1e-12);
        assert!(!Dash { dash_mm: 0.1, gap_mm: 1.0 }.is_valid());
    }
}
