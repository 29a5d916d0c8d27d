//! Slip detection: features from pin frames, labels from the marker track, classifiers and
//! their scores (SPEC.md, "Slip detection method"). Usable without any hardware.

pub mod classifier;
pub mod cross_validation;
pub mod dataset;
pub mod evaluation;
pub mod features;
pub mod labels;
pub mod metrics;
pub mod model;
pub mod onnx;
pub mod search_range;
pub mod slip_model;
pub mod sweep;
pub mod sweep_file;
pub mod threshold;
pub mod trees;
pub mod tuning;
pub mod warm;

// The classifiers themselves live in `tmo-learn`; they are re-exported here under the names
// the rest of the application has always used.
pub use tmo_learn::{bayes, cholesky, logreg, scaler, svm};

/// The two classes of a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Class {
    Static,
    Slip,
}

/// Slip is the class the classifiers learn to detect.
impl tmo_learn::Label for Class {
    fn is_positive(self) -> bool {
        self == Class::Slip
    }

    fn from_positive(positive: bool) -> Self {
        if positive {
            Class::Slip
        } else {
            Class::Static
        }
    }
}
