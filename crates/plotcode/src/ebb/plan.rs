//! The motion planner: a polyline in whole motor steps to constant-
//! acceleration blocks, each of which becomes one `LM` (or a few `SM` time
//! slices).
//!
//! As saxi's `planning.ts` does after fogleman/axi's planner: each vertex
//! gets the fastest speed its corner allows (GRBL's junction deviation: the
//! speed at which the pen, going round an arc `cornering` away from the
//! corner, accelerates sideways at the limit), 0 at both ends; a forward pass
//! lowers each to what can be reached from the one before, a backward pass
//! to what can still be stopped from. Each segment then speeds up, cruises
//! and slows down (a trapezoid, or a triangle when it is too short to reach
//! top speed).
//!
//! Steps are whole: the vertices are whole steps already, and the points
//! where a segment's trapezoid changes phase are rounded to the nearest
//! motor step, once, and become vertices of their own (with no corner
//! limit); the same two passes then run again over the refined polyline, so
//! every block goes from one whole-step point to the next with one constant
//! acceleration that never exceeds the limit and speeds that never exceed
//! the top speed. No rounding is carried from block to block, so nothing
//! accumulates along a stroke, and a block's steps are exactly the
//! difference of its ends.
//!
//! Speeds are along the pen's path in device units (steps) per second.

use super::motors::Motors;
use strokes::DVec2;

/// How one kind of move may go, in device units (steps) and seconds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits {
    /// Top speed along the path, steps/s.
    pub speed: f64,
    /// Acceleration along the path, steps/s^2.
    pub acceleration: f64,
    /// Junction deviation, steps: the corner speed is
    /// `sqrt(acceleration x cornering x sin(t/2) / (1 - sin(t/2)))` for an
    /// angle `t` between the reversed incoming and the outgoing direction.
    pub cornering: f64,
}

/// One straight piece of a move with constant acceleration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Block {
    /// Where it starts.
    pub from: Motors,
    /// Where it ends.
    pub to: Motors,
    /// Speed along the path at the start, steps/s.
    pub v0: f64,
    /// Speed along the path at the end, steps/s.
    pub v1: f64,
}

impl Block {
    /// Length along the path, steps.
    #[must_use]
    pub fn length(&self) -> f64 {
        (self.to.xy() - self.from.xy()).length()
    }

    /// Planned duration, seconds: the length at the mean of the two speeds.
    #[must_use]
    pub fn seconds(&self) -> f64 {
        2.0 * self.length() / (self.v0 + self.v1)
    }

    /// Acceleration along the path, steps/s^2 (negative when slowing down).
    #[must_use]
    pub fn acceleration(&self) -> f64 {
        (self.v1 * self.v1 - self.v0 * self.v0) / (2.0 * self.length())
    }
}

/// Directions closer than this (cosine) count as straight on or as a
/// full reversal.
const SAME_DIRECTION: f64 = 1e-9;

/// A phase point closer than this (steps) to a segment's end is no phase
/// point.
const PHASE_EPSILON: f64 = 1e-6;

/// The blocks that move the pen through `points` from rest to rest, in
/// order. Repeated points are passed once; fewer than two distinct points
/// make no blocks.
///
/// # Panics
/// Never for finite limits with positive speed and acceleration (the
/// profile checks them).
#[must_use]
pub fn plan(points: &[Motors], limits: &Limits) -> Vec<Block> {
    let mut pts: Vec<Motors> = Vec::with_capacity(points.len());
    for &p in points {
        if pts.last() != Some(&p) {
            pts.push(p);
        }
    }
    if pts.len() < 2 {
        return Vec::new();
    }
    let mut caps = vec![limits.speed; pts.len()];
    caps[0] = 0.0;
    *caps.last_mut().expect("two points") = 0.0;
    for i in 1..pts.len() - 1 {
        caps[i] = corner_speed(direction(pts[i - 1], pts[i]), direction(pts[i], pts[i + 1]), limits);
    }
    let v = speeds(&pts, &caps, limits.acceleration);

    // The phase changes, rounded to whole steps, as points of their own.
    let mut fine = vec![pts[0]];
    let mut fine_caps = vec![0.0];
    for i in 0..pts.len() - 1 {
        let (a, b) = (pts[i], pts[i + 1]);
        let (start, dir) = (a.xy(), direction(a, b));
        let len = (b.xy() - start).length();
        let mut last = 0.0;
        for d in phase_points(len, v[i], v[i + 1], limits).into_iter().flatten() {
            let p = Motors::nearest(start + dir * d);
            let along = (p.xy() - start).dot(dir);
            // Rounding may land on an end, or behind the last point on a
            // very short segment: then there is no room for a phase.
            if along > last && along < len && p != a && p != b {
                fine.push(p);
                fine_caps.push(limits.speed);
                last = along;
            }
        }
        fine.push(b);
        fine_caps.push(caps[i + 1]);
    }
    let v = speeds(&fine, &fine_caps, limits.acceleration);
    fine.windows(2)
        .zip(v.windows(2))
        .map(|(p, v)| {
            let mut block = Block { from: p[0], to: p[1], v0: v[0], v1: v[1] };
            if block.v0 + block.v1 <= 0.0 {
                // From rest to rest with no whole step in between to turn
                // round at (a move of a step or so): one steady block that
                // takes as long as the triangle would.
                let steady = (block.length() * limits.acceleration).sqrt() / 2.0;
                block.v0 = steady.min(limits.speed);
                block.v1 = block.v0;
            }
            block
        })
        .collect()
}

/// The unit vector from `a` to `b` (pen positions; distinct points).
fn direction(a: Motors, b: Motors) -> DVec2 {
    (b.xy() - a.xy()).normalize()
}

/// The fastest a corner from direction `d_in` to `d_out` may be taken.
pub(crate) fn corner_speed(d_in: DVec2, d_out: DVec2, limits: &Limits) -> f64 {
    // Cosine of the angle between the reversed incoming and the outgoing
    // direction: 1 for a full reversal, -1 straight on.
    let cosine = -d_in.dot(d_out);
    if cosine > 1.0 - SAME_DIRECTION {
        return 0.0;
    }
    let sine = ((1.0 - cosine) / 2.0).sqrt();
    if sine > 1.0 - SAME_DIRECTION {
        return limits.speed;
    }
    (limits.acceleration * limits.cornering * sine / (1.0 - sine)).sqrt().min(limits.speed)
}

/// The speed at each point: at most its cap, reachable from the point
/// before and able to slow down to the point after, at `acceleration`.
fn speeds(points: &[Motors], caps: &[f64], acceleration: f64) -> Vec<f64> {
    let lens: Vec<f64> = points.windows(2).map(|p| (p[1].xy() - p[0].xy()).length()).collect();
    let mut v = caps.to_vec();
    for (i, len) in lens.iter().enumerate() {
        v[i + 1] = v[i + 1].min((v[i] * v[i] + 2.0 * acceleration * len).sqrt());
    }
    for (i, len) in lens.iter().enumerate().rev() {
        v[i] = v[i].min((v[i + 1] * v[i + 1] + 2.0 * acceleration * len).sqrt());
    }
    v
}

/// Where along a segment of length `len`, entered at `u0` and left at `u1`,
/// the trapezoid stops speeding up and starts slowing down (one point for a
/// triangle, none for a segment that only speeds up, cruises or slows down).
fn phase_points(len: f64, u0: f64, u1: f64, limits: &Limits) -> [Option<f64>; 2] {
    let a = limits.acceleration;
    let peak = ((2.0 * a * len + u0 * u0 + u1 * u1) / 2.0).sqrt().min(limits.speed);
    let up = (peak * peak - u0 * u0) / (2.0 * a);
    let down = len - (peak * peak - u1 * u1) / (2.0 * a);
    let inside = |d: f64| d > PHASE_EPSILON && d < len - PHASE_EPSILON;
    let first = inside(up).then_some(up);
    let second = (inside(down) && down > up + PHASE_EPSILON).then_some(down);
    [first, second]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Pen-down defaults of an AxiDraw profile in steps (80 a mm).
    fn pen_down() -> Limits {
        Limits { speed: 50.0 * 80.0, acceleration: 200.0 * 80.0, cornering: 0.127 * 80.0 }
    }

    fn xy(x: i64, y: i64) -> Motors {
        Motors::new(x + y, x - y)
    }

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol
    }

    #[test]
    fn a_long_line_speeds_up_cruises_and_stops() {
        let l = pen_down();
        let blocks = plan(&[xy(0, 0), xy(8000, 0)], &l);
        assert_eq!(blocks.len(), 3, "{blocks:?}");
        // 50 mm/s at 200 mm/s^2: 0.25 s and 6.25 mm (500 steps) each way.
        assert_eq!(blocks[0].to, xy(500, 0));
        assert_eq!(blocks[2].from, xy(7500, 0));
        assert!(close(blocks[0].v0, 0.0, 0.0) && close(blocks[0].v1, l.speed, 1e-9));
        assert!(close(blocks[1].v0, l.speed, 1e-9) && close(blocks[1].v1, l.speed, 1e-9));
        assert!(close(blocks[2].v1, 0.0, 0.0));
        let t: f64 = blocks.iter().map(Block::seconds).sum();
        // 0.25 + 7000 / 4000 + 0.25 s.
        assert!(close(t, 2.25, 1e-9), "{t}");
    }

    #[test]
    fn a_short_line_is_a_triangle_at_whole_steps() {
        let l = pen_down();
        let blocks = plan(&[xy(0, 0), xy(101, 0)], &l);
        assert_eq!(blocks.len(), 2);
        // The peak, half way, is rounded to a whole step.
        assert!([xy(50, 0), xy(51, 0)].contains(&blocks[0].to), "{blocks:?}");
        for b in &blocks {
            assert!(b.acceleration().abs() <= l.acceleration * (1.0 + 1e-12), "{b:?}");
        }
        assert!(blocks[0].v1 < l.speed);
    }

    #[test]
    fn corners_slow_down_and_reversals_stop() {
        let l = pen_down();
        let right_angle = plan(&[xy(0, 0), xy(8000, 0), xy(8000, 8000)], &l);
        let at = |blocks: &[Block], p: Motors| blocks.iter().find(|b| b.to == p).unwrap().v1;
        // sin(45 deg) / (1 - sin 45 deg) = 2.414: sqrt(16000 x 10.16 x 2.414) steps/s.
        let want = (16000.0 * 10.16 * std::f64::consts::FRAC_1_SQRT_2 / (1.0 - std::f64::consts::FRAC_1_SQRT_2)).sqrt();
        assert!(close(at(&right_angle, xy(8000, 0)), want, 1e-6), "{}", at(&right_angle, xy(8000, 0)));
        let back = plan(&[xy(0, 0), xy(800, 0), xy(0, 0)], &l);
        assert_eq!(at(&back, xy(800, 0)), 0.0);
        let straight = plan(&[xy(0, 0), xy(4000, 0), xy(8000, 0)], &l);
        assert!(close(at(&straight, xy(4000, 0)), l.speed, 1e-9));
        let sharp = Limits { cornering: 0.0, ..l };
        assert_eq!(at(&plan(&[xy(0, 0), xy(800, 0), xy(800, 800)], &sharp), xy(800, 0)), 0.0);
    }

    #[test]
    fn every_block_keeps_to_the_limits_and_the_steps_add_up() {
        let l = pen_down();
        // A zigzag of short and long segments, one of a single step.
        let pts = [xy(0, 0), xy(3, 1), xy(3, 2), xy(900, 2), xy(0, 40), xy(1, 40), xy(1, 41), xy(5000, -3000)];
        let blocks = plan(&pts, &l);
        assert_eq!(blocks.first().unwrap().from, pts[0]);
        assert_eq!(blocks.last().unwrap().to, *pts.last().unwrap());
        for w in blocks.windows(2) {
            assert_eq!(w[0].to, w[1].from);
        }
        for p in &pts {
            assert!(blocks.iter().any(|b| b.to == *p || b.from == *p), "{p:?} is a block end");
        }
        for b in &blocks {
            assert!(b.v0 <= l.speed && b.v1 <= l.speed && b.seconds().is_finite() && b.seconds() > 0.0, "{b:?}");
            if b.v0 != b.v1 {
                assert!(b.acceleration().abs() <= l.acceleration * (1.0 + 1e-9), "{b:?}");
            }
        }
    }

    #[test]
    fn a_single_step_from_rest_to_rest_is_steady() {
        let l = pen_down();
        let blocks = plan(&[xy(0, 0), xy(1, 0), xy(0, 0)], &l);
        assert_eq!(blocks.len(), 2);
        for b in &blocks {
            assert!(b.v0 > 0.0 && b.v0 == b.v1, "{b:?}");
            assert!(close(b.seconds(), 2.0 * (1.0 / l.acceleration).sqrt(), 1e-12));
        }
        assert!(plan(&[xy(4, 4), xy(4, 4)], &l).is_empty());
    }
}
