//! How long a drawing takes to plot.
//!
//! Plot time is dominated by pen lifts and pen-up travel, which is why stroke
//! ordering matters. The model is deliberately simple: constant pen-down and
//! pen-up speeds, a fixed time per pen lift and per pen drop, and optionally
//! a trapezoidal speed profile per straight move when the acceleration is known.
//! Device profiles (in `plotcode`) supply the numbers.

use crate::drawing::Drawing;
use glam::DVec2;

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
    /// ending at `home` (page mm).
    #[must_use]
    pub fn plot_stats(&self, drawing: &Drawing, home: DVec2) -> PlotStats {
        let mut stats = PlotStats::default();
        let mut at = home;
        for poly in drawing.layers.iter().flat_map(|l| &l.polylines) {
            stats.add_stroke(self, at, &poly.points);
            at = poly.end().filter(|_| poly.points.len() >= 2).unwrap_or(at);
        }
        stats.add_travel(self, at, home);
        stats
    }
}

impl PlotStats {
    /// Adds one stroke, plotted from the pen resting at `at` (page mm): the
    /// pen-up travel to its start, the pen drop, the drawing, the pen lift.
    /// Returns the seconds it adds; a polyline of fewer than two points draws
    /// nothing and adds nothing. (A device's estimate is timed along the
    /// commands written for it, by `plotcode`, with the same
    /// [`MotionModel::move_time`].)
    pub fn add_stroke(&mut self, model: &MotionModel, at: DVec2, points: &[DVec2]) -> f64 {
        let (Some(&start), true) = (points.first(), points.len() >= 2) else { return 0.0 };
        let hop = at.distance(start);
        let mut seconds = model.move_time(hop, model.pen_up_speed) + model.pen_drop_time + model.pen_lift_time;
        self.travel_mm += hop;
        for w in points.windows(2) {
            let len = w[0].distance(w[1]);
            self.drawn_mm += len;
            seconds += model.move_time(len, model.pen_down_speed);
        }
        self.strokes += 1;
        self.pen_lifts += 1;
        self.seconds += seconds;
        seconds
    }

    /// Adds pen-up travel from `from` to `to` (the return home at the end).
    /// Returns the seconds it adds.
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
