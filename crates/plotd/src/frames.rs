//! Frame sequences for `plotd render`: an animated scene (`[animation]`)
//! rendered to one file per frame, in parallel.
//!
//! The output name carries a printf-style frame number: `%d`, or `%0Nd` for a
//! zero-padded width N (`frames/frame-%04d.svg` -> `frames/frame-0000.svg`,
//! ...). `%%` is a literal percent sign. Frames are numbered from 0.

use anyhow::{bail, Context};
use rayon::prelude::*;
use scene::Scene;
use std::path::{Path, PathBuf};

/// Widest zero padding accepted in `%0Nd`.
const MAX_PAD: usize = 12;

/// A parsed output pattern: text before and after one frame-number field.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FramePattern {
    before: String,
    after: String,
    pad: usize,
}

impl FramePattern {
    /// The pattern in `path`, `None` when it has no `%` field at all.
    ///
    /// # Errors
    /// A `%` that is not `%d`, `%0Nd` or `%%`, more than one frame field, or a
    /// path that is not UTF-8.
    pub fn parse(path: &Path) -> anyhow::Result<Option<FramePattern>> {
        let Some(s) = path.to_str() else {
            if path.as_os_str().as_encoded_bytes().contains(&b'%') {
                bail!("{}: a frame-number pattern must be UTF-8", path.display());
            }
            return Ok(None);
        };
        if !s.contains('%') {
            return Ok(None);
        }
        let bad = |why: &str| anyhow::anyhow!("{s}: {why} (use %d or %04d for the frame number, %% for a percent sign)");
        let (mut before, mut after, mut pad, mut found) = (String::new(), String::new(), 0, false);
        let mut chars = s.chars().peekable();
        while let Some(c) = chars.next() {
            let out = if found { &mut after } else { &mut before };
            if c != '%' {
                out.push(c);
                continue;
            }
            if chars.peek() == Some(&'%') {
                chars.next();
                out.push('%');
                continue;
            }
            let mut digits = String::new();
            while let Some(d) = chars.peek().filter(|d| d.is_ascii_digit()) {
                digits.push(*d);
                chars.next();
            }
            if chars.next() != Some('d') {
                return Err(bad("unknown `%` field"));
            }
            if found {
                return Err(bad("more than one frame-number field"));
            }
            pad = if digits.is_empty() { 0 } else { digits.parse::<usize>().map_err(|_| bad("bad width"))? };
            if pad > MAX_PAD {
                return Err(bad("frame-number width over 12"));
            }
            found = true;
        }
        if !found {
            // Only `%%` escapes: a plain single file.
            return Ok(None);
        }
        Ok(Some(FramePattern { before, after, pad }))
    }

    /// The file name of frame `index`.
    #[must_use]
    pub fn path(&self, index: usize) -> PathBuf {
        PathBuf::from(format!("{}{:0pad$}{}", self.before, index, self.after, pad = self.pad))
    }
}

/// Renders every frame of `scene` with `draw` and writes it to `pattern`'s
/// file for that frame with `write` (which picks the format), frames in
/// parallel (rayon). Creates the output directory if needed. Returns each
/// frame's path, drawing and what `write` said, in frame order.
///
/// # Errors
/// The first frame that fails to render or write (naming the frame and file).
pub fn render_all<D: Send, T: Send>(
    scene: &Scene,
    pattern: &FramePattern,
    draw: impl Fn(Scene) -> anyhow::Result<D> + Sync,
    write: impl Fn(&D, &Path) -> anyhow::Result<T> + Sync,
) -> anyhow::Result<Vec<(PathBuf, D, T)>> {
    if let Some(dir) = pattern.path(0).parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    }
    (0..scene.frame_count())
        .into_par_iter()
        .map(|i| {
            let path = pattern.path(i);
            let frame = scene.frame(i)?;
            let drawn = draw(frame).with_context(|| format!("frame {i}"))?;
            let written = write(&drawn, &path).with_context(|| format!("frame {i}"))?;
            Ok((path, drawn, written))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pat(s: &str) -> Option<FramePattern> {
        FramePattern::parse(Path::new(s)).unwrap()
    }

    #[test]
    fn patterns() {
        assert_eq!(pat("a.svg"), None);
        assert_eq!(pat("100%%.svg"), None);
        assert_eq!(pat("frames/frame-%04d.svg").unwrap().path(7), PathBuf::from("frames/frame-0007.svg"));
        assert_eq!(pat("f%d.hpgl").unwrap().path(123), PathBuf::from("f123.hpgl"));
        assert_eq!(pat("f%03d.svg").unwrap().path(12345), PathBuf::from("f12345.svg"), "never truncated");
        assert_eq!(pat("%%-%02d.svg").unwrap().path(3), PathBuf::from("%-03.svg"));
    }

    #[test]
    fn bad_patterns() {
        for p in ["f%s.svg", "f%4.svg", "f%d-%d.svg", "f%099d.svg", "f%"] {
            assert!(FramePattern::parse(Path::new(p)).is_err(), "{p}");
        }
    }
}
