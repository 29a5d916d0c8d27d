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

impl Evaluation {
    /// The evaluation of the model file at `path` (hashed here, so the file is named by
    /// its content) over `trials` trials and `rows` rows.
    pub fn of(
        path: &std::path::Path,
        model: &super::slip_model::SlipModel,
        trials: usize,
        rows: usize,
        overall: Scores,
        per_sensor: Vec<(u8, Scores)>,
    ) -> Result<Self, std::io::Error> {
        let bytes = std::fs::read(path)?;
        Ok(Self {
            format: EVALUATION_FORMAT.into(),
            model: path.display().to_string(),
            model_sha256: crate::trial::sha256_hex(&bytes),
            classifier: model.classifier_name().to_string(),
            scope: model.scope(),
            n_slip: model.labels().n_slip,
            trials,
            rows,
            overall,
            per_sensor: per_sensor
                .into_iter()
                .map(|(sensor, scores)| SensorScores { sensor, scores })
                .collect(),
        })
    }
}
