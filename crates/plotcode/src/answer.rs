//! What a device says back, as typed values: the one place its answers are
//! read.
//!
//! Answers arrive as lines ([`AnswerLines`]: bytes in, lines out, XON/XOFF
//! taken out, each line with the terminator it ended with, so a device that
//! lost the terminator it was given, a power cycle, shows). An HP-GL answer
//! says nothing about what it answers, so it is read as what was asked:
//! [`HpglNumber`] (`OE`, `ESC.B`, `ESC.E`, `ESC.L`, `ESC.O`, `OS`),
//! [`HpglPosition`] (`OA`), or an identification (`OI`). A GRBL line says what
//! it is: [`GrblAnswer`]. An EBB's lines are read knowing the command they
//! answer: [`ebb::Line`] and the query types beside it.

pub mod ebb;

/// XON (DC1): the device may receive again.
pub const XON: u8 = 0x11;
/// XOFF (DC3): the device's buffer is nearly full.
pub const XOFF: u8 = 0x13;
/// Backspace (BS): takes back the byte before it.
const BACKSPACE: u8 = 0x08;
/// Longest answer line kept; a device sending more without a terminator is
/// sending garbage, and the excess is dropped.
pub const MAX_ANSWER_BYTES: usize = 256;

/// How an answer line ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Terminator {
    /// Carriage return: an HP plotter's power-on terminator.
    Cr,
    /// Line feed.
    Lf,
}

/// One answer line, without its terminator, blanks trimmed.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct AnswerLine {
    /// The text (lossy UTF-8; at most [`MAX_ANSWER_BYTES`]).
    pub text: String,
    /// What ended it.
    pub terminator: Terminator,
}

/// Splits a device's output into answer lines: feed bytes as they arrive,
/// take whole lines. XON/XOFF are flow control, not answer bytes: they are
/// taken out and remembered.
#[derive(Clone, Debug, Default)]
pub struct AnswerLines {
    buf: Vec<u8>,
    xoff: bool,
    /// The last line taken ended with CR: an LF next ends no answer.
    after_cr: bool,
    /// Empty answers skipped (see [`AnswerLines::empty_answers`]).
    empty: usize,
}

impl AnswerLines {
    /// Takes in bytes the device sent. A backspace takes back the byte of
    /// the line before it, as on a terminal: an EBB erasing a half command
    /// echoes ` \x08` for each byte it removes
    /// ([`crate::control::ebb::ERASE_HALF_COMMAND`]).
    pub fn feed(&mut self, bytes: &[u8]) {
        for &b in bytes {
            match b {
                XON => self.xoff = false,
                XOFF => self.xoff = true,
                BACKSPACE => {
                    if self.buf.last().is_some_and(|&b| b != b'\r' && b != b'\n') {
                        self.buf.pop();
                    }
                }
                _ => self.buf.push(b),
            }
        }
        // A device sending this much without a terminator is sending garbage.
        if self.buf.len() > 4 * MAX_ANSWER_BYTES && !self.buf.iter().any(|&b| b == b'\r' || b == b'\n') {
            self.buf.clear();
        }
    }

    /// Whether the device last said XOFF.
    #[must_use]
    pub fn xoff(&self) -> bool {
        self.xoff
    }

    /// Forgets partial input and flow state (a new connection).
    pub fn clear(&mut self) {
        self.buf.clear();
        self.xoff = false;
        self.after_cr = false;
    }

    /// Empty answers skipped so far: a terminator alone, not the LF of a
    /// CR LF. A device that answers a question with one answered, with
    /// nothing readable.
    #[must_use]
    pub fn empty_answers(&self) -> usize {
        self.empty
    }

    /// The next whole line (ended by CR or LF); empty lines are skipped
    /// (and counted: [`AnswerLines::empty_answers`]).
    pub fn next_line(&mut self) -> Option<AnswerLine> {
        loop {
            let end = self.buf.iter().position(|&b| b == b'\r' || b == b'\n')?;
            let terminator = if self.buf[end] == b'\r' { Terminator::Cr } else { Terminator::Lf };
            let line: Vec<u8> = self.buf.drain(..=end).collect();
            let line = &line[..end];
            let after_cr = std::mem::replace(&mut self.after_cr, terminator == Terminator::Cr);
            // CR LF: the LF after a CR ends an empty line, skipped here.
            if line.iter().all(u8::is_ascii_whitespace) {
                if !(line.is_empty() && after_cr && terminator == Terminator::Lf) {
                    self.empty += 1;
                }
                continue;
            }
            let line = &line[line.len().saturating_sub(MAX_ANSWER_BYTES)..];
            return Some(AnswerLine { text: String::from_utf8_lossy(line).trim().to_owned(), terminator });
        }
    }
}

/// An HP-GL numeric answer (`OE`, `OS`, `ESC.B`, `ESC.E`, `ESC.L`, `ESC.O`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct HpglNumber(pub i64);

impl HpglNumber {
    /// Reads a line that should be one integer.
    #[must_use]
    pub fn parse(line: &str) -> Option<HpglNumber> {
        line.trim().parse().ok().map(HpglNumber)
    }
}

/// The pen's place as `OA` answers it: `x,y,pen` (pen 1 down, 0 up).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HpglPosition {
    /// Plotter units.
    pub x: f64,
    /// Plotter units.
    pub y: f64,
    /// Whether the pen is down.
    pub down: bool,
}

impl HpglPosition {
    /// Reads an `OA` answer; `None` for anything else.
    #[must_use]
    pub fn parse(line: &str) -> Option<HpglPosition> {
        let mut v = line.split(',').map(|w| w.trim().parse::<f64>());
        let (Some(Ok(x)), Some(Ok(y)), Some(Ok(p)), None) = (v.next(), v.next(), v.next(), v.next()) else { return None };
        Some(HpglPosition { x, y, down: p != 0.0 })
    }
}

/// Whether an answer is an identification (`OI`: a model name such as
/// `7475A`), not a number or position.
#[must_use]
pub fn is_identification(line: &str) -> bool {
    line.bytes().any(|b| b.is_ascii_alphabetic())
}

/// The largest `OE` answer: HP-GL instruction errors are numbered 0 to 7.
pub const MAX_HPGL_ERROR: i64 = 7;

/// The 7475A's extended status (`ESC.O`) bits that matter to a host.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ExtendedStatus(pub i64);

impl ExtendedStatus {
    /// Whether `n` can be an `ESC.O` answer at all: one byte whose bits 0
    /// to 2 are never set, so a multiple of 8 up to 248 (a host tells it
    /// from an `OE` answer, 1 to 7, by the bits, and from a buffer size or
    /// free space answered late, such as 1024, by the byte).
    #[must_use]
    pub fn possible(n: i64) -> bool {
        (0..=0xff).contains(&n) && n % 8 == 0
    }
    /// Bit 3: the buffer is empty.
    #[must_use]
    pub fn buffer_empty(self) -> bool {
        self.0 & 8 != 0
    }
    /// Bit 5: the paper lever is raised (or the plotter is otherwise "not
    /// ready", in view mode): it holds its buffer and draws nothing.
    #[must_use]
    pub fn paper_lever_up(self) -> bool {
        self.0 & 32 != 0
    }
}

/// Meaning of an HP-GL `OE` error number.
#[must_use]
pub fn hpgl_error_text(n: i64) -> &'static str {
    match n {
        1 => "instruction not recognised",
        2 => "wrong number of parameters",
        3 => "out-of-range parameter",
        5 => "unknown character set",
        6 => "position overflow",
        7 => "buffer overflow for polygons or labels",
        _ => "unknown error",
    }
}

/// Meaning of an `ESC.E` (device control / I/O) error number.
#[must_use]
pub fn device_control_error_text(n: i64) -> &'static str {
    match n {
        10 => "output instruction received while another is being processed",
        11 => "invalid byte after ESC .",
        12 => "invalid byte in a device-control instruction",
        13 => "device-control parameter out of range",
        14 => "too many parameters",
        15 => "framing, parity or overrun error",
        16 => "input buffer overflow",
        _ => "unknown error",
    }
}

/// An error a device reports, by its number: what the device said went
/// wrong, with the meaning its manual gives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ErrorCode {
    /// HP-GL `OE` answer 1 to 7: an instruction error ([`hpgl_error_text`]).
    Hpgl(i64),
    /// HP-GL `ESC.E` answer: a device-control or I/O error
    /// ([`device_control_error_text`]).
    DeviceControl(i64),
    /// GRBL `error:N`: a line refused.
    Grbl(u32),
    /// GRBL `ALARM:N`: the board locked itself ([`grbl_alarm_text`]).
    GrblAlarm(u32),
    /// A GRBL status report in state `Alarm`, its reason not heard.
    GrblInAlarm,
    /// An EiBotBoard's `!N Err: ...`: a command refused (its number when
    /// the message has one).
    Ebb(Option<u32>),
}

impl std::fmt::Display for ErrorCode {
    /// As the device's manual writes it, with its meaning:
    /// `HP-GL error 3 (out-of-range parameter)`, `GRBL error:20`,
    /// `GRBL ALARM:1 (hard limit triggered)`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            ErrorCode::Hpgl(n) => write!(f, "HP-GL error {n} ({})", hpgl_error_text(n)),
            ErrorCode::DeviceControl(n) => write!(f, "ESC.E error {n} ({})", device_control_error_text(n)),
            ErrorCode::Grbl(n) => write!(f, "GRBL error:{n}"),
            ErrorCode::GrblAlarm(n) => write!(f, "GRBL ALARM:{n} ({})", grbl_alarm_text(n)),
            ErrorCode::GrblInAlarm => f.write_str("GRBL in alarm"),
            ErrorCode::Ebb(Some(n)) => write!(f, "EBB error !{n}"),
            ErrorCode::Ebb(None) => f.write_str("EBB error"),
        }
    }
}

/// A GRBL board's machine state, from a status report.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GrblState {
    /// Nothing executing, planner empty.
    Idle,
    /// Executing motion.
    Run,
    /// Feed hold (`!`), decelerating or stopped.
    Hold,
    /// Jogging.
    Jog,
    /// Locked in alarm: G-code answers `error:9` until `$X`.
    Alarm,
    /// Safety door open.
    Door,
    /// Check mode (`$C`).
    Check,
    /// Homing.
    Home,
    /// Sleeping.
    Sleep,
}

/// A status report (`<Idle|MPos:1.000,2.000,0.000|FS:0,0>`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GrblStatus {
    /// The machine state.
    pub state: GrblState,
    /// The sub-state after the state's `:`, when given (`Hold:0`: the hold
    /// is complete, the tool stopped; `Hold:1`: still decelerating).
    pub sub: Option<u8>,
    /// Machine position (or work position when the board reports that), mm.
    pub pos: Option<[f64; 3]>,
}

/// The modal state `$G` reports (`[GC:G0 G54 G17 G21 G90 G94 M5 M9 T0 F0 S0]`),
/// as far as locating the pen needs it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GrblModal {
    /// The feed rate (0 at power-on and after a reset).
    pub feed: Option<f64>,
    /// Spindle on (`M3`/`M4`) or off (`M5`).
    pub spindle_on: Option<bool>,
    /// Spindle speed.
    pub speed: f64,
}

/// One line from a GRBL 1.1 board.
#[derive(Clone, Debug, PartialEq)]
pub enum GrblAnswer {
    /// `ok`: a line was taken (a motion line planned, a dwell executed).
    Ok,
    /// `error:N`: a line was refused.
    Error(u32),
    /// `ALARM:N`: the board locked itself.
    Alarm(u32),
    /// `<...>`: a status report.
    Status(GrblStatus),
    /// `Grbl 1.1h ['$' for help]`: the board has just reset or powered up.
    Welcome(String),
    /// `[OPT:...]` of `$I`: the receive buffer size, when it says.
    Options {
        /// The serial receive buffer in bytes (third field).
        rx_buffer: Option<usize>,
    },
    /// `[VER:...]` of `$I`.
    Version(String),
    /// `[GC:...]`: the modal state (`$G`).
    Modal(GrblModal),
    /// Any other `[...]` message (`[MSG:...]`, settings, parameters).
    Message(String),
    /// `$N=V` setting lines and anything else a board may print.
    Other(String),
}

impl GrblAnswer {
    /// Reads one line.
    #[must_use]
    pub fn parse(line: &str) -> GrblAnswer {
        let line = line.trim();
        if line == "ok" {
            return GrblAnswer::Ok;
        }
        let number = |s: &str| s.trim().parse::<u32>().ok();
        if let Some(n) = line.strip_prefix("error:").and_then(number) {
            return GrblAnswer::Error(n);
        }
        if let Some(n) = line.strip_prefix("ALARM:").and_then(number) {
            return GrblAnswer::Alarm(n);
        }
        if line.starts_with('<') && line.ends_with('>') {
            if let Some(s) = parse_status(&line[1..line.len() - 1]) {
                return GrblAnswer::Status(s);
            }
        }
        if line.starts_with("Grbl ") {
            return GrblAnswer::Welcome(line.to_owned());
        }
        if let Some(body) = line.strip_prefix('[').and_then(|l| l.strip_suffix(']')) {
            if let Some(opt) = body.strip_prefix("OPT:") {
                return GrblAnswer::Options { rx_buffer: opt.split(',').nth(2).and_then(|s| s.trim().parse().ok()) };
            }
            if let Some(v) = body.strip_prefix("VER:") {
                return GrblAnswer::Version(v.to_owned());
            }
            if let Some(gc) = body.strip_prefix("GC:") {
                return GrblAnswer::Modal(parse_modal(gc));
            }
            return GrblAnswer::Message(body.to_owned());
        }
        GrblAnswer::Other(line.to_owned())
    }
}

/// Whether a GRBL line is a status report (`<...>`), whether or not its
/// fields can be read: the answer to [`crate::control::grbl::Op::Status`].
#[must_use]
pub fn is_grbl_status(line: &str) -> bool {
    line.trim_start().starts_with('<')
}

fn parse_status(body: &str) -> Option<GrblStatus> {
    let mut fields = body.split('|');
    // `Hold:0`, `Door:1`: the state with a sub-state.
    let mut head = fields.next()?.split(':');
    let state = match head.next()? {
        "Idle" => GrblState::Idle,
        "Run" => GrblState::Run,
        "Hold" => GrblState::Hold,
        "Jog" => GrblState::Jog,
        "Alarm" => GrblState::Alarm,
        "Door" => GrblState::Door,
        "Check" => GrblState::Check,
        "Home" => GrblState::Home,
        "Sleep" => GrblState::Sleep,
        _ => return None,
    };
    let pos = fields.find_map(|f| {
        let v = f.strip_prefix("MPos:").or_else(|| f.strip_prefix("WPos:"))?;
        let v: Vec<f64> = v.split(',').map(|w| w.trim().parse().ok()).collect::<Option<_>>()?;
        Some([*v.first()?, *v.get(1)?, v.get(2).copied().unwrap_or(0.0)])
    });
    let sub = head.next().and_then(|n| n.parse().ok());
    Some(GrblStatus { state, sub, pos })
}

fn parse_modal(gc: &str) -> GrblModal {
    let mut m = GrblModal { feed: None, spindle_on: None, speed: 0.0 };
    for w in gc.split_whitespace() {
        match w {
            "M3" | "M4" => m.spindle_on = Some(true),
            "M5" => m.spindle_on = Some(false),
            _ => {}
        }
        let number = |prefix: char| w.strip_prefix(prefix)?.parse::<f64>().ok();
        m.feed = number('F').or(m.feed);
        m.speed = number('S').unwrap_or(m.speed);
    }
    m
}

/// Meaning of a GRBL 1.1 `ALARM:N`.
#[must_use]
pub fn grbl_alarm_text(n: u32) -> &'static str {
    match n {
        1 => "hard limit triggered",
        2 => "soft limit: motion target beyond travel",
        3 => "reset while in motion",
        4 | 5 => "probe fail",
        6..=9 => "homing fail",
        _ => "unknown alarm",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_keep_their_terminator_and_drop_flow_control() {
        let mut l = AnswerLines::default();
        l.feed(b"12\n\x13 0\r");
        assert!(l.xoff());
        assert_eq!(l.next_line(), Some(AnswerLine { text: "12".into(), terminator: Terminator::Lf }));
        assert_eq!(l.next_line(), Some(AnswerLine { text: "0".into(), terminator: Terminator::Cr }));
        assert_eq!(l.next_line(), None);
        l.feed(b"\x11\r\n3");
        assert!(!l.xoff());
        assert_eq!(l.next_line(), None, "an empty line is skipped, a partial one waits");
        l.feed(b"\n");
        assert_eq!(l.next_line().unwrap().text, "3");
        l.feed(&[b'x'; 2000]);
        assert_eq!(l.next_line(), None);
        l.feed(b"ok\n");
        assert_eq!(l.next_line().unwrap().text, "ok", "runaway garbage without a terminator is dropped");
    }

    /// An EBB erasing a half command echoes ` \x08` per byte before the
    /// version line, in as many reads as the link likes: the echo is taken
    /// back, and a backspace never reaches into an answer already ended.
    #[test]
    fn a_backspace_takes_back_the_byte_before_it_in_its_line() {
        let mut l = AnswerLines::default();
        l.feed(b"OK\r\n \x08 ");
        l.feed(b"\x08 \x08EBBv13_and_above EB Firmware Version 2.8.1\r\n");
        assert_eq!(l.next_line().unwrap().text, "OK");
        assert_eq!(l.next_line().unwrap().text, "EBBv13_and_above EB Firmware Version 2.8.1");
        l.feed(b"\x08\x08QS");
        l.feed(b"\r");
        assert_eq!(l.next_line().unwrap().text, "QS");
    }

    /// Issue 36: a device that answered with a bare CR was told "no answer":
    /// an empty answer is skipped as a line, and counted. The LF of a CR LF
    /// ends no answer.
    #[test]
    fn empty_answers_are_counted_apart_from_cr_lf() {
        let mut l = AnswerLines::default();
        l.feed(b"\r");
        assert_eq!((l.next_line(), l.empty_answers()), (None, 1), "a bare CR is an empty answer");
        l.feed(b"12\r");
        assert_eq!(l.next_line().unwrap().text, "12");
        l.feed(b"\n7\r\n");
        assert_eq!(l.next_line().unwrap().text, "7", "the LF after a CR, split across reads, is no answer");
        assert_eq!((l.next_line(), l.empty_answers()), (None, 1));
        l.feed(b"\n");
        assert_eq!((l.next_line(), l.empty_answers()), (None, 2), "an LF alone is an empty answer");
    }

    #[test]
    fn hpgl_answers() {
        assert_eq!(HpglNumber::parse(" 1022 "), Some(HpglNumber(1022)));
        assert_eq!(HpglNumber::parse("1,2,0"), None);
        assert_eq!(HpglPosition::parse("100,-20,1"), Some(HpglPosition { x: 100.0, y: -20.0, down: true }));
        assert_eq!(HpglPosition::parse("100,-20"), None);
        assert_eq!(HpglPosition::parse("1,2,3,4"), None);
        assert!(is_identification("7475A") && !is_identification("0"));
        assert!(ExtendedStatus(32 + 8).paper_lever_up() && ExtendedStatus(40).buffer_empty());
        assert!(!ExtendedStatus(8).paper_lever_up());
    }

    #[test]
    fn error_codes_say_what_the_manual_says() {
        assert_eq!(ErrorCode::Hpgl(3).to_string(), "HP-GL error 3 (out-of-range parameter)");
        assert_eq!(ErrorCode::DeviceControl(15).to_string(), "ESC.E error 15 (framing, parity or overrun error)");
        assert_eq!(ErrorCode::Grbl(20).to_string(), "GRBL error:20");
        assert_eq!(ErrorCode::GrblAlarm(1).to_string(), "GRBL ALARM:1 (hard limit triggered)");
        assert!((1..=MAX_HPGL_ERROR).all(|n| !ExtendedStatus::possible(n)) && ExtendedStatus::possible(40));
        assert!(!ExtendedStatus::possible(1024) && !ExtendedStatus::possible(256), "a buffer size is not a status byte");
        assert!(is_grbl_status("<Bogus|x>") && !is_grbl_status("ok"));
    }

    #[test]
    fn grbl_answers() {
        assert_eq!(GrblAnswer::parse("ok"), GrblAnswer::Ok);
        assert_eq!(GrblAnswer::parse("error:9"), GrblAnswer::Error(9));
        assert_eq!(GrblAnswer::parse("ALARM:3"), GrblAnswer::Alarm(3));
        assert_eq!(
            GrblAnswer::parse("<Idle|MPos:1.000,2.500,-1.000|FS:0,0>"),
            GrblAnswer::Status(GrblStatus { state: GrblState::Idle, sub: None, pos: Some([1.0, 2.5, -1.0]) })
        );
        assert_eq!(
            GrblAnswer::parse("<Hold:0|WPos:0,0,0>"),
            GrblAnswer::Status(GrblStatus { state: GrblState::Hold, sub: Some(0), pos: Some([0.0; 3]) })
        );
        assert!(matches!(GrblAnswer::parse("<Hold:1|MPos:0,0,0>"), GrblAnswer::Status(GrblStatus { sub: Some(1), .. })));
        assert!(matches!(GrblAnswer::parse("<Bogus|x>"), GrblAnswer::Other(_)));
        assert!(matches!(GrblAnswer::parse("Grbl 1.1h ['$' for help]"), GrblAnswer::Welcome(_)));
        assert_eq!(GrblAnswer::parse("[OPT:V,15,128]"), GrblAnswer::Options { rx_buffer: Some(128) });
        assert_eq!(
            GrblAnswer::parse("[GC:G1 G54 G17 G21 G90 G94 M3 M9 T0 F3000 S1000]"),
            GrblAnswer::Modal(GrblModal { feed: Some(3000.0), spindle_on: Some(true), speed: 1000.0 })
        );
        assert!(matches!(GrblAnswer::parse("[MSG:'$H'|'$X' to unlock]"), GrblAnswer::Message(_)));
        assert!(matches!(GrblAnswer::parse("okay"), GrblAnswer::Other(_)));
    }
}
