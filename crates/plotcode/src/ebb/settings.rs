//! The `[ebb]` table of a device profile: firmware, step mode, the motion
//! planner's accelerations and cornering, and the pen-lift servo, with the
//! servo's positions, rates and travel times worked out from it.
//!
//! The servo is described as the AxiDraw software describes it (evil-mad/axidraw
//! `axidraw_conf.py`, `pen_handling.py`): heights and rates in percent of
//! the servo's full range, which `SC,4` / `SC,5` (positions, 83.3 ns units)
//! and `SC,11` / `SC,12` (rates) are computed from; and how long a move of
//! the pen takes, the fourth-power blend of a fast servo's transit time
//! (`slope x d% + min`) and a slow sweep's (`sweep x d% / rate%`).

use super::firmware::{Firmware, OLDEST_FIRMWARE};
use serde::{Deserialize, Serialize};

/// The `[ebb]` table.
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct EbbSettings {
    /// The firmware the commands are written for (`"2.8.1"`): `LM` moves
    /// from 2.7.0, `SM` time slices below; at least 2.6.2. A daemon writes
    /// for the version its board reports instead.
    pub firmware: Firmware,
    /// `EM`'s step mode: 1 is 1/16 steps ... 5 full steps. The profile's
    /// `unit_mm` is one step in this mode.
    pub microstep_mode: u8,
    /// Acceleration while drawing, mm/s^2.
    pub pen_down_acceleration_mm_s2: f64,
    /// Acceleration of pen-up travel, mm/s^2.
    pub pen_up_acceleration_mm_s2: f64,
    /// How far from a drawn corner the pen may pass, mm (GRBL's junction
    /// deviation): it sets how fast a corner is taken. 0 stops at every
    /// corner.
    pub cornering_mm: f64,
    /// The pen-lift servo.
    pub servo: Servo,
}

/// The pen-lift servo, as the `[ebb.servo]` table.
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Servo {
    /// Pulse width at 0 % height, 83.3 ns units.
    pub min: u16,
    /// Pulse width at 100 % height, 83.3 ns units.
    pub max: u16,
    /// Height of the raised pen, percent of the range.
    pub up_percent: f64,
    /// Height of the lowered pen, percent of the range.
    pub down_percent: f64,
    /// Speed of raising, percent of the fastest sweep.
    pub raise_rate_percent: f64,
    /// Speed of lowering, percent of the fastest sweep.
    pub lower_rate_percent: f64,
    /// Time to sweep the control signal over the whole range at 100 %, ms.
    pub sweep_ms: f64,
    /// Shortest time the servo takes for any move, ms.
    pub move_min_ms: f64,
    /// Time the servo takes per percent of travel at full speed, ms.
    pub move_slope_ms: f64,
}

/// The servo's control period: eight channels of 3 ms each, in which the
/// firmware adds the rate to the pulse width once (EBB docs, FAQ 1).
const SERVO_PERIOD_MS: f64 = 24.0;

/// Moves of the pen over less than this much of the range (percent) take no
/// time: the heights are the same (as the AxiDraw software counts them).
const NO_PEN_TRAVEL_PERCENT: f64 = 0.9;

impl Servo {
    /// `SC,4`: the raised pen's pulse width.
    #[must_use]
    pub fn up_position(&self) -> u16 {
        self.position(self.up_percent)
    }

    /// `SC,5`: the lowered pen's pulse width.
    #[must_use]
    pub fn down_position(&self) -> u16 {
        self.position(self.down_percent)
    }

    fn position(&self, percent: f64) -> u16 {
        let (lo, hi) = (f64::from(self.min), f64::from(self.max));
        (lo + (hi - lo) * percent / 100.0).round().clamp(1.0, 65535.0) as u16
    }

    /// `SC,11`: the pulse-width change per servo period when raising.
    #[must_use]
    pub fn raise_rate(&self) -> u16 {
        self.rate(self.raise_rate_percent)
    }

    /// `SC,12`: the pulse-width change per servo period when lowering.
    #[must_use]
    pub fn lower_rate(&self) -> u16 {
        self.rate(self.lower_rate_percent)
    }

    fn rate(&self, percent: f64) -> u16 {
        // The whole range in `sweep_ms` at 100 %: range / (sweep / period) per period.
        let range = f64::from(self.max) - f64::from(self.min);
        (range * SERVO_PERIOD_MS / self.sweep_ms * percent / 100.0).round().clamp(1.0, 65535.0) as u16
    }

    /// Milliseconds the pen takes to go up (`SP,1`'s duration).
    #[must_use]
    pub fn raise_ms(&self) -> u32 {
        self.travel_ms(self.raise_rate_percent)
    }

    /// Milliseconds the pen takes to come down (`SP,0`'s duration).
    #[must_use]
    pub fn lower_ms(&self) -> u32 {
        self.travel_ms(self.lower_rate_percent)
    }

    fn travel_ms(&self, rate_percent: f64) -> u32 {
        let d = (self.up_percent - self.down_percent).abs();
        if d < NO_PEN_TRAVEL_PERCENT {
            return 0;
        }
        let transit = self.move_slope_ms * d + self.move_min_ms;
        let sweep = self.sweep_ms * d / rate_percent;
        // Whole milliseconds, as SP takes them; down, as the AxiDraw software rounds.
        (transit.powi(4) + sweep.powi(4)).powf(0.25).floor().min(f64::from(u16::MAX)) as u32
    }
}

/// A value of the `[ebb]` table that makes no sense: the field (under
/// `ebb.`) and what is wrong.
pub(crate) type Invalid = (String, String);

impl EbbSettings {
    /// Checks the table.
    pub(crate) fn validate(&self) -> Result<(), Invalid> {
        let bad = |field: &str, problem: String| Err((format!("ebb.{field}"), problem));
        if self.firmware < OLDEST_FIRMWARE {
            return bad("firmware", format!("{} is older than {OLDEST_FIRMWARE}, the oldest plotd drives (HM, QG)", self.firmware));
        }
        if !(1..=5).contains(&self.microstep_mode) {
            return bad("microstep_mode", format!("must be 1 (1/16 steps) to 5 (full steps), got {}", self.microstep_mode));
        }
        for (field, v) in [
            ("pen_down_acceleration_mm_s2", self.pen_down_acceleration_mm_s2),
            ("pen_up_acceleration_mm_s2", self.pen_up_acceleration_mm_s2),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return bad(field, format!("must be a positive number, got {v}"));
            }
        }
        if !(self.cornering_mm.is_finite() && self.cornering_mm >= 0.0) {
            return bad("cornering_mm", format!("must be zero or positive, got {}", self.cornering_mm));
        }
        let s = &self.servo;
        if s.min == 0 || s.min >= s.max {
            return bad("servo.min", format!("needs 1 <= min < max, got min {} and max {}", s.min, s.max));
        }
        for (field, v) in [("servo.up_percent", s.up_percent), ("servo.down_percent", s.down_percent)] {
            if !(0.0..=100.0).contains(&v) {
                return bad(field, format!("must be 0 to 100, got {v}"));
            }
        }
        for (field, v) in [("servo.raise_rate_percent", s.raise_rate_percent), ("servo.lower_rate_percent", s.lower_rate_percent)] {
            if !(v > 0.0 && v <= 100.0) {
                return bad(field, format!("must be above 0 and at most 100, got {v}"));
            }
        }
        for (field, v) in [("servo.sweep_ms", s.sweep_ms), ("servo.move_min_ms", s.move_min_ms), ("servo.move_slope_ms", s.move_slope_ms)] {
            if !(v.is_finite() && v >= 0.0) {
                return bad(field, format!("must be zero or positive, got {v}"));
            }
        }
        if s.sweep_ms <= 0.0 {
            return bad("servo.sweep_ms", "must be positive".to_owned());
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The AxiDraw software's defaults (`axidraw_conf.py`).
    fn axidraw() -> Servo {
        Servo {
            min: 9855,
            max: 27831,
            up_percent: 60.0,
            down_percent: 30.0,
            raise_rate_percent: 75.0,
            lower_rate_percent: 50.0,
            sweep_ms: 200.0,
            move_min_ms: 45.0,
            move_slope_ms: 2.69,
        }
    }

    #[test]
    fn servo_positions_rates_and_times_as_the_axidraw_software_works_them_out() {
        let s = axidraw();
        // 9855 + 17976 x 60 % = 20640.6; x 30 % = 15247.8.
        assert_eq!((s.up_position(), s.down_position()), (20641, 15248));
        // 17976 x 24 ms / 200 ms = 2157.12 a period at 100 %.
        assert_eq!((s.raise_rate(), s.lower_rate()), (1618, 1079));
        // d = 30 %: transit 2.69 x 30 + 45 = 125.7 ms; sweeps 80 ms (75 %)
        // and 120 ms (50 %); (125.7^4 + 80^4)^(1/4) = 130.6, with 120: 146.2.
        assert_eq!((s.raise_ms(), s.lower_ms()), (130, 146));
        let level = Servo { down_percent: 60.5, ..axidraw() };
        assert_eq!(level.raise_ms(), 0, "the same height: no wait");
    }
}
