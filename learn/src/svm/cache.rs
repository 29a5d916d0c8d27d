//! A bounded, least-recently-used cache of kernel matrix rows, as libsvm keeps one.
//!
//! Rows may be partly filled: while shrinking, the solver only needs the first
//! `active_size` entries of a row, and fills more later if it needs them. When the solver
//! swaps two indices, every cached row swaps those two entries (or is dropped if it is too
//! short to hold both), so cached values stay valid under the solver's reordering.

const NONE: usize = usize::MAX;

pub struct RowCache {
    rows: Vec<Vec<f32>>,
    prev: Vec<usize>,
    next: Vec<usize>,
    /// Most recently used row, and least.
    head: usize,
    tail: usize,
    budget: usize,
    used: usize,
}

impl RowCache {
    /// A cache for `n` rows holding at most `budget_bytes` of values (at least two full rows,
    /// which the solver needs at once).
    pub fn new(n: usize, budget_bytes: usize) -> Self {
        let budget = (budget_bytes / std::mem::size_of::<f32>()).max(2 * n);
        Self {
            rows: vec![Vec::new(); n],
            prev: vec![NONE; n],
            next: vec![NONE; n],
            head: NONE,
            tail: NONE,
            budget,
            used: 0,
        }
    }

    fn unlink(&mut self, i: usize) {
        let (p, n) = (self.prev[i], self.next[i]);
        if p != NONE {
            self.next[p] = n;
        } else if self.head == i {
            self.head = n;
        }
        if n != NONE {
            self.prev[n] = p;
        } else if self.tail == i {
            self.tail = p;
        }
        self.prev[i] = NONE;
        self.next[i] = NONE;
    }

    fn push_front(&mut self, i: usize) {
        self.prev[i] = NONE;
        self.next[i] = self.head;
        if self.head != NONE {
            self.prev[self.head] = i;
        }
        self.head = i;
        if self.tail == NONE {
            self.tail = i;
        }
    }

    fn is_linked(&self, i: usize) -> bool {
        self.head == i || self.prev[i] != NONE
    }

    fn drop_row(&mut self, i: usize) {
        self.unlink(i);
        self.used -= self.rows[i].len();
        self.rows[i] = Vec::new();
    }

    /// Makes row `i` at least `len` long; returns where the entries still to be computed
    /// start (== `len` if the row was already long enough). Marks the row most recently used.
    pub fn reserve(&mut self, i: usize, len: usize) -> usize {
        let have = self.rows[i].len();
        if self.is_linked(i) {
            self.unlink(i);
        }
        if have < len {
            let more = len - have;
            while self.used + more > self.budget && self.tail != NONE {
                let victim = self.tail;
                self.drop_row(victim);
            }
            // Dropping may have taken this row itself only if the cache were smaller than
            // one row, which `new` rules out; but it may have been unlinked above, so its
            // length is still `have`.
            self.rows[i].resize(len, 0.0);
            self.used += more;
        }
        self.push_front(i);
        have.min(len)
    }

    pub fn row(&self, i: usize) -> &[f32] {
        &self.rows[i]
    }

    pub fn row_mut(&mut self, i: usize) -> &mut [f32] {
        &mut self.rows[i]
    }

    /// Keeps cached values valid when the solver swaps indices `i` and `j`.
    pub fn swap_index(&mut self, i: usize, j: usize) {
        self.swap_indices(&[(i, j)]);
    }

    /// [`Self::swap_index`] of each pair in turn, leaving the cache as one call per pair
    /// would (the same rows, values and recency order), but walking each cached row once
    /// for all the pairs instead of every cached row once per pair: a shrinking step swaps
    /// hundreds of pairs, and one pass per pair over thousands of rows, two scattered
    /// entries a row, took 13 % of a 20k-row fit.
    pub fn swap_indices(&mut self, pairs: &[(usize, usize)]) {
        let pairs: Vec<(usize, usize)> = pairs
            .iter()
            .filter(|(i, j)| i != j)
            .map(|&(i, j)| (i.min(j), i.max(j)))
            .collect();
        if pairs.is_empty() {
            return;
        }
        // A row's entries trade places pair by pair until a pair it holds only the lower
        // entry of, which drops it: what happens to it does not depend on where it sits.
        let mut doomed = Vec::new();
        let mut k = self.head;
        while k != NONE {
            let row = &mut self.rows[k];
            let len = row.len();
            for &(i, j) in &pairs {
                if len > j {
                    row.swap(i, j);
                } else if len > i {
                    doomed.push(k);
                    break;
                }
            }
            k = self.next[k];
        }
        for k in doomed {
            self.drop_row(k);
        }
        // Then the rows move, pair by pair; each moved row becomes most recently used (as
        // libsvm does). A dropped row is empty wherever it goes, as it would have been from
        // the pair that dropped it on.
        for &(i, j) in &pairs {
            for k in [i, j] {
                if self.is_linked(k) {
                    self.unlink(k);
                }
            }
            self.rows.swap(i, j);
            for k in [i, j] {
                if !self.rows[k].is_empty() {
                    self.push_front(k);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn least_recently_used_rows_are_evicted() {
        // budget: 8 floats -> at least 2 * n = 8 for n = 4
        let mut c = RowCache::new(4, 8 * 4);
        assert_eq!(c.reserve(0, 4), 0);
        assert_eq!(c.reserve(1, 4), 0);
        assert_eq!(c.reserve(0, 4), 4, "cached");
        assert_eq!(c.reserve(2, 4), 0); // evicts 1, the least recently used
        assert_eq!(c.reserve(0, 4), 4);
        assert_eq!(c.reserve(1, 4), 0);
    }

    #[test]
    fn partial_rows_grow() {
        let mut c = RowCache::new(4, 1 << 20);
        assert_eq!(c.reserve(3, 2), 0);
        c.row_mut(3).copy_from_slice(&[1.0, 2.0]);
        assert_eq!(c.reserve(3, 4), 2);
        assert_eq!(&c.row(3)[..2], &[1.0, 2.0]);
    }

    /// Rows from most to least recently used, each with its values.
    fn contents(c: &RowCache) -> Vec<(usize, Vec<f32>)> {
        let mut out = Vec::new();
        let mut k = c.head;
        while k != NONE {
            out.push((k, c.rows[k].clone()));
            k = c.next[k];
        }
        out
    }

    #[test]
    fn swaps_applied_together_leave_the_cache_as_swaps_one_at_a_time() {
        let n = 12;
        let mut state = 5u64;
        let mut next = |m: usize| {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 33) as usize % m
        };
        for _ in 0..200 {
            let mut c = RowCache::new(n, 1 << 20);
            // rows of every length, some of them full, in a random recency order
            for _ in 0..8 {
                let (i, len) = (next(n), 1 + next(n));
                let start = c.reserve(i, len);
                for (at, v) in c.row_mut(i)[start..].iter_mut().enumerate() {
                    *v = (100 * i + start + at) as f32;
                }
            }
            // a shrinking step's pairs: a rising lower index, a falling upper one, and
            // some arbitrary pairs beside them
            let pairs: Vec<(usize, usize)> = (0..6)
                .map(|s| {
                    if s % 2 == 0 {
                        (s, n - 1 - s)
                    } else {
                        (next(n), next(n))
                    }
                })
                .collect();
            let mut one_at_a_time = RowCache::new(n, 1 << 20);
            one_at_a_time.rows = c.rows.clone();
            one_at_a_time.prev = c.prev.clone();
            one_at_a_time.next = c.next.clone();
            (one_at_a_time.head, one_at_a_time.tail, one_at_a_time.used) = (c.head, c.tail, c.used);
            for &(i, j) in &pairs {
                one_at_a_time.swap_index(i, j);
            }
            c.swap_indices(&pairs);
            assert_eq!(contents(&c), contents(&one_at_a_time), "{pairs:?}");
            assert_eq!((c.tail, c.used), (one_at_a_time.tail, one_at_a_time.used));
        }
    }

    #[test]
    fn swap_index_keeps_values_consistent() {
        let mut c = RowCache::new(4, 1 << 20);
        c.reserve(0, 4);
        c.row_mut(0).copy_from_slice(&[10.0, 11.0, 12.0, 13.0]);
        c.reserve(2, 2);
        c.row_mut(2).copy_from_slice(&[30.0, 31.0]);
        c.swap_index(1, 3);
        // row 0 had both entries: swapped
        assert_eq!(c.reserve(0, 4), 4);
        assert_eq!(c.row(0), &[10.0, 13.0, 12.0, 11.0]);
        // row 2 had entry 1 but not 3: dropped
        assert_eq!(c.reserve(2, 2), 0);
        // swapping a cached row's own index moves the row
        c.swap_index(0, 3);
        assert_eq!(c.reserve(3, 4), 4);
        // it is now row 3, and its entries 0 and 3 trade places too
        assert_eq!(c.row(3), &[11.0, 13.0, 12.0, 10.0]);
        assert_eq!(c.reserve(0, 1), 0);
    }
}
