//! Rows an RBF model surely calls negative, found from its positive support vectors alone.
//!
//! Why: scoring a test set or a held-out fold needs only each row's class, and most rows
//! are negative rows far from any positive one. A decision is `P - N - rho`, where `P` sums the terms
//! of the support vectors with positive coefficients (the positive class's rows, usually the smaller share) and
//! `N >= 0` the rest. When `rho > 0` and `P` (computed) falls short of `rho` by more than
//! rounding can explain, the full decision is not positive, so the row is negative without
//! summing the other support vectors.
//!
//! The bound is exact about the class, not a tolerance: both sums add the very same `f32`
//! terms (each `coef * exp(-gamma d2)` is computed by the same operations whichever sum it
//! joins), and recursive summation of `n` terms errs by at most `(n - 1) u sum |t|`
//! (`u` the unit roundoff). So the computed full sum is at most `P (1 + n u) - N (1 - n u)`,
//! which is at most `P (1 + n u)`; the computed `P` is at least `P (1 - n u)`. [`FACTOR_SLACK`]
//! doubles the margin that leaves.

use std::sync::atomic::{AtomicUsize, Ordering};

use super::SvmModel;

/// The margin's multiple of the worst-case rounding.
const FACTOR_SLACK: f64 = 2.0;
/// Covers the absolute (not relative) rounding of sums of subnormal `f32` terms.
const SUBNORMAL_SLACK: f64 = 1e-30;

/// The positive support vectors of a model, to tell rows it surely calls negative.
#[derive(Debug, Clone)]
pub struct NegativeBound {
    positive: SvmModel,
    /// A row is surely negative when its computed `P` times this is below `rho`.
    factor: f64,
    rho: f64,
}

impl SvmModel {
    /// The bound for this model, when it can pay: an RBF model with `rho > 0` whose positive
    /// support vectors are at most half of them (else their sum costs as much as the
    /// decision it would save).
    pub fn negative_bound(&self) -> Option<NegativeBound> {
        if self.weights.is_some() || self.rho <= 0.0 {
            return None;
        }
        let positive_count = self.dual_coef.iter().filter(|c| **c > 0.0).count();
        if positive_count == 0 || 2 * positive_count > self.dual_coef.len() {
            return None;
        }
        let (mut support_vectors, mut dual_coef) = (Vec::new(), Vec::new());
        for (sv, c) in self
            .support_vectors
            .chunks_exact(self.dim)
            .zip(&self.dual_coef)
        {
            if *c > 0.0 {
                support_vectors.extend_from_slice(sv);
                dual_coef.push(*c);
            }
        }
        let mut positive = SvmModel {
            kernel: self.kernel,
            dim: self.dim,
            support_vectors,
            dual_coef,
            rho: 0.0,
            weights: None,
            iterations: self.iterations,
            unconverged_gap: self.unconverged_gap,
            norms: Vec::new(),
            coef32: Vec::new(),
            blocks: Vec::new(),
        };
        positive.prepare();
        // Terms per f32 lane (the longer of the two sums) and the 64 lanes' f64 sum.
        let lane_terms = self.coef32.len().div_ceil(super::kernel::BLOCK) as f64;
        let worst = lane_terms * f64::from(f32::EPSILON) / 2.0 + 64.0 * f64::EPSILON;
        Some(NegativeBound {
            positive,
            factor: 1.0 + FACTOR_SLACK * 2.0 * worst,
            rho: self.rho,
        })
    }
}

impl NegativeBound {
    /// For each row of `xs` (row-major, scaled), whether the model surely calls it negative
    /// (its decision is not positive); `false` means the full decision must tell.
    pub fn surely_negative(&self, xs: &[f32]) -> Vec<bool> {
        let mut positive = vec![0.0; xs.len() / self.positive.dim];
        self.positive.decisions(xs, &mut positive);
        positive
            .iter()
            .map(|p| p * self.factor + SUBNORMAL_SLACK < self.rho)
            .collect()
    }
}

/// Whether each row's decision is positive, for scoring many rows in pieces (possibly in
/// parallel): rows the model's [`NegativeBound`] shows negative are spared the full sum while
/// the bound keeps sparing at least half the rows it is tried on (else its own sum only
/// adds work). Which pieces try it may vary between runs; the answers do not.
#[derive(Debug)]
pub struct PositiveScoring<'a> {
    model: &'a SvmModel,
    bound: Option<NegativeBound>,
    tried: AtomicUsize,
    spared: AtomicUsize,
}

impl SvmModel {
    pub fn positive_scoring(&self) -> PositiveScoring<'_> {
        PositiveScoring {
            model: self,
            bound: self.negative_bound(),
            tried: AtomicUsize::new(0),
            spared: AtomicUsize::new(0),
        }
    }
}

impl PositiveScoring<'_> {
    /// Rows tried before judging the bound, and the share of them it must spare.
    const TRIAL_ROWS: usize = 2048;
    const MIN_SPARED_SHARE: f64 = 0.5;

    /// For each row of `xs` (row-major, scaled; reused as scratch), whether the model's
    /// decision is positive, as [`SvmModel::decisions`] would say.
    pub fn positive(&self, mut xs: Vec<f32>) -> Vec<bool> {
        let dim = self.model.dim;
        let n = xs.len() / dim;
        let sure = match &self.bound {
            Some(bound) if self.bound_pays() => {
                let sure = bound.surely_negative(&xs);
                self.tried.fetch_add(n, Ordering::Relaxed);
                let spared = sure.iter().filter(|s| **s).count();
                self.spared.fetch_add(spared, Ordering::Relaxed);
                sure
            }
            _ => vec![false; n],
        };
        // the rows left, packed to the front
        let mut left = 0;
        for (i, s) in sure.iter().enumerate() {
            if !s {
                xs.copy_within(i * dim..(i + 1) * dim, left * dim);
                left += 1;
            }
        }
        let mut decisions = vec![0.0; left];
        self.model.decisions(&xs[..left * dim], &mut decisions);
        let mut decided = decisions.into_iter();
        sure.iter()
            .map(|s| !s && decided.next().expect("one decision per row left") > 0.0)
            .collect()
    }

    fn bound_pays(&self) -> bool {
        let tried = self.tried.load(Ordering::Relaxed);
        tried < Self::TRIAL_ROWS
            || self.spared.load(Ordering::Relaxed) as f64 >= Self::MIN_SPARED_SHARE * tried as f64
    }
}

#[cfg(test)]
mod tests {
    use crate::svm::SvmParams;

    #[test]
    fn rows_surely_negative_are_those_the_full_decision_calls_negative() {
        // A few positive rows in a cloud of negative ones, as in a test set: most rows are far
        // from every positive row.
        let (n, dim) = (900, 6);
        let (x, y) = crate::svm::noisy_classes(n, dim, 17, 9, 2.0, 1.5);
        let mut checked = 0;
        for (c, gamma) in [(1.0, 0.5), (10.0, 2.0), (100.0, 0.1)] {
            let model = SvmParams::rbf(c, gamma)
                .check()
                .unwrap()
                .fit(dim, &x, &y)
                .unwrap();
            let Some(bound) = model.negative_bound() else {
                continue;
            };
            // the training rows, then rows on a line from the negative cloud out past the
            // positive rows, where the positive rows' sum alone crosses rho
            let mut scored = x.clone();
            for step in 0..2000 {
                let t = -2.0 + 8.0 * step as f32 / 2000.0;
                scored.extend((0..dim).map(|_| 1.5 * t));
            }
            let rows = scored.len() / dim;
            let sure = bound.surely_negative(&scored);
            let mut full = vec![0.0; rows];
            model.decisions(&scored, &mut full);
            for (i, (s, d)) in sure.iter().zip(&full).enumerate() {
                assert!(!s || *d <= 0.0, "C {c} gamma {gamma}: row {i} sure but {d}");
            }
            let sure_count = sure[..n].iter().filter(|s| **s).count();
            assert!(sure_count > n / 2, "C {c} gamma {gamma}: {sure_count} sure");
            checked += 1;
        }
        assert!(checked >= 2, "{checked} models had a bound");
    }
}
