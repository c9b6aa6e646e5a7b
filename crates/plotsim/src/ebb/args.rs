//! Reading a command's arguments the way `extract_number` and
//! `extract_string` in `UBW.c` do (identical in 2.8.1 and 3.0.2).
//!
//! Each argument is a comma and then up to ten decimal digits, with a minus
//! sign for the signed types; no digits at all reads as 0. The digits
//! accumulate in an unsigned 32-bit register (so ten digits may wrap), then
//! the value is range-checked for its type. A missing required argument sets
//! error !4, a value out of range !6; a byte other than a comma where the next
//! argument should start prints `!5 Err: Need comma next, found: 'x'` at once
//! (for a required argument; an optional one is just absent). Reading goes
//! on after an error, as on the board.

use super::reply::{flag, Le, Out};

/// The firmware's argument types.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Ty {
    UChar,
    Int,
    UInt,
    Long,
    ULong,
    /// One byte, upper-cased.
    UpperChar,
}

/// Why an argument has no value.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Absent {
    Missing,
    NoComma,
    OutOfRange,
}

/// The arguments of one command: its bytes after the command letters, the
/// line end included.
#[derive(Clone, Debug)]
pub(crate) struct Args {
    bytes: Vec<u8>,
    pos: usize,
}

const CR: u8 = b'\r';

impl Args {
    /// `line` without its line end; `pos` just past the command's letters.
    pub fn new(line: &[u8], pos: usize) -> Args {
        let mut bytes = line.to_vec();
        bytes.push(CR);
        Args { bytes, pos: pos.min(line.len()) }
    }

    /// The byte under the cursor (past the end reads as the line end).
    pub fn peek(&self) -> u8 {
        self.bytes.get(self.pos).copied().unwrap_or(CR)
    }

    fn advance(&mut self) {
        if self.pos < self.bytes.len() - 1 {
            self.pos += 1;
        }
    }

    /// Everything was read.
    pub fn at_end(&self) -> bool {
        self.peek() == CR
    }

    /// Checks for the comma and skips it; Err when the argument is absent.
    fn comma(&mut self, required: bool, out: &mut Out) -> Result<(), Absent> {
        if self.at_end() {
            if required {
                out.flag(flag::MISSING);
            }
            return Err(Absent::Missing);
        }
        if self.peek() != b',' {
            if required {
                let mut message = b"!5 Err: Need comma next, found: '".to_vec();
                message.extend_from_slice(&[self.peek(), b'\'']);
                out.error_bytes(5, &message, Le::Norm);
                out.flag(flag::PRINTED);
            }
            return Err(Absent::NoComma);
        }
        self.advance();
        if self.at_end() {
            if required {
                out.flag(flag::MISSING);
            }
            return Err(Absent::Missing);
        }
        Ok(())
    }

    /// `extract_number`: the value as an i64 (a ULong as its unsigned value).
    pub fn number(&mut self, ty: Ty, required: bool, out: &mut Out) -> Result<i64, Absent> {
        self.comma(required, out)?;
        if ty == Ty::UpperChar {
            let b = self.peek();
            self.advance();
            return Ok(i64::from(b.to_ascii_uppercase()));
        }
        let mut negative = false;
        if self.peek() == b'-' {
            if matches!(ty, Ty::UChar | Ty::UInt | Ty::ULong) {
                out.flag(flag::OUT_OF_RANGE);
                return Err(Absent::OutOfRange);
            }
            negative = true;
            self.advance();
        }
        let mut acc: u32 = 0;
        for _ in 0..10 {
            let b = self.peek();
            if !b.is_ascii_digit() {
                break;
            }
            acc = acc.wrapping_mul(10).wrapping_add(u32::from(b - b'0'));
            self.advance();
        }
        let limit: u32 = match (ty, negative) {
            (Ty::Int, true) => 32_768,
            (Ty::Long, true) => 0x8000_0000,
            (Ty::UChar, _) => 255,
            (Ty::Int, false) => 32_767,
            (Ty::UInt, _) => 65_535,
            (Ty::Long, false) => 0x7FFF_FFFF,
            _ => u32::MAX,
        };
        if acc > limit {
            out.flag(flag::OUT_OF_RANGE);
            return Err(Absent::OutOfRange);
        }
        Ok(if negative { -i64::from(acc) } else { i64::from(acc) })
    }

    /// `extract_string`: up to `max` bytes to the next comma or the line end.
    pub fn string(&mut self, max: usize, out: &mut Out) -> Vec<u8> {
        if self.comma(true, out).is_err() {
            return Vec::new();
        }
        let mut s = Vec::new();
        while !self.at_end() && self.peek() != b',' && s.len() < max {
            s.push(self.peek());
            self.advance();
        }
        s
    }
}

/// Typed helpers for the commands: absent arguments leave the default.
impl Args {
    pub fn req(&mut self, ty: Ty, out: &mut Out) -> Option<i64> {
        self.number(ty, true, out).ok()
    }

    pub fn opt(&mut self, ty: Ty, out: &mut Out) -> Option<i64> {
        self.number(ty, false, out).ok()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ebb::firmware::Firmware;

    fn out() -> Out {
        Out::new(Firmware::V2_8_1, false, true)
    }

    #[test]
    fn numbers_read_as_the_firmware_reads_them() {
        let mut o = out();
        let mut a = Args::new(b"SM,1000,-250,,9999999999,-2147483648,x", 2);
        assert_eq!(a.req(Ty::ULong, &mut o), Some(1000));
        assert_eq!(a.req(Ty::Long, &mut o), Some(-250));
        assert_eq!(a.req(Ty::Long, &mut o), Some(0), "no digits read as 0");
        // Ten nines wrap in the 32-bit register: 9999999999 mod 2^32.
        assert_eq!(a.req(Ty::ULong, &mut o), Some(1_410_065_407));
        assert_eq!(a.req(Ty::Long, &mut o), Some(-2_147_483_648));
        assert_eq!(a.req(Ty::UChar, &mut o), Some(0), "',x' reads no digits");
        assert_eq!(o.errors, 0);
        assert!(!a.at_end(), "the x is left for the extra-parameter check");
    }

    #[test]
    fn absent_and_bad_arguments_set_the_flags() {
        let mut o = out();
        let mut a = Args::new(b"SC,300", 2);
        assert_eq!(a.number(Ty::UChar, true, &mut o), Err(Absent::OutOfRange));
        assert_eq!(o.errors, flag::OUT_OF_RANGE);
        assert_eq!(a.number(Ty::UInt, false, &mut o), Err(Absent::Missing));
        assert_eq!(a.number(Ty::UInt, true, &mut o), Err(Absent::Missing));
        assert_eq!(o.errors, flag::OUT_OF_RANGE | flag::MISSING);
        let mut o = out();
        let mut a = Args::new(b"SMX", 2);
        assert_eq!(a.number(Ty::ULong, true, &mut o), Err(Absent::NoComma));
        assert_eq!(String::from_utf8(o.bytes).unwrap(), "!5 Err: Need comma next, found: 'X'\r\n");
        let mut o = out();
        let mut a = Args::new(b"EM,-1", 2);
        assert_eq!(a.number(Ty::UChar, true, &mut o), Err(Absent::OutOfRange));
    }
}
