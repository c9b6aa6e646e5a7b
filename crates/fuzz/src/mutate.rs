//! Byte-level mutation: the changes a careless editor, a truncated transfer
//! or an attacker make to a file, drawn from a seeded generator so a run is
//! repeatable from its seed.

/// Numbers that have broken parsers and engines: huge, tiny, signed zero,
/// not finite, just past integer widths.
pub const NUMBERS: &[&str] = &[
    "0",
    "-0",
    "1",
    "-1",
    "0.0",
    "1e-300",
    "-1e-300",
    "1e10",
    "-1e10",
    "1e12",
    "9.2e18",
    "-9.2e18",
    "1e100",
    "1e308",
    "-1e308",
    "1e400",
    "nan",
    "NaN",
    "inf",
    "-inf",
    "4294967295",
    "4294967296",
    "2147483648",
    "-2147483649",
    "18446744073709551616",
    "65536",
    "1000000",
    "3e38",
    "999999999999",
    "0x10",
    "1e",
    ".",
    "-",
    "+",
];

/// A small, fast, seeded generator (xorshift64*): repeatable, no dependency.
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    /// A generator from `seed` (any value; zero is moved off zero).
    #[must_use]
    pub fn new(seed: u64) -> Rng {
        Rng(seed ^ 0x9e37_79b9_7f4a_7c15 | 1)
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }

    /// A number in `0..n` (`n` > 0).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }

    /// True with probability 1 / `n`.
    pub fn one_in(&mut self, n: usize) -> bool {
        self.below(n) == 0
    }

    /// A random element of a non-empty slice.
    pub fn pick<'a, T>(&mut self, items: &'a [T]) -> &'a T {
        &items[self.below(items.len())]
    }
}

/// Applies one to eight random mutations to `data`, keeping it at most
/// `max_len` bytes. `dictionary` holds tokens of the format (keys, tags,
/// mnemonics) to insert; `others` are other inputs to splice from.
pub fn mutate(data: &mut Vec<u8>, rng: &mut Rng, dictionary: &[&[u8]], others: &[&[u8]], max_len: usize) {
    let rounds = 1 + rng.below(8);
    for _ in 0..rounds {
        mutate_once(data, rng, dictionary, others);
    }
    data.truncate(max_len);
}

fn mutate_once(data: &mut Vec<u8>, rng: &mut Rng, dictionary: &[&[u8]], others: &[&[u8]]) {
    let len = data.len();
    let at = |rng: &mut Rng| if len == 0 { 0 } else { rng.below(len + 1) };
    match rng.below(11) {
        // Flip a bit.
        0 if len > 0 => {
            let i = rng.below(len);
            data[i] ^= 1 << rng.below(8);
        }
        // A byte that means something to text formats.
        1 if len > 0 => {
            let i = rng.below(len);
            data[i] = *rng.pick(b"\0\xff\n\r\t \"'[]{}<>,;:.-+e9=#/\\&\x1b\x03");
        }
        // Delete a range.
        2 if len > 0 => {
            let i = rng.below(len);
            let most = if rng.one_in(4) { len - i } else { 16.min(len - i) };
            let n = 1 + rng.below(most);
            data.drain(i..i + n);
        }
        // Duplicate a range somewhere.
        3 if len > 0 => {
            let (i, n) = range(rng, len);
            let chunk = data[i..i + n].to_vec();
            let j = at(rng);
            data.splice(j..j, chunk);
        }
        // Replace a number with one that has broken things before.
        4 => {
            let numbers = number_spans(data);
            let new = rng.pick(NUMBERS).as_bytes();
            if numbers.is_empty() {
                let j = at(rng);
                data.splice(j..j, new.iter().copied());
            } else {
                let (i, j) = *rng.pick(&numbers);
                data.splice(i..j, new.iter().copied());
            }
        }
        // A token of the format.
        5 | 6 if !dictionary.is_empty() => {
            let j = at(rng);
            data.splice(j..j, rng.pick(dictionary).iter().copied());
        }
        // A piece of another input.
        7 if !others.is_empty() => {
            let other = rng.pick(others);
            if !other.is_empty() {
                let (i, n) = range(rng, other.len());
                let j = at(rng);
                data.splice(j..j, other[i..i + n].iter().copied());
            }
        }
        // Repeat a short piece many times: deep nesting, long lines, huge counts.
        8 if len > 0 => {
            let i = rng.below(len);
            let n = 1 + rng.below(16.min(len - i));
            let most = if rng.one_in(4) { 5000 } else { 50 };
            let times = 2 + rng.below(most);
            let chunk = data[i..i + n].repeat(times);
            data.splice(i..i, chunk);
        }
        // Cut the end off.
        9 if len > 0 => data.truncate(rng.below(len)),
        // Swap two bytes.
        _ if len > 1 => {
            let (i, j) = (rng.below(len), rng.below(len));
            data.swap(i, j);
        }
        _ => data.push(*rng.pick(b"0a<[")),
    }
}

/// A random range `(start, len)` in `0..len`, mostly short.
fn range(rng: &mut Rng, len: usize) -> (usize, usize) {
    let i = rng.below(len);
    let most = if rng.one_in(4) { len - i } else { 64.min(len - i) };
    let n = 1 + rng.below(most);
    (i, n)
}

/// Byte spans of the numbers in `data` (a digit run with its sign, point and exponent).
fn number_spans(data: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < data.len() {
        if data[i].is_ascii_digit() {
            let mut start = i;
            if start > 0 && matches!(data[start - 1], b'-' | b'+') {
                start -= 1;
            }
            while i < data.len() && (data[i].is_ascii_digit() || matches!(data[i], b'.' | b'e' | b'E' | b'-' | b'+')) {
                i += 1;
            }
            out.push((start, i));
        } else {
            i += 1;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn repeatable_from_the_seed_and_bounded() {
        let run = |seed| {
            let mut rng = Rng::new(seed);
            let mut d = b"[camera]\neye = [1.0, 2.0, 3.0]\n".to_vec();
            for _ in 0..200 {
                mutate(&mut d, &mut rng, &[b"[[mesh]]"], &[b"other input"], 4096);
            }
            d
        };
        assert_eq!(run(7), run(7));
        assert_ne!(run(7), run(8));
        assert!(run(9).len() <= 4096);
    }

    #[test]
    fn numbers_are_found_with_sign_and_exponent() {
        assert_eq!(number_spans(b"a = -1.5e3, b = 2"), vec![(4, 10), (16, 17)]);
    }
}
