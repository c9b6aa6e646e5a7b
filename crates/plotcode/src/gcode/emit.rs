//! G-code output for GRBL pen plotters.
//!
//! ```text
//! (plotd: grbl-servo, paper A4)
//! G21 G90              start template (millimetres, absolute)
//! T1                   tool-change template, once per pen
//! M0 (plotd: insert pen 2, then cycle start)   one-pen device, at a change
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

use super::line::{parse_line, Block, Line};
use super::state::BoardState;
use crate::clock::Clock;
use crate::emit::{EmitError, EmitOptions};
use crate::placed::{device_strokes, Emitted};
use crate::placement::place;
use crate::profile::{DeviceProfile, Protocol, GRBL_MAX_LINE};
use std::fmt::Write as _;
use strokes::{DVec2, Drawing};

/// Emits `drawing` as G-code for `profile`, its plot time told by the
/// [`Clock`] as it writes (through [`BoardState`], as a cutter of the file
/// times it).
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
    // G-code has no line types: a hidden line's dashes are strokes.
    let strokes = device_strokes(drawing, profile, &placement, g.decimals, true)?;
    let num = |v: f64| number(v, g.decimals);
    let xy = |p: DVec2| format!("X{} Y{}", num(p.x), num(p.y));
    // A pen of the table with a speed draws at its own feed.
    let feed = |pen: u32| {
        let mm_min = opts.pens.get(&pen).and_then(|p| p.speed_mm_s).map_or(g.draw_feed_mm_min, |v| v * 60.0);
        format!("F{}", num(mm_min))
    };
    let (pen_down, pen_up) = (Template::new(&g.pen_down), Template::new(&g.pen_up));

    let mut w = Writer { out: String::new(), board: BoardState::new(profile), clock: Clock::new(profile) };
    let _ = writeln!(w.out, "(plotd: {}, paper {})", sanitize(&profile.name), sanitize(&placement.paper));
    w.template(&Template::new(&g.start));
    let mut pen = None;
    for s in &strokes {
        if pen != Some(s.pen) {
            w.template(&Template::new(&template_for_pen(&g.tool_change, s.pen)));
            // One pen: a human changes it, so the program stops (GRBL holds
            // on M0 until cycle start); the first pen is loaded before the job.
            if pen.is_some() && profile.pens <= 1 && opts.pen_change_pauses {
                let _ = writeln!(w.out, "M0 (plotd: insert pen {}, then cycle start)", s.pen);
            }
        }
        pen = Some(s.pen);
        let _ = writeln!(w.out, "G0 {}", xy(s.points[0]));
        w.board.move_to(s.points[0], false, &mut w.clock);
        w.template(&pen_down);
        // A one-point stroke is a dot: a zero-length draw keeps it visible to readers.
        let rest = if s.points.len() == 1 { &s.points[..] } else { &s.points[1..] };
        for (k, &p) in rest.iter().enumerate() {
            if k == 0 {
                let _ = writeln!(w.out, "G1 {} {}", xy(p), feed(s.pen));
            } else {
                let _ = writeln!(w.out, "G1 {}", xy(p));
            }
            w.board.move_to(p, true, &mut w.clock);
        }
        w.template(&pen_up);
    }
    w.template(&Template::new(&g.end));
    debug_assert!(w.out.lines().all(|l| l.len() <= GRBL_MAX_LINE));
    Ok(Emitted { text: w.out, placement, stats: w.clock.stats() })
}

/// A template's lines, trimmed, blank ones left out, each with its parsed
/// block (what it does to the board).
struct Template {
    lines: Vec<(String, Block)>,
}

impl Template {
    fn new(text: &str) -> Template {
        let lines = text
            .lines()
            .map(str::trim)
            .filter(|l| !l.is_empty())
            .map(|l| {
                let block = match parse_line(l) {
                    Ok(Line::Block(b)) => b,
                    // `$` commands and lines GRBL would refuse move nothing the
                    // chunks follow.
                    Ok(Line::System(_)) | Err(_) => Block::default(),
                };
                (l.to_owned(), block)
            })
            .collect();
        Template { lines }
    }
}

/// The text written so far, the board's state and the plot time.
struct Writer {
    out: String,
    board: BoardState,
    clock: Clock,
}

impl Writer {
    fn template(&mut self, t: &Template) {
        for (line, block) in &t.lines {
            self.out.push_str(line);
            self.out.push('\n');
            self.board.run(block, &mut self.clock);
        }
    }
}

/// A template's text with `{pen}` replaced.
fn template_for_pen(text: &str, pen: u32) -> String {
    text.replace("{pen}", &pen.to_string())
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

    /// A pen table: pen 2's strokes draw at its own feed (20 mm/s: F1200),
    /// pen 1's at the profile's (3000 mm/min).
    #[test]
    fn a_pen_with_a_speed_draws_at_its_own_feed() {
        let p = DeviceProfile::builtin("grbl-servo").unwrap();
        let d = drawing(&[(1, &[&[(100.0, 100.0), (120.0, 100.0)]]), (2, &[&[(100.0, 90.0), (120.0, 90.0)]])]);
        let pens = crate::PenSettings::from([(2, crate::PenSetting { speed_mm_s: Some(20.0), force: None })]);
        let e = emit(&d, &p, &EmitOptions { pens, ..EmitOptions::default() }).unwrap();
        let feeds: Vec<&str> =
            e.text.lines().filter(|l| l.starts_with("G1")).filter_map(|l| l.split(' ').find(|w| w.starts_with('F'))).collect();
        assert_eq!(feeds, ["F3000", "F1200"], "{}", e.text);
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
    fn a_pen_change_on_a_one_pen_device_pauses_the_program() {
        let p = DeviceProfile::builtin("grbl-servo").unwrap();
        assert_eq!(p.pens, 1);
        let d = drawing(&[(1, &[&[(10.0, 10.0), (20.0, 10.0)]]), (2, &[&[(30.0, 30.0), (40.0, 40.0)]])]);
        let e = emit(&d, &p, &EmitOptions::default()).unwrap();
        // The first pen is loaded before the job starts; the change to pen 2
        // stops GRBL (M0, a program pause) after the pen is up and T2 is
        // written, before the travel to pen 2's stroke.
        assert!(!e.text.contains("insert pen 1"), "{}", e.text);
        let at = e.text.find("T2\nM0 (plotd: insert pen 2, then cycle start)\nG0 X30 Y30\n").expect(&e.text);
        assert!(e.text[..at].ends_with("M5\nG4 P0.15\n"), "{}", e.text);
        assert_eq!(e.text.matches("M0").count(), 1);
        // Cut for a daemon, which pauses the job itself, the pause is gone.
        let c = crate::cut(e.text.as_bytes(), &p).unwrap();
        assert!(c.chunks.iter().all(|c| !c.bytes.windows(2).chain(c.resume.windows(2)).any(|w| w == b"M0")), "{c:?}");
        assert!(String::from_utf8_lossy(&c.chunks[0].bytes).ends_with("M5\nG4 P0.15\nT2\n"));
        // A daemon pauses the job itself and asks for no program pause.
        let quiet = emit(&d, &p, &EmitOptions { pen_change_pauses: false, ..EmitOptions::default() }).unwrap();
        assert!(!quiet.text.contains("M0"));
        // A device with a tool changer changes pens itself.
        let mut changer = p.clone();
        changer.pens = 4;
        assert!(!emit(&d, &changer, &EmitOptions::default()).unwrap().text.contains("M0"));
    }

    #[test]
    fn numbers() {
        assert_eq!(number(12.0, 3), "12");
        assert_eq!(number(-0.0001, 3), "0");
        assert_eq!(number(1.23456, 3), "1.235");
        assert_eq!(number(3000.0, 0), "3000");
    }
}
