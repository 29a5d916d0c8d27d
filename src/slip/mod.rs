//! Slip detection: features from pin frames, labels from the marker track, classifiers and
//! their scores (SPEC.md, "Slip detection method"). Usable without any hardware.

pub mod bayes;
pub mod cholesky;
pub mod cross_validation;
pub mod dataset;
pub mod evaluation;
pub mod features;
pub mod labels;
pub mod logreg;
pub mod metrics;
pub mod model;
pub mod scaler;
pub mod search_range;
pub mod svm;
pub mod sweep;
pub mod sweep_file;
pub mod threshold;
pub mod tuning;
pub mod warm;

/// The two classes of a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Class {
    Static,
    Slip,
}
