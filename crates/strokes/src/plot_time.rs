//! How long a drawing takes to plot.
//!
//! Plot time is dominated by pen lifts and pen-up travel, which is why stroke
//! ordering matters. The model is deliberately simple: constant pen-down and
//! pen-up speeds, a fixed time per pen lift and per pen drop, and optionally
//! a trapezoidal speed profile per straight move when the acceleration is known.
//! Device profiles (in `plotcode`) supply the numbers.

use crate::drawing::Drawing;
use glam::DVec2;
use rayon::prelude::*;

/// Kinematic parameters of a plotter, in page millimetres and seconds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotionModel {
    /// Drawing speed with the pen down, mm/s.
    pub pen_down_speed: f64,
    /// Travel speed with the pen up, mm/s.
    pub pen_up_speed: f64,
    /// Seconds to lift the pen.
    pub pen_lift_time: f64,
    /// Seconds to lower the pen.
    pub pen_drop_time: f64,
    /// Acceleration in mm/s^2; `None` means moves reach full speed at once.
    pub acceleration: Option<f64>,
}

impl Default for MotionModel {
    /// Roughly an HP 7475A: 380 mm/s pen down (its fastest VS), faster
    /// pen-up slews, about 0.1 s per pen movement.
    fn default() -> Self {
        MotionModel { pen_down_speed: 380.0, pen_up_speed: 500.0, pen_lift_time: 0.1, pen_drop_time: 0.1, acceleration: None }
    }
}

/// What plotting a drawing costs.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PlotStats {
    /// Pen-down strokes (polylines with at least one segment).
    pub strokes: usize,
    /// Pen lifts, the return to home at the end included.
    pub pen_lifts: usize,
    /// Length drawn with the pen down, mm.
    pub drawn_mm: f64,
    /// Length travelled with the pen up, from `home` through every stroke and back, mm.
    pub travel_mm: f64,
    /// Estimated plot time in seconds.
    pub seconds: f64,
}

impl MotionModel {
    /// Seconds for one straight move of `len` mm at top speed `v`.
    #[must_use]
    pub fn move_time(&self, len: f64, v: f64) -> f64 {
        if len <= 0.0 || v <= 0.0 {
            return 0.0;
        }
        match self.acceleration {
            Some(a) if a > 0.0 => {
                // Trapezoid: accelerate to v, cruise, decelerate. Short moves never
                // reach v and form a triangle.
                let ramp = v * v / a;
                if len >= ramp {
                    len / v + v / a
                } else {
                    2.0 * (len / a).sqrt()
                }
            }
            _ => len / v,
        }
    }

    /// Cost of plotting `drawing` in its current stroke order, starting and
    /// ending at `home` (page mm). Each stroke's drawing is timed on its own
    /// (in parallel: a large drawing has millions of segments), then the
    /// strokes are added in order with the travel between them, so the sums
    /// do not depend on the threads.
    #[must_use]
    pub fn plot_stats(&self, drawing: &Drawing, home: DVec2) -> PlotStats {
        let polylines: Vec<&[DVec2]> = drawing.layers.iter().flat_map(|l| &l.polylines).map(|p| p.points.as_slice()).collect();
        let drawn: Vec<(f64, f64)> = polylines.par_iter().map(|points| self.drawing_time(points)).collect();
        let mut stats = PlotStats::default();
        let mut at = home;
        for (points, (mm, seconds)) in polylines.iter().zip(drawn) {
            let (Some(&start), Some(&end), true) = (points.first(), points.last(), points.len() >= 2) else { continue };
            stats.add_travel(self, at, start);
            stats.seconds += self.pen_drop_time + seconds + self.pen_lift_time;
            stats.drawn_mm += mm;
            stats.strokes += 1;
            stats.pen_lifts += 1;
            at = end;
        }
        stats.add_travel(self, at, home);
        stats
    }

    /// Length (mm) and seconds of drawing through `points` with the pen down.
    fn drawing_time(&self, points: &[DVec2]) -> (f64, f64) {
        points.windows(2).fold((0.0, 0.0), |(mm, seconds), w| {
            let len = w[0].distance(w[1]);
            (mm + len, seconds + self.move_time(len, self.pen_down_speed))
        })
    }
}

impl PlotStats {
    /// Adds pen-up travel from `from` to `to`. Returns the seconds it adds.
    pub fn add_travel(&mut self, model: &MotionModel, from: DVec2, to: DVec2) -> f64 {
        let hop = from.distance(to);
        let seconds = model.move_time(hop, model.pen_up_speed);
        self.travel_mm += hop;
        self.seconds += seconds;
        seconds
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{LineKind, Polyline};

    #[test]
    fn two_strokes_from_home() {
        let mut d = Drawing::new(100.0, 100.0);
        let layer = d.layer_mut(1, LineKind::Visible);
        layer.polylines.push(Polyline::new(vec![DVec2::new(0.0, 10.0), DVec2::new(10.0, 10.0)]));
        layer.polylines.push(Polyline::new(vec![DVec2::new(10.0, 20.0), DVec2::new(0.0, 20.0)]));
        let m = MotionModel { pen_down_speed: 10.0, pen_up_speed: 20.0, pen_lift_time: 0.5, pen_drop_time: 0.25, acceleration: None };
        let s = m.plot_stats(&d, DVec2::ZERO);
        assert_eq!(s.strokes, 2);
        assert_eq!(s.pen_lifts, 2);
        assert!((s.drawn_mm - 20.0).abs() < 1e-12);
        // home -> (0,10): 10; (10,10) -> (10,20): 10; (0,20) -> home: 20.
        assert!((s.travel_mm - 40.0).abs() < 1e-12);
        assert!((s.seconds - (2.0 + 40.0 / 20.0 + 2.0 * 0.75)).abs() < 1e-12);
    }

    #[test]
    fn acceleration_slows_short_moves_more() {
        let m = MotionModel { acceleration: Some(1000.0), ..MotionModel::default() };
        let flat = MotionModel::default();
        assert!(m.move_time(1.0, 380.0) > flat.move_time(1.0, 380.0));
        // A long move costs its cruise time plus one ramp.
        let t = m.move_time(1000.0, 380.0);
        assert!((t - (1000.0 / 380.0 + 0.38)).abs() < 1e-9);
        assert_eq!(m.move_time(0.0, 380.0), 0.0);
    }
}
