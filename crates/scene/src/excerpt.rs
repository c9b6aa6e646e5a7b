//! How errors quote the input: never more than a short excerpt of a line,
//! cell, name or path, so a 100 KB line does not become a 100 KB message
//! (issue #20). A leaf module: every loader's errors use it.

/// The most characters of the input an error message quotes.
pub const MAX_EXCERPT_CHARS: usize = 40;

/// `text` as an error message quotes it: whole when short, else its first
/// [`MAX_EXCERPT_CHARS`] characters and `...`, so a 100 KB line or field
/// does not become a 100 KB message.
#[must_use]
pub fn excerpt(text: &str) -> String {
    excerpt_of(text, MAX_EXCERPT_CHARS)
}

/// `text` cut to `chars` characters and `...` when longer.
pub(crate) fn excerpt_of(text: &str, chars: usize) -> String {
    match text.char_indices().nth(chars) {
        Some((cut, _)) => format!("{}...", &text[..cut]),
        None => text.to_owned(),
    }
}

/// A path as an error shows it: whole up to 120 characters, else its first
/// and last 50 (the directory's start and the file's name) around `...`:
/// paths come from the scene, and a 7 KB name must not make a 7 KB message.
#[must_use]
pub fn shown_path(path: &std::path::Path) -> String {
    let text = path.display().to_string();
    let chars: Vec<char> = text.chars().collect();
    if chars.len() <= 120 {
        return text;
    }
    let head: String = chars[..50].iter().collect();
    let tail: String = chars[chars.len() - 50..].iter().collect();
    format!("{head}...{tail}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn excerpts_are_short() {
        assert_eq!(excerpt("abc"), "abc");
        let long = "é".repeat(100_000);
        assert_eq!(excerpt(&long), format!("{}...", "é".repeat(MAX_EXCERPT_CHARS)));
    }

    #[test]
    fn long_paths_are_shown_by_their_ends() {
        let long = format!("data/{}/towns.csv", "x".repeat(10_000));
        let e = crate::SceneError::new(&long, crate::SceneErrorKind::Empty);
        let shown = e.to_string();
        assert!(
            shown.len() < 200 && shown.starts_with("data/xxx") && shown.contains("...xxx") && shown.contains("/towns.csv: the scene"),
            "{shown}"
        );
        assert_eq!(shown_path(std::path::Path::new("a/b.obj")), "a/b.obj");
    }
}
