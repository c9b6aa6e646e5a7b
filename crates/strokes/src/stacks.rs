//! Stacks: segments drawn over one another on one line, many times over,
//! cut before [`crate::dedupe()`] forms its pairs.
//!
//! A drawing that draws one square 10,000 times over itself (an HP-GL file
//! going round and round, an SVG of copies of one shape, a fuzzer's
//! mutation) hands `dedupe`'s first pass a pair for every two copies of a
//! side: `k` copies, `k^2 / 2` pairs, gigabytes at `k = 10,000`. Here the
//! segments that lie on one line are found by one sort of a key (their
//! direction and their offset across it, each in small steps), and each
//! such group is cut as `dedupe`'s second pass cuts, longest first: each
//! member keeps what the pieces kept before it do not cover ([`cover`],
//! [`uncovered`]), those pieces found by their place along the line (a
//! sorted map), not through pairs. What the groups keep then goes through
//! `dedupe` with everything else: a stack of `k` copies comes out as one,
//! and pieces of one line as their union, so the pairs left are about as
//! many as the pieces.
//!
//! Nothing here changes what `dedupe` promises: a member is cut only
//! against pieces kept before it in its group, within [`SLOP`] of one line
//! (far inside the tolerance), by the same [`cover`] test; a member farther
//! than that from its group's longest segment is left whole to `dedupe`.
//! A stack split by a step's border is two groups, whose survivors
//! `dedupe` cuts against each other. Segments no longer than the tolerance
//! cover nothing and are never covered ([`cover`]), so they are left out.

use crate::dedupe::{cover, drawable, rebuilt, uncovered, zeroed, Cover, Piece, Points};
use crate::drawing::Polyline;
use glam::DVec2;
use rayon::prelude::*;
use std::collections::BTreeMap;

/// Direction steps over the half turn, of a pseudo-angle (monotone in the
/// angle): about 1e-4 radians each. Segments of one line have one direction
/// to rounding (1e-12 radians on a page); a step's border splits a stack
/// into two groups only when it passes through that rounding.
const DIRECTION_STEPS: f64 = 32_768.0;

/// Offset steps across a direction, as a part of the tolerance. Segments of
/// one line have one offset to rounding (1e-13 mm on a page).
const OFFSET_STEP_OF_TOL: f64 = 0.125;

/// How far (as a part of the tolerance) a member's ends may lie from the
/// line of its group's longest segment for the group to cut it: two members
/// then lie within half the tolerance of each other, and a removed point
/// within that of the piece that covers it.
const SLOP_OF_TOL: f64 = 0.25;

/// Offset steps a sort key holds (40 bits); the step grows on drawings so
/// large that the tolerance's would not fit.
const OFFSET_KEYS: f64 = (1u64 << 40) as f64;

/// The segments of `polylines` that lie on one line with others, cut
/// longest first against the pieces of their line kept before them; the
/// polylines with a cut segment rebuilt around what is kept (see
/// [`rebuilt`]), the others moved whole. Returns them and the length
/// removed. A tolerance of 0 collapses nothing.
pub(crate) fn collapsed(polylines: Vec<Polyline>, tol: f64) -> (Vec<Polyline>, f64) {
    if !(tol > 0.0) {
        return (polylines, 0.0);
    }
    let points = Points::new(&polylines);
    let extent = points.extent();
    if extent.count < 2 {
        return (polylines, 0.0);
    }
    let centre = (extent.lo + extent.hi) * 0.5;
    let reach = (extent.hi - extent.lo).length() + 1.0;
    let step = (OFFSET_STEP_OF_TOL * tol).max(2.0 * reach / OFFSET_KEYS);
    let first = &points.first;
    // (direction step, offset step) and the segment (a point index).
    let mut keyed: Vec<(u64, u32)> = polylines
        .par_iter()
        .enumerate()
        .flat_map_iter(|(pi, p)| {
            let from = first[pi];
            p.points.windows(2).enumerate().filter_map(move |(i, w)| {
                let (a, b) = (w[0], w[1]);
                if !drawable(a, b) || !(a.distance_squared(b) > tol * tol) {
                    return None;
                }
                let mut d = b - a;
                if d.y < 0.0 || (d.y == 0.0 && d.x < 0.0) {
                    d = -d;
                }
                // In [0, 2) over the half turn, growing with the angle.
                let pseudo = 1.0 - d.x / (d.x.abs() + d.y);
                let direction = ((pseudo * 0.5 * DIRECTION_STEPS) as u64).min(DIRECTION_STEPS as u64 - 1);
                let across = d.perp().normalize().dot(a - centre);
                let offset = (((across + reach) / step).max(0.0) as u64).min(OFFSET_KEYS as u64 - 1);
                Some(((direction << 40) | offset, (from + i) as u32))
            })
        })
        .collect();
    keyed.par_sort_unstable();
    let tolerance = tol;
    // Only the members a group cut: (segment, its kept pieces), in key order.
    let cut: Vec<(u32, Vec<Piece>)> = keyed
        .par_chunk_by(|x, y| x.0 == y.0)
        .filter(|group| group.len() > 1)
        .flat_map_iter(|group| cut_group(group, &points, tolerance))
        .collect();
    drop(keyed);
    if cut.is_empty() {
        return (polylines, 0.0);
    }
    let removed: f64 = cut
        .iter()
        .map(|(k, pieces)| {
            let (a, b) = points.segment(*k);
            a.distance(b) - pieces.iter().map(|(p, q)| p.distance(*q)).sum::<f64>()
        })
        .sum();
    let mut marks: Vec<u32> = zeroed(points.len());
    for (i, (k, _)) in cut.iter().enumerate() {
        marks[*k as usize] = i as u32 + 1;
    }
    let first = points.first.clone();
    drop(points);
    (rebuilt(polylines, &first, &marks, |i| &cut[i].1), removed)
}

/// One group's members (`(key, segment)`), cut longest first (ties by
/// position, as `dedupe` ranks them) against the pieces kept before them;
/// the members that lost something, with what they keep.
fn cut_group(group: &[(u64, u32)], points: &Points<'_>, tol: f64) -> Vec<(u32, Vec<Piece>)> {
    let mut members: Vec<(u64, u32)> = group
        .iter()
        .map(|&(_, k)| {
            let (a, b) = points.segment(k);
            (!a.distance_squared(b).to_bits(), k)
        })
        .collect();
    members.sort_unstable();
    let (a0, b0) = points.segment(members[0].1);
    let u = (b0 - a0).normalize();
    let slop = SLOP_OF_TOL * tol;
    let along = |p: DVec2| u.dot(p - a0);
    // Kept pieces by where they start along the line (and an arrival
    // number: two may start at one place): where they end, and the piece.
    // Kept pieces overlap by at most the tolerance and none lies inside
    // another, so their ends come in the order of their starts.
    let mut kept: BTreeMap<(u64, u32), (f64, Piece)> = BTreeMap::new();
    let mut covers: Vec<Cover> = Vec::new();
    let mut pieces: Vec<Piece> = Vec::new();
    let mut out = Vec::new();
    // How many members end at each exact point.
    let mut ends: rustc_hash::FxHashMap<[u64; 2], u32> = rustc_hash::FxHashMap::default();
    for &(_, k) in &members {
        let (a, b) = points.segment(k);
        for x in [a, b] {
            *ends.entry([x.x.to_bits(), x.y.to_bits()]).or_default() += 1;
        }
    }
    let ends_at = |x: DVec2| ends.get(&[x.x.to_bits(), x.y.to_bits()]).copied().unwrap_or(0);
    for &(_, k) in &members {
        let (a, b) = points.segment(k);
        if u.perp_dot(a - a0).abs() > slop || u.perp_dot(b - a0).abs() > slop {
            continue;
        }
        let (lo, hi) = (along(a).min(along(b)), along(a).max(along(b)));
        covers.clear();
        for (_, &(end, (p, q))) in kept.range(..(ordered(hi + tol), u32::MAX)).rev() {
            if end < lo - tol {
                break;
            }
            // A fold's tip only where the two are all that end there (many
            // copies ending at one point are a stack, not a line turning).
            covers.extend(cover(a, b, p, q, tol).filter(|c| c.fold_at(a, b, p, q, tol).is_none_or(|x| ends_at(x) != 2)));
        }
        pieces.clear();
        uncovered(a, b, &mut covers, tol, &mut pieces);
        for &(p, q) in &pieces {
            let n = kept.len() as u32;
            kept.insert((ordered(along(p).min(along(q))), n), (along(p).max(along(q)), (p, q)));
        }
        if pieces[..] != [(a, b)] {
            out.push((k, pieces.clone()));
        }
    }
    out
}

/// `x`'s bits, in the order of the numbers (finite ones).
fn ordered(x: f64) -> u64 {
    let bits = x.to_bits();
    if bits >> 63 == 1 {
        !bits
    } else {
        bits | (1 << 63)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ordered_bits_sort_as_the_numbers() {
        let xs = [-1e300, -3.5, -1e-300, -0.0, 0.0, 1e-300, 2.0, 7.5, 1e300];
        for w in xs.windows(2) {
            assert!(ordered(w[0]) <= ordered(w[1]), "{} {}", w[0], w[1]);
        }
    }
}
