//! Support vector machines: C-SVC with a Gaussian (RBF) kernel, trained by our own SMO solver
//! ([`smo`]), or with a linear kernel, trained by an interior-point method ([`linear_ipm`]).
//!
//! Why our own: linfa-svm took about 146 s and 3 GB for 20,000 rows of a 60-dimensional,
//! imbalanced task, and smartcore's SVC about 21 s for only 2,000 rows. The method needs
//! hundreds of fits per sweep, so the RBF solver follows libsvm's algorithm (second-order
//! working sets, LRU kernel cache, shrinking) and adds parallel kernel rows. Measured with
//! `cargo bench -p tmo-learn --bench svm_speed` and `scripts/time_sklearn.py` on the same rows, C and
//! gamma (2 cores, 2026-11-25, run back to back; scikit-learn 1.9.1 is libsvm on one
//! thread, here with its best 4000 MB cache), with the same support vectors to within 3:
//!
//! | rows | tmo, 1 thread | tmo, 2 threads | scikit-learn | ratio, 1 thread |
//! | --- | --- | --- | --- | --- |
//! | 20,000 | 0.48 s | 0.44 s | 2.36 s | 0.20 |
//! | 61,315 | 5.18 s | 4.18 s | 37.2 s | 0.14 |
//!
//! (The machine's speed wandered that day: three more runs fitted the 61k rows in 3.7-4.1 s
//! on one thread; an earlier pair measured scikit-learn at 1.68 s and 25.3 s, tmo at 0.59 s
//! and 5.18 s, before the vectorised working-set selection.)
//!
//! (A comparison before that used scikit-learn's default 200 MB cache, which thrashes at
//! these sizes and made libsvm look slower than it is.)
//!
//! Decision values follow scikit-learn's sign: positive means the positive class.
//!
//! Where a sweep's RBF time goes, and why it is near its floor (the step-by-step pipeline's fixed grid, 150
//! RBF cells, counted and profiled 2026-11-26): 179 G kernel values of 60 features each.
//! 76 G score the test rows (every test row against every support vector); 65 G are
//! [`screening`]'s whole passes over the rows outside the subset (about one is needed per
//! fit to show them optimal; the rest follow subsets that moved too far to bound); 24 G
//! are warm starts' and gradient reconstructions' products; 8 G are SMO's own rows. The
//! dot products run at the core's rate (38 G multiply-adds/s, one thread, multiply then
//! add as libsvm) and the exponential and sums add about half again: 2.3 ns a value, some
//! 200 s of two cores. The decisions are small differences of large sums (slip terms
//! about 844 against static terms about 845 at a negative row), so no bound spares a row.
//! Measured and not kept: `bfloat16` dot products (AVX512-BF16, 2.9x the `f32` rate) in
//! scoring alone took the RBF cells from 253 to 226 s but moved 119 of 150 cells' test
//! macro F1, by up to 0.010; a stopping tolerance of 1e-2 took them to 230 s and moved 65
//! cells' by up to 0.0065.

mod bound;
pub mod cache;
pub mod kernel;
pub mod linear_ipm;
mod predict;
mod q_batch;
pub mod screening;
mod select;
pub mod smo;
mod status;

pub use bound::{NegativeBound, PositiveScoring};
pub use kernel::Kernel;

use crate::Label;
use kernel::{dot, BLOCK};

/// Hyperparameters as given; [`SvmParams::check`] turns them into [`ValidSvmParams`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SvmParams {
    pub kernel: Kernel,
    pub c: f64,
    /// Stopping tolerance on the KKT violation (libsvm's and scikit-learn's 1e-3).
    pub tolerance: f64,
    pub shrinking: bool,
    pub cache_mb: usize,
    pub max_iterations: Option<usize>,
}

impl SvmParams {
    pub fn rbf(c: f64, gamma: f64) -> Self {
        Self {
            kernel: Kernel::Rbf { gamma },
            ..Self::linear(c)
        }
    }

    pub fn linear(c: f64) -> Self {
        Self {
            kernel: Kernel::Linear,
            c,
            tolerance: 1e-3,
            shrinking: true,
            cache_mb: 200,
            max_iterations: None,
        }
    }

    pub fn check(self) -> Result<ValidSvmParams, SvmError> {
        if !(self.c.is_finite() && self.c > 0.0) {
            return Err(SvmError::InvalidParameter {
                name: "C",
                value: self.c,
                expected: "a positive number",
            });
        }
        if let Kernel::Rbf { gamma } = self.kernel {
            if !(gamma.is_finite() && gamma > 0.0) {
                return Err(SvmError::InvalidParameter {
                    name: "gamma",
                    value: gamma,
                    expected: "a positive number",
                });
            }
        }
        if !(self.tolerance.is_finite() && self.tolerance > 0.0) {
            return Err(SvmError::InvalidParameter {
                name: "tolerance",
                value: self.tolerance,
                expected: "a positive number",
            });
        }
        Ok(ValidSvmParams(self))
    }
}

/// Hyperparameters that passed [`SvmParams::check`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ValidSvmParams(SvmParams);

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SvmError {
    #[error("invalid {name} = {value}: expected {expected}")]
    InvalidParameter {
        name: &'static str,
        value: f64,
        expected: &'static str,
    },
    #[error("training data needs rows of both classes (negative {negative_rows}, positive {positive_rows})")]
    OneClass {
        negative_rows: usize,
        positive_rows: usize,
    },
    #[error("training rows have {got} values, expected a multiple of {dim}")]
    Shape { got: usize, dim: usize },
}

/// A fit's solution, to start a neighbouring fit from (see [`ValidSvmParams::fit_from`]).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct DualStart {
    /// Each row's dual variable.
    pub alpha: Vec<f64>,
    /// Each row's margin `y f(x)` at that solution, NaN where unknown; or empty. Lets a
    /// large fit begin with the rows near the margin (see [`screening`]).
    pub margin: Vec<f64>,
}

impl DualStart {
    /// A start from dual variables alone.
    pub fn from_alpha(alpha: Vec<f64>) -> Self {
        Self {
            alpha,
            margin: Vec::new(),
        }
    }
}

/// A trained SVM.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SvmModel {
    pub kernel: Kernel,
    pub dim: usize,
    /// Support vectors, row-major.
    pub support_vectors: Vec<f32>,
    /// `alpha_i y_i` of each support vector.
    pub dual_coef: Vec<f64>,
    pub rho: f64,
    /// For the linear kernel: the primal weights `sum alpha_i y_i x_i`, so prediction is one
    /// dot product.
    pub weights: Option<Vec<f64>>,
    pub iterations: usize,
    /// The optimality gap left when the solver stopped at its iteration limit before
    /// converging (`None`: it converged). Such a fit is approximate, and says so.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub unconverged_gap: Option<f64>,
    #[serde(skip)]
    norms: Vec<f32>,
    #[serde(skip)]
    coef32: Vec<f32>,
    /// Support vectors in blocks of [`BLOCK`], each stored feature-major (see [`predict`]).
    #[serde(skip)]
    blocks: Vec<f32>,
}

/// Default limit on the linear solver's Newton steps.
pub const LINEAR_MAX_ITERATIONS: usize = 200;

impl ValidSvmParams {
    pub fn params(&self) -> &SvmParams {
        &self.0
    }

    /// Fits on `x` (row-major, `dim` wide) and labels `y`.
    pub fn fit(&self, dim: usize, x: &[f32], y: &[impl Label]) -> Result<SvmModel, SvmError> {
        self.fit_from(dim, x, y, None).map(|(model, _)| model)
    }

    /// [`Self::fit`] starting from `start` (e.g. a neighbouring fit's [`Self::fit_from`]
    /// output mapped onto these rows; RBF only, the linear solver starts from its own
    /// centre), returning this fit's solution beside the model.
    pub fn fit_from(
        &self,
        dim: usize,
        x: &[f32],
        y: &[impl Label],
        start: Option<&DualStart>,
    ) -> Result<(SvmModel, DualStart), SvmError> {
        let p = &self.0;
        if dim == 0 || x.len() != dim * y.len() {
            return Err(SvmError::Shape { got: x.len(), dim });
        }
        let positive_rows = y.iter().filter(|c| c.is_positive()).count();
        if positive_rows == 0 || positive_rows == y.len() {
            return Err(SvmError::OneClass {
                negative_rows: y.len() - positive_rows,
                positive_rows,
            });
        }
        let signs: Vec<i8> = y
            .iter()
            .map(|c| if c.is_positive() { 1 } else { -1 })
            .collect();
        let n = y.len();
        let (solution, margin) = match p.kernel {
            // An interior-point method: SMO's step count grows with C on a linear kernel
            // (see `linear_ipm`). Its iterations are Newton steps.
            Kernel::Linear => (
                linear_ipm::solve(
                    dim,
                    x,
                    &signs,
                    p.c,
                    p.tolerance,
                    p.max_iterations.unwrap_or(LINEAR_MAX_ITERATIONS),
                ),
                Vec::new(),
            ),
            Kernel::Rbf { .. } => {
                let options = smo::SolverOptions {
                    c: p.c,
                    tolerance: p.tolerance,
                    shrinking: p.shrinking,
                    cache_bytes: p.cache_mb << 20,
                    max_iterations: p
                        .max_iterations
                        .unwrap_or_else(|| (100 * n).max(10_000_000)),
                };
                screening::solve(dim, x.to_vec(), signs.clone(), p.kernel, &options, start)
            }
        };
        let mut support_vectors = Vec::new();
        let mut dual_coef = Vec::new();
        for i in 0..n {
            if solution.alpha[i] > 0.0 {
                support_vectors.extend_from_slice(&x[i * dim..(i + 1) * dim]);
                dual_coef.push(solution.alpha[i] * f64::from(signs[i]));
            }
        }
        let weights = (p.kernel == Kernel::Linear).then(|| {
            let mut w = vec![0.0f64; dim];
            for (sv, coef) in support_vectors.chunks_exact(dim).zip(&dual_coef) {
                for (wk, xk) in w.iter_mut().zip(sv) {
                    *wk += coef * f64::from(*xk);
                }
            }
            w
        });
        let mut model = SvmModel {
            kernel: p.kernel,
            dim,
            support_vectors,
            dual_coef,
            rho: solution.rho,
            weights,
            iterations: solution.iterations,
            unconverged_gap: solution.hit_iteration_limit.then_some(solution.kkt_gap),
            norms: Vec::new(),
            coef32: Vec::new(),
            blocks: Vec::new(),
        };
        model.prepare();
        let solved = DualStart {
            alpha: solution.alpha,
            margin,
        };
        Ok((model, solved))
    }
}

impl SvmModel {
    /// Precomputes what prediction needs; call after deserialising.
    pub fn prepare(&mut self) {
        self.norms = self
            .support_vectors
            .chunks_exact(self.dim)
            .map(|r| dot(r, r))
            .collect();
        let n = self.dual_coef.len();
        let padded = n.div_ceil(BLOCK) * BLOCK;
        self.coef32 = self.dual_coef.iter().map(|c| *c as f32).collect();
        self.coef32.resize(padded, 0.0);
        self.norms.resize(padded, 0.0);
        self.blocks = vec![0.0; padded * self.dim];
        for (i, sv) in self.support_vectors.chunks_exact(self.dim).enumerate() {
            let (b, k) = (i / BLOCK, i % BLOCK);
            for (j, v) in sv.iter().enumerate() {
                self.blocks[(b * self.dim + j) * BLOCK + k] = *v;
            }
        }
    }

    pub fn support_vector_count(&self) -> usize {
        self.dual_coef.len()
    }

    /// `sum_i coef_i K(sv_i, x) - rho`; positive means the positive class.
    pub fn decision(&self, x: &[f32]) -> f64 {
        if let Some(w) = &self.weights {
            return w.iter().zip(x).map(|(a, b)| a * f64::from(*b)).sum::<f64>() - self.rho;
        }
        let Kernel::Rbf { gamma } = self.kernel else {
            unreachable!("linear models predict through their weights")
        };
        predict::rbf_sum(self, gamma as f32, x) - self.rho
    }

    /// [`Self::decision`] of each row of `xs` (row-major, `dim` wide) into `out`, the same
    /// values one row at a time gives, faster for many rows.
    pub fn decisions(&self, xs: &[f32], out: &mut [f64]) {
        assert_eq!(
            xs.len(),
            self.dim * out.len(),
            "one output per {}-wide row",
            self.dim
        );
        match (&self.weights, self.kernel) {
            (None, Kernel::Rbf { gamma }) => {
                predict::rbf_sums(self, gamma as f32, xs, out);
                for d in out.iter_mut() {
                    *d -= self.rho;
                }
            }
            _ => {
                for (x, d) in xs.chunks_exact(self.dim).zip(out.iter_mut()) {
                    *d = self.decision(x);
                }
            }
        }
    }

    /// Whether one row is of the positive class: its decision value is above zero.
    pub fn predict(&self, x: &[f32]) -> bool {
        self.decision(x) > 0.0
    }
}

/// Synthetic rows for tests and benches (as scikit-learn's `make_classification`): `n`
/// rows of `dim` features, every `positive_every`-th row positive, each feature `spread`
/// times a seeded uniform draw in `[-1, 1)`, positive rows shifted by `shift`.
pub fn noisy_classes(
    n: usize,
    dim: usize,
    seed: u64,
    positive_every: usize,
    spread: f32,
    shift: f32,
) -> (Vec<f32>, Vec<bool>) {
    let mut state = seed;
    let mut next = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 40) as f32 / (1u64 << 24) as f32) * 2.0 - 1.0
    };
    let y: Vec<bool> = (0..n).map(|i| i % positive_every == 0).collect();
    let x = (0..n * dim)
        .map(|k| spread * next() + if y[k / dim] { shift } else { 0.0 })
        .collect();
    (x, y)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two noisy blobs: slip around (+1, +1), static around (-1, -1), plus a ring case.
    fn blobs(n: usize) -> (Vec<f32>, Vec<bool>) {
        let mut state = 99u64;
        let mut rand = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 11) as f64 / (1u64 << 53) as f64) as f32 - 0.5
        };
        let (mut x, mut y) = (Vec::new(), Vec::new());
        for i in 0..n {
            let slip = i % 3 == 0;
            let c = if slip { 1.0 } else { -1.0 };
            x.push(c + 1.5 * rand());
            x.push(c + 1.5 * rand());
            y.push(slip);
        }
        (x, y)
    }

    #[test]
    fn separates_blobs_with_either_kernel() {
        let (x, y) = blobs(300);
        for params in [SvmParams::linear(1.0), SvmParams::rbf(1.0, 0.5)] {
            let m = params.check().unwrap().fit(2, &x, &y).unwrap();
            let correct = (0..300)
                .filter(|&i| m.predict(&x[2 * i..2 * i + 2]) == y[i])
                .count();
            assert!(correct >= 280, "{params:?}: {correct}/300");
            assert!(m.support_vector_count() < 300);
        }
    }

    #[test]
    fn a_fit_stopped_at_its_iteration_limit_says_so_with_its_gap() {
        let (x, y) = blobs(300);
        let converged = SvmParams::rbf(1.0, 0.5)
            .check()
            .unwrap()
            .fit(2, &x, &y)
            .unwrap();
        assert_eq!(converged.unconverged_gap, None);
        let capped = SvmParams {
            max_iterations: Some(3),
            ..SvmParams::rbf(1.0, 0.5)
        }
        .check()
        .unwrap()
        .fit(2, &x, &y)
        .unwrap();
        let gap = capped.unconverged_gap.expect("stopped early");
        assert!(gap > 1e-3, "{gap}");
        assert_eq!(capped.iterations, 3);
        // the record survives the model file
        let text = serde_json::to_string(&capped).unwrap();
        let back: SvmModel = serde_json::from_str(&text).unwrap();
        assert_eq!(back.unconverged_gap, Some(gap));
    }

    #[test]
    fn a_linear_svm_converges_at_large_c() {
        // Overlapping classes with correlated features (as pin velocities are): most rows
        // end at C, where SMO's pair steps grow with C (issue 15 #23: 10 M steps and a gap
        // of 23 at C = 20 on the simulator's rows; here SMO took 2.6 M steps).
        let (x, signs) = linear_ipm::tests::overlapping(3000);
        let y: Vec<bool> = signs.iter().map(|s| *s > 0).collect();
        let m = SvmParams::linear(1000.0)
            .check()
            .unwrap()
            .fit(5, &x, &y)
            .unwrap();
        assert_eq!(m.unconverged_gap, None);
        assert!(m.iterations < 200, "{} iterations", m.iterations);
        let sum: f64 = m.dual_coef.iter().sum();
        assert!(sum.abs() < 1e-6, "{sum}");
    }

    #[test]
    fn dual_solution_satisfies_its_constraints() {
        let (x, y) = blobs(200);
        let c = 0.7;
        let m = SvmParams::rbf(c, 0.8)
            .check()
            .unwrap()
            .fit(2, &x, &y)
            .unwrap();
        // sum alpha_i y_i = 0 and 0 < alpha <= C
        let sum: f64 = m.dual_coef.iter().sum();
        assert!(sum.abs() < 1e-9, "{sum}");
        assert!(m.dual_coef.iter().all(|a| a.abs() <= c + 1e-12));
    }

    #[test]
    fn shrinking_and_cache_size_do_not_change_the_answer() {
        let (x, y) = blobs(400);
        let mut base = SvmParams::rbf(2.0, 0.5);
        base.tolerance = 1e-5;
        let a = base.check().unwrap().fit(2, &x, &y).unwrap();
        let mut other = base;
        other.shrinking = false;
        other.cache_mb = 0; // the minimum: two rows
        let b = other.check().unwrap().fit(2, &x, &y).unwrap();
        for i in 0..400 {
            let (da, db) = (
                a.decision(&x[2 * i..2 * i + 2]),
                b.decision(&x[2 * i..2 * i + 2]),
            );
            assert!((da - db).abs() < 1e-3, "row {i}: {da} vs {db}");
        }
    }

    #[test]
    fn a_fit_started_from_a_neighbours_solution_reaches_the_same_optimum_in_fewer_steps() {
        let (x, y) = blobs(900);
        let params = SvmParams::rbf(2.0, 0.5).check().unwrap();
        // the neighbour: the same rows but the last 60, as a sweep's previous n_slip cell
        let n0 = 840;
        let (_, solved0) = params.fit_from(2, &x[..2 * n0], &y[..n0], None).unwrap();
        let mut start = solved0.alpha.clone();
        start.resize(900, 0.0);
        let start = DualStart::from_alpha(start);
        let cold = params.fit(2, &x, &y).unwrap();
        let (warm, solved) = params.fit_from(2, &x, &y, Some(&start)).unwrap();
        assert!(
            warm.iterations < cold.iterations,
            "{} vs {}",
            warm.iterations,
            cold.iterations
        );
        assert_eq!(solved.alpha.len(), 900);
        // both within the stopping tolerance of the one optimum: same decisions to ~1e-3
        for i in 0..900 {
            let xi = &x[2 * i..2 * i + 2];
            let (a, b) = (cold.decision(xi), warm.decision(xi));
            assert!((a - b).abs() < 1e-2, "row {i}: {a} vs {b}");
        }
        // started from its own optimum, a fit has nothing left to do
        let (again, _) = params.fit_from(2, &x, &y, Some(&solved)).unwrap();
        assert_eq!(again.iterations, 0);
    }

    #[test]
    fn a_start_is_made_feasible_before_the_solver_uses_it() {
        let y = [1i8, 1, -1, -1];
        // out of [0, C], and the classes' sums unequal
        let a = smo::feasible_start(&[3.0, 0.5, f64::NAN, -1.0], &y, 2.0);
        assert!(a.iter().all(|v| (0.0..=2.0).contains(v)), "{a:?}");
        let balance: f64 = a.iter().zip(y).map(|(v, s)| v * f64::from(s)).sum();
        assert!(balance.abs() < 1e-12, "{a:?}");
        // and a fit from any start still converges to the cold fit's answer
        let (x, labels) = blobs(200);
        let params = SvmParams::rbf(1.0, 0.5).check().unwrap();
        let cold = params.fit(2, &x, &labels).unwrap();
        let junk = DualStart::from_alpha((0..200).map(|i| (i % 7) as f64).collect());
        let (warm, _) = params.fit_from(2, &x, &labels, Some(&junk)).unwrap();
        for i in 0..200 {
            let xi = &x[2 * i..2 * i + 2];
            assert!(
                (cold.decision(xi) - warm.decision(xi)).abs() < 1e-2,
                "row {i}"
            );
        }
    }

    #[test]
    fn invalid_hyperparameters_are_rejected_before_fitting() {
        assert!(SvmParams::rbf(0.0, 1.0).check().is_err());
        assert!(SvmParams::rbf(1.0, -1.0).check().is_err());
        assert!(SvmParams::linear(f64::NAN).check().is_err());
        let e = SvmParams::linear(1.0)
            .check()
            .unwrap()
            .fit(1, &[0.0, 1.0], &[false, false])
            .unwrap_err();
        assert!(matches!(e, SvmError::OneClass { .. }));
    }
}
