//! Sequential minimal optimisation for the C-SVC dual, after libsvm (Chang & Lin 2011;
//! Fan, Chen & Lin 2005), written for this project because the Rust crates measured too
//! slow (see the module docs of `svm`):
//!
//!   min_a  1/2 a^T Q a - e^T a   s.t.  0 <= a_i <= C,  y^T a = 0,   Q_ij = y_i y_j K(x_i, x_j)
//!
//! - working sets by second-order selection (WSS 2 of Fan et al.);
//! - a bounded LRU cache of Q rows, partly filled while shrinking;
//! - shrinking of bounded variables that are unlikely to move, with the gradient
//!   reconstructed before the final optimality check;
//! - kernel rows computed in parallel when a row is long enough to pay for it, and where the
//!   rows needed are known ahead (a warm start, a gradient reconstruction) many at a time
//!   in one pass over the training rows (`q_batch`): a reconstruction on 151k rows
//!   took 3.8 s one row at a time, 1.9 s with 64 rows a pass, and about 1.0 s with their
//!   values added to the gradient as they are computed, with the same gradient to the bit.
//!
//! Index loops mirror libsvm's so the two can be read side by side.
#![allow(clippy::needless_range_loop)]

use rayon::prelude::*;

use super::cache::RowCache;
use super::kernel::{Kernel, Rows, BLOCK};
use super::q_batch::{add_q_products, q_rows, Sum, PARALLEL_WORK, ROWS_PER_PASS};
use super::select;
use super::status::Bound;

const TAU: f64 = 1e-12;

/// What the solver found, in the caller's row order.
#[derive(Debug, Clone, PartialEq)]
pub struct Solution {
    pub alpha: Vec<f64>,
    pub rho: f64,
    pub iterations: usize,
    /// The iteration limit was hit before the stopping tolerance was met.
    pub hit_iteration_limit: bool,
    /// The largest violation of the optimality (KKT) conditions at the end, as libsvm
    /// measures it (`m(alpha) - M(alpha)`); below the tolerance when converged.
    pub kkt_gap: f64,
}

pub struct SolverOptions {
    pub c: f64,
    pub tolerance: f64,
    pub shrinking: bool,
    pub cache_bytes: usize,
    pub max_iterations: usize,
}

/// Rows of Q: `y_i y_j K(x_i, x_j)` for the current ordering of the rows.
struct QMatrix {
    rows: Rows,
    y: Vec<i8>,
    kernel: Kernel,
    cache: RowCache,
    diagonal: Vec<f64>,
}

impl QMatrix {
    /// Ensures row `i` holds its first `len` entries.
    fn fill(&mut self, i: usize, len: usize) {
        let start = self.cache.reserve(i, len);
        if start >= len {
            return;
        }
        let (rows, y, kernel) = (&self.rows, &self.y, self.kernel);
        let out = &mut self.cache.row_mut(i)[start..len];
        let compute = |from: usize, chunk: &mut [f32]| {
            #[cfg(target_arch = "x86_64")]
            {
                if std::arch::is_x86_feature_detected!("avx2")
                    && std::arch::is_x86_feature_detected!("fma")
                {
                    // SAFETY: the CPU has the features the function is compiled for.
                    return unsafe { kernel_row_chunk_avx2(rows, y, kernel, i, from, chunk) };
                }
            }
            kernel_row_chunk(rows, y, kernel, i, from, chunk)
        };
        // Chunks start on block boundaries (after a possibly partial first block).
        let head = ((BLOCK - start % BLOCK) % BLOCK).min(len - start);
        let (first, rest) = out.split_at_mut(head);
        compute(start, first);
        let rest_start = start + head;
        if rest.len() * rows.dim >= PARALLEL_WORK {
            const CHUNK: usize = 8 * BLOCK;
            rest.par_chunks_mut(CHUNK)
                .enumerate()
                .for_each(|(c, chunk)| compute(rest_start + c * CHUNK, chunk));
        } else {
            compute(rest_start, rest);
        }
    }

    /// Rows `targets` of Q, their entries in `columns`, uncached (see [`q_rows`]).
    fn compute_rows(&self, targets: &[usize], columns: std::ops::Range<usize>) -> Vec<Vec<f32>> {
        q_rows(&self.rows, &self.y, self.kernel, targets, columns)
    }

    /// Adds each sum's coefficients times rows `targets` of Q, uncached (see
    /// [`add_q_products`]).
    fn add_products(&self, targets: &[usize], columns: std::ops::Range<usize>, sums: &mut [Sum]) {
        add_q_products(&self.rows, &self.y, self.kernel, targets, columns, sums)
    }

    /// Swaps rows `i` and `j` of everything but the cache (see [`Solver::do_shrinking`]).
    fn swap_uncached(&mut self, i: usize, j: usize) {
        self.rows.swap(i, j);
        self.y.swap(i, j);
        self.diagonal.swap(i, j);
    }
}

/// `Q_ij` for `j` in `from..from + chunk.len()`: dot products by blocks of rows, then the
/// kernel and the label signs in one pass.
#[inline(always)]
fn kernel_row_chunk(
    rows: &Rows,
    y: &[i8],
    kernel: Kernel,
    i: usize,
    from: usize,
    chunk: &mut [f32],
) {
    let (ni, yi) = (rows.norms[i], f32::from(y[i]));
    rows.dots(rows.row(i), from, chunk);
    for (k, v) in chunk.iter_mut().enumerate() {
        let j = from + k;
        *v = yi * f32::from(y[j]) * kernel.from_dot(*v, ni, rows.norms[j]) as f32;
    }
}

/// [`kernel_row_chunk`] compiled for AVX2 and FMA (measured on a 20,000-row fit: 5.6 s
/// without, 3.9 s with), chosen at run time when the CPU has them.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn kernel_row_chunk_avx2(
    rows: &Rows,
    y: &[i8],
    kernel: Kernel,
    i: usize,
    from: usize,
    chunk: &mut [f32],
) {
    kernel_row_chunk(rows, y, kernel, i, from, chunk)
}

struct Solver {
    q: QMatrix,
    n: usize,
    active_size: usize,
    alpha: Vec<f64>,
    status: Vec<Bound>,
    gradient: Vec<f64>,
    /// Sum over upper-bounded j of C Q_ij: lets the gradient of shrunk variables be rebuilt.
    gradient_bar: Vec<f64>,
    /// original index of the row now at each position
    order: Vec<usize>,
    c: f64,
    eps: f64,
    unshrink: bool,
}

impl Solver {
    /// The solver at `alpha = 0` for rows `x` (row-major, `dim` wide) and labels `y`.
    fn new(dim: usize, x: Vec<f32>, y: Vec<i8>, kernel: Kernel, options: &SolverOptions) -> Self {
        let rows = Rows::new(dim, x);
        let n = rows.len();
        let diagonal = (0..n)
            .map(|i| kernel.from_dot(rows.norms[i], rows.norms[i], rows.norms[i]))
            .collect();
        let q = QMatrix {
            cache: RowCache::new(n, options.cache_bytes),
            rows,
            y,
            kernel,
            diagonal,
        };
        Self {
            q,
            n,
            active_size: n,
            alpha: vec![0.0; n],
            status: vec![Bound::Lower; n],
            gradient: vec![-1.0; n],
            gradient_bar: vec![0.0; n],
            order: (0..n).collect(),
            c: options.c,
            eps: options.tolerance,
            unshrink: false,
        }
    }

    fn y(&self, i: usize) -> f64 {
        f64::from(self.q.y[i])
    }

    fn update_status(&mut self, i: usize) {
        self.status[i] = Bound::of(self.alpha[i], self.c);
    }

    /// Swaps variables `i` and `j` everywhere but in the kernel-row cache, which the caller
    /// updates with [`RowCache::swap_indices`] before it next reads the cache.
    fn swap_index_uncached(&mut self, i: usize, j: usize) {
        self.q.swap_uncached(i, j);
        self.alpha.swap(i, j);
        self.status.swap(i, j);
        self.gradient.swap(i, j);
        self.gradient_bar.swap(i, j);
        self.order.swap(i, j);
    }

    /// Each active variable's label, bound and gradient.
    fn active_variables(&self) -> impl Iterator<Item = (i8, Bound, f64)> + '_ {
        (0..self.active_size).map(|t| (self.q.y[t], self.status[t], self.gradient[t]))
    }

    /// `m(alpha) - M(alpha)` over the active set: how far from optimal (libsvm's stopping
    /// quantity, `Gmax + Gmax2`).
    fn kkt_gap(&self) -> f64 {
        let (m, big_m) = violation_extremes(self.active_variables());
        (m - big_m).max(0.0)
    }

    /// Second-order working-set selection; `None` when optimal within `eps`.
    fn select_working_set(&mut self) -> Option<(usize, usize)> {
        let active = self.active_size;
        let (i, gmax) = select::max_violating_up(
            &self.q.y[..active],
            &self.status[..active],
            &self.gradient[..active],
        )?;
        self.q.fill(i, active);
        let first = select::First {
            q_i: &self.q.cache.row(i)[..active],
            gmax,
            y_i: self.y(i),
            qd_i: self.q.diagonal[i],
            tau: TAU,
        };
        let partner = select::best_partner(
            &self.q.y[..active],
            &self.status[..active],
            &self.gradient[..active],
            &self.q.diagonal[..active],
            &first,
        );
        if gmax + partner.gmax2 < self.eps {
            return None;
        }
        partner.j.map(|j| (i, j))
    }

    fn be_shrunk(&self, i: usize, gmax1: f64, gmax2: f64) -> bool {
        let (g, up) = (self.gradient[i], self.q.y[i] == 1);
        match self.status[i] {
            Bound::Upper => -g > if up { gmax1 } else { gmax2 },
            Bound::Lower => g > if up { gmax2 } else { gmax1 },
            Bound::Free => false,
        }
    }

    fn do_shrinking(&mut self) {
        let (mut gmax1, mut gmax2) = (f64::NEG_INFINITY, f64::NEG_INFINITY);
        for i in 0..self.active_size {
            let g = self.gradient[i];
            let (not_upper, not_lower) = (
                self.status[i] != Bound::Upper,
                self.status[i] != Bound::Lower,
            );
            if self.q.y[i] == 1 {
                if not_upper {
                    gmax1 = gmax1.max(-g);
                }
                if not_lower {
                    gmax2 = gmax2.max(g);
                }
            } else {
                if not_upper {
                    gmax2 = gmax2.max(-g);
                }
                if not_lower {
                    gmax1 = gmax1.max(g);
                }
            }
        }
        if !self.unshrink && gmax1 + gmax2 <= self.eps * 10.0 {
            self.unshrink = true;
            self.reconstruct_gradient();
            self.active_size = self.n;
        }
        // The cache learns the step's swaps together, once they are all known.
        let mut swaps = Vec::new();
        let mut i = 0;
        while i < self.active_size {
            if self.be_shrunk(i, gmax1, gmax2) {
                self.active_size -= 1;
                while self.active_size > i {
                    if !self.be_shrunk(self.active_size, gmax1, gmax2) {
                        self.swap_index_uncached(i, self.active_size);
                        swaps.push((i, self.active_size));
                        break;
                    }
                    self.active_size -= 1;
                }
            }
            i += 1;
        }
        self.q.cache.swap_indices(&swaps);
    }

    fn reconstruct_gradient(&mut self) {
        let (active, n) = (self.active_size, self.n);
        if active == n {
            return;
        }
        for j in active..n {
            self.gradient[j] = self.gradient_bar[j] - 1.0;
        }
        let free = (0..active)
            .filter(|&j| self.status[j] == Bound::Free)
            .count();
        // The rows needed are known ahead, so they are computed [`ROWS_PER_PASS`] at a time
        // in one pass over the training rows each (the sums run in libsvm's order, so the
        // gradient is the same to the bit as one row at a time).
        if free * n > 2 * active * (n - active) {
            let inactive: Vec<usize> = (active..n).collect();
            for batch in inactive.chunks(ROWS_PER_PASS) {
                let rows = self.q.compute_rows(batch, 0..active);
                for (&i, qi) in batch.iter().zip(&rows) {
                    let mut g = 0.0;
                    for j in 0..active {
                        if self.status[j] == Bound::Free {
                            g += self.alpha[j] * f64::from(qi[j]);
                        }
                    }
                    self.gradient[i] += g;
                }
            }
        } else {
            let free_rows: Vec<usize> = (0..active)
                .filter(|&i| self.status[i] == Bound::Free)
                .collect();
            let coefs: Vec<f64> = free_rows.iter().map(|&i| self.alpha[i]).collect();
            self.q.add_products(
                &free_rows,
                active..n,
                &mut [Sum {
                    coefs: &coefs,
                    out: &mut self.gradient[active..],
                }],
            );
        }
    }

    fn update_pair(&mut self, i: usize, j: usize) {
        let active = self.active_size;
        self.q.fill(i, active);
        self.q.fill(j, active);
        let c = self.c;
        let (old_ai, old_aj) = (self.alpha[i], self.alpha[j]);
        let qij = f64::from(self.q.cache.row(i)[j]);
        let (qd_i, qd_j) = (self.q.diagonal[i], self.q.diagonal[j]);
        let (gi, gj) = (self.gradient[i], self.gradient[j]);
        let (mut ai, mut aj) = (old_ai, old_aj);
        if self.q.y[i] != self.q.y[j] {
            let quad = (qd_i + qd_j + 2.0 * qij).max(TAU);
            let delta = (-gi - gj) / quad;
            let diff = ai - aj;
            ai += delta;
            aj += delta;
            if diff > 0.0 {
                if aj < 0.0 {
                    aj = 0.0;
                    ai = diff;
                }
            } else if ai < 0.0 {
                ai = 0.0;
                aj = -diff;
            }
            if diff > 0.0 {
                if ai > c {
                    ai = c;
                    aj = c - diff;
                }
            } else if aj > c {
                aj = c;
                ai = c + diff;
            }
        } else {
            let quad = (qd_i + qd_j - 2.0 * qij).max(TAU);
            let delta = (gi - gj) / quad;
            let sum = ai + aj;
            ai -= delta;
            aj += delta;
            if sum > c {
                if ai > c {
                    ai = c;
                    aj = sum - c;
                }
            } else if aj < 0.0 {
                aj = 0.0;
                ai = sum;
            }
            if sum > c {
                if aj > c {
                    aj = c;
                    ai = sum - c;
                }
            } else if ai < 0.0 {
                ai = 0.0;
                aj = sum;
            }
        }
        self.alpha[i] = ai;
        self.alpha[j] = aj;
        let (dai, daj) = (ai - old_ai, aj - old_aj);
        add_two_rows(
            &mut self.gradient[..active],
            &self.q.cache.row(i)[..active],
            dai,
            &self.q.cache.row(j)[..active],
            daj,
        );
        for k in [i, j] {
            let was_upper = self.status[k] == Bound::Upper;
            self.update_status(k);
            let is_upper = self.status[k] == Bound::Upper;
            if was_upper != is_upper {
                self.q.fill(k, self.n);
                let qk = self.q.cache.row(k);
                let sign = if was_upper { -c } else { c };
                for (gb, q) in self.gradient_bar.iter_mut().zip(qk) {
                    *gb += sign * f64::from(*q);
                }
            }
        }
    }

    /// Sets `alpha` to a feasible point near `start` and the gradients to match it:
    /// `G_i = sum_j alpha_j Q_ij - 1` and `G_bar_i = C sum_{j at C} Q_ij`, one kernel row per
    /// nonzero alpha, computed [`ROWS_PER_PASS`] at a time.
    fn start_from(&mut self, start: &[f64]) {
        assert_eq!(start.len(), self.n, "one starting alpha per row");
        self.set_alpha(feasible_start(start, &self.q.y, self.c));
    }

    /// Sets `alpha` (within the box) and the gradients to match it.
    fn set_alpha(&mut self, alpha: Vec<f64>) {
        self.alpha = alpha;
        for i in 0..self.n {
            self.update_status(i);
        }
        let nonzero: Vec<usize> = (0..self.n).filter(|&j| self.alpha[j] > 0.0).collect();
        let alpha: Vec<f64> = nonzero.iter().map(|&j| self.alpha[j]).collect();
        let at_c: Vec<f64> = nonzero
            .iter()
            .map(|&j| match self.status[j] {
                Bound::Upper => self.c,
                _ => 0.0,
            })
            .collect();
        self.q.add_products(
            &nonzero,
            0..self.n,
            &mut [
                Sum {
                    coefs: &alpha,
                    out: &mut self.gradient,
                },
                Sum {
                    coefs: &at_c,
                    out: &mut self.gradient_bar,
                },
            ],
        );
    }

    fn rho(&self) -> f64 {
        rho_of(self.active_variables())
    }
}

/// `gradient[k] += q_i[k] a_i + q_j[k] a_j`: an SMO step's change of the gradient, the same
/// operations in the same order on every CPU, four at a time with AVX2 (the loop was a
/// tenth of a search sweep's time on SSE2's two).
fn add_two_rows(gradient: &mut [f64], q_i: &[f32], a_i: f64, q_j: &[f32], a_j: f64) {
    #[inline(always)]
    fn add(gradient: &mut [f64], q_i: &[f32], a_i: f64, q_j: &[f32], a_j: f64) {
        for ((g, qi), qj) in gradient.iter_mut().zip(q_i).zip(q_j) {
            *g += f64::from(*qi) * a_i + f64::from(*qj) * a_j;
        }
    }
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn add_avx2(gradient: &mut [f64], q_i: &[f32], a_i: f64, q_j: &[f32], a_j: f64) {
        add(gradient, q_i, a_i, q_j, a_j)
    }
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has the feature the function is compiled for.
            return unsafe { add_avx2(gradient, q_i, a_i, q_j, a_j) };
        }
    }
    add(gradient, q_i, a_i, q_j, a_j)
}

/// libsvm's `m(alpha)`, the largest `-y_t G_t` over the variables that may move up
/// (`I_up`), and `M(alpha)`, the smallest over those that may move down (`I_low`), of the
/// variables given as (label, bound, gradient). The dual is optimal within `eps` when
/// `m - M < eps`.
pub(super) fn violation_extremes(variables: impl Iterator<Item = (i8, Bound, f64)>) -> (f64, f64) {
    let (mut up, mut low) = (f64::NEG_INFINITY, f64::NEG_INFINITY);
    for (y, status, g) in variables {
        if y == 1 {
            if status != Bound::Upper {
                up = up.max(-g);
            }
            if status != Bound::Lower {
                low = low.max(g);
            }
        } else {
            if status != Bound::Lower {
                up = up.max(g);
            }
            if status != Bound::Upper {
                low = low.max(-g);
            }
        }
    }
    (up, -low)
}

/// The offset `rho` of the decision function at an optimum, as libsvm computes it from the
/// variables given as (label, bound, gradient): the mean `y_t G_t` of the free variables, or
/// the middle of the bounds the others set when none is free.
pub(super) fn rho_of(variables: impl Iterator<Item = (i8, Bound, f64)>) -> f64 {
    let (mut ub, mut lb, mut sum_free, mut free) = (f64::INFINITY, f64::NEG_INFINITY, 0.0, 0usize);
    for (y, status, g) in variables {
        let yg = f64::from(y) * g;
        match (status, y == 1) {
            (Bound::Upper, false) | (Bound::Lower, true) => ub = ub.min(yg),
            (Bound::Upper, true) | (Bound::Lower, false) => lb = lb.max(yg),
            (Bound::Free, _) => {
                free += 1;
                sum_free += yg;
            }
        }
    }
    if free > 0 {
        sum_free / free as f64
    } else {
        (ub + lb) / 2.0
    }
}

/// A feasible starting point near `start`: each alpha clipped into `[0, C]`, then the class
/// with the larger share of `sum y_i alpha_i` scaled down so that `y^T alpha = 0` holds
/// (SMO keeps that constraint exactly, so it must hold from the start).
pub fn feasible_start(start: &[f64], y: &[i8], c: f64) -> Vec<f64> {
    let mut alpha: Vec<f64> = start
        .iter()
        .map(|a| if a.is_finite() { a.clamp(0.0, c) } else { 0.0 })
        .collect();
    let (mut positive, mut negative) = (0.0, 0.0);
    for (a, &yi) in alpha.iter().zip(y) {
        if yi > 0 {
            positive += a;
        } else {
            negative += a;
        }
    }
    let (excess_class, total, keep) = if positive > negative {
        (1, positive, negative)
    } else {
        (-1, negative, positive)
    };
    if total > keep {
        let scale = if total > 0.0 { keep / total } else { 0.0 };
        for (a, &yi) in alpha.iter_mut().zip(y) {
            if yi == excess_class {
                *a *= scale;
            }
        }
    }
    alpha
}

/// Solves the C-SVC dual for rows `x` (row-major, `dim` wide) with labels `y` in {-1, +1},
/// from `alpha = 0`, or from `start` (one value per row; made feasible by
/// [`feasible_start`]): a neighbouring problem's solution, for example the same rows but a
/// few, which SMO then needs fewer steps to finish.
pub fn solve(
    dim: usize,
    x: Vec<f32>,
    y: Vec<i8>,
    kernel: Kernel,
    options: &SolverOptions,
    start: Option<&[f64]>,
) -> Solution {
    solve_with_gradient(dim, x, y, kernel, options, start).0
}

/// [`solve`], and the gradient `G` at the solution, in the caller's row order.
pub(super) fn solve_with_gradient(
    dim: usize,
    x: Vec<f32>,
    y: Vec<i8>,
    kernel: Kernel,
    options: &SolverOptions,
    start: Option<&[f64]>,
) -> (Solution, Vec<f64>) {
    let mut s = Solver::new(dim, x, y, kernel, options);
    let n = s.n;
    if let Some(start) = start {
        s.start_from(start);
    }
    let mut iterations = 0;
    let mut counter = n.min(1000) + 1;
    let mut hit_iteration_limit = false;
    loop {
        if iterations >= options.max_iterations {
            hit_iteration_limit = true;
            break;
        }
        counter -= 1;
        if counter == 0 {
            counter = n.min(1000);
            if options.shrinking {
                s.do_shrinking();
            }
        }
        let (i, j) = match s.select_working_set() {
            Some(pair) => pair,
            None => {
                // Optimal on the active set: check all variables before stopping.
                s.reconstruct_gradient();
                s.active_size = n;
                match s.select_working_set() {
                    Some(pair) => {
                        counter = 1;
                        pair
                    }
                    None => break,
                }
            }
        };
        iterations += 1;
        s.update_pair(i, j);
    }
    if hit_iteration_limit && s.active_size < n {
        s.reconstruct_gradient();
        s.active_size = n;
    }
    let kkt_gap = s.kkt_gap();
    let rho = s.rho();
    let (mut alpha, mut gradient) = (vec![0.0; n], vec![0.0; n]);
    for (pos, &orig) in s.order.iter().enumerate() {
        alpha[orig] = s.alpha[pos];
        gradient[orig] = s.gradient[pos];
    }
    let solution = Solution {
        alpha,
        rho,
        iterations,
        hit_iteration_limit,
        kkt_gap,
    };
    (solution, gradient)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(n: usize, dim: usize) -> (Vec<f32>, Vec<i8>) {
        let mut state = 7u64;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 40) as f32 / (1u64 << 24) as f32) * 2.0 - 1.0
        };
        let x = (0..n * dim).map(|_| next()).collect();
        let y = (0..n).map(|i| if i % 3 == 0 { 1 } else { -1 }).collect();
        (x, y)
    }

    fn options(c: f64) -> SolverOptions {
        SolverOptions {
            c,
            tolerance: 1e-3,
            shrinking: true,
            cache_bytes: 1 << 20,
            max_iterations: 1_000_000,
        }
    }

    #[test]
    fn rows_computed_together_are_those_computed_one_at_a_time() {
        let (n, dim) = (300, 7);
        let (x, y) = sample(n, dim);
        let mut s = Solver::new(dim, x, y, Kernel::Rbf { gamma: 0.3 }, &options(1.0));
        let targets = [5, 290, 64, 0, 133];
        for columns in [0..n, 3..n, 64..200, 70..71, 130..130] {
            let together = s.q.compute_rows(&targets, columns.clone());
            for (&i, row) in targets.iter().zip(&together) {
                s.q.fill(i, n);
                assert_eq!(
                    row.as_slice(),
                    &s.q.cache.row(i)[columns.clone()],
                    "row {i}, columns {columns:?}"
                );
            }
        }
    }

    /// `G_i = sum_j alpha_j Q_ij - 1`, one entry at a time in `f64`.
    fn direct_gradient(s: &Solver) -> Vec<f64> {
        (0..s.n)
            .map(|i| {
                let qi = s.q.compute_rows(&[i], 0..s.n).remove(0);
                (0..s.n).map(|j| s.alpha[j] * f64::from(qi[j])).sum::<f64>() - 1.0
            })
            .collect()
    }

    #[test]
    fn a_reconstructed_gradient_is_the_gradient_by_either_way_of_summing() {
        let (n, dim) = (260, 5);
        let (x, y) = sample(n, dim);
        let c = 0.8;
        // Two active sizes, one on each side of reconstruct_gradient's choice between
        // summing by inactive row and by free row.
        for active in [250, 20] {
            let mut s = Solver::new(
                dim,
                x.clone(),
                y.clone(),
                Kernel::Rbf { gamma: 0.5 },
                &options(c),
            );
            // Free and bounded variables of both labels among the active ones; only bounded
            // ones beyond them, as shrinking leaves it (the equality constraint plays no
            // part in the gradient).
            let alpha: Vec<f64> = (0..n)
                .map(|i| match (i < active, i % 4) {
                    (_, 0) => 0.0,
                    (true, 1) => 0.3,
                    (_, 2) => c,
                    (true, _) => 0.55,
                    (false, _) => c,
                })
                .collect();
            s.set_alpha(alpha);
            let expected = direct_gradient(&s);
            let free = (0..active).filter(|&j| s.status[j] == Bound::Free).count();
            let by_free_rows = free * n <= 2 * active * (n - active);
            assert_eq!(
                by_free_rows,
                active == 20,
                "the case meant for active {active}"
            );
            s.active_size = active;
            for g in &mut s.gradient[active..] {
                *g = f64::NAN;
            }
            s.reconstruct_gradient();
            for (i, (got, want)) in s.gradient.iter().zip(&expected).enumerate() {
                assert!(
                    (got - want).abs() < 1e-9,
                    "active {active}, row {i}: {got} vs {want}"
                );
            }
        }
    }
}
