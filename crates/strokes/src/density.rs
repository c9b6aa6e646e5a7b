//! How crowded a drawing is for a pen: the share of its ink that lies
//! closer than the pen's width to a parallel line, where the two lines run
//! together into one solid band on paper.
//!
//! A fine grid seen from afar, or hatching tighter than the pen, comes out
//! black: a 400 x 400 surface on A4 is 99 m of ink, and with a 0.3 mm pen
//! most of it lies within a pen width of the next grid line. [`crowding`]
//! measures it before anything is plotted.
//!
//! **How.** [`PROBES`] points are spread evenly along the length of a pen's
//! lines (the same spacing everywhere, so each stands for as much ink as any
//! other; on a short drawing fewer, [`MIN_PROBE_SPACING_WIDTHS`] apart). A
//! probe is crowded when some other segment runs beside it within
//! [`PARALLEL_RAD`] of its direction, its foot within that segment, and at a
//! distance above [`SAME_LINE_MM`] (a line's own continuation and what the
//! stroke stages already merged lie closer) but below the pen width. The
//! segments near each probe are found through a uniform grid of cells over
//! the drawing, each cell listing the probes of its own and its eight
//! neighbours' cells; every segment is walked through the cells it crosses,
//! in parallel. The share is exact for the probes; for the drawing it is a
//! sample of [`PROBES`] points (within about 1 % of the share).

use crate::drawing::Drawing;
use glam::DVec2;
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};

/// Probes per pen: the share is measured to within about a percent, at a
/// cost that does not grow with the drawing's length.
pub const PROBES: usize = 16_384;

/// Probes are never closer than this many pen widths: two long lines that
/// run together do so over at least `2 / PARALLEL_RAD` widths, so a finer
/// spacing adds nothing but time (16,384 probes on one 300 mm line cost 12
/// million instructions, most of the whole render of that line).
pub const MIN_PROBE_SPACING_WIDTHS: f64 = 0.25;

/// Two lines closer in direction than this (radians) are parallel: lines
/// that cross at a steeper angle touch at a point, not along a band.
pub const PARALLEL_RAD: f64 = 0.2;

/// A line closer than this (mm) to a probe is the probe's own line (or a
/// part the stroke stages merge with it: their tolerance is 0.01 mm).
pub const SAME_LINE_MM: f64 = 0.01;

/// The most cells of the probes' grid: a page of 200 x 300 mm at 0.6 mm
/// cells; a larger drawing gets larger cells.
const MAX_CELLS: usize = 1 << 20;

/// The most cells per probe: a short line across a page needs a few cells
/// along it, not the page's hundred thousand (their counts are summed and
/// copied whole).
const MAX_CELLS_PER_PROBE: usize = 4;

/// How crowded one pen's lines are.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PenCrowding {
    /// The pen.
    pub pen: u32,
    /// Its width, mm.
    pub width_mm: f64,
    /// Length of its lines, mm.
    pub ink_mm: f64,
    /// Share (0 to 1) of that length lying closer than the pen's width to a
    /// parallel line.
    pub crowded_share: f64,
    /// The median distance between those crowded lines and their nearest
    /// parallel neighbour, mm (`None` when nothing is crowded): a pen finer
    /// than this, or lines this much further apart, would keep them apart.
    pub median_gap_mm: Option<f64>,
}

impl PenCrowding {
    /// How many times further apart the crowded lines must be for the
    /// median pair to stand a pen width apart (`every = N` on a surface).
    #[must_use]
    pub fn spacing_factor(&self) -> Option<usize> {
        let gap = self.median_gap_mm?;
        // (Less a hair: 0.3 / 0.1 is 2.9999999999999996, 0.3 / 0.09999999999999998 a hair above 3.)
        Some(((self.width_mm / gap - 1e-9).ceil() as usize).max(2))
    }
}

/// One probe: a point on a segment, and that segment's direction.
#[derive(Clone, Copy)]
struct Probe {
    at: DVec2,
    dir: DVec2,
}

/// How crowded each pen's lines are for a pen `width_mm(pen)` wide (the
/// pens in order of first use; a pen's visible and hidden layers together).
/// A pen whose width is not a positive number is left out.
#[must_use]
pub fn crowding(drawing: &Drawing, width_mm: impl Fn(u32) -> f64) -> Vec<PenCrowding> {
    let mut pens: Vec<u32> = Vec::new();
    for l in &drawing.layers {
        if !pens.contains(&l.pen) {
            pens.push(l.pen);
        }
    }
    pens.into_iter()
        .filter_map(|pen| {
            let width = width_mm(pen);
            if !(width > 0.0 && width.is_finite()) {
                return None;
            }
            let lines: Vec<&[DVec2]> =
                drawing.layers.iter().filter(|l| l.pen == pen).flat_map(|l| &l.polylines).map(|p| p.points.as_slice()).collect();
            Some(pen_crowding(pen, width, &lines))
        })
        .collect()
}

fn pen_crowding(pen: u32, width: f64, lines: &[&[DVec2]]) -> PenCrowding {
    let lengths: Vec<f64> = lines.par_iter().map(|p| p.windows(2).map(|w| w[0].distance(w[1])).sum()).collect();
    let ink: f64 = lengths.iter().sum();
    let none = PenCrowding { pen, width_mm: width, ink_mm: ink, crowded_share: 0.0, median_gap_mm: None };
    if !(ink > 0.0) {
        return none;
    }
    let probes = probes(lines, &lengths, (ink / PROBES as f64).max(MIN_PROBE_SPACING_WIDTHS * width));
    let Some(cells) = ProbeCells::new(&probes, width) else { return none };
    // The nearest parallel line's distance from each probe, as the bits of
    // a positive f64 (ordered as the numbers are), from every thread.
    let nearest: Vec<AtomicU64> = probes.iter().map(|_| AtomicU64::new(f64::INFINITY.to_bits())).collect();
    let (min_cos, step) = (PARALLEL_RAD.cos(), cells.size);
    lines.par_iter().for_each(|points| {
        for w in points.windows(2) {
            let (a, b) = (w[0], w[1]);
            let len = a.distance(b);
            if !(len > 0.0 && len.is_finite()) {
                continue;
            }
            let dir = (b - a) / len;
            // Points `step` apart along the segment and its end: every probe
            // within a pen width of it lies in a cell next to one of theirs.
            let n = (len / step).ceil() as usize;
            let to_next = (b - a) / n.max(1) as f64;
            let mut last_cell = usize::MAX;
            for k in 0..=n {
                let Some(cell) = cells.cell_of(a + to_next * k as f64) else { continue };
                if cell == last_cell {
                    continue;
                }
                last_cell = cell;
                for &p in cells.near(cell) {
                    let probe = probes[p as usize];
                    if probe.dir.dot(dir).abs() < min_cos {
                        continue;
                    }
                    let along = (probe.at - a).dot(dir);
                    if !(0.0..=len).contains(&along) {
                        continue;
                    }
                    let gap = (probe.at - a).perp_dot(dir).abs();
                    if gap > SAME_LINE_MM && gap < width {
                        nearest[p as usize].fetch_min(gap.to_bits(), Ordering::Relaxed);
                    }
                }
            }
        }
    });
    let mut gaps: Vec<f64> = nearest.iter().map(|g| f64::from_bits(g.load(Ordering::Relaxed))).filter(|g| g.is_finite()).collect();
    if gaps.is_empty() {
        return none;
    }
    let share = gaps.len() as f64 / probes.len() as f64;
    let mid = gaps.len() / 2;
    let (_, median, _) = gaps.select_nth_unstable_by(mid, f64::total_cmp);
    PenCrowding { crowded_share: share, median_gap_mm: Some(*median), ..none }
}

/// Probes `spacing` apart along the lines' length, the first half a spacing in.
fn probes(lines: &[&[DVec2]], lengths: &[f64], spacing: f64) -> Vec<Probe> {
    let mut out = Vec::with_capacity(PROBES + 1);
    // Distance along the whole drawing to the next probe.
    let mut next = 0.5 * spacing;
    let mut walked = 0.0;
    for (points, &length) in lines.iter().zip(lengths) {
        if walked + length < next {
            walked += length;
            continue;
        }
        for w in points.windows(2) {
            let len = w[0].distance(w[1]);
            while next <= walked + len && len > 0.0 {
                let dir = (w[1] - w[0]) / len;
                out.push(Probe { at: w[0] + dir * (next - walked), dir });
                next += spacing;
            }
            walked += len;
        }
    }
    out
}

/// A uniform grid of square cells over the probes, each cell listing the
/// probes in it and in its eight neighbours.
struct ProbeCells {
    origin: DVec2,
    size: f64,
    per_size: f64,
    columns: usize,
    rows: usize,
    /// Per cell, its probes are `order[start[c]..start[c + 1]]`.
    start: Vec<u32>,
    order: Vec<u32>,
}

impl ProbeCells {
    /// Cells at least twice the pen's width across, so that a probe within
    /// a pen width of a segment lies in a cell next to the cell of a point
    /// of the segment no more than a cell away along it. `None` without
    /// probes.
    fn new(probes: &[Probe], width: f64) -> Option<ProbeCells> {
        let first = probes.first()?.at;
        let (lo, hi) = probes.iter().fold((first, first), |(lo, hi), p| (lo.min(p.at), hi.max(p.at)));
        let origin = lo - DVec2::splat(2.0 * width);
        let extent = hi - origin + DVec2::splat(2.0 * width);
        let most = MAX_CELLS.min(MAX_CELLS_PER_PROBE * probes.len());
        let size = (2.0 * width).max((extent.x * extent.y / most as f64).sqrt());
        let columns = (extent.x / size).ceil() as usize + 1;
        let rows = (extent.y / size).ceil() as usize + 1;
        let mut cells =
            ProbeCells { origin, size, per_size: 1.0 / size, columns, rows, start: vec![0; columns * rows + 1], order: Vec::new() };
        let home: Vec<(usize, usize)> =
            probes.iter().map(|p| cells.coordinates(p.at).expect("inside: the grid holds every probe")).collect();
        let neighbours = |(i, j): (usize, usize)| {
            let (i0, j0) = (i.saturating_sub(1), j.saturating_sub(1));
            let (i1, j1) = ((i + 1).min(columns - 1), (j + 1).min(rows - 1));
            (j0..=j1).flat_map(move |j| (i0..=i1).map(move |i| j * columns + i))
        };
        for &h in &home {
            for c in neighbours(h) {
                cells.start[c + 1] += 1;
            }
        }
        for c in 0..columns * rows {
            cells.start[c + 1] += cells.start[c];
        }
        let mut fill = cells.start.clone();
        cells.order = vec![0; cells.start[columns * rows] as usize];
        for (p, &h) in home.iter().enumerate() {
            for c in neighbours(h) {
                cells.order[fill[c] as usize] = p as u32;
                fill[c] += 1;
            }
        }
        Some(cells)
    }

    fn coordinates(&self, p: DVec2) -> Option<(usize, usize)> {
        let q = (p - self.origin) * self.per_size;
        // Truncation is the floor here (not below 0); every segment's every
        // step comes through, and `floor` is a call into libm.
        if !(q.x >= 0.0 && q.y >= 0.0) {
            return None;
        }
        let (i, j) = (q.x as usize, q.y as usize);
        (i < self.columns && j < self.rows).then_some((i, j))
    }

    /// The cell holding `p`, if any.
    fn cell_of(&self, p: DVec2) -> Option<usize> {
        self.coordinates(p).map(|(i, j)| j * self.columns + i)
    }

    /// The probes in and around `cell`.
    fn near(&self, cell: usize) -> &[u32] {
        &self.order[self.start[cell] as usize..self.start[cell + 1] as usize]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{LineKind, Polyline};

    /// `n` horizontal lines `gap` mm apart, 100 mm long, on pen 1.
    fn hatching(n: usize, gap: f64) -> Drawing {
        let mut d = Drawing::new(297.0, 210.0);
        for k in 0..n {
            let y = 20.0 + k as f64 * gap;
            d.layer_mut(1, LineKind::Visible).polylines.push(Polyline::new(vec![DVec2::new(10.0, y), DVec2::new(110.0, y)]));
        }
        d
    }

    #[test]
    fn lines_closer_than_the_pen_are_crowded() {
        // 0.2 mm apart: every line has a neighbour within a 0.3 mm pen.
        let c = crowding(&hatching(50, 0.2), |_| 0.3);
        assert_eq!(c.len(), 1);
        assert!((c[0].ink_mm - 5000.0).abs() < 1e-6);
        assert!(c[0].crowded_share > 0.99, "{c:?}");
        assert!((c[0].median_gap_mm.unwrap() - 0.2).abs() < 1e-9);
        assert_eq!(c[0].spacing_factor(), Some(2));
        // A finer pen keeps them apart.
        let fine = crowding(&hatching(50, 0.2), |_| 0.15);
        assert_eq!((fine[0].crowded_share, fine[0].median_gap_mm), (0.0, None));
    }

    /// A short drawing is probed a quarter pen width apart (40 probes a
    /// line here), not with all [`PROBES`], and still measured: two 3 mm
    /// lines 0.2 mm apart and a third far off are two thirds crowded.
    #[test]
    fn a_short_drawing_is_measured_with_probes_a_quarter_pen_apart() {
        let mut d = hatching(2, 0.2);
        let third = Polyline::new(vec![DVec2::new(10.0, 40.0), DVec2::new(13.0, 40.0)]);
        for (l, y) in d.layer_mut(1, LineKind::Visible).polylines.iter_mut().zip([20.0, 20.2]) {
            *l = Polyline::new(vec![DVec2::new(10.0, y), DVec2::new(13.0, y)]);
        }
        d.layer_mut(1, LineKind::Visible).polylines.push(third);
        let c = crowding(&d, |_| 0.3);
        assert!((c[0].crowded_share - 2.0 / 3.0).abs() < 0.01, "{c:?}");
    }

    #[test]
    fn lines_apart_crossing_or_continuing_are_not_crowded() {
        // 1 mm apart for a 0.3 mm pen.
        assert_eq!(crowding(&hatching(50, 1.0), |_| 0.3)[0].crowded_share, 0.0);
        // Lines crossing at right angles touch at a point, not along a band.
        let mut d = hatching(20, 2.0);
        for k in 0..50 {
            let x = 10.0 + k as f64 * 2.0;
            d.layer_mut(1, LineKind::Visible).polylines.push(Polyline::new(vec![DVec2::new(x, 15.0), DVec2::new(x, 65.0)]));
        }
        // A line in many short pieces, each continuing the last.
        let pieces: Vec<DVec2> = (0..=1000).map(|k| DVec2::new(10.0 + 0.1 * k as f64, 100.0)).collect();
        d.layer_mut(1, LineKind::Visible).polylines.push(Polyline::new(pieces));
        assert_eq!(crowding(&d, |_| 0.3)[0].crowded_share, 0.0);
    }

    #[test]
    fn half_crowded_and_per_pen() {
        // Pen 1: 10 lines 0.1 mm apart and 10 lines 5 mm apart, same length.
        let mut d = hatching(10, 0.1);
        for k in 0..10 {
            let y = 100.0 + k as f64 * 5.0;
            d.layer_mut(1, LineKind::Visible).polylines.push(Polyline::new(vec![DVec2::new(10.0, y), DVec2::new(110.0, y)]));
        }
        // Pen 2 (hidden lines): one line alone; pen 3 has no width.
        d.layer_mut(2, LineKind::Hidden).polylines.push(Polyline::new(vec![DVec2::ZERO, DVec2::new(5.0, 5.0)]));
        d.layer_mut(3, LineKind::Visible).polylines.push(Polyline::new(vec![DVec2::ZERO, DVec2::new(5.0, 0.0)]));
        let c = crowding(&d, |pen| if pen == 3 { 0.0 } else { 0.3 });
        assert_eq!(c.iter().map(|p| p.pen).collect::<Vec<_>>(), vec![1, 2]);
        assert!((c[0].crowded_share - 0.5).abs() < 0.01, "{c:?}");
        assert_eq!(c[1].crowded_share, 0.0);
        assert!((c[1].ink_mm - 50f64.sqrt()).abs() < 1e-9);
    }

    #[test]
    fn nearly_parallel_lines_count_and_steep_ones_do_not() {
        let mut d = Drawing::new(297.0, 210.0);
        let l = d.layer_mut(1, LineKind::Visible);
        // 0.1 rad apart, crossing in the middle: near the crossing they
        // lie within the pen of each other, along about 3 mm of each.
        l.polylines.push(Polyline::new(vec![DVec2::new(0.0, 50.0), DVec2::new(100.0, 50.0)]));
        let (s, c) = 0.1f64.sin_cos();
        l.polylines.push(Polyline::new(vec![DVec2::new(50.0 - 50.0 * c, 50.0 - 50.0 * s), DVec2::new(50.0 + 50.0 * c, 50.0 + 50.0 * s)]));
        let share = crowding(&d, |_| 0.3)[0].crowded_share;
        // Within 0.3 mm across for |x| < 0.3 / tan 0.1 ≈ 3 mm each side: 6 of 100 mm.
        assert!(share > 0.04 && share < 0.08, "{share}");
        // Crossing at 0.5 rad: only a point.
        let mut d = Drawing::new(297.0, 210.0);
        let l = d.layer_mut(1, LineKind::Visible);
        l.polylines.push(Polyline::new(vec![DVec2::new(0.0, 50.0), DVec2::new(100.0, 50.0)]));
        let (s, c) = 0.5f64.sin_cos();
        l.polylines.push(Polyline::new(vec![DVec2::new(50.0 - 50.0 * c, 50.0 - 50.0 * s), DVec2::new(50.0 + 50.0 * c, 50.0 + 50.0 * s)]));
        assert_eq!(crowding(&d, |_| 0.3)[0].crowded_share, 0.0);
    }

    #[test]
    fn every_probe_finds_what_a_scan_of_every_segment_finds() {
        // Short segments of every direction in a small square, bunches of
        // them nearly parallel around the half turn's wrap (angles just
        // above 0 and just below pi, both ways along) and at the other
        // directions' borders: each probe's nearest parallel line as a
        // scan of every segment finds it, to the bit.
        let mut d = Drawing::new(100.0, 100.0);
        let l = d.layer_mut(1, LineKind::Visible);
        let mut x = 0.5_f64;
        let mut next = move || {
            x = (x * 7919.0 + 0.377).fract();
            x
        };
        for k in 0..4000 {
            let angle = match k % 4 {
                0 => next() * std::f64::consts::TAU,
                1 => (next() - 0.5) * 0.3,
                2 => std::f64::consts::PI + (next() - 0.5) * 0.3,
                _ => (next() * 16.0).floor() * std::f64::consts::PI / 8.0 + (next() - 0.5) * 1e-9,
            };
            let a = DVec2::new(next() * 20.0, next() * 20.0);
            let b = a + DVec2::from_angle(angle) * (0.2 + next() * 4.0);
            l.polylines.push(Polyline::new(vec![a, b]));
        }
        let width = 0.3;
        let lines: Vec<&[DVec2]> = d.layers[0].polylines.iter().map(|p| p.points.as_slice()).collect();
        let got = pen_crowding(1, width, &lines);
        let lengths: Vec<f64> = lines.iter().map(|p| p[0].distance(p[1])).collect();
        let ink: f64 = lengths.iter().sum();
        let min_cos = PARALLEL_RAD.cos();
        let all = probes(&lines, &lengths, ink / PROBES as f64);
        let mut gaps: Vec<f64> = all
            .iter()
            .filter_map(|probe| {
                let mut best = f64::INFINITY;
                for p in &lines {
                    let (a, b) = (p[0], p[1]);
                    let len = a.distance(b);
                    let dir = (b - a) / len;
                    let along = (probe.at - a).dot(dir);
                    let gap = (probe.at - a).perp_dot(dir).abs();
                    if probe.dir.dot(dir).abs() >= min_cos && (0.0..=len).contains(&along) && gap > SAME_LINE_MM && gap < width {
                        best = best.min(gap);
                    }
                }
                best.is_finite().then_some(best)
            })
            .collect();
        assert!(gaps.len() > 3000, "too few crowded probes to test: {}", gaps.len());
        let share = gaps.len() as f64 / all.len() as f64;
        let mid = gaps.len() / 2;
        let median = *gaps.select_nth_unstable_by(mid, f64::total_cmp).1;
        assert_eq!((got.crowded_share, got.median_gap_mm), (share, Some(median)));
    }

    #[test]
    fn empty_and_degenerate_drawings() {
        assert!(crowding(&Drawing::new(10.0, 10.0), |_| 0.3).is_empty());
        let mut d = Drawing::new(10.0, 10.0);
        d.layer_mut(1, LineKind::Visible).polylines.push(Polyline::new(vec![DVec2::ONE, DVec2::ONE]));
        let c = crowding(&d, |_| 0.3);
        assert_eq!((c[0].ink_mm, c[0].crowded_share), (0.0, 0.0));
    }
}
