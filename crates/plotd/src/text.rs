//! Text that came from outside, made safe to show: control characters
//! escaped (a job name cannot forge a line of `plotd jobs` or move the
//! terminal's cursor), and long input cut to a short excerpt (an error about
//! a 100 KB line does not repeat the line).

use std::borrow::Cow;
use std::fmt::Write as _;

/// Longest line of an error message or reason shown to a client, in
/// characters; longer lines are cut in the middle (`...`).
pub const MAX_LINE_CHARS: usize = 1000;
/// Most lines of one error message or reason; further lines are dropped.
pub const MAX_LINES: usize = 12;

/// Whether `c` must not reach a terminal as it is: C0 and C1 controls, DEL,
/// and the Unicode marks that reorder text on screen (bidirectional
/// embeddings, overrides and isolates).
fn is_unsafe(c: char) -> bool {
    c.is_control() || matches!(c, '\u{200E}' | '\u{200F}' | '\u{202A}'..='\u{202E}' | '\u{2066}'..='\u{2069}')
}

/// `s` with every control character escaped as Rust writes it in a string
/// (`\n`, `\r`, `\t`, `\u{1b}`); other text unchanged. Borrowed when there is
/// nothing to escape.
#[must_use]
pub fn escaped(s: &str) -> Cow<'_, str> {
    escaped_but(s, &[])
}

/// [`escaped`], keeping the characters in `keep` (such as `\n` for a
/// message of several lines).
fn escaped_but<'a>(s: &'a str, keep: &[char]) -> Cow<'a, str> {
    if !s.chars().any(|c| is_unsafe(c) && !keep.contains(&c)) {
        return Cow::Borrowed(s);
    }
    let mut out = String::with_capacity(s.len() + 8);
    for c in s.chars() {
        if is_unsafe(c) && !keep.contains(&c) {
            let _ = write!(out, "{}", c.escape_default());
        } else {
            out.push(c);
        }
    }
    Cow::Owned(out)
}

/// A message (an error, a job's failure reason) fit to show: control
/// characters escaped except line breaks, each line cut to
/// [`MAX_LINE_CHARS`] characters (keeping its start and end, where parsers
/// put the position and the caret), at most [`MAX_LINES`] lines.
#[must_use]
pub fn message(s: &str) -> String {
    let safe = escaped_but(s, &['\n']);
    let mut out = String::with_capacity(safe.len().min(MAX_LINES * (MAX_LINE_CHARS + 1)));
    let lines = safe.split('\n');
    for (i, line) in lines.enumerate() {
        if i == MAX_LINES {
            out.push_str("\n...");
            break;
        }
        if i > 0 {
            out.push('\n');
        }
        out.push_str(&cut_line(line));
    }
    out
}

/// `line` cut to [`MAX_LINE_CHARS`] characters: its first two thirds and its
/// last third, joined by `...`.
fn cut_line(line: &str) -> Cow<'_, str> {
    let n = line.chars().count();
    if n <= MAX_LINE_CHARS {
        return Cow::Borrowed(line);
    }
    let head = MAX_LINE_CHARS * 2 / 3;
    let tail = MAX_LINE_CHARS - head - 3;
    let start: String = line.chars().take(head).collect();
    let end: String = line.chars().skip(n - tail).collect();
    Cow::Owned(format!("{start}...{end}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn control_characters_are_escaped_and_plain_text_borrowed() {
        assert!(matches!(escaped("plot-1.hpgl"), Cow::Borrowed(_)));
        assert_eq!(escaped("a\u{1b}[2K\r\n   99  done"), "a\\u{1b}[2K\\r\\n   99  done");
        assert_eq!(escaped("x\u{9b}y\u{7f}\u{202e}txt.exe"), "x\\u{9b}y\\u{7f}\\u{202e}txt.exe");
        assert_eq!(escaped("tab\there"), "tab\\there");
        // Non-ASCII text that is not a control stays as it is.
        assert_eq!(escaped("Zürich — 東京"), "Zürich — 東京");
    }

    #[test]
    fn long_lines_are_cut_keeping_both_ends_and_lines_are_bounded() {
        let line = format!("scene.toml:3: {}<- here", "x".repeat(100_000));
        let m = message(&line);
        assert_eq!(m.chars().count(), MAX_LINE_CHARS);
        assert!(m.starts_with("scene.toml:3: xxx") && m.ends_with("x<- here") && m.contains("..."), "{m}");
        let many = (0..100).map(|i| format!("line {i}")).collect::<Vec<_>>().join("\n");
        let m = message(&many);
        assert_eq!(m.lines().count(), MAX_LINES + 1);
        assert!(m.ends_with("line 11\n..."), "{m}");
        // Line breaks stay; other controls are escaped.
        assert_eq!(message("a\nb\rc\u{1b}"), "a\nb\\rc\\u{1b}");
        assert!(matches!(cut_line("short"), Cow::Borrowed(_)));
    }
}
