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
        if i == j {
            return;
        }
        let (i, j) = (i.min(j), i.max(j));
        // Swap the rows themselves; both become most recently used (as libsvm does).
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
        // Swap entries i and j inside every row that has both; drop rows with only i.
        let mut k = self.head;
        while k != NONE {
            let next = self.next[k];
            let len = self.rows[k].len();
            if len > j {
                self.rows[k].swap(i, j);
            } else if len > i {
                self.drop_row(k);
            }
            k = next;
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
