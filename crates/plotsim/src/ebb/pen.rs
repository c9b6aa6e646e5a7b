//! The pen-lift servo as a mechanism: where the pen is, not where the
//! firmware told it to go.
//!
//! A powered servo that receives pulses drives towards the latest pulse
//! width with a dead time and a top speed, the two terms of the AxiDraw
//! software's servo timing model (`axidraw_conf.py`: `servo_move_min` 45 ms,
//! `servo_move_slope` 2.69 ms per percent of the 9855..27831 range): a step
//! of d percent takes 45 + 2.69·d ms, and a slow sweep is followed 45 ms
//! late. A servo without power (the `SR` timeout, `SR,...,0`, V+ lost) or
//! without pulses goes limp and the pen arm falls onto the paper (EggBot
//! issue #184: a weighted pen drops when the servo power times out during a
//! long pause). A lower pulse width is a lower pen; the pen touches the paper
//! at and below the contact width.

use std::collections::VecDeque;

/// The servo reacts to a new pulse width this many milliseconds late.
pub(crate) const DEAD_TIME_MS: usize = 45;
/// Top speed, pulse-width units (83.3 ns) per millisecond: 100 % of the
/// AxiDraw's 9855..27831 range in 269 ms.
pub(crate) const SPEED: f64 = (27_831.0 - 9_855.0) / 269.0;
/// Default contact width (1.417 ms): between the down and up widths of the
/// EBB's boot settings (15302 / 22565), of axicli's defaults (15248 /
/// 20641, 30 % / 60 %) and of saxi's (15700 / 17750, 60 % / 50 %).
pub(crate) const DEFAULT_CONTACT: u16 = 17_000;

/// The pen servo's mechanism.
#[derive(Clone, Debug)]
pub(crate) struct PenServo {
    /// Pulse widths the servo received over the last dead time, oldest first.
    seen: VecDeque<u16>,
    /// Latest pulse width received (0: none yet).
    command: u16,
    /// Where the arm is, in pulse-width units.
    position: f64,
    /// At or below this width the pen is on the paper.
    contact: u16,
}

impl PenServo {
    /// A servo at rest on the paper (the board is off, the servo limp).
    pub fn new(contact: u16) -> PenServo {
        PenServo { seen: VecDeque::with_capacity(DEAD_TIME_MS + 1), command: 0, position: f64::from(contact), contact }
    }

    /// One millisecond: `pulse` is a pulse sent on the servo's pin in it,
    /// `powered` whether its 5 V supply is on.
    pub fn ms_tick(&mut self, powered: bool, pulse: Option<u16>) {
        if let Some(p) = pulse {
            self.command = p;
        }
        if !powered || self.command == 0 {
            self.seen.clear();
            self.position = self.position.min(f64::from(self.contact));
            return;
        }
        self.seen.push_back(self.command);
        if self.seen.len() <= DEAD_TIME_MS {
            return;
        }
        let aim = f64::from(self.seen.pop_front().expect("longer than the dead time"));
        let d = aim - self.position;
        // Arrive exactly (a settled arm lets the board skip time).
        self.position = if d.abs() <= SPEED { aim } else { self.position + SPEED.copysign(d) };
    }

    /// Limp or lagging, nothing will change until a new pulse width or a
    /// change of power: the caller may skip milliseconds.
    pub fn settled(&self, powered: bool) -> bool {
        if !powered || self.command == 0 {
            return self.position <= f64::from(self.contact);
        }
        self.seen.len() == DEAD_TIME_MS && self.seen.iter().all(|&p| p == self.command) && self.position == f64::from(self.command)
    }

    /// The pen touches the paper.
    pub fn on_paper(&self) -> bool {
        self.position <= f64::from(self.contact)
    }

    /// The arm's position, pulse-width units.
    #[cfg(test)]
    pub fn position(&self) -> f64 {
        self.position
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_step_takes_the_dead_time_plus_the_slope() {
        // 30 % of the range (5393 units) down from 60 %: 45 + 2.69 × 30 ms.
        let (up, down): (u16, u16) = (9_855 + 10_785, 9_855 + 5_392); // 60 % and 30 %
        let mut s = PenServo::new(DEFAULT_CONTACT);
        for _ in 0..1000 {
            s.ms_tick(true, Some(up));
        }
        assert!(!s.on_paper());
        let mut ms = 0;
        while s.position() > f64::from(down) {
            s.ms_tick(true, Some(down));
            ms += 1;
        }
        let model = 45.0 + 2.69 * f64::from(up - down) / 179.76;
        assert!((f64::from(ms) - model).abs() <= 1.0, "{ms} ms, model {model}");
        assert!(s.on_paper());
    }

    #[test]
    fn without_power_the_pen_falls() {
        let mut s = PenServo::new(DEFAULT_CONTACT);
        for _ in 0..500 {
            s.ms_tick(true, Some(22_000));
        }
        assert!(!s.on_paper());
        s.ms_tick(false, None);
        assert!(s.on_paper());
        assert!(s.settled(false));
    }
}
