//! Kernels over row-major `f32` data with precomputed squared norms.
//!
//! Dot products run in `f32` with eight independent accumulators so the compiler vectorises
//! them; on standardised 60-dimensional features the rounding error is around 1e-6 of the
//! value, far below what moves a decision. Kernel values are `f32` too (they are cached as
//! `f32`); sums over them are `f64`.

#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum Kernel {
    Linear,
    Rbf { gamma: f64 },
}

/// `a . b`, vectorisable.
#[inline(always)]
pub fn dot(a: &[f32], b: &[f32]) -> f32 {
    debug_assert_eq!(a.len(), b.len());
    let mut acc = [0.0f32; 8];
    let chunks = a.len() / 8;
    for c in 0..chunks {
        let (x, y) = (&a[c * 8..c * 8 + 8], &b[c * 8..c * 8 + 8]);
        for k in 0..8 {
            acc[k] += x[k] * y[k];
        }
    }
    let mut tail = 0.0f32;
    for k in chunks * 8..a.len() {
        tail += a[k] * b[k];
    }
    ((acc[0] + acc[4]) + (acc[1] + acc[5])) + ((acc[2] + acc[6]) + (acc[3] + acc[7])) + tail
}

/// `e^x` for `x <= 0` in `f32`, written so the compiler can vectorise it (no branches, no
/// library call): `x = n ln 2 + r`, `e^r` by its degree-6 Taylor polynomial on
/// `|r| <= ln 2 / 2`, `2^n` by building the float's exponent bits. Relative error below 3e-7,
/// i.e. within a few ulps of `f32`. Measured: with `std`'s `f64` `exp`, computing the RBF
/// terms took most of prediction time (83 us median for 6,274 support vectors).
#[inline(always)]
pub fn exp_nonpositive(x: f32) -> f32 {
    const LOG2E: f32 = std::f32::consts::LOG2_E;
    const LN2_HI: f32 = 0.693_145_75;
    const LN2_LO: f32 = 1.428_606_8e-6;
    // 1.5 * 2^23: adding and subtracting it rounds to an integer
    const ROUND: f32 = 12_582_912.0;
    // Only the lower clamp, which keeps 2^n a normal float: every caller passes `-gamma d2`
    // with `d2 >= 0` (a positive `x` would still get about `e^x` up to 88), and the upper one
    // was an instruction of the RBF loops' ~40 past their dot products.
    let x = x.max(-87.0);
    let t = x * LOG2E + ROUND;
    let n = t - ROUND;
    let r = x - n * LN2_HI - n * LN2_LO;
    let p = 1.0
        + r * (1.0
            + r * (0.5
                + r * (1.0 / 6.0 + r * (1.0 / 24.0 + r * (1.0 / 120.0 + r * (1.0 / 720.0))))));
    // The integer n sits in the low mantissa bits of t: no float-to-int conversion (whose
    // saturating semantics kept the loop from vectorising).
    let n_int = (t.to_bits() as i32).wrapping_sub(ROUND.to_bits() as i32);
    let scale = f32::from_bits((n_int.wrapping_add(127) << 23) as u32);
    p * scale
}

impl Kernel {
    /// Kernel value from the dot product and both squared norms.
    #[inline(always)]
    pub fn from_dot(&self, dot: f32, norm_a: f32, norm_b: f32) -> f64 {
        match *self {
            Kernel::Linear => f64::from(dot),
            Kernel::Rbf { gamma } => {
                let d2 = (norm_a + norm_b - 2.0 * dot).max(0.0);
                f64::from(exp_nonpositive(-(gamma as f32) * d2))
            }
        }
    }

    pub fn eval(&self, a: &[f32], b: &[f32]) -> f64 {
        self.from_dot(dot(a, b), dot(a, a), dot(b, b))
    }
}

/// Rows handled together when computing many kernel values against one row.
pub const BLOCK: usize = 64;

/// Training rows, owned so the solver can reorder them (shrinking swaps rows). Kept twice:
/// row-major for reading one row, and in blocks of [`BLOCK`] rows stored feature-major so a
/// kernel row (one row against many) vectorises across rows with no horizontal sums.
#[derive(Debug, Clone)]
pub struct Rows {
    pub dim: usize,
    pub x: Vec<f32>,
    pub norms: Vec<f32>,
    blocks: Vec<f32>,
}

impl Rows {
    pub fn new(dim: usize, x: Vec<f32>) -> Self {
        let norms: Vec<f32> = x.chunks_exact(dim).map(|r| dot(r, r)).collect();
        let n = norms.len();
        let mut blocks = vec![0.0; n.div_ceil(BLOCK) * BLOCK * dim];
        for (i, row) in x.chunks_exact(dim).enumerate() {
            for (f, v) in row.iter().enumerate() {
                blocks[Self::at(dim, i, f)] = *v;
            }
        }
        Self {
            dim,
            x,
            norms,
            blocks,
        }
    }

    #[inline]
    fn at(dim: usize, row: usize, feature: usize) -> usize {
        ((row / BLOCK) * dim + feature) * BLOCK + row % BLOCK
    }

    pub fn len(&self) -> usize {
        self.norms.len()
    }

    pub fn is_empty(&self) -> bool {
        self.norms.is_empty()
    }

    /// Block `b`'s rows, feature-major: feature `f` of row `b * BLOCK + k` at `f * BLOCK + k`
    /// (rows past the end are zero).
    #[inline]
    pub(super) fn block(&self, b: usize) -> &[f32] {
        &self.blocks[b * self.dim * BLOCK..(b + 1) * self.dim * BLOCK]
    }

    #[inline]
    pub fn row(&self, i: usize) -> &[f32] {
        &self.x[i * self.dim..(i + 1) * self.dim]
    }

    pub fn swap(&mut self, i: usize, j: usize) {
        if i == j {
            return;
        }
        let (a, b) = (i.min(j), i.max(j));
        let (head, tail) = self.x.split_at_mut(b * self.dim);
        head[a * self.dim..(a + 1) * self.dim].swap_with_slice(&mut tail[..self.dim]);
        self.norms.swap(a, b);
        for f in 0..self.dim {
            self.blocks
                .swap(Self::at(self.dim, a, f), Self::at(self.dim, b, f));
        }
    }

    /// `out[k] = x . row(start + k)`; `start` must be a multiple of [`BLOCK`] or `out` lie
    /// within one block.
    #[inline(always)]
    pub fn dots(&self, x: &[f32], start: usize, out: &mut [f32]) {
        let mut done = 0;
        while done < out.len() {
            let row = start + done;
            let (b, first) = (row / BLOCK, row % BLOCK);
            let take = (BLOCK - first).min(out.len() - done);
            let block = &self.blocks[b * self.dim * BLOCK..(b + 1) * self.dim * BLOCK];
            let mut acc = [0.0f32; BLOCK];
            for (f, xf) in x.iter().enumerate() {
                let col = &block[f * BLOCK..(f + 1) * BLOCK];
                for k in 0..BLOCK {
                    acc[k] += col[k] * xf;
                }
            }
            out[done..done + take].copy_from_slice(&acc[first..first + take]);
            done += take;
        }
    }
}

impl Rows {
    /// [`Self::dots`] for several query rows in one pass over the data: each block of rows
    /// is read from memory once for all of them. One kernel row over many training rows is
    /// limited by memory bandwidth, not arithmetic (a full row of 151k rows took 0.8 ms, one
    /// thread 1.0-1.2 ms), so rows computed together cost less each: 0.35 ms a row, one
    /// thread, 64 at a time. Every `outs[q]` has the same length; the values are bit-identical
    /// to [`Self::dots`]'s.
    pub fn dots_many(&self, xs: &[&[f32]], start: usize, outs: &mut [&mut [f32]]) {
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx2")
                && std::arch::is_x86_feature_detected!("fma")
            {
                // SAFETY: the CPU has the features the function is compiled for.
                return unsafe { self.dots_many_avx(xs, start, outs) };
            }
        }
        self.dots_many_portable(xs, start, outs)
    }

    fn dots_many_portable(&self, xs: &[&[f32]], start: usize, outs: &mut [&mut [f32]]) {
        for (x, out) in xs.iter().zip(outs.iter_mut()) {
            self.dots(x, start, out);
        }
    }

    /// [`Self::dots_many`] as a register-tiled product: 16 training rows x 4 query rows of
    /// accumulators per pass over a block's features (8 of the 16 AVX registers, with 4
    /// broadcast query values, a column vector and a product beside them), so each value
    /// loaded serves four queries and each broadcast two vectors of rows. Multiply then add,
    /// not fused, so every value is bit-identical to [`Self::dots`] (which the compiler does
    /// not fuse either). Measured, one thread, 60 features: 37-38 G multiply-adds/s on 512
    /// rows in cache (15 queries), against 23-26 G/s with 32 x 3 accumulators, two of which
    /// the compiler spilled to the stack; on 151k rows, 64 queries, 26 G/s (24 without the
    /// prefetch of the next block), where one row at a time gets 8-10 G/s.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn dots_many_avx(&self, xs: &[&[f32]], start: usize, outs: &mut [&mut [f32]]) {
        const TILE: usize = 16;
        let dim = self.dim;
        let len = outs.first().map_or(0, |o| o.len());
        for x in xs {
            assert!(x.len() >= dim, "a query row is {dim} wide");
        }
        let mut done = 0;
        while done < len {
            let row = start + done;
            let (b, first) = (row / BLOCK, row % BLOCK);
            let take = (BLOCK - first).min(len - done);
            let block = &self.blocks[b * dim * BLOCK..(b + 1) * dim * BLOCK];
            if let Some(next) = self
                .blocks
                .get((b + 1) * dim * BLOCK..(b + 2) * dim * BLOCK)
            {
                use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
                for line in next.chunks(16) {
                    _mm_prefetch::<_MM_HINT_T0>(line.as_ptr().cast());
                }
            }
            for t0 in (0..BLOCK).step_by(TILE) {
                let (lo, hi) = (first.max(t0), (first + take).min(t0 + TILE));
                if lo >= hi {
                    continue;
                }
                let mut q = 0;
                while q < xs.len() {
                    let members = (xs.len() - q).min(4);
                    let mut tile = [[0.0f32; TILE]; 4];
                    match members {
                        4 => tile_product::<4>(block, dim, t0, &xs[q..q + 4], &mut tile),
                        3 => tile_product::<3>(block, dim, t0, &xs[q..q + 3], &mut tile),
                        2 => tile_product::<2>(block, dim, t0, &xs[q..q + 2], &mut tile),
                        _ => tile_product::<1>(block, dim, t0, &xs[q..q + 1], &mut tile),
                    }
                    for g in 0..members {
                        let out = &mut outs[q + g][done + lo - first..done + hi - first];
                        out.copy_from_slice(&tile[g][lo - t0..hi - t0]);
                    }
                    q += members;
                }
            }
            done += take;
        }
    }
}

/// Rows of a [`wide_dots`] tile.
#[cfg(target_arch = "x86_64")]
pub(super) const WIDE_ROWS: usize = 8;
/// Block rows (columns) of a [`wide_dots`] tile: two 16-lane registers.
#[cfg(target_arch = "x86_64")]
pub(super) const WIDE_COLUMNS: usize = 32;

/// `dots[r][k] = xs[r] . (block row t0 + k)` for the 32 rows from `t0` of a block stored
/// feature-major (feature `f` of its row `k` at `f * BLOCK + k`, as [`Rows`] and a model's
/// support vectors are), with AVX-512: 8 x 32 sums in 16 of the 32 registers, each loaded
/// block value serving eight rows and each broadcast row value two registers. Multiply then
/// add, in feature order, as [`Rows::dots`], so the values are bit-identical to it.
///
/// # Safety
///
/// Only callable where the CPU has AVX-512F (from code compiled for it, or after checking).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
pub(super) fn wide_dots(
    block: &[f32],
    t0: usize,
    xs: [&[f32]; WIDE_ROWS],
) -> [[f32; WIDE_COLUMNS]; WIDE_ROWS] {
    use std::arch::x86_64::*;
    let dim = xs[0].len();
    assert!(block.len() >= dim * BLOCK && t0 + WIDE_COLUMNS <= BLOCK);
    assert!(xs.iter().all(|x| x.len() == dim), "rows of one width");
    let mut dots = [[0.0f32; WIDE_COLUMNS]; WIDE_ROWS];
    // SAFETY: loads lie within `block` (feature f's 64 values from f * 64, t0 + 32 <= 64)
    // and within the rows of `dim` values; stores go to `dots`.
    unsafe {
        let bp = block.as_ptr().add(t0);
        let mut lo = [_mm512_setzero_ps(); WIDE_ROWS];
        let mut hi = [_mm512_setzero_ps(); WIDE_ROWS];
        for f in 0..dim {
            let col = bp.add(f * BLOCK);
            let (c0, c1) = (_mm512_loadu_ps(col), _mm512_loadu_ps(col.add(16)));
            for r in 0..WIDE_ROWS {
                let a = _mm512_set1_ps(*xs[r].get_unchecked(f));
                lo[r] = _mm512_add_ps(lo[r], _mm512_mul_ps(c0, a));
                hi[r] = _mm512_add_ps(hi[r], _mm512_mul_ps(c1, a));
            }
        }
        for r in 0..WIDE_ROWS {
            _mm512_storeu_ps(dots[r].as_mut_ptr(), lo[r]);
            _mm512_storeu_ps(dots[r].as_mut_ptr().add(16), hi[r]);
        }
    }
    dots
}

/// `tile[g][k] = xs[g] . row(t0 + k)` for the 16 rows of a block from `t0` (see
/// [`Rows::dots_many_avx`]).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
unsafe fn tile_product<const Q: usize>(
    block: &[f32],
    dim: usize,
    t0: usize,
    xs: &[&[f32]],
    tile: &mut [[f32; 16]; 4],
) {
    use std::arch::x86_64::*;
    assert!(block.len() >= dim * BLOCK && t0 + 16 <= BLOCK && xs.len() == Q);
    let bp = block.as_ptr();
    let mut lo = [_mm256_setzero_ps(); Q];
    let mut hi = [_mm256_setzero_ps(); Q];
    let ptrs: [*const f32; Q] = std::array::from_fn(|g| xs[g].as_ptr());
    for f in 0..dim {
        let col = bp.add(f * BLOCK + t0);
        let a: [__m256; Q] = std::array::from_fn(|g| _mm256_broadcast_ss(&*ptrs[g].add(f)));
        let c = _mm256_loadu_ps(col);
        for g in 0..Q {
            lo[g] = _mm256_add_ps(lo[g], _mm256_mul_ps(c, a[g]));
        }
        let c = _mm256_loadu_ps(col.add(8));
        for g in 0..Q {
            hi[g] = _mm256_add_ps(hi[g], _mm256_mul_ps(c, a[g]));
        }
    }
    for g in 0..Q {
        _mm256_storeu_ps(tile[g].as_mut_ptr(), lo[g]);
        _mm256_storeu_ps(tile[g].as_mut_ptr().add(8), hi[g]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dot_matches_naive_for_odd_lengths() {
        let a: Vec<f32> = (0..61).map(|i| i as f32 * 0.1).collect();
        let b: Vec<f32> = (0..61).map(|i| 1.0 - i as f32 * 0.01).collect();
        let naive: f32 = a.iter().zip(&b).map(|(x, y)| x * y).sum();
        assert!((dot(&a, &b) - naive).abs() < 1e-3);
    }

    #[test]
    fn fast_exp_is_accurate_to_f32_precision() {
        let mut worst = 0.0f64;
        let mut x = -87.0f32;
        while x <= 0.0 {
            let exact = f64::from(x).exp();
            let rel = (f64::from(exp_nonpositive(x)) - exact).abs() / exact;
            worst = worst.max(rel);
            x += 0.0007;
        }
        assert!(worst < 3e-7, "{worst}");
        assert_eq!(exp_nonpositive(0.0), 1.0);
        assert!(exp_nonpositive(-1000.0) < 1e-37);
    }

    #[test]
    fn rbf_is_one_on_the_diagonal_and_decays() {
        let k = Kernel::Rbf { gamma: 0.5 };
        assert!((k.eval(&[1.0, 2.0], &[1.0, 2.0]) - 1.0).abs() < 1e-12);
        assert!((k.eval(&[0.0, 0.0], &[1.0, 1.0]) - (-1.0f64).exp()).abs() < 1e-7);
    }

    #[test]
    fn blocked_dots_match_row_dots_after_swaps() {
        let (n, dim) = (150, 7);
        let x: Vec<f32> = (0..n * dim).map(|i| ((i * 37) % 11) as f32 - 5.0).collect();
        let mut r = Rows::new(dim, x);
        r.swap(3, 140);
        r.swap(70, 0);
        let q: Vec<f32> = (0..dim).map(|i| i as f32 * 0.5).collect();
        let mut out = vec![0.0; n - 5];
        r.dots(&q, 5, &mut out);
        for (k, v) in out.iter().enumerate() {
            assert_eq!(*v, dot(&q, r.row(5 + k)), "row {}", 5 + k);
        }
    }

    #[test]
    fn dots_of_several_rows_at_once_match_one_at_a_time() {
        let (n, dim) = (200, 9);
        let x: Vec<f32> = (0..n * dim).map(|i| ((i * 53) % 17) as f32 - 8.0).collect();
        let r = Rows::new(dim, x);
        // 9 queries: two full tiles of four and one of one; fewer in the loop below.
        let queries: Vec<Vec<f32>> = (0..9)
            .map(|q| {
                (0..dim)
                    .map(|f| (q * dim + f) as f32 * 0.25 - 3.0)
                    .collect()
            })
            .collect();
        for count in [1, 2, 3, 4, 5, 6, 7, 9] {
            let xs: Vec<&[f32]> = queries[..count].iter().map(|q| q.as_slice()).collect();
            // Starts within a tile, on a tile, on a block and in the last block.
            for start in [0, 3, 17, 64, 70, 199] {
                let mut bufs = vec![vec![0.0f32; n - start]; count];
                let mut outs: Vec<&mut [f32]> = bufs.iter_mut().map(|b| b.as_mut_slice()).collect();
                r.dots_many(&xs, start, &mut outs);
                for (q, out) in queries.iter().zip(&bufs) {
                    for (k, v) in out.iter().enumerate() {
                        assert_eq!(
                            *v,
                            dot(q, r.row(start + k)),
                            "{count} queries, start {start}, row {}",
                            start + k
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn swapping_rows_swaps_norms() {
        let mut r = Rows::new(2, vec![1.0, 0.0, 3.0, 4.0, 0.0, 2.0]);
        r.swap(2, 0);
        assert_eq!(r.row(0), &[0.0, 2.0]);
        assert_eq!(r.row(2), &[1.0, 0.0]);
        assert_eq!(r.norms, vec![4.0, 25.0, 1.0]);
    }
}
