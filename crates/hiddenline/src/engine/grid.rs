//! A uniform screen-space grid over the occluders (Griffith's buckets): each
//! line is compared only with the faces in the cells it passes through.

use glam::DVec2;

use super::faces::Occluder;

/// Cells per face the grid aims for: about one face per cell on average, so
/// a typical face covers a handful of cells and a line meets few faces.
const CELLS_PER_FACE: f64 = 1.0;
/// Upper bound on the number of cells (memory: 4 bytes per cell).
const MAX_CELLS: f64 = 4.0e6;

/// Faces bucketed by the cells their device-space bounding boxes cover.
#[derive(Debug)]
pub(crate) struct Grid {
    lo: DVec2,
    cell: DVec2,
    nx: usize,
    ny: usize,
    /// CSR: faces of cell `c` are `items[starts[c]..starts[c + 1]]`, in
    /// ascending index, that is front to back.
    starts: Vec<u32>,
    items: Vec<u32>,
    /// Slack added around boxes and segments so that touching counts.
    pad: f64,
}

impl Grid {
    /// A grid over the box `(lo, hi)` (where the lines are) holding `faces`.
    pub fn new(faces: &[Occluder], lo: DVec2, hi: DVec2) -> Grid {
        let size = (hi - lo).max(DVec2::splat(1e-12));
        let pad = 1e-9 * size.max_element();
        let target = (faces.len() as f64 * CELLS_PER_FACE).clamp(1.0, MAX_CELLS);
        let nx = ((target * size.x / size.y).sqrt().round() as usize).clamp(1, 1 << 12);
        let ny = ((target / nx as f64).round() as usize).clamp(1, 1 << 12);
        let cell = size / DVec2::new(nx as f64, ny as f64);
        let mut grid = Grid { lo, cell, nx, ny, starts: vec![0; nx * ny + 1], items: Vec::new(), pad };
        let ranges: Vec<_> = faces.iter().map(|f| grid.range(f.lo, f.hi)).collect();
        for r in ranges.iter().flatten() {
            for y in r.2..=r.3 {
                for x in r.0..=r.1 {
                    grid.starts[y * nx + x + 1] += 1;
                }
            }
        }
        for c in 0..nx * ny {
            grid.starts[c + 1] += grid.starts[c];
        }
        let mut fill = grid.starts.clone();
        grid.items = vec![0; grid.starts[nx * ny] as usize];
        for (i, r) in ranges.iter().enumerate() {
            let Some(r) = r else { continue };
            for y in r.2..=r.3 {
                for x in r.0..=r.1 {
                    let c = y * nx + x;
                    grid.items[fill[c] as usize] = i as u32;
                    fill[c] += 1;
                }
            }
        }
        grid
    }

    fn col(&self, x: f64) -> isize {
        ((x - self.lo.x) / self.cell.x).floor() as isize
    }

    fn row(&self, y: f64) -> isize {
        ((y - self.lo.y) / self.cell.y).floor() as isize
    }

    /// Cell range `(x0, x1, y0, y1)` covered by a box, `None` if outside.
    fn range(&self, lo: DVec2, hi: DVec2) -> Option<(usize, usize, usize, usize)> {
        let (x0, x1) = (self.col(lo.x - self.pad), self.col(hi.x + self.pad));
        let (y0, y1) = (self.row(lo.y - self.pad), self.row(hi.y + self.pad));
        if x1 < 0 || y1 < 0 || x0 >= self.nx as isize || y0 >= self.ny as isize {
            return None;
        }
        let cx = |v: isize| v.clamp(0, self.nx as isize - 1) as usize;
        let cy = |v: isize| v.clamp(0, self.ny as isize - 1) as usize;
        Some((cx(x0), cx(x1), cy(y0), cy(y1)))
    }

    /// Calls `f` with every face index in every cell the segment `a`-`b`
    /// touches (a face may come more than once).
    pub fn visit_segment(&self, a: DVec2, b: DVec2, mut f: impl FnMut(u32)) {
        let (l, r) = if a.x <= b.x { (a, b) } else { (b, a) };
        let Some((x0, x1, _, _)) = self.range(l.min(r), l.max(r)) else { return };
        let dx = r.x - l.x;
        for x in x0..=x1 {
            // The part of the segment over this column, padded.
            let cx0 = self.lo.x + x as f64 * self.cell.x - self.pad;
            let cx1 = cx0 + self.cell.x + 2.0 * self.pad;
            let (ya, yb) = if dx > 0.0 {
                let ta = ((cx0 - l.x) / dx).clamp(0.0, 1.0);
                let tb = ((cx1 - l.x) / dx).clamp(0.0, 1.0);
                (l.y + (r.y - l.y) * ta, l.y + (r.y - l.y) * tb)
            } else {
                (l.y, r.y)
            };
            let (ylo, yhi) = (ya.min(yb) - self.pad, ya.max(yb) + self.pad);
            let (y0, y1) = (self.row(ylo), self.row(yhi));
            if y1 < 0 || y0 >= self.ny as isize {
                continue;
            }
            for y in y0.max(0) as usize..=(y1.min(self.ny as isize - 1) as usize) {
                let c = y * self.nx + x;
                for &i in &self.items[self.starts[c] as usize..self.starts[c + 1] as usize] {
                    f(i);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    fn occ(lo: (f64, f64), hi: (f64, f64)) -> Occluder {
        Occluder {
            id: 0,
            rings: (0, 0),
            lo: DVec2::new(lo.0, lo.1),
            hi: DVec2::new(hi.0, hi.1),
            zmin: 0.0,
            normal: DVec3::Z,
            offset: 0.0,
            eye_side: 1.0,
        }
    }

    fn visited(g: &Grid, a: (f64, f64), b: (f64, f64)) -> Vec<u32> {
        let mut v = Vec::new();
        g.visit_segment(DVec2::new(a.0, a.1), DVec2::new(b.0, b.1), |i| v.push(i));
        v.sort_unstable();
        v.dedup();
        v
    }

    #[test]
    fn segments_find_exactly_the_faces_along_them() {
        let faces: Vec<Occluder> = (0..10)
            .flat_map(|i| (0..10).map(move |j| occ((i as f64, j as f64), (i as f64 + 0.5, j as f64 + 0.5))))
            .collect();
        let g = Grid::new(&faces, DVec2::ZERO, DVec2::splat(10.0));
        // A diagonal through the squares (i, i).
        let v = visited(&g, (0.1, 0.1), (9.4, 9.4));
        for i in 0..10 {
            assert!(v.contains(&(i * 10 + i)), "{i}");
        }
        assert!(!v.contains(&9), "far corner square");
        // Vertical and point-like segments, and one outside the grid.
        assert!(visited(&g, (3.2, 0.0), (3.2, 10.0)).contains(&35));
        let v = visited(&g, (7.2, 7.2), (7.2, 7.2));
        assert!(v.contains(&77) && !v.contains(&66) && !v.contains(&99), "{v:?}");
        assert!(visited(&g, (20.0, 20.0), (30.0, 30.0)).is_empty());
    }

    #[test]
    fn a_face_touching_the_segment_is_found() {
        let faces = vec![occ((0.0, 0.0), (1.0, 1.0)), occ((5.0, 5.0), (6.0, 6.0))];
        let g = Grid::new(&faces, DVec2::ZERO, DVec2::splat(6.0));
        assert!(visited(&g, (1.0, 3.0), (1.0, 1.0)).contains(&0));
        assert!(visited(&g, (1.0 + 1e-6, 3.0), (1.0 + 1e-6, 1.0 + 1e-6)).contains(&0));
    }
}
