//! Scores of a binary slip classifier (paper, "Classifier Evaluation"): F1 of each class and
//! their mean (macro F1), with precision, recall and the confusion counts, under the names
//! evaluation files use (slip and static). The arithmetic is `tmo_learn::metrics`'s
//! (scikit-learn's, with `zero_division=0`).

use super::Class;

/// Confusion counts with `slip` as the positive class.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub struct Confusion {
    pub true_slip: u64,
    pub false_slip: u64,
    pub true_static: u64,
    pub false_static: u64,
}

pub use tmo_learn::metrics::ClassScores;

#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct Scores {
    pub confusion: Confusion,
    pub slip: ClassScores,
    /// `static` in files (files written before this name was fixed say `static_`).
    #[serde(rename = "static", alias = "static_")]
    pub static_: ClassScores,
    pub macro_f1: f64,
}

impl Confusion {
    pub fn add(&mut self, truth: Class, predicted: Class) {
        match (truth, predicted) {
            (Class::Slip, Class::Slip) => self.true_slip += 1,
            (Class::Static, Class::Slip) => self.false_slip += 1,
            (Class::Static, Class::Static) => self.true_static += 1,
            (Class::Slip, Class::Static) => self.false_static += 1,
        }
    }

    pub fn from_pairs(truth: &[Class], predicted: &[Class]) -> Self {
        assert_eq!(truth.len(), predicted.len(), "one prediction per label");
        let mut c = Self::default();
        for (&t, &p) in truth.iter().zip(predicted) {
            c.add(t, p);
        }
        c
    }

    pub fn scores(&self) -> Scores {
        let (slip, static_) = tmo_learn::metrics::BinaryConfusion {
            true_positive: self.true_slip,
            false_positive: self.false_slip,
            true_negative: self.true_static,
            false_negative: self.false_static,
        }
        .class_scores();
        Scores {
            confusion: *self,
            slip,
            static_,
            macro_f1: 0.5 * (slip.f1 + static_.f1),
        }
    }
}

/// Below this slip recall, on rows that hold slip, a model counts as one that detects
/// (almost) no slip: it scores well on static rows and never fires on a new trial.
pub const ALMOST_NO_SLIP_RECALL: f64 = 0.05;

impl Scores {
    /// Whether these rows held slip and the model found almost none of it.
    pub fn detects_almost_no_slip(&self) -> bool {
        self.slip.support > 0 && self.slip.recall < ALMOST_NO_SLIP_RECALL
    }
}

/// Macro F1 of predictions against labels.
pub fn macro_f1(truth: &[Class], predicted: &[Class]) -> f64 {
    Confusion::from_pairs(truth, predicted).scores().macro_f1
}

#[cfg(test)]
mod tests {
    use super::*;
    use Class::{Slip as P, Static as N};

    #[test]
    fn a_model_that_finds_almost_no_slip_is_told_apart() {
        let scores = |found: usize, slip: usize| {
            let truth: Vec<Class> = (0..100).map(|i| if i < slip { P } else { N }).collect();
            let pred: Vec<Class> = (0..100).map(|i| if i < found { P } else { N }).collect();
            Confusion::from_pairs(&truth, &pred).scores()
        };
        assert!(scores(0, 40).detects_almost_no_slip());
        assert!(scores(1, 40).detects_almost_no_slip());
        assert!(!scores(2, 40).detects_almost_no_slip());
        // rows without slip say nothing about it
        assert!(!scores(0, 0).detects_almost_no_slip());
    }

    #[test]
    fn hand_computed_scores() {
        // truth:     P P P N N N N N
        // predicted: P P N P N N N N
        let truth = [P, P, P, N, N, N, N, N];
        let pred = [P, P, N, P, N, N, N, N];
        let s = Confusion::from_pairs(&truth, &pred).scores();
        assert_eq!(
            s.confusion,
            Confusion {
                true_slip: 2,
                false_slip: 1,
                true_static: 4,
                false_static: 1
            }
        );
        assert!((s.slip.precision - 2.0 / 3.0).abs() < 1e-12);
        assert!((s.slip.recall - 2.0 / 3.0).abs() < 1e-12);
        assert!((s.static_.f1 - 0.8).abs() < 1e-12);
        assert!((s.macro_f1 - (2.0 / 3.0 + 0.8) / 2.0).abs() < 1e-12);
        assert_eq!(s.slip.support, 3);
    }

    #[test]
    fn scores_are_written_with_a_static_key_and_read_with_either() {
        let s = Scores::default();
        let text = serde_json::to_string(&s).unwrap();
        assert!(
            text.contains("\"static\":") && !text.contains("static_"),
            "{text}"
        );
        let old = text.replace("\"static\":", "\"static_\":");
        assert_eq!(serde_json::from_str::<Scores>(&old).unwrap(), s);
    }

    #[test]
    fn predicting_only_static_scores_zero_for_slip() {
        let s = Confusion::from_pairs(&[P, N, N], &[N, N, N]).scores();
        assert_eq!(s.slip.f1, 0.0);
        assert!((s.static_.f1 - 0.8).abs() < 1e-12);
        assert!((s.macro_f1 - 0.4).abs() < 1e-12);
    }
}
