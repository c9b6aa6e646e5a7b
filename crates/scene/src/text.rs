//! `[[text]]`: free single-stroke text, on the page (a title, a signature,
//! a scale: placed in millimetres, never hidden) or at a point of the
//! scene's 3-D space (facing the viewer in the picture plane, and hidden by
//! faces in front of it like any free line).

use crate::builder::ModelBuilder;
use crate::error::SceneErrorKind;
use crate::font::{text_polylines, Align, Font, TextPlacement};
use crate::mesh::default_pen;
use crate::points::FieldError;
use glam::{DVec2, DVec3};
use hiddenline::camera::Camera;
use serde::Deserialize;
use strokes::font::Lettering;

/// `align = "left" | "center" | "right"`: where the text's position is
/// along its baseline.
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum TextAlign {
    /// The text starts at its position.
    #[default]
    Left,
    /// The text is centred on it.
    Center,
    /// The text ends at it.
    Right,
}

impl From<TextAlign> for Align {
    fn from(a: TextAlign) -> Align {
        match a {
            TextAlign::Left => Align::Start,
            TextAlign::Center => Align::Center,
            TextAlign::Right => Align::End,
        }
    }
}

/// A `[[text]]` table as written.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TextSpec {
    /// What to write.
    pub text: String,
    /// Position on the page, mm from its bottom-left corner (on the
    /// baseline).
    pub at: Option<[f64; 2]>,
    /// Or a point in the scene's world space.
    pub world: Option<[f64; 3]>,
    /// Cap height: mm on the page, world units in 3-D.
    #[serde(default = "default_size")]
    pub size: f64,
    /// Baseline turned counter-clockwise by this, degrees.
    #[serde(default)]
    pub angle_deg: f64,
    /// Where the position is along the text.
    #[serde(default)]
    pub align: TextAlign,
    /// Hershey font: simplex (default), duplex, complex, triplex, script,
    /// italic, gothic, greek.
    #[serde(default = "default_font")]
    pub font: String,
    /// Pen.
    #[serde(default = "default_pen")]
    pub pen: u32,
    /// Drawn whole over the picture, every other line cut under it
    /// ([`crate::knockout`]), instead of hidden like a line.
    #[serde(default)]
    pub knockout: bool,
}

fn default_size() -> f64 {
    5.0
}
fn default_font() -> String {
    "simplex".into()
}

/// Where a text stands.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TextPlace {
    /// On the page, mm.
    Page(DVec2),
    /// In world space.
    World(DVec3),
}

/// A validated `[[text]]`.
#[derive(Clone, Debug, PartialEq)]
pub struct Text {
    /// The text as written.
    pub text: String,
    /// Where it stands.
    pub place: TextPlace,
    /// Cap height (mm on the page, world units in 3-D).
    pub size: f64,
    /// Baseline angle, radians counter-clockwise.
    pub angle: f64,
    /// Alignment along the baseline.
    pub align: Align,
    /// Font.
    pub font: Font,
    /// The text shaped (for counting its work at load).
    pub lettering: Lettering,
    /// Pen.
    pub pen: u32,
    /// Drawn whole over the picture ([`crate::knockout`]).
    pub knockout: bool,
}

impl Text {
    /// Validates a spec.
    ///
    /// # Errors
    /// Not exactly one of `at` and `world`, a coordinate or angle not
    /// finite, a size not above 0, an unknown font, an empty text.
    pub fn from_spec(spec: &TextSpec) -> Result<Text, FieldError> {
        let bad = |f: &str, m: String| (f.to_string(), SceneErrorKind::OutOfRange(m));
        let place = match (spec.at, spec.world) {
            (Some(at), None) => TextPlace::Page(DVec2::from_array(at)),
            (None, Some(w)) => TextPlace::World(DVec3::from_array(w)),
            _ => return Err(bad("at", "give exactly one of at = [x, y] (page mm) and world = [x, y, z]".into())),
        };
        let far = match place {
            TextPlace::Page(p) => (!p.is_finite() || p.abs().max_element() > crate::tolerance::MAX_COORDINATE).then_some("at"),
            TextPlace::World(w) => crate::tolerance::beyond_limit(w).map(|_| "world").or((!w.is_finite()).then_some("world")),
        };
        if let Some(field) = far {
            return Err(bad(field, format!("must be finite numbers within ±{:e}", crate::tolerance::MAX_COORDINATE)));
        }
        if !(spec.size > 0.0 && spec.size <= crate::tolerance::MAX_COORDINATE) {
            return Err(bad("size", format!("size = {} must be above 0", spec.size)));
        }
        if !spec.angle_deg.is_finite() {
            return Err(bad("angle_deg", format!("angle_deg = {} is not a finite number", spec.angle_deg)));
        }
        let names: Vec<&str> = Font::NAMED.iter().map(|(n, _)| *n).collect();
        let font = Font::named(&spec.font).ok_or_else(|| {
            bad("font", format!("`{}` is not a Hershey font of plotd ({})", crate::excerpt::excerpt(&spec.font), names.join(", ")))
        })?;
        if spec.text.trim().is_empty() {
            return Err(bad("text", "is empty".into()));
        }
        Ok(Text {
            text: spec.text.clone(),
            place,
            size: spec.size,
            angle: spec.angle_deg.to_radians(),
            align: spec.align.into(),
            font,
            lettering: strokes::font::shape(&spec.text, font),
            pen: spec.pen,
            knockout: spec.knockout,
        })
    }

    /// Segments the text draws.
    #[must_use]
    pub fn segment_count(&self) -> usize {
        self.lettering.lines.iter().map(|l| l.len() - 1).sum()
    }

    /// A page text's polylines, page mm; nothing for a text in 3-D.
    #[must_use]
    pub fn page_lines(&self) -> Vec<Vec<DVec2>> {
        let TextPlace::Page(at) = self.place else { return Vec::new() };
        let (sin, cos) = self.angle.sin_cos();
        let (right, up) = (DVec2::new(cos, sin), DVec2::new(-sin, cos));
        let dx = self.align.offset(self.lettering.width);
        let to_page = |p: &DVec2| at + right * ((p.x - dx) * self.size) + up * (p.y * self.size);
        self.lettering.lines.iter().map(|l| l.iter().map(to_page).collect()).collect()
    }

    /// A 3-D text's segments, world space, in the picture plane of
    /// `camera` (facing the viewer); nothing for a page text.
    #[must_use]
    pub fn world_segments(&self, camera: &Camera) -> Vec<(DVec3, DVec3)> {
        let TextPlace::World(anchor) = self.place else { return Vec::new() };
        let dir = camera.direction();
        let right = dir.cross(camera.up).try_normalize().unwrap_or(DVec3::X);
        let up = right.cross(dir).normalize_or_zero();
        let (sin, cos) = self.angle.sin_cos();
        let mut place =
            TextPlacement::new(anchor, right * cos + up * sin, up * cos - right * sin, self.size).aligned(self.align, Align::Start);
        place.font = self.font;
        text_polylines(&self.text, &place).iter().flat_map(|l| l.windows(2).map(|w| (w[0], w[1]))).collect()
    }

    /// True for a text in 3-D that faces hide (not a knockout).
    #[must_use]
    pub fn is_hidden_line(&self) -> bool {
        matches!(self.place, TextPlace::World(_)) && !self.knockout
    }

    /// Adds a 3-D text as free lines (hidden by faces, hiding nothing);
    /// nothing for a knockout, drawn over the picture instead.
    pub fn lower(&self, camera: &Camera, out: &mut ModelBuilder) {
        if self.knockout {
            return;
        }
        for (a, b) in self.world_segments(camera) {
            out.add_edge(a, b, self.pen, &[]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use hiddenline::camera::Projection;

    fn text(toml_text: &str) -> Result<Text, FieldError> {
        Text::from_spec(&toml::from_str(toml_text).unwrap())
    }

    #[test]
    fn page_text_is_placed_in_millimetres() {
        let t = text("text = \"HI\"\nat = [20.0, 10.0]\nsize = 4.0").unwrap();
        let pts: Vec<DVec2> = t.page_lines().into_iter().flatten().collect();
        let (lo, hi) = pts.iter().fold((DVec2::INFINITY, DVec2::NEG_INFINITY), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
        assert!((lo.y - 10.0).abs() < 1e-9 && (hi.y - 14.0).abs() < 1e-9, "{lo} {hi}");
        assert!(lo.x >= 20.0 && hi.x < 30.0, "{lo} {hi}");
        // Turned a quarter, right-aligned: it rises to the left of x = 20.
        let t = text("text = \"HI\"\nat = [20.0, 10.0]\nsize = 4.0\nangle_deg = 90.0\nalign = \"right\"").unwrap();
        let pts: Vec<DVec2> = t.page_lines().into_iter().flatten().collect();
        assert!(pts.iter().all(|p| p.x <= 20.0 + 1e-9 && p.x >= 16.0 - 1e-9 && p.y <= 10.0 + 1e-9), "{pts:?}");
        assert!(t
            .world_segments(&Camera::new(DVec3::ONE, DVec3::ZERO, DVec3::Z, Projection::Perspective { fov_deg: 30.0 }).unwrap())
            .is_empty());
    }

    #[test]
    fn world_text_faces_the_camera() {
        let t = text("text = \"A\"\nworld = [0.0, 0.0, 1.0]\nsize = 0.5\nfont = \"script\"").unwrap();
        assert_eq!(t.font, Font::Script);
        let cam = Camera::new(DVec3::new(0.0, -10.0, 1.0), DVec3::new(0.0, 0.0, 1.0), DVec3::Z, Projection::Perspective { fov_deg: 30.0 })
            .unwrap();
        let segs = t.world_segments(&cam);
        assert!(!segs.is_empty());
        // In the plane y = 0 facing the eye at -y, from the baseline z = 1 up.
        assert!(segs.iter().flat_map(|s| [s.0, s.1]).all(|p| p.y.abs() < 1e-12 && p.z > 0.8 && p.z < 1.6));
        assert!(t.page_lines().is_empty());
    }

    #[test]
    fn bad_texts_name_the_field() {
        let cases = [
            ("text = \"a\"", "at"),
            ("text = \"a\"\nat = [0.0, 0.0]\nworld = [0.0, 0.0, 0.0]", "at"),
            ("text = \"a\"\nat = [0.0, 0.0]\nsize = 0.0", "size"),
            ("text = \"a\"\nat = [0.0, 0.0]\nfont = \"wingdings\"", "font"),
            ("text = \" \"\nat = [0.0, 0.0]", "text"),
            ("text = \"a\"\nworld = [0.0, 0.0, 1e12]", "world"),
            ("text = \"a\"\nat = [0.0, 0.0]\nangle_deg = nan", "angle_deg"),
        ];
        for (t, field) in cases {
            assert_eq!(text(t).unwrap_err().0, field, "{t}");
        }
        assert!(text("text = \"a\"\nat = [0.0, 0.0]\nfont = \"wingdings\"").unwrap_err().1.to_string().contains("simplex, duplex"));
    }
}
