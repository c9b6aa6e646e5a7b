//! The G-code reader: the subset a pen plotter file uses, turned into strokes.
//!
//! Understood: `G0 G1` (lines), `G2 G3` (arcs, `I J` centre or `R` radius,
//! flattened), `G4` (dwell), `G17`, `G20 G21` (inch, mm), `G90 G91`, `M3 M4`
//! with `S` > 0 (pen down), `M3 S0` and `M5` (pen up), `Z` moves (pen down at or
//! below a threshold), `F`, `T` (pen), `M0 M1 M2 M30`, comments and `N`.
//! Anything else is skipped with a [`Warning`] naming it and its line.
//!
//! Coordinates come out in device units (millimetres divided by the profile's
//! unit length).

use super::line::{parse_line, Block, Line, LineError};
use crate::plot::{Location, Plot, Stroke, Warning};
use std::f64::consts::TAU;
use strokes::DVec2;

/// Largest chord error allowed when flattening an arc, mm.
pub const ARC_TOLERANCE_MM: f64 = 0.01;

/// Most segments one arc may become (bounds work for huge radii).
const MAX_ARC_SEGMENTS: usize = 10_000;

/// Largest coordinate magnitude accepted, mm (far beyond any plotter).
const MAX_COORDINATE_MM: f64 = 1.0e6;

/// How to read pen state and units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParseOptions {
    /// A `Z` at or below this (mm) means the pen is down.
    pub z_down_at_or_below: f64,
    /// Millimetres per device unit of the output.
    pub unit_mm: f64,
}

impl Default for ParseOptions {
    fn default() -> Self {
        ParseOptions { z_down_at_or_below: 0.0, unit_mm: 1.0 }
    }
}

/// Why a G-code file cannot be read.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("G-code error at line {line}, {problem}")]
pub struct GcodeError {
    /// 1-based line number.
    pub line: usize,
    /// What is wrong (with the column for syntax errors).
    pub problem: String,
}

/// Reads a G-code program into strokes.
///
/// # Errors
/// [`GcodeError`] naming the line (and column) of the first malformed or
/// unusable line.
pub fn parse(text: &str, opts: &ParseOptions) -> Result<Plot, GcodeError> {
    let mut m = Machine::new(*opts);
    for (n, raw) in text.lines().enumerate() {
        let line = n + 1;
        let parsed = parse_line(raw).map_err(|e: LineError| GcodeError { line, problem: e.to_string() })?;
        match parsed {
            Line::System(s) => m.warn(line, format!("skipped GRBL system command ${s}")),
            Line::Block(b) => m.execute(&b, line).map_err(|problem| GcodeError { line, problem })?,
        }
    }
    m.end_stroke();
    Ok(m.plot)
}

struct Machine {
    opts: ParseOptions,
    /// Position in mm.
    at: DVec2,
    z: Option<f64>,
    inches: bool,
    relative: bool,
    motion: Option<u8>,
    spindle_s: f64,
    down: bool,
    pen: u32,
    current: Option<Stroke>,
    plot: Plot,
}

impl Machine {
    fn new(opts: ParseOptions) -> Self {
        Machine {
            opts,
            at: DVec2::ZERO,
            z: None,
            inches: false,
            relative: false,
            motion: None,
            spindle_s: 0.0,
            down: false,
            pen: 1,
            current: None,
            plot: Plot::default(),
        }
    }

    fn warn(&mut self, line: usize, message: String) {
        self.plot.warnings.push(Warning { at: Location::Line(line), message });
    }

    fn execute(&mut self, b: &Block, line: usize) -> Result<(), String> {
        if let Some(w) = b.words.iter().find(|w| w.value.abs() > MAX_COORDINATE_MM) {
            return Err(format!("value {w} is out of range"));
        }
        let mut skip_motion = false;
        for w in &b.words {
            match w.letter {
                'G' => match w.value {
                    v if v == 0.0 || v == 1.0 || v == 2.0 || v == 3.0 => self.motion = Some(v as u8),
                    v if v == 4.0 || v == 17.0 || v == 94.0 => {}
                    20.0 => self.inches = true,
                    21.0 => self.inches = false,
                    90.0 => self.relative = false,
                    91.0 => self.relative = true,
                    v => {
                        self.warn(line, format!("skipped block with unsupported G{v}"));
                        skip_motion = true;
                    }
                },
                'M' => match w.value {
                    v if v == 3.0 || v == 4.0 => {
                        let s = b.get('S').unwrap_or(self.spindle_s);
                        self.set_pen(s > 0.0);
                    }
                    5.0 => self.set_pen(false),
                    v if v == 0.0 || v == 1.0 || v == 2.0 || v == 30.0 => {}
                    v => self.warn(line, format!("skipped unsupported M{v}")),
                },
                'T' => {
                    if !(0.0..=255.0).contains(&w.value) || w.value.fract() != 0.0 {
                        return Err(format!("tool number {} is not a pen number 0..255", w.value));
                    }
                    self.end_stroke();
                    self.pen = w.value as u32;
                }
                'S' => self.spindle_s = w.value,
                'X' | 'Y' | 'Z' | 'I' | 'J' | 'R' | 'F' | 'P' | 'N' => {}
                other => self.warn(line, format!("skipped unsupported word {other}")),
            }
        }
        if skip_motion {
            return Ok(());
        }
        let scale = if self.inches { 25.4 } else { 1.0 };
        let get = |c: char| b.get(c).map(|v| v * scale);
        if let Some(z) = get('Z') {
            let z = if self.relative { self.z.unwrap_or(0.0) + z } else { z };
            self.z = Some(z);
            self.set_pen(z <= self.opts.z_down_at_or_below);
        }
        let (x, y) = (get('X'), get('Y'));
        if x.is_none() && y.is_none() {
            return Ok(());
        }
        let target = if self.relative {
            self.at + DVec2::new(x.unwrap_or(0.0), y.unwrap_or(0.0))
        } else {
            DVec2::new(x.unwrap_or(self.at.x), y.unwrap_or(self.at.y))
        };
        match self.motion {
            None => return Err("coordinates without a motion mode (G0/G1/G2/G3)".to_owned()),
            Some(0) | Some(1) => self.line_to(target),
            Some(g) => {
                let points = arc(self.at, target, g == 2, get('I'), get('J'), get('R'))?;
                for p in points {
                    self.line_to(p);
                }
            }
        }
        Ok(())
    }

    fn set_pen(&mut self, down: bool) {
        if down && !self.down {
            self.current = Some(Stroke { pen: self.pen, points: vec![self.at / self.opts.unit_mm] });
        }
        if !down {
            self.end_stroke();
        }
        self.down = down;
    }

    fn line_to(&mut self, p: DVec2) {
        if self.down {
            let unit = self.opts.unit_mm;
            let (pen, at) = (self.pen, self.at);
            self.current.get_or_insert_with(|| Stroke { pen, points: vec![at / unit] }).points.push(p / unit);
        }
        self.at = p;
    }

    fn end_stroke(&mut self) {
        if let Some(s) = self.current.take() {
            self.plot.strokes.push(s);
        }
    }
}

/// The points (after `from`) of an arc to `to`, clockwise for `G2`.
fn arc(from: DVec2, to: DVec2, clockwise: bool, i: Option<f64>, j: Option<f64>, r: Option<f64>) -> Result<Vec<DVec2>, String> {
    let center = match (i, j, r) {
        (None, None, Some(r)) => {
            // Two circles pass through both ends; a negative R picks the long way round.
            let chord = to - from;
            let d = chord.length();
            if d == 0.0 {
                return Err("R-format arc with identical start and end".to_owned());
            }
            let h2 = r * r - d * d / 4.0;
            if h2 < -1e-9 * r * r {
                return Err(format!("arc radius {} is shorter than half the chord {}", r.abs(), d / 2.0));
            }
            let h = h2.max(0.0).sqrt();
            let left = DVec2::new(-chord.y, chord.x) / d;
            // Clockwise short arcs have their centre to the right of the chord.
            let side = if clockwise == (r > 0.0) { -1.0 } else { 1.0 };
            from + chord / 2.0 + left * h * side
        }
        (None, None, None) => return Err("arc without I/J or R".to_owned()),
        (i, j, _) => from + DVec2::new(i.unwrap_or(0.0), j.unwrap_or(0.0)),
    };
    let radius = from.distance(center);
    if radius == 0.0 {
        return Ok(vec![to]);
    }
    let a0 = (from - center).to_angle();
    let a1 = (to - center).to_angle();
    let mut sweep = a1 - a0;
    if clockwise {
        while sweep >= 0.0 {
            sweep -= TAU;
        }
    } else {
        while sweep <= 0.0 {
            sweep += TAU;
        }
    }
    // Chord error r(1 - cos(t/2)) <= tolerance.
    let step = 2.0 * (1.0 - (ARC_TOLERANCE_MM / radius).min(1.0)).acos();
    let n = ((sweep.abs() / step.max(1e-9)).ceil() as usize).clamp(1, MAX_ARC_SEGMENTS);
    let mut out: Vec<DVec2> = (1..n).map(|k| center + DVec2::from_angle(a0 + sweep * k as f64 / n as f64) * radius).collect();
    out.push(to);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn strokes(text: &str) -> Vec<(u32, Vec<(f64, f64)>)> {
        parse(text, &ParseOptions::default())
            .unwrap_or_else(|e| panic!("{e}"))
            .strokes
            .into_iter()
            .map(|s| (s.pen, s.points.iter().map(|p| ((p.x * 1e6).round() / 1e6, (p.y * 1e6).round() / 1e6)).collect()))
            .collect()
    }

    #[test]
    fn servo_pen_and_modes() {
        let text = "G21 G90\nG0 X10 Y10\nM3 S1000\nG1 X20 F3000\nY20\nM5\nG91\nG0 X5\nM3\nG1 Y-5\nM5\n";
        assert_eq!(strokes(text), vec![(1, vec![(10.0, 10.0), (20.0, 10.0), (20.0, 20.0)]), (1, vec![(25.0, 20.0), (25.0, 15.0)])]);
        // M3 S0 is pen up; inches scale to mm.
        assert_eq!(strokes("G20 G0 X1 Y1\nM3 S0\nG1 X2\nM3 S10\nG1 X2 Y2\n"), vec![(1, vec![(50.8, 25.4), (50.8, 50.8)])]);
    }

    #[test]
    fn z_pen_and_tools() {
        let text = "G21 G90\nT2\nG0 Z5\nG0 X1 Y1\nG1 Z0 F500\nG1 X2 Y1\nG0 Z5\nT3\nG0 X3 Y3\nG1 Z-0.5\nG1 X4\nG0 Z5";
        assert_eq!(strokes(text), vec![(2, vec![(1.0, 1.0), (2.0, 1.0)]), (3, vec![(3.0, 3.0), (4.0, 3.0)])]);
    }

    #[test]
    fn arcs_are_flattened_within_tolerance() {
        // A half circle of radius 10 about (10, 0), counter-clockwise from (20,0) to (0,0).
        for text in ["G0 X20 Y0\nM3 S1\nG3 X0 Y0 I-10 J0\n", "G0 X20 Y0\nM3 S1\nG3 X0 Y0 R10\n"] {
            let s = &strokes(text)[0].1;
            assert!(s.len() > 20, "{}", s.len());
            for &(x, y) in s {
                assert!(((x - 10.0).hypot(y) - 10.0).abs() < 1e-6);
                assert!(y >= -1e-9, "counter-clockwise from (20,0) goes through y > 0: {y}");
            }
            assert_eq!(*s.last().unwrap(), (0.0, 0.0));
        }
        // Clockwise goes the other way.
        let s = &strokes("G0 X20 Y0\nM3 S1\nG2 X0 Y0 I-10 J0\n")[0].1;
        assert!(s.iter().all(|&(_, y)| y <= 1e-9));
        // A full circle when the ends coincide.
        let s = &strokes("G0 X10 Y0\nM3 S1\nG2 X10 Y0 I-10\n")[0].1;
        let min_x = s.iter().map(|p| p.0).fold(f64::MAX, f64::min);
        assert!((min_x + 10.0).abs() < 0.02, "{min_x}");
    }

    #[test]
    fn warnings_and_errors_name_lines() {
        let plot = parse("G21\n$H\nG28\nM8\nG0 X1 Y1\n", &ParseOptions::default()).unwrap();
        let w: Vec<String> = plot.warnings.iter().map(ToString::to_string).collect();
        assert_eq!(
            w,
            ["line 2: skipped GRBL system command $H", "line 3: skipped block with unsupported G28", "line 4: skipped unsupported M8"]
        );
        let cases: &[(&str, &str)] = &[
            ("G21\nG1 X", "line 2, column 4"),
            ("G21\nX5 Y5", "line 2, coordinates without a motion mode"),
            ("G0 X0 Y0\nM3 S1\nG2 X10 Y0", "line 3, arc without I/J or R"),
            ("G0 X0 Y0\nG2 X10 Y0 R2", "line 2, arc radius 2"),
            ("T-1", "line 1, tool number"),
            ("G1 X10000000", "line 1, value X10000000 is out of range"),
        ];
        for (text, msg) in cases {
            let e = parse(text, &ParseOptions::default()).unwrap_err().to_string();
            assert!(e.contains(msg), "{text:?}: {e}");
        }
    }
}
