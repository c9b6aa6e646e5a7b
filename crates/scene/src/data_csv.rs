//! The one CSV dialect of the data files a scene names (height tables,
//! ridgeline rows, map outlines, places): fields trimmed, `#` starts a
//! comment line, rows may differ in length (each reader checks the widths
//! itself so that its error can name the row).

/// A CSV reader over `text` in that dialect; `headers` says whether the
/// first row is a header (read with `Reader::headers`).
pub(crate) fn reader(text: &str, headers: bool) -> csv::Reader<&[u8]> {
    csv::ReaderBuilder::new().has_headers(headers).flexible(true).trim(csv::Trim::All).comment(Some(b'#')).from_reader(text.as_bytes())
}
