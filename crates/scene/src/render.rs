//! The pipeline: scene -> model -> visible intervals -> polylines on a page.
//!
//! [`render`] reads top to bottom: lower every object to faces and edges,
//! let the engine find the exact visible intervals of every line, cut the lines
//! into pieces (clipped to the camera's frame for `frame = "fov"`), place the
//! picture on the page, and join pieces that touch into polylines, one layer
//! per pen (and per line kind when hidden lines are drawn).
//!
//! The grid engine ([`hiddenline::grid`]) takes a scene of one surface (with
//! its axes and contours when it can settle them from the ground plan) or of
//! ridgelines seen from above; whenever it declines, the general engine draws
//! the lowered scene, with the same result.
//!
//! **Loading did all the I/O and validation: rendering a loaded scene fails
//! only when it lowers to nothing.**

use crate::knockout::Knockout;
use crate::page::{Frame, Placement};
use crate::scene::Scene;
use glam::{DVec2, DVec3};
use hiddenline::camera::Camera;
use hiddenline::clip::clip_segment_t;
use hiddenline::engine;
use hiddenline::model::LineVisibility;
use rayon::prelude::*;
use std::path::PathBuf;
use strokes::{Drawing, LineKind, Polyline};
use thiserror::Error;

/// Two piece ends closer than this (page mm) are the same point, so the pieces
/// join into one polyline. Far below any plotter's step (0.025 mm), far above
/// the rounding of a projected shared vertex.
pub const JOIN_TOL_MM: f64 = 1e-6;

/// With `frame = "fit"`, a drawing wider than this in device units (the field
/// of view is 2 tall) almost surely has lines running off towards the eye, and
/// fitting it shrinks the subject to nothing: worth a warning.
const HUGE_FIT: f64 = 100.0;

/// Hidden gaps between visible intervals shorter than this (in line
/// parameter) are rounding, not hidden lines.
const MIN_HIDDEN_T: f64 = 1e-9;

/// Why a scene cannot be rendered.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum RenderError {
    /// Lowering left no faces and no lines.
    #[error("{}: the scene lowers to nothing (every object degenerate)", .0.display())]
    Empty(PathBuf),
}

/// A straight piece of a line to draw, device space.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Piece {
    pen: u32,
    kind: LineKind,
    a: DVec2,
    b: DVec2,
}

/// Renders a scene to a drawing on its page: the visible lines (and, with
/// `hidden_pen`, the hidden ones on their own layer), in page millimetres.
///
/// The scene is taken whole so that its meshes can be freed once lowered:
/// the engine's own copy is what it works on (10^7 triangles: a 1.6 GB
/// mesh, the peak 5103 -> 3824 MB).
///
/// # Errors
/// [`RenderError::Empty`] when nothing is left to draw after lowering.
pub fn render(mut scene: Scene) -> Result<Drawing, RenderError> {
    // Texts in 3-D drawn over the picture, in device space: they take part
    // in fitting the picture to the page but not in hiding.
    let over: Vec<(Vec<Vec<DVec2>>, u32)> =
        scene.knockouts_in_world().into_iter().map(|(segments, pen)| (device_polylines(&segments, &scene.camera), pen)).collect();
    let over_points = || over.iter().flat_map(|(lines, _)| lines.iter().flatten().copied());
    let (mut drawing, placement) = match grid_polylines(&scene, bounds(over_points())) {
        Some(drawn) => drawn,
        None => picture(&mut scene, bounds(over_points()))?,
    };
    // 6. `[[text]]` on the page, where it says, over the picture; knockout
    //    texts (on the page or in 3-D) last, cutting what lies under them.
    let mut knockouts: Vec<Knockout> = over
        .into_iter()
        .map(|(lines, pen)| Knockout {
            pen,
            lines: lines.into_iter().map(|l| l.into_iter().map(|p| placement.apply(p)).collect()).collect(),
        })
        .collect();
    for t in &scene.texts {
        let lines = t.page_lines();
        if t.knockout {
            knockouts.push(Knockout { pen: t.pen, lines });
        } else if !lines.is_empty() {
            drawing.layer_mut(t.pen, LineKind::Visible).polylines.extend(lines.into_iter().map(Polyline::new));
        }
    }
    crate::knockout::apply(&mut drawing, &knockouts);
    Ok(drawing)
}

/// World segments as device-space polylines (segments that meet end to
/// start joined), the parts behind the eye left out.
fn device_polylines(segments: &[(DVec3, DVec3)], camera: &Camera) -> Vec<Vec<DVec2>> {
    let mut out: Vec<Vec<DVec2>> = Vec::new();
    let mut last_end: Option<DVec3> = None;
    for &(a, b) in segments {
        let (Some(pa), Some(pb)) = (camera.project(a), camera.project(b)) else {
            last_end = None;
            continue;
        };
        let (pa, pb) = (DVec2::new(pa.x, pa.y), DVec2::new(pb.x, pb.y));
        match out.last_mut() {
            Some(line) if last_end == Some(a) => line.push(pb),
            _ => out.push(vec![pa, pb]),
        }
        last_end = Some(b);
    }
    out
}

/// The picture of the scene's objects on the page (steps 1 to 5), and
/// where it was placed; `extra` is more device space the fit must hold.
fn picture(scene: &mut Scene, extra: Option<(DVec2, DVec2)>) -> Result<(Drawing, Placement), RenderError> {
    // 1-2. A scene that is one surface (or one ridgeline) takes the fast
    //    exact grid engine (same lines as the general one, near-linear
    //    time). Otherwise every
    //    object becomes faces that hide and edges that are drawn, and the
    //    engine finds the exact visible parameter intervals of every line and
    //    the lines where faces penetrate each other.
    let lines = if let Some(lines) = fast_lines(scene) {
        lines
    } else {
        let model = scene.lower();
        // Lowered: the model holds what the engine needs of the meshes.
        scene.meshes = Vec::new();
        if model.edges.is_empty() && model.faces.is_empty() && scene.texts.is_empty() && extra.is_none() {
            return Err(RenderError::Empty(scene.path.clone()));
        }
        engine::visibility(&model, &scene.camera)
    };
    // 3. Visible (and hidden, when asked) pieces in device space; with
    //    `frame = "fov"` clipped exactly at the camera's frame.
    let (window, fov_placement) = scene.page.fov();
    let window = (scene.frame == Frame::Fov).then_some(window);
    let pieces = pieces(&lines, scene.options.hidden_pen, window);
    drop(lines);
    // 4. Device space to page millimetres.
    let placement = match scene.frame {
        Frame::Fit => fitted(scene, bounds(pieces.iter().flat_map(|p| [p.a, p.b]).chain(extra.into_iter().flat_map(|(lo, hi)| [lo, hi])))),
        Frame::Fov => fov_placement,
    };
    // 5. Join touching pieces into polylines, one layer per pen and kind.
    let mut drawing = assemble(&pieces, placement, scene.page.width_mm, scene.page.height_mm);
    drawing.hidden_dash = scene.options.hidden_dash;
    Ok((drawing, placement))
}

/// The drawing of a scene that is one surface, visible lines only, fitted
/// to the page, straight from the grid engine's polylines (the visible
/// parts of each grid line, already joined), placed in place: no
/// per-edge [`LineVisibility`] (88 bytes each, 700 MB for a 2000 x 2000
/// grid) and no pieces. `None` for every other scene.
fn grid_polylines(scene: &Scene, extra: Option<(DVec2, DVec2)>) -> Option<(Drawing, Placement)> {
    if !(scene.grid_only() && scene.options.hidden_pen.is_none() && scene.frame == Frame::Fit) {
        return None;
    }
    let s = &scene.surfaces[0];
    let mut lines = hiddenline::grid::visible_lines(&s.grid, &scene.camera, s.drawn());
    let drawn = lines.par_iter().filter_map(|l| bounds(l.iter().copied())).reduce_with(|a, b| bounds([a.0, a.1, b.0, b.1]).unwrap_or(a));
    let placement = fitted(scene, bounds(drawn.into_iter().chain(extra).flat_map(|(lo, hi)| [lo, hi])));
    lines.par_iter_mut().flatten().for_each(|p| *p = placement.apply(*p));
    let mut drawing = Drawing::new(scene.page.width_mm, scene.page.height_mm);
    if !lines.is_empty() {
        drawing.layer_mut(s.pen, LineKind::Visible).polylines = lines.into_iter().map(Polyline::new).collect();
    }
    Some((drawing, placement))
}

/// The placement that fits device-space `bounds` to the page, with a
/// warning when the drawing is far larger than the view.
fn fitted(scene: &Scene, b: Option<(DVec2, DVec2)>) -> Placement {
    if b.is_some_and(|(lo, hi)| (hi - lo).max_element() > HUGE_FIT) {
        tracing::warn!(
            "{}: the drawing spans {:.0} times the field of view (lines run towards the eye?); \
             camera.frame = \"fov\" clips it to the view",
            scene.path.display(),
            b.map_or(0.0, |(lo, hi)| (hi - lo).max_element() / 2.0)
        );
    }
    scene.page.fit(b)
}

/// The visibility of every line by a fast exact path, when the scene is one
/// the grid engine draws (one surface, alone or with axes and base-plane
/// contours it can settle exactly; ridgelines seen from above their
/// baselines), numbered as `Scene::lower` numbers the lines.
fn fast_lines(scene: &Scene) -> Option<Vec<LineVisibility>> {
    if scene.grid_only() {
        let s = &scene.surfaces[0];
        return Some(hiddenline::grid::visibility(&s.grid, &scene.camera, s.drawn(), s.pen));
    }
    if let Some(free) = scene.grid_free_segments() {
        let s = &scene.surfaces[0];
        if let Some(lines) = hiddenline::grid::free::visibility_with_free(&s.grid, &scene.camera, s.drawn(), s.pen, &free) {
            return Some(lines);
        }
    }
    if scene.ridgelines_only() {
        let sets: Vec<_> = scene.ridgelines.iter().map(crate::ridgeline::Ridgeline::curtains).collect();
        return hiddenline::grid::ridgeline::visibility(&sets, &scene.camera);
    }
    None
}

/// The visible intervals of every line as pieces, plus the hidden remainder
/// (drawn with `hidden_pen`) when asked; clipped to `window` when given.
fn pieces(lines: &[LineVisibility], hidden_pen: Option<u32>, window: Option<(DVec2, DVec2)>) -> Vec<Piece> {
    let mut out = Vec::with_capacity(lines.len() + lines.len() / 2);
    for line in lines {
        if !(line.a.is_finite() && line.b.is_finite()) {
            continue;
        }
        let (lo, hi) = match window {
            Some((wlo, whi)) => match clip_segment_t(line.a, line.b, wlo, whi) {
                Some(range) => range,
                None => continue,
            },
            None => (0.0, 1.0),
        };
        let mut push = |t0: f64, t1: f64, pen: u32, kind: LineKind| {
            let (t0, t1) = (t0.max(lo), t1.min(hi));
            if t1 > t0 {
                let d = line.b - line.a;
                out.push(Piece { pen, kind, a: line.a + d * t0, b: line.a + d * t1 });
            }
        };
        let mut hidden_from = 0.0;
        for &(t0, t1) in &line.visible {
            if let Some(pen) = hidden_pen {
                if t0 - hidden_from > MIN_HIDDEN_T {
                    push(hidden_from, t0, pen, LineKind::Hidden);
                }
            }
            push(t0, t1, line.pen, LineKind::Visible);
            hidden_from = t1;
        }
        if let Some(pen) = hidden_pen {
            if 1.0 - hidden_from > MIN_HIDDEN_T {
                push(hidden_from, 1.0, pen, LineKind::Hidden);
            }
        }
    }
    out
}

/// Bounding box of device-space points.
fn bounds(points: impl IntoIterator<Item = DVec2>) -> Option<(DVec2, DVec2)> {
    let mut pts = points.into_iter();
    let first = pts.next()?;
    Some(pts.fold((first, first), |(lo, hi), p| (lo.min(p), hi.max(p))))
}

/// Places the pieces on the page and joins each piece to the polyline before
/// it on its layer when they touch (end to start, or end to end reversed).
fn assemble(pieces: &[Piece], placement: Placement, width_mm: f64, height_mm: f64) -> Drawing {
    let mut drawing = Drawing::new(width_mm, height_mm);
    // Layers in a fixed order: visible lines by pen, then hidden ones.
    let mut keys: Vec<(LineKind, u32)> = pieces.iter().map(|p| (p.kind, p.pen)).collect();
    keys.sort_by_key(|&(kind, pen)| (kind == LineKind::Hidden, pen));
    keys.dedup();
    for (kind, pen) in keys {
        drawing.layer_mut(pen, kind);
    }
    for p in pieces {
        let (a, b) = (placement.apply(p.a), placement.apply(p.b));
        let layer = drawing.layer_mut(p.pen, p.kind);
        match layer.polylines.last_mut() {
            Some(last) if last.end().is_some_and(|e| e.distance(a) <= JOIN_TOL_MM) => last.points.push(b),
            Some(last) if last.end().is_some_and(|e| e.distance(b) <= JOIN_TOL_MM) => last.points.push(a),
            _ => layer.polylines.push(Polyline::new(vec![a, b])),
        }
    }
    drawing
}

#[cfg(test)]
mod tests {
    use super::*;
    use hiddenline::model::LineSource;

    fn line(a: (f64, f64), b: (f64, f64), visible: Vec<(f64, f64)>) -> LineVisibility {
        LineVisibility { source: LineSource::Edge(0), pen: 1, a: DVec2::new(a.0, a.1), b: DVec2::new(b.0, b.1), visible: visible.into() }
    }

    const ID: Placement = Placement { scale: 1.0, offset: DVec2::ZERO };

    #[test]
    fn touching_pieces_stay_one_polyline() {
        let lines = vec![
            line((0.0, 0.0), (1.0, 0.0), vec![(0.0, 0.5), (0.5, 1.0)]),
            line((1.0, 0.0), (1.0, 1.0), vec![(0.0, 1.0)]),
            // Drawn backwards: still joins.
            line((0.0, 1.0), (1.0, 1.0), vec![(0.0, 1.0)]),
            // Its first piece continues the chain; after the gap, a new polyline.
            line((0.0, 1.0), (0.0, 0.0), vec![(0.0, 0.4), (0.6, 1.0)]),
        ];
        let d = assemble(&pieces(&lines, None, None), ID, 10.0, 10.0);
        assert_eq!(d.layers.len(), 1);
        let polys = &d.layers[0].polylines;
        assert_eq!(polys.len(), 2);
        assert_eq!(polys[0].points.len(), 6);
        assert_eq!(polys[1].points, vec![DVec2::new(0.0, 0.4), DVec2::new(0.0, 0.0)]);
        assert!((d.drawn_length() - 3.8).abs() < 1e-12);
    }

    #[test]
    fn hidden_parts_go_to_their_own_layer() {
        let lines = vec![line((0.0, 0.0), (10.0, 0.0), vec![(0.2, 0.5)]), line((0.0, 1.0), (10.0, 1.0), vec![])];
        let d = assemble(&pieces(&lines, Some(2), None), ID, 10.0, 10.0);
        assert_eq!(d.layers.len(), 2);
        assert_eq!((d.layers[0].pen, d.layers[0].kind), (1, LineKind::Visible));
        assert_eq!((d.layers[1].pen, d.layers[1].kind), (2, LineKind::Hidden));
        let hidden: f64 = d.layers[1].polylines.iter().map(Polyline::length).sum();
        assert!((hidden - 17.0).abs() < 1e-9, "{hidden}");
        assert!((d.layers[0].polylines[0].length() - 3.0).abs() < 1e-9);
        // Without a hidden pen, only the visible layer.
        assert_eq!(assemble(&pieces(&lines, None, None), ID, 10.0, 10.0).layers.len(), 1);
    }

    #[test]
    fn fov_window_clips_exactly() {
        let lines = vec![line((-3.0, 0.0), (3.0, 0.0), vec![(0.0, 0.25), (0.5, 1.0)]), line((-3.0, 2.0), (3.0, 2.0), vec![(0.0, 1.0)])];
        let window = Some((DVec2::new(-1.0, -1.0), DVec2::new(1.0, 1.0)));
        let p = pieces(&lines, None, window);
        // Visible [-3,-1.5] is outside; [0, 3] is clipped to [0, 1].
        assert_eq!(p.len(), 1);
        assert_eq!((p[0].a, p[0].b), (DVec2::new(0.0, 0.0), DVec2::new(1.0, 0.0)));
    }

    #[test]
    fn nothing_visible_is_an_empty_drawing() {
        let d = assemble(&pieces(&[line((0.0, 0.0), (1.0, 0.0), vec![])], None, None), ID, 10.0, 10.0);
        assert_eq!(d.stroke_count(), 0);
        assert_eq!(bounds([]), None);
    }
}
