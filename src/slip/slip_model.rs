//! A slip model wherever one is taken (evaluate, replay, a protocol's `models`): a model
//! file of tmo's own, or an ONNX model brought from elsewhere (`.onnx`). Both are read,
//! checked and scored the same way; only tmo's own can be trained here.

use std::path::Path;

use super::dataset::{Dataset, LabelSpec, Scope, TrialRef};
use super::features::FeatureSpec;
use super::metrics::Scores;
use super::model::{ModelFile, ModelFileError};
use super::onnx::OnnxModel;
use super::Class;

/// The classifier name of every ONNX model, in evaluations and tables.
pub const ONNX_CLASSIFIER: &str = "onnx";

#[derive(Debug, Clone)]
pub enum SlipModel {
    Tmo(ModelFile),
    Onnx(OnnxModel),
}

impl From<ModelFile> for SlipModel {
    fn from(m: ModelFile) -> Self {
        SlipModel::Tmo(m)
    }
}

/// What [`SlipModel::evaluate`] gives: scores overall and per sensor, and how many rows had
/// no full window (a windowed model's first frames of each trial and sensor, scored static).
#[derive(Debug, Clone, PartialEq)]
pub struct Evaluated {
    pub overall: Scores,
    pub per_sensor: Vec<(u8, Scores)>,
    pub rows_without_window: usize,
}

impl SlipModel {
    /// Reads `path`: an ONNX model by its `.onnx` extension, else a model file of tmo's own.
    pub fn load(path: &Path) -> Result<Self, ModelFileError> {
        if path.is_dir() {
            return Err(ModelFileError::Directory {
                path: path.display().to_string(),
            });
        }
        if is_onnx(path) {
            Ok(SlipModel::Onnx(OnnxModel::load(path)?))
        } else {
            Ok(SlipModel::Tmo(ModelFile::load(path)?))
        }
    }

    pub fn features(&self) -> &FeatureSpec {
        match self {
            SlipModel::Tmo(m) => &m.features,
            SlipModel::Onnx(m) => &m.meta.features,
        }
    }

    pub fn labels(&self) -> &LabelSpec {
        match self {
            SlipModel::Tmo(m) => &m.labels,
            SlipModel::Onnx(m) => &m.meta.labels,
        }
    }

    /// The sensors it was trained on.
    pub fn sensors(&self) -> &[u8] {
        match self {
            SlipModel::Tmo(m) => &m.sensors,
            SlipModel::Onnx(m) => &m.meta.sensors,
        }
    }

    /// An ONNX model is one graph for every sensor: global.
    pub fn scope(&self) -> Scope {
        match self {
            SlipModel::Tmo(m) => m.scope,
            SlipModel::Onnx(_) => Scope::Global,
        }
    }

    /// The classifier's name for tables: `svm`, `logreg`, `threshold` or `onnx`.
    pub fn classifier_name(&self) -> &'static str {
        match self {
            SlipModel::Tmo(m) => m.classifier.name(),
            SlipModel::Onnx(_) => ONNX_CLASSIFIER,
        }
    }

    /// The model's name in tables: an ONNX model's `tmo.name`, else the file's stem.
    pub fn name(&self, path: &Path) -> String {
        match self {
            SlipModel::Onnx(m) => m.meta.name.clone(),
            SlipModel::Tmo(_) => file_stem(path),
        }
    }

    /// Frames each classification reads (1 for every model of tmo's own).
    pub fn window(&self) -> usize {
        match self {
            SlipModel::Tmo(_) => 1,
            SlipModel::Onnx(m) => m.meta.window,
        }
    }

    /// Whether it can classify the frames of `sensors` fingertips of `pins` pins each (see
    /// [`ModelFile::fits`]).
    pub fn fits(&self, sensors: usize, pins: usize) -> Result<(), String> {
        match self {
            SlipModel::Tmo(m) => m.fits(sensors, pins),
            SlipModel::Onnx(m) if m.meta.features.pins != pins => Err(format!(
                "tmo.features pins = {}, but the fingertips report {pins} pins each; export a model for this rig's frames",
                m.meta.features.pins
            )),
            SlipModel::Onnx(_) => Ok(()),
        }
    }

    /// A trial shorter than the window never gets a class: refused where the trial is known.
    pub fn fits_frames(&self, frames_per_sensor: usize) -> Result<(), String> {
        let k = self.window();
        if frames_per_sensor > 0 && frames_per_sensor < k {
            return Err(format!(
                "the model reads a window of {k} frames (tmo.window), longer than the trial ({frames_per_sensor} frames per sensor): it could never classify a frame"
            ));
        }
        Ok(())
    }

    /// The trials of `data` too short for the window (fewer frames with features than the
    /// window, for some sensor), by index into `data.trial_ids`, each with that count,
    /// shortest first.
    pub fn short_trials(&self, data: &Dataset) -> Vec<(u32, usize)> {
        let mut rows: std::collections::BTreeMap<(u32, u8), usize> = Default::default();
        for (&t, &s) in data.trial.iter().zip(&data.sensor) {
            *rows.entry((t, s)).or_default() += 1;
        }
        let mut per_trial: std::collections::BTreeMap<u32, usize> = Default::default();
        for ((t, _), n) in rows {
            let shortest = per_trial.entry(t).or_insert(n);
            *shortest = (*shortest).min(n);
        }
        let mut short: Vec<(u32, usize)> = per_trial
            .into_iter()
            .filter(|&(_, n)| self.fits_frames(n).is_err())
            .collect();
        short.sort_by_key(|&(_, n)| n);
        short
    }

    /// [`Self::fits_frames`] for every trial of `data` (each trial's frames with features,
    /// per sensor): the error names the shortest trial that does not fit.
    pub fn fits_trials(&self, data: &Dataset) -> Result<(), String> {
        match self.short_trials(data).first() {
            Some(&(t, n)) => self
                .fits_frames(n)
                .map_err(|e| format!("trial {}: {e}", data.trial_ids[t as usize])),
            None => Ok(()),
        }
    }

    /// Scores on every row of `data` (never down-sampled), overall and per sensor.
    pub fn evaluate(&self, data: &Dataset) -> Result<Evaluated, ModelFileError> {
        match self {
            SlipModel::Tmo(m) => {
                let (overall, per_sensor) = m.evaluate(data)?;
                Ok(Evaluated {
                    overall,
                    per_sensor,
                    rows_without_window: 0,
                })
            }
            SlipModel::Onnx(m) => {
                let (predicted, without) = m.predict_rows(data)?;
                let rows: Vec<usize> = (0..data.len()).collect();
                let (overall, per_sensor) = super::model::scores_by_sensor(data, &rows, &predicted);
                Ok(Evaluated {
                    overall,
                    per_sensor,
                    rows_without_window: without,
                })
            }
        }
    }

    /// Each row's slip value and class, as the online loop reads them: an ONNX model's
    /// output as its metadata states it, a tmo model's decision value (positive for slip);
    /// `None` for a row that has no full window. A non-finite value is an error naming the
    /// trial and frame.
    pub fn row_values(&self, data: &Dataset) -> Result<Vec<Option<(f32, Class)>>, ModelFileError> {
        match self {
            SlipModel::Onnx(m) => Ok(m
                .slip_values(data)?
                .into_iter()
                .map(|v| v.map(|v| (v, m.class_of(v))))
                .collect()),
            SlipModel::Tmo(m) => {
                let mut scratch = Vec::new();
                (0..data.len())
                    .map(|i| {
                        let model = m.for_sensor(data.sensor[i]).ok_or_else(|| {
                            ModelFileError::NoSensor {
                                path: "model".into(),
                                sensor: data.sensor[i],
                            }
                        })?;
                        let decision = model.decision(data.row(i), &mut scratch);
                        Ok(Some((decision as f32, model.class_of(decision))))
                    })
                    .collect()
            }
        }
    }

    /// The trials of `refs` it was trained on (an ONNX model does not say: none).
    pub fn trained_on<'a>(&self, refs: &'a [TrialRef]) -> Vec<&'a TrialRef> {
        match self {
            SlipModel::Tmo(m) => m.trained_on(refs),
            SlipModel::Onnx(_) => Vec::new(),
        }
    }

    /// Whether the trial log whose SHA-256 is `sha256` is one of its training trials (an
    /// ONNX model does not say: no).
    pub fn trained_on_log(&self, sha256: &str) -> bool {
        match self {
            SlipModel::Tmo(m) => m.trained_on_log(sha256),
            SlipModel::Onnx(_) => false,
        }
    }

    /// The sensors of `sensors` a global model never saw in training.
    pub fn unseen_sensors(&self, sensors: &[u8]) -> Vec<u8> {
        match self {
            SlipModel::Tmo(m) => m.unseen_sensors(sensors),
            SlipModel::Onnx(m) => sensors
                .iter()
                .copied()
                .filter(|s| !m.meta.sensors.contains(s))
                .collect(),
        }
    }
}

/// A file's stem (`svm` of `models/svm.json`), else the path as given.
pub fn file_stem(path: &Path) -> String {
    path.file_stem().map_or_else(
        || path.display().to_string(),
        |s| s.to_string_lossy().into_owned(),
    )
}

/// Each model's name in tables ([`SlipModel::name`]), unique among them: where two share
/// a name (`a/svm.json` and `b/svm.json`), those are named by their paths as given.
pub fn unique_names<'a>(
    models: impl IntoIterator<Item = (&'a Path, &'a SlipModel)>,
) -> Vec<String> {
    let models: Vec<(&Path, &SlipModel)> = models.into_iter().collect();
    let names: Vec<String> = models.iter().map(|(p, m)| m.name(p)).collect();
    names
        .iter()
        .zip(&models)
        .map(|(n, (p, _))| {
            if names.iter().filter(|o| *o == n).count() > 1 {
                p.display().to_string()
            } else {
                n.clone()
            }
        })
        .collect()
}

/// Whether `path` names an ONNX model (by its extension, as exporters write them).
pub fn is_onnx(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("onnx"))
}
