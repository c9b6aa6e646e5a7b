//! What a host sends an EiBotBoard (AxiDraw) besides the program: the
//! queries a daemon confirms progress with (`QS`, `QG`), the board's
//! identity (`V`, `QT`), its power and button (`QC`, `QB`), the emergency
//! stop (`ES`) and immediate pen lift (`SP,3`), and the set-up before a job
//! (`EM`, `SC`, `SR`, `CU`), as [`Op`]s. Every command ends with a carriage
//! return (EggBot `docs/ebb.html`, `docs/ebb2.html`).
//!
//! The program itself (moves, pen moves) is [`crate::ebb::Command`]; the
//! answers are read by [`crate::answer::ebb`].

use crate::ebb::{Firmware, MAX_COMMAND_BYTES};

/// Backspaces, one for each byte a half command can have: a link lost in
/// the middle of a command leaves its start in the board's line buffer,
/// and the next bytes would become its tail. A refusal is harmless, but the
/// tail may complete it instead: `LM,...,-222,-2` then `V` reads as an
/// acceleration of -2 (the `V` only an extra character, refused after the
/// move is queued), and the carriage leaves its line with the pen down. The
/// board takes a backspace as the terminal key (`ProcessIO` in `UBW.c`):
/// it removes the last byte of the line, echoing ` \x08`, and does nothing
/// to an empty line. [`crate::answer::AnswerLines`] takes the echo back.
pub const ERASE_HALF_COMMAND: [u8; MAX_COMMAND_BYTES - 1] = [BACKSPACE; MAX_COMMAND_BYTES - 1];

const BACKSPACE: u8 = 0x08;

/// One command a host sends an EBB to run the line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Op {
    /// `V`: the firmware version line (no `OK` follows it on 2.x). Every
    /// session on a port starts with it, so its bytes first erase a half
    /// command ([`ERASE_HALF_COMMAND`]).
    Version,
    /// `QT`: the nickname set with `ST` (which board this is).
    Nickname,
    /// `QS`: the two step counters, since `EM` enabled the motors.
    Steps,
    /// `QG`: the status byte (FIFO, motors moving, pen, button, power lost
    /// on 3.x); reading it clears the button latch.
    Status,
    /// `QB`: whether the PRG button was pressed since the last `QB`/`QG`.
    Button,
    /// `QC`: the two ADC readings, the second the motor supply (V+).
    Voltages,
    /// `QE`: each motor's step mode, 0 when it is off (a board reset or
    /// power-cycled has its motors off and its counters at zero).
    MotorModes,
    /// `ES`: stop the motors now and drop what the motion FIFO holds; the
    /// answer says whether a move was interrupted (2.x: and its steps).
    Stop,
    /// `SP,3`: raise the pen at once, past the motion FIFO (3.0.1; use
    /// [`Op::lift_now`], which picks the command by firmware).
    PenUpAtOnce,
    /// `SP,1`: raise the pen when the FIFO comes to it (after `ES`, at once).
    PenUp,
    /// `EM,mode,mode`: enable both motors in a step mode (1: 1/16 steps),
    /// zeroing the step counters: where the carriage is becomes home.
    EnableMotors(u8),
    /// `EM,0,0`: both motors off (the carriage can be pushed by hand).
    DisableMotors,
    /// `SC,param,value`: a servo setting (4, 5: up and down positions; 11,
    /// 12: raising and lowering rates).
    ServoConfig {
        /// Which setting.
        param: u8,
        /// Its value.
        value: u16,
    },
    /// `SR,ms`: servo power turns off after `ms` of no servo motion; 0
    /// keeps it on (a weighted pen must not drop during a pause).
    ServoPowerTimeout(u32),
    /// `CU,4,n`: a motion FIFO `n` commands deep (3.x).
    FifoDepth(u16),
    /// `CU,60,n`: V+ readings under `n` set `QG`'s power-lost bit (3.x).
    PowerThreshold(u16),
    /// `CU,10,1`: the future reply syntax, `CMD[,data]\n` for every
    /// command (3.x).
    FutureSyntax,
}

impl Op {
    /// The command that raises the pen soonest on `firmware`: `SP,3` from
    /// 3.0.1, else `SP,1` (sent after `ES` emptied the FIFO, it is next).
    #[must_use]
    pub fn lift_now(firmware: Firmware) -> Op {
        if firmware.lifts_pen_at_once() {
            Op::PenUpAtOnce
        } else {
            Op::PenUp
        }
    }

    /// The command's letters, as the future syntax names its answers.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Op::Version => "V",
            Op::Nickname => "QT",
            Op::Steps => "QS",
            Op::Status => "QG",
            Op::Button => "QB",
            Op::Voltages => "QC",
            Op::MotorModes => "QE",
            Op::Stop => "ES",
            Op::PenUpAtOnce | Op::PenUp => "SP",
            Op::EnableMotors(_) | Op::DisableMotors => "EM",
            Op::ServoConfig { .. } => "SC",
            Op::ServoPowerTimeout(_) => "SR",
            Op::FifoDepth(_) | Op::PowerThreshold(_) | Op::FutureSyntax => "CU",
        }
    }

    /// The bytes on the line, carriage return included (for `V`, after
    /// [`ERASE_HALF_COMMAND`]).
    #[must_use]
    pub fn bytes(self) -> Vec<u8> {
        let erase: &[u8] = if self == Op::Version { &ERASE_HALF_COMMAND } else { &[] };
        [erase, self.to_string().as_bytes(), b"\r"].concat()
    }

    /// What follows the command's letters.
    fn args(self) -> String {
        match self {
            Op::PenUpAtOnce => ",3".to_owned(),
            Op::PenUp => ",1".to_owned(),
            Op::EnableMotors(mode) => format!(",{mode},{mode}"),
            Op::DisableMotors => ",0,0".to_owned(),
            Op::ServoConfig { param, value } => format!(",{param},{value}"),
            Op::ServoPowerTimeout(ms) => format!(",{ms}"),
            Op::FifoDepth(n) => format!(",4,{n}"),
            Op::PowerThreshold(n) => format!(",60,{n}"),
            Op::FutureSyntax => ",10,1".to_owned(),
            Op::Version | Op::Nickname | Op::Steps | Op::Status | Op::Button | Op::Voltages | Op::MotorModes | Op::Stop => String::new(),
        }
    }

    /// Whether the board answers it with a data line before (or instead of)
    /// its `OK`: the queries and `ES`.
    #[must_use]
    pub const fn answers_data(self) -> bool {
        matches!(self, Op::Version | Op::Nickname | Op::Steps | Op::Status | Op::Button | Op::Voltages | Op::MotorModes | Op::Stop)
    }

    /// Whether a legacy-syntax board ends its answer with `OK` (`V` and
    /// `QG` do not: their data line is the whole answer).
    #[must_use]
    pub const fn ends_with_ok(self) -> bool {
        !matches!(self, Op::Version | Op::Status)
    }
}

impl std::fmt::Display for Op {
    /// The command as the EBB documentation writes it, without its return.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}{}", self.name(), self.args())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The bytes of each command as the EBB documentation writes them.
    #[test]
    fn each_operation_is_its_command() {
        let expected: [(Op, &[u8], bool, bool); 17] = [
            (Op::Version, &[&ERASE_HALF_COMMAND[..], b"V\r"].concat(), true, false),
            (Op::Nickname, b"QT\r", true, true),
            (Op::Steps, b"QS\r", true, true),
            (Op::Status, b"QG\r", true, false),
            (Op::Button, b"QB\r", true, true),
            (Op::Voltages, b"QC\r", true, true),
            (Op::MotorModes, b"QE\r", true, true),
            (Op::Stop, b"ES\r", true, true),
            (Op::PenUpAtOnce, b"SP,3\r", false, true),
            (Op::PenUp, b"SP,1\r", false, true),
            (Op::EnableMotors(1), b"EM,1,1\r", false, true),
            (Op::DisableMotors, b"EM,0,0\r", false, true),
            (Op::ServoConfig { param: 4, value: 20641 }, b"SC,4,20641\r", false, true),
            (Op::ServoPowerTimeout(0), b"SR,0\r", false, true),
            (Op::FifoDepth(32), b"CU,4,32\r", false, true),
            (Op::PowerThreshold(250), b"CU,60,250\r", false, true),
            (Op::FutureSyntax, b"CU,10,1\r", false, true),
        ];
        for (op, bytes, data, ok) in expected {
            assert_eq!((op.bytes().as_slice(), op.answers_data(), op.ends_with_ok()), (bytes, data, ok), "{op}");
        }
        assert_eq!(Op::ServoConfig { param: 5, value: 15248 }.to_string(), "SC,5,15248");
    }

    #[test]
    fn the_pen_is_lifted_at_once_from_3_0_1() {
        assert_eq!(Op::lift_now(Firmware::new(2, 8, 1)), Op::PenUp);
        assert_eq!(Op::lift_now(Firmware::new(3, 0, 0)), Op::PenUp);
        assert_eq!(Op::lift_now(Firmware::new(3, 0, 2)), Op::PenUpAtOnce);
    }
}
