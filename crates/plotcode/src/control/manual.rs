//! What a person at the plotter asks between jobs: the pen up or down, the
//! carriage moved to a point or by a step, with the pen up ([`Motion`]),
//! written in the device's own commands as a [`Program`] of one chunk, so
//! that a daemon streams and confirms it as it does a job (the protocol's
//! marker follows it).
//!
//! - HP-GL: `PU;`, `PD;`, `PU;PA x,y;`, and `PU;PR dx,dy;PA;` (the
//!   relative step, then absolute mode again, which every job assumes);
//! - G-code: the profile's own pen-up and pen-down lines (a servo's
//!   `M5`/`M3`, a Z axis's moves), `G90 G21 G0 X Y` and `G91 G0 X Y`,
//!   then `G90` again;
//! - EBB: `SP,1,ms` and `SP,0,ms` with the profile's servo times; a move
//!   to a point is `HM,rate,m1,m2` (firmware 2.7.0 and later: the motors
//!   go to those step counters, counted from home), a step is one `SM`.
//!
//! Positions are millimetres from the device's own origin, along its own
//! axes (an HP 7475A's lower-left corner; a GRBL board's work zero; an
//! AxiDraw's home): the frame its programs are written in.

use crate::ebb::{lm::Sm, Command, Motors};
use crate::profile::{DeviceProfile, Protocol};
use crate::program::{Chunk, Program};
use strokes::DVec2;

/// One thing a person asks of the carriage.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Motion {
    /// Raise the pen.
    PenUp,
    /// Lower the pen where it is.
    PenDown,
    /// Raise the pen, then go to this point (mm from the device's origin).
    MoveTo(DVec2),
    /// Raise the pen, then move by this much (mm).
    Jog(DVec2),
}

/// Why a motion cannot be written for a device.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ManualError {
    /// A coordinate that is not a finite number.
    #[error("{0} is not a position in millimetres")]
    NotFinite(String),
    /// A point outside every plotting area the device has.
    #[error("({x:.2}, {y:.2}) mm is outside device {device:?}'s reach: x {x_min:.2}..{x_max:.2}, y {y_min:.2}..{y_max:.2} mm")]
    OutOfReach {
        /// The device.
        device: String,
        /// The point.
        x: f64,
        /// The point.
        y: f64,
        /// The reach, mm.
        x_min: f64,
        /// The reach, mm.
        x_max: f64,
        /// The reach, mm.
        y_min: f64,
        /// The reach, mm.
        y_max: f64,
    },
    /// The profile lacks what the protocol needs (a `[gcode]` or `[ebb]` table).
    #[error("device {0:?} cannot be moved by hand: {1}")]
    Profile(String, String),
}

/// The device's reach in millimetres from its origin: the union of its
/// papers' plotting areas, `(min, max)`.
#[must_use]
pub fn reach_mm(profile: &DeviceProfile) -> (DVec2, DVec2) {
    let u = profile.unit_mm;
    let mut lo = DVec2::splat(f64::INFINITY);
    let mut hi = DVec2::splat(f64::NEG_INFINITY);
    for p in &profile.paper {
        lo = lo.min(DVec2::new(p.x_range[0], p.y_range[0]) * u);
        hi = hi.max(DVec2::new(p.x_range[1], p.y_range[1]) * u);
    }
    (lo, hi)
}

/// `motion` in `profile`'s commands: a program of one chunk, which does
/// not say where it leaves the pen (a step's end depends on where it
/// starts), timed for the longest move the device can make, so that a
/// streamer's wait for its marker is never too short.
///
/// # Errors
/// [`ManualError`]: a point that is not finite or out of the device's
/// reach, a profile without its protocol's table.
pub fn program(profile: &DeviceProfile, motion: Motion) -> Result<Program, ManualError> {
    check(profile, motion)?;
    let text = match profile.protocol {
        Protocol::Hpgl => hpgl(profile, motion),
        Protocol::Gcode => gcode(profile, motion)?,
        Protocol::Ebb => ebb(profile, motion)?,
    };
    let pen_s = profile.pen_lift_s.unwrap_or(0.0) + profile.pen_drop_s.unwrap_or(0.0);
    let (lo, hi) = reach_mm(profile);
    let travel_s = match motion {
        Motion::PenUp | Motion::PenDown => 0.0,
        Motion::MoveTo(_) => (hi - lo).length() / profile.pen_up_speed_mm_s,
        Motion::Jog(d) => d.length() / profile.pen_up_speed_mm_s,
    };
    let chunk = Chunk {
        bytes: text.into_bytes(),
        resume: Vec::new(),
        pen: None,
        draws: false,
        seconds: pen_s + travel_s,
        page: 0,
        end: None,
        path: None,
    };
    Ok(Program { protocol: profile.protocol, chunks: vec![chunk], pen_up: Vec::new() })
}

fn check(profile: &DeviceProfile, m: Motion) -> Result<(), ManualError> {
    let p = match m {
        Motion::MoveTo(p) | Motion::Jog(p) => p,
        Motion::PenUp | Motion::PenDown => return Ok(()),
    };
    if !p.is_finite() {
        return Err(ManualError::NotFinite(format!("({}, {})", p.x, p.y)));
    }
    let (lo, hi) = reach_mm(profile);
    if let (Motion::MoveTo(p), false) = (m, (lo.x..=hi.x).contains(&p.x) && (lo.y..=hi.y).contains(&p.y)) {
        return Err(ManualError::OutOfReach {
            device: profile.name.clone(),
            x: p.x,
            y: p.y,
            x_min: lo.x,
            x_max: hi.x,
            y_min: lo.y,
            y_max: hi.y,
        });
    }
    Ok(())
}

/// Device units of `mm`, rounded to whole ones.
fn units(profile: &DeviceProfile, mm: DVec2) -> DVec2 {
    (mm / profile.unit_mm).round()
}

fn hpgl(profile: &DeviceProfile, m: Motion) -> String {
    match m {
        Motion::PenUp => "PU;".to_owned(),
        Motion::PenDown => "PD;".to_owned(),
        Motion::MoveTo(p) => {
            let d = units(profile, p);
            format!("PU;PA{},{};", d.x, d.y)
        }
        Motion::Jog(p) => {
            let d = units(profile, p);
            format!("PU;PR{},{};PA;", d.x, d.y)
        }
    }
}

fn gcode(profile: &DeviceProfile, m: Motion) -> Result<String, ManualError> {
    let g = profile.gcode.as_ref().ok_or_else(|| ManualError::Profile(profile.name.clone(), "no [gcode] table".into()))?;
    let n = g.decimals;
    let line = |t: &str| format!("{}\n", t.trim_end());
    Ok(match m {
        Motion::PenUp => line(&g.pen_up),
        Motion::PenDown => line(&g.pen_down),
        Motion::MoveTo(p) => format!("{}G90 G21 G0 X{:.n$} Y{:.n$}\n", line(&g.pen_up), p.x, p.y),
        Motion::Jog(p) => format!("{}G91 G0 X{:.n$} Y{:.n$}\nG90\n", line(&g.pen_up), p.x, p.y),
    })
}

/// The fastest step rate `HM` takes, steps/s (EBB documentation).
const EBB_MAX_RATE: f64 = 25_000.0;

fn ebb(profile: &DeviceProfile, m: Motion) -> Result<String, ManualError> {
    let e = profile.ebb.as_ref().ok_or_else(|| ManualError::Profile(profile.name.clone(), "no [ebb] table".into()))?;
    let up = Command::Pen { up: true, ms: e.servo.raise_ms() };
    let rate = (profile.pen_up_speed_mm_s / profile.unit_mm).clamp(2.0, EBB_MAX_RATE);
    let lines: Vec<Command> = match m {
        Motion::PenUp => vec![up],
        Motion::PenDown => vec![Command::Pen { up: false, ms: e.servo.lower_ms() }],
        Motion::MoveTo(p) => vec![up, Command::Home { rate: rate as u32, to: Some(Motors::nearest(p / profile.unit_mm)) }],
        Motion::Jog(p) => {
            let steps = Motors::nearest(p / profile.unit_mm);
            let ms = (p.length() / profile.pen_up_speed_mm_s * 1000.0).ceil().max(1.0) as u32;
            vec![up, Command::Sm(Sm { ms, steps })]
        }
    };
    Ok(lines.iter().map(|c| format!("{c}\r")).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn profile(name: &str) -> DeviceProfile {
        DeviceProfile::builtin(name).unwrap()
    }

    fn text(profile: &DeviceProfile, motions: &[Motion]) -> String {
        let bytes: Vec<u8> = motions.iter().flat_map(|&m| program(profile, m).unwrap().bytes()).collect();
        String::from_utf8(bytes).unwrap()
    }

    /// Each protocol's own words, one chunk a motion.
    #[test]
    fn motions_are_the_devices_commands() {
        let hp = profile("hp7475a");
        let all = [Motion::PenDown, Motion::PenUp, Motion::MoveTo(DVec2::new(10.0, 5.0)), Motion::Jog(DVec2::new(-1.0, 2.0))];
        // The 7475A's unit is 0.02488 mm (its own figure, not 1/40).
        assert_eq!(text(&hp, &all), "PD;PU;PU;PA402,201;PU;PR-40,80;PA;");
        for m in all {
            let p = program(&hp, m).unwrap();
            assert_eq!((p.chunks.len(), p.chunks[0].draws, p.chunks[0].end), (1, false, None), "{m:?}");
        }

        let grbl = profile("grbl-servo");
        let t = text(&grbl, &[Motion::MoveTo(DVec2::new(10.0, 5.0)), Motion::PenDown]);
        assert_eq!(t, "M5\nG4 P0.15\nG90 G21 G0 X10.000 Y5.000\nM3 S1000\nG4 P0.15\n");
        assert_eq!(text(&grbl, &[Motion::Jog(DVec2::new(1.5, -2.0))]), "M5\nG4 P0.15\nG91 G0 X1.500 Y-2.000\nG90\n");
        // What the G-code reader makes of it: lines it knows.
        plotcode_cut_reads(&grbl, &t);

        let ebb = profile("axidraw");
        let t = text(&ebb, &[Motion::PenDown, Motion::MoveTo(DVec2::new(10.0, 5.0)), Motion::Jog(DVec2::new(1.0, 0.0))]);
        let lines: Vec<&str> = t.split('\r').filter(|l| !l.is_empty()).collect();
        assert!(lines[0].starts_with("SP,0"), "{t:?}");
        // 10 mm and 5 mm are 800 and 400 steps: motors 1200 and 400 (CoreXY).
        assert!(lines[1].starts_with("SP,1") && lines[2].starts_with("HM,") && lines[2].ends_with(",1200,400"), "{t:?}");
        assert!(lines[4].starts_with("SM,") && lines[4].ends_with(",80,80"), "{t:?}");
        plotcode_cut_reads(&ebb, &t);
    }

    fn plotcode_cut_reads(profile: &DeviceProfile, text: &str) {
        crate::cut(text.as_bytes(), profile).unwrap_or_else(|e| panic!("{text:?}: {e}"));
    }

    #[test]
    fn a_point_out_of_reach_or_not_a_number_is_refused_naming_it() {
        let hp = profile("hp7475a");
        let e = program(&hp, Motion::MoveTo(DVec2::new(900.0, 5.0))).unwrap_err().to_string();
        assert!(e.contains("(900.00, 5.00) mm is outside") && e.contains("hp7475a"), "{e}");
        let e = program(&hp, Motion::Jog(DVec2::new(f64::NAN, 5.0))).unwrap_err().to_string();
        assert!(e.contains("NaN"), "{e}");
    }
}
