//! The two stepper drivers and motors, and where the carriage really is.
//!
//! The EBB's drivers (Allegro A4988) keep a step table position (the
//! "translator") that every step pulse advances by the step size of the
//! current microstep mode; an energised motor sits where the translator
//! says. A motor that is disabled (EM) or whose supply V+ is gone holds no
//! position: step pulses still advance the translator but the motor stays
//! put, and when it is energised again it jumps to the nearest rotor
//! position of the translator's electrical phase (a whole cycle is 4 full
//! steps, 64 sixteenth steps), up to two full steps either way. That is how
//! a board loses its position without knowing it: the step counters of `QS`
//! count every pulse.
//!
//! Positions are in sixteenth steps of the motor shaft, the finest
//! microstep. The AxiDraw's geometry (CoreXY, mixed axes) is the record's
//! business: motor 1 = x + y, motor 2 = x - y, 80 sixteenth steps per mm
//! (2032 per inch, `native_res_factor` 1016 doubled).

/// Sixteenth steps in one electrical cycle (4 full steps).
const CYCLE: i64 = 64;
/// Sixteenth steps per millimetre of carriage travel along x or y.
pub(crate) const STEPS_PER_MM: f64 = 80.0;

/// The drivers' state.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Motors {
    /// EM's enable of each driver.
    pub enabled: [bool; 2],
    /// EM's first argument when it enabled: 1 = 1/16 ... 5 = full steps.
    pub mode: u8,
    /// Motor supply present (QC's V+).
    pub vplus: bool,
    /// Step pulses reach the on-board drivers (`SC,2,0`).
    pub driven: bool,
    translator: [i64; 2],
    /// Shaft position minus translator position, fixed while energised.
    offset: [i64; 2],
}

impl Motors {
    /// Power-on: both drivers disabled, 1/16 steps, at the origin.
    pub fn new(vplus: bool) -> Motors {
        Motors { enabled: [false; 2], mode: 1, vplus, driven: true, translator: [0; 2], offset: [0; 2] }
    }

    /// Sixteenth steps per step pulse in the current mode.
    pub fn step_size(&self) -> i64 {
        1 << (self.mode.clamp(1, 5) - 1)
    }

    fn energised(&self, axis: usize) -> bool {
        self.enabled[axis] && self.vplus
    }

    /// A step pulse on an axis.
    pub fn step(&mut self, axis: usize, dir: i8) {
        if !self.driven {
            return;
        }
        let d = i64::from(dir) * self.step_size();
        self.translator[axis] += d;
        if !self.energised(axis) {
            self.offset[axis] -= d;
        }
    }

    /// Changes what powers the motors; a motor that becomes energised jumps
    /// to the translator's phase.
    fn set(&mut self, enabled: [bool; 2], vplus: bool) {
        let before = [self.energised(0), self.energised(1)];
        self.enabled = enabled;
        self.vplus = vplus;
        for (axis, was) in before.into_iter().enumerate() {
            if !was && self.energised(axis) {
                self.offset[axis] = snap(self.offset[axis]);
            }
        }
    }

    pub fn set_enabled(&mut self, enabled: [bool; 2]) {
        self.set(enabled, self.vplus);
    }

    pub fn set_vplus(&mut self, on: bool) {
        self.set(self.enabled, on);
    }

    /// Whether either motor is energised (holds the carriage).
    pub fn holding(&self) -> bool {
        self.energised(0) || self.energised(1)
    }

    /// A person pushes the carriage home by hand (motors not energised):
    /// the shafts go to home, the translators stay.
    pub fn park(&mut self) {
        self.offset = [-self.translator[0], -self.translator[1]];
    }

    /// Shaft positions in sixteenth steps.
    pub fn shaft(&self) -> [i64; 2] {
        [self.translator[0] + self.offset[0], self.translator[1] + self.offset[1]]
    }

    /// The pen's position in millimetres, x right and y up from where the
    /// board powered on (the AxiDraw's y, towards the front, is -y here).
    pub fn position_mm(&self) -> [f64; 2] {
        mm(self.shaft())
    }
}

/// Millimetres of a shaft position pair (x right, y up; see [`Motors`]).
pub(crate) fn mm(shaft: [i64; 2]) -> [f64; 2] {
    let x = (shaft[0] + shaft[1]) as f64 / 2.0 / STEPS_PER_MM;
    let y_front = (shaft[0] - shaft[1]) as f64 / 2.0 / STEPS_PER_MM;
    [x, -y_front]
}

/// The multiple of a cycle nearest to an offset (the rotor falls into the
/// nearest position of the driver's phase).
fn snap(offset: i64) -> i64 {
    (offset as f64 / CYCLE as f64).round() as i64 * CYCLE
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn steps_move_an_energised_motor_by_the_step_size() {
        let mut m = Motors::new(true);
        m.set_enabled([true, true]);
        m.mode = 2; // 1/8 steps: two sixteenths a pulse
        m.step(0, 1);
        m.step(1, -1);
        assert_eq!(m.shaft(), [2, -2]);
        // Motor 1 = x + y, motor 2 = x - y: +2/-2 is y towards the front.
        assert_eq!(m.position_mm(), [0.0, -2.0 / 80.0]);
    }

    #[test]
    fn steps_without_power_are_lost_and_the_rotor_snaps_to_the_phase() {
        let mut m = Motors::new(true);
        m.set_enabled([true, true]);
        for _ in 0..100 {
            m.step(0, 1);
        }
        m.set_vplus(false);
        for _ in 0..40 {
            m.step(0, 1);
        }
        assert_eq!(m.shaft()[0], 100, "the shaft stayed");
        m.set_vplus(true);
        // Translator 140, shaft 100: offset -40 snaps to -64 (nearest cycle).
        assert_eq!(m.shaft()[0], 76);
        m.step(0, 1);
        assert_eq!(m.shaft()[0], 77);
    }
}
