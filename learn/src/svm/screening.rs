//! Large problems solved on a subset of their rows that grows until every other row meets
//! the optimality conditions: the answer meets [`smo::solve`]'s stopping rule on all rows,
//! with far fewer full-length kernel rows.
//!
//! Why: on tmo's slip sweep's largest cells (151k rows, 1.6k of them positive, about 6k support
//! vectors) SMO's first few thousand steps each compute two kernel rows over nearly all
//! rows before shrinking sets the far-away negative rows aside, and the gradient of the rows
//! set aside is rebuilt twice at the end. Most rows never become support vectors. Here SMO
//! runs on the rows that can matter (the smaller class, the warm start's support vectors and
//! an even sample of the rest); one pass over the other rows then gives their gradients at
//! that solution, and those that violate the optimality conditions join the subset before
//! SMO runs again from where it stopped.
//!
//! Rows outside the subset have `alpha = 0`, which leaves `y^T alpha = 0` and the subset's
//! gradients as they are; so when the violation over all rows, `m(alpha) - M(alpha)`, is
//! below the tolerance, the solution is one [`smo::solve`] could have stopped at.

use super::kernel::{Kernel, Rows};
use super::q_batch::{add_q_products, Sum};
use super::smo::{self, feasible_start, rho_of, violation_extremes, Solution, SolverOptions};
use super::status::Bound;
use super::DualStart;

/// Problems with fewer rows are solved whole: below these the full-length rows are cheap
/// and the extra passes do not pay. Measured on tmo's slip sweep's cells at n_slip 13-15 (the
/// first of a chain starts cold, the others from their neighbour with its margins): cold,
/// 61k rows took 6.4 s screened against 5.3 s whole, 106k 9.6 s against 14.6 s; from a
/// neighbour, 31k rows 1.8 s against 2.2 s, 61k 2.9 s against 3.9 s, 151k 4.7 s against
/// 11.0 s (cells' seconds, with prediction).
pub const MIN_ROWS: usize = 80_000;
/// [`MIN_ROWS`] for a start with margins (see [`DualStart`]).
pub const MIN_ROWS_WITH_HINT: usize = 25_000;

/// The first subset's size without a hint, at least: the smaller class and every k-th
/// other row up to it.
const FIRST_SUBSET: usize = 20_000;

/// How far beyond the margin (`y f(x) = 1`) a neighbouring fit may have put a row that the
/// first subset still takes. Margins crowd near 1 on tmo's slip sweep's features: at d 1, n_slip
/// 15, 0.1 took 17k of 151k rows and left 4 to add; 0.25 took 67k.
const START_SLACK: f64 = 0.1;

/// Share of the tolerance kept between the band a row outside the subset must keep to
/// (see [`Band`]) and the tolerance itself: room for rounding, in the kernel's `f32` values
/// and in the bound on how far a gradient has moved.
const MARGIN: f64 = 0.1;

/// Solves the C-SVC dual as [`smo::solve`] does, on subsets of the rows when there are at
/// least [`MIN_ROWS`] of them ([`MIN_ROWS_WITH_HINT`] from a start with margins) and
/// shrinking is on; returns each row's margin `y f(x)` at
/// the solution beside it (for the rows that ended outside the subset, at the last whole
/// pass over them, which is close enough to choose the next fit's first subset by).
pub fn solve(
    dim: usize,
    x: Vec<f32>,
    y: Vec<i8>,
    kernel: Kernel,
    options: &SolverOptions,
    start: Option<&DualStart>,
) -> (Solution, Vec<f64>) {
    let n = y.len();
    let min_rows = if margin_hint(start, n).is_some() {
        MIN_ROWS_WITH_HINT
    } else {
        MIN_ROWS
    };
    if n < min_rows || !options.shrinking {
        let alpha = start.map(|s| s.alpha.as_slice());
        let (solution, gradient) =
            smo::solve_with_gradient(dim, x, y.clone(), kernel, options, alpha);
        let margin = margins(&y, &gradient, solution.rho);
        return (solution, margin);
    }
    solve_screened(dim, x, y, kernel, options, start, FIRST_SUBSET)
}

/// [`solve`] on subsets whatever the size, the first of about `first_subset` rows when
/// there is no hint.
fn solve_screened(
    dim: usize,
    x: Vec<f32>,
    y: Vec<i8>,
    kernel: Kernel,
    options: &SolverOptions,
    start: Option<&DualStart>,
    first_subset: usize,
) -> (Solution, Vec<f64>) {
    let n = y.len();
    let hint = margin_hint(start, n);
    let c = options.c;
    let alpha = match start {
        Some(start) => feasible_start(&start.alpha, &y, c),
        None => vec![0.0; n],
    };
    let mut p = Permuted::new(dim, x, y, alpha);
    let first = p.first_subset(hint, first_subset);
    let mut size = p.move_to_front(0, &first);
    let (mut iterations, mut hit_iteration_limit) = (0, false);
    loop {
        let (solution, subset_gradient) = p.solve_subset(size, kernel, options, iterations);
        iterations += solution.iterations;
        hit_iteration_limit |= solution.hit_iteration_limit;
        p.alpha[..size].copy_from_slice(&solution.alpha);
        p.gradient[..size].copy_from_slice(&subset_gradient);
        if hit_iteration_limit {
            p.exact_rest(size, kernel);
            break;
        }
        let band = Band::around(
            violation_extremes(p.variables(0..size, c)),
            options.tolerance,
        );
        let violates = p.judge_rest(size, kernel, band);
        let added = p.move_to_front(size, &violates);
        if added == 0 {
            break;
        }
        size += added;
    }
    // The rest's gradients are current only after a whole pass: rho needs them when no
    // variable is free (it then rests on the bounded ones), and an unconverged solution
    // reports its violation over all rows.
    let no_free = (0..size).all(|t| Bound::of(p.alpha[t], c) != Bound::Free);
    let current = if hit_iteration_limit || no_free {
        if !hit_iteration_limit {
            p.exact_rest(size, kernel);
        }
        0..n
    } else {
        0..size
    };
    let (m, big_m) = violation_extremes(p.variables(current.clone(), c));
    let rho = rho_of(p.variables(current, c));
    let (mut alpha, mut margin) = (vec![0.0; n], vec![0.0; n]);
    let at = margins(&p.y, &p.gradient, rho);
    for (pos, &orig) in p.order.iter().enumerate() {
        alpha[orig] = p.alpha[pos];
        margin[orig] = at[pos];
    }
    let solution = Solution {
        alpha,
        rho,
        iterations,
        hit_iteration_limit,
        kkt_gap: (m - big_m).max(0.0),
    };
    (solution, margin)
}

/// The start's margins, when it has one for each of the `n` rows.
fn margin_hint(start: Option<&DualStart>, n: usize) -> Option<&[f64]> {
    start.map(|s| s.margin.as_slice()).filter(|m| m.len() == n)
}

/// Each row's margin `y_t f(x_t) = G_t + 1 - y_t rho` (at most 1 for a support vector).
fn margins(y: &[i8], gradient: &[f64], rho: f64) -> Vec<f64> {
    y.iter()
        .zip(gradient)
        .map(|(&yt, g)| g + 1.0 - f64::from(yt) * rho)
        .collect()
}

/// Where the values `-y_t G_t` of the rows outside the subset must lie for the whole problem
/// to be optimal within the tolerance, given the subset's `m` and `M`: rows that may move up
/// (`I_up`) at most `upper`, rows that may move down (`I_low`) at least `lower`. A band of
/// less than the tolerance about the subset's middle, so that whichever of the subset's and
/// the band's ends count, `m - M` over all rows stays below the tolerance.
#[derive(Debug, Clone, Copy)]
struct Band {
    lower: f64,
    upper: f64,
}

impl Band {
    fn around((m, big_m): (f64, f64), tolerance: f64) -> Self {
        let (middle, half) = ((m + big_m) / 2.0, tolerance * (1.0 - MARGIN) / 2.0);
        Self {
            lower: middle - half,
            upper: middle + half,
        }
    }

    /// Whether a row outside the subset (at `alpha = 0`) with label `y` and gradient `g`
    /// keeps to the band: it may only move up (a positive row) or only down (a negative row).
    fn holds(&self, y: i8, g: f64) -> bool {
        match y {
            1 => -g <= self.upper,
            _ => g >= self.lower,
        }
    }

    /// [`Self::holds`] for every gradient within `radius` of `g`.
    fn holds_within(&self, y: i8, g: f64, radius: f64) -> bool {
        match y {
            1 => -g + radius <= self.upper,
            _ => g - radius >= self.lower,
        }
    }
}

/// The rows, labels and dual variables in working order: the subset first.
#[derive(Clone)]
struct Permuted {
    rows: Rows,
    y: Vec<i8>,
    alpha: Vec<f64>,
    /// The subset's gradients at the subset's solution; the rest's at `reference`.
    gradient: Vec<f64>,
    /// `alpha` when the rest's gradients were last computed whole.
    reference: Option<Vec<f64>>,
    /// The caller's index of the row at each position.
    order: Vec<usize>,
}

impl Permuted {
    fn new(dim: usize, x: Vec<f32>, y: Vec<i8>, alpha: Vec<f64>) -> Self {
        let n = y.len();
        Self {
            rows: Rows::new(dim, x),
            y,
            alpha,
            gradient: vec![0.0; n],
            reference: None,
            order: (0..n).collect(),
        }
    }

    /// Which rows the first subset takes: every row of the smaller class and every row with
    /// a starting `alpha`; then every row whose margin in the `hint` (a neighbouring fit's)
    /// is unknown or below `1 + `[`START_SLACK`], or without a hint every k-th row so that
    /// there are about `size`.
    fn first_subset(&self, hint: Option<&[f64]>, size: usize) -> Vec<bool> {
        let n = self.y.len();
        let positive = self.y.iter().filter(|&&y| y == 1).count();
        let smaller = if positive * 2 <= n { 1 } else { -1 };
        let stride = (n / size.max(1)).max(1);
        (0..n)
            .map(|t| {
                self.y[t] == smaller
                    || self.alpha[t] > 0.0
                    || match hint {
                        Some(margin) => margin[t].is_nan() || margin[t] < 1.0 + START_SLACK,
                        None => t % stride == 0,
                    }
            })
            .collect()
    }

    /// Moves the rows from `from` on whose flag (`take[t - from]`) is set to the front of
    /// that range, keeping their order; returns how many moved.
    fn move_to_front(&mut self, from: usize, take: &[bool]) -> usize {
        let mut next = from;
        for (k, &taken) in take.iter().enumerate() {
            let t = from + k;
            if taken {
                if t != next {
                    self.rows.swap(next, t);
                    self.y.swap(next, t);
                    self.alpha.swap(next, t);
                    self.gradient.swap(next, t);
                    if let Some(reference) = &mut self.reference {
                        reference.swap(next, t);
                    }
                    self.order.swap(next, t);
                }
                next += 1;
            }
        }
        next - from
    }

    /// SMO on the first `size` rows from their current `alpha`.
    fn solve_subset(
        &self,
        size: usize,
        kernel: Kernel,
        options: &SolverOptions,
        iterations_used: usize,
    ) -> (Solution, Vec<f64>) {
        let dim = self.rows.dim;
        let start = &self.alpha[..size];
        let options = SolverOptions {
            max_iterations: options.max_iterations.saturating_sub(iterations_used),
            ..*options
        };
        smo::solve_with_gradient(
            dim,
            self.rows.x[..size * dim].to_vec(),
            self.y[..size].to_vec(),
            kernel,
            &options,
            start.iter().any(|&a| a > 0.0).then_some(start),
        )
    }

    /// The gradients of the rows from `size` on (whose own `alpha` is zero), computed whole
    /// at the current `alpha`, which becomes the reference.
    fn exact_rest(&mut self, size: usize, kernel: Kernel) {
        let n = self.y.len();
        self.gradient[size..].fill(-1.0);
        let (support, coefs) = nonzero(&self.alpha[..size]);
        add_q_products(
            &self.rows,
            &self.y,
            kernel,
            &support,
            size..n,
            &mut [Sum {
                coefs: &coefs,
                out: &mut self.gradient[size..],
            }],
        );
        self.reference = Some(self.alpha.clone());
    }

    /// Which rows from `size` on break the `band` (one flag each). Judged from their
    /// gradients at the reference where those are close enough to decide; otherwise
    /// computed.
    ///
    /// The bound: `G_t = y_t <phi(x_t), w> - 1` with `w = sum_j alpha_j y_j phi(x_j)`, so
    /// `G_t` has moved since the reference by at most `|phi(x_t)| |w - w_ref|`, where
    /// `|phi(x_t)|^2 = K(x_t, x_t)` (1 for the RBF kernel) and
    /// `|w - w_ref|^2 = d^T Q d` for `d = alpha - alpha_ref`.
    fn judge_rest(&mut self, size: usize, kernel: Kernel, band: Band) -> Vec<bool> {
        let n = self.y.len();
        let Some(moved) = self.moved_since_reference(size, kernel) else {
            return self.judge_rest_exactly(size, kernel, band);
        };
        let unsure = self.unsure(size, kernel, band, moved.distance);
        if unsure.iter().filter(|&&u| u).count() * 4 > n - size {
            return self.judge_rest_exactly(size, kernel, band);
        }
        // The unsure rows first after the subset, to compute their gradients now (from
        // the reference's, by the change) without disturbing the reference's.
        let unsure_count = self.move_to_front(size, &unsure);
        let mut now = self.gradient[size..size + unsure_count].to_vec();
        add_q_products(
            &self.rows,
            &self.y,
            kernel,
            &moved.rows,
            size..size + unsure_count,
            &mut [Sum {
                coefs: &moved.change,
                out: &mut now,
            }],
        );
        (size..n)
            .map(|t| t < size + unsure_count && !band.holds(self.y[t], now[t - size]))
            .collect()
    }

    /// [`Self::judge_rest`] from gradients computed whole (see [`Self::exact_rest`]).
    fn judge_rest_exactly(&mut self, size: usize, kernel: Kernel, band: Band) -> Vec<bool> {
        self.exact_rest(size, kernel);
        (size..self.y.len())
            .map(|t| !band.holds(self.y[t], self.gradient[t]))
            .collect()
    }

    /// How `alpha` has changed since the reference (`None` without one): the rows and
    /// changes, and `|w - w_ref| = sqrt(d^T Q d)`, rounded up for the kernel's `f32` values.
    fn moved_since_reference(&self, size: usize, kernel: Kernel) -> Option<Moved> {
        let reference = self.reference.as_ref()?;
        let (rows, change): (Vec<usize>, Vec<f64>) = (0..size)
            .filter(|&j| self.alpha[j] != reference[j])
            .map(|j| (j, self.alpha[j] - reference[j]))
            .unzip();
        let mut q_change = vec![0.0; size];
        add_q_products(
            &self.rows,
            &self.y,
            kernel,
            &rows,
            0..size,
            &mut [Sum {
                coefs: &change,
                out: &mut q_change,
            }],
        );
        let squared: f64 = rows
            .iter()
            .zip(&change)
            .map(|(&j, d)| d * q_change[j])
            .sum();
        let distance = squared.max(0.0).sqrt() * (1.0 + 1e-6) + 1e-9;
        Some(Moved {
            rows,
            change,
            distance,
        })
    }

    /// Flags the rows from `size` on whose gradient at the reference does not keep them to
    /// the `band` by more than it can have moved, `distance |phi(x_t)|`.
    fn unsure(&self, size: usize, kernel: Kernel, band: Band, distance: f64) -> Vec<bool> {
        let norm = |t: usize| {
            let s = self.rows.norms[t];
            kernel.from_dot(s, s, s).max(0.0).sqrt()
        };
        (size..self.y.len())
            .map(|t| !band.holds_within(self.y[t], self.gradient[t], distance * norm(t)))
            .collect()
    }

    /// The label, bound and gradient of the rows at `positions`.
    fn variables(
        &self,
        positions: std::ops::Range<usize>,
        c: f64,
    ) -> impl Iterator<Item = (i8, Bound, f64)> + '_ {
        positions.map(move |t| (self.y[t], Bound::of(self.alpha[t], c), self.gradient[t]))
    }
}

/// How the subset's `alpha` has moved since the reference.
struct Moved {
    rows: Vec<usize>,
    change: Vec<f64>,
    /// `|w - w_ref|`, rounded up.
    distance: f64,
}

/// The positions and values of the nonzero entries of `alpha`.
fn nonzero(alpha: &[f64]) -> (Vec<usize>, Vec<f64>) {
    alpha
        .iter()
        .enumerate()
        .filter(|(_, &a)| a > 0.0)
        .map(|(j, &a)| (j, a))
        .unzip()
}

#[cfg(test)]
mod tests {
    use super::*;

    const KERNEL: Kernel = Kernel::Rbf { gamma: 0.5 };
    const TOLERANCE: f64 = 1e-3;

    /// An imbalanced, overlapping problem like tmo's slip sweep's: one positive row in ten.
    fn problem(n: usize, dim: usize) -> (Vec<f32>, Vec<i8>) {
        let mut state = 11u64;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 40) as f32 / (1u64 << 24) as f32) * 2.0 - 1.0
        };
        let y: Vec<i8> = (0..n).map(|i| if i % 10 == 3 { 1 } else { -1 }).collect();
        let x = (0..n * dim)
            .map(|k| next() * 1.5 + if y[k / dim] == 1 { 0.6 } else { 0.0 })
            .collect();
        (x, y)
    }

    fn options(c: f64) -> SolverOptions {
        SolverOptions {
            c,
            tolerance: TOLERANCE,
            shrinking: true,
            cache_bytes: 1 << 22,
            max_iterations: 1_000_000,
        }
    }

    /// `m(alpha) - M(alpha)` over every row, from gradients summed one kernel value at a
    /// time.
    fn violation(dim: usize, x: &[f32], y: &[i8], alpha: &[f64], c: f64) -> f64 {
        let row = |t: usize| &x[t * dim..(t + 1) * dim];
        let gradient: Vec<f64> = (0..y.len())
            .map(|t| {
                let sum: f64 = (0..y.len())
                    .filter(|&j| alpha[j] > 0.0)
                    .map(|j| alpha[j] * f64::from(y[t] * y[j]) * KERNEL.eval(row(t), row(j)))
                    .sum();
                sum - 1.0
            })
            .collect();
        let variables = (0..y.len()).map(|t| (y[t], Bound::of(alpha[t], c), gradient[t]));
        let (m, big_m) = violation_extremes(variables);
        m - big_m
    }

    fn decision(dim: usize, x: &[f32], y: &[i8], solution: &Solution, t: usize) -> f64 {
        let row = |i: usize| &x[i * dim..(i + 1) * dim];
        (0..y.len())
            .filter(|&j| solution.alpha[j] > 0.0)
            .map(|j| solution.alpha[j] * f64::from(y[j]) * KERNEL.eval(row(t), row(j)))
            .sum::<f64>()
            - solution.rho
    }

    #[test]
    fn a_screened_solve_meets_the_stopping_rule_on_every_row() {
        let (n, dim, c) = (2_000, 3, 1.0);
        let (x, y) = problem(n, dim);
        let (screened, margin) =
            solve_screened(dim, x.clone(), y.clone(), KERNEL, &options(c), None, 300);
        assert!(!screened.hit_iteration_limit);
        let gap = violation(dim, &x, &y, &screened.alpha, c);
        assert!(gap < TOLERANCE, "m - M = {gap} over all rows");
        // The first subset alone would not have done: the rows outside it mattered.
        let first = Permuted::new(dim, x.clone(), y.clone(), vec![0.0; n]).first_subset(None, 300);
        let kept: Vec<usize> = (0..n).filter(|&t| first[t]).collect();
        let sub_x: Vec<f32> = kept
            .iter()
            .flat_map(|&t| x[t * dim..(t + 1) * dim].to_vec())
            .collect();
        let sub_y: Vec<i8> = kept.iter().map(|&t| y[t]).collect();
        let sub = smo::solve(dim, sub_x, sub_y, KERNEL, &options(c), None);
        let mut alpha = vec![0.0; n];
        for (k, &t) in kept.iter().enumerate() {
            alpha[t] = sub.alpha[k];
        }
        assert!(
            kept.len() < n / 2,
            "{} rows in the first subset",
            kept.len()
        );
        assert!(violation(dim, &x, &y, &alpha, c) > TOLERANCE);
        // The same optimum as SMO on every row, within the tolerance; margins y f(x).
        let whole = smo::solve(dim, x.clone(), y.clone(), KERNEL, &options(c), None);
        for t in (0..n).step_by(7) {
            let (a, b) = (
                decision(dim, &x, &y, &screened, t),
                decision(dim, &x, &y, &whole, t),
            );
            assert!((a - b).abs() < 1e-2, "row {t}: {a} vs {b}");
            assert!(
                (f64::from(y[t]) * a - margin[t]).abs() < 1e-2,
                "row {t}'s margin"
            );
        }
    }

    #[test]
    fn a_start_with_margins_ends_at_the_same_optimum_in_fewer_steps() {
        let (n, dim, c) = (2_000, 3, 1.0);
        let (x, y) = problem(n, dim);
        // The neighbour: the same rows but the last 100.
        let m = n - 100;
        let (near, near_margin) = solve_screened(
            dim,
            x[..m * dim].to_vec(),
            y[..m].to_vec(),
            KERNEL,
            &options(c),
            None,
            300,
        );
        let mut start = DualStart {
            alpha: near.alpha,
            margin: near_margin,
        };
        start.alpha.resize(n, 0.0);
        start.margin.resize(n, f64::NAN);
        let opts = options(c);
        let (warm, _) = solve_screened(dim, x.clone(), y.clone(), KERNEL, &opts, Some(&start), 300);
        let (cold, _) = solve_screened(dim, x.clone(), y.clone(), KERNEL, &opts, None, 300);
        let gap = violation(dim, &x, &y, &warm.alpha, c);
        assert!(gap < TOLERANCE, "m - M = {gap} over all rows");
        assert!(
            warm.iterations < cold.iterations,
            "{} vs {}",
            warm.iterations,
            cold.iterations
        );
        for t in (0..n).step_by(7) {
            let (a, b) = (
                decision(dim, &x, &y, &warm, t),
                decision(dim, &x, &y, &cold, t),
            );
            assert!((a - b).abs() < 1e-2, "row {t}: {a} vs {b}");
        }
    }

    #[test]
    fn rows_judged_from_the_bound_are_judged_as_their_computed_gradients_would_be() {
        let (n, dim) = (2_000, 3);
        let (x, y) = problem(n, dim);
        let mut p = Permuted::new(dim, x, y, vec![0.0; n]);
        let first = p.first_subset(None, 300);
        let mut size = p.move_to_front(0, &first);
        // The whole problem's solution, screened to the end, with the rest's gradients
        // there (the reference).
        let solve = |p: &mut Permuted, size: usize, c: f64| {
            let (solution, gradient) = p.solve_subset(size, KERNEL, &options(c), 0);
            p.alpha[..size].copy_from_slice(&solution.alpha);
            p.gradient[..size].copy_from_slice(&gradient);
        };
        loop {
            solve(&mut p, size, 1.0);
            let band = Band::around(violation_extremes(p.variables(0..size, 1.0)), TOLERANCE);
            let violates = p.judge_rest_exactly(size, KERNEL, band);
            match p.move_to_front(size, &violates) {
                0 => break,
                added => size += added,
            }
        }
        // A band that the tenth-worst row outside the subset just keeps to at the reference,
        // so that some rows break it (all positive rows, the smaller class, are in the subset).
        let (mut slip, mut stat): (Vec<f64>, Vec<f64>) = (Vec::new(), Vec::new());
        for t in size..n {
            match p.y[t] {
                1 => slip.push(-p.gradient[t]),
                _ => stat.push(p.gradient[t]),
            }
        }
        slip.sort_by(|a, b| b.total_cmp(a));
        stat.sort_by(f64::total_cmp);
        let band = Band {
            lower: stat[10],
            upper: slip.get(10).copied().unwrap_or(f64::INFINITY),
        };
        // Solved again more tightly, which moves alpha a little.
        let tight = SolverOptions {
            tolerance: TOLERANCE / 100.0,
            ..options(1.0)
        };
        let (solution, gradient) = p.solve_subset(size, KERNEL, &tight, 0);
        p.alpha[..size].copy_from_slice(&solution.alpha);
        p.gradient[..size].copy_from_slice(&gradient);
        let moved = p.moved_since_reference(size, KERNEL).unwrap();
        let unsure = p
            .unsure(size, KERNEL, band, moved.distance)
            .iter()
            .filter(|&&u| u)
            .count();
        assert!(
            0 < unsure && unsure * 4 <= n - size,
            "{unsure} of {} rows unsure: the bound decides some, not all",
            n - size
        );
        let flagged = |p: &Permuted, flags: &[bool]| -> Vec<usize> {
            let mut rows: Vec<usize> = (0..flags.len())
                .filter(|&k| flags[k])
                .map(|k| p.order[size + k])
                .collect();
            rows.sort_unstable();
            rows
        };
        let mut exact = p.clone();
        let by_computing = exact.judge_rest_exactly(size, KERNEL, band);
        let by_bound = p.judge_rest(size, KERNEL, band);
        assert_eq!(flagged(&p, &by_bound), flagged(&exact, &by_computing));
        assert!(by_computing.iter().any(|&v| v), "some row breaks the band");
    }

    #[test]
    fn rows_within_the_band_keep_the_violation_over_all_rows_below_the_tolerance() {
        // The subset's m and M, from well inside the tolerance to just under it, either way.
        for (m, big_m) in [(0.2, 0.2), (0.2, 0.5), (0.2004, 0.2), (0.2 + 0.999e-3, 0.2)] {
            let band = Band::around((m, big_m), TOLERANCE);
            // The worst rows the band allows: a positive row at its upper end (value -G), a
            // negative row at its lower end (value G).
            assert!(band.holds(1, -band.upper) && band.holds(-1, band.lower));
            assert!(!band.holds(1, -band.upper - 1e-9) && !band.holds(-1, band.lower - 1e-9));
            let gap = f64::max(m, band.upper) - f64::min(big_m, band.lower);
            assert!(gap < TOLERANCE, "m {m}, M {big_m}: {gap}");
            // A gradient that can have moved by up to the radius.
            assert!(band.holds_within(1, -(band.upper - 0.5), 0.25));
            assert!(!band.holds_within(1, -(band.upper - 0.5), 0.75));
            assert!(band.holds_within(-1, band.lower + 0.5, 0.25));
            assert!(!band.holds_within(-1, band.lower + 0.5, 0.75));
        }
    }
}
