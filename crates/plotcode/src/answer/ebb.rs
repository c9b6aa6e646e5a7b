//! What an EiBotBoard says back, as typed values.
//!
//! The board's replies are lines, but not of one pattern: in the legacy
//! syntax (2.x, and 3.x until `CU,10,1`) commands end with `OK\r\n`, queries
//! print their data first, some lines end `\n\r`, and `V` and `QG` print no
//! `OK`; so a host splits what it reads on any CR or LF and drops the empty
//! pieces. In the future syntax (3.x) every reply is `CMD[,data]\n`. Errors
//! start with `!` (`!8 Err: Unknown command`); 3.0.2 in the future syntax
//! writes them after the command's name (`SM!4 Err: ...`). A [`Line`] is one
//! such piece, read knowing which command it answers; the data of each
//! query is read by its own type ([`Steps`], [`Status`], [`EStop`],
//! [`Voltages`], the button, the version with
//! [`crate::ebb::Firmware::from_version_answer`]).
//!
//! The commands are [`crate::control::ebb::Op`].

use crate::ebb::Motors;

/// One line of an EBB's reply (CR and LF taken off).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Line<'a> {
    /// The command is done: `OK`, or in the future syntax the command's
    /// name alone.
    Ok,
    /// An error: its number (`!8` is 8) when it has one, and the text
    /// after the `!`.
    Error {
        /// The error's number.
        number: Option<u32>,
        /// The whole message, after the `!`.
        message: &'a str,
    },
    /// A query's data, the future syntax's `NAME,` taken off.
    Data(&'a str),
}

impl<'a> Line<'a> {
    /// Reads `line`, an answer to the command named `sent` (its letters:
    /// `QS`, `SM`). `None` for an empty line.
    #[must_use]
    pub fn parse(line: &'a str, sent: &str) -> Option<Line<'a>> {
        let line = line.trim_matches(['\r', '\n']);
        if line.is_empty() {
            return None;
        }
        // Future syntax: the command's name first (case as sent is upper).
        let after_name = line
            .strip_prefix(sent)
            .filter(|rest| rest.is_empty() || rest.starts_with(',') || rest.starts_with('!'))
            .filter(|_| !sent.is_empty());
        let body = match after_name {
            Some("") => return Some(Line::Ok),
            Some(rest) => rest.strip_prefix(',').unwrap_or(rest),
            None if line == "OK" => return Some(Line::Ok),
            None => line,
        };
        if let Some(message) = body.strip_prefix('!') {
            let digits: String = message.chars().take_while(char::is_ascii_digit).collect();
            return Some(Line::Error { number: digits.parse().ok(), message });
        }
        Some(Line::Data(body))
    }
}

/// Whether `line` is an error of whatever command, not only of the one
/// sent: `!N ...`, or in the future syntax `NAME!N ...` (a half command left
/// in the board's buffer that took the command sent as its tail is refused
/// under its own name).
#[must_use]
pub fn is_error(line: &str) -> bool {
    let line = line.trim_matches(['\r', '\n']);
    line.find('!').is_some_and(|i| i <= 2 && line[..i].bytes().all(|b| b.is_ascii_uppercase() || b.is_ascii_digit()))
}

/// The whole numbers of a data line, comma-separated.
fn numbers<const N: usize>(data: &str) -> Option<[i64; N]> {
    let mut out = [0; N];
    let mut parts = data.split(',');
    for slot in &mut out {
        *slot = parts.next()?.trim().parse().ok()?;
    }
    parts.next().is_none().then_some(out)
}

/// `QS`'s answer: the step counters (`m1,m2`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Steps(pub Motors);

impl Steps {
    /// Reads `QS`'s data (`1200,-400`).
    #[must_use]
    pub fn parse(data: &str) -> Option<Steps> {
        numbers::<2>(data).map(|[m1, m2]| Steps(Motors::new(m1, m2)))
    }
}

/// `QG`'s answer: one status byte, two hex digits (`3E`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Status(pub u8);

impl Status {
    /// Reads `QG`'s data.
    #[must_use]
    pub fn parse(data: &str) -> Option<Status> {
        let data = data.trim();
        (!data.is_empty() && data.len() <= 2).then(|| u8::from_str_radix(data, 16).ok()).flatten().map(Status)
    }

    /// Bit 0: the motion FIFO holds a command not yet started.
    #[must_use]
    pub fn fifo_pending(self) -> bool {
        self.0 & 1 != 0
    }

    /// Bits 1 and 2: a motor is moving.
    #[must_use]
    pub fn moving(self) -> bool {
        self.0 & 0b110 != 0
    }

    /// Bit 3: a motion command (move, pen move, delay) is executing.
    #[must_use]
    pub fn executing(self) -> bool {
        self.0 & 0b1000 != 0
    }

    /// Whether the board has done everything it was sent: nothing
    /// executing, nothing waiting in the FIFO.
    #[must_use]
    pub fn idle(self) -> bool {
        self.0 & 0b1111 == 0
    }

    /// Bit 4: the pen is up.
    #[must_use]
    pub fn pen_up(self) -> bool {
        self.0 & 0x10 != 0
    }

    /// Bit 5: the PRG button was pressed since the last `QG`/`QB`.
    #[must_use]
    pub fn button_pressed(self) -> bool {
        self.0 & 0x20 != 0
    }

    /// Bit 6 on firmware 3.x: the motor supply dropped since the last `QG`
    /// (the motors may have lost their place). On 2.x the bit is a pin.
    #[must_use]
    pub fn power_lost(self, firmware_3x: bool) -> bool {
        firmware_3x && self.0 & 0x40 != 0
    }
}

/// `QE`'s answer: each motor's step mode as a divisor (16 for 1/16 steps),
/// 0 for a motor that is off.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MotorModes(pub [u8; 2]);

impl MotorModes {
    /// Reads `QE`'s data (`16,16`).
    #[must_use]
    pub fn parse(data: &str) -> Option<MotorModes> {
        let [a, b] = numbers::<2>(data)?;
        Some(MotorModes([u8::try_from(a).ok()?, u8::try_from(b).ok()?]))
    }

    /// Whether both motors are on: the step counters still count from the
    /// home the last `EM` set.
    #[must_use]
    pub fn enabled(self) -> bool {
        self.0.iter().all(|&m| m > 0)
    }
}

/// `ES`'s answer: whether a move was cut short, and on 2.x how many steps
/// it and the FIFO's next move would still have made.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EStop {
    /// A move was interrupted.
    pub interrupted: bool,
    /// 2.x: the steps of the move dropped from the FIFO.
    pub dropped: Option<Motors>,
    /// 2.x: the steps the interrupted move had left.
    pub remaining: Option<Motors>,
}

impl EStop {
    /// Reads `ES`'s data: `int,fifo1,fifo2,rem1,rem2` (2.x) or `int` (3.x).
    #[must_use]
    pub fn parse(data: &str) -> Option<EStop> {
        let flag = |n: i64| matches!(n, 0 | 1).then_some(n == 1);
        if let Some([i, f1, f2, r1, r2]) = numbers::<5>(data) {
            return Some(EStop { interrupted: flag(i)?, dropped: Some(Motors::new(f1, f2)), remaining: Some(Motors::new(r1, r2)) });
        }
        numbers::<1>(data).and_then(|[i]| Some(EStop { interrupted: flag(i)?, dropped: None, remaining: None }))
    }
}

/// The lowest V+ reading (`QC`'s second number) at which the motors have
/// power. A 9 V supply reads about 300 (plotink), so 250 is about 7.5 V,
/// the AxiDraw software's low-voltage threshold; a supply that is off or
/// unplugged reads near 0.
pub const MIN_MOTOR_POWER_ADC: u16 = 250;

/// `QC`'s answer: two 10-bit ADC readings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Voltages {
    /// The motor current reference (RA0).
    pub current_ref: u16,
    /// The motor supply, V+, through a divider.
    pub supply: u16,
}

impl Voltages {
    /// Reads `QC`'s data (`0394,0300` on 2.x, `394,300` on 3.x).
    #[must_use]
    pub fn parse(data: &str) -> Option<Voltages> {
        let [a, b] = numbers::<2>(data)?;
        let adc = |n: i64| u16::try_from(n).ok().filter(|&n| n <= 1023);
        Some(Voltages { current_ref: adc(a)?, supply: adc(b)? })
    }

    /// Whether the motors have power ([`MIN_MOTOR_POWER_ADC`]).
    #[must_use]
    pub fn motor_power(self) -> bool {
        self.supply >= MIN_MOTOR_POWER_ADC
    }
}

/// Reads `QB`'s data: whether the button was pressed.
#[must_use]
pub fn button_pressed(data: &str) -> Option<bool> {
    match data.trim() {
        "0" => Some(false),
        "1" => Some(true),
        _ => None,
    }
}

/// What one line of `QT`'s answer told.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum NicknameLine {
    /// Not the whole answer yet (the legacy syntax's name, its `OK` due).
    Pending,
    /// The nickname; empty when the board has none.
    Name(String),
    /// The board refused `QT` (its number, when it has one).
    Error(Option<u32>),
}

/// `QT`'s answer, read line by line: in the legacy syntax the name and then
/// `OK` (a board with no name answers `OK` alone), in the future syntax
/// `QT,name` in one line. A nickname holds no comma (`ST` stops at one), so
/// a line `QT,...` is the future syntax's.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct NicknameAnswer {
    /// The legacy syntax's name line, before its `OK`.
    name: Option<String>,
}

impl NicknameAnswer {
    /// Reads the next line of the answer (CR and LF taken off).
    pub fn line(&mut self, line: &str) -> NicknameLine {
        let name = crate::control::ebb::Op::Nickname.name();
        let future = line.strip_prefix(name).is_some_and(|rest| rest.starts_with(','));
        match Line::parse(line, name) {
            None => NicknameLine::Pending,
            Some(Line::Error { number, .. }) => NicknameLine::Error(number),
            Some(Line::Data(data)) if future => NicknameLine::Name(data.to_owned()),
            Some(Line::Data(data)) => {
                self.name = Some(data.to_owned());
                NicknameLine::Pending
            }
            Some(Line::Ok) => NicknameLine::Name(self.name.take().unwrap_or_default()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::ebb::Op;
    use crate::ebb::Firmware;

    /// Splits a reply as a host does: on any CR or LF, empty pieces dropped.
    fn lines<'a>(reply: &'a str, sent: Op) -> Vec<Line<'a>> {
        reply.split(['\r', '\n']).filter_map(|l| Line::parse(l, sent.name())).collect()
    }

    #[test]
    fn legacy_and_future_replies_read_alike() {
        // QS on 2.x: data ending `\n\r`, then OK; on 3.x future syntax, one line.
        assert_eq!(lines("1200,-400\n\rOK\r\n", Op::Steps), [Line::Data("1200,-400"), Line::Ok]);
        assert_eq!(lines("QS,1200,-400\n", Op::Steps), [Line::Data("1200,-400")]);
        assert_eq!(lines("OK\r\n", Op::PenUp), [Line::Ok]);
        assert_eq!(lines("SP\n", Op::PenUp), [Line::Ok]);
        assert_eq!(lines("3E\r\n", Op::Status), [Line::Data("3E")]);
        assert_eq!(lines("QG,3E\n", Op::Status), [Line::Data("3E")]);
        let v = lines("EBBv13_and_above EB Firmware Version 2.8.1\r\n", Op::Version);
        let [Line::Data(v)] = v[..] else { panic!("{v:?}") };
        assert_eq!(Firmware::from_version_answer(v), Some(Firmware::new(2, 8, 1)));
    }

    #[test]
    fn errors_carry_their_number() {
        assert_eq!(
            lines("!8 Err: Unknown command 'ZZ:5A5A'\r\n", Op::Steps),
            [Line::Error { number: Some(8), message: "8 Err: Unknown command 'ZZ:5A5A'" }]
        );
        // 3.0.2's future syntax: the name, then the error on the same line.
        assert_eq!(
            lines("SP!4 Err: Missing parameter(s)\n", Op::PenUp),
            [Line::Error { number: Some(4), message: "4 Err: Missing parameter(s)" }]
        );
        assert_eq!(lines("!0 \r\n", Op::Stop), [Line::Error { number: Some(0), message: "0 " }]);
        // An error under another command's name (what took `V` as its tail).
        for (line, error) in
            [("!5 Need comma", true), ("SM!5 Err: Need comma", true), ("S2!4 Err", true), ("OK", false), ("QT,a!b", false), ("hi!", false)]
        {
            assert_eq!(is_error(line), error, "{line}");
        }
    }

    /// Feeds a whole reply, line by line, to a [`NicknameAnswer`].
    fn nickname(reply: &str) -> Vec<NicknameLine> {
        let mut answer = NicknameAnswer::default();
        reply.split(['\r', '\n']).filter(|l| !l.is_empty()).map(|l| answer.line(l)).collect()
    }

    #[test]
    fn the_nickname_in_both_syntaxes() {
        let named = |n: &str| NicknameLine::Name(n.to_owned());
        // Legacy (2.x, 3.x): the name, then OK; no name: OK alone.
        assert_eq!(nickname("axi1\r\nOK\r\n"), [NicknameLine::Pending, named("axi1")]);
        assert_eq!(nickname("\r\nOK\r\n"), [named("")]);
        // Future syntax (3.x after CU,10,1): one line.
        assert_eq!(nickname("QT,axi1\n"), [named("axi1")]);
        assert_eq!(nickname("QT,\n"), [named("")]);
        assert_eq!(nickname("!8 Err: Unknown command 'QT:5154'\r\n"), [NicknameLine::Error(Some(8))]);
        assert_eq!(nickname("QT!8 Err\n"), [NicknameLine::Error(Some(8))]);
    }

    #[test]
    fn query_data_as_values() {
        assert_eq!(Steps::parse("1200,-400"), Some(Steps(Motors::new(1200, -400))));
        assert_eq!(Steps::parse("1200"), None);
        let s = Status::parse("3E").unwrap();
        assert!(!s.fifo_pending() && s.moving() && s.executing() && s.pen_up() && s.button_pressed() && !s.idle());
        assert!(!s.power_lost(true), "bit 6 clear");
        assert!(Status::parse("50").unwrap().power_lost(true) && !Status::parse("50").unwrap().power_lost(false));
        assert!(Status::parse("30").unwrap().idle());
        assert_eq!(Status::parse("1FF"), None);
        assert_eq!(Status::parse(""), None);
        assert_eq!(
            EStop::parse("1,100,-20,55,7"),
            Some(EStop { interrupted: true, dropped: Some(Motors::new(100, -20)), remaining: Some(Motors::new(55, 7)) })
        );
        assert_eq!(EStop::parse("0"), Some(EStop { interrupted: false, dropped: None, remaining: None }));
        assert_eq!(EStop::parse("2"), None);
        let v = Voltages::parse("0394,0300").unwrap();
        assert_eq!((v.current_ref, v.supply, v.motor_power()), (394, 300, true));
        assert!(!Voltages::parse("394,12").unwrap().motor_power());
        assert_eq!(Voltages::parse("394,2000"), None);
        assert_eq!((button_pressed("1"), button_pressed("0"), button_pressed("x")), (Some(true), Some(false), None));
        assert!(MotorModes::parse("16,16").unwrap().enabled());
        assert!(!MotorModes::parse("0,0").unwrap().enabled() && !MotorModes::parse("16,0").unwrap().enabled());
        assert_eq!(MotorModes::parse("16"), None);
    }
}
