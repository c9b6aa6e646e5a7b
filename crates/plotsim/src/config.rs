//! What a simulated plotter is: personality, buffer, link speed, kinematics.

pub use crate::ebb::Firmware;
pub use crate::personality::Personality;
use crate::quirks::Quirk;
use std::path::PathBuf;
use strokes::MotionModel;

/// Paper loaded in an HP plotter; sets the hard-clip limits (`OH`) and P1/P2 (`OP`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Paper {
    /// ISO A4 (the 7475A's metric setting).
    #[default]
    A4,
    /// US letter / ANSI A.
    Letter,
    /// ISO A3 (the 7475A's large setting).
    A3,
}

impl Paper {
    /// Hard-clip limits in plotter units (x_min, y_min, x_max, y_max), as the
    /// 7475A reports them to `OH` for this paper.
    #[must_use]
    pub fn hard_clip(self) -> [i32; 4] {
        match self {
            Paper::A4 => [0, 0, 11040, 7721],
            Paper::Letter => [0, 0, 10365, 7962],
            Paper::A3 => [0, 0, 16158, 11040],
        }
    }

    /// Default scaling points P1 and P2 (x1, y1, x2, y2) after `IN`.
    #[must_use]
    pub fn p1p2(self) -> [i32; 4] {
        match self {
            Paper::A4 => [603, 521, 10603, 7721],
            Paper::Letter => [250, 596, 10250, 7796],
            Paper::A3 => [170, 602, 15370, 10602],
        }
    }
}

/// How a GRBL plotter raises and lowers its pen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum GrblPen {
    /// A servo on the spindle output: the pen is down while `M3`/`M4` is on
    /// with `S` above zero, up after `M5` or `S0`.
    Spindle,
    /// A Z axis: the pen is down while Z is below this height (mm).
    ZBelow(f64),
}

/// The AxiDraw models an EBB personality stands for, by `model` name, and
/// their travel in mm (x, y), from the AxiDraw software's `axidraw_conf.py`.
pub const EBB_MODELS: [(&str, [f64; 2]); 7] = [
    ("axidraw", [300.0, 218.0]),
    ("axidraw-a3", [430.0, 297.0]),
    ("axidraw-xlx", [595.0, 218.0]),
    ("axidraw-mini", [160.0, 101.6]),
    ("axidraw-se-a2", [594.0, 432.0]),
    ("axidraw-se-a1", [864.0, 594.0]),
    ("axidraw-b6", [190.0, 140.0]),
];

/// What an EBB personality is beyond its firmware's behaviour.
#[derive(Clone, Debug, PartialEq)]
pub struct EbbOptions {
    /// The firmware release (`V`, and every difference it brings).
    pub firmware: Firmware,
    /// The nickname in the board's flash at start (`QT`), at most 16 printable bytes.
    pub nickname: String,
    /// Servo pulse width (83.3 ns units) at and below which the pen touches
    /// the paper; see the `pen` module of the EBB personality.
    pub pen_contact: u16,
    /// The motor supply (V+) is on at start.
    pub motor_power: bool,
}

impl Default for EbbOptions {
    fn default() -> Self {
        EbbOptions { firmware: Firmware::V2_8_1, nickname: String::new(), pen_contact: crate::ebb::DEFAULT_CONTACT, motor_power: true }
    }
}

/// Everything needed to start a [`crate::Simulator`].
#[derive(Clone, Debug)]
pub struct SimConfig {
    /// HP-GL or GRBL.
    pub personality: Personality,
    /// Model name reported by `OI` (HP) or in `$I` (GRBL); `None` for the
    /// personality's own ("7475A", "plotsim").
    pub model: Option<String>,
    /// Input buffer size in bytes; `None` for the personality's own (HP 7475A:
    /// 1024, GRBL: 128). A 7550A has 12 KiB here, a DXY 2 KiB or so.
    pub buffer_size: Option<usize>,
    /// Serial speed: bytes reach the device at `baud / 10` per second (start,
    /// 8 data, stop bit). 0 delivers bytes as fast as the pty gives them.
    pub baud: u32,
    /// Multiplies every motion's duration: 1 is real time, 0.1 ten times
    /// faster, 0 instant (the device still parses everything in order).
    pub speed_scale: f64,
    /// A symlink made to point at the current pty slave (re-made after an unplug).
    pub link: Option<PathBuf>,
    /// Pen speeds and lift times; speeds in page mm/s.
    pub motion: MotionModel,
    /// Paper loaded in an HP plotter.
    pub paper: Paper,
    /// Pens in an HP plotter's carousel (`SP` above this is out of range).
    pub pens: u32,
    /// How a GRBL plotter moves its pen.
    pub grbl_pen: GrblPen,
    /// Planner blocks on a GRBL board.
    pub planner_blocks: usize,
    /// Ways this device differs from the personality's reference firmware
    /// (each belongs to one personality; see [`Quirk`]).
    pub quirks: Vec<Quirk>,
    /// EBB: firmware, nickname, pen contact, motor supply.
    pub ebb: EbbOptions,
}

impl SimConfig {
    /// An HP 7475A at 9600 baud, real-time plotting.
    #[must_use]
    pub fn hp7475a() -> Self {
        SimConfig {
            personality: Personality::Hp7475a,
            model: None,
            buffer_size: None,
            baud: 9600,
            speed_scale: 1.0,
            link: None,
            motion: MotionModel::default(),
            paper: Paper::default(),
            pens: 6,
            grbl_pen: GrblPen::Spindle,
            planner_blocks: 16,
            quirks: Vec::new(),
            ebb: EbbOptions::default(),
        }
    }

    /// A GRBL 1.1 board at 115200 baud, pen on the spindle (servo) output.
    #[must_use]
    pub fn grbl() -> Self {
        SimConfig { personality: Personality::Grbl, baud: 115_200, ..SimConfig::hp7475a() }
    }

    /// An EiBotBoard with this firmware, on USB: no baud rate, but bytes
    /// reach it at full-speed USB's pace for a CDC device, one 64-byte bulk
    /// packet per 1 ms frame (`baud` 640000 is that 64 kB/s), and it holds
    /// the host off rather than lose a byte. Real-time plotting.
    #[must_use]
    pub fn ebb(firmware: Firmware) -> Self {
        SimConfig {
            personality: Personality::Ebb,
            baud: EBB_USB_BAUD,
            ebb: EbbOptions { firmware, ..EbbOptions::default() },
            ..SimConfig::hp7475a()
        }
    }

    /// The default configuration of a personality.
    #[must_use]
    pub fn for_personality(p: Personality) -> Self {
        match p {
            Personality::Hp7475a => SimConfig::hp7475a(),
            Personality::Grbl => SimConfig::grbl(),
            Personality::Ebb => SimConfig::ebb(Firmware::V2_8_1),
        }
    }

    /// EBB: the travel (x, y) in mm of the AxiDraw model named by `model`.
    #[must_use]
    pub fn ebb_travel(&self) -> Option<[f64; 2]> {
        let name = self.model.as_deref().unwrap_or("axidraw");
        EBB_MODELS.iter().find(|(n, _)| *n == name).map(|(_, t)| *t)
    }

    /// Sets the speed scale (0 = instant plotting).
    #[must_use]
    pub fn with_speed_scale(mut self, scale: f64) -> Self {
        self.speed_scale = scale;
        self
    }

    /// Sets the baud rate (0 = unpaced).
    #[must_use]
    pub fn with_baud(mut self, baud: u32) -> Self {
        self.baud = baud;
        self
    }

    /// Sets the input buffer size.
    #[must_use]
    pub fn with_buffer_size(mut self, bytes: usize) -> Self {
        self.buffer_size = Some(bytes);
        self
    }

    /// Sets the link symlink path.
    #[must_use]
    pub fn with_link(mut self, link: impl Into<PathBuf>) -> Self {
        self.link = Some(link.into());
        self
    }

    /// Adds quirks of real firmware (see [`Quirk`]).
    #[must_use]
    pub fn with_quirks(mut self, quirks: impl IntoIterator<Item = Quirk>) -> Self {
        self.quirks.extend(quirks);
        self
    }

    /// Whether the device has this quirk.
    #[must_use]
    pub fn has(&self, quirk: Quirk) -> bool {
        self.quirks.contains(&quirk)
    }

    /// The buffer size in effect.
    #[must_use]
    pub fn effective_buffer_size(&self) -> usize {
        self.buffer_size.unwrap_or(match self.personality {
            Personality::Hp7475a => 1024,
            Personality::Grbl => 128,
            Personality::Ebb => crate::ebb::RX_CAPACITY,
        })
    }

    /// Checks the limits: buffer 2..=1 MiB, baud <= 4 Mbit/s, scale finite
    /// and >= 0, quirks of this personality's firmware.
    ///
    /// # Errors
    /// [`crate::SimError::Config`] naming the field that is out of range.
    pub fn validate(&self) -> Result<(), crate::SimError> {
        let bad = |field: &'static str, why: String| Err(crate::SimError::Config { field, why });
        let buf = self.effective_buffer_size();
        if !(2..=MAX_BUFFER).contains(&buf) {
            return bad("buffer_size", format!("{buf} is outside 2..={MAX_BUFFER}"));
        }
        if self.baud > 4_000_000 {
            return bad("baud", format!("{} is above 4000000", self.baud));
        }
        if !self.speed_scale.is_finite() || self.speed_scale < 0.0 {
            return bad("speed_scale", format!("{} is not a finite number >= 0", self.speed_scale));
        }
        if self.planner_blocks == 0 || self.planner_blocks > 1024 {
            return bad("planner_blocks", format!("{} is outside 1..=1024", self.planner_blocks));
        }
        if self.pens == 0 || self.pens > 256 {
            return bad("pens", format!("{} is outside 1..=256", self.pens));
        }
        if let Some(q) = self.quirks.iter().find(|q| q.personality() != self.personality) {
            return bad("quirks", format!("{q} is a quirk of {} firmware, not of {}", q.personality().name(), self.personality.name()));
        }
        let m = &self.motion;
        if !(m.pen_down_speed > 0.0 && m.pen_up_speed > 0.0) {
            return bad("motion", "pen speeds must be > 0".to_string());
        }
        if self.personality == Personality::Ebb {
            if self.buffer_size.is_some_and(|b| b != crate::ebb::RX_CAPACITY) {
                return bad("buffer_size", format!("an EBB's USB buffers are fixed ({} bytes)", crate::ebb::RX_CAPACITY));
            }
            if self.ebb_travel().is_none() {
                let names: Vec<&str> = EBB_MODELS.iter().map(|(n, _)| *n).collect();
                return bad("model", format!("'{}' is not an AxiDraw model ({})", self.model.as_deref().unwrap_or(""), names.join(", ")));
            }
            let n = &self.ebb.nickname;
            if n.len() > crate::ebb::NICKNAME_MAX || !n.bytes().all(|b| (32..127).contains(&b) && b != b',') {
                return bad("nickname", format!("'{n}' is not 0..=16 printable ASCII characters without a comma"));
            }
            if self.ebb.pen_contact == 0 {
                return bad("pen_contact", "0 is not a servo pulse width".to_string());
            }
        }
        Ok(())
    }
}

/// Largest input buffer a simulated device may have.
pub const MAX_BUFFER: usize = 1 << 20;

/// An EBB's link speed in `baud` terms: 64 bytes per 1 ms USB frame.
pub const EBB_USB_BAUD: u32 = 640_000;
