//! The fast exact engine for grid surfaces z = f(x, y).
//!
//! A grid surface is a height field sampled on a (possibly non-uniform)
//! rectangular grid; each cell is the two triangles split along the diagonal
//! from `(x_i, y_j)` to `(x_i+1, y_j+1)`, exactly as the general engine splits
//! a mesh quad, and only grid lines are drawn.
//!
//! The method is Anderson's (seed 000) in device space: facets are visited in
//! an occlusion-compatible order (rows outward from the eye's ground point,
//! each row outward from the eye's column, the two triangles of a cell in the
//! order the eye sees them), so a facet can only be hidden by facets already
//! visited. The picture of the visited facets is star-shaped about the pole
//! (the vanishing point of verticals), so it is held as an outer and an inner
//! horizon along the rays from the pole ([`horizon`]). Each grid line is tested
//! once, against the horizon, when the first facet containing it is visited;
//! then the facet is merged into the horizon. Visibility changes only where a
//! line crosses the horizon, and those crossings are computed exactly (up to
//! floating point): nothing is sampled.
//!
//! Cost: each facet touches the few horizon pieces over its own key range; the
//! gap buffer makes each row's sweep linear. Memory is linear in the grid.
//! With a finite pole, the picture's two halves about a line through the pole
//! hold disjoint keys, so two sweeps, one per half, run at once over the same
//! order (the line turned to put half of the vertices on either side), and
//! each edge's visible parts are the complement of what both found hidden.
//!
//! # Edge tests and merges
//! Key and radius of every grid vertex are computed once. A cell that
//! projects to a strictly convex quadrilateral has its four edges tested
//! first and is merged once (neither of its triangles can cover the other's
//! edges); other cells go triangle by triangle. An edge test walks each chain
//! once over the edge's keys (`Chain::inside`): radius bounds settle most
//! pieces without a division, the rest are cut exactly, and parameters are
//! computed only where a hidden interval starts or ends. A merge skips the
//! envelope when radius bounds show the facet changes nothing, replaces a run
//! of pieces that is exactly the cell's opposite chain by the cell's own
//! chain, keeps whole every old piece the new chain does not beat and puts in
//! whole every new piece that beats the old chain; only pieces at crossings
//! are cut. Per-edge results are stored in sweep order, and an edge visible
//! from end to end stores no interval.
//!
//! **Its edge numbering equals the lowering's** (`scene::Surface::lower`,
//! `scene::Ridgeline::lower`, then axes and contours in the order
//! `scene::Scene::lower` adds them), so the reference checker and the general
//! engine judge it on the lowered model.

pub mod free;
mod horizon;
pub mod ridgeline;
mod sweep;
pub mod tolerance;

use crate::camera::{Camera, Projection};
use crate::model::{Intervals, LineSource, LineVisibility};
use glam::{DVec2, DVec3};
use horizon::{Half, Pole};
use rayon::prelude::*;
use sweep::{pole_of, Sweep};
use thiserror::Error;

/// A height field on a rectangular grid.
#[derive(Clone, Debug, PartialEq)]
pub struct Grid {
    /// Grid x coordinates, strictly increasing, at least two.
    pub xs: Vec<f64>,
    /// Grid y coordinates, strictly increasing, at least two.
    pub ys: Vec<f64>,
    /// Heights, row-major: `z[j * xs.len() + i]` is the height at `(xs[i], ys[j])`.
    pub z: Vec<f64>,
}

/// Why a [`Grid`] cannot be used.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum GridError {
    /// Fewer than two values on an axis.
    #[error("the grid needs at least 2 points along {axis}, got {count}")]
    TooFewPoints {
        /// `"x"` or `"y"`.
        axis: &'static str,
        /// How many there are.
        count: usize,
    },
    /// Coordinates not strictly increasing (or not finite).
    #[error("grid {axis} values must be finite and strictly increasing: {axis}[{index}] = {value} after {prev}")]
    NotIncreasing {
        /// `"x"` or `"y"`.
        axis: &'static str,
        /// Index of the offending value.
        index: usize,
        /// The offending value.
        value: f64,
        /// The value before it.
        prev: f64,
    },
    /// The heights array has the wrong length.
    #[error("the grid has {xs} x {ys} points but {len} heights")]
    WrongSize {
        /// Points along x.
        xs: usize,
        /// Points along y.
        ys: usize,
        /// Heights given.
        len: usize,
    },
    /// A height is NaN or infinite.
    #[error("the height at grid point (x = {x}, y = {y}) is not finite ({z})")]
    NotFinite {
        /// x of the point.
        x: f64,
        /// y of the point.
        y: f64,
        /// The value.
        z: f64,
    },
    /// The grid is too large to handle.
    #[error("the grid has {0} points; the limit is {MAX_GRID_POINTS}")]
    TooLarge(usize),
}

/// The most grid points a surface may have (16 M: about 1.5 GB of working
/// memory at the engine's worst).
pub const MAX_GRID_POINTS: usize = 1 << 24;

/// Checks a coordinate axis.
///
/// # Errors
/// Fewer than 2 values, or values not finite and strictly increasing.
pub fn check_axis(axis: &'static str, v: &[f64]) -> Result<(), GridError> {
    if v.len() < 2 {
        return Err(GridError::TooFewPoints { axis, count: v.len() });
    }
    if let Some(i) = v.iter().position(|x| !x.is_finite()) {
        return Err(GridError::NotIncreasing { axis, index: i, value: v[i], prev: if i > 0 { v[i - 1] } else { f64::NAN } });
    }
    for i in 1..v.len() {
        if !(v[i] > v[i - 1]) {
            return Err(GridError::NotIncreasing { axis, index: i, value: v[i], prev: v[i - 1] });
        }
    }
    Ok(())
}

impl Grid {
    /// A validated grid.
    ///
    /// # Errors
    /// See [`GridError`].
    pub fn new(xs: Vec<f64>, ys: Vec<f64>, z: Vec<f64>) -> Result<Grid, GridError> {
        check_axis("x", &xs)?;
        check_axis("y", &ys)?;
        let n = xs.len().saturating_mul(ys.len());
        if n > MAX_GRID_POINTS {
            return Err(GridError::TooLarge(n));
        }
        if z.len() != n {
            return Err(GridError::WrongSize { xs: xs.len(), ys: ys.len(), len: z.len() });
        }
        if let Some(k) = z.iter().position(|v| !v.is_finite()) {
            return Err(GridError::NotFinite { x: xs[k % xs.len()], y: ys[k / xs.len()], z: z[k] });
        }
        Ok(Grid { xs, ys, z })
    }

    /// Samples `f` at every grid point.
    ///
    /// # Errors
    /// As [`Grid::new`]; the error names the first point where `f` is not
    /// finite.
    pub fn from_fn(xs: Vec<f64>, ys: Vec<f64>, f: impl Fn(f64, f64) -> f64 + Sync) -> Result<Grid, GridError> {
        check_axis("x", &xs)?;
        check_axis("y", &ys)?;
        let n = xs.len().saturating_mul(ys.len());
        if n > MAX_GRID_POINTS {
            return Err(GridError::TooLarge(n));
        }
        // Row by row in parallel, straight into place: a million
        // evaluations of a scene's expression are a tenth of a second on
        // one core. (Zeroed memory comes fresh from the kernel, untouched:
        // the rows' pages fault on every core.)
        let mut z = vec![0.0; n];
        z.par_chunks_mut(xs.len().max(1)).zip(ys.par_iter()).for_each(|(row, &y)| {
            for (v, &x) in row.iter_mut().zip(&xs) {
                *v = f(x, y);
            }
        });
        Grid::new(xs, ys, z)
    }

    /// `steps + 1` evenly spaced values from `from` to `to`.
    #[must_use]
    pub fn linspace(from: f64, to: f64, steps: usize) -> Vec<f64> {
        (0..=steps).map(|i| from + (to - from) * (i as f64 / steps.max(1) as f64)).collect()
    }

    /// Points along x.
    #[must_use]
    pub fn nx(&self) -> usize {
        self.xs.len()
    }

    /// Points along y.
    #[must_use]
    pub fn ny(&self) -> usize {
        self.ys.len()
    }

    /// The world point of grid index `(i, j)`.
    #[must_use]
    pub fn point(&self, i: usize, j: usize) -> DVec3 {
        DVec3::new(self.xs[i], self.ys[j], self.z[j * self.xs.len() + i])
    }

    /// Lowest and highest height.
    #[must_use]
    pub fn z_range(&self) -> (f64, f64) {
        self.z.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| (lo.min(v), hi.max(v)))
    }
}

/// Which grid lines are drawn.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum GridLines {
    /// Lines running along x (one per grid row, y constant).
    X,
    /// Lines running along y (one per grid column, x constant).
    Y,
    /// Both.
    #[default]
    Both,
}

/// The grid lines drawn: which directions, and every how many grid lines.
/// The surface that hides them is always the whole grid.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DrawnLines {
    /// Along x, along y, or both.
    pub directions: GridLines,
    /// Every `every`-th grid line from the first is drawn, and the last
    /// (the surface's border); 1 draws them all.
    pub every: usize,
}

impl From<GridLines> for DrawnLines {
    fn from(directions: GridLines) -> DrawnLines {
        DrawnLines { directions, every: 1 }
    }
}

impl DrawnLines {
    /// Whether grid line `k` of `count` (in one direction) is drawn.
    #[must_use]
    pub fn draws(&self, k: usize, count: usize) -> bool {
        k % self.every.max(1) == 0 || k + 1 == count
    }

    /// Whether the line along x at row `j` of `grid` is drawn.
    #[must_use]
    pub fn draws_row(&self, grid: &Grid, j: usize) -> bool {
        self.directions != GridLines::Y && self.draws(j, grid.ny())
    }

    /// Whether the line along y at column `i` of `grid` is drawn.
    #[must_use]
    pub fn draws_column(&self, grid: &Grid, i: usize) -> bool {
        self.directions != GridLines::X && self.draws(i, grid.nx())
    }

    /// Edges drawn: the edges of the drawn rows and columns.
    #[must_use]
    pub fn edge_count(&self, grid: &Grid) -> usize {
        let (nx, ny) = (grid.nx(), grid.ny());
        let rows = (0..ny).filter(|&j| self.draws_row(grid, j)).count();
        let columns = (0..nx).filter(|&i| self.draws_column(grid, i)).count();
        rows * (nx - 1) + columns * (ny - 1)
    }
}

/// What a pass found of one edge, and what the engine keeps of it: one of
/// the three values below, or an index into a list of runs (`FIRST_RUN` and
/// up). Four bytes an edge and no flag beside it: at 2000 x 2000 each half's
/// pass holds 8 million of these (its lines along x and along y), the join
/// writes into the first half's, and every page of them is fresh memory.
type Slot = u32;

/// Not met by the pass (in a half's pass: the edge lies in the other half).
const UNTESTED: Slot = 0;

/// Nothing hidden: visible from end to end (no interval stored), the common
/// case; in a half's pass, nothing hidden in that half.
const WHOLE: Slot = 1;

/// Nothing visible: hidden throughout, or wholly behind the near plane.
const NOTHING: Slot = 2;

/// Slot `FIRST_RUN + r` is run `r` of a [`RunList`].
const FIRST_RUN: Slot = 3;

/// The intervals (edge parameters) that slots from [`FIRST_RUN`] up name,
/// a run of them per slot.
#[derive(Default)]
struct RunList {
    /// (first, count) in `tvals`.
    runs: Vec<(u32, u32)>,
    tvals: Vec<(f64, f64)>,
}

impl RunList {
    /// The slot of a new run of `intervals` (not empty).
    fn push(&mut self, intervals: &[(f64, f64)]) -> Slot {
        self.runs.push((self.tvals.len() as u32, intervals.len() as u32));
        self.tvals.extend_from_slice(intervals);
        FIRST_RUN + self.runs.len() as u32 - 1
    }

    /// The intervals of a slot from [`FIRST_RUN`] up.
    fn get(&self, slot: Slot) -> &[(f64, f64)] {
        let (s, n) = self.runs[(slot - FIRST_RUN) as usize];
        &self.tvals[s as usize..(s + n) as usize]
    }

    /// `other`'s runs after these (the slots naming them are `other`'s
    /// plus the runs here before: see `Engine::join_halves`).
    fn append(&mut self, other: &RunList) {
        let base = self.tvals.len() as u32;
        self.runs.extend(other.runs.iter().map(|&(s, n)| (s + base, n)));
        self.tvals.extend_from_slice(&other.tvals);
    }
}

/// Edges per parallel task where the halves' findings are joined.
const JOIN_CHUNK: usize = 1 << 16;

/// A visible polyline in device space (see [`crate::camera`]).
pub type DevicePolyline = Vec<DVec2>;

/// The order in which the engine visits cells and the two triangles of each.
struct Order {
    rows: Vec<usize>,
    cols: Vec<usize>,
    /// Eye's ground point (perspective) or `None` (orthographic).
    eye: Option<DVec2>,
    /// Ground view direction for orthographic views.
    ground_dir: DVec2,
}

/// Indices `0..n` from `start` upwards, then from `start - 1` downwards;
/// `start` may be `-1` or `n` (the eye outside on that side).
fn outward(n: usize, start: isize) -> Vec<usize> {
    let mut v = Vec::with_capacity(n);
    let s = start.clamp(0, n as isize) as usize;
    v.extend(s..n);
    v.extend((0..s).rev());
    v
}

/// The cell whose span holds `e`: `-1` before the first, `n - 1` (one past the
/// last cell) beyond the last value.
fn cell_of(v: &[f64], e: f64) -> isize {
    let n = v.len();
    if e < v[0] {
        return -1;
    }
    if e > v[n - 1] {
        return n as isize - 1;
    }
    let i = v.partition_point(|&x| x <= e).saturating_sub(1);
    i.min(n - 2) as isize
}

impl Order {
    fn new(grid: &Grid, camera: &Camera) -> Order {
        let (ncx, ncy) = (grid.nx() - 1, grid.ny() - 1);
        match camera.projection {
            Projection::Perspective { .. } => {
                let e = DVec2::new(camera.eye.x, camera.eye.y);
                let ci = cell_of(&grid.xs, e.x);
                let cj = cell_of(&grid.ys, e.y);
                Order { rows: outward(ncy, cj), cols: outward(ncx, ci), eye: Some(e), ground_dir: DVec2::ZERO }
            }
            Projection::Orthographic { .. } => {
                let d = camera.direction();
                let g = DVec2::new(d.x, d.y);
                let along = |n: usize, c: f64| if c < 0.0 { outward(n, n as isize) } else { outward(n, -1) };
                Order { rows: along(ncy, g.y), cols: along(ncx, g.x), eye: None, ground_dir: g }
            }
        }
    }

    /// Whether the lower triangle of cell (i, j) (the one holding
    /// `(x_i+1, y_j)`) comes first: the eye sees across the diagonal from its
    /// side.
    fn lower_first(&self, grid: &Grid, i: usize, j: usize) -> bool {
        let p0 = DVec2::new(grid.xs[i], grid.ys[j]);
        let d = DVec2::new(grid.xs[i + 1] - grid.xs[i], grid.ys[j + 1] - grid.ys[j]);
        let toward = match self.eye {
            Some(e) => e - p0,
            None => -self.ground_dir,
        };
        d.x * toward.y - d.y * toward.x < 0.0
    }
}

/// The screen polygon of the convex world polygon `w`, clipped at the near
/// plane, into `poly`; false when fewer than three points remain.
pub(crate) fn near_clipped(camera: &Camera, w: &[DVec3], poly: &mut Vec<DVec2>) -> bool {
    poly.clear();
    let n = w.len();
    for k in 0..n {
        let (a, b) = (w[k], w[(k + 1) % n]);
        let (da, db) = (camera.near_distance(a), camera.near_distance(b));
        if da >= 0.0 {
            if let Some(p) = camera.project(a).or_else(|| camera.project(a + (b - a) * 1e-12)) {
                poly.push(DVec2::new(p.x, p.y));
            }
        }
        if (da >= 0.0) != (db >= 0.0) {
            let t = da / (da - db);
            let x = a + (b - a) * t;
            let v = camera.to_view(x);
            let dv = camera.view_to_device(DVec3::new(v.x, v.y, v.z.min(-camera.near)));
            poly.push(DVec2::new(dv.x, dv.y));
        }
    }
    poly.len() >= 3
}

/// Device ends of the part of the world segment `a`-`b` in front of the near
/// plane.
pub(crate) fn clipped_ends(camera: &Camera, a: DVec3, b: DVec3) -> Option<(DVec2, DVec2)> {
    let (t0, t1) = camera.clip_segment(a, b)?;
    let end = |p: DVec3| {
        let v = camera.to_view(p);
        let d = camera.view_to_device(DVec3::new(v.x, v.y, v.z.min(-camera.near)));
        d.is_finite().then(|| DVec2::new(d.x, d.y))
    };
    Some((end(a.lerp(b, t0))?, end(a.lerp(b, t1))?))
}

/// The visible parts of the grid lines of `grid` seen through `camera`, as
/// device-space polylines, each running along one grid line.
#[must_use]
pub fn visible_lines(grid: &Grid, camera: &Camera, lines: impl Into<DrawnLines>) -> Vec<DevicePolyline> {
    Engine::new(grid, camera, lines.into()).run()
}

/// The visibility of every drawn grid line in the general engine's form: one
/// [`LineVisibility`] per grid edge (edges wholly behind the near plane are
/// left out), with `LineSource::Edge(k)` numbering the edges as
/// `scene::Surface::lower` adds them to a model: first the lines
/// along x, row by row (`k = j (nx - 1) + i`), then the lines along y, column
/// by column (lines not drawn are left out of the numbering, as the
/// lowering leaves them out). So the answer can be checked against the
/// reference on the lowered model, and `render` treats both engines alike.
#[must_use]
pub fn visibility(grid: &Grid, camera: &Camera, lines: impl Into<DrawnLines>, pen: u32) -> Vec<LineVisibility> {
    Engine::new(grid, camera, lines.into()).compute().into_visibility(pen)
}

/// A finite `pole` whose splitting line has about half of the projected
/// vertices `proj` on either side, so that the two halves' sweeps take about
/// as long: turned to a sampled vertex of median key. (Keys are measured
/// from the old line, which points near the picture's centre, so they do
/// not wrap across it.) Turned a little further by an arbitrary angle, so
/// that the line is unlikely to run along a grid line of a symmetric view.
fn halving(pole: Pole, proj: &[DVec2]) -> Pole {
    let Pole::Finite { c, .. } = pole else { return pole };
    let step = (proj.len() / 4096).max(1);
    let mut sample: Vec<(f64, usize)> = (0..proj.len()).step_by(step).map(|v| (pole.raw_key(proj[v]), v)).collect();
    if sample.is_empty() {
        return pole;
    }
    let mid = sample.len() / 2;
    let (_, &mut (_, v), _) = sample.select_nth_unstable_by(mid, |a, b| a.0.total_cmp(&b.0));
    let Some(d) = (proj[v] - c).try_normalize() else { return pole };
    let (sn, cs) = 0.001_234_567_f64.sin_cos();
    Pole::Finite { c, w: DVec2::new(d.x * cs - d.y * sn, d.x * sn + d.y * cs) }
}

/// True when a cell whose corners project to `p` (in order around it) is
/// a strictly convex quadrilateral: its two triangles then lie on either
/// side of the diagonal, and their union is the quadrilateral.
fn convex_cell(p: &[DVec2; 4]) -> bool {
    if p.iter().any(|v| v.x.is_nan()) {
        return false;
    }
    let turn = |a: DVec2, b: DVec2, c: DVec2| (b - a).perp_dot(c - b);
    let t = [turn(p[0], p[1], p[2]), turn(p[1], p[2], p[3]), turn(p[2], p[3], p[0]), turn(p[3], p[0], p[1])];
    t.iter().all(|&x| x > 0.0) || t.iter().all(|&x| x < 0.0)
}

/// Per-vertex projection: device x, y, or NaN when behind the near plane.
struct Engine<'a> {
    grid: &'a Grid,
    camera: &'a Camera,
    lines: DrawnLines,
    proj: Vec<DVec2>,
    /// Raw key of each projected vertex (see `horizon`), filled by `compute`.
    keys: Vec<f64>,
    /// Radius of each projected vertex (distance from the pole, or the
    /// coordinate along parallel rays), filled by `compute`.
    radii: Vec<f64>,
    /// Visible pieces as parameter intervals of their edge (device points
    /// are made from them only at the end, so they are not stored twice).
    visible: RunList,
    /// Per edge, its [`Slot`]. Lines along x at `j (nx - 1) + i`; lines
    /// along y at the index of their lower vertex, `j nx + i`, row by row
    /// like the sweep (not in the lowering's column order, which would
    /// stride across memory).
    h_run: Vec<Slot>,
    v_run: Vec<Slot>,
    /// The complete picture once `compute` has run (for free lines): one
    /// sweep, or one per half of the picture.
    picture: Vec<Sweep>,
    /// Lines lying in facets (contours on the surface), tested when their
    /// facet is visited, before it is merged.
    in_facet: InFacet,
}

/// Segments lying in facets, grouped by facet.
#[derive(Default)]
struct InFacet {
    /// World ends of each segment.
    segments: Vec<(DVec3, DVec3)>,
    /// Per facet `f`, its segments are `order[start[f]..start[f + 1]]`;
    /// empty when there are none at all.
    start: Vec<u32>,
    order: Vec<u32>,
    /// Device ends and visible intervals of each segment, once tested.
    result: Vec<Option<TestedSegment>>,
}

/// What one sweep finds about the edges as it meets them (see
/// [`Engine::pass`]): slots and runs as the engine's own, of visible
/// intervals, or of hidden ones in a half's pass.
struct Found {
    hidden: bool,
    list: RunList,
    h_run: Vec<Slot>,
    v_run: Vec<Slot>,
    /// Scratch for one edge's intervals.
    vis: Vec<(f64, f64)>,
    /// Per segment lying in a facet, its test (see [`InFacet::result`]).
    in_facet: Vec<Option<TestedSegment>>,
}

/// `n` slots, [`UNTESTED`], written here. Not `vec![UNTESTED; n]`: that is
/// zeroed memory the kernel maps lazily, and a pass reads a slot before it
/// writes it, so every page would fault twice, the second time (copy on
/// write of the zero page) with a TLB flush on every core the process runs
/// on (measured at 2000 x 2000: 20 % more system time for the stage).
fn untested(n: usize) -> Vec<Slot> {
    let mut v = Vec::with_capacity(n);
    v.resize(n, UNTESTED);
    v
}

/// What a half's pass found hidden of an edge with this slot.
fn hidden_of(list: &RunList, slot: Slot) -> &[(f64, f64)] {
    match slot {
        UNTESTED | WHOLE => &[],
        NOTHING => &[(0.0, 1.0)],
        run => list.get(run),
    }
}

/// A tested segment: its device ends and visible intervals.
type TestedSegment = (DVec2, DVec2, Vec<(f64, f64)>);

impl<'a> Engine<'a> {
    fn new(grid: &'a Grid, camera: &'a Camera, lines: DrawnLines) -> Engine<'a> {
        let (nx, ny) = (grid.nx(), grid.ny());
        let projector = camera.projector();
        // Collected straight into place in parallel (a fill first would be
        // tens of MB written twice, once on one thread).
        let proj: Vec<DVec2> = (0..nx * ny)
            .into_par_iter()
            .map(|v| projector.project(grid.point(v % nx, v / nx)).map_or(DVec2::NAN, |d| DVec2::new(d.x, d.y)))
            .collect();
        let draw_h = lines.directions != GridLines::Y;
        let draw_v = lines.directions != GridLines::X;
        let nh = if draw_h { (nx - 1) * ny } else { 0 };
        let nv = if draw_v { nx * (ny - 1) } else { 0 };
        Engine {
            grid,
            camera,
            lines,
            proj,
            keys: Vec::new(),
            radii: Vec::new(),
            visible: RunList::default(),
            h_run: vec![UNTESTED; nh],
            v_run: vec![UNTESTED; nv],
            picture: Vec::new(),
            in_facet: InFacet::default(),
        }
    }

    fn run(self) -> Vec<DevicePolyline> {
        self.compute().assemble()
    }

    fn compute(self) -> Self {
        self.compute_in_halves(true)
    }

    /// [`Engine::compute`], with one sweep per half of the picture where
    /// `in_halves` allows it (tests compare the two ways).
    fn compute_in_halves(mut self, in_halves: bool) -> Self {
        let Some(pole) = pole_of(self.camera) else {
            // Straight down or up, orthographic: every line is visible.
            return self.all_visible();
        };
        let order = Order::new(self.grid, self.camera);
        // The two halves of the picture about the line through a finite pole
        // hold disjoint keys: one sweep each, at once, when every vertex
        // projects and no segment lies in a facet (the cases the halves'
        // passes are built for), with the line turned to halve the work.
        let halves = in_halves
            && matches!(pole, Pole::Finite { .. })
            && self.in_facet.start.is_empty()
            && self.proj.par_iter().all(|p| !p.x.is_nan());
        let pole = if halves { halving(pole, &self.proj) } else { pole };
        self.keys = self.proj.par_iter().map(|&p| if p.x.is_nan() { 0.0 } else { pole.raw_key(p) }).collect();
        self.radii = self.proj.par_iter().map(|&p| if p.x.is_nan() { 0.0 } else { pole.radius(p) }).collect();
        if halves {
            let ((left, a), (right, b)) = rayon::join(
                || self.pass(Sweep::of_half(pole, Half::Left), true, &order),
                || self.pass(Sweep::of_half(pole, Half::Right), true, &order),
            );
            self.join_halves(a, &b);
            self.picture = vec![left, right];
        } else {
            let (sweep, found) = self.pass(Sweep::new(pole), false, &order);
            self.in_facet.result = found.in_facet;
            (self.visible, self.h_run, self.v_run) = (found.list, found.h_run, found.v_run);
            self.picture = vec![sweep];
        }
        self
    }

    /// One sweep over every cell in occlusion-compatible order: each edge
    /// tested when the first facet holding it is visited, then the facet
    /// merged. `hidden`: record hidden intervals (a half's pass) rather
    /// than visible ones.
    fn pass(&self, mut sweep: Sweep, hidden: bool, order: &Order) -> (Sweep, Found) {
        let (nh, nv) = (self.h_run.len(), self.v_run.len());
        let mut found = Found {
            hidden,
            list: RunList::default(),
            h_run: untested(nh),
            v_run: untested(nv),
            vis: Vec::new(),
            in_facet: vec![None; self.in_facet.segments.len()],
        };
        let nx = self.grid.nx();
        let mut poly: Vec<DVec2> = Vec::with_capacity(6);
        for &j in &order.rows {
            for &i in &order.cols {
                let v00 = j * nx + i;
                let v10 = v00 + 1;
                let v01 = v00 + nx;
                let v11 = v01 + 1;
                // Lower: (i,j) (i+1,j) (i+1,j+1); draws H(i,j) and V(i+1,j).
                // Upper: (i,j) (i+1,j+1) (i,j+1); draws H(i,j+1) and V(i,j).
                let q = [v00, v10, v11, v01];
                let pts = q.map(|v| self.proj[v]);
                if hidden && sweep.leaves(&pts) {
                    // The other half's: its edges, tested here, would show
                    // nothing hidden (they are left untested: `join_halves`).
                    continue;
                }
                let lower = [(v00, v10, v11), (v00, v11, v01)];
                let first = if order.lower_first(self.grid, i, j) { 0 } else { 1 };
                if self.in_facet.start.is_empty() && convex_cell(&pts) {
                    // Neither triangle can cover the other's edges, so all
                    // four are tested first and the cell is merged once.
                    for t in [first, 1 - first] {
                        self.test_triangle_edges(&mut sweep, &mut found, i, j, t);
                    }
                    sweep.add_convex(&pts, &q.map(|v| self.keys[v]), &q.map(|v| self.radii[v]));
                    continue;
                }
                for t in [first, 1 - first] {
                    let (a, b, c) = lower[t];
                    self.test_triangle_edges(&mut sweep, &mut found, i, j, t);
                    if !self.in_facet.start.is_empty() {
                        self.test_in_facet(&mut sweep, &mut found, 2 * (j * (nx - 1) + i) + t);
                    }
                    if self.facet_polygon([a, b, c], &mut poly) {
                        if poly.len() == 3 && !self.proj[a].x.is_nan() && !self.proj[b].x.is_nan() && !self.proj[c].x.is_nan() {
                            let keys = [self.keys[a], self.keys[b], self.keys[c]];
                            let radii = [self.radii[a], self.radii[b], self.radii[c]];
                            sweep.add_convex(&[poly[0], poly[1], poly[2]], &keys, &radii);
                        } else {
                            sweep.add_polygon(&poly);
                        }
                    }
                }
            }
        }
        (sweep, found)
    }

    /// The visible intervals of every edge from what the two halves' passes
    /// found hidden: the complement of both together, as one sweep of both
    /// halves finds it. An edge a pass left untested lies wholly in the
    /// other's half: it hides nothing of it there. Joined into `a`'s slots,
    /// in place, a chunk of edges per parallel task.
    fn join_halves(&mut self, a: Found, b: &Found) {
        let Found { h_run: mut h, v_run: mut v, list, .. } = a;
        let mut visible = RunList::default();
        let mut join = |mine: &mut [Slot], theirs: &[Slot]| {
            let parts: Vec<RunList> = mine
                .par_chunks_mut(JOIN_CHUNK)
                .zip(theirs.par_chunks(JOIN_CHUNK))
                .map(|(mine, theirs)| {
                    let (mut part, mut hidden, mut shown) = (RunList::default(), Vec::new(), Vec::new());
                    for (slot, &other) in mine.iter_mut().zip(theirs) {
                        let (ha, hb) = (hidden_of(&list, *slot), hidden_of(&b.list, other));
                        if ha.is_empty() && hb.is_empty() {
                            *slot = WHOLE;
                            continue;
                        }
                        hidden.clear();
                        hidden.extend_from_slice(ha);
                        hidden.extend_from_slice(hb);
                        shown.clear();
                        sweep::complement(&mut hidden, &mut shown);
                        *slot = match shown[..] {
                            [] => NOTHING,
                            [(0.0, 1.0)] => WHOLE,
                            _ => part.push(&shown),
                        };
                    }
                    part
                })
                .collect();
            // Each chunk numbered its runs from 0: its slots are shifted
            // by the runs before it, and the runs put end to end.
            let bases: Vec<u32> = parts
                .iter()
                .scan(visible.runs.len() as u32, |base, part| {
                    let at = *base;
                    *base += part.runs.len() as u32;
                    Some(at)
                })
                .collect();
            mine.par_chunks_mut(JOIN_CHUNK).zip(bases).for_each(|(slots, base)| {
                slots.iter_mut().filter(|s| **s >= FIRST_RUN).for_each(|s| *s += base);
            });
            visible.runs.reserve(parts.iter().map(|p| p.runs.len()).sum());
            visible.tvals.reserve(parts.iter().map(|p| p.tvals.len()).sum());
            parts.iter().for_each(|part| visible.append(part));
        };
        join(&mut h, &b.h_run);
        join(&mut v, &b.v_run);
        (self.visible, self.h_run, self.v_run) = (visible, h, v);
    }

    /// Registers segments lying in facets (`(facet, a, b)`, facets numbered
    /// as `scene::contours::trace_facets` numbers them).
    fn with_in_facet(mut self, lines: &[(u32, DVec3, DVec3)]) -> Self {
        if lines.is_empty() {
            return self;
        }
        let facets = 2 * (self.grid.nx() - 1) * (self.grid.ny() - 1);
        let mut count = vec![0u32; facets + 1];
        for &(f, _, _) in lines {
            count[f as usize + 1] += 1;
        }
        for f in 0..facets {
            count[f + 1] += count[f];
        }
        let mut fill = count.clone();
        let mut order = vec![0u32; lines.len()];
        for (n, &(f, _, _)) in lines.iter().enumerate() {
            order[fill[f as usize] as usize] = n as u32;
            fill[f as usize] += 1;
        }
        self.in_facet =
            InFacet { segments: lines.iter().map(|&(_, a, b)| (a, b)).collect(), start: count, order, result: vec![None; lines.len()] };
        self
    }

    /// Tests the segments lying in facet `f` against the horizon.
    fn test_in_facet(&self, sweep: &mut Sweep, found: &mut Found, f: usize) {
        let (s, e) = (self.in_facet.start[f] as usize, self.in_facet.start[f + 1] as usize);
        for k in s..e {
            let n = self.in_facet.order[k] as usize;
            let (a, b) = self.in_facet.segments[n];
            if let Some((p, q)) = clipped_ends(self.camera, a, b) {
                let mut vis = Vec::new();
                sweep.visible_keyed(p, q, None, &mut vis);
                found.in_facet[n] = Some((p, q, vis));
            }
        }
    }

    fn world(&self, v: usize) -> DVec3 {
        let nx = self.grid.nx();
        self.grid.point(v % nx, v / nx)
    }

    /// The facet's screen polygon, clipped at the near plane; false if empty.
    fn facet_polygon(&self, tri: [usize; 3], poly: &mut Vec<DVec2>) -> bool {
        poly.clear();
        if tri.iter().all(|&v| !self.proj[v].x.is_nan()) {
            poly.extend(tri.iter().map(|&v| self.proj[v]));
            return true;
        }
        let w = [self.world(tri[0]), self.world(tri[1]), self.world(tri[2])];
        near_clipped(self.camera, &w, poly)
    }

    /// Tests the two grid edges triangle `t` of cell `(i, j)` draws: the
    /// lower (`t = 0`) H(i,j) and V(i+1,j), the upper H(i,j+1) and V(i,j).
    #[inline]
    fn test_triangle_edges(&self, sweep: &mut Sweep, found: &mut Found, i: usize, j: usize, t: usize) {
        if t == 0 {
            self.test_h(sweep, found, i, j);
            self.test_v(sweep, found, i + 1, j);
        } else {
            self.test_h(sweep, found, i, j + 1);
            self.test_v(sweep, found, i, j);
        }
    }

    fn test_h(&self, sweep: &mut Sweep, found: &mut Found, i: usize, j: usize) {
        if !self.lines.draws_row(self.grid, j) {
            return;
        }
        let e = j * (self.grid.nx() - 1) + i;
        if found.h_run[e] != UNTESTED {
            return;
        }
        let v = j * self.grid.nx() + i;
        found.h_run[e] = self.test_edge(sweep, found, v, v + 1);
    }

    fn test_v(&self, sweep: &mut Sweep, found: &mut Found, i: usize, j: usize) {
        if !self.lines.draws_column(self.grid, i) {
            return;
        }
        let v = j * self.grid.nx() + i;
        if found.v_run[v] != UNTESTED {
            return;
        }
        found.v_run[v] = self.test_edge(sweep, found, v, v + self.grid.nx());
    }

    /// Device ends of the part of edge `va`-`vb` in front of the near plane.
    fn edge_ends(&self, va: usize, vb: usize) -> Option<(DVec2, DVec2)> {
        let (pa, pb) = (self.proj[va], self.proj[vb]);
        if !pa.x.is_nan() && !pb.x.is_nan() {
            return Some((pa, pb));
        }
        clipped_ends(self.camera, self.world(va), self.world(vb))
    }

    /// The visible intervals of an edge.
    fn visible(&self, slot: Slot) -> &[(f64, f64)] {
        match slot {
            WHOLE => &[(0.0, 1.0)],
            UNTESTED | NOTHING => &[],
            run => self.visible.get(run),
        }
    }

    /// Tests the grid edge between vertices `va`, `vb` against the horizon and
    /// records its visible pieces, or in a half's pass its hidden ones
    /// (ordered from `va` to `vb`; [`WHOLE`]: nothing hidden).
    fn test_edge(&self, sweep: &mut Sweep, found: &mut Found, va: usize, vb: usize) -> Slot {
        let (pa, pb) = (self.proj[va], self.proj[vb]);
        found.vis.clear();
        if !pa.x.is_nan() && !pb.x.is_nan() {
            let (keys, radii) = ((self.keys[va], self.keys[vb]), (self.radii[va], self.radii[vb]));
            if found.hidden {
                sweep.hidden_known(pa, pb, keys, radii, &mut found.vis);
                if found.vis.is_empty() {
                    return WHOLE;
                }
            } else if sweep.visible_known(pa, pb, keys, radii, &mut found.vis) {
                return WHOLE;
            }
        } else {
            let Some((p, q)) = clipped_ends(self.camera, self.world(va), self.world(vb)) else { return NOTHING };
            sweep.visible_keyed(p, q, None, &mut found.vis);
            if found.vis[..] == [(0.0, 1.0)] {
                return WHOLE;
            }
        }
        if found.vis.is_empty() {
            return NOTHING;
        }
        found.list.push(&found.vis)
    }

    fn all_visible(mut self) -> Self {
        let nx = self.grid.nx();
        // Lines not drawn stay untested, as a sweep leaves them.
        for e in 0..self.h_run.len() {
            let (i, j) = (e % (nx - 1), e / (nx - 1));
            let v = j * nx + i;
            let seen = !self.proj[v].x.is_nan() && !self.proj[v + 1].x.is_nan();
            self.h_run[e] = if !self.lines.draws_row(self.grid, j) {
                UNTESTED
            } else if seen {
                WHOLE
            } else {
                NOTHING
            };
        }
        for v in 0..self.v_run.len() {
            let seen = !self.proj[v].x.is_nan() && !self.proj[v + nx].x.is_nan();
            self.v_run[v] = if !self.lines.draws_column(self.grid, v % nx) {
                UNTESTED
            } else if seen {
                WHOLE
            } else {
                NOTHING
            };
        }
        self
    }

    /// One [`LineVisibility`] per drawn edge, numbered as the lowering does.
    fn into_visibility(self, pen: u32) -> Vec<LineVisibility> {
        let (nx, ny) = (self.grid.nx(), self.grid.ny());
        let mut out = Vec::with_capacity(self.h_run.len() + self.v_run.len());
        let mut k = 0u32;
        let mut push = |va: usize, vb: usize, run: Slot, k: u32| {
            if let Some((a, b)) = self.edge_ends(va, vb) {
                let visible = Intervals::from_slice(self.visible(run));
                out.push(LineVisibility { source: LineSource::Edge(k), pen, a, b, visible });
            }
        };
        for (e, &run) in self.h_run.iter().enumerate() {
            if !self.lines.draws_row(self.grid, e / (nx - 1)) {
                continue;
            }
            let v = (e / (nx - 1)) * nx + e % (nx - 1);
            push(v, v + 1, run, k);
            k += 1;
        }
        if !self.v_run.is_empty() {
            for i in (0..nx).filter(|&i| self.lines.draws_column(self.grid, i)) {
                for j in 0..ny - 1 {
                    let v = j * nx + i;
                    push(v, v + nx, self.v_run[v], k);
                    k += 1;
                }
            }
        }
        out
    }

    /// Joins the visible pieces along each grid line into polylines, the
    /// lines along x row by row, then those along y column by column. The
    /// lines are independent, so they are joined in parallel.
    fn assemble(self) -> Vec<DevicePolyline> {
        let (nx, ny) = (self.grid.nx(), self.grid.ny());
        // (A line not drawn is untested in both halves, and so joined as
        // visible: only drawn lines are assembled.)
        let rows = (0..if self.h_run.is_empty() { 0 } else { ny })
            .into_par_iter()
            .filter(|&j| self.lines.draws_row(self.grid, j))
            .map(|j| self.line(&self.h_run, j * nx, 1, nx - 1));
        let cols = (0..if self.v_run.is_empty() { 0 } else { nx })
            .into_par_iter()
            .filter(|&i| self.lines.draws_column(self.grid, i))
            .map(|i| self.line(&self.v_run, i, nx, ny - 1));
        let per_line: Vec<Vec<DevicePolyline>> = rows.chain(cols).collect();
        per_line.into_iter().flatten().collect()
    }

    /// The polylines of one grid line: `count` edges from vertex `first`,
    /// `step` from one vertex to the next along it.
    fn line(&self, slots: &[Slot], first: usize, step: usize, count: usize) -> Vec<DevicePolyline> {
        let nx = self.grid.nx();
        let mut out = Vec::new();
        // `cur` is reused; each polyline is copied out at its exact size
        // (one allocation instead of a doubling series per polyline).
        let mut cur: Vec<DVec2> = Vec::new();
        let flush = |cur: &mut Vec<DVec2>, out: &mut Vec<DevicePolyline>| {
            if cur.len() >= 2 {
                out.push(cur.clone());
            }
            cur.clear();
        };
        for e in 0..count {
            let va = first + e * step;
            let visible = self.visible(slots[if step == 1 { va - va / nx } else { va }]);
            let ends = if visible.is_empty() { None } else { self.edge_ends(va, va + step) };
            for &(t0, t1) in visible {
                let Some((p, q)) = ends else { break };
                let a = if t0 == 0.0 { p } else { p.lerp(q, t0) };
                let b = if t1 == 1.0 { q } else { p.lerp(q, t1) };
                // Mostly the very point the last piece ended on (an edge
                // visible to its end, then the next from its start): no
                // square roots for those.
                let joins = cur.last().is_some_and(|&l: &DVec2| l == a || l.distance(a) <= tolerance::JOIN * (1.0 + a.length()));
                if !joins {
                    flush(&mut cur, &mut out);
                    cur.push(a);
                }
                cur.push(b);
            }
            if visible.is_empty() {
                flush(&mut cur, &mut out);
            }
        }
        flush(&mut cur, &mut out);
        out
    }
}

#[cfg(test)]
mod tests;
