//! Assembling commands from the bytes the host sends (`ProcessIO` in
//! `UBW.c`).
//!
//! A CR or an LF ends a command; further CRs and LFs are ignored until a
//! printable byte comes (so CR LF, LF CR and blank lines end one command).
//! Bytes below 32 are dropped, except backspace, which removes the last byte
//! and echoes " \b". A command may hold 255 bytes: the 256th byte without a
//! line end overruns the buffer, which is emptied (error !3) and filled on
//! with what follows. 2.8.1 also recalls the last command on the terminal's
//! up-arrow (ESC [ A) and echoes it (the recall leaves the last line end in
//! force, so a CR right after it is ignored, as on the board).

/// Most bytes of one command, its CR included (`kRX_BUF_SIZE`).
pub(crate) const MAX_COMMAND: usize = 256;

/// What one byte did.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) enum Fed {
    Nothing,
    /// Bytes the firmware echoes (backspace, up-arrow).
    Echo(Vec<u8>),
    /// A complete command, without its line end.
    Command(Vec<u8>),
    /// The buffer overran and was emptied.
    Overrun,
}

/// The command being received.
#[derive(Clone, Debug, Default)]
pub(crate) struct LineBuffer {
    buf: Vec<u8>,
    in_cr: bool,
    /// 2.8.1's up-arrow recall: ESC seen, then `[` seen.
    esc: (bool, bool),
    last: Vec<u8>,
    recall: bool,
}

impl LineBuffer {
    /// A buffer; `recall` enables 2.8.1's up-arrow.
    pub fn new(recall: bool) -> LineBuffer {
        LineBuffer { recall, ..LineBuffer::default() }
    }

    /// Bytes of the command being received.
    pub fn len(&self) -> usize {
        self.buf.len()
    }

    pub fn feed(&mut self, b: u8) -> Fed {
        let mut fed = Fed::Nothing;
        if !self.in_cr && (b == b'\r' || b == b'\n') {
            self.in_cr = true;
            let line = std::mem::take(&mut self.buf);
            self.last.clone_from(&line);
            return Fed::Command(line);
        } else if self.recall && b == 27 && !self.esc.0 {
            self.esc = (true, false);
        } else if self.recall && self.esc.0 && !self.esc.1 && b == b'[' {
            self.esc.1 = true;
        } else if self.recall && self.esc == (true, true) && b == b'A' {
            self.esc = (false, false);
            self.buf.clone_from(&self.last);
            let mut echo = b"\x1b[B\x1b[1K\x1b[0G".to_vec();
            echo.extend_from_slice(&self.buf);
            fed = Fed::Echo(echo);
        } else if b == 8 && !self.buf.is_empty() {
            self.buf.pop();
            fed = Fed::Echo(b" \x08".to_vec());
        } else if b != b'\r' && b != b'\n' && b >= 32 {
            self.esc = (false, false);
            self.buf.push(b);
            self.in_cr = false;
        }
        if self.buf.len() == MAX_COMMAND {
            self.buf.clear();
            fed = Fed::Overrun;
        }
        fed
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn commands(line: &mut LineBuffer, bytes: &[u8]) -> Vec<String> {
        bytes
            .iter()
            .filter_map(|&b| match line.feed(b) {
                Fed::Command(c) => Some(String::from_utf8(c).unwrap()),
                _ => None,
            })
            .collect()
    }

    #[test]
    fn cr_lf_and_blank_lines_end_one_command_each() {
        let mut l = LineBuffer::new(false);
        assert_eq!(commands(&mut l, b"V\r\nQS\n\r\r\nsm,1,2\tx\r"), ["V", "QS", "sm,1,2x"]);
        // A line end first thing is an empty command (the firmware parses it).
        let mut l = LineBuffer::new(false);
        assert_eq!(commands(&mut l, b"\rV\r"), ["", "V"]);
    }

    #[test]
    fn backspace_and_overrun() {
        let mut l = LineBuffer::new(false);
        assert_eq!(l.feed(b'Q'), Fed::Nothing);
        assert_eq!(l.feed(8), Fed::Echo(b" \x08".to_vec()));
        assert_eq!(commands(&mut l, b"V\r"), ["V"]);
        let mut long = vec![b'X'; 255];
        long.push(b'\r');
        assert_eq!(commands(&mut l, &long).len(), 1, "255 bytes and the CR fit");
        let mut over = 0;
        for _ in 0..300 {
            if l.feed(b'Y') == Fed::Overrun {
                over += 1;
            }
        }
        assert_eq!(over, 1);
        assert_eq!(l.len(), 300 - 256);
    }

    #[test]
    fn up_arrow_recalls_on_2x_only() {
        let mut l = LineBuffer::new(true);
        commands(&mut l, b"QS\r");
        assert!(matches!(l.feed(27), Fed::Nothing));
        l.feed(b'[');
        assert!(matches!(l.feed(b'A'), Fed::Echo(_)));
        // The recall leaves the line end of the last command in force: a CR
        // right after it is swallowed, as on the board; any printable byte
        // re-arms it.
        assert!(commands(&mut l, b"\r").is_empty());
        assert_eq!(commands(&mut l, b",\r"), ["QS,"]);
        let mut l = LineBuffer::new(false);
        commands(&mut l, b"QS\r");
        assert_eq!(commands(&mut l, b"\x1b[A\r"), ["[A"]);
    }
}
