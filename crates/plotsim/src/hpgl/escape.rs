//! Device-control instructions (`ESC . letter [params ;...] :`), read as the
//! bytes arrive and never stored in the buffer, and the handshakes they set up.
//!
//! Reference: HP 7475A Interfacing and Programming Manual, RS-232-C chapter
//! (the 7470A manual has the same chapter): ESC.B buffer space, ESC.E
//! extended error (10 output request while busy, 11 bad byte after "ESC.",
//! 12 bad byte in a device-control parameter, 13 parameter out of range,
//! 14 too many parameters, 15 framing/parity/overrun, 16 buffer overflow),
//! ESC.O extended status (8 buffer empty, 32 paper lever raised), ESC.L buffer
//! size, ESC.@ configuration (bit 0: hardwire handshake; first parameter: the
//! logical buffer size), ESC.H / ESC.I handshake mode 1 / 2 (block size or
//! XOFF threshold; enquiry character; acknowledge string or XON trigger),
//! ESC.M output mode (terminator in parameters 4 and 5), ESC.N extended
//! handshake (intercharacter delay; XOFF trigger), ESC.K abort graphics,
//! ESC.J abort device control, ESC.R reset handshake. Replies end with the
//! output terminator, CR unless ESC.M changed it.

/// Extended (I/O) error numbers reported by `ESC.E`.
pub(crate) mod ext {
    /// Byte after "ESC." is not a known instruction.
    pub const BAD_INSTRUCTION: u32 = 11;
    /// Bad byte inside a device-control instruction's parameters.
    pub const BAD_PARAMETER_BYTE: u32 = 12;
    /// Parameter out of range.
    pub const OUT_OF_RANGE: u32 = 13;
    /// Too many parameters.
    pub const TOO_MANY: u32 = 14;
    /// Input buffer overflow: bytes were lost.
    pub const OVERFLOW: u32 = 16;
}

/// ESC.O bit: buffer empty.
pub(crate) const STATUS_BUFFER_EMPTY: u32 = 8;
/// ESC.O bit: paper lever raised (plotting paused).
pub(crate) const STATUS_LEVER_UP: u32 = 32;

/// Default block size / XOFF threshold after power-on or ESC.R (manual: 80 bytes).
pub(crate) const DEFAULT_BLOCK: usize = 80;
/// The XON level the manual fixes: XON once this few bytes are stored (or
/// fewer when the XOFF threshold is large; see [`Handshake::xon_level`]).
pub(crate) const XON_STORED_LEVEL: usize = 128;
/// Longest parameter value (ESC parameters are small integers; anything
/// longer is out of range, not an overflow of ours).
const MAX_ESC_PARAM: u32 = 65_535;

/// Where we are in reading a device-control instruction.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) enum EscState {
    /// Not in one: bytes are data.
    #[default]
    None,
    /// Read ESC.
    Esc,
    /// Read "ESC.".
    Dot,
    /// Reading parameters of `letter`.
    Params { letter: u8, params: Vec<Option<u32>>, cur: Option<u32> },
    /// A parameterless instruction just ended; an optional ':' follows.
    AfterNoParam,
}

/// What a complete device-control instruction asks for.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum EscCommand {
    /// A letter without parameters (B, E, O, L, K, J, R, and the on/off ones).
    Plain(u8),
    /// A letter with its parameters (`None` for defaulted ones).
    WithParams(u8, Vec<Option<u32>>),
}

/// What feeding a byte produced.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum EscFeed {
    /// The byte is data for the buffer.
    Data,
    /// The byte belonged to a device-control instruction, nothing to do yet.
    Consumed,
    /// A complete instruction.
    Command(EscCommand),
    /// A malformed instruction: the extended error to raise.
    Error(u32),
}

const ESC: u8 = 0x1b;

/// Maximum parameters each instruction takes (ESC.I/H/N: a string of up to 10 characters).
fn max_params(letter: u8) -> usize {
    match letter {
        b'@' => 2,
        b'H' | b'I' => 12,
        b'M' => 6,
        b'N' => 11,
        _ => 0,
    }
}

impl EscState {
    /// Reads one byte.
    pub fn feed(&mut self, b: u8) -> EscFeed {
        match std::mem::take(self) {
            EscState::None | EscState::AfterNoParam if b == ESC => {
                *self = EscState::Esc;
                EscFeed::Consumed
            }
            EscState::AfterNoParam if b == b':' => EscFeed::Consumed,
            EscState::None | EscState::AfterNoParam => EscFeed::Data,
            EscState::Esc if b == b'.' => {
                *self = EscState::Dot;
                EscFeed::Consumed
            }
            // ESC not followed by '.' is not a device-control instruction.
            EscState::Esc => EscFeed::Data,
            EscState::Dot => {
                let letter = b.to_ascii_uppercase();
                match letter {
                    b'B' | b'E' | b'O' | b'L' | b'K' | b'J' | b'R' | b'(' | b')' | b'Y' | b'Z' => {
                        *self = EscState::AfterNoParam;
                        EscFeed::Command(EscCommand::Plain(letter))
                    }
                    b'@' | b'H' | b'I' | b'M' | b'N' => {
                        *self = EscState::Params { letter, params: Vec::new(), cur: None };
                        EscFeed::Consumed
                    }
                    _ => EscFeed::Error(ext::BAD_INSTRUCTION),
                }
            }
            EscState::Params { letter, mut params, cur } => match b {
                b'0'..=b'9' => {
                    let v = cur.unwrap_or(0).saturating_mul(10).saturating_add(u32::from(b - b'0'));
                    *self = EscState::Params { letter, params, cur: Some(v.min(MAX_ESC_PARAM + 1)) };
                    EscFeed::Consumed
                }
                b';' | b':' => {
                    params.push(cur);
                    if params.len() > max_params(letter) {
                        // Swallow the rest of the instruction after too many parameters.
                        if b == b';' {
                            *self = EscState::Params { letter, params, cur: None };
                            return EscFeed::Consumed;
                        }
                        return EscFeed::Error(ext::TOO_MANY);
                    }
                    if b == b':' {
                        if params.iter().flatten().any(|&v| v > MAX_ESC_PARAM) {
                            return EscFeed::Error(ext::OUT_OF_RANGE);
                        }
                        return EscFeed::Command(EscCommand::WithParams(letter, params));
                    }
                    *self = EscState::Params { letter, params, cur: None };
                    EscFeed::Consumed
                }
                _ => EscFeed::Error(ext::BAD_PARAMETER_BYTE),
            },
        }
    }

    /// True between instructions.
    pub fn is_idle(&self) -> bool {
        matches!(self, EscState::None | EscState::AfterNoParam)
    }
}

/// Handshake settings (ESC.@, ESC.H/I, ESC.N, ESC.M).
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Handshake {
    /// ESC.@ bit 0: hardwire (DTR/CTS) handshake.
    pub hardwire: bool,
    /// Block size for enquire/acknowledge and hardwire handshakes, and the
    /// XOFF threshold (free bytes) for XON/XOFF.
    pub block: usize,
    /// Enquiry character; `Some` enables enquire/acknowledge.
    pub enq: Option<u8>,
    /// Acknowledge string (enquire/acknowledge) or XON trigger (XON/XOFF).
    pub ack: Vec<u8>,
    /// XOFF trigger (ESC.N second parameter on).
    pub xoff: Vec<u8>,
    /// Output terminator for replies.
    pub terminator: Vec<u8>,
}

impl Default for Handshake {
    fn default() -> Self {
        Handshake { hardwire: false, block: DEFAULT_BLOCK, enq: None, ack: Vec::new(), xoff: Vec::new(), terminator: vec![b'\r'] }
    }
}

impl Handshake {
    /// XON/XOFF is on when both trigger strings are set and no enquiry
    /// character is (the manual: "the enquiry character must be defaulted or 0").
    pub fn xon_xoff(&self) -> bool {
        self.enq.is_none() && !self.ack.is_empty() && !self.xoff.is_empty()
    }

    /// Stored bytes at or below which XON is sent after an XOFF: 128, or
    /// lower when the XOFF threshold leaves less room (manual: "one more byte
    /// than required by the XOFF threshold").
    pub fn xon_level(&self, capacity: usize) -> usize {
        XON_STORED_LEVEL.min(capacity.saturating_sub(self.block + 1))
    }
}

/// Characters from parameters (a 0 or missing parameter ends the string).
pub(crate) fn chars(params: &[Option<u32>]) -> Result<Vec<u8>, u32> {
    let mut s = Vec::new();
    for p in params {
        match p {
            None | Some(0) => break,
            Some(v) if *v < 128 => s.push(*v as u8),
            Some(_) => return Err(ext::OUT_OF_RANGE),
        }
    }
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn feed_all(s: &mut EscState, bytes: &[u8]) -> Vec<EscFeed> {
        bytes.iter().map(|&b| s.feed(b)).filter(|f| *f != EscFeed::Consumed).collect()
    }

    #[test]
    fn plain_and_parameterised_instructions() {
        let mut s = EscState::default();
        assert_eq!(feed_all(&mut s, b"\x1b.B"), vec![EscFeed::Command(EscCommand::Plain(b'B'))]);
        // An optional ':' after a plain instruction is swallowed.
        assert_eq!(feed_all(&mut s, b":P"), vec![EscFeed::Data]);
        assert_eq!(
            feed_all(&mut s, b"\x1b.I81;;17:"),
            vec![EscFeed::Command(EscCommand::WithParams(b'I', vec![Some(81), None, Some(17)]))]
        );
        assert!(s.is_idle());
    }

    #[test]
    fn malformed_instructions_raise_extended_errors() {
        let mut s = EscState::default();
        assert_eq!(feed_all(&mut s, b"\x1b.Q"), vec![EscFeed::Error(ext::BAD_INSTRUCTION)]);
        assert_eq!(feed_all(&mut s, b"\x1b.@1x"), vec![EscFeed::Error(ext::BAD_PARAMETER_BYTE)]);
        assert_eq!(feed_all(&mut s, b"\x1b.@1;2;3:"), vec![EscFeed::Error(ext::TOO_MANY)]);
        assert_eq!(feed_all(&mut s, b"\x1b.@99999999:"), vec![EscFeed::Error(ext::OUT_OF_RANGE)]);
        assert!(s.is_idle());
        // ESC without '.' is data.
        assert_eq!(feed_all(&mut s, b"\x1bA"), vec![EscFeed::Data]);
    }

    #[test]
    fn xon_level_follows_the_threshold() {
        let mut h = Handshake::default();
        assert_eq!(h.xon_level(1024), 128);
        h.block = 1000;
        assert_eq!(h.xon_level(1024), 23);
        assert_eq!(chars(&[Some(17), Some(0), Some(5)]).unwrap(), vec![17]);
        assert_eq!(chars(&[Some(300)]), Err(ext::OUT_OF_RANGE));
    }
}
