//! Starting a fit from a neighbouring fit's solution.
//!
//! A sweep's cells of one classifier and one down-sampling `d` differ only in `n_slip`, and
//! their training rows are nested: the static rows are the same seeded draw, and cell `k`'s
//! slip rows are cell `k + 1`'s without the `(k + 1)`-th frame of each onset. So cell `k`'s
//! solution is a good start for cell `k + 1`: the SVM's dual variables of the shared rows
//! (new rows start at zero, which keeps the start feasible), the logistic regression's
//! weights. The SVM's optimum is then reached within the same stopping tolerance; the
//! logistic regression's objective is strictly convex, so its optimum is the same.

use std::collections::HashMap;

use super::dataset::Dataset;

/// A training row's identity across datasets cut from the same trials.
type RowKey = (u32, u8, u64);

fn key(data: &Dataset, i: usize) -> RowKey {
    (data.trial[i], data.sensor[i], data.seq[i])
}

/// A finished fit's solution, kept to start the next fit near it.
#[derive(Debug, Clone, PartialEq)]
pub enum WarmStart {
    /// The RBF SVM's dual variable of every training row that has one (the rest are zero).
    Svm { alpha: HashMap<RowKey, f64> },
    /// The logistic regression's weights, then its intercept.
    LogReg { theta: Vec<f64> },
}

impl WarmStart {
    /// Keeps the nonzero dual variables of `data`'s rows (`alpha` in `data`'s row order).
    pub fn svm(data: &Dataset, alpha: &[f64]) -> Self {
        let alpha = alpha
            .iter()
            .enumerate()
            .filter(|(_, a)| **a > 0.0)
            .map(|(i, a)| (key(data, i), *a))
            .collect();
        WarmStart::Svm { alpha }
    }

    /// The dual variables for `data`'s rows: the kept value of a row seen before, zero for
    /// a new one. `None` for a logistic regression's start.
    pub fn svm_alpha_for(&self, data: &Dataset) -> Option<Vec<f64>> {
        match self {
            WarmStart::Svm { alpha } => Some(
                (0..data.len())
                    .map(|i| alpha.get(&key(data, i)).copied().unwrap_or(0.0))
                    .collect(),
            ),
            WarmStart::LogReg { .. } => None,
        }
    }

    pub fn logreg_theta(&self) -> Option<&[f64]> {
        match self {
            WarmStart::LogReg { theta } => Some(theta),
            WarmStart::Svm { .. } => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::slip::Class;

    fn rows(keys: &[(u32, u8, u64)]) -> Dataset {
        let mut d = Dataset {
            dim: 1,
            trial_ids: vec!["a".into(), "b".into()],
            ..Default::default()
        };
        for &(t, s, q) in keys {
            d.x.push(0.0);
            d.y.push(Class::Static);
            d.trial.push(t);
            d.sensor.push(s);
            d.seq.push(q);
            d.time_s.push(0.0);
        }
        d
    }

    #[test]
    fn a_rows_dual_variable_follows_the_row_and_new_rows_start_at_zero() {
        let before = rows(&[(0, 0, 1), (0, 1, 1), (1, 0, 7)]);
        let start = WarmStart::svm(&before, &[0.5, 0.0, 2.0]);
        // Reordered, one row dropped, one new row.
        let after = rows(&[(1, 0, 7), (1, 2, 9), (0, 0, 1)]);
        assert_eq!(start.svm_alpha_for(&after), Some(vec![2.0, 0.0, 0.5]));
        assert_eq!(start.logreg_theta(), None);
    }
}
