//! The 7475A's reading of its input buffer: two-letter mnemonics, numeric
//! parameters separated by commas or spaces, ended by `;` or by the next
//! mnemonic.
//!
//! This is the device's side of HP-GL, byte by byte, and it reports events
//! rather than whole instructions so that `PD x,y,x,y,...` draws each pair as
//! it is read, as the real plotter does: a long coordinate list never has to
//! fit the buffer at once. (The host-side `plotcode::hpgl` parser reads whole
//! files; the device needs this streaming form and its error numbers.)
//! Reference: HP 7475A Interfacing and Programming Manual, ch. "HP-GL
//! instruction syntax" (mnemonic, parameters, separators, terminators).

/// One step of the parse.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Event {
    /// A mnemonic was read (upper-cased).
    Begin([u8; 2]),
    /// A complete numeric parameter.
    Param(f64),
    /// A parameter that is not a number.
    BadParam,
    /// The instruction ended.
    End,
    /// A byte that cannot start an instruction (HP-GL error 1).
    Stray,
}

/// Longest numeric parameter accepted; longer ones are malformed.
const MAX_NUMBER_LEN: usize = 24;

#[derive(Clone, Debug, Default, PartialEq)]
enum State {
    #[default]
    Idle,
    /// First mnemonic letter read.
    Mnemonic(u8),
    /// Reading parameters; the current number's text so far.
    Args(String),
    /// Inside `LB` text, up to the label terminator.
    Label,
    /// After `DT` or `SM`: their single-character parameter (`;` for none).
    OneChar([u8; 2]),
}

/// The label terminator at power-on and after `DT;`.
const ETX: u8 = 3;

/// Byte-at-a-time HP-GL reader.
#[derive(Clone, Debug)]
pub(crate) struct Parser {
    state: State,
    /// Ends `LB` text; `DT` changes it.
    label_terminator: u8,
    /// A bare `;`, CR or LF where an instruction should begin is a stray
    /// byte ([`crate::Quirk::StrictSeparators`]); the 7475A skips them.
    strict_separators: bool,
}

impl Default for Parser {
    fn default() -> Self {
        Parser::new(false)
    }
}

impl Parser {
    /// A reader at power-on; `strict_separators` as on strict clones.
    pub fn new(strict_separators: bool) -> Self {
        Parser { state: State::Idle, label_terminator: ETX, strict_separators }
    }

    /// Forgets a half-read instruction (`ESC.K`, power-cycle).
    pub fn reset(&mut self) {
        self.state = State::Idle;
    }

    /// Back to the power-on label terminator (`IN`, power-cycle).
    pub fn reset_label_terminator(&mut self) {
        self.label_terminator = ETX;
    }

    /// True between instructions.
    pub fn is_idle(&self) -> bool {
        self.state == State::Idle
    }

    /// Reads one byte; pushes what it completes onto `events`.
    pub fn feed(&mut self, b: u8, events: &mut Vec<Event>) {
        match std::mem::take(&mut self.state) {
            State::Idle => {
                let strict_stray = self.strict_separators && matches!(b, b';' | b'\r' | b'\n');
                if b.is_ascii_alphabetic() {
                    self.state = State::Mnemonic(b.to_ascii_uppercase());
                } else if strict_stray || !(b == b';' || b == b',' || b.is_ascii_whitespace() || b.is_ascii_control()) {
                    events.push(Event::Stray);
                }
            }
            State::Mnemonic(a) => {
                if b.is_ascii_alphabetic() {
                    let mn = [a, b.to_ascii_uppercase()];
                    events.push(Event::Begin(mn));
                    self.state = match &mn {
                        b"LB" => State::Label,
                        b"DT" | b"SM" => State::OneChar(mn),
                        _ => State::Args(String::new()),
                    };
                } else {
                    events.push(Event::Stray);
                }
            }
            State::OneChar(mn) => {
                // The character itself is the parameter; `;` right away means none.
                if &mn == b"DT" {
                    self.label_terminator = if b == b';' { ETX } else { b };
                }
                events.push(Event::End);
            }
            State::Label => {
                if b == self.label_terminator {
                    events.push(Event::End);
                } else {
                    self.state = State::Label;
                }
            }
            State::Args(mut num) => match b {
                b'0'..=b'9' | b'.' => {
                    num.push(b as char);
                    self.state = State::Args(num);
                }
                b'+' | b'-' => {
                    // A sign starts a new number, so "10-5" reads as 10 and -5.
                    flush(&mut num, events);
                    num.push(b as char);
                    self.state = State::Args(num);
                }
                b';' => {
                    flush(&mut num, events);
                    events.push(Event::End);
                }
                _ if b.is_ascii_alphabetic() => {
                    flush(&mut num, events);
                    events.push(Event::End);
                    self.state = State::Mnemonic(b.to_ascii_uppercase());
                }
                // Commas, spaces, CR/LF and other bytes separate parameters.
                _ => {
                    flush(&mut num, events);
                    self.state = State::Args(num);
                }
            },
        }
    }
}

fn flush(num: &mut String, events: &mut Vec<Event>) {
    if num.is_empty() {
        return;
    }
    let ev = match num.parse::<f64>() {
        Ok(v) if num.len() <= MAX_NUMBER_LEN && v.is_finite() => Event::Param(v),
        _ => Event::BadParam,
    };
    events.push(ev);
    num.clear();
}

#[cfg(test)]
mod tests {
    use super::*;
    use Event::*;

    fn parse(input: &str) -> Vec<Event> {
        let mut p = Parser::default();
        let mut ev = Vec::new();
        for b in input.bytes() {
            p.feed(b, &mut ev);
        }
        ev
    }

    #[test]
    fn instructions_parameters_and_terminators() {
        assert_eq!(parse("IN;PA10,-20.5 30;"), vec![Begin(*b"IN"), End, Begin(*b"PA"), Param(10.0), Param(-20.5), Param(30.0), End]);
    }

    #[test]
    fn next_mnemonic_ends_an_instruction_and_lowercase_is_read() {
        assert_eq!(parse("sp1pu"), vec![Begin(*b"SP"), Param(1.0), End, Begin(*b"PU")]);
    }

    #[test]
    fn signs_split_numbers_and_junk_is_flagged() {
        assert_eq!(parse("PR10-5;"), vec![Begin(*b"PR"), Param(10.0), Param(-5.0), End]);
        assert_eq!(parse("PA1..2;"), vec![Begin(*b"PA"), BadParam, End]);
        assert_eq!(parse("5;"), vec![Stray]);
        assert_eq!(parse("P1"), vec![Stray]);
    }

    #[test]
    fn label_text_runs_to_etx() {
        assert_eq!(parse("LBHI;PA\u{3}PU;"), vec![Begin(*b"LB"), End, Begin(*b"PU"), End]);
    }

    #[test]
    fn dt_changes_the_label_terminator_and_sm_takes_one_character() {
        assert_eq!(
            parse("DT#;LBa;b#PU;DT;LBx#\u{3}SMA;PA"),
            vec![
                Begin(*b"DT"),
                End,
                Begin(*b"LB"),
                End,
                Begin(*b"PU"),
                End,
                Begin(*b"DT"),
                End,
                Begin(*b"LB"),
                End,
                Begin(*b"SM"),
                End,
                Begin(*b"PA")
            ]
        );
    }

    #[test]
    fn strict_separators_flag_a_bare_semicolon_and_line_breaks_between_instructions() {
        let mut p = Parser::new(true);
        let mut ev = Vec::new();
        for b in b";PU;\r\nPA1\n2;" {
            p.feed(*b, &mut ev);
        }
        assert_eq!(ev, vec![Stray, Begin(*b"PU"), End, Stray, Stray, Begin(*b"PA"), Param(1.0), Param(2.0), End]);
    }

    #[test]
    fn incomplete_input_waits() {
        let mut p = Parser::default();
        let mut ev = Vec::new();
        for b in b"PA10,2" {
            p.feed(*b, &mut ev);
        }
        assert_eq!(ev, vec![Begin(*b"PA"), Param(10.0)]);
        assert!(!p.is_idle());
        p.feed(b'0', &mut ev);
        p.feed(b';', &mut ev);
        assert_eq!(ev[2..], [Param(20.0), End]);
        assert!(p.is_idle());
    }
}
