//! Exact hidden-line removal for 3-D line drawings.
//!
//! This is the geometric core of plotd. It takes a [`Model`] (faces that hide
//! and edges that are drawn, in world space) and a [`Camera`], and computes
//! exactly which parts of every edge the eye sees: a [`LineVisibility`] per
//! edge, a list of parameter intervals. Visibility changes only where a line
//! crosses a face's outline or pierces a face, and those points are computed,
//! never sampled.
//!
//! It knows nothing about scene files, pages, pens' order, HP-GL, G-code,
//! serial ports or clocks, and does no I/O: the `scene` crate builds the
//! model and places the result on paper.
//!
//! The main types:
//! - [`Camera`]: world space to device space, near-plane clipping.
//! - [`Model`]: faces that hide and edges that are drawn, the engine's input.
//! - [`engine::visibility`]: the general exact engine (any polygons).
//! - [`grid::visibility`]: the fast exact engine for height fields on a grid
//!   ([`grid::Grid`]), and [`grid::ridgeline`] for stacked profiles.
//! - [`reference`]: the brute-force ray-casting checker every hidden-line
//!   test is judged by; it shares no code with the engines.
//!
//! ```
//! use hiddenline::{engine, Camera, DVec3, Edge, Face, Model, Projection};
//! // A square facing the eye, and a line behind it, longer than it is wide.
//! let square = [[-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [1.0, 1.0, 0.0], [-1.0, 1.0, 0.0]];
//! let face = Face { outer: square.map(DVec3::from).to_vec(), holes: vec![], pen: 1, outward: false };
//! let line = Edge { a: DVec3::new(-2.0, 0.0, -1.0), b: DVec3::new(2.0, 0.0, -1.0), pen: 1, faces: vec![] };
//! let model = Model { faces: vec![face], edges: vec![line] };
//! let camera = Camera::new(DVec3::new(0.0, 0.0, 10.0), DVec3::ZERO, DVec3::Y,
//!     Projection::Orthographic { height: 5.0 })?;
//! let seen = engine::visibility(&model, &camera);
//! // Only its two ends, outside the square, are visible.
//! assert_eq!(seen[0].visible.len(), 2);
//! # Ok::<(), hiddenline::CameraError>(())
//! ```
#![deny(missing_docs)]

pub mod camera;
pub mod clip;
pub mod engine;
pub mod grid;
pub mod model;
pub mod reference;
pub mod tolerance;

pub use camera::{Camera, CameraError, Projection, Projector};
pub use glam::{DMat4, DVec2, DVec3, DVec4};
pub use model::{Edge, Face, Intervals, LineSource, LineVisibility, Model};
