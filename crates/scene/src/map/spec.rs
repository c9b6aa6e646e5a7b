//! The scene-file tables of map scenes, as written in TOML: `[[map]]`,
//! `[[symbols]]`, `[[labels]]` and `[animation]`. Paths are relative to the
//! scene file. These are file-format types (serde); [`super::MapScene`] is
//! what they load into.

use super::projection::Projection;
use serde::Deserialize;
use std::path::PathBuf;

/// `[[map]]`: an outline on the ground plane.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MapSpec {
    /// GeoJSON (`.geojson`, `.json`) or Bramall CSV (`x, y, pen_up`).
    pub outline: PathBuf,
    /// How the outline's (and lon/lat places') coordinates become map units.
    #[serde(default)]
    pub projection: Projection,
    /// World units per map unit.
    #[serde(default = "one")]
    pub scale: f64,
    /// World x, y of the map-unit origin.
    #[serde(default)]
    pub offset: [f64; 2],
    /// Pen for the outline.
    #[serde(default = "pen_one")]
    pub pen: u32,
}

/// `[[symbols]]`: one convex solid per place, its height from the data.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SymbolsSpec {
    /// CSV with header `name,x,y,value` or `name,lon,lat,value`.
    pub data: PathBuf,
    /// `box`, `hex_prism`, `cylinder`, `pyramid`, or a path to a convex OBJ.
    #[serde(default = "default_shape")]
    pub shape: String,
    /// Footprint width in map units, centred on the place.
    #[serde(default = "one")]
    pub size: f64,
    /// World height per unit of value (per decade with `log`).
    #[serde(default = "one")]
    pub height_scale: f64,
    /// Height = `height_scale` x log10(1 + value) instead of x value.
    #[serde(default)]
    pub log: bool,
    /// Pen for the symbols' edges and their intersection lines.
    #[serde(default = "pen_one")]
    pub pen: u32,
    /// The value column when there is no `[animation]` of values.
    #[serde(default = "default_value")]
    pub value: String,
    /// Sides of a `cylinder`.
    #[serde(default = "default_segments")]
    pub segments: u32,
    /// Index of the `[[map]]` whose projection, scale and offset place these
    /// symbols (default: the first map; none: planar, scale 1).
    #[serde(default)]
    pub map: Option<usize>,
}

/// Where labels go.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum LabelPlacement {
    /// Lying on the ground in front of each symbol.
    Ground,
    /// Standing upright, floating above each symbol's top.
    #[default]
    Above,
}

/// `[[labels]]`: the place names of a `[[symbols]]` table in the
/// single-stroke font, hidden like everything else.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LabelsSpec {
    /// Index of the `[[symbols]]` table whose places are named.
    #[serde(default)]
    pub symbols: usize,
    /// On the ground or above the symbols.
    #[serde(default)]
    pub placement: LabelPlacement,
    /// Cap height of the text in map units (default: half the symbol size).
    #[serde(default)]
    pub height: Option<f64>,
    /// Space between symbol and text, in map units (default: a quarter of the
    /// text height).
    #[serde(default)]
    pub gap: Option<f64>,
    /// Pen for the text.
    #[serde(default = "pen_one")]
    pub pen: u32,
    /// Drawn whole over the picture, every other line cut under it
    /// ([`crate::knockout`]), instead of hidden like a line.
    #[serde(default)]
    pub knockout: bool,
}

/// `[animation]`: a sequence of frames.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AnimationSpec {
    /// Number of frames, >= 1.
    pub frames: usize,
    /// Value column at the first frame (with `to`).
    #[serde(default)]
    pub from: Option<String>,
    /// Value column at the last frame (with `from`).
    #[serde(default)]
    pub to: Option<String>,
    /// One value column per time step, spread evenly over the frames (instead
    /// of `from`/`to`).
    #[serde(default)]
    pub columns: Option<Vec<String>>,
    /// Camera keyframes, in increasing frame order.
    #[serde(default)]
    pub camera: Vec<CameraKey>,
}

/// One camera keyframe; between keys eye and target move linearly.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraKey {
    /// 0-based frame index.
    pub frame: usize,
    /// Eye position at this frame.
    pub eye: [f64; 3],
    /// Target at this frame (default: the `[camera]` target).
    #[serde(default)]
    pub target: Option<[f64; 3]>,
}

/// All the map tables of one scene file (what a scene file's top level holds
/// besides its other object kinds).
#[derive(Clone, Debug, Default, PartialEq, Deserialize)]
pub struct MapSpecs {
    /// `[[map]]` tables.
    #[serde(default)]
    pub map: Vec<MapSpec>,
    /// `[[symbols]]` tables.
    #[serde(default)]
    pub symbols: Vec<SymbolsSpec>,
    /// `[[labels]]` tables.
    #[serde(default)]
    pub labels: Vec<LabelsSpec>,
    /// The `[animation]` table.
    #[serde(default)]
    pub animation: Option<AnimationSpec>,
}

impl MapSpecs {
    /// True when the scene has no map tables at all.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.map.is_empty() && self.symbols.is_empty() && self.labels.is_empty() && self.animation.is_none()
    }
}

fn one() -> f64 {
    1.0
}
fn pen_one() -> u32 {
    1
}
fn default_shape() -> String {
    "box".to_owned()
}
fn default_value() -> String {
    "value".to_owned()
}
fn default_segments() -> u32 {
    24
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_all_tables_with_defaults() {
        let s: MapSpecs = toml::from_str(
            r#"
            [[map]]
            outline = "world.geojson"
            projection = "mercator"
            scale = 0.1
            [[symbols]]
            data = "cities.csv"
            shape = "cylinder"
            log = true
            [[labels]]
            placement = "ground"
            [animation]
            frames = 10
            from = "a"
            to = "b"
            [[animation.camera]]
            frame = 0
            eye = [1.0, 2.0, 3.0]
            "#,
        )
        .unwrap();
        assert_eq!(s.map[0].projection, Projection::Mercator);
        assert_eq!(s.map[0].offset, [0.0, 0.0]);
        assert_eq!(s.symbols[0].size, 1.0);
        assert_eq!(s.symbols[0].value, "value");
        assert_eq!(s.labels[0].placement, LabelPlacement::Ground);
        let a = s.animation.unwrap();
        assert_eq!(a.frames, 10);
        assert_eq!(a.camera[0].target, None);
    }

    #[test]
    fn unknown_keys_and_projections_are_errors() {
        let e = toml::from_str::<MapSpecs>("[[map]]\noutline = \"a.csv\"\nprojetion = \"mercator\"\n").unwrap_err();
        assert!(e.to_string().contains("projetion"), "{e}");
        let e = toml::from_str::<MapSpecs>("[[map]]\noutline = \"a.csv\"\nprojection = \"robinson\"\n").unwrap_err();
        assert!(e.to_string().contains("robinson"), "{e}");
    }
}
