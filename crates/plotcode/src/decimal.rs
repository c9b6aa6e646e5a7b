//! Coordinates as short decimal text: what `format!("{v:.N}")` writes, with
//! trailing zeros, a bare point and a negative zero dropped, but written
//! with integer arithmetic.
//!
//! `std::fmt` rounds the exact binary value of `v` to `N` places, which
//! takes an arbitrary-precision algorithm per number; on a drawing of
//! millions of points that was a third of a whole render. Here `v * 10^N` is
//! rounded as a float instead. That product is off from the exact one by at
//! most half a unit in its last place, so whenever its fraction is clearly
//! away from one half both round to the same integer, and the digits are
//! that integer's. The rare number near a tie (or too large for the bound)
//! goes through `std::fmt`, so **the text is always exactly what `std::fmt`
//! writes** (trimmed), byte for byte.

/// Products `v * 10^N` at most this large are written by the fast path: their
/// rounding error (half an ulp, at most 2^-13) stays far below [`TIE_MARGIN`].
const FAST_LIMIT: f64 = (1u64 << 40) as f64;

/// How far from one half a product's fraction must be for the fast path: a
/// product nearer a tie than this may round either way in exact arithmetic.
const TIE_MARGIN: f64 = 1.0 / 4096.0;

/// 10^0 ..= 10^9, exact in `f64`.
const POWERS_OF_TEN: [f64; 10] = [1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9];

/// 1.5 * 2^52: see [`scaled`].
const ROUNDER: f64 = 6_755_399_441_055_744.0;

/// Appends `v` with `D` places (at most 9), trailing zeros and a trailing
/// point dropped, and `-0` written as `0`, to a byte buffer: the writers
/// build their text as bytes and check it is UTF-8 once per piece (checking
/// each number's few bytes cost as much as finding its digits).
pub(crate) fn push<const D: u32>(out: &mut Vec<u8>, v: f64) {
    match scaled::<D>(v) {
        Some(n) => {
            let mut buf = [0u8; 24];
            let at = write_back::<D>(&mut buf, 24, n);
            out.extend_from_slice(&buf[at..]);
        }
        None => push_std(out, v, D),
    }
}

/// Appends `a`, `between` and `b` as [`push`] writes them: a point's two
/// coordinates go out in one copy, which on a drawing of millions of points
/// costs less than the digits of either.
pub(crate) fn push_pair<const D: u32>(out: &mut Vec<u8>, a: f64, between: u8, b: f64) {
    if let (Some(m), Some(n)) = (scaled::<D>(a), scaled::<D>(b)) {
        let mut buf = [0u8; 48];
        let at = write_back::<D>(&mut buf, 48, n);
        buf[at - 1] = between;
        let at = write_back::<D>(&mut buf, at - 1, m);
        out.extend_from_slice(&buf[at..]);
    } else {
        push::<D>(out, a);
        out.push(between);
        push::<D>(out, b);
    }
}

/// Bytes [`int_pair`] may need: two signed 19-digit integers and a separator.
pub(crate) const PAIR_BYTES: usize = 41;

/// `a`, `between` and `b` as integers, written at the end of `buf`.
pub(crate) fn int_pair(buf: &mut [u8; PAIR_BYTES], a: i64, between: u8, b: i64) -> &[u8] {
    let at = write_back::<0>(buf, PAIR_BYTES, b);
    buf[at - 1] = between;
    let at = write_back::<0>(buf, at - 1, a);
    &buf[at..]
}

/// `v * 10^D` rounded to an integer, when that is sure to be the integer
/// `std::fmt` rounds to (see the module doc); `None` near a tie or past
/// [`FAST_LIMIT`].
fn scaled<const D: u32>(v: f64) -> Option<i64> {
    const { assert!(D <= 9) };
    let s = v * POWERS_OF_TEN[D as usize];
    // Rounds to an integer for |s| < 2^51 (adding and taking away 1.5 * 2^52
    // leaves no fraction bits); ties do not matter, they take the slow path.
    let r = (s + ROUNDER) - ROUNDER;
    // `s - r` is exact (Sterbenz), so this is the true distance to the tie.
    (s.abs() < FAST_LIMIT && (0.5 - (s - r).abs()) > TIE_MARGIN).then_some(r as i64)
}

/// "00" to "99", for writing two digits at a time.
const TWO_DIGITS: &[u8; 200] = b"\
    0001020304050607080910111213141516171819\
    2021222324252627282930313233343536373839\
    4041424344454647484950515253545556575859\
    6061626364656667686970717273747576777879\
    8081828384858687888990919293949596979899";

/// Writes the integer `n` scaled down by `10^D`, trimmed, so that it ends
/// just before `buf[end]`, and returns where it starts. Written backwards,
/// last digit first, so the trailing zeros of the fraction are dropped
/// before they are written. At most 19 digits, a point and a sign: `end`
/// must leave room for 21 bytes (15 for an `n` below [`FAST_LIMIT`]).
fn write_back<const D: u32>(buf: &mut [u8], end: usize, n: i64) -> usize {
    let mut at = end;
    let mut m = n.unsigned_abs();
    let mut places = D;
    while places > 0 && m % 10 == 0 {
        m /= 10;
        places -= 1;
    }
    if places > 0 {
        while places >= 2 {
            let d = 2 * (m % 100) as usize;
            m /= 100;
            at -= 2;
            buf[at..at + 2].copy_from_slice(&TWO_DIGITS[d..d + 2]);
            places -= 2;
        }
        if places == 1 {
            at -= 1;
            buf[at] = b'0' + (m % 10) as u8;
            m /= 10;
        }
        at -= 1;
        buf[at] = b'.';
    }
    // The whole part has a digit at least: `0.5`, and `0` for zero.
    while m >= 100 {
        let d = 2 * (m % 100) as usize;
        m /= 100;
        at -= 2;
        buf[at..at + 2].copy_from_slice(&TWO_DIGITS[d..d + 2]);
    }
    if m >= 10 {
        let d = 2 * m as usize;
        at -= 2;
        buf[at..at + 2].copy_from_slice(&TWO_DIGITS[d..d + 2]);
    } else {
        at -= 1;
        buf[at] = b'0' + m as u8;
    }
    if n < 0 {
        at -= 1;
        buf[at] = b'-';
    }
    at
}

/// The reference: `std::fmt` with `decimals` places, trimmed the same way.
fn push_std(out: &mut Vec<u8>, v: f64, decimals: u32) {
    let mut text = format!("{v:.prec$}", prec = decimals as usize);
    if text.contains('.') {
        let trimmed = text.trim_end_matches('0').trim_end_matches('.').len();
        text.truncate(trimmed);
    }
    out.extend_from_slice(if text == "-0" { b"0" } else { text.as_bytes() });
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fast(v: f64, d: u32) -> String {
        let mut s = Vec::new();
        match d {
            0 => push::<0>(&mut s, v),
            1 => push::<1>(&mut s, v),
            2 => push::<2>(&mut s, v),
            3 => push::<3>(&mut s, v),
            6 => push::<6>(&mut s, v),
            9 => push::<9>(&mut s, v),
            _ => unreachable!("no test of {d} places"),
        }
        String::from_utf8(s).unwrap()
    }

    fn reference(v: f64, d: u32) -> String {
        let mut s = Vec::new();
        push_std(&mut s, v, d);
        String::from_utf8(s).unwrap()
    }

    #[test]
    fn the_reference_trims_as_documented() {
        assert_eq!(reference(12.0, 3), "12");
        assert_eq!(reference(-2.5, 3), "-2.5");
        assert_eq!(reference(-0.0001, 3), "0");
        assert_eq!(reference(-0.0, 3), "0");
        assert_eq!(reference(0.0205, 2), "0.02");
        assert_eq!(reference(1234.5, 0), "1234");
    }

    #[test]
    fn same_text_as_std_fmt() {
        let mut s = 0x2545_F491_4F6C_DD1Du64;
        let mut next = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            s
        };
        let mut values = vec![0.0, -0.0, 1.0, -1.0, 0.5, 0.0005, 0.0015, 2.5005, -2.5005, 1e-9, 1e12, -1e12, 1e300, f64::MAX];
        for _ in 0..200_000 {
            let r = next();
            let unit = (r >> 11) as f64 / (1u64 << 53) as f64;
            let v = match r % 4 {
                // Page coordinates.
                0 => unit * 600.0 - 100.0,
                // Exactly on, or a hair off, a multiple of 1/10^4: ties and near-ties.
                1 => ((unit * 4e6).round() / 1e4) * if r & 16 == 0 { 1.0 } else { -1.0 },
                2 => (unit * 4e6).round() / 2e4 + f64::from((r >> 8) as u8 as i8) * 1e-15,
                // Any magnitude.
                _ => f64::from_bits(r & !(0x7ffu64 << 52) | (((r >> 52) % 0x7ff) << 52)),
            };
            values.push(v);
        }
        for v in values {
            for d in [0, 1, 2, 3, 6, 9] {
                assert_eq!(fast(v, d), reference(v, d), "{v:e} with {d} places");
            }
        }
    }

    #[test]
    fn a_pair_is_its_two_numbers_either_side_of_the_separator() {
        // Fast and slow numbers on either side: near ties, huge, tiny.
        let values = [0.0, -0.0, 12.5, -3.0005, 0.0015, 2.5005, 1e13, -1e300, 1e-9, 999.9996, -0.0004];
        for &a in &values {
            for &b in &values {
                let mut s = Vec::new();
                push_pair::<3>(&mut s, a, b',', b);
                assert_eq!(String::from_utf8(s).unwrap(), format!("{},{}", fast(a, 3), fast(b, 3)), "{a:e} {b:e}");
            }
        }
    }

    #[test]
    fn integer_pairs_as_std_writes_them() {
        let mut buf = [0u8; PAIR_BYTES];
        for (a, b) in [(0, 0), (-1, 10), (99, -100), (1234567, -7654321), (i64::MIN, i64::MAX), (i64::MAX, i64::MIN)] {
            assert_eq!(int_pair(&mut buf, a, b';', b), format!("{a};{b}").as_bytes());
        }
    }

    #[test]
    fn small_fractions_keep_their_leading_zeros() {
        assert_eq!(fast(1.002, 3), "1.002");
        assert_eq!(fast(-0.05, 3), "-0.05");
        assert_eq!(fast(0.3333, 3), "0.333");
        assert_eq!(fast(-0.0004, 3), "0");
        assert_eq!(fast(7.0, 3), "7");
    }
}
