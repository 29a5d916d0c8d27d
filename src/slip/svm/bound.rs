//! Rows an RBF model surely calls static, found from its slip support vectors alone.
//!
//! Why: scoring a test set or a held-out fold needs only each row's class, and most rows
//! are static rows far from any slip. A decision is `P - N - rho`, where `P` sums the terms
//! of the support vectors with positive coefficients (slip rows, usually a small share) and
//! `N >= 0` the rest. When `rho > 0` and `P` (computed) falls short of `rho` by more than
//! rounding can explain, the full decision is not positive, so the row is static without
//! summing the other support vectors.
//!
//! The bound is exact about the class, not a tolerance: both sums add the very same `f32`
//! terms (each `coef * exp(-gamma d2)` is computed by the same operations whichever sum it
//! joins), and recursive summation of `n` terms errs by at most `(n - 1) u sum |t|`
//! (`u` the unit roundoff). So the computed full sum is at most `P (1 + n u) - N (1 - n u)`,
//! which is at most `P (1 + n u)`; the computed `P` is at least `P (1 - n u)`. [`FACTOR_SLACK`]
//! doubles the margin that leaves.

use super::SvmModel;

/// The margin's multiple of the worst-case rounding.
const FACTOR_SLACK: f64 = 2.0;
/// Covers the absolute (not relative) rounding of sums of subnormal `f32` terms.
const SUBNORMAL_SLACK: f64 = 1e-30;

/// The slip support vectors of a model, to tell rows it surely calls static.
#[derive(Debug, Clone)]
pub struct StaticBound {
    positive: SvmModel,
    /// A row is surely static when its computed `P` times this is below `rho`.
    factor: f64,
    rho: f64,
}

impl SvmModel {
    /// The bound for this model, when it can pay: an RBF model with `rho > 0` whose slip
    /// support vectors are at most half of them (else their sum costs as much as the
    /// decision it would save).
    pub fn static_bound(&self) -> Option<StaticBound> {
        if self.weights.is_some() || self.rho <= 0.0 {
            return None;
        }
        let positive_count = self.dual_coef.iter().filter(|c| **c > 0.0).count();
        if positive_count == 0 || 2 * positive_count > self.dual_coef.len() {
            return None;
        }
        let mut positive = SvmModel {
            support_vectors: Vec::with_capacity(positive_count * self.dim),
            dual_coef: Vec::with_capacity(positive_count),
            norms: Vec::new(),
            coef32: Vec::new(),
            blocks: Vec::new(),
            ..self.clone_header()
        };
        for (sv, c) in self
            .support_vectors
            .chunks_exact(self.dim)
            .zip(&self.dual_coef)
        {
            if *c > 0.0 {
                positive.support_vectors.extend_from_slice(sv);
                positive.dual_coef.push(*c);
            }
        }
        positive.rho = 0.0;
        positive.prepare();
        // Terms per f32 lane (the longer of the two sums) and the 64 lanes' f64 sum.
        let lane_terms = self.coef32.len().div_ceil(super::kernel::BLOCK) as f64;
        let worst = lane_terms * f64::from(f32::EPSILON) / 2.0 + 64.0 * f64::EPSILON;
        Some(StaticBound {
            positive,
            factor: 1.0 + FACTOR_SLACK * 2.0 * worst,
            rho: self.rho,
        })
    }

    /// The model's fields but its support vectors and what is derived from them.
    fn clone_header(&self) -> SvmModel {
        SvmModel {
            kernel: self.kernel,
            dim: self.dim,
            support_vectors: Vec::new(),
            dual_coef: Vec::new(),
            rho: self.rho,
            weights: None,
            iterations: self.iterations,
            unconverged_gap: self.unconverged_gap,
            norms: Vec::new(),
            coef32: Vec::new(),
            blocks: Vec::new(),
        }
    }
}

impl StaticBound {
    /// For each row of `xs` (row-major, scaled), whether the model surely calls it static
    /// (its decision is not positive); `false` means the full decision must tell.
    pub fn surely_static(&self, xs: &[f32]) -> Vec<bool> {
        let mut positive = vec![0.0; xs.len() / self.positive.dim];
        self.positive.decisions(xs, &mut positive);
        positive
            .iter()
            .map(|p| p * self.factor + SUBNORMAL_SLACK < self.rho)
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use crate::slip::svm::SvmParams;

    #[test]
    fn rows_surely_static_are_those_the_full_decision_calls_static() {
        // A few slip rows in a cloud of static ones, as in a test set: most rows are far
        // from every slip row.
        let (n, dim) = (900, 6);
        let (x, y) = crate::slip::svm::noisy_classes(n, dim, 17, 9, 2.0, 1.5);
        let mut checked = 0;
        for (c, gamma) in [(1.0, 0.5), (10.0, 2.0), (100.0, 0.1)] {
            let model = SvmParams::rbf(c, gamma)
                .check()
                .unwrap()
                .fit(dim, &x, &y)
                .unwrap();
            let Some(bound) = model.static_bound() else {
                continue;
            };
            // the training rows, then rows on a line from the static cloud out past the
            // slip rows, where the slip rows' sum alone crosses rho
            let mut scored = x.clone();
            for step in 0..2000 {
                let t = -2.0 + 8.0 * step as f32 / 2000.0;
                scored.extend((0..dim).map(|_| 1.5 * t));
            }
            let rows = scored.len() / dim;
            let sure = bound.surely_static(&scored);
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
