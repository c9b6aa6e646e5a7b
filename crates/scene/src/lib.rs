//! The scene file and everything it names, lowered to the hidden-line
//! engine's model, and rendered to a drawing on paper.
//!
//! A scene is a TOML file: one `[camera]`, an optional `[page]` and
//! `[render]`, and any number of objects (`[[mesh]]` from OBJ or STL,
//! `[[polygon]]`, `[[polyline]]`, `[[surface]]` from an expression or a CSV of
//! heights, `[[axes]]`, `[[contours]]`, `[[ridgeline]]`, statistical
//! `[[map]]`s with 3-D symbols and their `[animation]`). This crate reads all
//! of it, and every file it names, with errors that name the file, line and
//! field; it is the only crate on the geometry side that does file I/O.
//!
//! The main types:
//! - [`Scene`] ([`Scene::load`], [`Scene::from_toml`]): a validated scene with
//!   every file it names read; [`Scene::lower`] builds the engine's
//!   [`hiddenline::Model`].
//! - [`render()`]: a scene to a [`strokes::Drawing`] on its [`Page`], by the
//!   fast grid engine where it can settle the scene exactly, else by the
//!   general engine.
//! - [`Resolver`]: where a scene's files come from (the file system, or a
//!   daemon job's attachments: [`Attached`]).
//! - [`ModelBuilder`]: the lowering every object kind shares (shared edges
//!   drawn once, coplanar seams dropped).
//!
//! ```no_run
//! let scene = scene::Scene::load("examples/cube.toml")?;
//! let drawing = scene::render(scene)?;
//! println!("{:.1} mm in {} strokes", drawing.drawn_length(), drawing.stroke_count());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
#![deny(missing_docs)]

pub mod axes;
pub mod builder;
pub mod contours;
mod data_csv;
pub mod error;
pub mod excerpt;
pub mod expr;
pub mod font;
pub mod geometry;
pub mod knockout;
pub mod map;
pub mod mesh;
pub mod mesh_file;
pub mod page;
mod points;
pub mod polygon;
pub mod polyline;
pub mod render;
pub mod resolver;
pub mod ridgeline;
pub mod scene;
pub mod surface;
pub mod table;
pub mod text;
pub mod tolerance;
pub mod transform;

pub use axes::{Axes, AxesSpec};
pub use builder::ModelBuilder;
pub use contours::{Contours, ContoursSpec};
pub use error::{SceneError, SceneErrorKind};
pub use mesh::{EdgeChoice, EdgeStyle, Mesh, MeshSpec};
pub use page::{Frame, Page};
pub use points::FieldError;
pub use polygon::{Polygon, PolygonSpec};
pub use polyline::{Polyline3, PolylineSpec};
pub use render::{render, RenderError};
pub use resolver::{Attached, FileSystem, ReadError, Recorder, Resolver};
pub use ridgeline::{Ridgeline, RidgelineSpec};
pub use scene::{Scene, Work};
pub use surface::{Surface, SurfaceSpec};
pub use text::{Text, TextSpec};
pub use transform::Transform;
