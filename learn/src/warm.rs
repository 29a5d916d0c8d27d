//! Starting a fit from a neighbouring fit's solution, row by row.
//!
//! Neighbouring fits (say, a sweep's cells that differ in one setting) often share most of
//! their training rows, in another order, with some rows dropped and some added. A row's
//! part of a solution is carried over by its identity `K` (any key the caller gives each
//! row): the SVM's dual variable and margin of a shared row; new rows start at zero, which
//! keeps the start feasible. The SVM's optimum is then reached within the same stopping
//! tolerance; the logistic regression's objective is strictly convex, so its optimum is the
//! same from any start.

use std::collections::HashMap;
use std::hash::Hash;

use crate::svm::DualStart;

/// A finished fit's solution, kept to start the next fit near it.
#[derive(Debug, Clone, PartialEq)]
pub enum WarmStart<K: Hash + Eq> {
    /// The RBF SVM's dual variable of every training row that has one (the rest are zero),
    /// and every row's margin `y f(x)`, which lets a large fit begin with the rows near the
    /// margin.
    Svm { rows: HashMap<K, SvmRow> },
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

impl<K: Hash + Eq> WarmStart<K> {
    /// Keeps the part of `solved` of each row, the rows named by `keys` in the fit's order.
    pub fn svm(keys: impl IntoIterator<Item = K>, solved: &DualStart) -> Self {
        let margin = |i: usize| solved.margin.get(i).map_or(f32::NAN, |&m| m as f32);
        let rows = keys
            .into_iter()
            .enumerate()
            .map(|(i, key)| {
                let alpha = solved.alpha.get(i).copied().unwrap_or(0.0);
                (
                    key,
                    SvmRow {
                        alpha,
                        margin: margin(i),
                    },
                )
            })
            .filter(|(_, row)| row.alpha > 0.0 || !row.margin.is_nan())
            .collect();
        WarmStart::Svm { rows }
    }

    /// The start for the rows `keys` names, in the next fit's order: a row seen before
    /// keeps its dual variable and margin, a new one starts at zero with an unknown (NaN)
    /// margin. `None` for a logistic regression's start.
    pub fn svm_start_for(&self, keys: impl IntoIterator<Item = K>) -> Option<DualStart> {
        let WarmStart::Svm { rows } = self else {
            return None;
        };
        let (alpha, margin) = keys
            .into_iter()
            .map(|key| {
                rows.get(&key)
                    .map_or((0.0, f64::NAN), |r| (r.alpha, f64::from(r.margin)))
            })
            .unzip();
        Some(DualStart { alpha, margin })
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

    #[test]
    fn a_rows_dual_variable_and_margin_follow_the_row_and_new_rows_start_at_zero() {
        let solved = DualStart {
            alpha: vec![0.5, 0.0, 2.0],
            margin: vec![0.75, 1.5, 1.0],
        };
        let start = WarmStart::svm(["a", "b", "c"], &solved);
        // Reordered, one row dropped, one new row.
        let got = start.svm_start_for(["c", "new", "a"]).unwrap();
        assert_eq!(got.alpha, vec![2.0, 0.0, 0.5]);
        assert_eq!(got.margin[0], 1.0);
        assert!(got.margin[1].is_nan(), "a new row's margin is unknown");
        assert_eq!(got.margin[2], 0.75);
        assert_eq!(start.logreg_theta(), None);
        // Without margins, only the dual variables are kept.
        let start = WarmStart::svm(
            ["a", "b", "c"],
            &DualStart::from_alpha(solved.alpha.clone()),
        );
        let got = start.svm_start_for(["c", "new", "a"]).unwrap();
        assert_eq!(got.alpha, vec![2.0, 0.0, 0.5]);
        assert!(got.margin.iter().all(|m| m.is_nan()));
    }

    #[test]
    fn a_logistic_regressions_start_gives_no_dual_start() {
        let start: WarmStart<u32> = WarmStart::LogReg {
            theta: vec![1.0, -2.0],
        };
        assert_eq!(start.svm_start_for([1, 2]), None);
        assert_eq!(start.logreg_theta(), Some(&[1.0, -2.0][..]));
    }
}
