//! One line of G-code, as GRBL reads it: words, comments, system commands.

use std::fmt;

/// The longest line the reader accepts. GRBL's own buffer holds 80 characters;
/// files from other programs may be wider, so reading is more lenient than
/// writing, but bounded.
pub const MAX_LINE_CHARS: usize = 256;

/// A parsed line.
#[derive(Clone, Debug, PartialEq)]
pub enum Line {
    /// A block of words (possibly none: a blank or comment-only line).
    Block(Block),
    /// A GRBL system command such as `$H` or `$$` (the text after the `$`).
    System(String),
}

/// The words of one block, in order, and its comment.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Block {
    /// Letter-value words, letters upper-cased.
    pub words: Vec<Word>,
    /// Text of the first `( )` or `;` comment, if any.
    pub comment: Option<String>,
}

/// A letter and its number, such as `G1` or `X-12.5`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Word {
    /// The letter, upper case.
    pub letter: char,
    /// The number.
    pub value: f64,
}

impl Block {
    /// The value of the first word with `letter`, if any.
    #[must_use]
    pub fn get(&self, letter: char) -> Option<f64> {
        self.words.iter().find(|w| w.letter == letter).map(|w| w.value)
    }

    /// Whether the block has the word `letter value` (such as `G`, 1.0).
    #[must_use]
    pub fn has(&self, letter: char, value: f64) -> bool {
        self.words.iter().any(|w| w.letter == letter && w.value == value)
    }
}

/// A malformed line.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("column {column}: {problem}")]
pub struct LineError {
    /// 1-based column (character) of the problem.
    pub column: usize,
    /// What is wrong.
    pub problem: String,
}

impl fmt::Display for Word {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}{}", self.letter, self.value)
    }
}

/// Parses one line (without its line ending).
///
/// Spaces are ignored anywhere, as GRBL does; `( )` comments may appear between
/// words and `;` starts a comment to the end of the line; a `%` line (program
/// delimiter) is an empty block.
///
/// # Errors
/// [`LineError`] naming the column: a letter without a number, a malformed
/// number, an unclosed `(` comment, an unexpected character, a line longer
/// than [`MAX_LINE_CHARS`].
pub fn parse_line(line: &str) -> Result<Line, LineError> {
    let err = |column: usize, problem: String| Err(LineError { column, problem });
    if line.chars().count() > MAX_LINE_CHARS {
        return err(MAX_LINE_CHARS + 1, format!("line longer than {MAX_LINE_CHARS} characters"));
    }
    let trimmed = line.trim_start();
    if let Some(rest) = trimmed.strip_prefix('$') {
        return Ok(Line::System(rest.trim_end().to_owned()));
    }
    if trimmed.trim_end() == "%" {
        return Ok(Line::Block(Block::default()));
    }
    let chars: Vec<char> = line.chars().collect();
    let mut block = Block::default();
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        match c {
            ' ' | '\t' | '\r' => i += 1,
            '(' => {
                let Some(close) = chars[i..].iter().position(|&c| c == ')') else {
                    return err(i + 1, "comment '(' is not closed".to_owned());
                };
                block.comment.get_or_insert_with(|| chars[i + 1..i + close].iter().collect());
                i += close + 1;
            }
            ';' => {
                block.comment.get_or_insert_with(|| chars[i + 1..].iter().collect());
                break;
            }
            c if c.is_ascii_alphabetic() => {
                let letter = c.to_ascii_uppercase();
                let start = i + 1;
                let mut j = start;
                let mut text = String::new();
                while j < chars.len() {
                    let d = chars[j];
                    if d.is_ascii_digit() || d == '.' || ((d == '-' || d == '+') && text.trim().is_empty()) {
                        text.push(d);
                    } else if d != ' ' && d != '\t' {
                        break;
                    }
                    j += 1;
                }
                if text.is_empty() {
                    return err(i + 1, format!("word '{letter}' has no number"));
                }
                let digits = text.trim_start_matches(['+', '-']);
                let value = if digits.bytes().any(|b| b.is_ascii_digit()) && digits.matches('.').count() <= 1 {
                    text.parse::<f64>().ok()
                } else {
                    None
                };
                match value {
                    Some(value) => block.words.push(Word { letter, value }),
                    None => return err(start + 1, format!("malformed number {text:?} after '{letter}'")),
                }
                i = j;
            }
            other => return err(i + 1, format!("unexpected character {other:?}")),
        }
    }
    Ok(Line::Block(block))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn words(line: &str) -> Vec<String> {
        match parse_line(line).unwrap_or_else(|e| panic!("{line:?}: {e}")) {
            Line::Block(b) => b.words.iter().map(ToString::to_string).collect(),
            Line::System(s) => vec![format!("${s}")],
        }
    }

    #[test]
    fn words_spaces_and_comments() {
        assert_eq!(words("G1 X10.5 Y-2 F3000"), ["G1", "X10.5", "Y-2", "F3000"]);
        assert_eq!(words("g0x1y2"), ["G0", "X1", "Y2"]);
        assert_eq!(words("G1 X 1 0 Y.5"), ["G1", "X10", "Y0.5"]);
        assert_eq!(words("(pen 2) T2 ; change pen"), ["T2"]);
        assert_eq!(words("G1 (mid) X1"), ["G1", "X1"]);
        assert_eq!(words(""), Vec::<String>::new());
        assert_eq!(words("%"), Vec::<String>::new());
        assert_eq!(words("$H"), ["$H"]);
        let Line::Block(b) = parse_line("M3 S1000 (pen down)").unwrap() else { panic!() };
        assert_eq!(b.comment.as_deref(), Some("pen down"));
        assert_eq!(b.get('S'), Some(1000.0));
        assert!(b.has('M', 3.0));
    }

    #[test]
    fn bad_lines_name_the_column() {
        let cases: &[(&str, usize, &str)] = &[
            ("G1 X", 4, "no number"),
            ("G1 X1.2.3", 5, "malformed number"),
            ("G1 (oops X1", 4, "not closed"),
            ("G1 X1 #", 7, "unexpected character"),
            ("G1 X-", 5, "malformed number"),
        ];
        for (line, column, msg) in cases {
            let e = parse_line(line).unwrap_err();
            assert_eq!(e.column, *column, "{line:?}: {e}");
            assert!(e.problem.contains(msg), "{e}");
        }
        assert!(parse_line(&"G1 ".repeat(100)).is_err());
    }
}
