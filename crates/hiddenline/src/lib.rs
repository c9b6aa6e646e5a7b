//! Exact hidden-line removal for 3-D line drawings, and the ordering of the
//! visible lines into pen strokes.
//!
//! This is the geometric core of plotd. It takes a scene (polygons, meshes, free
//! 3-D lines, seen through a camera), computes exactly which parts of every line
//! are visible, fits them to a page in millimetres, and hands back a [`Drawing`]:
//! polylines grouped by pen. It knows nothing about HP-GL, G-code, serial ports
//! or clocks; the only I/O it does is reading the scene and mesh files a scene
//! names.
//!
//! Data flows one way:
//!
//! ```text
//! scene file -> Scene -> visible polylines (Drawing, page mm) -> ordered strokes (Drawing)
//! ```
//!
//! The main types:
//! - [`Scene`] ([`Scene::load`]): a validated scene file with its meshes loaded;
//!   [`render()`] turns it into a [`Drawing`] on its [`Page`].
//! - [`Camera`]: world space to device space, near-plane clipping.
//! - [`Model`]: faces that hide and edges that are drawn, the engine's input.
//! - [`Drawing`], [`Layer`], [`Polyline`]: the 2-D result, the currency between
//!   this crate and `plotcode`.
//! - [`MotionModel`] and [`PlotStats`]: how long a drawing takes to plot.
//! - [`engine::visibility`]: the exact hidden-line engine; [`reference`]: the
//!   brute-force ray-casting checker every hidden-line test is judged by.
//!
//! ```no_run
//! let scene = hiddenline::Scene::load("examples/cube.toml")?;
//! let drawing = hiddenline::render(&scene)?;
//! println!("{:.1} mm in {} strokes", drawing.drawn_length(), drawing.stroke_count());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
#![deny(missing_docs)]

pub mod camera;
mod data_csv;
pub mod drawing;
pub mod engine;
pub mod font;
pub mod grid;
pub mod map;
pub mod model;
pub mod page;
pub mod plot_time;
pub mod reference;
pub mod render;
pub mod scene;
pub mod strokes;
pub mod tolerance;

pub use camera::{Camera, CameraError, Projection, Projector};
pub use drawing::{Drawing, Layer, LineKind, Polyline};
pub use glam::{DMat4, DVec2, DVec3, DVec4};
pub use model::{Edge, Face, Intervals, LineSource, LineVisibility, Model};
pub use page::{Frame, Page};
pub use plot_time::{MotionModel, PlotStats};
pub use render::{render, RenderError};
pub use scene::{Scene, SceneError};
