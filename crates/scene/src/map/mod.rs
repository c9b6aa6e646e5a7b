//! Statistical maps with 3-D symbols (after Bramall, 1972): a map outline on
//! the ground plane z = 0, one convex solid per place whose height shows a
//! value, place-name labels, and frame sequences in which the values change
//! and the camera moves.
//!
//! The scene-file tables ([`spec`]) load once into a [`MapScene`] (all files
//! read, projected and validated); [`MapScene::lower`] then adds one frame's
//! faces and edges to a [`Model`] cheaply, so a 500-frame film reads its
//! data once.
//!
//! **Invariants.** The outline is free lines on z = 0 (hidden by symbols,
//! hiding nothing). Every symbol is a closed convex solid whose faces wind
//! counter-clockwise seen from outside (`outward = true`) and whose edges name
//! their two faces; symbols that interpenetrate are left to the engine, which
//! draws their intersection lines. Frame 0 and the last frame use the start
//! and end data columns exactly.
//!
//! ```no_run
//! use scene::map::{MapScene, MapSpecs};
//! use hiddenline::{Camera, DVec3, Model, Projection};
//! let specs: MapSpecs = toml::from_str(r#"
//!     [[map]]
//!     outline = "outline.csv"
//!     [[symbols]]
//!     data = "places.csv"
//!     shape = "hex_prism"
//! "#).unwrap();
//! let scene = MapScene::load(&specs, std::path::Path::new("examples")).unwrap();
//! let camera = Camera::new(DVec3::new(0.0, -30.0, 20.0), DVec3::ZERO, DVec3::Z,
//!     Projection::Perspective { fov_deg: 30.0 }).unwrap();
//! let model: Model = scene.model(0, &camera);
//! ```

pub mod animation;
pub mod error;
pub mod labels;
pub mod limits;
pub mod outline;
pub mod places;
pub mod projection;
pub mod shape;
pub mod spec;

pub use animation::Animation;
pub use error::MapError;
pub use labels::TextStrokes;
pub use outline::Outline;
pub use places::{Coords, Places};
pub use projection::{Placement, Projection};
pub use shape::Solid;
pub use spec::{AnimationSpec, CameraKey, LabelPlacement, LabelsSpec, MapSpec, MapSpecs, SymbolsSpec};

use crate::builder::ModelBuilder;
use crate::resolver::{FileSystem, Resolver};
use crate::tolerance::{beyond_limit, MAX_COORDINATE};
use glam::{DVec2, DVec3};
use hiddenline::camera::{Camera, CameraError};
use hiddenline::model::Model;
use std::collections::HashSet;
use std::path::Path;

/// A loaded map outline: world-space segments on z = 0.
#[derive(Clone, Debug, PartialEq)]
pub struct MapLayer {
    /// How this map's data become world x, y.
    pub placement: Placement,
    /// Segments in world x, y, each once (shared region boundaries are
    /// drawn once).
    pub segments: Vec<(DVec2, DVec2)>,
    /// Pen.
    pub pen: u32,
}

/// A loaded `[[symbols]]` table.
#[derive(Clone, Debug, PartialEq)]
pub struct SymbolLayer {
    /// The unit solid.
    pub solid: Solid,
    /// Place names, as in the file.
    pub names: Vec<String>,
    /// Base centre of each place's symbol on the ground, world space.
    pub bases: Vec<DVec3>,
    /// Each place's values, in the order of the animation's columns.
    pub values: Vec<Vec<f64>>,
    /// Footprint width, world units.
    pub width: f64,
    /// World units per map unit (of the map placing these symbols).
    pub map_scale: f64,
    /// World height per unit of (possibly log-scaled) value.
    pub height_scale: f64,
    /// Log scale.
    pub log: bool,
    /// Pen.
    pub pen: u32,
}

impl SymbolLayer {
    /// World height of a symbol showing `value`.
    #[must_use]
    pub fn height(&self, value: f64) -> f64 {
        let v = if self.log { (1.0 + value.max(0.0)).log10() } else { value.max(0.0) };
        self.height_scale * v
    }
}

/// A loaded `[[labels]]` table.
#[derive(Clone, Debug, PartialEq)]
pub struct LabelLayer {
    /// The table as written (validated).
    pub spec: LabelsSpec,
    /// Each place's name in strokes, in the order of the symbols table.
    pub text: Vec<TextStrokes>,
}

/// Shapes a string into single-stroke text (em units, see [`TextStrokes`]).
pub type Shaper<'a> = &'a (dyn Fn(&str) -> TextStrokes + Sync);

/// Every map table of a scene, loaded and validated.
#[derive(Clone, Debug, PartialEq)]
pub struct MapScene {
    /// `[[map]]` outlines.
    pub maps: Vec<MapLayer>,
    /// `[[symbols]]` tables.
    pub symbols: Vec<SymbolLayer>,
    /// `[[labels]]` tables, their text shaped.
    pub labels: Vec<LabelLayer>,
    /// The frame sequence; a still picture is one frame.
    pub animation: Animation,
}

impl MapScene {
    /// Reads every file the tables name (relative to `base_dir`), projects,
    /// and validates.
    ///
    /// # Errors
    /// Any [`MapError`]: a file missing or malformed (with row, column or
    /// position), a key out of range (with table and key).
    pub fn load(specs: &MapSpecs, base_dir: &Path) -> Result<MapScene, MapError> {
        MapScene::load_with_font(specs, base_dir, Some(&labels::hershey), &FileSystem)
    }

    /// [`MapScene::load`] with the font that shapes label text, reading
    /// files through `files`.
    ///
    /// # Errors
    /// As [`MapScene::load`]; also `[[labels]]` without a font.
    pub fn load_with_font(specs: &MapSpecs, base_dir: &Path, font: Option<Shaper<'_>>, files: &dyn Resolver) -> Result<MapScene, MapError> {
        let animation = match &specs.animation {
            Some(a) => Animation::from_spec(a)?,
            None => Animation { frames: 1, values: None, keys: Vec::new() },
        };
        let mut maps = Vec::with_capacity(specs.map.len());
        for (i, m) in specs.map.iter().enumerate() {
            maps.push(load_map(m, i, base_dir, files)?);
        }
        let mut symbols = Vec::with_capacity(specs.symbols.len());
        for (i, s) in specs.symbols.iter().enumerate() {
            symbols.push(load_symbols(s, i, &maps, &specs.map, &animation, base_dir, files)?);
        }
        let mut labels = Vec::with_capacity(specs.labels.len());
        for (i, l) in specs.labels.iter().enumerate() {
            let table = format!("labels[{i}]");
            if l.symbols >= symbols.len() {
                return Err(MapError::spec(table, "symbols", format!("there is no symbols[{}]", l.symbols)));
            }
            for (key, v) in [("height", l.height), ("gap", l.gap)] {
                if v.is_some_and(|v| !(v.is_finite() && v >= 0.0)) {
                    return Err(MapError::spec(table, key, "must be a finite number >= 0"));
                }
            }
            let Some(font) = font else {
                return Err(MapError::spec(
                    table,
                    "labels",
                    "this build has no single-stroke font yet (hiddenline::font), so labels cannot be drawn",
                ));
            };
            let text = symbols[l.symbols].names.iter().map(|n| font(n)).collect();
            labels.push(LabelLayer { spec: l.clone(), text });
        }
        Ok(MapScene { maps, symbols, labels, animation })
    }

    /// Number of frames (1 without an `[animation]`).
    #[must_use]
    pub fn frames(&self) -> usize {
        self.animation.frames
    }

    /// The camera of `frame`, moved from `base` along the keyframes.
    ///
    /// # Errors
    /// The keyframed camera is unusable (eye on target).
    pub fn camera(&self, frame: usize, base: &Camera) -> Result<Camera, CameraError> {
        self.animation.camera(frame, base)
    }

    /// Adds frame `frame`'s outline, symbols and labels, as seen by `camera`
    /// (labels turn to face it), to `out`.
    pub fn lower(&self, frame: usize, camera: &Camera, out: &mut ModelBuilder) {
        for m in &self.maps {
            for &(a, b) in &m.segments {
                out.add_edge(a.extend(0.0), b.extend(0.0), m.pen, &[]);
            }
        }
        for s in &self.symbols {
            for (base, values) in s.bases.iter().zip(&s.values) {
                let h = s.height(self.animation.value(values, frame));
                s.solid.emit(*base, s.width, h, s.pen, out);
            }
        }
        for (segments, pen, knockout) in self.placed_labels(frame, camera) {
            if knockout {
                continue; // drawn over the picture: `knockout_labels`
            }
            for (a, b) in segments {
                out.add_edge(a, b, pen, &[]);
            }
        }
    }

    /// Frame `frame`'s labels of the tables with `knockout = true`, placed
    /// as [`MapScene::placed_labels`] places them: world segments and pen.
    #[must_use]
    pub fn knockout_labels(&self, frame: usize, camera: &Camera) -> Vec<(labels::Segments, u32)> {
        if !self.labels.iter().any(|l| l.spec.knockout) {
            return Vec::new();
        }
        self.placed_labels(frame, camera).into_iter().filter(|l| l.2).map(|(s, pen, _)| (s, pen)).collect()
    }

    /// Frame `frame`'s labels as placed for `camera`: each label's world
    /// segments, pen and whether its table knocks out, the tables' labels in order. They go where they
    /// can be read ([`labels::place_all`]): against the symbols as they
    /// stand in this frame, apart from each other, off the lines.
    #[must_use]
    pub fn placed_labels(&self, frame: usize, camera: &Camera) -> Vec<(labels::Segments, u32, bool)> {
        if self.labels.is_empty() {
            return Vec::new();
        }
        let mut solids = ModelBuilder::new();
        for s in &self.symbols {
            for (base, values) in s.bases.iter().zip(&s.values) {
                s.solid.emit(*base, s.width, s.height(self.animation.value(values, frame)), s.pen, &mut solids);
            }
        }
        let solids = solids.finish();
        let outline = self.maps.iter().flat_map(|m| m.segments.iter().map(|&(a, b)| (a.extend(0.0), b.extend(0.0))));
        let lines: Vec<(DVec3, DVec3)> = outline.chain(solids.edges.iter().map(|e| (e.a, e.b))).collect();
        let mut all = Vec::new();
        let mut pens = Vec::new();
        for l in &self.labels {
            let s = &self.symbols[l.spec.symbols];
            let height = l.spec.height.map_or(0.5 * s.width, |h| h * s.map_scale);
            let gap = l.spec.gap.map_or(0.25 * height, |g| g * s.map_scale);
            for ((base, values), text) in s.bases.iter().zip(&s.values).zip(&l.text) {
                let frame = labels::LabelFrame {
                    anchor: *base,
                    placement: l.spec.placement,
                    height,
                    gap,
                    half_width: 0.5 * s.width,
                    symbol_height: s.height(self.animation.value(values, frame)),
                };
                all.push(labels::Label { text, frame });
                pens.push((l.spec.pen, l.spec.knockout));
            }
        }
        labels::place_all(&all, &solids, &lines, camera).into_iter().zip(pens).map(|(s, (pen, k))| (s, pen, k)).collect()
    }

    /// Frame `frame` lowered to a fresh [`Model`] (the map tables alone).
    #[must_use]
    pub fn model(&self, frame: usize, camera: &Camera) -> Model {
        let mut out = ModelBuilder::new();
        self.lower(frame, camera, &mut out);
        out.finish()
    }

    /// Upper bound of the faces one frame lowers to.
    #[must_use]
    pub fn face_estimate(&self) -> usize {
        self.symbols.iter().map(|s| s.solid.faces.len() * s.bases.len()).sum()
    }

    /// True when a frame draws nothing.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.maps.iter().all(|m| m.segments.is_empty()) && self.symbols.iter().all(|s| s.bases.is_empty())
    }
}

fn positive(table: &str, key: &'static str, v: f64) -> Result<f64, MapError> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(MapError::spec(table, key, format!("{v} must be a finite number > 0")))
    }
}

fn load_map(m: &MapSpec, i: usize, base_dir: &Path, files: &dyn Resolver) -> Result<MapLayer, MapError> {
    let table = format!("map[{i}]");
    let scale = positive(&table, "scale", m.scale)?;
    let offset = DVec2::from_array(m.offset);
    if !offset.is_finite() {
        return Err(MapError::spec(table, "offset", "must be finite"));
    }
    let placement = Placement { projection: m.projection, scale, offset };
    let outline = Outline::load(&base_dir.join(&m.outline), m.projection, files).map_err(|e| e.keyed(&table, "outline"))?;
    // Neighbouring regions share boundaries: draw each segment once (exact
    // match, either direction), and skip zero-length ones.
    let mut seen = HashSet::new();
    let mut segments = Vec::with_capacity(outline.point_count());
    for (l, line) in outline.polylines.iter().enumerate() {
        if let Some((k, far)) =
            line.iter().enumerate().find_map(|(k, &p)| beyond_limit(placement.place_map_units(p).extend(0.0)).map(|c| (k, c)))
        {
            let m =
                format!("point {} of line {} is at {far:e} after scale and offset, beyond the limit of ±{MAX_COORDINATE:e}", k + 1, l + 1);
            return Err(MapError::spec(table, "outline", m));
        }
        for w in line.windows(2) {
            let (a, b) = (placement.place_map_units(w[0]), placement.place_map_units(w[1]));
            let (ka, kb) = (a.to_array().map(f64::to_bits), b.to_array().map(f64::to_bits));
            if ka != kb && seen.insert(if ka < kb { (ka, kb) } else { (kb, ka) }) {
                segments.push((a, b));
            }
        }
    }
    Ok(MapLayer { placement, segments, pen: m.pen })
}

fn load_symbols(
    s: &SymbolsSpec,
    i: usize,
    maps: &[MapLayer],
    map_specs: &[MapSpec],
    animation: &Animation,
    base_dir: &Path,
    files: &dyn Resolver,
) -> Result<SymbolLayer, MapError> {
    let table = format!("symbols[{i}]");
    let size = positive(&table, "size", s.size)?;
    if !(s.height_scale.is_finite() && s.height_scale >= 0.0) {
        return Err(MapError::spec(table, "height_scale", format!("{} must be a finite number >= 0", s.height_scale)));
    }
    let placement = match s.map {
        Some(k) => maps
            .get(k)
            .map(|m| m.placement)
            .ok_or_else(|| MapError::spec(&table, "map", format!("there is no map[{k}] ({} map tables)", map_specs.len())))?,
        None => maps.first().map(|m| m.placement).unwrap_or_default(),
    };
    let solid = match s.shape.as_str() {
        "box" => Solid::unit_box(),
        "hex_prism" => Solid::hex_prism(),
        "pyramid" => Solid::pyramid(),
        "cylinder" => {
            if !limits::CYLINDER_SEGMENTS.contains(&s.segments) {
                return Err(MapError::spec(table, "segments", format!("{} is outside {:?}", s.segments, limits::CYLINDER_SEGMENTS)));
            }
            Solid::cylinder(s.segments)
        }
        other if other.to_ascii_lowercase().ends_with(".obj") => {
            Solid::from_obj(&base_dir.join(other), files).map_err(|e| e.keyed(&table, "shape"))?
        }
        other => {
            return Err(MapError::spec(
                table,
                "shape",
                format!("`{}` is not box, hex_prism, cylinder, pyramid or a path to an .obj", crate::excerpt::excerpt(other)),
            ))
        }
    };
    let path = base_dir.join(&s.data);
    let places = Places::load(&path, &animation.columns(&s.value), files).map_err(|e| e.keyed(&table, "data"))?;
    // Lon/lat places go through the map's projection (plate carrée when the
    // map itself is planar); x/y places are map units already.
    let projection = match places.coords {
        Coords::Planar => Projection::Planar,
        Coords::LonLat if placement.projection.is_geographic() => placement.projection,
        Coords::LonLat => Projection::Equirectangular,
    };
    let mut bases = Vec::with_capacity(places.places.len());
    for p in &places.places {
        let m = projection.project(p.at).map_err(|message| MapError::Projection {
            path: path.clone(),
            at: format!("row {}", p.row),
            message,
        })?;
        let base = placement.place_map_units(m).extend(0.0);
        if let Some(far) = beyond_limit(base) {
            let message = format!("the place is at {far:e} after scale and offset, beyond the limit of ±{MAX_COORDINATE:e}");
            return Err(MapError::Projection { path: path.clone(), at: format!("row {}", p.row), message });
        }
        bases.push(base);
    }
    let layer = SymbolLayer {
        solid,
        names: places.places.iter().map(|p| p.name.clone()).collect(),
        bases,
        values: places.places.into_iter().map(|p| p.values).collect(),
        width: size * placement.scale,
        map_scale: placement.scale,
        height_scale: s.height_scale,
        log: s.log,
        pen: s.pen,
    };
    let tallest = layer.values.iter().flatten().map(|&v| layer.height(v)).fold(0.0, f64::max);
    for (key, v) in [("size", layer.width), ("height_scale", tallest)] {
        if !(v <= MAX_COORDINATE) {
            let m = format!("symbols reach {v:e} world units (after the map's scale), beyond the limit of ±{MAX_COORDINATE:e}");
            return Err(MapError::spec(table, key, m));
        }
    }
    Ok(layer)
}
