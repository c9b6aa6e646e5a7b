//! HP-GL output.
//!
//! ```text
//! IN;VS38;            initialise; optional pen speed
//! SP1;                pen per layer
//! PU1000,1000;PD2000,1000,2000,2000;   one stroke: travel, then many pairs
//! PU;SP0;             lift and put the pen away
//! ```
//!
//! Hidden lines are dashed by the device's own line type when it has them
//! (`line_types`, the default): the header then sets P1 and P2 to the
//! paper's hard-clip corners (`IP`), so that a pattern length, which HP-GL
//! gives in percent of the P1-P2 diagonal, is known in millimetres; `LT3,l;`
//! (70 % drawn) or `LT2,l;` (50 %), whichever is nearer the drawing's dash,
//! with `l` its period, goes before hidden strokes and `LT;` (solid) before
//! visible ones. Without line types the dashes are cut as strokes.
//!
//! Coordinates are whole plotter units (the 7475A truncates fractions anyway).
//! With `relative`, the first move is absolute and everything after it is `PR`
//! relative, computed from the rounded absolute points so that rounding never
//! accumulates. No instruction is longer than the profile's
//! `max_instruction_bytes`: long strokes continue in further `PD` instructions.
//! Each stroke ends its line, so files diff and read well. The same input gives
//! the same bytes.

use super::cut::line_type_dash;
use crate::clock::Clock;
use crate::emit::{EmitError, EmitOptions, Sink};
use crate::placed::{device_strokes, DeviceStroke, Emitted, Written};
use crate::placement::place;
use crate::profile::{DeviceProfile, Protocol};
use rayon::prelude::*;
use std::fmt::Write as _;
use strokes::{DVec2, Dash, Drawing};

/// Emits `drawing` as HP-GL for `profile`, its plot time told by the
/// [`Clock`] as it writes (the clock a cutter of the file runs).
///
/// # Errors
/// [`EmitError::WrongProtocol`] for a G-code profile, [`EmitError::NoSuchPen`]
/// for a pen beyond the device's count, and the placement and range errors of
/// [`EmitError`].
pub fn emit(drawing: &Drawing, profile: &DeviceProfile, opts: &EmitOptions) -> Result<Emitted, EmitError> {
    let mut text = String::new();
    let written = emit_to(drawing, profile, opts, &mut |piece: String| text.push_str(&piece))?;
    Ok(Emitted::of(text, written))
}

/// [`emit`], the text handed to `sink` piece by piece as it is written.
/// Nothing reaches `sink` when the drawing cannot be emitted.
///
/// # Errors
/// As [`emit`].
pub fn emit_to(drawing: &Drawing, profile: &DeviceProfile, opts: &EmitOptions, sink: &mut Sink<'_>) -> Result<Written, EmitError> {
    if profile.protocol != Protocol::Hpgl {
        return Err(EmitError::WrongProtocol { device: profile.name.clone(), protocol: profile.protocol });
    }
    let placement = place(drawing, profile, opts)?;
    let strokes = device_strokes(drawing, profile, &placement, 0, !profile.line_types)?;
    if let Some(s) = strokes.iter().find(|s| s.pen == 0 || s.pen > profile.pens) {
        return Err(EmitError::NoSuchPen { pen: s.pen, device: profile.name.clone(), pens: profile.pens });
    }
    let mut head = String::from("IN;");
    if let Some(v) = profile.velocity_cm_s {
        let _ = write!(head, "VS{};", trim(v));
    }
    // Line types: P1 and P2 at the paper's corners, and the dashed line type.
    let dashed = (profile.line_types && strokes.iter().any(|s| s.hidden)).then(|| line_type(drawing.hidden_dash, profile, &placement));
    if let Some(lt) = &dashed {
        head.push_str(&lt.ip);
    }
    head.push('\n');
    sink(head);
    // What goes before a stroke (a pen change, a line type change, where its
    // first move starts from) depends only on the stroke before it, so the
    // strokes are written in parallel, a batch at a time, while the clock
    // runs along them.
    let plan = Plan {
        strokes: &strokes,
        dashed: dashed.as_ref(),
        first_hidden: dashed.as_ref().and_then(|_| strokes.iter().position(|s| s.hidden)),
        relative: opts.relative,
        pen_table: PenTable::of(&opts.pens, profile.velocity_cm_s),
    };
    let ((), mut clock) = rayon::join(
        || {
            for (b, batch) in strokes.chunks(STROKES_PER_BATCH).enumerate() {
                let texts: Vec<String> = batch
                    .par_chunks(STROKES_PER_TASK)
                    .enumerate()
                    .map(|(c, chunk)| {
                        // About 10 bytes a point, sized so the text is not
                        // copied as it grows.
                        let bytes = chunk.iter().map(|s| 32 + 12 * s.points.len()).sum();
                        let mut w = Writer { out: Vec::with_capacity(bytes), max: profile.max_instruction_bytes };
                        for k in 0..chunk.len() {
                            plan.write(&mut w, b * STROKES_PER_BATCH + c * STROKES_PER_TASK + k);
                        }
                        String::from_utf8(w.out).expect("HP-GL text is ASCII")
                    })
                    .collect();
                texts.into_iter().for_each(&mut *sink);
            }
        },
        || {
            let mut clock = Clock::new(profile);
            for (i, s) in strokes.iter().enumerate() {
                if let Some(dashed) = plan.dashed.filter(|_| plan.changes_line_type(i)) {
                    clock.line_type(s.hidden.then_some(dashed.dash).flatten());
                }
                let (first, rest) = first_and_rest(&s.points);
                clock.pen(false);
                clock.move_to(first, false);
                clock.pen(true);
                for &p in rest {
                    clock.move_to(p, true);
                }
            }
            clock
        },
    );
    let mut tail = String::new();
    if plan.first_hidden.is_some() && strokes.last().is_some_and(|s| s.hidden) {
        tail.push_str("LT;");
        clock.line_type(None);
    }
    tail.push_str("PU;SP0;\n");
    sink(tail);
    clock.pen(false);
    Ok(Written { placement, stats: clock.stats() })
}

/// Strokes written by one parallel task.
const STROKES_PER_TASK: usize = 64;
/// Strokes written before their text goes to the sink.
const STROKES_PER_BATCH: usize = 16 * STROKES_PER_TASK;

/// A stroke's first point and the points its `PD` goes through: a one-point
/// stroke is a dot, the pen put down where it is.
fn first_and_rest(points: &[DVec2]) -> (DVec2, &[DVec2]) {
    (points[0], if points.len() == 1 { points } else { &points[1..] })
}

/// The strokes to write and what decides the commands around each.
struct Plan<'a> {
    strokes: &'a [DeviceStroke],
    /// The dashed line type, when hidden strokes are dashed by the device.
    dashed: Option<&'a LineType>,
    /// The first hidden stroke, when they are dashed by the device.
    first_hidden: Option<usize>,
    relative: bool,
    pen_table: PenTable<'a>,
}

/// What a pen change sets besides the pen: `VS` when a pen of the table
/// has a speed, `FS` when one has a force; then at every change, a pen
/// without its own going back to the default (the profile's velocity, or
/// the device's).
struct PenTable<'a> {
    pens: &'a crate::pens::PenSettings,
    speeds: bool,
    forces: bool,
    default_velocity_cm_s: Option<f64>,
}

impl PenTable<'_> {
    fn of(pens: &crate::pens::PenSettings, default_velocity_cm_s: Option<f64>) -> PenTable<'_> {
        let speeds = crate::pens::any_sets(pens, |p| p.speed_mm_s);
        let forces = crate::pens::any_sets(pens, |p| p.force);
        PenTable { pens, speeds, forces, default_velocity_cm_s }
    }

    /// The instructions after `SP pen`.
    fn after_select(&self, pen: u32) -> String {
        let setting = self.pens.get(&pen).copied().unwrap_or_default();
        let mut out = String::new();
        if self.speeds {
            match setting.speed_mm_s.map(|v| v / 10.0).or(self.default_velocity_cm_s) {
                Some(v) => _ = write!(out, "VS{};", trim(v)),
                None => out.push_str("VS;"),
            }
        }
        if self.forces {
            match setting.force {
                Some(f) => _ = write!(out, "FS{f};"),
                None => out.push_str("FS;"),
            }
        }
        out
    }
}

impl Plan<'_> {
    /// The line type stroke `i` is drawn with.
    fn wanted<'d>(&self, i: usize, dashed: &'d LineType) -> &'d str {
        if self.strokes[i].hidden {
            dashed.lt.as_str()
        } else {
            "LT;"
        }
    }

    /// Whether an `LT` goes before stroke `i`: solid is the state after
    /// `IN`, so the first goes before the first hidden stroke, and from
    /// there on one goes wherever a stroke wants another than the last.
    fn changes_line_type(&self, i: usize) -> bool {
        match (self.dashed, self.first_hidden) {
            (Some(d), Some(h)) => i == h || (i > h && self.wanted(i, d) != self.wanted(i - 1, d)),
            _ => false,
        }
    }

    /// Writes stroke `i` with the pen and line type changes before it.
    fn write(&self, w: &mut Writer, i: usize) {
        let s = &self.strokes[i];
        if i == 0 || self.strokes[i - 1].pen != s.pen {
            w.out.extend_from_slice(format!("SP{};{}\n", s.pen, self.pen_table.after_select(s.pen)).as_bytes());
        }
        if let Some(d) = self.dashed.filter(|_| self.changes_line_type(i)) {
            w.out.extend_from_slice(self.wanted(i, d).as_bytes());
            w.out.push(b'\n');
        }
        let (first, rest) = first_and_rest(&s.points);
        match i.checked_sub(1).and_then(|p| self.strokes[p].points.last()) {
            Some(&prev) if self.relative => {
                w.instruction("PU", &[first - prev]);
                w.instruction("PD", &deltas(first, rest));
            }
            _ => {
                w.instruction("PU", &[first]);
                if self.relative {
                    // The first stroke: absolute to it, relative after.
                    w.out.extend_from_slice(b"PR;");
                    w.instruction("PD", &deltas(first, rest));
                } else {
                    w.instruction("PD", rest);
                }
            }
        }
        w.out.push(b'\n');
    }
}

struct Writer {
    out: Vec<u8>,
    max: usize,
}

impl Writer {
    /// `MN x,y,x,y...;`, continued in further `MN` instructions when it would
    /// exceed the length cap. Written in place as bytes, each pair in one
    /// copy: on a drawing of millions of points a string per pair, and then
    /// a copy per number, was most of the writing.
    fn instruction(&mut self, mnemonic: &str, points: &[DVec2]) {
        self.out.extend_from_slice(mnemonic.as_bytes());
        let mut len = mnemonic.len();
        let mut has = false;
        let mut buf = [0u8; crate::decimal::PAIR_BYTES];
        for p in points {
            let pair = crate::decimal::int_pair(&mut buf, p.x as i64, b',', p.y as i64);
            // +2: the separating comma and the final `;`.
            if has && len + pair.len() + 2 > self.max {
                self.out.push(b';');
                self.out.extend_from_slice(mnemonic.as_bytes());
                len = mnemonic.len();
                has = false;
            }
            if has {
                self.out.push(b',');
                len += 1;
            }
            self.out.extend_from_slice(pair);
            len += pair.len();
            has = true;
        }
        self.out.push(b';');
    }
}

/// The steps from `first` through each point of `rest`, for relative (`PR`) moves.
fn deltas(first: DVec2, rest: &[DVec2]) -> Vec<DVec2> {
    let mut cur = first;
    rest.iter()
        .map(|&p| {
            let d = p - cur;
            cur = p;
            d
        })
        .collect()
}

/// The line type that dashes hidden lines on the device.
struct LineType {
    /// `IP` with P1 and P2 at the corners of the paper's hard-clip limits.
    ip: String,
    /// The dashed `LT`.
    lt: String,
    /// The dashes it draws, as the plot time counts them.
    dash: Option<Dash>,
}

/// The [`LineType`] that dashes like `dash`: line type 3 (70 % drawn) or 2
/// (50 %), whichever is nearer its drawn fraction, with its period as the
/// pattern length in percent of the P1-P2 diagonal (at most 127.9999, the
/// largest HP-GL takes: a 50 mm period on a sheet at least 39 mm across).
fn line_type(dash: Dash, profile: &DeviceProfile, placement: &crate::Placement) -> LineType {
    let paper = profile.paper_named(&placement.paper).expect("placement names a paper of this profile");
    let (x, y) = (paper.x_range, paper.y_range);
    let p1p2 = [DVec2::new(x[0], y[0]), DVec2::new(x[1], y[1])];
    let diagonal_mm = p1p2[0].distance(p1p2[1]) * profile.unit_mm;
    let kind = if (dash.drawn_fraction() - 0.7).abs() <= (dash.drawn_fraction() - 0.5).abs() { 3 } else { 2 };
    let percent = trim4((100.0 * dash.period_mm() / diagonal_mm).min(127.9999));
    // Timed at the length the device is given, as a cutter of the file reads it.
    let given: f64 = percent.parse().expect("a formatted number reads back");
    LineType {
        ip: format!("IP{},{},{},{};", x[0], y[0], x[1], y[1]),
        lt: format!("LT{kind},{percent};"),
        dash: line_type_dash(f64::from(kind), given, p1p2, profile.unit_mm),
    }
}

/// A number with at most four decimals, no needless zeros.
fn trim4(v: f64) -> String {
    let s = format!("{v:.4}");
    s.trim_end_matches('0').trim_end_matches('.').to_owned()
}

/// A number without a needless fraction (`38`, `12.5`).
fn trim(v: f64) -> String {
    let s = format!("{v:.2}");
    s.trim_end_matches('0').trim_end_matches('.').to_owned()
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

    /// A pen table: pen 2 draws at 15 mm/s (`VS1.5`) pressed with force 3,
    /// pen 1 at the profile's velocity and the device's force, each set
    /// after every `SP` (the device keeps the last `VS` across pens); the
    /// cut's resume prefix carries them.
    #[test]
    fn a_pen_with_a_speed_gets_its_vs_after_its_sp() {
        let mut p = DeviceProfile::builtin("hp7550a").unwrap();
        p.velocity_cm_s = Some(38.0);
        let d = drawing(&[(1, &[&[(100.0, 100.0), (120.0, 100.0)]]), (2, &[&[(100.0, 90.0), (120.0, 90.0)]])]);
        let pens = crate::PenSettings::from([(2, crate::PenSetting { speed_mm_s: Some(15.0), force: Some(3) })]);
        let e = emit(&d, &p, &EmitOptions { pens, ..EmitOptions::default() }).unwrap();
        let selects: Vec<&str> = e.text.lines().filter(|l| l.starts_with("SP") && !l.starts_with("SP0")).collect();
        assert_eq!(selects, ["SP1;VS38;FS;", "SP2;VS1.5;FS3;"], "{}", e.text);
        let program = crate::cut(e.text.as_bytes(), &p).unwrap();
        let last = program.chunks.iter().rfind(|c| c.draws).unwrap();
        let prefix = String::from_utf8_lossy(&last.resume);
        assert!(prefix.contains("VS1.5;") && prefix.contains("FS3;"), "{prefix}");
        // Without a table, nothing changes.
        let plain = emit(&d, &p, &EmitOptions::default()).unwrap();
        assert!(plain.text.contains("SP2;\n") && !plain.text.contains("FS"), "{}", plain.text);
    }

    #[test]
    fn structure_and_exact_bytes() {
        let p = DeviceProfile::builtin("hp7475a").unwrap();
        // Page centre (148.5, 105) maps to (5520, 3860.5); 1 mm = 1/0.02488 units.
        let d = drawing(&[(1, &[&[(148.5, 105.0), (158.5, 105.0), (158.5, 115.0)]]), (2, &[&[(148.5, 95.0), (148.5, 105.0)]])]);
        let e = emit(&d, &p, &EmitOptions::default()).unwrap();
        let u = 10.0 / 0.02488;
        let (x0, y0) = (5520.0, 3860.5);
        let r = |v: f64| v.round() as i64;
        let expected = format!(
            "IN;\nSP1;\nPU{},{};PD{},{},{},{};\nSP2;\nPU{},{};PD{},{};\nPU;SP0;\n",
            r(x0),
            r(y0),
            r(x0 + u),
            r(y0),
            r(x0 + u),
            r(y0 + u),
            r(x0),
            r(y0 - u),
            r(x0),
            r(y0)
        );
        assert_eq!(e.text, expected);
        assert!(!e.placement.scaled_down());
        assert_eq!(e.stats.strokes, 2);
        // Deterministic.
        assert_eq!(emit(&d, &p, &EmitOptions::default()).unwrap().text, e.text);
    }

    #[test]
    fn relative_mode_and_long_strokes_split() {
        let mut p = DeviceProfile::builtin("hp7475a").unwrap();
        p.max_instruction_bytes = 40;
        let pts: Vec<(f64, f64)> = (0..50).map(|i| (20.0 + i as f64 * 5.0, 30.0 + (i % 7) as f64 * 9.0)).collect();
        let d = drawing(&[(1, &[&pts, &[(100.0, 100.0), (120.0, 150.0)]])]);
        for relative in [false, true] {
            let e = emit(&d, &p, &EmitOptions { relative, ..EmitOptions::default() }).unwrap();
            for instr in e.text.split(';') {
                assert!(instr.trim_start().len() < 40, "{instr:?}");
            }
            assert_eq!(e.text.contains("PR;"), relative);
            assert!(e.text.matches("PD").count() > 5);
        }
        let abs = emit(&d, &p, &EmitOptions::default()).unwrap().text;
        let rel = emit(&d, &p, &EmitOptions { relative: true, ..EmitOptions::default() }).unwrap().text;
        assert!(rel.len() < abs.len(), "relative {} >= absolute {}", rel.len(), abs.len());
    }

    #[test]
    fn velocity_dots_and_degenerate_polylines() {
        let mut p = DeviceProfile::builtin("hp7475a").unwrap();
        p.velocity_cm_s = Some(20.0);
        // A polyline shorter than one plotter unit is a dot; one-point polylines draw nothing.
        let d = drawing(&[(3, &[&[(100.0, 100.0), (100.001, 100.0)], &[(50.0, 50.0)], &[]])]);
        let e = emit(&d, &p, &EmitOptions::default()).unwrap();
        assert!(e.text.starts_with("IN;VS20;\nSP3;\nPU"), "{}", e.text);
        let line = e.text.lines().nth(2).unwrap();
        let (pu, pd) = line.split_once(";PD").unwrap();
        assert_eq!(&pu[2..], pd.trim_end_matches(';'));
        assert!(e.text.ends_with("PU;SP0;\n"));
    }

    #[test]
    fn bad_input() {
        let p = DeviceProfile::builtin("hp7475a").unwrap();
        let g = DeviceProfile::builtin("grbl-servo").unwrap();
        let d = drawing(&[(7, &[&[(10.0, 10.0), (20.0, 20.0)]])]);
        assert!(matches!(emit(&d, &p, &EmitOptions::default()), Err(EmitError::NoSuchPen { pen: 7, pens: 6, .. })));
        let d = drawing(&[(1, &[&[(10.0, 10.0), (20.0, 20.0)]])]);
        assert!(matches!(emit(&d, &g, &EmitOptions::default()), Err(EmitError::WrongProtocol { .. })));
        // Without scaling, ink past the hard-clip limits is an error naming the point.
        let d = drawing(&[(1, &[&[(148.0, 105.0), (296.0, 105.0)]])]);
        let no_fit = EmitOptions { scale_to_fit: false, ..EmitOptions::default() };
        let e = emit(&d, &p, &no_fit).unwrap_err();
        assert!(matches!(e, EmitError::OutOfRange { point: 1, .. }), "{e}");
        assert!(e.to_string().contains("outside the range of paper A4"), "{e}");
        // With scaling (the default) it fits and says so.
        let ok = emit(&d, &p, &EmitOptions::default()).unwrap();
        assert!(ok.placement.scaled_down());
    }
}
