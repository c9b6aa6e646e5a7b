//! GRBL's reading of one G-code line: words, modal groups, error numbers.
//!
//! This is device behaviour (which words GRBL 1.1 accepts and which error it
//! answers), so it lives here rather than in `plotcode`'s host-side parser.
//! Reference: GRBL 1.1 `doc/markdown/commands.md` (supported G/M codes) and
//! `doc/csv/error_codes_en_US.csv`: 1 expected command letter, 2 bad number
//! format, 4 negative value, 20 unsupported command, 21 modal group
//! violation, 22 undefined feed rate, 25 repeated word, 26 no axis words,
//! 27 no arc offsets in plane, 28 value word missing, 31 axis words with no
//! motion, 33 invalid target (arc), 36 unused value words. Arcs are cut into
//! chords the way `mc_arc` does, within the arc tolerance `$12`.

/// GRBL error numbers used here.
pub(crate) mod err {
    pub const EXPECTED_LETTER: u32 = 1;
    pub const BAD_NUMBER: u32 = 2;
    pub const NEGATIVE: u32 = 4;
    pub const UNSUPPORTED: u32 = 20;
    pub const MODAL_GROUP: u32 = 21;
    pub const UNDEFINED_FEED: u32 = 22;
    pub const REPEATED_WORD: u32 = 25;
    pub const NO_OFFSETS: u32 = 27;
    pub const VALUE_MISSING: u32 = 28;
    pub const AXIS_NO_MOTION: u32 = 31;
    pub const INVALID_TARGET: u32 = 33;
    pub const UNUSED_WORDS: u32 = 36;
}

/// Most chords one arc may be cut into; a larger arc is refused with error
/// 33 rather than flooding the planner without end.
pub(crate) const MAX_ARC_SEGMENTS: usize = 100_000;

/// Parser state that persists between lines (GRBL's `gc_state`).
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Modal {
    /// 0, 1, 2, 3, or `None` after G80.
    pub motion: Option<u8>,
    /// G91.
    pub relative: bool,
    /// G20.
    pub inches: bool,
    /// Feed rate in mm/min, once set.
    pub feed: Option<f64>,
    /// M3/M4 on.
    pub spindle_on: bool,
    /// S value.
    pub spindle_s: f64,
    /// T value.
    pub tool: u32,
    /// Programmed position (machine mm) at the end of the parsed lines.
    pub pos: [f64; 3],
}

impl Default for Modal {
    fn default() -> Self {
        Modal { motion: Some(0), relative: false, inches: false, feed: None, spindle_on: false, spindle_s: 0.0, tool: 0, pos: [0.0; 3] }
    }
}

/// What a line asks the machine to do, in order.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Planned {
    /// Spindle (pen servo) state changes; GRBL syncs the planner first.
    Spindle { on: bool, s: f64 },
    /// G4: wait for the planner to empty, then pause this long (seconds).
    Dwell(f64),
    /// A straight move to `to` (machine mm) at `feed` mm/min, or rapid.
    Move { to: [f64; 3], rapid: bool, feed: f64 },
    /// M0: a program pause once the planner empties, until cycle start `~`.
    Pause,
}

#[derive(Default)]
struct Words {
    g: Vec<u32>,
    m: Vec<u32>,
    vals: [Option<f64>; 26],
}

fn read_number(line: &[u8], i: &mut usize) -> Option<f64> {
    let start = *i;
    if *i < line.len() && (line[*i] == b'-' || line[*i] == b'+') {
        *i += 1;
    }
    let (mut digits, mut dot) = (0, false);
    while *i < line.len() {
        match line[*i] {
            b'0'..=b'9' => digits += 1,
            b'.' if !dot => dot = true,
            _ => break,
        }
        *i += 1;
    }
    if digits == 0 {
        return None;
    }
    std::str::from_utf8(&line[start..*i]).ok()?.parse().ok()
}

fn split_words(line: &[u8]) -> Result<Words, u32> {
    let mut w = Words::default();
    let mut i = 0;
    while i < line.len() {
        let letter = line[i];
        if !letter.is_ascii_uppercase() {
            return Err(err::EXPECTED_LETTER);
        }
        i += 1;
        let v = read_number(line, &mut i).ok_or(err::BAD_NUMBER)?;
        match letter {
            b'G' | b'M' => {
                // G38.2 and friends are not for plotters; only whole codes.
                if v.fract() != 0.0 || !(0.0..=1000.0).contains(&v) {
                    return Err(err::UNSUPPORTED);
                }
                let list = if letter == b'G' { &mut w.g } else { &mut w.m };
                list.push(v as u32);
            }
            b'F' | b'I' | b'J' | b'K' | b'L' | b'N' | b'P' | b'R' | b'S' | b'T' | b'X' | b'Y' | b'Z' => {
                let slot = &mut w.vals[usize::from(letter - b'A')];
                if slot.is_some() {
                    return Err(err::REPEATED_WORD);
                }
                if matches!(letter, b'F' | b'N' | b'P' | b'S' | b'T') && v < 0.0 {
                    return Err(err::NEGATIVE);
                }
                *slot = Some(v);
            }
            _ => return Err(err::UNSUPPORTED),
        }
    }
    Ok(w)
}

fn group_of_g(g: u32) -> Option<u8> {
    Some(match g {
        0..=3 | 80 => 1,
        4 => 0,
        17 => 2,
        20 | 21 => 6,
        90 | 91 => 3,
        94 => 5,
        54 => 12,
        _ => return None,
    })
}

fn group_of_m(m: u32) -> Option<u8> {
    Some(match m {
        0 | 1 | 2 | 30 => 4,
        3..=5 => 7,
        7..=9 => 8,
        _ => return None,
    })
}

/// Parses one (already cleaned, upper-case) line and updates `modal`.
/// `arc_tolerance` is `$12` in mm. The modal state is only changed when the
/// line is accepted, as GRBL does.
pub(crate) fn parse_line(line: &[u8], modal: &mut Modal, arc_tolerance: f64) -> Result<Vec<Planned>, u32> {
    let w = split_words(line)?;
    let mut seen = [false; 16];
    for g in &w.g {
        let grp = group_of_g(*g).ok_or(err::UNSUPPORTED)?;
        if std::mem::replace(&mut seen[usize::from(grp)], true) {
            return Err(err::MODAL_GROUP);
        }
    }
    for m in &w.m {
        let grp = group_of_m(*m).ok_or(err::UNSUPPORTED)?;
        if std::mem::replace(&mut seen[usize::from(grp)], true) {
            return Err(err::MODAL_GROUP);
        }
    }
    let val = |c: u8| w.vals[usize::from(c - b'A')];
    let mut next = modal.clone();
    let mut out = Vec::new();

    if w.g.contains(&20) {
        next.inches = true;
    }
    if w.g.contains(&21) {
        next.inches = false;
    }
    let unit = if next.inches { 25.4 } else { 1.0 };
    if let Some(f) = val(b'F') {
        next.feed = Some(f * unit);
    }
    if let Some(t) = val(b'T') {
        next.tool = t as u32;
    }
    let old_spindle = (next.spindle_on, next.spindle_s);
    if let Some(s) = val(b'S') {
        next.spindle_s = s;
    }
    for m in &w.m {
        match m {
            3 | 4 => next.spindle_on = true,
            5 | 2 | 30 => next.spindle_on = false,
            _ => {}
        }
    }
    if (next.spindle_on, next.spindle_s) != old_spindle {
        out.push(Planned::Spindle { on: next.spindle_on, s: next.spindle_s });
    }
    if w.g.contains(&4) {
        let p = val(b'P').ok_or(err::VALUE_MISSING)?;
        out.push(Planned::Dwell(p));
    }
    if w.g.contains(&90) {
        next.relative = false;
    }
    if w.g.contains(&91) {
        next.relative = true;
    }
    if let Some(&g) = w.g.iter().find(|g| matches!(g, 0..=3 | 80)) {
        next.motion = (g != 80).then_some(g as u8);
    }

    let axes = [val(b'X'), val(b'Y'), val(b'Z')];
    let has_axes = axes.iter().any(Option::is_some);
    let arc_words = val(b'I').is_some() || val(b'J').is_some() || val(b'R').is_some();
    let motion_here = w.g.iter().any(|g| matches!(g, 0..=3));
    let mut used_arc = false;
    if has_axes || motion_here {
        let Some(motion) = next.motion else { return Err(err::AXIS_NO_MOTION) };
        let mut to = next.pos;
        for (k, a) in axes.iter().enumerate() {
            if let Some(v) = a {
                to[k] = if next.relative { to[k] + v * unit } else { v * unit };
            }
        }
        let feed = match motion {
            0 => 0.0,
            _ => next.feed.ok_or(err::UNDEFINED_FEED)?,
        };
        match motion {
            0 | 1 => out.push(Planned::Move { to, rapid: motion == 0, feed }),
            _ => {
                used_arc = true;
                let offsets = [val(b'I').map(|v| v * unit), val(b'J').map(|v| v * unit)];
                let centre = arc_centre(next.pos, to, offsets, val(b'R').map(|r| r * unit), motion == 2)?;
                for p in arc_points(next.pos, to, centre, motion == 2, arc_tolerance)? {
                    out.push(Planned::Move { to: p, rapid: false, feed });
                }
            }
        }
        next.pos = to;
    }
    if (arc_words && !used_arc) || val(b'K').is_some() || (val(b'P').is_some() && !w.g.contains(&4)) {
        return Err(err::UNUSED_WORDS);
    }
    // Program flow comes last in a block; GRBL ignores M1 (no optional stop
    // switch) and ends a program on M2/M30 without pausing.
    if w.m.contains(&0) {
        out.push(Planned::Pause);
    }
    *modal = next;
    Ok(out)
}

/// Arc centre from I/J offsets or radius R (GRBL's `gc_execute_block` maths).
fn arc_centre(from: [f64; 3], to: [f64; 3], ij: [Option<f64>; 2], r: Option<f64>, clockwise: bool) -> Result<[f64; 2], u32> {
    let (dx, dy) = (to[0] - from[0], to[1] - from[1]);
    if let Some(r) = r {
        let d2 = dx * dx + dy * dy;
        if d2 == 0.0 {
            return Err(err::INVALID_TARGET);
        }
        let h2 = 4.0 * r * r - d2;
        if h2 < 0.0 {
            return Err(err::INVALID_TARGET);
        }
        let mut h = -h2.sqrt() / d2.sqrt();
        if !clockwise {
            h = -h;
        }
        // A negative radius asks for the long way round.
        if r < 0.0 {
            h = -h;
        }
        return Ok([from[0] + 0.5 * (dx - dy * h), from[1] + 0.5 * (dy + dx * h)]);
    }
    if ij[0].is_none() && ij[1].is_none() {
        return Err(err::NO_OFFSETS);
    }
    let c = [from[0] + ij[0].unwrap_or(0.0), from[1] + ij[1].unwrap_or(0.0)];
    let r0 = (from[0] - c[0]).hypot(from[1] - c[1]);
    let r1 = (to[0] - c[0]).hypot(to[1] - c[1]);
    let delta = (r1 - r0).abs();
    if delta > 0.005 && delta > 0.001 * r0 {
        return Err(err::INVALID_TARGET);
    }
    Ok(c)
}

/// Chord end points of an arc in the XY plane (Z interpolated), as `mc_arc`
/// cuts it: chord count from the tolerance, the last point exactly `to`.
fn arc_points(from: [f64; 3], to: [f64; 3], c: [f64; 2], clockwise: bool, tol: f64) -> Result<Vec<[f64; 3]>, u32> {
    let r = (from[0] - c[0]).hypot(from[1] - c[1]);
    let a0 = (from[1] - c[1]).atan2(from[0] - c[0]);
    let a1 = (to[1] - c[1]).atan2(to[0] - c[0]);
    let mut sweep = a1 - a0;
    let tau = std::f64::consts::TAU;
    if clockwise {
        if sweep >= -1e-9 {
            sweep -= tau;
        }
    } else if sweep <= 1e-9 {
        sweep += tau;
    }
    let tol = tol.max(1e-6);
    let chord = (tol * (2.0 * r - tol)).max(0.0).sqrt();
    let n = if chord > 0.0 { (0.5 * sweep.abs() * r / chord).floor() as usize } else { 1 }.max(1);
    if n > MAX_ARC_SEGMENTS {
        return Err(err::INVALID_TARGET);
    }
    let mut pts = Vec::with_capacity(n);
    for k in 1..n {
        let t = k as f64 / n as f64;
        let a = a0 + sweep * t;
        pts.push([c[0] + r * a.cos(), c[1] + r * a.sin(), from[2] + (to[2] - from[2]) * t]);
    }
    pts.push(to);
    Ok(pts)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(lines: &[&str]) -> (Modal, Vec<Result<Vec<Planned>, u32>>) {
        let mut m = Modal::default();
        let res = lines.iter().map(|l| parse_line(l.as_bytes(), &mut m, 0.002)).collect();
        (m, res)
    }

    #[test]
    fn moves_units_and_distance_modes() {
        let (m, r) = run(&["G21G90G1X10Y5F600", "G91X1Y1", "G20G90X1"]);
        assert_eq!(r[0], Ok(vec![Planned::Move { to: [10.0, 5.0, 0.0], rapid: false, feed: 600.0 }]));
        assert_eq!(r[1], Ok(vec![Planned::Move { to: [11.0, 6.0, 0.0], rapid: false, feed: 600.0 }]));
        assert_eq!(m.pos, [25.4, 6.0, 0.0]);
    }

    #[test]
    fn error_numbers() {
        let (_, r) = run(&["X", "1X2", "G1X1", "G0G1X1", "X1X2", "G38", "Q1", "G2X1F100", "G80X1", "G0I1X1", "F-1", "G4"]);
        let codes: Vec<u32> = r.into_iter().map(|x| x.unwrap_err()).collect();
        assert_eq!(codes, vec![2, 1, 22, 21, 25, 20, 20, 27, 31, 36, 4, 28]);
    }

    #[test]
    fn rejected_lines_leave_the_modal_state_alone() {
        let (m, r) = run(&["G1X5F100", "G91G1X1X2"]);
        assert!(r[1].is_err());
        assert!(!m.relative);
        assert_eq!(m.pos, [5.0, 0.0, 0.0]);
    }

    #[test]
    fn spindle_changes_are_planned_once() {
        let (m, r) = run(&["M3S1000", "S1000", "M5"]);
        assert_eq!(r[0], Ok(vec![Planned::Spindle { on: true, s: 1000.0 }]));
        assert_eq!(r[1], Ok(vec![]));
        assert_eq!(r[2], Ok(vec![Planned::Spindle { on: false, s: 1000.0 }]));
        assert!(!m.spindle_on);
    }

    #[test]
    fn arcs_are_chords_on_the_circle_ending_at_the_target() {
        let (_, r) = run(&["G0X10Y0", "G3X0Y10I-10J0F100"]);
        let pts = r[1].clone().unwrap();
        assert!(pts.len() > 10);
        for p in &pts {
            let Planned::Move { to, .. } = p else { panic!() };
            assert!((to[0].hypot(to[1]) - 10.0).abs() < 1e-9);
            assert!(to[0] >= -1e-9 && to[1] >= -1e-9, "counter-clockwise stays in the first quadrant");
        }
        assert_eq!(pts.last(), Some(&Planned::Move { to: [0.0, 10.0, 0.0], rapid: false, feed: 100.0 }));
        // Same arc by radius; a radius too small for the chord is an invalid target.
        let (_, r) = run(&["G0X10Y0", "G3X0Y10R10F100", "G2X0Y-10R1"]);
        assert_eq!(r[1].as_ref().unwrap().last(), pts.last());
        assert_eq!(r[2], Err(33));
        // Offsets that put start and end on different circles are refused.
        let (_, r) = run(&["G0X10Y0", "G2X0Y5I-10J0F100"]);
        assert_eq!(r[1], Err(33));
    }
}
