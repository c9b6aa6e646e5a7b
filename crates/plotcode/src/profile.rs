//! Device profiles: what one plotter model wants, read from TOML.
//!
//! The shipped profiles live in `config/devices/*.toml` and are compiled in, so
//! [`DeviceProfile::builtin`] needs no file system. A user's own profile is read
//! by the caller (this crate does no I/O) and handed to
//! [`DeviceProfile::from_toml`]. Unknown keys are rejected, so a typo in a
//! profile is an error naming the key rather than a silently ignored setting.

use crate::ebb::EbbSettings;
use serde::{Deserialize, Serialize};
use strokes::MotionModel;

/// The profiles built into the crate: (name, TOML text).
const BUILTIN: &[(&str, &str)] = &[
    ("hp7475a", include_str!("../../../config/devices/hp7475a.toml")),
    ("hp7550a", include_str!("../../../config/devices/hp7550a.toml")),
    ("hp7585b", include_str!("../../../config/devices/hp7585b.toml")),
    ("roland-dxy1300", include_str!("../../../config/devices/roland-dxy1300.toml")),
    ("hpgl2-generic", include_str!("../../../config/devices/hpgl2-generic.toml")),
    ("grbl-servo", include_str!("../../../config/devices/grbl-servo.toml")),
    ("grbl-z", include_str!("../../../config/devices/grbl-z.toml")),
    ("axidraw", include_str!("../../../config/devices/axidraw.toml")),
    ("axidraw-se-a3", include_str!("../../../config/devices/axidraw-se-a3.toml")),
    ("axidraw-se-a1", include_str!("../../../config/devices/axidraw-se-a1.toml")),
];

/// The fastest an EBB steps a motor, steps/s, with a margin of 1 % for the
/// rounding of step counts and rates (the firmware's limit is 25,000).
pub const MAX_EBB_STEP_RATE: f64 = 24_750.0;

/// The longest G-code line GRBL accepts (its `LINE_BUFFER_SIZE` is 80 including
/// the terminator; 79 characters are usable).
pub const GRBL_MAX_LINE: usize = 79;

/// One plotter model. (Serialize too: the daemon hands a loaded profile
/// to the process that renders a job.)
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct DeviceProfile {
    /// Short name, as given to `--device`.
    pub name: String,
    /// One line for humans.
    #[serde(default)]
    pub description: String,
    /// The command language.
    pub protocol: Protocol,
    /// Length of one device unit in millimetres (HP: 0.02488 or 0.025; G-code: 1).
    pub unit_mm: f64,
    /// Whether device y grows away from the operator (up on the page).
    pub y_up: bool,
    /// Number of pens the device holds.
    pub pens: u32,
    /// Drawing speed, mm/s (plot-time model).
    pub pen_down_speed_mm_s: f64,
    /// Pen-up travel speed, mm/s (plot-time model).
    pub pen_up_speed_mm_s: f64,
    /// Seconds to lift the pen (HP-GL and G-code; an EBB's servo times come
    /// from its `[ebb.servo]` table).
    #[serde(default)]
    pub pen_lift_s: Option<f64>,
    /// Seconds to lower the pen; the lift time when left out.
    #[serde(default)]
    pub pen_drop_s: Option<f64>,
    /// Acceleration in mm/s^2, when known (an EBB has one for drawing and
    /// one for travel in its `[ebb]` table).
    #[serde(default)]
    pub acceleration_mm_s2: Option<f64>,
    /// Size of the device's input buffer in bytes (for the daemon's flow control).
    pub buffer_bytes: usize,
    /// The flow control the daemon uses unless its config sets another
    /// (one for this profile's `protocol`).
    pub handshake: Handshake,
    /// HP-GL only: the longest instruction the emitter writes, bytes.
    #[serde(default = "default_max_instruction")]
    pub max_instruction_bytes: usize,
    /// HP-GL only: a `VS` pen speed in cm/s to send after `IN`, if any.
    #[serde(default)]
    pub velocity_cm_s: Option<f64>,
    /// HP-GL only: the device draws dashed lines itself (`LT`, as every HP
    /// plotter does; the default); when false, hidden lines' dashes are cut
    /// as strokes, as they always are for G-code.
    #[serde(default = "default_line_types")]
    pub line_types: bool,
    /// The paper used when the caller names none and the drawing's page matches none.
    pub default_paper: String,
    /// The paper sizes the device takes.
    pub paper: Vec<Paper>,
    /// G-code only: command templates and feeds.
    #[serde(default)]
    pub gcode: Option<GcodeSettings>,
    /// EBB only: firmware, step mode, motion planning and the pen servo.
    #[serde(default)]
    pub ebb: Option<EbbSettings>,
    /// How far a person moved this plotter's drawings on the sheet, mm
    /// along the device's axes (`plotd offset`): the daemon sets it on the
    /// profile it renders a job with; 0 in every built-in profile. A
    /// drawing placed on the device moves by it, and is scaled down if it
    /// would then cross the plotting area's limits, as any drawing too
    /// big is.
    #[serde(default, skip_serializing_if = "is_origin")]
    pub origin_offset_mm: [f64; 2],
}

#[allow(clippy::trivially_copy_pass_by_ref)] // serde's signature
fn is_origin(v: &[f64; 2]) -> bool {
    *v == [0.0, 0.0]
}

fn default_max_instruction() -> usize {
    256
}
fn default_line_types() -> bool {
    true
}

/// The command language of a device.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Protocol {
    /// HP-GL (and HP-GL/2).
    Hpgl,
    /// G-code as GRBL speaks it.
    Gcode,
    /// EiBotBoard commands (AxiDraw): step counts and rates.
    Ebb,
}

impl std::fmt::Display for Protocol {
    /// The language's own name, as users write it ("HP-GL", "G-code").
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Protocol::Hpgl => "HP-GL",
            Protocol::Gcode => "G-code",
            Protocol::Ebb => "EBB",
        })
    }
}

/// How the host keeps from overflowing the device's input buffer: the one
/// vocabulary of flow control, set in a profile (the device's default) and
/// in the daemon's config (per plotter, overriding it). Written in files in
/// kebab-case (`xon-xoff`); the spellings of earlier versions are still
/// read: `xonxoff` (the daemon's config), `buffer-query` and `char-count`
/// (profiles).
///
/// Whatever the handshake, the daemon keeps the bytes a device has not
/// confirmed executing under a window smaller than its buffer.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Handshake {
    /// HP-GL: the RTS/CTS lines, done by the serial driver (HP's hardwire
    /// handshake: the plotter drops its DTR, the host's CTS, when its
    /// buffer is nearly full).
    Hardware,
    /// HP-GL: XON/XOFF characters sent by the device (switched on by
    /// [`crate::control::hpgl::Op::XonXoff`]).
    #[serde(alias = "xonxoff")]
    XonXoff,
    /// HP-GL: no flow control by the device; inside a stroke longer than
    /// the window the host asks the free space
    /// ([`crate::control::hpgl::Op::FreeSpace`]) and writes at most that.
    #[serde(alias = "buffer-query")]
    Escb,
    /// GRBL's character counting against its receive buffer, with status
    /// polls.
    #[serde(alias = "char-count")]
    Grbl,
    /// The EBB's own: it answers every command, and holds back the answer
    /// to a motion command while its motion FIFO is full.
    Ebb,
}

impl Handshake {
    /// The command language this handshake streams.
    #[must_use]
    pub fn protocol(self) -> Protocol {
        match self {
            Handshake::Hardware | Handshake::XonXoff | Handshake::Escb => Protocol::Hpgl,
            Handshake::Grbl => Protocol::Gcode,
            Handshake::Ebb => Protocol::Ebb,
        }
    }
}

impl std::fmt::Display for Handshake {
    /// The name as written in a profile or config (`xon-xoff`).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Handshake::Hardware => "hardware",
            Handshake::XonXoff => "xon-xoff",
            Handshake::Escb => "escb",
            Handshake::Grbl => "grbl",
            Handshake::Ebb => "ebb",
        })
    }
}

/// Where the device's (0, 0) is on the paper.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Origin {
    /// At the lower-left corner of the plotting area.
    LowerLeft,
    /// At the centre of the plotting area (large HP drafting plotters).
    Center,
    /// At the upper-left corner, y growing towards the operator (an
    /// AxiDraw's home, where the sheet's top-left corner goes).
    UpperLeft,
}

/// One paper size and the plotting area the device reaches on it.
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Paper {
    /// Name, such as `A4`.
    pub name: String,
    /// The sheet in millimetres, `[width, height]` as loaded.
    pub page_mm: [f64; 2],
    /// Device x range (hard-clip limits) in device units, `[min, max]`.
    pub x_range: [f64; 2],
    /// Device y range (hard-clip limits) in device units, `[min, max]`.
    pub y_range: [f64; 2],
    /// Where device (0, 0) is.
    pub origin: Origin,
}

/// G-code templates and feeds.
///
/// Templates may span lines (`\n`); `{pen}` in `tool_change` is the pen number.
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct GcodeSettings {
    /// Sent first (must set millimetres and absolute mode, such as `G21 G90`).
    pub start: String,
    /// Sent last.
    pub end: String,
    /// Raises the pen.
    pub pen_up: String,
    /// Lowers the pen.
    pub pen_down: String,
    /// Sent before the first stroke of each pen; `{pen}` is replaced.
    #[serde(default)]
    pub tool_change: String,
    /// Feed rate of drawing moves (`G1 F`), mm/min.
    pub draw_feed_mm_min: f64,
    /// Decimal places of coordinates.
    #[serde(default = "default_decimals")]
    pub decimals: usize,
    /// When reading G-code: a Z at or below this height means the pen is down.
    #[serde(default)]
    pub z_down_at_or_below: Option<f64>,
}

fn default_decimals() -> usize {
    3
}

/// A profile that cannot be used.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ProfileError {
    /// No built-in profile of that name.
    #[error("unknown device {name:?}; known devices: {}", known.join(", "))]
    Unknown {
        /// The name asked for.
        name: String,
        /// The built-in names.
        known: Vec<String>,
    },
    /// Not valid TOML, a missing or unknown key, or a value of the wrong type
    /// (the message names the key and the line).
    #[error("device profile: {0}")]
    Toml(String),
    /// Parsed, but a value makes no sense.
    #[error("device profile {profile:?}: field `{field}`: {problem}")]
    Invalid {
        /// The profile's name.
        profile: String,
        /// The offending field.
        field: String,
        /// What is wrong.
        problem: String,
    },
}

impl DeviceProfile {
    /// The names of the built-in profiles.
    #[must_use]
    pub fn builtin_names() -> Vec<&'static str> {
        BUILTIN.iter().map(|(n, _)| *n).collect()
    }

    /// The built-in profile `name`.
    ///
    /// # Errors
    /// [`ProfileError::Unknown`] listing the known names.
    pub fn builtin(name: &str) -> Result<DeviceProfile, ProfileError> {
        match BUILTIN.iter().find(|(n, _)| n.eq_ignore_ascii_case(name)) {
            Some((_, text)) => DeviceProfile::from_toml(text),
            None => Err(ProfileError::Unknown { name: name.to_owned(), known: BUILTIN.iter().map(|(n, _)| (*n).to_owned()).collect() }),
        }
    }

    /// Reads and checks a profile.
    ///
    /// # Errors
    /// [`ProfileError::Toml`] for syntax errors and missing, unknown or mistyped
    /// keys, [`ProfileError::Invalid`] for values out of range.
    pub fn from_toml(text: &str) -> Result<DeviceProfile, ProfileError> {
        let p: DeviceProfile = toml::from_str(text).map_err(|e| ProfileError::Toml(e.to_string().trim_end().to_owned()))?;
        p.validate()?;
        Ok(p)
    }

    fn invalid(&self, field: &str, problem: impl Into<String>) -> ProfileError {
        ProfileError::Invalid { profile: self.name.clone(), field: field.to_owned(), problem: problem.into() }
    }

    fn validate(&self) -> Result<(), ProfileError> {
        let positive = |v: f64, field: &str| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(self.invalid(field, format!("must be a positive number, got {v}")))
            }
        };
        let non_negative = |v: f64, field: &str| {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(self.invalid(field, format!("must be zero or positive, got {v}")))
            }
        };
        if self.name.trim().is_empty() {
            return Err(self.invalid("name", "must not be empty"));
        }
        positive(self.unit_mm, "unit_mm")?;
        positive(self.pen_down_speed_mm_s, "pen_down_speed_mm_s")?;
        positive(self.pen_up_speed_mm_s, "pen_up_speed_mm_s")?;
        match (self.protocol, self.pen_lift_s) {
            (Protocol::Ebb, None) | (Protocol::Hpgl | Protocol::Gcode, Some(_)) => {}
            (Protocol::Ebb, Some(_)) => return Err(self.invalid("pen_lift_s", "an EBB's pen times come from [ebb.servo]; leave it out")),
            (_, None) => return Err(self.invalid("pen_lift_s", "missing: the seconds to lift the pen")),
        }
        if let Some(v) = self.pen_lift_s {
            non_negative(v, "pen_lift_s")?;
        }
        if let Some(v) = self.pen_drop_s {
            non_negative(v, "pen_drop_s")?;
        }
        if let Some(v) = self.acceleration_mm_s2 {
            positive(v, "acceleration_mm_s2")?;
        }
        if let Some(v) = self.velocity_cm_s {
            positive(v, "velocity_cm_s")?;
        }
        if self.pens == 0 {
            return Err(self.invalid("pens", "must be at least 1"));
        }
        if self.buffer_bytes == 0 {
            return Err(self.invalid("buffer_bytes", "must be at least 1"));
        }
        if self.max_instruction_bytes < 32 {
            return Err(self.invalid("max_instruction_bytes", "must be at least 32"));
        }
        if self.paper.is_empty() {
            return Err(self.invalid("paper", "at least one [[paper]] is needed"));
        }
        for (i, paper) in self.paper.iter().enumerate() {
            let field = |f: &str| format!("paper[{i}] ({}).{f}", paper.name);
            for (k, v) in paper.page_mm.iter().enumerate() {
                if !(v.is_finite() && *v > 0.0) {
                    return Err(self.invalid(&field("page_mm"), format!("entry {k} must be positive, got {v}")));
                }
            }
            for (name, r) in [("x_range", paper.x_range), ("y_range", paper.y_range)] {
                if !(r[0].is_finite() && r[1].is_finite() && r[0] < r[1]) {
                    return Err(self.invalid(&field(name), format!("needs min < max, got [{}, {}]", r[0], r[1])));
                }
            }
        }
        if self.paper_named(&self.default_paper).is_none() {
            return Err(self.invalid(
                "default_paper",
                format!("no [[paper]] named {:?} (have {})", self.default_paper, self.paper_names().join(", ")),
            ));
        }
        if self.handshake.protocol() != self.protocol {
            return Err(self.invalid(
                "handshake",
                format!("\"{}\" streams {}, and this device speaks {}", self.handshake, self.handshake.protocol(), self.protocol),
            ));
        }
        match (self.protocol, &self.gcode) {
            (Protocol::Gcode, None) => return Err(self.invalid("gcode", "protocol \"gcode\" needs a [gcode] table")),
            (Protocol::Gcode, Some(g)) => {
                positive(g.draw_feed_mm_min, "gcode.draw_feed_mm_min")?;
                if g.decimals > 6 {
                    return Err(self.invalid("gcode.decimals", "at most 6"));
                }
                for (name, t) in [
                    ("gcode.start", &g.start),
                    ("gcode.end", &g.end),
                    ("gcode.pen_up", &g.pen_up),
                    ("gcode.pen_down", &g.pen_down),
                    ("gcode.tool_change", &g.tool_change),
                ] {
                    for line in t.lines() {
                        // `{pen}` expands to at most 10 digits.
                        if line.len() + 5 > GRBL_MAX_LINE {
                            return Err(self.invalid(name, format!("line {line:?} is too long for GRBL's 80-character buffer")));
                        }
                    }
                }
            }
            (Protocol::Hpgl, _) => {}
            (Protocol::Ebb, _) => self.validate_ebb()?,
        }
        Ok(())
    }

    /// The `[ebb]` table, and what an EBB needs of the rest: steps as
    /// device units from home at the sheet's top-left corner, and speeds
    /// the step generator can make.
    fn validate_ebb(&self) -> Result<(), ProfileError> {
        let Some(ebb) = &self.ebb else { return Err(self.invalid("ebb", "protocol \"ebb\" needs an [ebb] table")) };
        ebb.validate().map_err(|(field, problem)| self.invalid(&field, problem))?;
        for (field, set) in [
            ("pen_drop_s", self.pen_drop_s.is_some()),
            ("acceleration_mm_s2", self.acceleration_mm_s2.is_some()),
            ("gcode", self.gcode.is_some()),
        ] {
            if set {
                return Err(self.invalid(field, "not for an EBB device: see its [ebb] table"));
            }
        }
        if self.y_up {
            return Err(self.invalid("y_up", "an EBB's y grows from home towards the operator: false"));
        }
        for (i, paper) in self.paper.iter().enumerate() {
            if paper.x_range[0] != 0.0 || paper.y_range[0] != 0.0 || paper.origin != Origin::UpperLeft {
                return Err(self.invalid(
                    &format!("paper[{i}] ({})", paper.name),
                    "an EBB's sheet has its top-left corner at home: x_range and y_range from 0, origin \"upper-left\"",
                ));
            }
        }
        // A motor on the diagonal turns sqrt(2) times as fast as the pen moves.
        let fastest = self.pen_down_speed_mm_s.max(self.pen_up_speed_mm_s) * std::f64::consts::SQRT_2 / self.unit_mm;
        if fastest > MAX_EBB_STEP_RATE {
            let field = if self.pen_up_speed_mm_s >= self.pen_down_speed_mm_s { "pen_up_speed_mm_s" } else { "pen_down_speed_mm_s" };
            return Err(self.invalid(
                field,
                format!("{fastest:.0} steps/s on a motor moving diagonally; the EBB steps at most {MAX_EBB_STEP_RATE:.0} a second"),
            ));
        }
        Ok(())
    }

    /// The paper called `name` (any case).
    #[must_use]
    pub fn paper_named(&self, name: &str) -> Option<&Paper> {
        self.paper.iter().find(|p| p.name.eq_ignore_ascii_case(name))
    }

    /// Names of the papers, in profile order.
    #[must_use]
    pub fn paper_names(&self) -> Vec<&str> {
        self.paper.iter().map(|p| p.name.as_str()).collect()
    }

    /// The plot-time model of this device, for `hiddenline`'s estimates.
    #[must_use]
    pub fn motion_model(&self) -> MotionModel {
        if let Some(ebb) = &self.ebb {
            return MotionModel {
                pen_down_speed: self.pen_down_speed_mm_s,
                pen_up_speed: self.pen_up_speed_mm_s,
                pen_lift_time: f64::from(ebb.servo.raise_ms()) / 1000.0,
                pen_drop_time: f64::from(ebb.servo.lower_ms()) / 1000.0,
                acceleration: Some(ebb.pen_down_acceleration_mm_s2),
            };
        }
        let lift = self.pen_lift_s.unwrap_or_default();
        MotionModel {
            pen_down_speed: self.pen_down_speed_mm_s,
            pen_up_speed: self.pen_up_speed_mm_s,
            pen_lift_time: lift,
            pen_drop_time: self.pen_drop_s.unwrap_or(lift),
            acceleration: self.acceleration_mm_s2,
        }
    }
}

impl Paper {
    /// Width and height of the plotting area in millimetres.
    #[must_use]
    pub fn area_mm(&self, unit_mm: f64) -> (f64, f64) {
        ((self.x_range[1] - self.x_range[0]) * unit_mm, (self.y_range[1] - self.y_range[0]) * unit_mm)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_builtin_profile_loads() {
        for name in DeviceProfile::builtin_names() {
            let p = DeviceProfile::builtin(name).unwrap_or_else(|e| panic!("{name}: {e}"));
            assert_eq!(p.name, name);
            assert!(p.paper_named(&p.default_paper).is_some());
            let m = p.motion_model();
            assert!(m.pen_down_speed > 0.0 && m.pen_up_speed > 0.0);
            // Each plotting area fits on its sheet (with the sheet either way round).
            for paper in &p.paper {
                let (w, h) = paper.area_mm(p.unit_mm);
                let (pw, ph) = (paper.page_mm[0], paper.page_mm[1]);
                assert!(
                    (w <= pw + 0.5 && h <= ph + 0.5) || (w <= ph + 0.5 && h <= pw + 0.5),
                    "{name} {}: area {w}x{h} mm on a {pw}x{ph} mm sheet",
                    paper.name
                );
            }
        }
    }

    #[test]
    fn hp7475a_values() {
        let p = DeviceProfile::builtin("HP7475A").unwrap();
        assert_eq!(p.protocol, Protocol::Hpgl);
        assert_eq!(p.buffer_bytes, 1024);
        assert!((1.0 / p.unit_mm - 40.19).abs() < 0.01);
        assert_eq!(p.paper_names(), vec!["A4", "A3", "letter", "tabloid"]);
        assert_eq!(p.motion_model().pen_drop_time, 0.06);
    }

    /// One handshake vocabulary: each built-in profile's is one the daemon
    /// streams for the profile's language and the device offers (HP's
    /// plotters: XON/XOFF, set up by the RS-232 device-control
    /// instructions, 7475A interfacing manual; Roland DXY-1300: its DTR
    /// hardwire line; GRBL: character counting), and the older spellings
    /// still load.
    #[test]
    fn each_profile_names_a_handshake_for_its_language() {
        let expected = [
            ("hp7475a", Handshake::XonXoff),
            ("hp7550a", Handshake::XonXoff),
            ("hp7585b", Handshake::XonXoff),
            ("roland-dxy1300", Handshake::Hardware),
            ("hpgl2-generic", Handshake::XonXoff),
            ("grbl-servo", Handshake::Grbl),
            ("grbl-z", Handshake::Grbl),
            ("axidraw", Handshake::Ebb),
            ("axidraw-se-a3", Handshake::Ebb),
            ("axidraw-se-a1", Handshake::Ebb),
        ];
        assert_eq!(expected.len(), BUILTIN.len());
        for (name, handshake) in expected {
            let p = DeviceProfile::builtin(name).unwrap();
            assert_eq!((p.handshake, p.handshake.protocol()), (handshake, p.protocol), "{name}");
        }
        let hp = BUILTIN[0].1;
        let grbl = BUILTIN.iter().find(|(n, _)| *n == "grbl-z").unwrap().1;
        for (text, from, to, handshake) in [
            (hp, "xon-xoff", "xonxoff", Handshake::XonXoff),
            (hp, "xon-xoff", "buffer-query", Handshake::Escb),
            (grbl, "grbl", "char-count", Handshake::Grbl),
        ] {
            let text = text.replace(&format!("handshake = \"{from}\""), &format!("handshake = \"{to}\""));
            assert_eq!(DeviceProfile::from_toml(&text).unwrap().handshake, handshake, "{to}");
        }
    }

    #[test]
    fn unknown_device_lists_known_ones() {
        let e = DeviceProfile::builtin("hp9999").unwrap_err().to_string();
        assert!(e.contains("\"hp9999\"") && e.contains("hp7475a") && e.contains("grbl-z"), "{e}");
    }

    fn without(text: &str, key: &str) -> String {
        text.lines().filter(|l| !l.starts_with(&format!("{key} "))).collect::<Vec<_>>().join("\n")
    }

    #[test]
    fn bad_profiles_name_the_field() {
        let base = BUILTIN[0].1;
        let grbl = BUILTIN.iter().find(|(n, _)| *n == "grbl-z").unwrap().1;
        let cases: Vec<(String, &str)> = vec![
            (without(base, "unit_mm"), "unit_mm"),
            (without(base, "pens"), "pens"),
            (without(base, "protocol"), "protocol"),
            (base.replace("unit_mm = 0.02488", "unit_mm = -1.0"), "unit_mm"),
            (base.replace("unit_mm = 0.02488", "unit_mm = \"small\""), "unit_mm"),
            (base.replace("pens = 6", "pens = 0"), "pens"),
            (base.replace("pens = 6", "pens = 6\ncolour = 3"), "colour"),
            (base.replace("protocol = \"hpgl\"", "protocol = \"postscript\""), "postscript"),
            (base.replace("default_paper = \"A4\"", "default_paper = \"B0\""), "default_paper"),
            (base.replace("x_range = [0, 11040]", "x_range = [11040, 0]"), "x_range"),
            (base.replace("handshake = \"xon-xoff\"", "handshake = \"smoke-signals\""), "smoke-signals"),
            (base.replace("handshake = \"xon-xoff\"", "handshake = \"grbl\""), "handshake"),
            (base.replace("handshake = \"xon-xoff\"", "handshake = \"enq-ack\""), "enq-ack"),
            (without(grbl, "draw_feed_mm_min"), "draw_feed_mm_min"),
            (grbl.replace("[gcode]", "[gcode_x]"), "gcode"),
            ("this is not toml".to_owned(), "line 1"),
        ];
        let axi = BUILTIN.iter().find(|(n, _)| *n == "axidraw").unwrap().1;
        let ebb_cases: Vec<(String, &str)> = vec![
            (axi.replace("firmware = \"2.8.1\"", "firmware = \"2.5.0\""), "ebb.firmware"),
            (axi.replace("firmware = \"2.8.1\"", "firmware = \"two\""), "\"two\" is not a firmware version"),
            (axi.replace("microstep_mode = 1", "microstep_mode = 9"), "ebb.microstep_mode"),
            (axi.replace("pen_down_acceleration_mm_s2 = 200.0", "pen_down_acceleration_mm_s2 = 0.0"), "ebb.pen_down_acceleration_mm_s2"),
            (axi.replace("cornering_mm = 0.127", "cornering_mm = -1.0"), "ebb.cornering_mm"),
            (axi.replace("max = 27831", "max = 9000"), "ebb.servo.min"),
            (axi.replace("up_percent = 60.0", "up_percent = 120.0"), "ebb.servo.up_percent"),
            (axi.replace("raise_rate_percent = 75.0", "raise_rate_percent = 0.0"), "ebb.servo.raise_rate_percent"),
            (axi.replace("sweep_ms = 200.0", "sweep_ms = 200.0\nwobble = 1"), "wobble"),
            (axi.replace("pen_up_speed_mm_s = 200.0", "pen_up_speed_mm_s = 500.0"), "pen_up_speed_mm_s"),
            (axi.replace("pens = 1", "pens = 1\npen_lift_s = 0.2"), "pen_lift_s"),
            (axi.replace("[ebb]", "[ebb_x]"), "ebb"),
            (axi.replace("y_up = false", "y_up = true"), "y_up"),
            (axi.replace("handshake = \"ebb\"", "handshake = \"grbl\""), "handshake"),
            (axi.replacen("origin = \"upper-left\"", "origin = \"lower-left\"", 1), "paper[0] (A4)"),
        ];
        for (text, field) in cases.into_iter().chain(ebb_cases) {
            let e = DeviceProfile::from_toml(&text).expect_err(field).to_string();
            assert!(e.contains(field), "expected {field:?} in {e}");
        }
    }
}
