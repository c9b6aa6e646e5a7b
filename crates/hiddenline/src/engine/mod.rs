//! The exact hidden-line engine for scenes of planar polygons and lines.
//!
//! [`visibility`] answers, for every line of a [`Model`] (each edge, and each
//! penetration line where two faces pass through each other), the exact
//! parameter intervals that the camera sees. Exact means in object space:
//! visibility along a line can only change where, on screen, it crosses a
//! face's boundary or where it pierces a face's plane (Hedgley's theorem), so
//! the engine computes those events and tests one point per interval between
//! them. Nothing is sampled.
//!
//! The pipeline:
//! 1. penetration lines, in world space ([`intersect`]);
//! 2. faces clipped at the near plane, projected to device space, edge-on and
//!    (when safe) back faces dropped, sorted front to back ([`faces`]);
//! 3. a bounding-volume hierarchy over the faces' screen boxes, with depth
//!    ([`bvh`]);
//! 4. per line, in parallel: candidate faces whose boxes the line meets and
//!    that start in front of its far end, rejected by plane side, events and midpoint tests per face, the union
//!    of hidden intervals, its complement ([`line`]).
//!
//! # Rules for the degenerate cases
//! These are the reference checker's rules too ([`crate::reference`]):
//! - A face hides a point when the sight ray from the point meets the face
//!   (boundary included: faces are closed) in front of the near plane and
//!   the point is farther than [`PLANE_REL`](crate::tolerance::PLANE_REL)
//!   times the scene size behind the face's plane. Hence a line lying in a
//!   face's plane is never hidden by it, **coplanar faces never hide one
//!   another's lines** (the outlines of overlapping coplanar faces are all
//!   drawn), and a face seen exactly edge-on hides nothing.
//! - The faces an edge lies on ([`Edge::faces`](crate::Edge::faces)) never
//!   hide it, nor do two faces their own penetration line.
//! - Penetration lines are where the *interiors* of two faces meet; contact
//!   along a boundary is not one. Their pen is the lower-numbered face's.
//! - Geometry in front of the near plane is all there is: an eye inside the
//!   scene is ordinary input.
//! - Back faces are skipped only if every face marked
//!   [`Face::outward`](crate::Face::outward) lies wholly in front of the near
//!   plane (which also rules out an eye inside a closed mesh).
//!
//! Lines entirely behind the near plane, or seen end-on (a point on screen),
//! have no entry in the answer.

mod bvh;
mod estimate;
mod faces;
mod intersect;
mod intervals;
mod line;

use glam::DVec3;
use rayon::prelude::*;

use crate::camera::Camera;
use crate::model::{LineSource, LineVisibility, Model};
use crate::tolerance::PLANE_REL;
pub use estimate::{estimate, Estimate};
pub use faces::scene_scale;
use line::{Exclude, Line, Scratch};

/// The penetration lines of `model`: `(i, j, a, b)` with `i < j`, the world
/// segment `a`-`b` where the interiors of faces `i` and `j` meet.
#[must_use]
pub fn penetrations(model: &Model, camera: &Camera) -> Vec<(u32, u32, DVec3, DVec3)> {
    intersect::penetrations(model, PLANE_REL * scene_scale(model, camera))
}

/// The exact visible intervals of every line of `model` seen through
/// `camera`: first the edges (in order, [`LineSource::Edge`]), then the
/// penetration lines ([`LineSource::Intersection`]). Lines behind the near
/// plane or seen end-on are left out.
#[must_use]
pub fn visibility(model: &Model, camera: &Camera) -> Vec<LineVisibility> {
    let eps = PLANE_REL * scene_scale(model, camera);
    let crossings = intersect::penetrations(model, eps);
    let mut lines: Vec<Line> = model
        .edges
        .iter()
        .enumerate()
        .filter_map(|(i, e)| Line::new(LineSource::Edge(i as u32), e.pen, Exclude::Faces(&e.faces), e.a, e.b, camera))
        .collect();
    lines.extend(crossings.iter().filter_map(|&(i, j, a, b)| {
        let pen = model.faces[i as usize].pen;
        Line::new(LineSource::Intersection(i, j), pen, Exclude::Pair(i, j), a, b, camera)
    }));
    if lines.is_empty() {
        return Vec::new();
    }
    let occluders = faces::prepare(model, camera, eps);
    let bvh = bvh::Bvh::new(&occluders.faces);
    lines.par_iter().map_init(Scratch::default, |s, l| line::visibility(l, &occluders, &bvh, eps, s)).collect()
}
