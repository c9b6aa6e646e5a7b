//! The HP-GL interpreter: instructions in, pen strokes out.
//!
//! It follows a plotter's state: selected pen, pen up or down, absolute or
//! relative mode, the current position, and user-unit scaling (`IP` / `SC`).
//! Understood: `IN DF SP PU PD PA PR IP SC`; accepted without effect on the
//! strokes: `VS LT` (speed, line type) and escape sequences. Any other
//! instruction (labels, arcs, fills, output requests) is skipped with a
//! [`Warning`] naming it and its byte offset.

use super::lexer::{Instruction, LexError, Lexer, Token};
use crate::plot::{Location, Plot, Stroke, Warning};
use strokes::DVec2;

/// The default scaling points when a file scales without `IP`: those of an HP
/// 7475A on A4 (Operation Manual, "Default coordinate values for P1 and P2").
const DEFAULT_P1: DVec2 = DVec2::new(603.0, 521.0);
const DEFAULT_P2: DVec2 = DVec2::new(10603.0, 7721.0);

/// Largest magnitude of a plot coordinate HP-GL devices accept (the 16-bit
/// range of the 7475A and its relatives, with room for HP-GL/2's wider one).
const MAX_COORDINATE: f64 = 1.0e7;

/// Why an HP-GL file cannot be read.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum HpglError {
    /// A syntax error.
    #[error(transparent)]
    Lex(#[from] LexError),
    /// A well-formed instruction with unusable parameters.
    #[error("HP-GL error at byte {offset}: {mnemonic}: {problem}")]
    Instruction {
        /// Byte offset of the instruction.
        offset: u64,
        /// Its mnemonic.
        mnemonic: String,
        /// What is wrong.
        problem: String,
    },
}

/// Executes HP-GL tokens one at a time; [`Interpreter::finish`] returns the strokes.
#[derive(Clone, Debug)]
pub struct Interpreter {
    pen: u32,
    down: bool,
    relative: bool,
    /// Current position in plotter units.
    at: DVec2,
    p1: DVec2,
    p2: DVec2,
    /// User-unit window `(xmin, xmax, ymin, ymax)` when `SC` is on.
    scale: Option<[f64; 4]>,
    current: Option<Stroke>,
    plot: Plot,
}

impl Default for Interpreter {
    fn default() -> Self {
        Interpreter::new()
    }
}

impl Interpreter {
    /// A plotter just switched on: pen 0 (none), pen up, absolute, at (0, 0).
    #[must_use]
    pub fn new() -> Self {
        Interpreter {
            pen: 0,
            down: false,
            relative: false,
            at: DVec2::ZERO,
            p1: DEFAULT_P1,
            p2: DEFAULT_P2,
            scale: None,
            current: None,
            plot: Plot::default(),
        }
    }

    /// Sets the scaling points `IN` and `IP;` return to (a device's default P1/P2).
    #[must_use]
    pub fn with_default_scaling_points(mut self, p1: DVec2, p2: DVec2) -> Self {
        self.p1 = p1;
        self.p2 = p2;
        self
    }

    /// The current pen position in plotter units.
    #[must_use]
    pub fn position(&self) -> DVec2 {
        self.at
    }

    /// The selected pen (0: none) and whether it is down.
    #[must_use]
    pub fn pen(&self) -> (u32, bool) {
        (self.pen, self.down)
    }

    /// Strokes completed so far (the one being drawn is not included).
    #[must_use]
    pub fn strokes(&self) -> &[Stroke] {
        &self.plot.strokes
    }

    /// Executes one token.
    ///
    /// # Errors
    /// [`HpglError::Instruction`] for unusable parameters (odd coordinate
    /// counts, wrong parameter counts, out-of-range values); the instruction
    /// is then ignored, as a plotter does, and the state is unchanged.
    pub fn execute(&mut self, token: &Token) -> Result<(), HpglError> {
        let Token::Instruction(i) = token else {
            // Device-control and mode-switch escapes do not draw.
            return Ok(());
        };
        let bad = |problem: String| HpglError::Instruction { offset: i.offset, mnemonic: i.name().to_owned(), problem };
        if let Some(v) = i.params.iter().find(|v| v.abs() > MAX_COORDINATE) {
            return Err(bad(format!("parameter {v} is out of range")));
        }
        match &i.mnemonic {
            b"IN" => {
                self.end_stroke();
                self.down = false;
                self.relative = false;
                self.scale = None;
                self.reset_scaling_points();
            }
            b"DF" => {
                self.relative = false;
                self.scale = None;
            }
            b"SP" => {
                let pen = match i.params.first() {
                    None => 0,
                    Some(&v) if (0.0..=255.0).contains(&v) => v as u32,
                    Some(v) => return Err(bad(format!("pen number {v} is out of range 0..255"))),
                };
                self.end_stroke();
                self.pen = pen;
            }
            b"PU" => {
                let pts = pairs(i).map_err(bad)?;
                self.end_stroke();
                self.down = false;
                self.move_through(&pts);
            }
            b"PD" => {
                let pts = pairs(i).map_err(bad)?;
                self.down = true;
                if pts.is_empty() {
                    // Lowering the pen in place marks a dot.
                    self.current.get_or_insert_with(|| Stroke { pen: self.pen, points: vec![self.at] });
                }
                self.move_through(&pts);
            }
            b"PA" | b"PR" => {
                let pts = pairs(i).map_err(bad)?;
                self.relative = i.is("PR");
                self.move_through(&pts);
            }
            b"IP" => match i.params.len() {
                0 => self.reset_scaling_points(),
                2 | 4 => {
                    let p1 = DVec2::new(i.params[0], i.params[1]);
                    self.p2 += p1 - self.p1;
                    self.p1 = p1;
                    if i.params.len() == 4 {
                        self.p2 = DVec2::new(i.params[2], i.params[3]);
                    }
                }
                n => return Err(bad(format!("takes 0, 2 or 4 parameters, got {n}"))),
            },
            b"SC" => match i.params.len() {
                0 => self.scale = None,
                4 => {
                    let s = [i.params[0], i.params[1], i.params[2], i.params[3]];
                    // Equal minimum and maximum turn scaling off (7470A/7475A manuals).
                    self.scale = if s[0] == s[1] || s[2] == s[3] { None } else { Some(s) };
                }
                n => return Err(bad(format!("takes 0 or 4 parameters, got {n}"))),
            },
            // Speed, line type and the label terminator change nothing in the
            // geometry (DT's terminator is the lexer's business).
            b"VS" | b"LT" | b"DT" => {}
            _ => {
                let what = match &i.mnemonic {
                    b"LB" => "label text is not drawn".to_owned(),
                    _ => "instruction not supported".to_owned(),
                };
                self.plot.warnings.push(Warning { at: Location::Byte(i.offset), message: format!("skipped {}: {what}", i.name()) });
            }
        }
        Ok(())
    }

    /// Ends the stroke in progress and returns everything drawn.
    #[must_use]
    pub fn finish(mut self) -> Plot {
        self.end_stroke();
        self.plot
    }

    fn reset_scaling_points(&mut self) {
        self.p1 = DEFAULT_P1;
        self.p2 = DEFAULT_P2;
    }

    /// A user-unit (or plotter-unit, when not scaling) point to plotter units.
    fn to_plotter(&self, v: DVec2) -> DVec2 {
        match self.scale {
            None => v,
            Some([x0, x1, y0, y1]) => DVec2::new(
                self.p1.x + (v.x - x0) * (self.p2.x - self.p1.x) / (x1 - x0),
                self.p1.y + (v.y - y0) * (self.p2.y - self.p1.y) / (y1 - y0),
            ),
        }
    }

    fn move_through(&mut self, pts: &[DVec2]) {
        for &p in pts {
            let target = if self.relative {
                // Relative moves are in the current units; scale the offset only.
                self.at + (self.to_plotter(p) - self.to_plotter(DVec2::ZERO))
            } else {
                self.to_plotter(p)
            };
            if self.down {
                let start = self.at;
                let pen = self.pen;
                self.current.get_or_insert_with(|| Stroke { pen, points: vec![start] }).points.push(target);
            }
            self.at = target;
        }
    }

    fn end_stroke(&mut self) {
        if let Some(s) = self.current.take() {
            self.plot.strokes.push(s);
        }
    }
}

/// The parameters of a plot instruction as points.
fn pairs(i: &Instruction) -> Result<Vec<DVec2>, String> {
    if i.params.len() % 2 != 0 {
        return Err(format!("{} parameters; coordinates come in x,y pairs", i.params.len()));
    }
    Ok(i.params.chunks(2).map(|c| DVec2::new(c[0], c[1])).collect())
}

/// Reads a whole HP-GL file into strokes per pen, in plotter units.
///
/// # Errors
/// The first syntax error or unusable instruction, with its byte offset.
pub fn parse(bytes: &[u8]) -> Result<Plot, HpglError> {
    let mut lexer = Lexer::new();
    lexer.feed(bytes);
    lexer.end();
    let mut interp = Interpreter::new();
    while let Some(t) = lexer.next_token()? {
        interp.execute(&t)?;
    }
    Ok(interp.finish())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn strokes(input: &str) -> Vec<(u32, Vec<(f64, f64)>)> {
        parse(input.as_bytes())
            .unwrap_or_else(|e| panic!("{input:?}: {e}"))
            .strokes
            .into_iter()
            .map(|s| (s.pen, s.points.iter().map(|p| (p.x, p.y)).collect()))
            .collect()
    }

    #[test]
    fn absolute_relative_and_pens() {
        assert_eq!(
            strokes("IN;SP1;PU10,10;PD20,10,20,20;PU;SP2;PR;PU5,5;PD0,10,-5,0;PU;SP0;"),
            vec![(1, vec![(10.0, 10.0), (20.0, 10.0), (20.0, 20.0)]), (2, vec![(25.0, 25.0), (25.0, 35.0), (20.0, 35.0)]),]
        );
        // PA/PR with the pen down keep drawing; SP ends a stroke.
        assert_eq!(
            strokes("SP1 PA 0 0 PD PA 10 0 PR 0 10 SP2 PR 1 1"),
            vec![(1, vec![(0.0, 0.0), (10.0, 0.0), (10.0, 10.0)]), (2, vec![(10.0, 10.0), (11.0, 11.0)])]
        );
    }

    #[test]
    fn dot_and_pen_zero() {
        assert_eq!(strokes("PU5,5;PD;PU;"), vec![(0, vec![(5.0, 5.0)])]);
    }

    #[test]
    fn scaling_with_ip_sc() {
        // P1/P2 = (1000,1000)-(2000,3000); user window 0..10 x 0..10.
        assert_eq!(
            strokes("IN;IP1000,1000,2000,3000;SC0,10,0,10;SP1;PU0,0;PD10,10;PR;PD-5,0;SC;PA;PD0,0;"),
            vec![(1, vec![(1000.0, 1000.0), (2000.0, 3000.0), (1500.0, 3000.0), (0.0, 0.0)])]
        );
    }

    #[test]
    fn unknown_instructions_are_warnings() {
        let plot = parse(b"IN;SP1;LBHello\x03CI100;PU0,0;PD1,1;").unwrap();
        assert_eq!(plot.strokes.len(), 1);
        let w: Vec<String> = plot.warnings.iter().map(ToString::to_string).collect();
        assert_eq!(w, vec!["byte 7: skipped LB: label text is not drawn", "byte 15: skipped CI: instruction not supported"]);
    }

    #[test]
    fn label_terminator_is_understood_not_warned() {
        // DT changes how LB text ends; the label is skipped (one warning) and
        // the drawing after it is read as usual.
        let plot = parse(b"IN;DT*;LBabc*PU0,0;PD5,5;").unwrap();
        assert_eq!(plot.strokes.len(), 1);
        let w: Vec<String> = plot.warnings.iter().map(ToString::to_string).collect();
        assert_eq!(w, vec!["byte 7: skipped LB: label text is not drawn"]);
    }

    #[test]
    fn bad_instructions_name_offset() {
        let cases: &[(&str, &str)] = &[
            ("IN;PD1,2,3;", "byte 3: PD: 3 parameters"),
            ("IN;SP-1;", "byte 3: SP: pen number -1"),
            ("IN;SC0,1,2;", "byte 3: SC: takes 0 or 4"),
            ("PA99999999999,0;", "byte 0: PA: parameter"),
            ("IN;PA1,%;", "byte 7"),
        ];
        for (input, msg) in cases {
            let e = parse(input.as_bytes()).unwrap_err().to_string();
            assert!(e.contains(msg), "{input:?}: {e}");
        }
    }
}
