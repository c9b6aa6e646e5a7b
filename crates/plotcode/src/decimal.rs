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

use std::fmt::Write as _;

/// Products `v * 10^N` at most this large are written by the fast path: their
/// rounding error (half an ulp, at most 2^-13) stays far below [`TIE_MARGIN`].
const FAST_LIMIT: f64 = (1u64 << 40) as f64;

/// How far from one half a product's fraction must be for the fast path: a
/// product nearer a tie than this may round either way in exact arithmetic.
const TIE_MARGIN: f64 = 1.0 / 4096.0;

/// 10^0 ..= 10^9, exact in `f64`.
const POWERS_OF_TEN: [f64; 10] = [1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9];

/// 1.5 * 2^52: see [`push`].
const ROUNDER: f64 = 6_755_399_441_055_744.0;

/// Appends `v` with `decimals` places (at most 9), trailing zeros and a
/// trailing point dropped, and `-0` written as `0`.
pub(crate) fn push(out: &mut String, v: f64, decimals: u32) {
    debug_assert!(decimals <= 9);
    let s = v * POWERS_OF_TEN[decimals as usize];
    // Rounds to an integer for |s| < 2^51 (adding and taking away 1.5 * 2^52
    // leaves no fraction bits); ties do not matter, they take the slow path.
    let r = (s + ROUNDER) - ROUNDER;
    // `s - r` is exact (Sterbenz), so this is the true distance to the tie.
    if s.abs() < FAST_LIMIT && (0.5 - (s - r).abs()) > TIE_MARGIN {
        push_scaled(out, r as i64, decimals);
    } else {
        push_std(out, v, decimals);
    }
}

/// Appends the integer `n` scaled down by `10^decimals`, trimmed: its
/// digits formatted once and split at the point, rather than as two numbers
/// made by a division and a remainder by a power of ten known only at run
/// time.
fn push_scaled(out: &mut String, n: i64, decimals: u32) {
    if n == 0 {
        out.push('0');
        return;
    }
    if n < 0 {
        out.push('-');
    }
    let mut buf = itoa::Buffer::new();
    let digits = buf.format(n.unsigned_abs());
    let places = decimals as usize;
    let (whole, fraction) = digits.split_at(digits.len().saturating_sub(places));
    out.push_str(if whole.is_empty() { "0" } else { whole });
    let fraction = fraction.trim_end_matches('0');
    if !fraction.is_empty() {
        out.push('.');
        // The zeros after the point that a short number has no digits for.
        for _ in digits.len().min(places)..places {
            out.push('0');
        }
        out.push_str(fraction);
    }
}

/// The reference: `std::fmt` with `decimals` places, trimmed the same way.
fn push_std(out: &mut String, v: f64, decimals: u32) {
    let from = out.len();
    let _ = write!(out, "{v:.prec$}", prec = decimals as usize);
    if out[from..].contains('.') {
        let trimmed = out.trim_end_matches('0').trim_end_matches('.').len();
        out.truncate(trimmed);
    }
    if &out[from..] == "-0" {
        out.truncate(from);
        out.push('0');
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fast(v: f64, d: u32) -> String {
        let mut s = String::new();
        push(&mut s, v, d);
        s
    }

    fn reference(v: f64, d: u32) -> String {
        let mut s = String::new();
        push_std(&mut s, v, d);
        s
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
            for d in [0, 2, 3, 6] {
                assert_eq!(fast(v, d), reference(v, d), "{v:e} with {d} places");
            }
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
