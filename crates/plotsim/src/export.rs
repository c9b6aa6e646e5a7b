//! Pictures of a record: SVG for people and diff tools, PNG via resvg.

use crate::record::Record;
use crate::SimError;
use std::fmt::Write as _;
use std::path::Path;

/// Pen colours by carousel slot (pen 1 black), so a person can tell the pens apart.
const PEN_COLOURS: [&str; 8] = ["#000000", "#d62728", "#1f77b4", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2"];

/// The area the picture shows, in device units: the device limits, grown to
/// hold every stroke (a record may go past them), or a unit square when empty.
fn view_box(record: &Record) -> [f64; 4] {
    let mut b = record.limits.unwrap_or([f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY]);
    for p in record.strokes.iter().flat_map(|s| &s.points) {
        b = [b[0].min(p[0]), b[1].min(p[1]), b[2].max(p[0]), b[3].max(p[1])];
    }
    if !(b[0].is_finite() && b[2] > b[0] && b[3] > b[1]) {
        let (x, y) = if b[0].is_finite() { (b[0], b[1]) } else { (0.0, 0.0) };
        return [x - 0.5, y - 0.5, x + 0.5, y + 0.5];
    }
    b
}

/// The strokes as an SVG document in millimetres (y flipped: devices count up).
#[must_use]
pub fn to_svg(record: &Record) -> String {
    let [x0, y0, x1, y1] = view_box(record);
    let upm = if record.units_per_mm > 0.0 { record.units_per_mm } else { 1.0 };
    let (w, h) = ((x1 - x0) / upm, (y1 - y0) / upm);
    // A pen line about 0.3 mm wide, in device units.
    let stroke_w = 0.3 * upm;
    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w:.3}mm" height="{h:.3}mm" viewBox="{x0} {} {} {}">"#,
        -y1,
        x1 - x0,
        y1 - y0
    );
    let _ = writeln!(s, r#"<rect x="{x0}" y="{}" width="{}" height="{}" fill="white"/>"#, -y1, x1 - x0, y1 - y0);
    let _ =
        writeln!(s, r#"<g transform="scale(1,-1)" fill="none" stroke-width="{stroke_w}" stroke-linecap="round" stroke-linejoin="round">"#);
    for st in &record.strokes {
        let colour = PEN_COLOURS[st.pen.saturating_sub(1) as usize % PEN_COLOURS.len()];
        let pts: Vec<String> = st.points.iter().map(|p| format!("{},{}", p[0], p[1])).collect();
        let _ = writeln!(s, r#"<polyline stroke="{colour}" points="{}"/>"#, pts.join(" "));
    }
    s.push_str("</g>\n</svg>\n");
    s
}

/// Writes the SVG picture.
///
/// # Errors
/// [`SimError::Write`] when the file cannot be written.
pub fn save_svg(record: &Record, path: &Path) -> Result<(), SimError> {
    std::fs::write(path, to_svg(record)).map_err(|source| SimError::Write { path: path.into(), source })
}

/// Writes the JSON record.
///
/// # Errors
/// [`SimError::Write`] when the file cannot be written.
pub fn save_json(record: &Record, path: &Path) -> Result<(), SimError> {
    std::fs::write(path, record.to_json()).map_err(|source| SimError::Write { path: path.into(), source })
}

/// Largest PNG side in pixels; bigger requests are refused, not allocated.
pub const MAX_PNG_SIDE: u32 = 8192;

/// Renders the SVG picture to a PNG `width_px` wide.
///
/// # Errors
/// [`SimError::Png`] for a width outside 1..=[`MAX_PNG_SIDE`] or a render
/// failure, [`SimError::Write`] when the file cannot be written.
pub fn save_png(record: &Record, path: &Path, width_px: u32) -> Result<(), SimError> {
    use resvg::{tiny_skia, usvg};
    let png_err = |why: String| SimError::Png { path: path.into(), why };
    if width_px == 0 || width_px > MAX_PNG_SIDE {
        return Err(png_err(format!("width {width_px} px is outside 1..={MAX_PNG_SIDE}")));
    }
    let tree = usvg::Tree::from_str(&to_svg(record), &usvg::Options::default()).map_err(|e| png_err(e.to_string()))?;
    let size = tree.size();
    let scale = width_px as f32 / size.width();
    let height_px = ((size.height() * scale).ceil() as u32).clamp(1, MAX_PNG_SIDE);
    let mut pixmap = tiny_skia::Pixmap::new(width_px, height_px).ok_or_else(|| png_err("empty image".into()))?;
    resvg::render(&tree, tiny_skia::Transform::from_scale(scale, scale), &mut pixmap.as_mut());
    let bytes = pixmap.encode_png().map_err(|e| png_err(e.to_string()))?;
    std::fs::write(path, bytes).map_err(|source| SimError::Write { path: path.into(), source })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn svg_has_one_polyline_per_stroke_and_renders() {
        let mut r = Record { units_per_mm: 40.0, limits: Some([0.0, 0.0, 4000.0, 2000.0]), ..Record::default() };
        r.segment(1, [0.0, 0.0], [4000.0, 2000.0]);
        r.segment(2, [0.0, 2000.0], [4000.0, 0.0]);
        let svg = to_svg(&r);
        assert_eq!(svg.matches("<polyline").count(), 2);
        assert!(svg.contains(r#"width="100.000mm""#));
        let dir = std::env::temp_dir().join(format!("plotsim-export-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let png = dir.join("r.png");
        save_png(&r, &png, 400).unwrap();
        let bytes = std::fs::read(&png).unwrap();
        assert_eq!(&bytes[1..4], b"PNG");
        // The picture is not blank: the diagonal strokes darken some pixels.
        let pixmap = resvg::tiny_skia::Pixmap::decode_png(&bytes).unwrap();
        assert!(pixmap.pixels().iter().filter(|p| p.green() < 128).count() > 100);
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn empty_record_still_makes_a_valid_picture() {
        let r = Record::default();
        assert!(to_svg(&r).contains("viewBox=\"-0.5"));
        assert!(save_png(&r, Path::new("/nonexistent/x.png"), 0).is_err());
    }
}
