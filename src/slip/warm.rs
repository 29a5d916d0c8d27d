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
use super::svm::DualStart;

/// A training row's identity across datasets cut from the same trials.
type RowKey = (u32, u8, u64);

fn key(data: &Dataset, i: usize) -> RowKey {
    (data.trial[i], data.sensor[i], data.seq[i])
}

/// A finished fit's solution, kept to start the next fit near it.
#[derive(Debug, Clone, PartialEq)]
pub enum WarmStart {
    /// The RBF SVM's dual variable of every training row that has one (the rest are zero),
    /// and every row's margin `y f(x)`, which lets a large fit begin with the rows near the
    /// margin.
    Svm { rows: HashMap<RowKey, SvmRow> },
    /// The logistic regression's weights, then its intercept.
    LogReg { theta: Vec<f64> },
}

/// A training row's part of an SVM's solution.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SvmRow {
    pub alpha: f64,
    /// NaN where the fit did not give one.
    pub margin: f32,
}

impl WarmStart {
    /// Keeps `data`'s rows' part of `solved` (in `data`'s row order).
    pub fn svm(data: &Dataset, solved: &DualStart) -> Self {
        let margin = |i: usize| solved.margin.get(i).map_or(f32::NAN, |&m| m as f32);
        let rows = (0..data.len())
            .map(|i| {
                let alpha = solved.alpha.get(i).copied().unwrap_or(0.0);
                let row = SvmRow {
                    alpha,
                    margin: margin(i),
                };
                (key(data, i), row)
            })
            .filter(|(_, row)| row.alpha > 0.0 || !row.margin.is_nan())
            .collect();
        WarmStart::Svm { rows }
    }

    /// The start for `data`'s rows: a row seen before keeps its dual variable and margin,
    /// a new one starts at zero with an unknown (NaN) margin. `None` for a logistic
    /// regression's start.
    pub fn svm_start_for(&self, data: &Dataset) -> Option<DualStart> {
        match self {
            WarmStart::Svm { rows } => {
                let row = |i: usize| rows.get(&key(data, i));
                Some(DualStart {
                    alpha: (0..data.len())
                        .map(|i| row(i).map_or(0.0, |r| r.alpha))
                        .collect(),
                    margin: (0..data.len())
                        .map(|i| row(i).map_or(f64::NAN, |r| f64::from(r.margin)))
                        .collect(),
                })
            }
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
    fn a_rows_dual_variable_and_margin_follow_the_row_and_new_rows_start_at_zero() {
        let before = rows(&[(0, 0, 1), (0, 1, 1), (1, 0, 7)]);
        let solved = DualStart {
            alpha: vec![0.5, 0.0, 2.0],
            margin: vec![0.75, 1.5, 1.0],
        };
        let start = WarmStart::svm(&before, &solved);
        // Reordered, one row dropped, one new row.
        let after = rows(&[(1, 0, 7), (1, 2, 9), (0, 0, 1)]);
        let got = start.svm_start_for(&after).unwrap();
        assert_eq!(got.alpha, vec![2.0, 0.0, 0.5]);
        assert_eq!(got.margin[0], 1.0);
        assert!(got.margin[1].is_nan(), "a new row's margin is unknown");
        assert_eq!(got.margin[2], 0.75);
        assert_eq!(start.logreg_theta(), None);
        // Without margins, only the dual variables are kept.
        let start = WarmStart::svm(&before, &DualStart::from_alpha(solved.alpha.clone()));
        let got = start.svm_start_for(&after).unwrap();
        assert_eq!(got.alpha, vec![2.0, 0.0, 0.5]);
        assert!(got.margin.iter().all(|m| m.is_nan()));
    }
}
