//! Euler-path decomposition: the fewest pen-down trails that draw every edge
//! of a graph exactly once.
//!
//! A connected component with `2k` odd-degree vertices needs `k` trails (each
//! odd vertex must end one), and a component with none is one closed trail.
//! We reach that bound the classic way: pair the odd vertices of each
//! component with `k` virtual edges, which makes every degree even; walk an
//! Euler circuit with Hierholzer's algorithm; cut the circuit at the virtual
//! edges. Pairs are matched greedily, nearest first, so virtual edges (the
//! pen-up moves between the trails of a component, in circuit order) are
//! short. While walking, the next edge out of a vertex is
//! the one that continues most straight on, so grid lines and long edges come
//! out as long straight runs that simplification then collapses where they join.

use super::cells::{morton, NO_NEIGHBOUR};
use super::graph::Graph;
use super::spatial::Groups;
use glam::DVec2;
use rayon::prelude::*;

pub(crate) const NONE: u32 = u32::MAX;

/// Vertices of higher degree take their edges in index order instead of the
/// straightest: choosing is quadratic in the degree.
const STRAIGHT_SCAN_MAX_DEGREE: usize = 16;

/// Nearest odd vertices each odd vertex may be paired with greedily.
const PAIR_NEIGHBOURS: usize = 6;

/// Nearest odd vertices each one may exchange partners with.
const EXCHANGE_NEIGHBOURS: usize = 10;

/// Looks at a vertex's exchanges per odd vertex, at most: a bound on the
/// work, which ends far sooner on drawings seen so far.
const EXCHANGE_WORK_PER_VERTEX: usize = 50;

/// Greedy rounds go on while one pairs at least one in this many of the
/// odd vertices it looks at. Past that the vertices left are those whose
/// nearest belong to other components: on a 2000 x 2000 surface, 7,000 of
/// them took 20 more rounds of 4 ms to pair 60.
const ROUND_PAIRS_AT_LEAST: usize = 100;

/// Vertex sequences in one flat list (one allocation for a million trails,
/// not a million): trail `t` is `verts[start[t]..start[t + 1]]`, and
/// `via[i]` the edge it took to reach `verts[i]` ([`NONE`] at a trail's
/// first vertex and in a dot).
#[derive(Debug, Default, PartialEq)]
pub(crate) struct Trails {
    verts: Vec<u32>,
    via: Vec<u32>,
    start: Vec<u32>,
}

impl Trails {
    /// Number of trails.
    pub fn len(&self) -> usize {
        self.start.len().saturating_sub(1)
    }

    /// The vertices of trail `t`.
    pub fn get(&self, t: usize) -> &[u32] {
        &self.verts[self.start[t] as usize..self.start[t + 1] as usize]
    }

    /// The edges trail `t` takes to each of its vertices ([`NONE`] for the
    /// first).
    pub fn via(&self, t: usize) -> &[u32] {
        &self.via[self.start[t] as usize..self.start[t + 1] as usize]
    }

    fn push(&mut self, v: u32, e: u32) {
        self.verts.push(v);
        self.via.push(e);
    }

    /// Ends the trail begun at `from` (an index into `verts`): kept if it is
    /// at least two vertices long, else dropped.
    fn close(&mut self, from: usize) {
        if self.verts.len() - from >= 2 {
            if self.start.is_empty() {
                self.start.push(from as u32);
            }
            self.start.push(self.verts.len() as u32);
        } else {
            self.verts.truncate(from);
            self.via.truncate(from);
        }
    }
}

/// The trails (vertex sequences, each at least two long) that draw every edge
/// of `g` once: the minimum number per connected component. A closed trail
/// starts and ends at the same vertex; a dot is `[v, v]`.
pub(crate) fn trails(g: &Graph<'_>) -> Trails {
    let n = g.vertices.len();
    let mut degree = vec![0u32; n];
    for e in &g.edges {
        degree[e[0] as usize] += 1;
        degree[e[1] as usize] += 1;
    }
    // A segment alone in its component (both ends of degree one) is a trail
    // by itself, from its lower vertex, just as the walk below would make it.
    // Leaving such segments out of the pairing and the walk saves most of the
    // work on scattered drawings. `lone[v]` is the other end of `v`'s.
    let mut lone = vec![NONE; n];
    let mut lone_edge = vec![NONE; n];
    for (id, &[a, b]) in g.edges.iter().enumerate() {
        if degree[a as usize] == 1 && degree[b as usize] == 1 {
            lone[a as usize] = b;
            lone[b as usize] = a;
            lone_edge[a.min(b) as usize] = id as u32;
        }
    }
    // Real edges are `g.edges`, virtual ones follow them (ids from `real`):
    // no copy of the edge list, which is the graph's largest array.
    let virtuals = pairing(g, &degree, &lone);
    let real = g.edges.len();
    let edges = Edges { real: &g.edges, virtuals: &virtuals };

    // Adjacency in compressed rows: the edge ids at each vertex.
    let mut start = vec![0u32; n + 1];
    for e in edges.iter().filter(|e| lone[e[0] as usize] == NONE) {
        start[e[0] as usize + 1] += 1;
        start[e[1] as usize + 1] += 1;
    }
    for i in 0..n {
        start[i + 1] += start[i];
    }
    let mut fill = start.clone();
    let mut adj = vec![0u32; start[n] as usize];
    for (id, e) in edges.iter().enumerate() {
        if lone[e[0] as usize] != NONE {
            continue;
        }
        for v in e {
            adj[fill[*v as usize] as usize] = id as u32;
            fill[*v as usize] += 1;
        }
    }

    let next_to_ends = g.next_to_ends();
    let walker = Walker { g, edges, real, start: &start, adj: &adj, next_to_ends: &next_to_ends };
    let mut used = vec![false; edges.len()];
    let mut ptr: Vec<u32> = start[..n].to_vec();
    let mut out = Trails::default();
    let mut stack: Vec<(u32, u32)> = Vec::new();
    let mut circuit: Vec<(u32, u32)> = Vec::new();
    for v0 in 0..n as u32 {
        let w = lone[v0 as usize];
        if w != NONE {
            let e = lone_edge[v0 as usize];
            if e != NONE {
                let from = out.verts.len();
                out.push(v0, NONE);
                out.push(w, e);
                out.close(from);
            }
            continue;
        }
        if ptr[v0 as usize] == start[v0 as usize + 1] {
            continue;
        }
        stack.clear();
        circuit.clear();
        stack.push((v0, NONE));
        while let Some(&(v, e_in)) = stack.last() {
            match walker.next_edge(v, e_in, &mut ptr, &mut used) {
                Some(e) => {
                    used[e as usize] = true;
                    stack.push((walker.other(e, v), e));
                }
                None => {
                    stack.pop();
                    circuit.push((v, e_in));
                }
            }
        }
        circuit.reverse();
        if circuit.len() >= 2 {
            split(&circuit, real, &mut out);
        }
    }
    for &v in &g.dots {
        let from = out.verts.len();
        out.push(v, NONE);
        out.push(v, NONE);
        out.close(from);
    }
    out
}

/// Virtual edges pairing the odd-degree vertices within each component,
/// but for lone segments (`lone[v] != NONE`).
///
/// Each virtual edge becomes a pen-up move between two trails (the circuit
/// alternates trails and virtual edges), so short pairs matter: odd vertices
/// are paired greedily, shortest pair first, among each one's
/// [`PAIR_NEIGHBOURS`] nearest odd vertices of its component (on a grid's
/// border that pairs each end with the one beside it), then the same among
/// those left over, round after round while a round pairs a good share of
/// them; the rest, whose nearest are of other components, are paired along
/// a Z-order curve.
fn pairing(g: &Graph<'_>, degree: &[u32], lone: &[u32]) -> Vec<[u32; 2]> {
    let n = g.vertices.len();
    let mut parent: Vec<u32> = (0..n as u32).collect();
    fn find(parent: &mut [u32], mut v: u32) -> u32 {
        while parent[v as usize] != v {
            let up = parent[parent[v as usize] as usize];
            parent[v as usize] = up;
            v = up;
        }
        v
    }
    for e in g.edges.iter().filter(|e| lone[e[0] as usize] == NONE) {
        let (a, b) = (find(&mut parent, e[0]), find(&mut parent, e[1]));
        if a != b {
            parent[a.max(b) as usize] = a.min(b);
        }
    }
    let odd: Vec<u32> = (0..n as u32).filter(|&v| degree[v as usize] % 2 == 1).collect();
    // The Z-order box is that of all odd vertices, lone ones too, so that
    // pairs do not depend on which components are lone.
    let (lo, hi) = odd.iter().fold((DVec2::INFINITY, DVec2::NEG_INFINITY), |(lo, hi), &v| {
        let p = g.vertices[v as usize];
        (lo.min(p), hi.max(p))
    });
    let span = (hi - lo).max(DVec2::splat(f64::MIN_POSITIVE));
    let odd: Vec<u32> = odd.into_iter().filter(|&v| lone[v as usize] == NONE).collect();
    let component: Vec<u32> = odd.iter().map(|&v| find(&mut parent, v)).collect();
    let mut pairs = Vec::with_capacity(odd.len() / 2);
    let mut paired = vec![false; odd.len()];

    // Greedy matching over near candidates, shortest first (ties by index,
    // so the result does not depend on the sort); then again among those
    // left, whose nearest were taken, while that pairs any.
    let positions: Vec<DVec2> = odd.iter().map(|&v| g.vertices[v as usize]).collect();
    let mut left: Vec<u32> = (0..odd.len() as u32).collect();
    while left.len() >= 2 {
        let before = pairs.len();
        let at: Vec<DVec2> = left.iter().map(|&i| positions[i as usize]).collect();
        let groups = Groups::new(&at);
        let near = groups.neighbours(PAIR_NEIGHBOURS);
        let groups = &groups;
        let mut candidates: Vec<(f64, u32, u32)> = (0..left.len())
            .into_par_iter()
            .flat_map_iter(|a| {
                let row = &near[groups.group_of[a] as usize * PAIR_NEIGHBOURS..][..PAIR_NEIGHBOURS];
                row.iter()
                    .take_while(|&&h| h != NO_NEIGHBOUR)
                    .flat_map(move |&h| groups.members(h as usize).iter().map(move |&b| (a, b as usize)))
            })
            .map(|(a, b)| (left[a], left[b]))
            .filter(|&(i, j)| i < j && component[i as usize] == component[j as usize])
            .map(|(i, j)| (positions[i as usize].distance_squared(positions[j as usize]), i, j))
            .collect();
        candidates.par_sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then((a.1, a.2).cmp(&(b.1, b.2))));
        for (_, i, j) in candidates {
            if !paired[i as usize] && !paired[j as usize] {
                paired[i as usize] = true;
                paired[j as usize] = true;
                pairs.push([odd[i as usize], odd[j as usize]]);
            }
        }
        let looked_at = left.len();
        left.retain(|&i| !paired[i as usize]);
        if (pairs.len() - before) * ROUND_PAIRS_AT_LEAST < looked_at {
            break;
        }
    }

    let mut keyed: Vec<(u32, u64, u32)> = left
        .iter()
        .map(|&i| i as usize)
        .filter(|&i| !paired[i])
        .map(|i| {
            let q = (positions[i] - lo) / span * 65535.0;
            (component[i], morton(q.x as u32, q.y as u32), odd[i])
        })
        .collect();
    keyed.sort_unstable();
    // Each component has an even number of odd vertices (handshake lemma)
    // and the matching took them two at a time, so consecutive pairs never
    // straddle two components.
    pairs.extend(keyed.chunks_exact(2).map(|c| [c[0].2, c[1].2]));
    exchange_partners(&positions, &component, &odd, &mut pairs);
    pairs
}

/// Shortens the pairing of `odd` (at `positions`, in `component`s) by
/// exchanging partners: pairs a-b and c-d become a-c and b-d wherever that
/// is shorter in all, c among a's [`EXCHANGE_NEIGHBOURS`] nearest, until no
/// exchange helps or [`EXCHANGE_WORK_PER_VERTEX`] looks per vertex are
/// spent. Shortest-first strands the far ends of a chain of odd vertices (a
/// grid's border, seen in perspective, pairs 1-2, then 0 with 3): on a
/// height field of 150 x 150 that took the pairing from 510 mm to 299 and
/// the ordered drawing's pen-up travel from 316 mm to 295.
fn exchange_partners(positions: &[DVec2], component: &[u32], odd: &[u32], pairs: &mut [[u32; 2]]) {
    if odd.len() < 4 {
        return;
    }
    // Partners by index into `odd`.
    let mut slot = rustc_hash::FxHashMap::with_capacity_and_hasher(odd.len(), Default::default());
    for (i, &v) in odd.iter().enumerate() {
        slot.insert(v, i as u32);
    }
    let mut partner = vec![NONE; odd.len()];
    for &[a, b] in pairs.iter() {
        let (i, j) = (slot[&a], slot[&b]);
        partner[i as usize] = j;
        partner[j as usize] = i;
    }
    let groups = Groups::new(positions);
    let near = groups.neighbours(EXCHANGE_NEIGHBOURS);
    let d = |i: u32, j: u32| positions[i as usize].distance(positions[j as usize]);
    let mut queue: std::collections::VecDeque<u32> = (0..odd.len() as u32).collect();
    let mut queued = vec![true; odd.len()];
    let mut work = EXCHANGE_WORK_PER_VERTEX * odd.len();
    while let Some(a) = queue.pop_front() {
        queued[a as usize] = false;
        if work == 0 {
            break;
        }
        work -= 1;
        let b = partner[a as usize];
        if b == NONE {
            continue;
        }
        let row = &near[groups.group_of[a as usize] as usize * EXCHANGE_NEIGHBOURS..][..EXCHANGE_NEIGHBOURS];
        let mut best: Option<(f64, u32)> = None;
        for &h in row.iter().take_while(|&&h| h != NO_NEIGHBOUR) {
            for &c in groups.members(h as usize) {
                if c == a || c == b || component[c as usize] != component[a as usize] {
                    continue;
                }
                let e = partner[c as usize];
                if e == NONE {
                    continue;
                }
                let gain = d(a, b) + d(c, e) - d(a, c) - d(b, e);
                if gain > crate::MIN_GAIN_MM && best.is_none_or(|(g, _)| gain > g) {
                    best = Some((gain, c));
                }
            }
        }
        if let Some((_, c)) = best {
            let e = partner[c as usize];
            partner[a as usize] = c;
            partner[c as usize] = a;
            partner[b as usize] = e;
            partner[e as usize] = b;
            for v in [a, b, c, e] {
                if !queued[v as usize] {
                    queued[v as usize] = true;
                    queue.push_back(v);
                }
            }
        }
    }
    let mut k = 0;
    for (i, &j) in partner.iter().enumerate() {
        if (i as u32) < j && j != NONE {
            pairs[k] = [odd[i], odd[j as usize]];
            k += 1;
        }
    }
}

/// The real edges followed by the virtual ones, as one list by id.
#[derive(Clone, Copy)]
struct Edges<'a> {
    real: &'a [[u32; 2]],
    virtuals: &'a [[u32; 2]],
}

impl Edges<'_> {
    fn len(&self) -> usize {
        self.real.len() + self.virtuals.len()
    }

    fn get(&self, id: usize) -> [u32; 2] {
        match self.real.get(id) {
            Some(&e) => e,
            None => self.virtuals[id - self.real.len()],
        }
    }

    fn iter(&self) -> impl Iterator<Item = &[u32; 2]> {
        self.real.iter().chain(self.virtuals)
    }
}

struct Walker<'a> {
    g: &'a Graph<'a>,
    edges: Edges<'a>,
    real: usize,
    start: &'a [u32],
    adj: &'a [u32],
    /// [`Graph::next_to_ends`].
    next_to_ends: &'a [[DVec2; 2]],
}

impl Walker<'_> {
    fn other(&self, e: u32, v: u32) -> u32 {
        let [a, b] = self.edges.get(e as usize);
        if a == v {
            b
        } else {
            a
        }
    }

    /// The point next to vertex `v` along real edge `e`: the direction the
    /// edge leaves `v` by (`leaving`) or arrives at it from. The two differ
    /// only on a loop, which leaves by its first end and arrives at its
    /// second.
    fn beside(&self, e: usize, v: u32, leaving: bool) -> DVec2 {
        let [a, b] = self.edges.get(e);
        self.next_to_ends[e][usize::from(!((leaving && a == v) || (!leaving && b != v)))]
    }

    /// The unused edge to leave `v` by, having arrived along `e_in`.
    fn next_edge(&self, v: u32, e_in: u32, ptr: &mut [u32], used: &mut [bool]) -> Option<u32> {
        let end = self.start[v as usize + 1];
        let mut i = ptr[v as usize];
        while i < end && used[self.adj[i as usize] as usize] {
            i += 1;
        }
        ptr[v as usize] = i;
        if i == end {
            return None;
        }
        let first = self.adj[i as usize];
        if (end - self.start[v as usize]) as usize > STRAIGHT_SCAN_MAX_DEGREE {
            return Some(first);
        }
        let here = self.g.vertices[v as usize];
        let dir_in = if e_in == NONE || e_in as usize >= self.real {
            DVec2::ZERO
        } else {
            (here - self.beside(e_in as usize, v, false)).normalize_or_zero()
        };
        let mut best = first;
        let mut best_score = f64::NEG_INFINITY;
        for &e in &self.adj[i as usize..end as usize] {
            if used[e as usize] {
                continue;
            }
            // Virtual edges last: they are pen lifts, and taking them early
            // would not save any.
            let score = if e as usize >= self.real {
                -3.0
            } else {
                let w = self.beside(e as usize, v, true);
                dir_in.dot((w - here).normalize_or_zero())
            };
            if score > best_score {
                best_score = score;
                best = e;
            }
        }
        Some(best)
    }
}

/// Cuts an Euler circuit `(vertex, edge arrived by)` at its virtual edges
/// (ids `>= real`) and appends the resulting trails to `out`.
fn split(circuit: &[(u32, u32)], real: usize, out: &mut Trails) {
    let l = circuit.len() - 1; // edges; circuit[0] and circuit[l] are the same vertex
    let is_virtual = |i: usize| circuit[i].1 as usize >= real;
    let Some(f) = (1..=l).find(|&i| is_virtual(i)) else {
        let from = out.verts.len();
        for &(v, e) in circuit {
            out.push(v, e);
        }
        out.close(from);
        return;
    };
    let mut from = out.verts.len();
    out.push(circuit[f].0, NONE);
    for k in 1..=l {
        let i = (f - 1 + k) % l + 1; // edge index cycling through 1..=l after f
        if is_virtual(i) {
            out.close(from);
            from = out.verts.len();
            out.push(circuit[i].0, NONE);
        } else {
            out.push(circuit[i].0, circuit[i].1);
        }
    }
    out.close(from);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn graph(points: &[(f64, f64)], edges: &[[u32; 2]]) -> Graph<'static> {
        Graph {
            vertices: points.iter().map(|&(x, y)| DVec2::new(x, y)).collect(),
            edges: edges.to_vec(),
            paths: Vec::new(),
            dots: Vec::new(),
        }
    }

    /// Every edge appears in exactly one trail, as consecutive vertices.
    fn check_cover(g: &Graph, trails: &[Vec<u32>]) {
        assert!(trails.iter().all(|t| t.len() >= 2));
        let mut count = std::collections::HashMap::new();
        for t in trails {
            for w in t.windows(2) {
                *count.entry((w[0].min(w[1]), w[0].max(w[1]))).or_insert(0) += 1;
            }
        }
        assert_eq!(count.values().sum::<i32>() as usize, g.edges.len());
        for e in &g.edges {
            assert_eq!(count.get(&(e[0].min(e[1]), e[0].max(e[1]))), Some(&1), "edge {e:?}");
        }
    }

    fn as_vecs(t: &Trails) -> Vec<Vec<u32>> {
        (0..t.len()).map(|i| t.get(i).to_vec()).collect()
    }

    /// Greedy pairing takes the shortest pair first; where that strands the
    /// two outer ends, exchanging partners finds the shorter matching.
    /// Four spokes from a hub: the leaves are the odd vertices, on a line
    /// at 0, 1, 1.9 and 2.9. Shortest first pairs 1-1.9 and then 0-2.9
    /// (3.8 in all); 0-1 with 1.9-2.9 is 2.0.
    #[test]
    fn pairs_exchange_partners_where_that_is_shorter() {
        let g = graph(&[(1.45, 5.0), (0.0, 0.0), (1.0, 0.0), (1.9, 0.0), (2.9, 0.0)], &[[0, 1], [0, 2], [0, 3], [0, 4]]);
        let degree = [4, 1, 1, 1, 1];
        let pairs = pairing(&g, &degree, &[NONE; 5]);
        let length: f64 = pairs.iter().map(|&[a, b]| g.vertices[a as usize].distance(g.vertices[b as usize])).sum();
        assert!((length - 2.0).abs() < 1e-9, "{pairs:?}: {length}");
        let t = as_vecs(&trails(&g));
        assert_eq!(t.len(), 2);
        check_cover(&g, &t);
    }

    #[test]
    fn path_is_one_trail() {
        let g = graph(&[(0.0, 0.0), (1.0, 0.0), (2.0, 0.0)], &[[1, 2], [0, 1]]);
        let t = as_vecs(&trails(&g));
        assert_eq!(t.len(), 1);
        check_cover(&g, &t);
    }

    #[test]
    fn square_is_one_closed_trail() {
        let g = graph(&[(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)], &[[0, 1], [2, 3], [1, 2], [3, 0]]);
        let t = as_vecs(&trails(&g));
        assert_eq!(t.len(), 1);
        assert_eq!(t[0].first(), t[0].last());
        check_cover(&g, &t);
    }

    #[test]
    fn star_with_five_rays_needs_three() {
        let mut pts = vec![(0.0, 0.0)];
        let mut edges = Vec::new();
        for i in 0..5 {
            let a = f64::from(i) * 1.2566;
            pts.push((a.cos(), a.sin()));
            edges.push([0, i + 1]);
        }
        let g = graph(&pts, &edges);
        let t = as_vecs(&trails(&g));
        assert_eq!(t.len(), 3);
        check_cover(&g, &t);
    }

    #[test]
    fn straight_continuation_preferred() {
        // A plus sign: the two straight lines should come out as two straight trails.
        let g = graph(&[(0.0, 0.0), (-1.0, 0.0), (1.0, 0.0), (0.0, -1.0), (0.0, 1.0)], &[[1, 0], [0, 3], [0, 2], [0, 4]]);
        let t = as_vecs(&trails(&g));
        assert_eq!(t.len(), 2);
        check_cover(&g, &t);
        for tr in &t {
            let (a, b) = (g.vertices[tr[0] as usize], g.vertices[tr[2] as usize]);
            assert!((a + b).length() < 1e-12, "trail {tr:?} turns");
        }
    }

    #[test]
    fn lone_segments_beside_other_components() {
        // Two lone segments (one listed high to low), a path of two and a
        // triangle: one trail each.
        let g = graph(
            &[(0.0, 0.0), (1.0, 0.0), (5.0, 5.0), (6.0, 5.0), (7.0, 5.0), (9.0, 0.0), (9.0, 1.0), (10.0, 0.0), (3.0, 3.0), (3.0, 4.0)],
            &[[1, 0], [2, 3], [3, 4], [5, 6], [6, 7], [7, 5], [8, 9]],
        );
        let t = as_vecs(&trails(&g));
        assert_eq!(t.len(), 4);
        check_cover(&g, &t);
        assert_eq!(t[0], vec![0, 1]);
        assert!(t.contains(&vec![8, 9]));
    }

    /// The graph of an `n` x `n` grid of unit cells (every edge once).
    fn grid_graph(n: u32) -> Graph<'static> {
        let id = |i: u32, j: u32| j * (n + 1) + i;
        let mut edges = Vec::new();
        for j in 0..=n {
            for i in 0..=n {
                if i < n {
                    edges.push([id(i, j), id(i + 1, j)]);
                }
                if j < n {
                    edges.push([id(i, j), id(i, j + 1)]);
                }
            }
        }
        let pts: Vec<(f64, f64)> = (0..=n).flat_map(|j| (0..=n).map(move |i| (f64::from(i), f64::from(j)))).collect();
        graph(&pts, &edges)
    }

    #[test]
    fn odd_vertices_pair_with_a_neighbour_along_the_border() {
        // The odd vertices of a grid are its border vertices but the
        // corners, one unit apart along each side, an even number per side
        // here: every virtual edge (a later pen-up move) should join two of
        // them beside each other, not jump across the grid. (With an odd
        // number per side greedy matching leaves a few far pairs: it is not
        // a minimum-weight matching.)
        let g = grid_graph(31);
        let mut degree = vec![0u32; g.vertices.len()];
        for e in &g.edges {
            degree[e[0] as usize] += 1;
            degree[e[1] as usize] += 1;
        }
        let lone = vec![NONE; g.vertices.len()];
        let pairs = pairing(&g, &degree, &lone);
        assert_eq!(pairs.len(), 4 * 30 / 2);
        let lengths: Vec<f64> = pairs.iter().map(|&[a, b]| g.vertices[a as usize].distance(g.vertices[b as usize])).collect();
        assert!(lengths.iter().all(|&d| d == 1.0), "{lengths:?}");
    }

    #[test]
    fn empty_graph_and_dots() {
        assert_eq!(trails(&Graph::default()).len(), 0);
        let g = Graph { vertices: vec![DVec2::ONE], edges: vec![], paths: Vec::new(), dots: vec![0] };
        assert_eq!(as_vecs(&trails(&g)), vec![vec![0, 0]]);
    }
}
