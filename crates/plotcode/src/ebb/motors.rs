//! The two step counters of an AxiDraw, and the pen position they make.
//!
//! The AxiDraw's belts are CoreXY-mixed: moving the pen by `x` steps along
//! the x axis and `y` along the y axis turns motor 1 by `x + y` steps and
//! motor 2 by `x - y` (evil-mad/axidraw `motion.py`: `motor_dist1 = xDist +
//! yDist`, `motor_dist2 = xDist - yDist`; the EBB's `XM` mixes its `A` and
//! `B` the same way). x grows away from home to the right, y towards the
//! operator. A device coordinate of an EBB profile is one such step
//! (`unit_mm`, 1/80 mm at 1/16 microstepping): whole-step pen positions
//! are whole-step motor positions, and motor positions whose counters
//! differ by an odd number sit half a step between them.

use strokes::DVec2;

/// The step counters `QS` reports: where the motors are since `EM` enabled
/// them (the home position).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Motors {
    /// Motor 1: `x + y` steps.
    pub m1: i64,
    /// Motor 2: `x - y` steps.
    pub m2: i64,
}

impl Motors {
    /// Counters `m1`, `m2`.
    #[must_use]
    pub const fn new(m1: i64, m2: i64) -> Motors {
        Motors { m1, m2 }
    }

    /// The counters nearest the pen position `p` (device units: steps along
    /// x and y).
    #[must_use]
    pub fn nearest(p: DVec2) -> Motors {
        Motors { m1: (p.x + p.y).round() as i64, m2: (p.x - p.y).round() as i64 }
    }

    /// The counters of a pen position at whole steps; `None` for any other.
    #[must_use]
    pub fn at(p: DVec2) -> Option<Motors> {
        let m = Motors::nearest(p);
        (m.xy() == p).then_some(m)
    }

    /// The pen position, device units (half steps where `m1 - m2` is odd).
    #[must_use]
    pub fn xy(self) -> DVec2 {
        DVec2::new((self.m1 + self.m2) as f64 / 2.0, (self.m1 - self.m2) as f64 / 2.0)
    }

    /// The steps each motor turns to go from `self` to `to`.
    #[must_use]
    pub fn to(self, to: Motors) -> Motors {
        Motors { m1: to.m1 - self.m1, m2: to.m2 - self.m2 }
    }

    /// `self` moved by `steps`.
    #[must_use]
    pub fn plus(self, steps: Motors) -> Motors {
        Motors { m1: self.m1 + steps.m1, m2: self.m2 + steps.m2 }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn corexy_mixing_both_ways() {
        // One step right turns both motors forward; one step towards the
        // operator turns motor 1 forward and motor 2 back.
        assert_eq!(Motors::nearest(DVec2::new(1.0, 0.0)), Motors::new(1, 1));
        assert_eq!(Motors::nearest(DVec2::new(0.0, 1.0)), Motors::new(1, -1));
        assert_eq!(Motors::new(1, 0).xy(), DVec2::new(0.5, 0.5));
        for p in [DVec2::new(24000.0, 17440.0), DVec2::new(-3.0, 7.0), DVec2::ZERO] {
            assert_eq!(Motors::at(p).map(Motors::xy), Some(p));
        }
        assert_eq!(Motors::at(DVec2::new(0.25, 0.0)), None);
        assert_eq!(Motors::new(5, -2).to(Motors::new(7, 3)), Motors::new(2, 5));
    }
}
