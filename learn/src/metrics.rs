//! Scores of a binary classifier: precision, recall and F1 of each class and their mean
//! (macro F1), as scikit-learn's `precision_recall_fscore_support` with `zero_division=0`:
//! where a ratio has a zero denominator (no predictions or no examples of a class) it is 0.

use crate::Label;

/// Confusion counts, the positive class first.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct BinaryConfusion {
    pub true_positive: u64,
    pub false_positive: u64,
    pub true_negative: u64,
    pub false_negative: u64,
}

/// Precision, recall and F1 of one class, and how many rows hold it.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct ClassScores {
    pub precision: f64,
    pub recall: f64,
    pub f1: f64,
    pub support: u64,
}

fn ratio(num: u64, den: u64) -> f64 {
    if den == 0 {
        0.0
    } else {
        num as f64 / den as f64
    }
}

/// The scores of a class with `tp` rows found, `fp` rows wrongly called it and `fn_` of its
/// rows missed.
pub fn class_scores(tp: u64, fp: u64, fn_: u64) -> ClassScores {
    let precision = ratio(tp, tp + fp);
    let recall = ratio(tp, tp + fn_);
    let f1 = if precision + recall == 0.0 {
        0.0
    } else {
        2.0 * precision * recall / (precision + recall)
    };
    ClassScores {
        precision,
        recall,
        f1,
        support: tp + fn_,
    }
}

impl BinaryConfusion {
    pub fn add(&mut self, truth: impl Label, predicted: impl Label) {
        match (truth.is_positive(), predicted.is_positive()) {
            (true, true) => self.true_positive += 1,
            (false, true) => self.false_positive += 1,
            (false, false) => self.true_negative += 1,
            (true, false) => self.false_negative += 1,
        }
    }

    /// The counts of predictions against labels, row for row.
    pub fn from_pairs<L: Label>(truth: &[L], predicted: &[L]) -> Self {
        assert_eq!(truth.len(), predicted.len(), "one prediction per label");
        let mut c = Self::default();
        for (&t, &p) in truth.iter().zip(predicted) {
            c.add(t, p);
        }
        c
    }

    /// The positive class's scores, then the negative class's.
    pub fn class_scores(&self) -> (ClassScores, ClassScores) {
        (
            class_scores(self.true_positive, self.false_positive, self.false_negative),
            class_scores(self.true_negative, self.false_negative, self.false_positive),
        )
    }

    /// The mean of the two classes' F1.
    pub fn macro_f1(&self) -> f64 {
        let (positive, negative) = self.class_scores();
        0.5 * (positive.f1 + negative.f1)
    }
}

/// Macro F1 of predictions against labels.
pub fn macro_f1<L: Label>(truth: &[L], predicted: &[L]) -> f64 {
    BinaryConfusion::from_pairs(truth, predicted).macro_f1()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hand_computed_scores() {
        // truth:     P P P N N N N N
        // predicted: P P N P N N N N
        let truth = [true, true, true, false, false, false, false, false];
        let pred = [true, true, false, true, false, false, false, false];
        let c = BinaryConfusion::from_pairs(&truth, &pred);
        assert_eq!(
            c,
            BinaryConfusion {
                true_positive: 2,
                false_positive: 1,
                true_negative: 4,
                false_negative: 1
            }
        );
        let (p, n) = c.class_scores();
        assert!((p.precision - 2.0 / 3.0).abs() < 1e-12);
        assert!((p.recall - 2.0 / 3.0).abs() < 1e-12);
        assert!((n.f1 - 0.8).abs() < 1e-12);
        assert!((c.macro_f1() - (2.0 / 3.0 + 0.8) / 2.0).abs() < 1e-12);
        assert_eq!(p.support, 3);
    }

    #[test]
    fn a_class_never_predicted_scores_zero() {
        let c = BinaryConfusion::from_pairs(&[true, false, false], &[false, false, false]);
        let (p, n) = c.class_scores();
        assert_eq!(p.f1, 0.0);
        assert!((n.f1 - 0.8).abs() < 1e-12);
        assert!((macro_f1(&[true, false, false], &[false, false, false]) - 0.4).abs() < 1e-12);
    }
}
