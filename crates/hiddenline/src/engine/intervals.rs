//! Sorted disjoint parameter intervals on `[0, 1]`: the hidden parts of a line.

use crate::model::Intervals;

/// A union of closed intervals, kept sorted and disjoint; intervals closer
/// than `gap` merge, so that the pieces hidden by two faces sharing an edge
/// join without a sliver between them.
#[derive(Clone, Debug, Default)]
pub(crate) struct IntervalSet {
    items: Vec<(f64, f64)>,
}

impl IntervalSet {
    /// Empties the set.
    pub fn clear(&mut self) {
        self.items.clear();
    }

    /// Adds `[a, b]`, merging with anything within `gap` of it.
    pub fn insert(&mut self, a: f64, b: f64, gap: f64) {
        if b < a {
            return;
        }
        // First interval whose end reaches a - gap.
        let i = self.items.partition_point(|&(_, e)| e < a - gap);
        let mut j = i;
        let (mut lo, mut hi) = (a, b);
        while j < self.items.len() && self.items[j].0 <= b + gap {
            lo = lo.min(self.items[j].0);
            hi = hi.max(self.items[j].1);
            j += 1;
        }
        self.items.splice(i..j, std::iter::once((lo, hi)));
    }

    /// Whether `[0, 1]` is covered up to `gap` at the ends.
    pub fn covers_all(&self, gap: f64) -> bool {
        matches!(self.items.as_slice(), [(a, b)] if *a <= gap && *b >= 1.0 - gap)
    }

    /// The complement in `[0, 1]`, without pieces of length `min_len` or less.
    pub fn complement(&self, min_len: f64) -> Intervals {
        let mut out = Intervals::new();
        let mut at = 0.0;
        for &(a, b) in &self.items {
            if a - at > min_len {
                out.push((at, a.min(1.0)));
            }
            at = at.max(b);
        }
        if 1.0 - at > min_len {
            out.push((at, 1.0));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inserts_merge_and_complement() {
        let mut s = IntervalSet::default();
        s.insert(0.5, 0.6, 1e-9);
        s.insert(0.1, 0.2, 1e-9);
        s.insert(0.2 + 1e-12, 0.3, 1e-9); // touching: merges
        assert_eq!(s.items.len(), 2);
        assert_eq!(s.complement(1e-9)[..], [(0.0, 0.1), (0.3, 0.5), (0.6, 1.0)]);
        s.insert(0.25, 0.55, 1e-9); // bridges both
        assert_eq!(s.items, vec![(0.1, 0.6)]);
        assert!(!s.covers_all(1e-9));
        s.insert(0.0, 0.1, 1e-9);
        s.insert(0.6, 1.0, 1e-9);
        assert!(s.covers_all(1e-9));
        assert!(s.complement(1e-9).is_empty());
    }

    #[test]
    fn empty_and_reversed_and_slivers() {
        let mut s = IntervalSet::default();
        assert_eq!(s.complement(0.0)[..], [(0.0, 1.0)]);
        s.insert(0.6, 0.5, 0.0);
        assert_eq!(s.complement(0.0)[..], [(0.0, 1.0)]);
        s.insert(1e-12, 1.0, 0.0);
        assert!(s.complement(1e-9).is_empty(), "a sliver at the start is dropped");
        s.clear();
        s.insert(0.3, 0.3, 0.0); // a point hides nothing of length
        assert_eq!(s.complement(1e-9)[..], [(0.0, 0.3), (0.3, 1.0)]);
    }
}
