//! A model's scores on a set of trials, as `tmo evaluate --out` writes them and
//! `tmo report` reads them (the paper's offline results: macro F1 per classifier and
//! scope, per sensor for local models).

use super::dataset::Scope;
use super::metrics::Scores;

/// Format name in every evaluation file.
pub const EVALUATION_FORMAT: &str = "tmo-evaluation";

#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Evaluation {
    pub format: String,
    pub model: String,
    pub model_sha256: String,
    pub classifier: String,
    pub scope: Scope,
    pub n_slip: usize,
    pub trials: usize,
    pub rows: usize,
    pub overall: Scores,
    /// Per sensor (every model's scores on each sensor's frames).
    pub per_sensor: Vec<SensorScores>,
}

#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SensorScores {
    pub sensor: u8,
    pub scores: Scores,
}
