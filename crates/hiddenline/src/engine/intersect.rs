//! Penetration lines: where the interiors of two faces meet (Hedgley's
//! "lines of intersection"). Found in world space, before any projection,
//! then treated like any other line.

use glam::DVec3;
use rayon::prelude::*;

use super::faces::newell;
use crate::model::Model;

/// At most this many cells in the 3-D bucket grid (memory: 4 bytes each).
const MAX_CELLS: usize = 1 << 22;

struct Plane {
    normal: DVec3,
    offset: f64,
    lo: DVec3,
    hi: DVec3,
}

fn rings(model: &Model, i: usize) -> impl Iterator<Item = &[DVec3]> {
    let f = &model.faces[i];
    std::iter::once(f.outer.as_slice()).chain(f.holes.iter().map(Vec::as_slice)).filter(|r| r.len() >= 3)
}

fn seg_dist(p: DVec3, a: DVec3, b: DVec3) -> f64 {
    let ab = b - a;
    let l2 = ab.length_squared();
    let t = if l2 > 0.0 { ((p - a).dot(ab) / l2).clamp(0.0, 1.0) } else { 0.0 };
    p.distance(a + ab * t)
}

/// Whether the face's vertices lie strictly on both sides of `plane` (beyond
/// `eps`): a face that only touches a plane does not penetrate it.
fn straddles(model: &Model, i: usize, plane: &Plane, eps: f64) -> bool {
    let (mut pos, mut neg) = (false, false);
    for p in &model.faces[i].outer {
        let v = plane.normal.dot(*p) - plane.offset;
        pos |= v > eps;
        neg |= v < -eps;
    }
    pos && neg
}

/// The parameter intervals along the line `x0 + u * lambda` inside face `i`,
/// which lies in a plane containing that line; `other` is the second plane
/// through the line. Crossings of the boundary with `other` are paired off
/// (even-odd); a vertex exactly on `other` counts on the positive side, so
/// every crossing is counted once.
fn spans(model: &Model, i: usize, other: &Plane, x0: DVec3, u: DVec3, out: &mut Vec<f64>) -> Vec<(f64, f64)> {
    out.clear();
    for ring in rings(model, i) {
        let mut a = ring[ring.len() - 1];
        let mut fa = other.normal.dot(a) - other.offset;
        for &b in ring {
            let fb = other.normal.dot(b) - other.offset;
            if (fa >= 0.0) != (fb >= 0.0) {
                out.push(u.dot(a + (b - a) * (fa / (fa - fb)) - x0));
            }
            a = b;
            fa = fb;
        }
    }
    out.sort_unstable_by(f64::total_cmp);
    out.chunks_exact(2).map(|c| (c[0], c[1])).collect()
}

fn pair(model: &Model, planes: &[Option<Plane>], i: usize, j: usize, eps: f64, out: &mut Vec<(u32, u32, DVec3, DVec3)>) {
    let (Some(pi), Some(pj)) = (&planes[i], &planes[j]) else { return };
    if (pi.lo - eps).cmpgt(pj.hi).any() || (pj.lo - eps).cmpgt(pi.hi).any() {
        return;
    }
    if !straddles(model, i, pj, eps) || !straddles(model, j, pi, eps) {
        return;
    }
    let u = pi.normal.cross(pj.normal);
    let u2 = u.length_squared();
    if u2 < 1e-18 {
        return;
    }
    let x0 = (pi.offset * pj.normal.cross(u) + pj.offset * u.cross(pi.normal)) / u2;
    let u = u / u2.sqrt();
    let mut buf = Vec::new();
    let si = spans(model, i, pj, x0, u, &mut buf);
    let sj = spans(model, j, pi, x0, u, &mut buf);
    // Intersect the two sorted interval lists.
    let (mut a, mut b) = (0, 0);
    while a < si.len() && b < sj.len() {
        let lo = si[a].0.max(sj[b].0);
        let hi = si[a].1.min(sj[b].1);
        if hi - lo > eps {
            let (p, q) = (x0 + u * lo, x0 + u * hi);
            // Contact along a boundary (faces sharing an edge, a face resting
            // on another) is drawn by the faces' own edges, not here.
            let m = (p + q) * 0.5;
            let on_boundary =
                [i, j].iter().any(|&k| rings(model, k).any(|r| (0..r.len()).any(|n| seg_dist(m, r[n], r[(n + 1) % r.len()]) <= eps)));
            if !on_boundary {
                out.push((i as u32, j as u32, p, q));
            }
        }
        if si[a].1 < sj[b].1 {
            a += 1;
        } else {
            b += 1;
        }
    }
}

/// The cell size and the cell counts of the bucket grid over boxes spanning
/// `span`, `mean_size` the typical box, each padded by `eps`: cells about a
/// face's size and never under twice the padding, at most
/// 1024 along an axis and [`MAX_CELLS`] in all, whatever the numbers (an
/// infinite span, as from coordinates near ±1e308, used to make the cell
/// infinite, the count NaN, and the sizing loop endless: issue #20).
fn bucket_grid(span: DVec3, mean_size: DVec3, eps: f64) -> (DVec3, DVec3) {
    let extent = span.max(DVec3::splat(eps.max(1e-300))).min(DVec3::splat(f64::MAX));
    // Boxes are padded by `eps` on each side: a cell smaller than the
    // padding would put every box of a tiny model in every cell.
    let mut cell = mean_size
        .min(DVec3::splat(f64::MAX))
        .max(extent / 1024.0)
        .max(DVec3::splat(extent.max_element() * 1e-6))
        .max(DVec3::splat(2.0 * eps));
    // `max` and `min` take the number over a NaN: NaN counts as one cell.
    let dims = |cell: DVec3| ((extent / cell).floor() + DVec3::ONE).max(DVec3::ONE).min(DVec3::splat(1024.0));
    // Each round divides the count by 1.5^3 or more: 1024^3 cells are under
    // MAX_CELLS after 18 rounds, so 64 always end it.
    for _ in 0..64 {
        if dims(cell).element_product() <= MAX_CELLS as f64 {
            break;
        }
        cell *= 1.5;
    }
    (cell, dims(cell))
}

/// All penetration lines `(i, j, a, b)`, `i < j`, in a deterministic order.
/// Candidate pairs come from a uniform 3-D grid over the faces' bounding
/// boxes; each pair is examined once, in the cell holding the low corner of
/// the overlap of their boxes.
pub(crate) fn penetrations(model: &Model, eps: f64) -> Vec<(u32, u32, DVec3, DVec3)> {
    // Each face's plane and box on its own, in parallel (ten million
    // faces took a second and a half on one core), collected in face order.
    let planes: Vec<Option<Plane>> = model
        .faces
        .par_iter()
        .map(|f| {
            if f.outer.len() < 3 {
                return None;
            }
            let normal = newell(&f.outer).try_normalize()?;
            let c = f.outer.iter().copied().sum::<DVec3>() / f.outer.len() as f64;
            let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
            for p in &f.outer {
                lo = lo.min(*p);
                hi = hi.max(*p);
            }
            Some(Plane { normal, offset: normal.dot(c), lo, hi })
        })
        .collect();
    let live: Vec<usize> = (0..planes.len()).filter(|&i| planes[i].is_some()).collect();
    if live.len() < 2 {
        return Vec::new();
    }
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    let mut mean_size = DVec3::ZERO;
    for p in planes.iter().flatten() {
        lo = lo.min(p.lo);
        hi = hi.max(p.hi);
        mean_size += p.hi - p.lo;
    }
    mean_size /= live.len() as f64;
    let (cell, n) = bucket_grid(hi - lo, mean_size, eps);
    let (nx, ny, nz) = (n.x as usize, n.y as usize, n.z as usize);
    let key = |p: DVec3| {
        let c = ((p - lo) / cell).floor().max(DVec3::ZERO).min(n - DVec3::ONE);
        (c.x as usize, c.y as usize, c.z as usize)
    };
    let index = |(x, y, z): (usize, usize, usize)| (z * ny + y) * nx + x;
    let mut starts = vec![0u32; nx * ny * nz + 1];
    let range = |i: usize| {
        let p = planes[i].as_ref().expect("live");
        (key(p.lo - eps), key(p.hi + eps))
    };
    let each_cell = |i: usize, f: &mut dyn FnMut(usize)| {
        let (a, b) = range(i);
        for z in a.2..=b.2 {
            for y in a.1..=b.1 {
                for x in a.0..=b.0 {
                    f(index((x, y, z)));
                }
            }
        }
    };
    for &i in &live {
        each_cell(i, &mut |c| starts[c + 1] += 1);
    }
    for c in 0..nx * ny * nz {
        starts[c + 1] += starts[c];
    }
    let mut items = vec![0u32; starts[nx * ny * nz] as usize];
    let mut fill = starts.clone();
    for &i in &live {
        each_cell(i, &mut |c| {
            items[fill[c] as usize] = i as u32;
            fill[c] += 1;
        });
    }
    let mut found: Vec<(u32, u32, DVec3, DVec3)> = live
        .par_iter()
        .map(|&i| {
            let mut out = Vec::new();
            let pi = planes[i].as_ref().expect("live");
            let (a, b) = range(i);
            for z in a.2..=b.2 {
                for y in a.1..=b.1 {
                    for x in a.0..=b.0 {
                        let c = index((x, y, z));
                        // A cell lists its faces in order: those after `i` are a tail.
                        let cell = &items[starts[c] as usize..starts[c + 1] as usize];
                        for &j in &cell[cell.partition_point(|&j| j as usize <= i)..] {
                            let j = j as usize;
                            let pj = planes[j].as_ref().expect("live");
                            if (pi.lo - eps).cmpgt(pj.hi).any() || (pj.lo - eps).cmpgt(pi.hi).any() {
                                continue;
                            }
                            // Examine the pair only in the cell of the low
                            // corner of the overlap of the (padded) boxes.
                            if key(pi.lo.max(pj.lo) - eps) != (x, y, z) {
                                continue;
                            }
                            pair(model, &planes, i, j, eps, &mut out);
                        }
                    }
                }
            }
            out
        })
        .flatten()
        .collect();
    found.sort_by_key(|p| (p.0, p.1));
    found
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Face;

    fn face(pts: &[[f64; 3]]) -> Face {
        Face { outer: pts.iter().map(|&p| DVec3::from(p)).collect(), holes: vec![], pen: 1, outward: false }
    }

    #[test]
    fn plate_through_a_square_with_a_hole() {
        let mut wall = face(&[[-2.0, 0.0, -2.0], [2.0, 0.0, -2.0], [2.0, 0.0, 2.0], [-2.0, 0.0, 2.0]]);
        wall.holes.push(vec![
            DVec3::new(-1.0, 0.0, -1.0),
            DVec3::new(1.0, 0.0, -1.0),
            DVec3::new(1.0, 0.0, 1.0),
            DVec3::new(-1.0, 0.0, 1.0),
        ]);
        // A horizontal plate through the wall at z = 1.5, x in [-3, 3].
        let plate = face(&[[-3.0, -1.0, 1.5], [3.0, -1.0, 1.5], [3.0, 1.0, 1.5], [-3.0, 1.0, 1.5]]);
        let x = penetrations(&Model { faces: vec![wall.clone(), plate], edges: vec![] }, 1e-9);
        assert_eq!(x.len(), 1);
        assert!((x[0].2.distance(x[0].3) - 4.0).abs() < 1e-12);
        // Through the hole at z = 0: two pieces either side of it.
        let plate = face(&[[-3.0, -1.0, 0.0], [3.0, -1.0, 0.0], [3.0, 1.0, 0.0], [-3.0, 1.0, 0.0]]);
        let x = penetrations(&Model { faces: vec![wall, plate], edges: vec![] }, 1e-9);
        assert_eq!(x.len(), 2);
        let total: f64 = x.iter().map(|s| s.2.distance(s.3)).sum();
        assert!((total - 2.0).abs() < 1e-12);
    }

    /// Issue #20: a scene with a town at longitude -1e308 looped forever in
    /// the grid sizing (seen in a debugger on main's build); an infinite or
    /// NaN span must still give a small grid.
    #[test]
    fn bucket_grid_is_bounded_for_any_numbers() {
        let cases = [
            (DVec3::splat(f64::INFINITY), DVec3::splat(f64::INFINITY)),
            (DVec3::splat(f64::INFINITY), DVec3::ONE),
            (DVec3::splat(f64::NAN), DVec3::splat(f64::NAN)),
            (DVec3::splat(1.7e308), DVec3::splat(1e-300)),
            (DVec3::new(1e300, 1e-300, 1.0), DVec3::splat(1e-9)),
            (DVec3::splat(4.0), DVec3::splat(0.5)),
        ];
        for (span, mean) in cases {
            let (_, n) = bucket_grid(span, mean, 1e-9);
            assert!(n.is_finite() && n.min_element() >= 1.0 && n.element_product() <= MAX_CELLS as f64, "{span} {mean}: {n}");
        }
        assert_eq!(bucket_grid(DVec3::splat(4.0), DVec3::splat(0.5), 1e-9).1, DVec3::splat(9.0));
    }

    /// A fuzzed binary STL of 32 triangles all within 1e-19 of the origin
    /// took 29 s (issue #20): each box, padded by `eps` (about 5e-9, from
    /// the camera's distance), spanned the whole 4M-cell grid sized to the
    /// boxes alone. A cell is never smaller than the padding, so a box
    /// covers a few cells per axis whatever the scale.
    #[test]
    fn a_padded_box_covers_few_cells_however_small_the_faces() {
        for (span, mean, eps) in [
            (DVec3::splat(1e-19), DVec3::splat(1e-19), 5e-9),
            (DVec3::new(1.0, 1e-19, 1e-19), DVec3::splat(1e-19), 1e-9),
            (DVec3::splat(4.0), DVec3::splat(0.5), 1e-9),
            (DVec3::splat(1e3), DVec3::splat(1e-6), 1e-3),
        ] {
            let (cell, n) = bucket_grid(span, mean, eps);
            let per_axis = ((mean + DVec3::splat(2.0 * eps)) / cell).ceil() + DVec3::ONE;
            let covered = per_axis.min(n).element_product();
            assert!(covered <= 27.0, "{span} {mean} {eps}: a face covers {covered} of {} cells", n.element_product());
        }
    }

    #[test]
    fn contact_is_not_penetration() {
        let floor = face(&[[-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [1.0, 1.0, 0.0], [-1.0, 1.0, 0.0]]);
        let wall = face(&[[-0.5, 0.0, 0.0], [0.5, 0.0, 0.0], [0.5, 0.0, 1.0], [-0.5, 0.0, 1.0]]);
        let hinge = face(&[[1.0, -1.0, 0.0], [1.0, 1.0, 0.0], [2.0, 1.0, 1.0], [2.0, -1.0, 1.0]]);
        let coplanar = face(&[[0.0, 0.0, 0.0], [3.0, 0.0, 0.0], [3.0, 3.0, 0.0]]);
        let model = Model { faces: vec![floor, wall, hinge, coplanar], edges: vec![] };
        assert!(penetrations(&model, 1e-9).is_empty());
    }

    #[test]
    fn matches_the_reference_on_a_pile_of_random_triangles() {
        // A deterministic scatter of triangles, many of them crossing.
        let mut s = 12345u64;
        let mut rnd = || {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (s >> 11) as f64 / (1u64 << 53) as f64 * 4.0 - 2.0
        };
        let faces: Vec<Face> = (0..40)
            .map(|_| {
                let c = [rnd(), rnd(), rnd()];
                let mut p = || [c[0] + rnd() * 0.5, c[1] + rnd() * 0.5, c[2] + rnd() * 0.5];
                face(&[p(), p(), p()])
            })
            .collect();
        let model = Model { faces, edges: vec![] };
        let ours = penetrations(&model, 1e-9);
        let theirs = crate::reference::intersections(&model);
        assert!(ours.len() > 5);
        assert_eq!(ours.len(), theirs.len());
        for (a, b) in ours.iter().zip(&theirs) {
            assert_eq!((a.0, a.1), (b.0, b.1));
            let same = a.2.distance(b.2) + a.3.distance(b.3);
            let flipped = a.2.distance(b.3) + a.3.distance(b.2);
            assert!(same.min(flipped) < 1e-9);
        }
    }
}
