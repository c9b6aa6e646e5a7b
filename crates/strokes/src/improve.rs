//! Local improvement of a stroke tour: 2-opt and Or-opt with stroke reversal,
//! then kicks with whatever work is left.
//!
//! The tour is a cycle of nodes; node 0 is the home position and stays at
//! position 0. Each node has two ends `a` and `b`; a flipped node is drawn
//! from `b` to `a`. The pen-up cost is the sum, over consecutive nodes, of the
//! distance from one node's exit to the next one's entry.
//!
//! Moves are looked for only among nearest-neighbour candidates (the `k`
//! nearest endpoints of each endpoint) and only when they bring a node's end
//! closer than its current tour neighbour, the usual pruning that makes 2-opt
//! near-linear. A work queue holds nodes whose surroundings changed. Every
//! applied move strictly shortens the tour, so the result is never worse than
//! the start.
//!
//! - 2-opt: remove two pen-up moves, reconnect by reversing the strokes
//!   between them (each reversed stroke is also flipped).
//! - Or-opt: move a run of one to five strokes elsewhere, either way round.
//! - Kick: once no such move helps (a local optimum), swap two short
//!   adjacent runs of the tour and descend again from there, keeping the
//!   result only if the tour got shorter (iterated local search with
//!   segment-local double bridges). Kicks spend the rest of the budget.

use super::cells::{bounds, CellGrid, KNN_POINTS_PER_CELL, NO_NEIGHBOUR};
use super::spatial::Groups;
use super::MIN_GAIN_MM;
use glam::DVec2;
use rayon::prelude::*;
use std::collections::VecDeque;

/// Candidate neighbours per endpoint.
const NEIGHBOURS: usize = 12;

/// Longest run of strokes an Or-opt move carries.
const MAX_OR_RUN: usize = 5;

/// Moves that would shift more tour positions than this are skipped: the
/// tour is an array, and one such move would cost more than many local ones.
const MAX_SPAN: usize = 50_000;

/// Tour positions a move may shift for one unit of work: shifting is a
/// sequential copy, a nanosecond or two a position, where one candidate
/// looked at costs tens.
const SHIFTS_PER_UNIT: usize = 16;

/// A cyclic tour of nodes with two ends each; see the module doc.
pub(crate) struct Tour {
    order: Vec<u32>,
    pos: Vec<u32>,
    flip: Vec<bool>,
    a: Vec<DVec2>,
    b: Vec<DVec2>,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Move {
    /// Reverse positions `lo + 1 ..= hi`.
    TwoOpt { lo: usize, hi: usize },
    /// Move positions `s ..= e` to just after position `p`, reversed or not.
    Or { s: usize, e: usize, p: usize, rev: bool },
}

impl Tour {
    /// A tour visiting `order` (which must start with node 0) with the given
    /// flips and node ends.
    pub fn new(order: Vec<u32>, flip: Vec<bool>, a: Vec<DVec2>, b: Vec<DVec2>) -> Self {
        let mut pos = vec![0u32; order.len()];
        for (p, &n) in order.iter().enumerate() {
            pos[n as usize] = p as u32;
        }
        debug_assert_eq!(order.first(), Some(&0));
        Tour { order, pos, flip, a, b }
    }

    /// Number of nodes, home included.
    pub fn len(&self) -> usize {
        self.order.len()
    }

    /// The node at position `p`.
    pub fn node(&self, p: usize) -> usize {
        self.order[p] as usize
    }

    /// Whether `node` is drawn from `b` to `a`.
    pub fn flipped(&self, node: usize) -> bool {
        self.flip[node]
    }

    /// Where the pen comes down on `node`.
    pub fn entry(&self, node: usize) -> DVec2 {
        if self.flip[node] {
            self.b[node]
        } else {
            self.a[node]
        }
    }

    /// Where the pen lifts off `node`.
    pub fn exit(&self, node: usize) -> DVec2 {
        if self.flip[node] {
            self.a[node]
        } else {
            self.b[node]
        }
    }

    /// Sets both ends of a closed node.
    pub fn set_point(&mut self, node: usize, q: DVec2) {
        self.a[node] = q;
        self.b[node] = q;
    }

    /// Position after `p`, cyclically.
    pub fn succ(&self, p: usize) -> usize {
        if p + 1 == self.order.len() {
            0
        } else {
            p + 1
        }
    }

    /// Position before `p`, cyclically.
    pub fn pred(&self, p: usize) -> usize {
        if p == 0 {
            self.order.len() - 1
        } else {
            p - 1
        }
    }

    /// The pen-up move from position `p` to the next.
    fn edge(&self, p: usize) -> f64 {
        self.exit(self.node(p)).distance(self.entry(self.node(self.succ(p))))
    }

    /// Total pen-up travel of the cycle.
    #[cfg(test)]
    pub fn travel(&self) -> f64 {
        (0..self.order.len()).map(|p| self.edge(p)).sum()
    }

    /// Endpoint id `2 * node + (0 for a, 1 for b)` is currently `node`'s exit.
    fn is_exit(&self, end: u32) -> bool {
        (end & 1 == 1) != self.flip[(end >> 1) as usize]
    }

    fn end_point(&self, end: u32) -> DVec2 {
        let n = (end >> 1) as usize;
        if end & 1 == 0 {
            self.a[n]
        } else {
            self.b[n]
        }
    }

    /// The gain of reversing positions `min(i, j) + 1 ..= max(i, j)`, every
    /// pen-up move measured here: what [`Tour::two_opt_gain_at`] must give.
    #[cfg(test)]
    fn two_opt_gain(&self, i: usize, j: usize) -> Option<(f64, Move)> {
        let (lo, hi) = (i.min(j), i.max(j));
        if lo == hi || hi - lo > MAX_SPAN {
            return None;
        }
        let gain = self.edge(lo) + self.edge(hi)
            - self.exit(self.node(lo)).distance(self.exit(self.node(hi)))
            - self.entry(self.node(lo + 1)).distance(self.entry(self.node(self.succ(hi))));
        Some((gain, Move::TwoOpt { lo, hi }))
    }

    /// [`Tour::two_opt_gain`] of `i` and `j` where two of its pen-up moves
    /// are known, as [`Tour::best_move`] knows them: `edge_i`, that is
    /// `self.edge(i)`, and `join`, the new move between the two nodes'
    /// exits (`exits`) or entries. The same numbers in the same order.
    fn two_opt_gain_at(&self, i: usize, j: usize, edge_i: f64, exits: bool, join: f64) -> Option<(f64, Move)> {
        let (lo, hi) = (i.min(j), i.max(j));
        if lo == hi || hi - lo > MAX_SPAN {
            return None;
        }
        let (edge_lo, edge_hi) = if i == lo { (edge_i, self.edge(hi)) } else { (self.edge(lo), edge_i) };
        let (exit_join, entry_join) = if exits {
            (join, self.entry(self.node(lo + 1)).distance(self.entry(self.node(self.succ(hi)))))
        } else {
            (self.exit(self.node(lo)).distance(self.exit(self.node(hi))), join)
        };
        let gain = edge_lo + edge_hi - exit_join - entry_join;
        Some((gain, Move::TwoOpt { lo, hi }))
    }

    /// Positions `s ..= e` as a run an Or-opt move may carry to just after
    /// `p`: inside the tour past home, `p` outside the run and the place
    /// before it, and the move not too long.
    fn or_run(&self, s: isize, e: isize, p: usize) -> Option<(usize, usize)> {
        let last = self.order.len() as isize - 1;
        if s < 1 || e > last || s > e {
            return None;
        }
        let (s, e) = (s as usize, e as usize);
        if (s - 1..=e).contains(&p) || p.abs_diff(s) > MAX_SPAN {
            return None;
        }
        Some((s, e))
    }

    fn or_gain(&self, s: isize, e: isize, p: usize, rev: bool) -> Option<(f64, Move)> {
        let (s, e) = self.or_run(s, e, p)?;
        let (ps, ne, np) = (s - 1, self.succ(e), self.succ(p));
        let removed = self.edge(ps) + self.edge(e) + self.edge(p);
        let (first, last_node) = (self.node(s), self.node(e));
        let inserted = if rev {
            self.exit(self.node(p)).distance(self.exit(last_node)) + self.entry(first).distance(self.entry(self.node(np)))
        } else {
            self.exit(self.node(p)).distance(self.entry(first)) + self.exit(last_node).distance(self.entry(self.node(np)))
        };
        let added = self.exit(self.node(ps)).distance(self.entry(self.node(ne))) + inserted;
        Some((removed - added, Move::Or { s, e, p, rev }))
    }

    /// [`Tour::or_gain`] of the runs of one to [`MAX_OR_RUN`] strokes that
    /// end at position `py` (`ends_at_y`: running back from it) or start
    /// there, each moved to just after `p` (`edge_p`: `self.edge(p)`, which
    /// the caller knows), reversed or not, handed to
    /// `consider` in order of length. The same numbers, summed in the same
    /// order, as `or_gain`'s: only the pen-up moves that do not depend on
    /// the run's length are measured once instead of once per length. (On a
    /// drawing of a few hundred strokes, where the tour is short and shifts
    /// cost little, measuring moves is the improver's time: this, with the
    /// 2-opt's known moves, took 35 % off it, and 7.5 % off the whole render
    /// of a 300 x 300 surface.)
    fn or_gains(&self, py: isize, ends_at_y: bool, (p, edge_p): (usize, f64), rev: bool, consider: &mut impl FnMut(Option<(f64, Move)>)) {
        let last = self.order.len() as isize - 1;
        if !(1..=last).contains(&py) {
            return;
        }
        let np = self.succ(p);
        let (exit_p, entry_np) = (self.exit(self.node(p)), self.entry(self.node(np)));
        // The end of the run at y: its pen-up move on the outside of the
        // run, and where the run meets the place it moves to at that end.
        let y = self.node(py as usize);
        let (fixed_edge, fixed_join) = if ends_at_y {
            let at_y = if rev { exit_p.distance(self.exit(y)) } else { self.exit(y).distance(entry_np) };
            (self.edge(py as usize), at_y)
        } else {
            let at_y = if rev { self.entry(y).distance(entry_np) } else { exit_p.distance(self.entry(y)) };
            (self.edge(py as usize - 1), at_y)
        };
        for l in 1..=MAX_OR_RUN as isize {
            let (s, e) = if ends_at_y { (py - l + 1, py) } else { (py, py + l - 1) };
            let Some((s, e)) = self.or_run(s, e, p) else { continue };
            let (ps, ne) = (s - 1, self.succ(e));
            let (edge_ps, edge_e) = if ends_at_y { (self.edge(ps), fixed_edge) } else { (fixed_edge, self.edge(e)) };
            let removed = edge_ps + edge_e + edge_p;
            let (first, last_node) = (self.node(s), self.node(e));
            let inserted = match (rev, ends_at_y) {
                (true, true) => fixed_join + self.entry(first).distance(entry_np),
                (true, false) => exit_p.distance(self.exit(last_node)) + fixed_join,
                (false, true) => exit_p.distance(self.entry(first)) + fixed_join,
                (false, false) => fixed_join + self.exit(last_node).distance(entry_np),
            };
            let added = self.exit(self.node(ps)).distance(self.entry(self.node(ne))) + inserted;
            consider(Some((removed - added, Move::Or { s, e, p, rev })));
        }
    }

    /// The best improving move around node `x` that the candidate lists
    /// suggest, and how many candidates were looked at.
    fn best_move(&self, x: usize, near: &[u32]) -> (Option<(f64, Move)>, u64) {
        let mut best: Option<(f64, Move)> = None;
        let mut looked = 0;
        let mut consider = |m: Option<(f64, Move)>| keep_better(&mut best, m);
        let px = self.pos[x] as usize;
        let flip = self.flip[x];
        // The pen-up move out of x, then the one into x.
        for outgoing in [true, false] {
            let end = 2 * x as u32 + u32::from(outgoing != flip);
            let here = self.end_point(end);
            let (edge_p, current) = if outgoing {
                (px, self.edge(px))
            } else {
                let pp = self.pred(px);
                (pp, self.edge(pp))
            };
            let row = &near[end as usize * NEIGHBOURS..(end as usize + 1) * NEIGHBOURS];
            for &q in row.iter().take_while(|&&q| q != NO_NEIGHBOUR) {
                let y = (q >> 1) as usize;
                if y == x {
                    continue;
                }
                looked += 1;
                // The pen-up move a 2-opt here would make: x's end to q.
                let join = here.distance(self.end_point(q));
                if join >= current {
                    break;
                }
                let py = self.pos[y] as isize;
                let q_exit = self.is_exit(q);
                if outgoing {
                    if q_exit {
                        consider(self.two_opt_gain_at(px, py as usize, current, true, join));
                    }
                    self.or_gains(py, q_exit, (px, current), q_exit, &mut consider);
                } else {
                    if !q_exit {
                        consider(self.two_opt_gain_at(edge_p, self.pred(py as usize), current, false, join));
                    }
                    self.or_gains(py, q_exit, (edge_p, current), !q_exit, &mut consider);
                }
            }
        }
        (best, looked)
    }

    /// Applies `m`; returns the nodes whose tour neighbours changed and the
    /// number of positions shifted.
    fn apply(&mut self, m: Move) -> ([usize; 6], usize) {
        match m {
            Move::TwoOpt { lo, hi } => {
                let touched = [self.node(lo), self.node(lo + 1), self.node(hi), self.node(self.succ(hi)), 0, 0];
                self.order[lo + 1..=hi].reverse();
                self.refresh(lo + 1, hi, true);
                (touched, hi - lo)
            }
            Move::Or { s, e, p, rev } => {
                let len = e - s + 1;
                let touched =
                    [self.node(s - 1), self.node(s), self.node(e), self.node(self.succ(e)), self.node(p), self.node(self.succ(p))];
                let (from, to, seg) = if p > e {
                    self.order[s..=p].rotate_left(len);
                    (s, p, p + 1 - len)
                } else {
                    self.order[p + 1..=e].rotate_right(len);
                    (p + 1, e, p + 1)
                };
                self.refresh(from, to, false);
                if rev {
                    self.order[seg..seg + len].reverse();
                    self.refresh(seg, seg + len - 1, true);
                }
                (touched, to - from + 1)
            }
        }
    }

    /// Updates positions in `from..=to` and, if `flip`, flips those nodes.
    fn refresh(&mut self, from: usize, to: usize, flip: bool) {
        for p in from..=to {
            let n = self.order[p] as usize;
            self.pos[n] = p as u32;
            if flip {
                self.flip[n] = !self.flip[n];
            }
        }
    }

    /// Every node end's position, by end id (`2 * node` for `a`, `+ 1` for `b`).
    pub fn end_points(&self) -> Vec<DVec2> {
        (0..2 * self.a.len() as u32).map(|e| self.end_point(e)).collect()
    }
}

/// Candidate lists for [`improve`]: each node end's nearest ends of other
/// nodes, nearest first, from the ends' positions by end id (see
/// [`Tour::end_points`]): [`NEIGHBOURS`] slots per end, [`NO_NEIGHBOUR`] in
/// those left over.
pub(crate) fn candidates(ends: &[DVec2]) -> Vec<u32> {
    let ids: Vec<u32> = (0..ends.len() as u32).collect();
    let (lo, hi) = bounds(ends.iter().copied());
    if let Some(grid) = CellGrid::new(ends, &ids, lo, hi, KNN_POINTS_PER_CELL) {
        // Endpoints at the very same place come first: they are nearest.
        return grid.all_nearest_k(ends.len(), NEIGHBOURS, |e, o| o >> 1 == e >> 1);
    }
    // Too crowded for a grid (many endpoints at few places): the same
    // lists, from the k-d tree of the distinct places.
    let groups = Groups::new(ends);
    let near = groups.neighbours(NEIGHBOURS);
    let mut out = vec![NO_NEIGHBOUR; ends.len() * NEIGHBOURS];
    out.par_chunks_mut(NEIGHBOURS).enumerate().for_each(|(e, row)| {
        let g = groups.group_of[e] as usize;
        // Endpoints at the very same place come first.
        let same = groups.members(g).iter().copied();
        let near_groups = near[g * NEIGHBOURS..(g + 1) * NEIGHBOURS].iter().take_while(|&&h| h != NO_NEIGHBOUR);
        let others = near_groups.flat_map(|&h| groups.members(h as usize).iter().copied());
        let cands = same.chain(others).filter(|&o| o >> 1 != e as u32 >> 1);
        for (slot, o) in row.iter_mut().zip(cands) {
            *slot = o;
        }
    });
    out
}

/// Improves `tour` within `budget` units of work (candidates looked at plus
/// positions shifted), looking for moves among `near` (from [`candidates`]
/// of the tour's ends); returns the budget left. First a descent: every
/// improving move the candidate lists suggest, until none is left (a local
/// optimum) or the budget is spent. Then, with what is left, kicks (see
/// [`kick`]) until the budget is spent, so the whole budget is used whenever
/// the descent ends early.
pub(crate) fn improve(tour: &mut Tour, budget: u64, near: &[u32]) -> u64 {
    if tour.len() < 3 || budget == 0 {
        return budget;
    }
    let mut queue: VecDeque<usize> = tour.order.iter().map(|&n| n as usize).collect();
    let mut queued = vec![true; tour.len()];
    let (left, _) = descend(tour, &mut queue, &mut queued, budget, near, None);
    kick(tour, &mut queued, left, near)
}

/// Keeps `m` in `best` if it gains more than [`MIN_GAIN_MM`] and more than
/// `best` does (the first of equal gains stays).
fn keep_better(best: &mut Option<(f64, Move)>, m: Option<(f64, Move)>) {
    if let Some((g, mv)) = m {
        if g > MIN_GAIN_MM && best.is_none_or(|(bg, _)| g > bg) {
            *best = Some((g, mv));
        }
    }
}

/// Applies improving moves around the nodes in `queue` (and around every
/// node a move touches) until none helps or `budget` is spent; returns the
/// budget left and the travel saved. Applied moves are appended to `log`
/// when given, so that they can be undone.
fn descend(
    tour: &mut Tour,
    queue: &mut VecDeque<usize>,
    queued: &mut [bool],
    budget: u64,
    near: &[u32],
    mut log: Option<&mut Vec<Move>>,
) -> (u64, f64) {
    let mut left = budget;
    let mut saved = 0.0;
    while let Some(x) = queue.pop_front() {
        queued[x] = false;
        if left == 0 {
            continue;
        }
        let (best, looked) = tour.best_move(x, near);
        left = left.saturating_sub(looked.max(1));
        if let Some((gain, m)) = best {
            saved += gain;
            let (touched, shifted) = tour.apply(m);
            if let Some(log) = log.as_deref_mut() {
                log.push(m);
            }
            left = left.saturating_sub((shifted / SHIFTS_PER_UNIT) as u64);
            for n in touched.into_iter().chain([x]) {
                if !queued[n] {
                    queued[n] = true;
                    queue.push_back(n);
                }
            }
        }
    }
    (left, saved)
}

/// Longest run of tour positions a kick exchanges on either side.
const MAX_KICK_RUN: u64 = 10;

/// Seed of the kicks' generator: fixed, so ordering is repeatable.
const KICK_SEED: u64 = 0x5eed_0019;

/// Iterated local search from a local optimum, until `budget` is spent:
/// each kick swaps two short adjacent runs of the tour (a segment-local
/// double bridge, the move 2-opt and Or-opt cannot undo one step at a time),
/// then descends from the nodes it touched; the result is kept if the tour
/// got shorter, and undone move by move otherwise. So the tour never gets
/// longer. The kicks come from a fixed-seed generator: the same input and
/// budget give the same tour. Returns the budget left (zero unless the tour
/// is too short to kick).
fn kick(tour: &mut Tour, queued: &mut [bool], budget: u64, near: &[u32]) -> u64 {
    let n = tour.len() as u64;
    if n < 4 {
        return budget;
    }
    let mut left = budget;
    let mut rng = KICK_SEED;
    let mut log: Vec<Move> = Vec::new();
    let mut queue = VecDeque::new();
    while left > 0 {
        // Runs [s, e] and (e, p] with 1 <= s and p < n.
        let r = splitmix(&mut rng);
        let l1 = 1 + (r % MAX_KICK_RUN).min(n - 3);
        let l2 = 1 + ((r >> 16) % MAX_KICK_RUN).min(n - 2 - l1);
        let s = 1 + (r >> 32) % (n - l1 - l2);
        let (e, p) = (s + l1 - 1, s + l1 + l2 - 1);
        let Some((kick_gain, m)) = tour.or_gain(s as isize, e as isize, p as usize, false) else {
            left = left.saturating_sub(1);
            continue;
        };
        log.clear();
        let (touched, shifted) = tour.apply(m);
        log.push(m);
        left = left.saturating_sub(1 + (shifted / SHIFTS_PER_UNIT) as u64);
        for x in touched {
            if !queued[x] {
                queued[x] = true;
                queue.push_back(x);
            }
        }
        let (rest, saved) = descend(tour, &mut queue, queued, left, near, Some(&mut log));
        left = rest;
        if kick_gain + saved <= MIN_GAIN_MM {
            for &m in log.iter().rev() {
                let (_, shifted) = tour.apply(inverse(m));
                left = left.saturating_sub((shifted / SHIFTS_PER_UNIT) as u64);
            }
        }
    }
    left
}

/// The move that undoes `m` right after it was applied.
fn inverse(m: Move) -> Move {
    match m {
        Move::TwoOpt { .. } => m,
        Move::Or { s, e, p, rev } => {
            let len = e - s + 1;
            if p > e {
                // [X][S] back to [S][X]: S now ends at p.
                Move::Or { s: p + 1 - len, e: p, p: s - 1, rev }
            } else {
                // [S][X] back to [X][S]: S now starts after p, X ends at e.
                Move::Or { s: p + 1, e: p + len, p: e, rev }
            }
        }
    }
}

/// splitmix64: the kicks' small deterministic generator.
fn splitmix(state: &mut u64) -> u64 {
    *state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A tour of unit segments on a line, visited in a bad order.
    fn line_tour(order: &[u32]) -> Tour {
        let n = order.len();
        let mut a = vec![DVec2::ZERO];
        let mut b = vec![DVec2::ZERO];
        for i in 1..n {
            a.push(DVec2::new(2.0 * i as f64, 0.0));
            b.push(DVec2::new(2.0 * i as f64 + 1.0, 0.0));
        }
        Tour::new(order.to_vec(), vec![false; n], a, b)
    }

    fn check_consistent(t: &Tour) {
        let mut seen = vec![false; t.len()];
        for (p, &n) in t.order.iter().enumerate() {
            assert_eq!(t.pos[n as usize] as usize, p);
            assert!(!seen[n as usize]);
            seen[n as usize] = true;
        }
        assert_eq!(t.order[0], 0);
    }

    #[test]
    fn every_move_matches_its_predicted_gain() {
        let t0 = line_tour(&[0, 5, 2, 7, 1, 3, 6, 4]);
        let mut moves = Vec::new();
        for i in 0..8 {
            for j in 0..8 {
                moves.push(t0.two_opt_gain(i, j));
                for l in 0..3 {
                    for rev in [false, true] {
                        moves.push(t0.or_gain(i as isize, i as isize + l, j, rev));
                    }
                }
            }
        }
        let mut tried = 0;
        for (gain, m) in moves.into_iter().flatten() {
            let mut t = line_tour(&[0, 5, 2, 7, 1, 3, 6, 4]);
            let before = t.travel();
            t.apply(m);
            check_consistent(&t);
            assert!((before - t.travel() - gain).abs() < 1e-9, "{m:?}");
            tried += 1;
        }
        assert!(tried > 100);
    }

    /// A tour of `n` strokes scattered by a fixed generator, every third
    /// one flipped, visited in a scrambled order.
    fn scattered_tour(n: usize) -> Tour {
        let mut state = 17u64;
        let mut next = || (splitmix(&mut state) >> 11) as f64 / (1u64 << 53) as f64 * 100.0;
        let mut a = vec![DVec2::new(50.0, 50.0)];
        let mut b = vec![DVec2::new(50.0, 50.0)];
        for _ in 1..n {
            a.push(DVec2::new(next(), next()));
            b.push(DVec2::new(next(), next()));
        }
        let mut order: Vec<u32> = (0..n as u32).collect();
        order[1..].sort_by_key(|&k| (k * 7) % n as u32);
        let flip = (0..n).map(|k| k % 3 == 1).collect();
        Tour::new(order, flip, a, b)
    }

    #[test]
    fn or_gains_are_or_gain_of_each_run_length() {
        let t = scattered_tour(13);
        let mut compared = 0;
        for py in -1..=14isize {
            for p in 0..13 {
                for ends_at_y in [false, true] {
                    for rev in [false, true] {
                        let mut got = Vec::new();
                        t.or_gains(py, ends_at_y, (p, t.edge(p)), rev, &mut |m| got.extend(m));
                        let want: Vec<(f64, Move)> = (1..=MAX_OR_RUN as isize)
                            .filter_map(|l| {
                                let (s, e) = if ends_at_y { (py - l + 1, py) } else { (py, py + l - 1) };
                                t.or_gain(s, e, p, rev)
                            })
                            .collect();
                        // The very same numbers, not merely close ones: the
                        // improver must choose the same moves either way.
                        let bits = |v: &[(f64, Move)]| v.iter().map(|&(g, m)| (g.to_bits(), m)).collect::<Vec<_>>();
                        assert_eq!(bits(&got), bits(&want), "py {py} p {p} ends_at_y {ends_at_y} rev {rev}");
                        compared += want.len();
                    }
                }
            }
        }
        assert!(compared > 500, "{compared}");
    }

    /// [`Tour::best_move`] as it was written first: every gain measured
    /// whole by `two_opt_gain` and `or_gain`.
    fn best_move_measured_whole(t: &Tour, x: usize, near: &[u32]) -> (Option<(f64, Move)>, u64) {
        let mut best: Option<(f64, Move)> = None;
        let mut looked = 0;
        let mut consider = |m: Option<(f64, Move)>| keep_better(&mut best, m);
        let px = t.pos[x] as usize;
        for outgoing in [true, false] {
            let end = 2 * x as u32 + u32::from(outgoing != t.flip[x]);
            let here = t.end_point(end);
            let edge_p = if outgoing { px } else { t.pred(px) };
            let current = t.edge(edge_p);
            for &q in near[end as usize * NEIGHBOURS..(end as usize + 1) * NEIGHBOURS].iter().take_while(|&&q| q != NO_NEIGHBOUR) {
                let y = (q >> 1) as usize;
                if y == x {
                    continue;
                }
                looked += 1;
                if here.distance(t.end_point(q)) >= current {
                    break;
                }
                let py = t.pos[y] as isize;
                let q_exit = t.is_exit(q);
                if outgoing && q_exit {
                    consider(t.two_opt_gain(px, py as usize));
                }
                if !outgoing && !q_exit {
                    consider(t.two_opt_gain(edge_p, t.pred(py as usize)));
                }
                for l in 1..=MAX_OR_RUN as isize {
                    let (s, e) = if q_exit { (py - l + 1, py) } else { (py, py + l - 1) };
                    consider(t.or_gain(s, e, edge_p, q_exit == outgoing));
                }
            }
        }
        (best, looked)
    }

    #[test]
    fn best_move_chooses_as_whole_measurement_would() {
        // Tours of several lengths, each also after a few moves (so that
        // positions wrap and nodes are flipped in every way).
        let mut compared = 0;
        for n in [3, 4, 9, 40] {
            let mut t = scattered_tour(n);
            let near = candidates(&t.end_points());
            for round in 0..4 {
                for x in 0..n {
                    let (got, want) = (t.best_move(x, &near), best_move_measured_whole(&t, x, &near));
                    let bits = |(m, looked): (Option<(f64, Move)>, u64)| (m.map(|(g, mv)| (g.to_bits(), mv)), looked);
                    assert_eq!(bits(got), bits(want), "n {n} round {round} x {x}");
                    compared += usize::from(want.0.is_some());
                }
                if let (Some((_, m)), _) = t.best_move(round % n, &near) {
                    t.apply(m);
                }
            }
        }
        assert!(compared > 40, "{compared}");
    }

    #[test]
    fn every_move_is_undone_by_its_inverse() {
        let start = [0, 5, 2, 7, 1, 3, 6, 4];
        let t0 = line_tour(&start);
        let mut tried = 0;
        for i in 0..8 {
            for j in 0..8 {
                let mut moves = vec![t0.two_opt_gain(i, j)];
                for l in 0..4 {
                    for rev in [false, true] {
                        moves.push(t0.or_gain(i as isize, i as isize + l, j, rev));
                    }
                }
                for (_, m) in moves.into_iter().flatten() {
                    let mut t = line_tour(&start);
                    t.apply(m);
                    t.apply(inverse(m));
                    check_consistent(&t);
                    assert_eq!(t.order, start, "{m:?}");
                    assert!(t.flip.iter().all(|&f| !f), "{m:?}");
                    tried += 1;
                }
            }
        }
        assert!(tried > 100);
    }

    #[test]
    fn improves_a_scrambled_line_to_the_optimum() {
        let mut t = line_tour(&[0, 5, 2, 7, 1, 3, 6, 4]);
        let before = t.travel();
        let near = candidates(&t.end_points());
        improve(&mut t, 10_000, &near);
        check_consistent(&t);
        // Optimal: 2 mm out to the first segment, 6 gaps of 1 mm, 15 mm home.
        assert!(t.travel() < before);
        assert!((t.travel() - (2.0 + 6.0 + 15.0)).abs() < 1e-9, "{}", t.travel());
    }

    #[test]
    fn zero_budget_does_nothing() {
        let mut t = line_tour(&[0, 2, 1]);
        let before = t.travel();
        assert_eq!(improve(&mut t, 0, &[]), 0);
        assert_eq!(t.travel(), before);
    }
}
