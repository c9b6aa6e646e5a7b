//! Incremental HP-GL lexer: bytes in, instructions out.
//!
//! The lexer owns no port and no file. A caller feeds it bytes as they arrive
//! ([`Lexer::feed`]) and pulls complete tokens ([`Lexer::next_token`]); when the
//! bytes so far end in the middle of an instruction the answer is `Ok(None)`,
//! which only means "feed me more". Once the input is over, [`Lexer::end`] lets
//! the last instruction finish without a terminator.
//!
//! Grammar (HP 7475A Interfacing and Programming Manual, ch. 2 "HP-GL syntax";
//! the same rules hold for the 7550A, 7585B and Roland DXY plotters):
//! - a mnemonic is two letters, either case;
//! - numeric parameters are separated by commas or spaces (a sign also starts a
//!   new number: `PA10-20` is 10, -20);
//! - an instruction ends at `;`, a newline, the next mnemonic, an ESC, or the end
//!   of input;
//! - `LB`, `BL` and `WD` take text up to the label terminator (ETX, 0x03, unless
//!   `DT` changed it); `DT` and `SM` take a single character; `PE` (HP-GL/2
//!   encoded polyline) takes raw bytes up to `;`;
//! - device-control sequences `ESC . X [p;p...:]`, `ESC % [n] X` and two-byte
//!   `ESC X` sequences (PCL reset `ESC E`) come out as [`Escape`] tokens.
//!
//! Carriage returns, spaces, separators and stray control bytes between
//! instructions are skipped.

use std::fmt;

/// The most bytes one instruction (mnemonic, parameters, label text) may take.
/// Real plotters hold 1 KiB to a few KiB of buffer in total; anything longer is
/// garbage or a runaway label, and the cap keeps memory bounded.
pub const MAX_INSTRUCTION_BYTES: usize = 64 * 1024;

/// The most characters one number may have (sign, digits, point); also the
/// most of a malformed number an error quotes.
pub const MAX_NUMBER_CHARS: usize = 32;

/// Label terminator at power-on and after `DT;`: ETX.
pub const DEFAULT_LABEL_TERMINATOR: u8 = 0x03;

const ESC: u8 = 0x1b;

/// Device-control letters (`ESC . X`) that take parameters up to a `:`
/// (7475A manual ch. 10 / 7550A manual ch. 15: `@` configuration, `H`/`I`/`N`
/// handshake modes, `M` output mode, `P` handshake select, `T` memory allocation).
const ESC_DOT_WITH_PARAMS: &[u8] = b"@HIMNPT";

/// One lexed item.
#[derive(Clone, Debug, PartialEq)]
pub enum Token {
    /// An HP-GL instruction.
    Instruction(Instruction),
    /// An escape (device-control or mode-switch) sequence.
    Escape(Escape),
}

/// An HP-GL instruction with its parameters, as written (no semantics applied).
#[derive(Clone, Debug, PartialEq)]
pub struct Instruction {
    /// Byte offset of the mnemonic's first letter in the whole stream.
    pub offset: u64,
    /// The mnemonic, upper-cased.
    pub mnemonic: [u8; 2],
    /// Numeric parameters in order (empty for text instructions).
    pub params: Vec<f64>,
    /// Text parameter of `LB`, `BL`, `WD` (without its terminator), `DT`, `SM`
    /// (the character; empty for the default) and `PE` (raw bytes).
    pub text: Option<Vec<u8>>,
}

impl Instruction {
    /// The mnemonic as a string, such as `"PD"`.
    #[must_use]
    pub fn name(&self) -> &str {
        // Both bytes are ASCII letters by construction.
        std::str::from_utf8(&self.mnemonic).unwrap_or("??")
    }

    /// Whether this is the instruction `name` (upper case, such as `"PU"`).
    #[must_use]
    pub fn is(&self, name: &str) -> bool {
        self.mnemonic == name.as_bytes()
    }
}

/// An escape sequence.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Escape {
    /// Byte offset of the ESC byte in the whole stream.
    pub offset: u64,
    /// What kind of sequence.
    pub kind: EscapeKind,
}

/// The escape sequences HP-GL devices understand.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum EscapeKind {
    /// `ESC . X [p1;p2;...:]`, an RS-232 device-control instruction such as
    /// `ESC.B` (output buffer space) or `ESC.@;512:` (configuration). Omitted
    /// parameters are `None`.
    Device {
        /// The letter or symbol after `ESC .`.
        command: u8,
        /// Parameters between the command and the `:`.
        params: Vec<Option<i64>>,
    },
    /// `ESC % [n] X`, a PCL / HP-GL/2 mode switch such as `ESC%-1B`.
    Mode {
        /// The signed number, if any.
        value: Option<i64>,
        /// The final letter.
        command: u8,
    },
    /// Any other two-byte `ESC X` sequence (such as PCL reset, `ESC E`).
    Other(u8),
}

/// What went wrong while lexing, and where.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("HP-GL syntax error at byte {offset}: {kind}")]
pub struct LexError {
    /// Byte offset of the offending byte in the whole stream.
    pub offset: u64,
    /// What is wrong.
    pub kind: LexErrorKind,
}

/// The kinds of [`LexError`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum LexErrorKind {
    /// A letter not followed by a second letter.
    BadMnemonic(u8),
    /// A byte that cannot start an instruction or be a parameter.
    UnexpectedByte {
        /// The byte.
        byte: u8,
        /// The instruction being read, if any.
        mnemonic: Option<[u8; 2]>,
    },
    /// A malformed number (such as `1.2.3` or a lone sign): its text, cut
    /// to [`MAX_NUMBER_CHARS`] characters and `...` when longer.
    BadNumber(String),
    /// An instruction longer than [`MAX_INSTRUCTION_BYTES`].
    TooLong([u8; 2]),
    /// The input ended inside an escape sequence, a mnemonic or a label.
    Truncated,
}

impl fmt::Display for LexErrorKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let name = |m: &[u8; 2]| String::from_utf8_lossy(m).into_owned();
        match self {
            LexErrorKind::BadMnemonic(b) => {
                write!(f, "letter {:?} is not followed by a second letter", *b as char)
            }
            LexErrorKind::UnexpectedByte { byte, mnemonic: Some(m) } => {
                write!(f, "unexpected byte 0x{byte:02x} ({}) in the parameters of {}", show(*byte), name(m))
            }
            LexErrorKind::UnexpectedByte { byte, mnemonic: None } => {
                write!(f, "unexpected byte 0x{byte:02x} ({}) where an instruction should start", show(*byte))
            }
            LexErrorKind::BadNumber(s) => write!(f, "malformed number {s:?}"),
            LexErrorKind::TooLong(m) => {
                write!(f, "instruction {} is longer than {MAX_INSTRUCTION_BYTES} bytes", name(m))
            }
            LexErrorKind::Truncated => write!(f, "input ends inside an instruction"),
        }
    }
}

fn show(b: u8) -> String {
    if b.is_ascii_graphic() {
        format!("{:?}", b as char)
    } else {
        "control".to_owned()
    }
}

/// The incremental lexer. See the module documentation.
#[derive(Clone, Debug)]
pub struct Lexer {
    /// Bytes fed; those before `start` are consumed. Consuming only moves
    /// `start`; the consumed front is dropped when it is at least half the
    /// buffer (see [`Lexer::feed`]), so the lexer's work stays linear in the
    /// input however many tokens one feed holds.
    buf: Vec<u8>,
    /// Index in `buf` of the first byte not yet consumed.
    start: usize,
    /// Stream offset of `buf[start]`.
    base: u64,
    /// Set by [`Lexer::end`]: the end of `buf` is the end of the input.
    ended: bool,
    /// Current label terminator (changed by `DT`).
    label_terminator: u8,
    /// Bytes moved inside `buf` so far: the lexer's housekeeping work, which
    /// must stay proportional to the input (tests check it).
    #[cfg(test)]
    moved: u64,
}

impl Default for Lexer {
    fn default() -> Self {
        Lexer::new()
    }
}

/// Result of trying to read one token at the front of the buffer.
enum Step {
    /// A token and the number of bytes it used.
    Token(Token, usize),
    /// Bytes to drop (whitespace, separators) before trying again.
    Skip(usize),
    /// Need more input.
    Incomplete,
    /// A syntax error; `skip` bytes are dropped so lexing can resume.
    Error(LexError, usize),
}

impl Lexer {
    /// A lexer at the start of a stream.
    #[must_use]
    pub fn new() -> Self {
        Lexer {
            buf: Vec::new(),
            start: 0,
            base: 0,
            ended: false,
            label_terminator: DEFAULT_LABEL_TERMINATOR,
            #[cfg(test)]
            moved: 0,
        }
    }

    /// Appends bytes that arrived.
    pub fn feed(&mut self, bytes: &[u8]) {
        if self.start > 0 && self.start >= self.buf.len() / 2 {
            #[cfg(test)]
            {
                self.moved += (self.buf.len() - self.start) as u64;
            }
            self.buf.drain(..self.start);
            self.start = 0;
        }
        self.buf.extend_from_slice(bytes);
    }

    /// The bytes fed and not yet consumed.
    fn rest(&self) -> &[u8] {
        &self.buf[self.start..]
    }

    /// Marks the end of the input: a final instruction without a terminator is
    /// complete now.
    pub fn end(&mut self) {
        self.ended = true;
    }

    /// Stream offset of the first byte not yet consumed.
    #[must_use]
    pub fn offset(&self) -> u64 {
        self.base
    }

    /// Bytes fed but not yet part of a returned token.
    #[must_use]
    pub fn pending(&self) -> usize {
        self.rest().len()
    }

    /// The next complete token, `Ok(None)` if the bytes so far do not complete
    /// one (feed more, or call [`Lexer::end`]).
    ///
    /// # Errors
    /// A [`LexError`] for malformed input. The offending bytes are consumed, so
    /// calling again resumes after them, as a plotter does after flagging an error.
    pub fn next_token(&mut self) -> Result<Option<Token>, LexError> {
        loop {
            match self.step() {
                Step::Skip(n) => self.consume(n),
                Step::Token(t, n) => {
                    self.consume(n);
                    if let Token::Instruction(i) = &t {
                        if i.is("DT") {
                            self.label_terminator = match i.text.as_deref() {
                                Some([c]) => *c,
                                _ => DEFAULT_LABEL_TERMINATOR,
                            };
                        }
                    }
                    return Ok(Some(t));
                }
                Step::Incomplete => return Ok(None),
                Step::Error(e, n) => {
                    self.consume(n.max(1).min(self.pending()));
                    return Err(e);
                }
            }
        }
    }

    fn consume(&mut self, n: usize) {
        self.start += n;
        self.base += n as u64;
    }

    fn err(&self, at: usize, kind: LexErrorKind, skip: usize) -> Step {
        Step::Error(LexError { offset: self.base + at as u64, kind }, skip)
    }

    fn step(&self) -> Step {
        let b = self.rest();
        let Some(&c) = b.first() else {
            return Step::Incomplete;
        };
        match c {
            ESC => self.escape(),
            c if c.is_ascii_alphabetic() => self.instruction(),
            // Separators and terminators between instructions, whitespace, and
            // stray control bytes (NUL padding, XON/XOFF echoes) are ignored.
            b';' | b',' | b' ' | b'\t' | b'\r' | b'\n' => Step::Skip(1),
            c if c < 0x20 || c == 0x7f => Step::Skip(1),
            _ => self.err(0, LexErrorKind::UnexpectedByte { byte: c, mnemonic: None }, 1),
        }
    }

    /// Reads the sequence starting with the ESC at `buf[0]`.
    fn escape(&self) -> Step {
        let b = self.rest();
        let Some(&second) = b.get(1) else {
            return self.need_more(0);
        };
        let kind;
        let used;
        match second {
            b'.' => {
                let Some(&cmd) = b.get(2) else {
                    return self.need_more(0);
                };
                if ESC_DOT_WITH_PARAMS.contains(&cmd.to_ascii_uppercase()) {
                    // Parameters are digits and signs separated by `;`, ended by `:`.
                    let mut i = 3;
                    loop {
                        match b.get(i) {
                            None if self.ended => break,
                            None => return self.need_more(0),
                            Some(c) if c.is_ascii_digit() || b"+-; ".contains(c) => i += 1,
                            Some(b':') => {
                                i += 1;
                                break;
                            }
                            // Colon left out: the sequence ends here.
                            Some(_) => break,
                        }
                        if i > 64 {
                            return self.err(0, LexErrorKind::UnexpectedByte { byte: b[i - 1], mnemonic: None }, i);
                        }
                    }
                    let body = &b[3..i];
                    let body = body.strip_suffix(b":").unwrap_or(body);
                    let mut params = Vec::new();
                    if !body.is_empty() {
                        for p in body.split(|&c| c == b';') {
                            let s = String::from_utf8_lossy(p);
                            let s = s.trim();
                            if s.is_empty() {
                                params.push(None);
                            } else {
                                match s.parse::<i64>() {
                                    Ok(v) => params.push(Some(v)),
                                    Err(_) => return self.err(3, bad_number(s.as_bytes()), i),
                                }
                            }
                        }
                    }
                    kind = EscapeKind::Device { command: cmd, params };
                    used = i;
                } else {
                    kind = EscapeKind::Device { command: cmd, params: Vec::new() };
                    used = 3;
                }
            }
            b'%' => {
                let mut i = 2;
                while let Some(c) = b.get(i) {
                    if c.is_ascii_digit() || (i == 2 && (*c == b'-' || *c == b'+')) {
                        i += 1;
                        if i > 20 {
                            return self.err(0, bad_number(&b[2..i]), i);
                        }
                    } else {
                        break;
                    }
                }
                let Some(&cmd) = b.get(i) else {
                    return self.need_more(0);
                };
                if !cmd.is_ascii_alphabetic() {
                    return self.err(i, LexErrorKind::UnexpectedByte { byte: cmd, mnemonic: None }, i);
                }
                let digits = String::from_utf8_lossy(&b[2..i]);
                let value = if digits.is_empty() { None } else { digits.parse::<i64>().ok() };
                kind = EscapeKind::Mode { value, command: cmd };
                used = i + 1;
            }
            other => {
                kind = EscapeKind::Other(other);
                used = 2;
            }
        }
        Step::Token(Token::Escape(Escape { offset: self.base, kind }), used)
    }

    /// Incomplete, or truncated at the end of the input.
    fn need_more(&self, at: usize) -> Step {
        if self.ended {
            self.err(at, LexErrorKind::Truncated, self.pending())
        } else if self.pending() > MAX_INSTRUCTION_BYTES {
            let b = self.rest();
            let m = [b[0], *b.get(1).unwrap_or(&b'?')];
            self.err(at, LexErrorKind::TooLong(m), b.len())
        } else {
            Step::Incomplete
        }
    }

    /// Reads the instruction whose mnemonic starts at `buf[0]`.
    fn instruction(&self) -> Step {
        let b = self.rest();
        let Some(&second) = b.get(1) else {
            return self.need_more(0);
        };
        if !second.is_ascii_alphabetic() {
            return self.err(0, LexErrorKind::BadMnemonic(b[0]), 1);
        }
        let mnemonic = [b[0].to_ascii_uppercase(), second.to_ascii_uppercase()];
        let make = |params, text| Token::Instruction(Instruction { offset: self.base, mnemonic, params, text });
        match &mnemonic {
            b"LB" | b"BL" | b"WD" => {
                let term = self.label_terminator;
                match b[2..].iter().position(|&c| c == term) {
                    Some(n) if n > MAX_INSTRUCTION_BYTES => self.err(0, LexErrorKind::TooLong(mnemonic), n + 3),
                    Some(n) => Step::Token(make(Vec::new(), Some(b[2..2 + n].to_vec())), n + 3),
                    None if self.ended => self.err(0, LexErrorKind::Truncated, b.len()),
                    None => self.need_more(0),
                }
            }
            b"DT" | b"SM" => match b.get(2) {
                None if self.ended => Step::Token(make(Vec::new(), Some(Vec::new())), 2),
                None => self.need_more(0),
                Some(b';') | Some(b'\n') => Step::Token(make(Vec::new(), Some(Vec::new())), 3),
                Some(&c) => {
                    let used = if b.get(3) == Some(&b';') { 4 } else { 3 };
                    Step::Token(make(Vec::new(), Some(vec![c])), used)
                }
            },
            b"PE" => match b[2..].iter().position(|&c| c == b';') {
                Some(n) if n > MAX_INSTRUCTION_BYTES => self.err(0, LexErrorKind::TooLong(mnemonic), n + 3),
                Some(n) => Step::Token(make(Vec::new(), Some(b[2..2 + n].to_vec())), n + 3),
                None if self.ended => Step::Token(make(Vec::new(), Some(b[2..].to_vec())), b.len()),
                None => self.need_more(0),
            },
            _ => self.numeric(mnemonic),
        }
    }

    /// Reads the numeric parameters after a mnemonic.
    fn numeric(&self, mnemonic: [u8; 2]) -> Step {
        let b = self.rest();
        let mut params = Vec::new();
        let mut i = 2;
        let done = |params, used| Step::Token(Token::Instruction(Instruction { offset: self.base, mnemonic, params, text: None }), used);
        loop {
            if i > MAX_INSTRUCTION_BYTES {
                return self.err(0, LexErrorKind::TooLong(mnemonic), i);
            }
            let Some(&c) = b.get(i) else {
                return if self.ended { done(params, i) } else { self.need_more(0) };
            };
            match c {
                b';' | b'\n' => return done(params, i + 1),
                // The next mnemonic or an escape ends this instruction; it is not consumed.
                ESC => return done(params, i),
                c if c.is_ascii_alphabetic() => return done(params, i),
                b',' | b' ' | b'\t' | b'\r' => i += 1,
                b'+' | b'-' | b'.' | b'0'..=b'9' => {
                    let start = i;
                    i += 1;
                    while let Some(&d) = b.get(i) {
                        if d.is_ascii_digit() || d == b'.' {
                            i += 1;
                        } else {
                            break;
                        }
                    }
                    if i == b.len() && !self.ended {
                        // The number may go on in the next chunk.
                        return self.need_more(0);
                    }
                    match parse_number(&b[start..i]) {
                        Some(v) => params.push(v),
                        None => return self.err(start, bad_number(&b[start..i]), i),
                    }
                }
                _ => return self.err(i, LexErrorKind::UnexpectedByte { byte: c, mnemonic: Some(mnemonic) }, i + 1),
            }
        }
    }
}

/// [`LexErrorKind::BadNumber`] quoting at most [`MAX_NUMBER_CHARS`] of `text`.
fn bad_number(text: &[u8]) -> LexErrorKind {
    let shown = String::from_utf8_lossy(&text[..text.len().min(MAX_NUMBER_CHARS)]).into_owned();
    LexErrorKind::BadNumber(if text.len() > MAX_NUMBER_CHARS { shown + "..." } else { shown })
}

/// An HP-GL number: optional sign, digits with at most one decimal point, at
/// least one digit.
fn parse_number(s: &[u8]) -> Option<f64> {
    if s.len() > MAX_NUMBER_CHARS {
        return None;
    }
    // Only signs, digits and points reach here: ASCII.
    let s = std::str::from_utf8(s).ok()?;
    let body = s.strip_prefix(['+', '-']).unwrap_or(s);
    if !body.bytes().any(|c| c.is_ascii_digit()) || body.bytes().filter(|&c| c == b'.').count() > 1 {
        return None;
    }
    s.parse::<f64>().ok()
}

/// Lexes a complete input, for callers that have all of it.
///
/// # Errors
/// The first [`LexError`].
pub fn tokenize(bytes: &[u8]) -> Result<Vec<Token>, LexError> {
    let mut lexer = Lexer::new();
    lexer.feed(bytes);
    lexer.end();
    let mut out = Vec::new();
    while let Some(t) = lexer.next_token()? {
        out.push(t);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Instructions as "NAME p,p,p" strings, escapes as "ESC..." for compact checks.
    fn show_all(tokens: &[Token]) -> Vec<String> {
        tokens
            .iter()
            .map(|t| match t {
                Token::Instruction(i) => {
                    let p: Vec<String> = i.params.iter().map(|v| v.to_string()).collect();
                    match &i.text {
                        Some(t) => format!("{} {:?}", i.name(), String::from_utf8_lossy(t)),
                        None if p.is_empty() => i.name().to_owned(),
                        None => format!("{} {}", i.name(), p.join(",")),
                    }
                }
                Token::Escape(e) => format!("ESC {:?}", e.kind),
            })
            .collect()
    }

    fn check(input: &str, expected: &[&str]) {
        let tokens = tokenize(input.as_bytes()).unwrap_or_else(|e| panic!("{input:?}: {e}"));
        assert_eq!(show_all(&tokens), expected, "input {input:?}");
    }

    #[test]
    fn separators_and_terminators() {
        check("IN;SP1;PU100,200;PD300,400,500,600;", &["IN", "SP 1", "PU 100,200", "PD 300,400,500,600"]);
        // Spaces, lower case, no terminators at all, newline as a terminator.
        check("in sp 1 pu 10 20 pd 30 40\npa 1,2", &["IN", "SP 1", "PU 10,20", "PD 30,40", "PA 1,2"]);
        check("PA10-20+30.5,.5", &["PA 10,-20,30.5,0.5"]);
        check("PU;PD\r\n;;  SP0", &["PU", "PD", "SP 0"]);
    }

    #[test]
    fn labels_and_terminator_changes() {
        check("LBHello, world;\u{3}PU1,1;", &["LB \"Hello, world;\"", "PU 1,1"]);
        check("DT*;LBabc*SP2;DT;LBx\u{3}", &["DT \"*\"", "LB \"abc\"", "SP 2", "DT \"\"", "LB \"x\""]);
        check("SM*;PD1,1;SM;", &["SM \"*\"", "PD 1,1", "SM \"\""]);
    }

    #[test]
    fn escape_sequences() {
        check(
            "\u{1b}.B\u{1b}.@;512:IN;",
            &["ESC Device { command: 66, params: [] }", "ESC Device { command: 64, params: [None, Some(512)] }", "IN"],
        );
        check("\u{1b}%-1BIN;\u{1b}E", &["ESC Mode { value: Some(-1), command: 66 }", "IN", "ESC Other(69)"]);
        check("\u{1b}.I81;;17:PU", &["ESC Device { command: 73, params: [Some(81), None, Some(17)] }", "PU"]);
    }

    #[test]
    fn incremental_feeding_matches_whole_input() {
        let input = b"IN;SP1;PU100,200;PD300,400,500,600;LBtext\x03\x1b.@;512:PA-5,6;SP0;";
        let whole = tokenize(input).unwrap();
        // Every split point, and byte-at-a-time.
        for cut in 0..input.len() {
            let mut lx = Lexer::new();
            let mut got = Vec::new();
            lx.feed(&input[..cut]);
            while let Some(t) = lx.next_token().unwrap() {
                got.push(t);
            }
            lx.feed(&input[cut..]);
            lx.end();
            while let Some(t) = lx.next_token().unwrap() {
                got.push(t);
            }
            assert_eq!(got, whole, "cut at {cut}");
        }
        let mut lx = Lexer::new();
        let mut got = Vec::new();
        for &b in input.iter() {
            lx.feed(&[b]);
            while let Some(t) = lx.next_token().unwrap() {
                got.push(t);
            }
        }
        lx.end();
        while let Some(t) = lx.next_token().unwrap() {
            got.push(t);
        }
        assert_eq!(got, whole);
    }

    #[test]
    fn incomplete_is_not_an_error() {
        let mut lx = Lexer::new();
        lx.feed(b"PD10,2");
        assert_eq!(lx.next_token(), Ok(None));
        lx.feed(b"0;P");
        let Some(Token::Instruction(i)) = lx.next_token().unwrap() else { panic!() };
        assert_eq!(i.params, vec![10.0, 20.0]);
        assert_eq!(lx.next_token(), Ok(None));
        assert_eq!(lx.offset(), 8);
        lx.end();
        assert_eq!(lx.next_token().unwrap_err().kind, LexErrorKind::Truncated);
    }

    #[test]
    fn offsets_are_stream_offsets() {
        let tokens = tokenize(b"IN;\n  SP1;PU0,0;").unwrap();
        let offsets: Vec<u64> = tokens
            .iter()
            .map(|t| match t {
                Token::Instruction(i) => i.offset,
                Token::Escape(e) => e.offset,
            })
            .collect();
        assert_eq!(offsets, vec![0, 6, 10]);
    }

    #[test]
    fn bad_input_names_the_offset() {
        let cases: &[(&[u8], u64, &str)] = &[
            (b"IN;PA10,#;", 8, "unexpected byte 0x23"),
            (b"IN;P1,2;", 3, "not followed by a second letter"),
            (b"PA1.2.3;", 2, "malformed number \"1.2.3\""),
            (b"PA-,5;", 2, "malformed number \"-\""),
            // Issue #20: errors echoed whole runaway numbers; now a short excerpt.
            (
                b"PA1111111111111111111111111111111111111111111111111111111111.;",
                2,
                "malformed number \"11111111111111111111111111111111...\"",
            ),
            (b"IN;LBunterminated", 3, "ends inside"),
            (b"IN;\x1b.", 3, "ends inside"),
            (b"#IN;", 0, "where an instruction should start"),
        ];
        for (input, offset, msg) in cases {
            let e = tokenize(input).unwrap_err();
            assert_eq!(e.offset, *offset, "{:?}: {e}", String::from_utf8_lossy(input));
            assert!(e.to_string().contains(msg), "{e}");
        }
    }

    #[test]
    fn lexing_resumes_after_an_error() {
        let mut lx = Lexer::new();
        lx.feed(b"PA1,#;PD2,3;");
        lx.end();
        assert!(lx.next_token().is_err());
        let mut rest = Vec::new();
        loop {
            match lx.next_token() {
                Ok(Some(t)) => rest.push(t),
                Ok(None) => break,
                Err(_) => continue,
            }
        }
        assert_eq!(show_all(&rest), vec!["PD 2,3"]);
    }

    /// Issue #20: a 3 MB file took 5-8 s, every token shifting the whole rest
    /// of the buffer. The housekeeping work must be linear in the input.
    #[test]
    fn lexing_work_is_linear_in_the_input() {
        let mut input = Vec::new();
        while input.len() < 1 << 20 {
            input.extend_from_slice(b"PU10,20;PD30,40,50,60;  \n");
        }
        let mut lx = Lexer::new();
        lx.feed(&input);
        lx.end();
        let mut tokens = 0;
        while lx.next_token().expect("valid").is_some() {
            tokens += 1;
        }
        assert!(tokens > 50_000);
        assert!(lx.moved <= 2 * input.len() as u64, "{} bytes moved for {} bytes of input", lx.moved, input.len());
    }

    #[test]
    fn runaway_label_is_capped() {
        let mut lx = Lexer::new();
        lx.feed(b"LB");
        let chunk = vec![b'a'; 4096];
        let mut err = None;
        for _ in 0..(MAX_INSTRUCTION_BYTES / 4096 + 2) {
            lx.feed(&chunk);
            match lx.next_token() {
                Ok(None) => {}
                Ok(Some(t)) => panic!("unexpected {t:?}"),
                Err(e) => {
                    err = Some(e);
                    break;
                }
            }
        }
        assert!(matches!(err.expect("capped").kind, LexErrorKind::TooLong(_)));
    }
}
