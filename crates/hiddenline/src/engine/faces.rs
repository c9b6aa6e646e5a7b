//! Faces as occluders: clipped at the near plane, projected to device space,
//! with their world-space plane, sorted front to back by nearest depth.

use glam::{DVec2, DVec3};
use rayon::prelude::*;

use crate::camera::{Camera, Projection};
use crate::model::Model;
use crate::tolerance::EDGE_ON_REL;

/// One face that can hide something.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Occluder {
    /// Index into `Model::faces`.
    pub id: u32,
    /// Range into [`Occluders::rings`].
    pub rings: (u32, u32),
    /// Device-space bounding box.
    pub lo: DVec2,
    /// Device-space bounding box.
    pub hi: DVec2,
    /// Nearest device depth of the (clipped) face.
    pub zmin: f64,
    /// Unit normal of the world-space plane `normal . x = offset`.
    pub normal: DVec3,
    /// Plane offset.
    pub offset: f64,
    /// The viewer's side of the plane: a point `x` with
    /// `(normal . x - offset) * eye_side < 0` lies behind the plane as seen
    /// from the eye. For perspective it is the plane value at the eye, for
    /// orthographic `-normal . view_direction`.
    pub eye_side: f64,
}

/// All occluders, their rings flattened into one vertex array.
#[derive(Debug, Default)]
pub(crate) struct Occluders {
    /// Sorted by `zmin`, nearest first: index order is depth order.
    pub faces: Vec<Occluder>,
    /// `(start, len)` into `points` per ring.
    pub rings: Vec<(u32, u32)>,
    /// Device-space ring vertices.
    pub points: Vec<DVec2>,
}

impl Occluders {
    /// The rings of `face` as vertex slices.
    pub fn rings_of(&self, face: &Occluder) -> impl Iterator<Item = &[DVec2]> {
        self.rings[face.rings.0 as usize..face.rings.1 as usize].iter().map(|&(s, n)| &self.points[s as usize..(s + n) as usize])
    }
}

/// Newell's normal: robust for any simple polygon, convex or not; its length
/// is twice the area, so zero means degenerate.
pub(crate) fn newell(ring: &[DVec3]) -> DVec3 {
    let mut n = DVec3::ZERO;
    for (i, &p) in ring.iter().enumerate() {
        let q = ring[(i + 1) % ring.len()];
        n += DVec3::new((p.y - q.y) * (p.z + q.z), (p.z - q.z) * (p.x + q.x), (p.x - q.x) * (p.y + q.y));
    }
    n
}

/// Device image of a world point whose view depth is clamped to the near
/// plane (clipped vertices sit on it up to rounding). Returns (x, y, depth).
pub(crate) fn device(camera: &Camera, p: DVec3) -> DVec3 {
    device_by(camera, camera.view_to_device_map(), p)
}

/// [`device`], the view-to-device map given ([`Camera::view_to_device_map`]).
fn device_by(camera: &Camera, view_to_device: impl Fn(DVec3) -> DVec3, p: DVec3) -> DVec3 {
    let mut v = camera.to_view(p);
    v.z = v.z.min(-camera.near);
    view_to_device(v)
}

/// Sutherland-Hodgman against the near plane, into `out`. Clipping each ring
/// of a face on its own keeps the even-odd region exact: the new pieces of
/// boundary lie on the near plane, which no sight ray inside the kept
/// half-space crosses.
fn clip_ring(ring: &[DVec3], camera: &Camera, out: &mut Vec<DVec3>) {
    out.clear();
    let d = |p: DVec3| camera.near_distance(p);
    if ring.iter().all(|&p| d(p) >= 0.0) {
        out.extend_from_slice(ring);
        return;
    }
    for i in 0..ring.len() {
        let j = (i + 1) % ring.len();
        let (di, dj) = (d(ring[i]), d(ring[j]));
        if di >= 0.0 {
            out.push(ring[i]);
        }
        if (di >= 0.0) != (dj >= 0.0) {
            out.push(ring[i] + (ring[j] - ring[i]) * (di / (di - dj)));
        }
    }
}

/// Whether back faces may be skipped: only when no face marked `outward` is
/// cut by the near plane. A closed mesh around the eye always reaches behind
/// it, so this also rules out an eye inside a closed mesh, where the walls
/// between the eye and the world beyond are back faces.
fn culling_is_safe(model: &Model, camera: &Camera) -> bool {
    model.faces.iter().filter(|f| f.outward).all(|f| f.outer.iter().all(|&p| camera.near_distance(p) > 0.0))
}

/// Prepares every face of `model` that can hide anything. Skipped: faces
/// with no area, faces entirely behind the near plane, faces seen edge-on,
/// and (when [`culling_is_safe`]) faces of closed meshes turned away from the
/// eye.
pub(crate) fn prepare(model: &Model, camera: &Camera, eps: f64) -> Occluders {
    let seen = Seen {
        camera,
        view_to_device: camera.view_to_device_map(),
        direction: camera.direction(),
        cull: culling_is_safe(model, camera),
        eps,
    };
    // Room for every face as written, reserved once: grown by doubling, the
    // occluders of ten million triangles held 1.6 GB for 1 GB of them, and
    // twice that for the moment of each move. Clipping at the near plane
    // adds a point now and then, which may grow `points` once.
    let ring_count = model.faces.iter().map(|f| 1 + f.holes.len()).sum();
    let point_count = model.faces.iter().map(|f| f.outer.len() + f.holes.iter().map(Vec::len).sum::<usize>()).sum();
    let mut out = Occluders {
        faces: Vec::with_capacity(model.faces.len()),
        rings: Vec::with_capacity(ring_count),
        points: Vec::with_capacity(point_count),
    };
    // Each face on its own, a window of them at a time in parallel (ten
    // million took 2 s on one core), each chunk's occluders numbered from
    // the chunk's start and appended in order.
    for (w, window) in model.faces.chunks(PREPARE_WINDOW).enumerate() {
        let parts: Vec<Occluders> = window
            .par_chunks(PREPARE_CHUNK)
            .enumerate()
            .map(|(c, faces)| {
                let mut part = Occluders::default();
                let mut clipped = Vec::new();
                for (k, face) in faces.iter().enumerate() {
                    let id = w * PREPARE_WINDOW + c * PREPARE_CHUNK + k;
                    seen.occlude(face, id as u32, &mut clipped, &mut part);
                }
                part
            })
            .collect();
        for part in parts {
            let (rings, points) = (out.rings.len() as u32, out.points.len() as u32);
            out.faces.extend(part.faces.into_iter().map(|f| Occluder { rings: (f.rings.0 + rings, f.rings.1 + rings), ..f }));
            out.rings.extend(part.rings.into_iter().map(|(s, n)| (s + points, n)));
            out.points.extend_from_slice(&part.points);
        }
    }
    // Ids are unique, so the order is total and an unstable sort (which
    // needs no buffer of half the faces) gives the one answer.
    out.faces.par_sort_unstable_by(|a, b| a.zmin.total_cmp(&b.zmin).then(a.id.cmp(&b.id)));
    out
}

/// Faces prepared at once, in parallel, and in one task: few enough that a
/// window's occluders are a small part of all of them.
const PREPARE_WINDOW: usize = 1 << 16;
const PREPARE_CHUNK: usize = 1 << 11;

/// What every face is prepared with: the camera, its projection's
/// constants (computed once: a tangent), whether back faces are culled, and
/// the plane tolerance.
struct Seen<'a, F> {
    camera: &'a Camera,
    view_to_device: F,
    direction: DVec3,
    cull: bool,
    eps: f64,
}

impl<F: Fn(DVec3) -> DVec3 + Copy> Seen<'_, F> {
    /// Appends face `id` (`face`) to `out` as an occluder, unless it hides
    /// nothing: culled as a back face, seen edge-on, wholly behind the near
    /// plane or degenerate. `clipped` is a buffer.
    fn occlude(&self, face: &crate::model::Face, id: u32, clipped: &mut Vec<DVec3>, out: &mut Occluders) {
        let Seen { camera, view_to_device, direction, cull, eps } = *self;
        if face.outer.len() < 3 {
            return;
        }
        let Some(normal) = newell(&face.outer).try_normalize() else { return };
        let centroid = face.outer.iter().copied().sum::<DVec3>() / face.outer.len() as f64;
        let offset = normal.dot(centroid);
        let eye_side = match camera.projection {
            Projection::Perspective { .. } => normal.dot(camera.eye) - offset,
            Projection::Orthographic { .. } => -normal.dot(direction),
        };
        if face.outward && cull && eye_side < 0.0 {
            return;
        }
        if let Projection::Perspective { .. } = camera.projection {
            // The eye in the face's plane: the face is a line on screen.
            if eye_side.abs() <= eps {
                return;
            }
        }
        let ring_start = out.rings.len();
        let point_start = out.points.len();
        let (mut lo, mut hi) = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
        let mut zmin = f64::INFINITY;
        for (r, ring) in std::iter::once(&face.outer).chain(&face.holes).enumerate() {
            clip_ring(ring, camera, clipped);
            if clipped.len() < 3 {
                if r == 0 {
                    return;
                }
                continue;
            }
            out.rings.push((out.points.len() as u32, clipped.len() as u32));
            for &p in clipped.iter() {
                let d = device_by(camera, view_to_device, p);
                let q = d.truncate();
                lo = lo.min(q);
                hi = hi.max(q);
                zmin = zmin.min(d.z);
                out.points.push(q);
            }
        }
        // Edge-on: the projected outer ring has (almost) no area.
        let outer_len = out.rings[ring_start].1 as usize;
        let outer = &out.points[point_start..point_start + outer_len];
        let (mut area2, mut perim) = (0.0, 0.0);
        for i in 0..outer.len() {
            let (p, q) = (outer[i], outer[(i + 1) % outer.len()]);
            area2 += p.perp_dot(q);
            perim += p.distance(q);
        }
        if !(area2.abs() * 0.5 > EDGE_ON_REL * perim * perim) || !lo.is_finite() || !hi.is_finite() {
            out.rings.truncate(ring_start);
            out.points.truncate(point_start);
            return;
        }
        out.faces.push(Occluder { id, rings: (ring_start as u32, out.rings.len() as u32), lo, hi, zmin, normal, offset, eye_side });
    }
}

/// Size of the scene: the diagonal of the bounding box of every vertex and
/// the eye, or the eye-target distance if larger. Plane tolerances scale
/// with it.
#[must_use]
pub fn scene_scale(model: &Model, camera: &Camera) -> f64 {
    let (mut lo, mut hi) = (camera.eye, camera.eye);
    let pts = model
        .faces
        .iter()
        .flat_map(|f| f.outer.iter().chain(f.holes.iter().flatten()))
        .chain(model.edges.iter().flat_map(|e| [&e.a, &e.b]));
    for p in pts.filter(|p| p.is_finite()) {
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    lo.distance(hi).max(camera.eye.distance(camera.target))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Face;

    fn cam() -> Camera {
        Camera::new(DVec3::new(0.0, -10.0, 0.0), DVec3::ZERO, DVec3::Z, Projection::Perspective { fov_deg: 40.0 }).unwrap()
    }

    fn face(pts: &[[f64; 3]], outward: bool) -> Face {
        Face { outer: pts.iter().map(|&p| DVec3::from(p)).collect(), holes: vec![], pen: 1, outward }
    }

    #[test]
    fn degenerate_and_edge_on_faces_are_skipped() {
        let model = Model {
            faces: vec![
                // Zero area (collinear).
                face(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]], false),
                // Contains the eye's sight lines: the plane x = 0 through the eye.
                face(&[[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 1.0, 1.0]], false),
                // Two vertices only.
                face(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]], false),
                // An ordinary face.
                face(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 0.0, 1.0]], false),
            ],
            edges: vec![],
        };
        let o = prepare(&model, &cam(), 1e-9);
        assert_eq!(o.faces.len(), 1);
        assert_eq!(o.faces[0].id, 3);
    }

    #[test]
    fn faces_behind_the_eye_vanish_and_straddling_ones_are_cut() {
        let model = Model {
            faces: vec![
                face(&[[0.0, -20.0, 0.0], [1.0, -20.0, 0.0], [1.0, -20.0, 1.0]], false),
                face(&[[-1.0, -20.0, -1.0], [1.0, -20.0, -1.0], [1.0, 0.0, -1.0], [-1.0, 0.0, -1.0]], false),
            ],
            edges: vec![],
        };
        let c = cam();
        let o = prepare(&model, &c, 1e-9);
        assert_eq!(o.faces.len(), 1);
        assert!(o.faces[0].zmin.abs() < 1e-9, "clipped at the near plane: depth 0");
        assert_eq!(o.rings_of(&o.faces[0]).next().unwrap().len(), 4);
    }

    #[test]
    fn occluders_hold_no_more_room_than_the_model_has_faces() {
        // 1000 triangles: grown by doubling, the arrays had room for 1024
        // faces and 3072 points.
        let faces: Vec<Face> = (0..1000)
            .map(|i| {
                let x = f64::from(i) * 0.01;
                face(&[[x, 0.0, 0.0], [x + 0.005, 0.0, 0.0], [x, 0.0, 0.005]], false)
            })
            .collect();
        let model = Model { faces, edges: vec![] };
        let o = prepare(&model, &cam(), 1e-9);
        assert_eq!(o.faces.len(), 1000);
        assert!(o.faces.capacity() <= 1000 && o.rings.capacity() <= 1000 && o.points.capacity() <= 3000);
    }

    #[test]
    fn back_faces_are_culled_only_when_safe() {
        // Facing away from the eye at y = -10 (normal +y by CCW order seen from +y).
        let back = face(&[[0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]], true);
        assert!(newell(&back.outer).y > 0.0);
        let c = cam();
        let o = prepare(&Model { faces: vec![back.clone()], edges: vec![] }, &c, 1e-9);
        assert!(o.faces.is_empty());
        // Another outward face reaching behind the eye: no culling at all.
        let around = face(&[[-1.0, -20.0, -1.0], [1.0, -20.0, -1.0], [1.0, 5.0, -1.0]], true);
        let o = prepare(&Model { faces: vec![back, around], edges: vec![] }, &c, 1e-9);
        assert_eq!(o.faces.len(), 2);
    }
}
