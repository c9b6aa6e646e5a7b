//! G-code output for GRBL pen plotters.
//!
//! ```text
//! (plotd: grbl-servo, paper A4)
//! G21 G90              start template (millimetres, absolute)
//! T1                   tool-change template, once per pen
//! G0 X10 Y10           travel with the pen up
//! M3 S1000             pen-down template
//! G1 X20 Y10 F3000     draw; the feed is restated after every pen-down
//! G1 X20 Y20
//! M5                   pen-up template
//! ...                  end template
//! ```
//!
//! Every line is at most [`GRBL_MAX_LINE`] characters (GRBL's line buffer is 80
//! with its terminator). The same input gives the same bytes.

use crate::emit::{EmitError, EmitOptions};
use crate::placed::{device_strokes, stats, Emitted};
use crate::placement::place;
use crate::profile::{DeviceProfile, Protocol, GRBL_MAX_LINE};
use std::fmt::Write as _;
use strokes::{DVec2, Drawing};

/// Emits `drawing` as G-code for `profile`.
///
/// # Errors
/// [`EmitError::WrongProtocol`] for an HP-GL profile, and the placement and
/// range errors of [`EmitError`].
pub fn emit(drawing: &Drawing, profile: &DeviceProfile, opts: &EmitOptions) -> Result<Emitted, EmitError> {
    let g = match (&profile.gcode, profile.protocol) {
        (Some(g), Protocol::Gcode) => g,
        _ => return Err(EmitError::WrongProtocol { device: profile.name.clone(), protocol: profile.protocol }),
    };
    let placement = place(drawing, profile, opts)?;
    let strokes = device_strokes(drawing, profile, &placement, g.decimals)?;
    let num = |v: f64| number(v, g.decimals);
    let xy = |p: DVec2| format!("X{} Y{}", num(p.x), num(p.y));

    let mut out = String::new();
    let _ = writeln!(out, "(plotd: {}, paper {})", sanitize(&profile.name), sanitize(&placement.paper));
    template(&mut out, &g.start, None);
    let mut pen = None;
    for s in &strokes {
        if pen != Some(s.pen) {
            template(&mut out, &g.tool_change, Some(s.pen));
            pen = Some(s.pen);
        }
        let _ = writeln!(out, "G0 {}", xy(s.points[0]));
        template(&mut out, &g.pen_down, None);
        // A one-point stroke is a dot: a zero-length draw keeps it visible to readers.
        let rest = if s.points.len() == 1 { &s.points[..] } else { &s.points[1..] };
        for (k, &p) in rest.iter().enumerate() {
            if k == 0 {
                let _ = writeln!(out, "G1 {} F{}", xy(p), num(g.draw_feed_mm_min));
            } else {
                let _ = writeln!(out, "G1 {}", xy(p));
            }
        }
        template(&mut out, &g.pen_up, None);
    }
    template(&mut out, &g.end, None);
    debug_assert!(out.lines().all(|l| l.len() <= GRBL_MAX_LINE));
    Ok(Emitted { stats: stats(drawing, profile, &placement), text: out, placement })
}

/// Appends a template's non-empty lines, `{pen}` replaced.
fn template(out: &mut String, text: &str, pen: Option<u32>) {
    for line in text.lines() {
        let line = line.trim();
        if line.is_empty() {
            continue;
        }
        match pen {
            Some(p) => out.push_str(&line.replace("{pen}", &p.to_string())),
            None => out.push_str(line),
        }
        out.push('\n');
    }
}

/// Keeps a name safe inside a `( )` comment and short.
fn sanitize(s: &str) -> String {
    s.chars().filter(|c| !matches!(c, '(' | ')' | ';' | '\n' | '\r')).take(24).collect()
}

/// `v` with `decimals` places, trailing zeros and negative zero dropped.
fn number(v: f64, decimals: usize) -> String {
    let mut s = format!("{v:.decimals$}");
    if s.contains('.') {
        s = s.trim_end_matches('0').trim_end_matches('.').to_owned();
    }
    if s == "-0" {
        s = "0".to_owned();
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use strokes::{LineKind, Polyline};

    #[allow(clippy::type_complexity)] // (pen, polylines as point lists): the test's own shorthand
    fn drawing(layers: &[(u32, &[&[(f64, f64)]])]) -> Drawing {
        let mut d = Drawing::new(297.0, 210.0);
        for (pen, polys) in layers {
            for pts in *polys {
                d.layer_mut(*pen, LineKind::Visible).polylines.push(Polyline::new(pts.iter().map(|&(x, y)| DVec2::new(x, y)).collect()));
            }
        }
        d
    }

    #[test]
    fn exact_program_for_grbl_servo() {
        let p = DeviceProfile::builtin("grbl-servo").unwrap();
        // The A4 area is the whole page, so page mm are device mm.
        let d = drawing(&[(1, &[&[(10.0, 10.0), (20.0, 10.0), (20.0, 20.5)]])]);
        let e = emit(&d, &p, &EmitOptions::default()).unwrap();
        let expected = "(plotd: grbl-servo, paper A4)\nG21 G90\nM5\nG4 P0.15\nT1\nG0 X10 Y10\nM3 S1000\nG4 P0.15\n\
                        G1 X20 Y10 F3000\nG1 X20 Y20.5\nM5\nG4 P0.15\nM5\nG4 P0.15\nG0 X0 Y0\n";
        assert_eq!(e.text, expected);
    }

    #[test]
    fn lines_fit_grbl_and_pens_change() {
        let p = DeviceProfile::builtin("grbl-z").unwrap();
        let d = drawing(&[(1, &[&[(1.0 / 3.0, 2.0 / 3.0), (296.999, 209.999)]]), (2, &[&[(5.0, 5.0), (6.0, 6.0)]])]);
        let e = emit(&d, &p, &EmitOptions::default()).unwrap();
        assert!(e.text.lines().all(|l| l.len() <= GRBL_MAX_LINE));
        assert!(e.text.contains("G0 X0.333 Y0.667\n"), "{}", e.text);
        assert!(e.text.contains("\nT1\n") && e.text.contains("\nT2\n"));
        assert!(e.text.starts_with("(plotd: grbl-z, paper A4)\nG21 G90\n"));
    }

    #[test]
    fn numbers() {
        assert_eq!(number(12.0, 3), "12");
        assert_eq!(number(-0.0001, 3), "0");
        assert_eq!(number(1.23456, 3), "1.235");
        assert_eq!(number(3000.0, 0), "3000");
    }
}
