//! The scene file: a camera, a page, render options, and any number of
//! objects, loaded from TOML and lowered to the engine's [`Model`].
//!
//! # Adding an object kind
//!
//! Every `[[kind]]` follows the same three steps, one module per kind:
//! 1. a serde `KindSpec` (the table as written, `deny_unknown_fields`) and a
//!    field `kind: Vec<Spanned<KindSpec>>` in [`SceneFile`];
//! 2. a validated `Kind` type built from the spec in [`Scene::from_toml`]
//!    (errors as [`FieldError`]s; the table's line and `kind[i]` are added
//!    here), stored in a `Vec` field of [`Scene`];
//! 3. a `lower(&self, ..., &mut ModelBuilder)` called from [`Scene::lower`].
//!
//! `[[mesh]]` ([`crate::mesh`]), `[[polygon]]` ([`crate::polygon`]) and `[[polyline]]`
//! ([`crate::polyline`]) are the examples to copy.

use crate::builder::ModelBuilder;
use crate::error::{SceneError, SceneErrorKind};
use crate::mesh::{EdgeChoice, EdgeStyle, Mesh, MeshSpec};

use crate::axes::{Axes, AxesSpec};
use crate::contours::{ContourPlace, Contours, ContoursSpec};
use crate::polygon::{Polygon, PolygonSpec};
use crate::polyline::{Polyline3, PolylineSpec};
use crate::resolver::{FileSystem, Resolver};
use crate::ridgeline::{Ridgeline, RidgelineSpec};
use crate::surface::{Surface, SurfaceSpec};
use crate::text::{Text, TextSpec};

use crate::error::line_of;
use crate::excerpt::excerpt;
use crate::map::{AnimationSpec, LabelsSpec, MapScene, MapSpec, MapSpecs, SymbolsSpec};
use crate::page::{Frame, Page, PageSpec};
use crate::tolerance::{MAX_FACES, MAX_SCENE_BYTES};
use glam::DVec3;
use hiddenline::camera::{Camera, Projection};
use hiddenline::model::Model;
use serde::Deserialize;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use toml::Spanned;

/// The `[camera]` table as written.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraSpec {
    /// Eye position.
    pub eye: [f64; 3],
    /// Point looked at.
    pub target: [f64; 3],
    /// Screen-up direction; default +z.
    #[serde(default = "z_up")]
    pub up: [f64; 3],
    /// Vertical field of view (perspective), degrees.
    pub fov_deg: Option<f64>,
    /// Picture height in world units (orthographic).
    pub ortho_height: Option<f64>,
    /// How the picture is framed on the page.
    #[serde(default)]
    pub frame: Frame,
}

fn z_up() -> [f64; 3] {
    [0.0, 0.0, 1.0]
}

/// The `[render]` table as written.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RenderSpec {
    /// Draw hidden lines too, with this pen, on their own layer.
    pub hidden_pen: Option<u32>,
    /// Hidden lines' dash and gap, mm on paper (default 3.5, 1.5).
    pub hidden_dash_mm: Option<[f64; 2]>,
}

/// Render options.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RenderOptions {
    /// When set, hidden parts of lines are drawn with this pen on a
    /// [`strokes::LineKind::Hidden`] layer.
    pub hidden_pen: Option<u32>,
    /// How those hidden lines are dashed on paper.
    pub hidden_dash: strokes::Dash,
}

/// The whole scene file as written (the serde side; validated into [`Scene`]).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    /// `[camera]`.
    pub camera: Spanned<CameraSpec>,
    /// `[page]`.
    #[serde(default)]
    pub page: Option<Spanned<PageSpec>>,
    /// `[render]`.
    #[serde(default)]
    pub render: Option<Spanned<RenderSpec>>,
    /// `[[mesh]]`.
    #[serde(default)]
    pub mesh: Vec<Spanned<MeshSpec>>,
    /// `[[polygon]]`.
    #[serde(default)]
    pub polygon: Vec<Spanned<PolygonSpec>>,
    /// `[[polyline]]`.
    #[serde(default)]
    pub polyline: Vec<Spanned<PolylineSpec>>,
    /// `[[map]]` outlines (see [`crate::map`]).
    #[serde(default)]
    pub map: Vec<Spanned<MapSpec>>,
    /// `[[symbols]]`.
    #[serde(default)]
    pub symbols: Vec<Spanned<SymbolsSpec>>,
    /// `[[labels]]`.
    #[serde(default)]
    pub labels: Vec<Spanned<LabelsSpec>>,
    /// `[animation]`.
    #[serde(default)]
    pub animation: Option<Spanned<AnimationSpec>>,
    /// `[[surface]]`.
    #[serde(default)]
    pub surface: Vec<Spanned<SurfaceSpec>>,
    /// `[[axes]]`.
    #[serde(default)]
    pub axes: Vec<Spanned<AxesSpec>>,
    /// `[[ridgeline]]`.
    #[serde(default)]
    pub ridgeline: Vec<Spanned<RidgelineSpec>>,
    /// `[[contours]]`.
    #[serde(default)]
    pub contours: Vec<Spanned<ContoursSpec>>,
    /// `[[text]]`.
    #[serde(default)]
    pub text: Vec<Spanned<TextSpec>>,
}

/// A loaded, validated scene: everything [`crate::render::render()`] needs.
#[derive(Clone, Debug)]
pub struct Scene {
    /// The scene file (for messages).
    pub path: PathBuf,
    /// The camera.
    pub camera: Camera,
    /// How the picture is framed.
    pub frame: Frame,
    /// The paper.
    pub page: Page,
    /// Render options.
    pub options: RenderOptions,
    /// `[[mesh]]` objects, loaded, in world space.
    pub meshes: Vec<Mesh>,
    /// `[[polygon]]` objects (degenerate ones dropped).
    pub polygons: Vec<Polygon>,
    /// `[[polyline]]` objects.
    pub polylines: Vec<Polyline3>,
    /// The map tables (`[[map]]`, `[[symbols]]`, `[[labels]]`,
    /// `[animation]`), loaded once and shared by every frame's scene.
    pub maps: Option<Arc<MapScene>>,
    /// Which frame of the `[animation]` this scene shows (0 for a still).
    pub frame_index: usize,
    /// `[[surface]]` objects.
    pub surfaces: Vec<Surface>,
    /// `[[axes]]` objects (lines around a surface).
    pub axes: Vec<Axes>,
    /// `[[ridgeline]]` objects.
    pub ridgelines: Vec<Ridgeline>,
    /// `[[contours]]` objects (contour lines of a surface).
    pub contours: Vec<Contours>,
    /// `[[text]]` objects: on the page, or in 3-D.
    pub texts: Vec<Text>,
}

impl Scene {
    /// Reads and validates a scene file and every mesh it names.
    ///
    /// # Errors
    /// A [`SceneError`] naming the file (scene or mesh), the line and the field.
    pub fn load(path: impl AsRef<Path>) -> Result<Scene, SceneError> {
        let path = path.as_ref();
        let bytes = crate::mesh_file::read_limited(&FileSystem, path, MAX_SCENE_BYTES)?;
        let text = String::from_utf8(bytes).map_err(|e| {
            let at = e.utf8_error().valid_up_to();
            let text = String::from_utf8_lossy(e.as_bytes()).into_owned();
            SceneError::new(path, SceneErrorKind::Toml(format!("not UTF-8 text (byte {at})"))).at_line(line_of(&text, at))
        })?;
        Scene::from_toml(&text, path)
    }

    /// Validates scene text as if read from `path` (mesh paths are relative to
    /// its directory).
    ///
    /// # Errors
    /// As [`Scene::load`].
    pub fn from_toml(text: &str, path: &Path) -> Result<Scene, SceneError> {
        Scene::from_toml_in(text, path, &FileSystem)
    }

    /// [`Scene::from_toml`] reading every file the scene names through
    /// `files` (the paths it is asked for are `path`'s directory joined with
    /// the names as written), not the file system.
    ///
    /// # Errors
    /// As [`Scene::load`]; also a file `files` refuses.
    pub fn from_toml_in(text: &str, path: &Path, files: &dyn Resolver) -> Result<Scene, SceneError> {
        let err = |kind| SceneError::new(path, kind);
        let file: SceneFile = toml::from_str(text).map_err(|e| {
            // The message may quote a key or value: a short excerpt of it.
            let msg = crate::excerpt::excerpt_of(e.message().trim_end(), 200);
            match e.span() {
                // Quote the line: the message alone often does not name the key.
                Some(span) => {
                    let line = line_of(text, span.start);
                    let quoted = excerpt(text.lines().nth(line - 1).unwrap_or("").trim());
                    err(SceneErrorKind::Toml(format!("{msg} (in `{quoted}`)"))).at_line(line)
                }
                None => match first_failing_line(text, e.message()) {
                    Some(line) => err(SceneErrorKind::Toml(msg.to_string())).at_line(line),
                    None => err(SceneErrorKind::Toml(msg.to_string())),
                },
            }
        })?;
        let at = |span: std::ops::Range<usize>, field: String, kind| err(kind).at_line(line_of(text, span.start)).in_field(field);
        let base = path.parent().unwrap_or(Path::new(""));

        let cam = file.camera.get_ref();
        for (name, p) in [("eye", cam.eye), ("target", cam.target)] {
            if let Some(far) = crate::tolerance::beyond_limit(DVec3::from(p)).filter(|c| c.is_finite()) {
                return Err(at(file.camera.span(), format!("camera.{name}"), SceneErrorKind::TooFar(far)));
            }
        }
        if let Some(h) = cam.ortho_height.filter(|h| h.abs() > 2.0 * crate::tolerance::MAX_COORDINATE) {
            return Err(at(file.camera.span(), "camera.ortho_height".into(), SceneErrorKind::TooFar(h)));
        }
        let projection = match (cam.fov_deg, cam.ortho_height) {
            (Some(fov_deg), None) => Projection::Perspective { fov_deg },
            (None, Some(height)) => Projection::Orthographic { height },
            _ => return Err(at(file.camera.span(), "camera".into(), SceneErrorKind::Projection)),
        };
        let camera = Camera::new(DVec3::from(cam.eye), DVec3::from(cam.target), DVec3::from(cam.up), projection)
            .map_err(|e| at(file.camera.span(), "camera".into(), e.into()))?;

        let page = match &file.page {
            None => Page::default(),
            Some(p) => Page::from_spec(p.get_ref()).map_err(|e| at(p.span(), "page".into(), SceneErrorKind::OutOfRange(e.to_string())))?,
        };
        let mut options = RenderOptions::default();
        if let Some(r) = &file.render {
            options.hidden_pen = r.get_ref().hidden_pen;
            if let Some([dash_mm, gap_mm]) = r.get_ref().hidden_dash_mm {
                options.hidden_dash = strokes::Dash { dash_mm, gap_mm };
                if !options.hidden_dash.is_valid() {
                    let (lo, hi) = (strokes::dash::MIN_DASH_MM, strokes::dash::MAX_DASH_MM);
                    let m = format!("hidden_dash_mm = [{dash_mm}, {gap_mm}]: dash and gap must each be {lo}..={hi} mm");
                    return Err(at(r.span(), "render.hidden_dash_mm".into(), SceneErrorKind::OutOfRange(m)));
                }
            }
        }

        let mut meshes = Vec::with_capacity(file.mesh.len());
        for (i, s) in file.mesh.iter().enumerate() {
            let spec = s.get_ref();
            let field = |sub: &str| format!("mesh[{i}]{sub}");
            if let Some(t) = &spec.transform {
                t.check().map_err(|(f, m)| at(s.span(), field(&format!(".transform.{f}")), SceneErrorKind::OutOfRange(m)))?;
            }
            if !(spec.crease_deg >= 0.0 && spec.crease_deg <= 180.0) {
                let m = format!("crease_deg = {} is outside [0, 180]", spec.crease_deg);
                return Err(at(s.span(), field(".crease_deg"), SceneErrorKind::OutOfRange(m)));
            }
            let mesh_path = base.join(&spec.path);
            let raw = crate::mesh_file::read_mesh(&mesh_path, files).map_err(|e| match e.kind {
                // The file itself cannot be opened: point at the scene line naming it.
                SceneErrorKind::Io(_)
                | SceneErrorKind::Refused(_)
                | SceneErrorKind::UnknownMeshFormat
                | SceneErrorKind::FileTooLarge { .. } => {
                    let reason = e.kind.to_string();
                    at(s.span(), field(".path"), SceneErrorKind::MeshFile { path: mesh_path.clone(), reason })
                }
                _ => e,
            })?;
            let transform = spec.transform.unwrap_or_default();
            let m = transform.matrix();
            let vertices: Vec<DVec3> = raw.vertices.iter().map(|p| m.transform_point3(*p)).collect();
            if let Some((k, far)) = vertices.iter().enumerate().find_map(|(k, &v)| crate::tolerance::beyond_limit(v).map(|c| (k, c))) {
                return Err(at(s.span(), field(&format!(" (vertex {})", k + 1)), SceneErrorKind::TooFar(far)));
            }
            let style = match spec.edges {
                EdgeChoice::All => EdgeStyle::All,
                EdgeChoice::Feature => EdgeStyle::Feature { crease: spec.crease_deg.to_radians() },
            };
            let name = format!("{} ({})", field(""), mesh_path.display());
            let rounding = raw.rounding * transform.scale.abs();
            meshes.push(Mesh::rounded(&name, vertices, raw.polygons, rounding, style, spec.pen));
        }

        let mut polygons = Vec::with_capacity(file.polygon.len());
        for (i, s) in file.polygon.iter().enumerate() {
            match Polygon::from_spec(s.get_ref()).map_err(|(f, k)| at(s.span(), format!("polygon[{i}].{f}"), k))? {
                Some(p) => polygons.push(p),
                None => {
                    tracing::warn!("{}:{}: polygon[{i}] is degenerate (zero area); skipped", path.display(), line_of(text, s.span().start))
                }
            }
        }
        let polylines = file
            .polyline
            .iter()
            .enumerate()
            .map(|(i, s)| Polyline3::from_spec(s.get_ref()).map_err(|(f, k)| at(s.span(), format!("polyline[{i}].{f}"), k)))
            .collect::<Result<Vec<_>, _>>()?;

        let surfaces = file
            .surface
            .iter()
            .enumerate()
            .map(|(i, s)| Surface::from_spec(s.get_ref(), base, files).map_err(|(f, k)| at(s.span(), format!("surface[{i}].{f}"), k)))
            .collect::<Result<Vec<_>, _>>()?;
        for (i, s) in surfaces.iter().enumerate() {
            let g = &s.grid;
            let far = (0..g.ny()).flat_map(|j| (0..g.nx()).map(move |i| g.point(i, j))).find_map(crate::tolerance::beyond_limit);
            if let Some(far) = far {
                return Err(at(file.surface[i].span(), format!("surface[{i}]"), SceneErrorKind::TooFar(far)));
            }
        }
        let ridgelines = file
            .ridgeline
            .iter()
            .enumerate()
            .map(|(i, s)| Ridgeline::from_spec(s.get_ref(), base, files).map_err(|(f, k)| at(s.span(), format!("ridgeline[{i}].{f}"), k)))
            .collect::<Result<Vec<_>, _>>()?;
        for (i, r) in ridgelines.iter().enumerate() {
            if let Some(far) = r.profiles.iter().flatten().copied().chain([DVec3::Z * r.base]).find_map(crate::tolerance::beyond_limit) {
                return Err(at(file.ridgeline[i].span(), format!("ridgeline[{i}]"), SceneErrorKind::TooFar(far)));
            }
        }
        let contours = file
            .contours
            .iter()
            .enumerate()
            .map(|(i, s)| Contours::from_spec(s.get_ref(), &surfaces).map_err(|(f, k)| at(s.span(), format!("contours[{i}].{f}"), k)))
            .collect::<Result<Vec<_>, _>>()?;
        let axes = file
            .axes
            .iter()
            .enumerate()
            .map(|(i, s)| {
                let spec = s.get_ref();
                // The box's floor is the contour map's plane under its surface, if any.
                let base_z = file
                    .contours
                    .iter()
                    .zip(&contours)
                    .filter(|(c, lowered)| c.get_ref().surface == spec.surface && lowered.on == ContourPlace::Base)
                    .filter_map(|(_, lowered)| lowered.segments.first().map(|seg| seg.0.z))
                    .reduce(f64::min);
                Axes::from_spec(spec, &surfaces, base_z, &camera).map_err(|(f, k)| at(s.span(), format!("axes[{i}].{f}"), k))
            })
            .collect::<Result<Vec<_>, _>>()?;

        let texts = file
            .text
            .iter()
            .enumerate()
            .map(|(i, s)| Text::from_spec(s.get_ref()).map_err(|(f, k)| at(s.span(), format!("text[{i}].{f}"), k)))
            .collect::<Result<Vec<_>, _>>()?;

        let maps = load_maps(&file, text, path, base, &camera, files)?;
        let scene = Scene {
            texts,
            path: path.to_path_buf(),
            camera,
            frame: cam.frame,
            page,
            options,
            meshes,
            polygons,
            polylines,
            maps,
            surfaces,
            axes,
            contours,
            ridgelines,
            frame_index: 0,
        };
        if scene.is_empty() {
            return Err(err(SceneErrorKind::Empty));
        }
        let faces = scene.face_estimate();
        if faces > MAX_FACES {
            return Err(err(SceneErrorKind::TooMany { what: "faces", count: faces, limit: MAX_FACES }));
        }
        Ok(scene)
    }

    /// True when there is nothing to draw (no objects, or only degenerate ones).
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.meshes.iter().all(|m| m.faces.is_empty())
            && self.polygons.is_empty()
            && self.polylines.is_empty()
            && self.maps.as_ref().is_none_or(|m| m.is_empty())
            && self.surfaces.is_empty()
            && self.ridgelines.is_empty()
            && self.texts.is_empty()
    }

    /// Number of frames: the `[animation]`'s, or 1 for a still.
    #[must_use]
    pub fn frame_count(&self) -> usize {
        self.maps.as_ref().map_or(1, |m| m.frames())
    }

    /// The scene of frame `index` of the animation: symbol values and camera
    /// moved to that frame. Call it on the scene as loaded (its camera is the
    /// base the keyframes move from). Cheap: the data are shared, not copied.
    ///
    /// # Errors
    /// `index` past the last frame, or the keyframed camera is unusable
    /// (both are checked at load time for every frame, so this does not
    /// happen for a loaded scene and an index below [`Scene::frame_count`]).
    pub fn frame(&self, index: usize) -> Result<Scene, SceneError> {
        let n = self.frame_count();
        if index >= n {
            let m = format!("frame {index} is past the last frame {}", n - 1);
            return Err(SceneError::new(&self.path, SceneErrorKind::OutOfRange(m)).in_field("animation"));
        }
        let mut s = self.clone();
        s.frame_index = index;
        if let Some(m) = &self.maps {
            s.camera = m.camera(index, &self.camera).map_err(|e| SceneError::new(&self.path, e.into()).in_field("animation.camera"))?;
            // Axes face the frame's viewer.
            s.axes = self.axes.iter().map(|a| a.facing(&s.camera)).collect();
        }
        Ok(s)
    }

    /// Every frame's scene, in order (one for a still): what `render -o
    /// frame-%04d.svg` renders and `submit` plots as consecutive pages.
    pub fn frames(&self) -> impl Iterator<Item = Result<Scene, SceneError>> + '_ {
        (0..self.frame_count()).map(|i| self.frame(i))
    }

    /// How much work rendering every frame of the scene takes, estimated
    /// from what was loaded, without lowering or rendering anything: what a
    /// daemon checks against its limits before it queues a job.
    #[must_use]
    pub fn work(&self) -> Work {
        let mesh: usize = self.meshes.iter().flat_map(|m| &m.faces).map(|f| f.vertices.len()).sum();
        let polygons: usize = self.polygons.iter().map(|p| p.outer.len() + p.holes.iter().map(Vec::len).sum::<usize>()).sum();
        let polylines: usize = self.polylines.iter().map(|p| p.points.len().saturating_sub(1)).sum();
        let surfaces: usize = self.surfaces.iter().map(|s| s.grid.nx() * s.grid.ny() * 2).sum();
        let segments: usize =
            self.axes.iter().map(|a| a.segments.len()).sum::<usize>() + self.contours.iter().map(|c| c.segments.len()).sum::<usize>();
        let ridges: usize = self.ridgelines.iter().flat_map(|r| &r.profiles).map(Vec::len).sum();
        let texts: usize = self.texts.iter().map(Text::segment_count).sum();
        // Each symbol draws its solid's edges; the outline is drawn once.
        let maps = self.maps.as_ref().map_or(0, |m| {
            m.maps.iter().map(|l| l.segments.len()).sum::<usize>()
                + m.symbols.iter().map(|s| s.solid.edges.len() * s.bases.len()).sum::<usize>()
        });
        Work {
            frames: self.frame_count(),
            general_faces: self.face_estimate(),
            segments: mesh + polygons + polylines + surfaces + segments + ridges + maps + texts,
        }
    }

    /// The general hidden-line engine's work on the scene, estimated from
    /// its faces' boxes in the picture ([`engine::estimate`]), without
    /// running it: `None` when the fast grid engine draws the scene (no
    /// faces for the general one). The first frame's, for an animation:
    /// frames move the camera, not the objects.
    ///
    /// [`engine::estimate`]: hiddenline::engine::estimate
    #[must_use]
    pub fn engine_estimate(&self) -> Option<hiddenline::engine::Estimate> {
        if self.face_estimate() == 0 {
            return None;
        }
        let first = self.frame(0).ok()?;
        Some(hiddenline::engine::estimate(&first.lower(), &first.camera))
    }

    /// Faces the scene lowers to, at most.
    fn face_estimate(&self) -> usize {
        let mesh: usize = self.meshes.iter().map(Mesh::model_face_count).sum();
        let surfaces: usize = if self.surface_on_fast_path() { 0 } else { self.surfaces.iter().map(Surface::face_count).sum() };
        let ridges: usize = self.ridgelines.iter().map(|r| r.profiles.len()).sum();
        mesh + self.polygons.len() + self.maps.as_ref().map_or(0, |m| m.face_estimate()) + surfaces + ridges
    }

    /// True when the scene is one surface and nothing else, so the fast grid
    /// engine ([`hiddenline::grid`]) draws it exactly; any other mix goes through
    /// the general engine, with surfaces lowered to triangles.
    #[must_use]
    pub fn grid_only(&self) -> bool {
        self.surfaces.len() == 1
            && self.only_grid_objects()
            && self.axes.is_empty()
            && self.contours.is_empty()
            && self.ridgelines.is_empty()
            && !self.has_world_text()
    }

    /// True when some `[[text]]` stands in 3-D and is hidden like a line.
    fn has_world_text(&self) -> bool {
        self.texts.iter().any(crate::text::Text::is_hidden_line)
    }

    /// True when `render` draws the scene's surface with the grid engine in
    /// every frame (alone, or with axes and contours the ground plan settles):
    /// then its faces never reach the general engine.
    fn surface_on_fast_path(&self) -> bool {
        if self.grid_only() {
            return true;
        }
        let Some(free) = self.grid_free_segments() else { return false };
        let grid = &self.surfaces[0].grid;
        match &self.maps {
            None => hiddenline::grid::free::takes(grid, &self.camera, &free),
            Some(m) => (0..m.frames()).all(|i| m.camera(i, &self.camera).is_ok_and(|c| hiddenline::grid::free::takes(grid, &c, &free))),
        }
    }

    /// True when the scene has no meshes, polygons, polylines or maps: only
    /// surfaces, ridgelines, axes and contours, what the grid engines draw.
    fn only_grid_objects(&self) -> bool {
        self.meshes.is_empty() && self.polygons.is_empty() && self.polylines.is_empty() && self.maps.as_ref().is_none_or(|m| m.is_empty())
    }

    /// The free segments drawn with the scene's one surface, in the order
    /// [`Scene::lower`] adds them (axes, contours, then texts in 3-D), when
    /// the scene is one surface with `[[axes]]`, `[[contours]]` and
    /// `[[text]]` and nothing else:
    /// [`hiddenline::grid::free`] may then draw it without the general engine.
    #[must_use]
    pub fn grid_free_segments(&self) -> Option<Vec<hiddenline::grid::free::FreeSegment>> {
        if !(self.surfaces.len() == 1 && self.only_grid_objects() && self.ridgelines.is_empty()) {
            return None;
        }
        let seg = |&(a, b): &(DVec3, DVec3), pen: u32, facet: Option<u32>| hiddenline::grid::free::FreeSegment { a, b, pen, facet };
        let axes = self.axes.iter().flat_map(|x| x.segments.iter().map(move |s| seg(s, x.pen, None)));
        let contours =
            self.contours.iter().flat_map(|c| c.segments.iter().enumerate().map(move |(n, s)| seg(s, c.pen, c.facets.get(n).copied())));
        let texts = self
            .texts
            .iter()
            .filter(|t| t.is_hidden_line())
            .flat_map(|t| t.world_segments(&self.camera).into_iter().map(move |s| seg(&s, t.pen, None)));
        Some(axes.chain(contours).chain(texts).collect())
    }

    /// The texts in 3-D drawn over the picture ([`crate::knockout`]): the
    /// world segments and pen of each `[[text]]` and map label with
    /// `knockout = true`, as seen by the camera in this frame.
    #[must_use]
    pub fn knockouts_in_world(&self) -> Vec<(Vec<(DVec3, DVec3)>, u32)> {
        let texts = self.texts.iter().filter(|t| t.knockout).map(|t| (t.world_segments(&self.camera), t.pen));
        let labels = self.maps.iter().flat_map(|m| m.knockout_labels(self.frame_index, &self.camera));
        texts.chain(labels).filter(|(s, _)| !s.is_empty()).collect()
    }

    /// True when the scene is `[[ridgeline]]`s and nothing else, so the
    /// horizon method ([`hiddenline::grid::ridgeline`]) can draw it (when the eye
    /// and every profile are not below the highest baseline).
    #[must_use]
    pub fn ridgelines_only(&self) -> bool {
        !self.ridgelines.is_empty()
            && self.surfaces.is_empty()
            && self.only_grid_objects()
            && self.axes.is_empty()
            && self.contours.is_empty()
            && !self.has_world_text()
    }

    /// Lowers every object to faces and edges for the engine, as seen by the
    /// scene's camera (silhouette edges depend on it).
    #[must_use]
    pub fn lower(&self) -> Model {
        let mut out = ModelBuilder::new();
        for m in &self.meshes {
            m.lower(&self.camera, &mut out);
        }
        for p in &self.polygons {
            p.lower(&mut out);
        }
        for p in &self.polylines {
            p.lower(&mut out);
        }
        if let Some(m) = &self.maps {
            m.lower(self.frame_index, &self.camera, &mut out);
        }
        for s in &self.surfaces {
            s.lower(&mut out);
        }
        for a in &self.axes {
            a.lower(&mut out);
        }
        for r in &self.ridgelines {
            r.lower(&mut out);
        }
        for c in &self.contours {
            c.lower(&mut out);
        }
        for t in &self.texts {
            t.lower(&self.camera, &mut out);
        }
        out.finish()
    }
}

/// Loads the map tables, if any; checks every frame's camera.
fn load_maps(
    file: &SceneFile,
    text: &str,
    path: &Path,
    base: &Path,
    camera: &Camera,
    files: &dyn Resolver,
) -> Result<Option<Arc<MapScene>>, SceneError> {
    let specs = MapSpecs {
        map: file.map.iter().map(|s| s.get_ref().clone()).collect(),
        symbols: file.symbols.iter().map(|s| s.get_ref().clone()).collect(),
        labels: file.labels.iter().map(|s| s.get_ref().clone()).collect(),
        animation: file.animation.as_ref().map(|s| s.get_ref().clone()),
    };
    if specs.is_empty() {
        return Ok(None);
    }
    let maps = MapScene::load_with_font(&specs, base, Some(&crate::map::labels::hershey), files).map_err(|e| {
        // Point at the table's line when the error names one.
        let span = match &e {
            crate::map::MapError::Spec { table, .. } => table_span(file, table),
            _ => None,
        };
        let err = SceneError::new(path, SceneErrorKind::Map(e));
        match span {
            Some(start) => err.at_line(line_of(text, start)),
            None => err,
        }
    })?;
    for i in 0..maps.frames() {
        maps.camera(i, camera).map_err(|e| {
            let err = SceneError::new(path, e.into()).in_field(format!("animation.camera (frame {i})"));
            match &file.animation {
                Some(a) => err.at_line(line_of(text, a.span().start)),
                None => err,
            }
        })?;
    }
    Ok(Some(Arc::new(maps)))
}

/// Byte offset of the map table named like `symbols[2]` or `animation`.
fn table_span(file: &SceneFile, table: &str) -> Option<usize> {
    let (kind, index) = match table.split_once('[') {
        Some((k, rest)) => (k, rest.trim_end_matches(']').parse::<usize>().ok()?),
        None => (table, 0),
    };
    match kind {
        "map" => file.map.get(index).map(|s| s.span().start),
        "symbols" => file.symbols.get(index).map(|s| s.span().start),
        "labels" => file.labels.get(index).map(|s| s.span().start),
        "animation" => file.animation.as_ref().map(|s| s.span().start),
        _ => None,
    }
}

/// The work a scene asks for, estimated at load ([`Scene::work`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Work {
    /// Frames of its `[animation]` (1 for a still): each is rendered.
    pub frames: usize,
    /// Faces each frame gives the general engine, at most (0 when the fast
    /// grid engines draw it all).
    pub general_faces: usize,
    /// Line segments each frame may draw, at most (an upper bound of what
    /// is emitted: hidden-line removal only removes).
    pub segments: usize,
}

/// The line a TOML error given without a place comes from (the parser's
/// recursion limit, for keys or arrays nested too deep, has none): the first
/// line whose prefix of the file fails with the same message. A binary
/// search: at most about log2(lines) parses of the text.
fn first_failing_line(text: &str, message: &str) -> Option<usize> {
    let ends: Vec<usize> = text.match_indices('\n').map(|(i, _)| i + 1).chain(std::iter::once(text.len())).collect();
    let fails =
        |k: usize| toml::from_str::<toml::Table>(&text[..ends[k]]).err().is_some_and(|e| e.span().is_none() && e.message() == message);
    let (mut lo, mut hi) = (0, ends.len() - 1);
    if !fails(hi) {
        return None;
    }
    while lo < hi {
        let mid = (lo + hi) / 2;
        if fails(mid) {
            hi = mid;
        } else {
            lo = mid + 1;
        }
    }
    Some(lo + 1)
}
