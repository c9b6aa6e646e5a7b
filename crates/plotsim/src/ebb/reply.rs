//! What the board prints back: the two reply syntaxes, line endings, and the
//! parse errors collected while a command is read.
//!
//! Legacy syntax (2.8.1, and 3.0.2 by default) has no single pattern: most
//! commands end with `OK\r\n`, queries print their data first, some lines end
//! `\n\r`, and a few queries (`V`, `QG`, `QM`, `PI`, ...) print no OK. 3.0.2's
//! future syntax (`CU,10,1`) answers every command with its name, then
//! `,data` if any, then `\n` (`print_command` and `print_line_ending` in
//! `UBW.c`). `CU,1,0` drops the OK: on 2.8.1 the whole `OK\r\n`, on 3.0.2
//! legacy only the letters (the `\r\n` stays).
//!
//! Errors are flags set while a command is read and printed after it, each on
//! its own line: `!3 Err: RX Buffer overrun`, `!4 Err: Missing parameter(s)`,
//! `!6 Err: Invalid parameter value`, `!7 Err: Extra parameter` (in that
//! order). Some errors are printed where they are found instead (`!0 ...`,
//! `!5 Err: Need comma next, found: 'x'`, `!8 Err: Unknown command ...`). On
//! 3.0.2 in future syntax the command's name was already printed when an
//! error follows, so the error continues that line (`SM!4 Err: ...`); 3.0.3
//! changed this, it is not modelled.

use super::firmware::Firmware;

/// `print_line_ending`'s kinds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Le {
    /// `OK\r\n` (legacy, with acks on), the end of a command.
    Ok,
    /// `\r\n`.
    Norm,
    /// `\n\r`.
    Rev,
}

/// Error flags (the firmware's `error_byte` bits).
pub(crate) mod flag {
    pub const RX_OVERRUN: u8 = 1 << 3;
    pub const MISSING: u8 = 1 << 4;
    /// An error already printed where it was found.
    pub const PRINTED: u8 = 1 << 5;
    pub const OUT_OF_RANGE: u8 = 1 << 6;
    pub const EXTRA: u8 = 1 << 7;
}

/// The messages of the error flags, by bit.
const FLAG_MESSAGES: [(u8, u32, &str); 7] = [
    (1 << 0, 0, "!0 "),
    (1 << 1, 1, "!1 Err: Can't step that fast"),
    (1 << 2, 2, "!2 Err: TX Buffer overrun"),
    (flag::RX_OVERRUN, 3, "!3 Err: RX Buffer overrun"),
    (flag::MISSING, 4, "!4 Err: Missing parameter(s)"),
    (flag::OUT_OF_RANGE, 6, "!6 Err: Invalid parameter value"),
    (flag::EXTRA, 7, "!7 Err: Extra parameter"),
];

/// The reply to one command as it is built, with the syntax in force.
#[derive(Clone, Debug)]
pub(crate) struct Out {
    pub fw: Firmware,
    /// 3.0.2 `CU,10,1`.
    pub future: bool,
    /// `CU,1`.
    pub ack: bool,
    /// The command's letters (`print_command`), upper-cased.
    pub name: Vec<u8>,
    pub bytes: Vec<u8>,
    pub errors: u8,
    /// Errors printed, for the record: number and message.
    pub logged: Vec<(u32, String)>,
}

impl Out {
    pub fn new(fw: Firmware, future: bool, ack: bool) -> Out {
        Out { fw, future, ack, name: Vec::new(), bytes: Vec::new(), errors: 0, logged: Vec::new() }
    }

    pub fn text(&mut self, s: &str) {
        self.bytes.extend_from_slice(s.as_bytes());
    }

    /// `print_line_ending`; on 2.8.1 the literal ending (`Le::Ok` is `print_ack`).
    pub fn le(&mut self, kind: Le) {
        if self.fw.is_v3() && self.future {
            self.text("\n");
            return;
        }
        if kind == Le::Ok && self.ack {
            self.text("OK");
        } else if kind == Le::Ok && !self.fw.is_v3() {
            return;
        }
        self.text(if kind == Le::Rev { "\n\r" } else { "\r\n" });
    }

    /// 3.0.2 `print_command`: the command's name in future syntax (or
    /// always), and a comma if data follows. Nothing on 2.8.1.
    pub fn name(&mut self, always: bool, comma: bool) {
        if self.fw.is_v3() && (self.future || always) {
            let n = self.name.clone();
            self.bytes.extend_from_slice(&n);
            if comma {
                self.text(",");
            }
        }
    }

    /// Sets an error flag.
    pub fn flag(&mut self, f: u8) {
        self.errors |= f;
    }

    /// Prints an error where it was found, on its own line, and logs it.
    pub fn error_line(&mut self, number: u32, message: &str, end: Le) {
        self.error_bytes(number, message.as_bytes(), end);
    }

    /// [`Out::error_line`] for a message that quotes the host's bytes as they came.
    pub fn error_bytes(&mut self, number: u32, message: &[u8], end: Le) {
        self.bytes.extend_from_slice(message);
        self.le(end);
        self.logged.push((number, String::from_utf8_lossy(message).into_owned()));
    }

    /// Prints the collected error flags, one line each, and clears them.
    pub fn print_errors(&mut self) {
        let errors = std::mem::take(&mut self.errors);
        for (bit, number, message) in FLAG_MESSAGES {
            if errors & bit != 0 {
                self.text(message);
                if self.fw.is_v3() {
                    self.le(Le::Norm);
                } else {
                    self.text("\r\n");
                }
                self.logged.push((number, message.to_string()));
            }
        }
    }
}
