//! A threshold on one score per row: positive where the score reaches `T`. `T` is the best
//! (by macro F1 on the training rows) of ten values evenly spaced between the mean score of
//! the negative rows and that of the positive rows.

use crate::metrics::macro_f1;
use crate::Label;

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ThresholdError {
    #[error("training data needs rows of both classes (negative {negative}, positive {positive})")]
    OneClass { negative: usize, positive: usize },
}

/// The threshold for `scores` (one a row) against `labels`.
pub fn fit_threshold<L: Label>(scores: &[f32], labels: &[L]) -> Result<f32, ThresholdError> {
    let mean_of = |positive: bool| {
        let (sum, n) = scores
            .iter()
            .zip(labels)
            .filter(|(_, l)| l.is_positive() == positive)
            .fold((0.0f64, 0usize), |(s, n), (x, _)| {
                (s + f64::from(*x), n + 1)
            });
        (sum / n.max(1) as f64, n)
    };
    let (negative_mean, negative) = mean_of(false);
    let (positive_mean, positive) = mean_of(true);
    if negative == 0 || positive == 0 {
        return Err(ThresholdError::OneClass { negative, positive });
    }
    let truth: Vec<bool> = labels.iter().map(|l| l.is_positive()).collect();
    let mut best = (f64::NEG_INFINITY, 0.0f32);
    for k in 0..10 {
        let t = (negative_mean + (positive_mean - negative_mean) * k as f64 / 9.0) as f32;
        let predicted: Vec<bool> = scores.iter().map(|&x| x >= t).collect();
        let f1 = macro_f1(&truth, &predicted);
        if f1 > best.0 {
            best = (f1, t);
        }
    }
    Ok(best.1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn picks_a_threshold_between_the_class_means_that_separates_them() {
        let scores = [0.1, 0.2, 0.1, 0.15, 1.0, 1.2];
        let labels = [false, false, false, false, true, true];
        let t = fit_threshold(&scores, &labels).unwrap();
        assert!(t > 0.2 && t <= 1.0, "{t}");
    }

    #[test]
    fn one_class_is_an_error() {
        assert!(matches!(
            fit_threshold(&[0.1], &[false]),
            Err(ThresholdError::OneClass {
                negative: 1,
                positive: 0
            })
        ));
    }
}
