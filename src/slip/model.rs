//! Trained slip models and their files: versioned, self-describing JSON with everything
//! needed to use and to trust the model (feature and label specs, scaler, classifier and
//! its parameters, scope and sensors, training trials with hashes, training scores).

use std::path::Path;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

pub use super::classifier::{scale_gamma, ClassifierKind, Hyperparameters};
pub use super::dataset::TrialRef;
use super::dataset::{Dataset, LabelSpec, Scope};
use super::features::FeatureSpec;
use super::logreg::{LogRegModel, LogRegParams};
use super::metrics::{Confusion, Scores};
use super::scaler::Scaler;
use super::svm::{SvmModel, SvmParams};
use super::threshold::ThresholdModel;
use super::warm::{row_keys, WarmStart};
use super::Class;
use tmo_learn::Label;

pub const MODEL_FORMAT: &str = "tmo-slip-model";
pub const MODEL_FORMAT_VERSION: u32 = 1;

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum Classifier {
    Threshold(ThresholdModel),
    Svm(SvmModel),
    LogReg(LogRegModel),
}

/// One classifier with its scaler: for one sensor (local) or all (global).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorModel {
    /// `None` for a global model.
    pub sensor: Option<u8>,
    /// Absent for the threshold classifier, which works on raw pin speeds.
    pub scaler: Option<Scaler>,
    pub classifier: Classifier,
    pub training_rows: usize,
    pub training_scores: Scores,
}

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TrainError {
    #[error("no training rows{for_sensor}")]
    Empty { for_sensor: String },
    #[error(transparent)]
    Threshold(#[from] super::threshold::ThresholdError),
    /// The SVM's one-class error in this application's words (static and slip rows).
    #[error("{}", match .0 {
        super::svm::SvmError::OneClass { negative_rows, positive_rows } => format!(
            "training data needs rows of both classes (static {negative_rows}, slip {positive_rows})"
        ),
        e => e.to_string(),
    })]
    Svm(#[from] super::svm::SvmError),
    #[error(transparent)]
    LogReg(#[from] super::logreg::LogRegError),
}

impl SensorModel {
    /// Fits `kind` on `data` (already down-sampled as wanted). Its `training_scores` stay
    /// empty: scoring the training rows costs another pass of prediction over them, which a
    /// search's folds and a sweep's cells never read (see [`Self::fit_scored`]).
    pub fn fit(
        data: &Dataset,
        sensor: Option<u8>,
        kind: ClassifierKind,
        hyper: Hyperparameters,
    ) -> Result<Self, TrainError> {
        Self::fit_from(data, sensor, kind, hyper, None).map(|(model, _)| model)
    }

    /// [`Self::fit`] started from a neighbouring fit's solution (see [`WarmStart`]; a start
    /// of another classifier is ignored), returning this fit's solution to start the next
    /// (`None` for the threshold and the linear SVM, which start from their own centre).
    pub fn fit_from(
        data: &Dataset,
        sensor: Option<u8>,
        kind: ClassifierKind,
        hyper: Hyperparameters,
        start: Option<&WarmStart>,
    ) -> Result<(Self, Option<WarmStart>), TrainError> {
        if data.is_empty() {
            return Err(TrainError::Empty {
                for_sensor: sensor.map_or(String::new(), |s| format!(" for sensor {s}")),
            });
        }
        let mut next = None;
        let (scaler, classifier) = match kind {
            ClassifierKind::Threshold => {
                let rows: Vec<&[f32]> = (0..data.len()).map(|i| data.row(i)).collect();
                (
                    None,
                    Classifier::Threshold(ThresholdModel::fit(&rows, &data.y)?),
                )
            }
            _ => {
                let scaler = Scaler::fit(data.dim, &data.x);
                let x = scaler.transform(&data.x);
                let classifier = match kind {
                    ClassifierKind::SvmRbf => {
                        let dual = start.and_then(|s| s.svm_start_for(row_keys(data)));
                        let (model, solved) = SvmParams {
                            max_iterations: hyper.max_iterations,
                            ..SvmParams::rbf(hyper.c, hyper.gamma)
                        }
                        .check()?
                        .fit_from(data.dim, &x, &data.y, dual.as_ref())?;
                        next = Some(WarmStart::svm(row_keys(data), &solved));
                        Classifier::Svm(model)
                    }
                    ClassifierKind::SvmLinear => Classifier::Svm(
                        SvmParams {
                            max_iterations: hyper.max_iterations,
                            ..SvmParams::linear(hyper.c)
                        }
                        .check()?
                        .fit(data.dim, &x, &data.y)?,
                    ),
                    ClassifierKind::Logreg => {
                        let model = LogRegParams::new(hyper.c).check()?.fit_from(
                            data.dim,
                            &x,
                            &data.y,
                            start.and_then(WarmStart::logreg_theta),
                        )?;
                        let mut theta = model.weights.clone();
                        theta.push(model.intercept);
                        next = Some(WarmStart::LogReg { theta });
                        Classifier::LogReg(model)
                    }
                    ClassifierKind::Threshold => unreachable!("handled above"),
                };
                (Some(scaler), classifier)
            }
        };
        let model = Self {
            sensor,
            scaler,
            classifier,
            training_rows: data.len(),
            training_scores: Scores::default(),
        };
        Ok((model, next))
    }

    /// [`Self::fit`], and the model's scores on its own training rows (kept in a model file).
    pub fn fit_scored(
        data: &Dataset,
        sensor: Option<u8>,
        kind: ClassifierKind,
        hyper: Hyperparameters,
    ) -> Result<Self, TrainError> {
        let mut model = Self::fit(data, sensor, kind, hyper)?;
        model.training_scores = model.score(data);
        Ok(model)
    }

    /// Decision value of one raw feature row: positive means slip (for the threshold
    /// classifier, `v - T`).
    pub fn decision(&self, features: &[f32], scratch: &mut Vec<f32>) -> f64 {
        let x: &[f32] = match &self.scaler {
            Some(s) => {
                scratch.resize(features.len(), 0.0);
                s.transform_into(features, scratch);
                scratch
            }
            None => features,
        };
        match &self.classifier {
            Classifier::Threshold(t) => {
                f64::from(super::features::mean_velocity_norm(x) - t.threshold)
            }
            Classifier::Svm(m) => m.decision(x),
            Classifier::LogReg(m) => m.decision(x),
        }
    }

    pub fn predict(&self, features: &[f32], scratch: &mut Vec<f32>) -> Class {
        self.class_of(self.decision(features, scratch))
    }

    /// The class a decision value means.
    pub fn class_of(&self, decision: f64) -> Class {
        let slip = match self.classifier {
            Classifier::Threshold(_) => decision >= 0.0,
            _ => decision > 0.0,
        };
        if slip {
            Class::Slip
        } else {
            Class::Static
        }
    }

    /// [`Self::predict`] of each of `data`'s rows `rows`, in parallel pieces: a sweep's
    /// last cells and a model's scoring no longer leave a core idle (147k rows against
    /// 5.5k support vectors: 2.9 s one at a time, 1.46 s on 2 cores). An RBF SVM sums a
    /// piece's rows several at a time ([`SvmModel::decisions`]), with the same values.
    pub fn predict_rows(&self, data: &Dataset, rows: &[usize]) -> Vec<Class> {
        const PIECE: usize = 512;
        // An RBF SVM spares rows its slip support vectors show static (same classes).
        let svm = match &self.classifier {
            Classifier::Svm(m) => Some(m.positive_scoring()),
            _ => None,
        };
        rows.par_chunks(PIECE)
            .flat_map_iter(|piece| {
                let mut scratch = Vec::new();
                match &svm {
                    Some(svm) => {
                        let x = self.scaled_rows(data, piece);
                        let slip = svm.positive(x).into_iter();
                        slip.map(Class::from_positive).collect()
                    }
                    _ => piece
                        .iter()
                        .map(|&i| self.predict(data.row(i), &mut scratch))
                        .collect::<Vec<_>>(),
                }
            })
            .collect()
    }

    /// `data`'s rows `rows`, scaled as [`Self::decision`] scales them, row-major.
    fn scaled_rows(&self, data: &Dataset, rows: &[usize]) -> Vec<f32> {
        let mut x = vec![0.0; rows.len() * data.dim];
        for (&i, out) in rows.iter().zip(x.chunks_exact_mut(data.dim)) {
            match &self.scaler {
                Some(s) => s.transform_into(data.row(i), out),
                None => out.copy_from_slice(data.row(i)),
            }
        }
        x
    }

    pub fn score(&self, data: &Dataset) -> Scores {
        let rows: Vec<usize> = (0..data.len()).collect();
        Confusion::from_pairs(&data.y, &self.predict_rows(data, &rows)).scores()
    }

    /// Call after deserialising.
    pub fn prepare(&mut self) {
        if let Classifier::Svm(m) = &mut self.classifier {
            m.prepare();
        }
    }
}

/// The contents of a model file. Unknown keys are refused: a misspelt or foreign field
/// would otherwise be silently ignored.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelFile {
    pub format: String,
    pub version: u32,
    pub classifier: ClassifierKind,
    pub hyperparameters: Hyperparameters,
    pub features: FeatureSpec,
    pub labels: LabelSpec,
    pub downsample: f64,
    pub seed: u64,
    pub scope: Scope,
    pub sensors: Vec<u8>,
    pub models: Vec<SensorModel>,
    pub training_trials: Vec<TrialRef>,
    /// How the hyperparameters were found, when a search found them.
    pub search: Option<SearchRecord>,
    pub tmo_version: String,
    pub git_revision: String,
}

/// What to train: everything a model file records about its fit but the data.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrainSpec {
    pub kind: ClassifierKind,
    pub hyper: Hyperparameters,
    pub scope: Scope,
    pub features: FeatureSpec,
    pub labels: LabelSpec,
    pub downsample: f64,
    pub seed: u64,
}

impl ModelFile {
    /// Trains the models of `spec` on `data` (labelled as `spec.labels` says) into a file
    /// that records how, on what, and with which code.
    pub fn train(
        data: &Dataset,
        spec: &TrainSpec,
        training_trials: Vec<TrialRef>,
        search: Option<SearchRecord>,
    ) -> Result<Self, TrainError> {
        let models = fit_models(
            data,
            spec.kind,
            spec.hyper,
            spec.scope,
            spec.downsample,
            spec.seed,
            SensorModel::fit_scored,
        )?;
        let (tmo_version, git_revision) = crate::trial::TrialMeta::code_version();
        Ok(ModelFile {
            format: MODEL_FORMAT.into(),
            version: MODEL_FORMAT_VERSION,
            classifier: spec.kind,
            hyperparameters: spec.hyper,
            features: spec.features,
            labels: spec.labels,
            downsample: spec.downsample,
            seed: spec.seed,
            scope: spec.scope,
            sensors: data.sensors(),
            models,
            training_trials,
            search,
            tmo_version,
            git_revision,
        })
    }
}

/// A hyperparameter search: every evaluation, scored by cross-validated macro F1.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SearchRecord {
    pub method: String,
    pub folds: usize,
    pub parameters: Vec<String>,
    /// The range searched for each parameter, `[low, high]` (absent in files written before
    /// ranges were options: the defaults, [`super::search_range::SearchRanges`]).
    #[serde(default)]
    pub ranges: Vec<[f64; 2]>,
    pub evaluations: Vec<super::bayes::Evaluation>,
}

impl SearchRecord {
    /// The parameters whose best value lies at an end of its range (within 2 % of the
    /// range's width in log scale): the optimum may lie beyond it. Each as
    /// `(name, value, "lower" | "upper")`.
    pub fn best_on_range_ends(&self) -> Vec<(String, f64, &'static str)> {
        let Some(best) = super::bayes::best(&self.evaluations) else {
            return Vec::new();
        };
        self.parameters
            .iter()
            .zip(&self.ranges)
            .zip(&best.params)
            .filter_map(|((name, &range), &value)| {
                super::search_range::at_range_end(value, range)
                    .map(|end| (name.clone(), value, end))
            })
            .collect()
    }
}

#[derive(Debug, thiserror::Error)]
pub enum ModelFileError {
    #[error("{path}: {source}")]
    Io {
        path: String,
        source: std::io::Error,
    },
    #[error("{path}: not a tmo model file: {message}")]
    Parse { path: String, message: String },
    #[error("{path} is a directory; a model is one file: a model file from `tmo train` (.json) or an ONNX model (.onnx)")]
    Directory { path: String },
    #[error("{path}: model format `{found}`, expected `{MODEL_FORMAT}`")]
    WrongFormat { path: String, found: String },
    #[error("{path}: model version {found} is newer than this tmo understands ({MODEL_FORMAT_VERSION}); upgrade tmo")]
    NewerVersion { path: String, found: u32 },
    #[error("{path}: no classifier for sensor {sensor}")]
    NoSensor { path: String, sensor: u8 },
    #[error("{path}: {field}: {message}")]
    Inconsistent {
        path: String,
        field: String,
        message: String,
    },
    /// An ONNX model (`.onnx`) that cannot be read or run (boxed: its messages are long,
    /// and every error that carries this one would grow with it).
    #[error(transparent)]
    Onnx(Box<super::onnx::OnnxError>),
}

impl From<super::onnx::OnnxError> for ModelFileError {
    fn from(e: super::onnx::OnnxError) -> Self {
        ModelFileError::Onnx(Box::new(e))
    }
}

impl ModelFile {
    pub fn save(&self, path: &Path) -> Result<(), ModelFileError> {
        let io = |source| ModelFileError::Io {
            path: path.display().to_string(),
            source,
        };
        let mut value = serde_json::to_value(self).expect("models serialise");
        // A file records only the hyperparameters its classifier uses: a logistic
        // regression's file that named a gamma would suggest it had one.
        if let Some(hyper) = value["hyperparameters"].as_object_mut() {
            if !self.classifier.uses_c() {
                hyper.remove("c");
            }
            if !self.classifier.uses_gamma() {
                hyper.remove("gamma");
            }
        }
        let text = serde_json::to_string_pretty(&value).expect("models serialise");
        crate::output::atomic::write_atomic(path, text.as_bytes()).map_err(io)
    }

    pub fn load(path: &Path) -> Result<Self, ModelFileError> {
        let p = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|source| match source.kind() {
            std::io::ErrorKind::InvalidData => ModelFileError::Parse {
                path: p.clone(),
                message:
                    "not text (a model is the JSON file `tmo train` writes; is this a trial log?)"
                        .into(),
            },
            _ => ModelFileError::Io {
                path: p.clone(),
                source,
            },
        })?;
        // Check the header first, so a newer file says so instead of failing to parse.
        #[derive(Deserialize)]
        struct Header {
            format: String,
            version: u32,
        }
        let header: Header = serde_json::from_str(&text).map_err(|e| ModelFileError::Parse {
            path: p.clone(),
            message: e.to_string(),
        })?;
        if header.format != MODEL_FORMAT {
            return Err(ModelFileError::WrongFormat {
                path: p,
                found: header.format,
            });
        }
        if header.version > MODEL_FORMAT_VERSION {
            return Err(ModelFileError::NewerVersion {
                path: p,
                found: header.version,
            });
        }
        let mut model: ModelFile =
            serde_json::from_str(&text).map_err(|e| ModelFileError::Parse {
                path: p.clone(),
                message: e.to_string(),
            })?;
        // Every command that reads a model reads it here: nothing inconsistent gets past.
        model
            .check()
            .map_err(|(field, message)| ModelFileError::Inconsistent {
                path: p.clone(),
                field,
                message,
            })?;
        model.models.iter_mut().for_each(SensorModel::prepare);
        Ok(model)
    }

    /// Whether this model can classify the frames of a rig or recording with `sensors`
    /// fingertips of `pins` pins each; the error says what does not fit and what to do.
    /// A model that cannot read the frames would never fire, and every trial would be
    /// scored as a missed slip.
    pub fn fits(&self, sensors: usize, pins: usize) -> Result<(), String> {
        if self.features.pins != pins {
            return Err(format!(
                "features.pins = {}, but the fingertips report {pins} pins each; train the model on trials from this rig",
                self.features.pins
            ));
        }
        if self.scope == Scope::Local {
            if let Some(k) = (0..sensors).find(|k| !self.sensors.contains(&(*k as u8))) {
                return Err(format!(
                    "a local model for sensors {:?} has no classifier for sensor {k} of {sensors}; train it on trials from all of them, or use a global model",
                    self.sensors
                ));
            }
        }
        Ok(())
    }

    /// The file's internal consistency: what every classifier needs to classify a frame of
    /// the file's feature layout without panicking or answering nonsense. The error names
    /// the field and what was expected.
    pub fn check(&self) -> Result<(), (String, String)> {
        let bad = |field: String, message: String| Err((field, message));
        if self.version == 0 {
            return bad("version".into(), "expected 1 or more, got 0".into());
        }
        let f = &self.features;
        if let Err((field, why)) = f.check() {
            return bad(format!("features.{field}"), why);
        }
        if let Err((field, why)) = self.labels.check() {
            return bad(format!("labels.{field}"), why);
        }
        if !(self.downsample.is_finite() && self.downsample > 0.0 && self.downsample <= 1.0) {
            return bad(
                "downsample".into(),
                format!("expected a proportion in (0, 1], got {}", self.downsample),
            );
        }
        let mut listed = self.sensors.clone();
        listed.sort_unstable();
        listed.dedup();
        if self.sensors.is_empty() || listed.len() != self.sensors.len() {
            return bad(
                "sensors".into(),
                format!(
                    "expected the trained sensors, each once, got {:?}",
                    self.sensors
                ),
            );
        }
        if self.models.is_empty() {
            return bad("models".into(), "expected at least one classifier".into());
        }
        // The training trials are the model's provenance, and what `evaluate` checks its
        // test trials against: a model that names none could be scored on its own
        // training data with nothing said.
        if self.training_trials.is_empty() {
            return bad(
                "training_trials".into(),
                "expected the trials the model was trained on (trial_id, path, sha256), got none"
                    .into(),
            );
        }
        let mut hashes = std::collections::HashSet::new();
        for (i, t) in self.training_trials.iter().enumerate() {
            if t.sha256.len() != 64 || !t.sha256.bytes().all(|b| b.is_ascii_hexdigit()) {
                return bad(
                    format!("training_trials.{i}.sha256"),
                    format!(
                        "expected the trial log's SHA-256 as 64 hex digits, got {:?}",
                        t.sha256
                    ),
                );
            }
            if !hashes.insert(t.sha256.to_ascii_lowercase()) {
                return bad(
                    format!("training_trials.{i}"),
                    format!(
                        "the log {} ({}) is listed twice: a model is trained on each trial once",
                        t.trial_id, t.path
                    ),
                );
            }
        }
        match self.scope {
            Scope::Global if self.models.len() != 1 || self.models[0].sensor.is_some() => {
                return bad(
                    "models".into(),
                    "a global model has exactly one classifier, for no sensor in particular".into(),
                );
            }
            Scope::Local => {
                let mut seen: Vec<u8> = Vec::new();
                for (i, m) in self.models.iter().enumerate() {
                    match m.sensor {
                        Some(s) if !seen.contains(&s) => seen.push(s),
                        Some(s) => {
                            return bad(
                                format!("models.{i}.sensor"),
                                format!("sensor {s} has two classifiers"),
                            )
                        }
                        None => {
                            return bad(
                                format!("models.{i}.sensor"),
                                "expected the sensor of a local classifier".into(),
                            )
                        }
                    }
                }
                let mut listed = self.sensors.clone();
                listed.sort_unstable();
                seen.sort_unstable();
                if listed != seen {
                    return bad(
                        "sensors".into(),
                        format!("lists {listed:?}, but the classifiers are for {seen:?}"),
                    );
                }
            }
            Scope::Global => {}
        }
        let dim = f.len();
        for (i, m) in self.models.iter().enumerate() {
            let field = |name: &str| format!("models.{i}.{name}");
            let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
            match (&m.classifier, self.classifier) {
                (Classifier::Threshold(_), ClassifierKind::Threshold)
                | (Classifier::LogReg(_), ClassifierKind::Logreg) => {}
                (Classifier::Svm(s), ClassifierKind::SvmRbf)
                    if matches!(s.kernel, super::svm::Kernel::Rbf { .. }) => {}
                (Classifier::Svm(s), ClassifierKind::SvmLinear)
                    if matches!(s.kernel, super::svm::Kernel::Linear) => {}
                _ => {
                    return bad(
                        field("classifier"),
                        format!(
                            "does not match the file's classifier `{}`",
                            self.classifier.name()
                        ),
                    )
                }
            }
            if matches!(m.classifier, Classifier::Threshold(_)) && m.scaler.is_some() {
                // the threshold reads raw pin speeds: a scaler would change what it compares
                return bad(
                    field("scaler"),
                    "a threshold classifier has no scaler (it works on raw pin speeds)".into(),
                );
            }
            if !matches!(m.classifier, Classifier::Threshold(_)) {
                let Some(sc) = &m.scaler else {
                    return bad(field("scaler"), "expected the feature scaler".into());
                };
                if sc.mean.len() != dim || sc.scale.len() != dim {
                    return bad(
                        field("scaler"),
                        format!(
                            "expected {dim} means and scales ({} pins), got {} and {}",
                            f.pins,
                            sc.mean.len(),
                            sc.scale.len()
                        ),
                    );
                }
                if !finite(&sc.mean) || !sc.scale.iter().all(|s| s.is_finite() && *s > 0.0) {
                    return bad(
                        field("scaler"),
                        "expected finite means and positive, finite scales".into(),
                    );
                }
            }
            match &m.classifier {
                Classifier::Threshold(t) => {
                    if !(t.threshold.is_finite() && t.threshold >= 0.0) {
                        return bad(
                            field("classifier.threshold"),
                            format!("expected a speed >= 0 px/frame, got {}", t.threshold),
                        );
                    }
                }
                Classifier::LogReg(l) => {
                    if l.weights.len() != dim || !finite(&l.weights) || !l.intercept.is_finite() {
                        return bad(
                            field("classifier.weights"),
                            format!("expected {dim} finite weights and a finite intercept"),
                        );
                    }
                }
                Classifier::Svm(s) => {
                    if s.dim != dim {
                        return bad(
                            field("classifier.dim"),
                            format!("expected {dim} ({} pins), got {}", f.pins, s.dim),
                        );
                    }
                    let n = s.dual_coef.len();
                    if n == 0 || s.support_vectors.len() != n * dim {
                        return bad(
                            field("classifier.support_vectors"),
                            format!(
                                "expected {n} support vectors of {dim} values (one per dual coefficient, at least one), got {} values",
                                s.support_vectors.len()
                            ),
                        );
                    }
                    if !finite(&s.dual_coef)
                        || !s.rho.is_finite()
                        || !s.support_vectors.iter().all(|v| v.is_finite())
                    {
                        return bad(
                            field("classifier"),
                            "expected finite support vectors, dual coefficients and rho".into(),
                        );
                    }
                    match s.kernel {
                        super::svm::Kernel::Rbf { gamma }
                            if !(gamma.is_finite() && gamma > 0.0) =>
                        {
                            return bad(
                                field("classifier.kernel.gamma"),
                                format!("expected a positive number, got {gamma}"),
                            )
                        }
                        super::svm::Kernel::Linear => match &s.weights {
                            Some(w) if w.len() == dim && finite(w) => {}
                            _ => {
                                return bad(
                                    field("classifier.weights"),
                                    format!("a linear SVM needs {dim} finite primal weights"),
                                )
                            }
                        },
                        _ => {}
                    }
                }
            }
        }
        Ok(())
    }

    /// The SVM fits that stopped at their iteration limit: (sensor, iterations, gap).
    pub fn unconverged(&self) -> Vec<(Option<u8>, usize, f64)> {
        self.models
            .iter()
            .filter_map(|m| match &m.classifier {
                Classifier::Svm(s) => s.unconverged_gap.map(|g| (m.sensor, s.iterations, g)),
                _ => None,
            })
            .collect()
    }

    /// The trials of `refs` this model was trained on (matched by their logs' SHA-256):
    /// scores on them are not held out.
    pub fn trained_on<'a>(&self, refs: &'a [TrialRef]) -> Vec<&'a TrialRef> {
        refs.iter()
            .filter(|r| self.trained_on_log(&r.sha256))
            .collect()
    }

    /// Whether the trial log whose SHA-256 is `sha256` is one of this model's training
    /// trials.
    pub fn trained_on_log(&self, sha256: &str) -> bool {
        self.training_trials
            .iter()
            .any(|t| t.sha256.eq_ignore_ascii_case(sha256))
    }

    /// The sensors of `sensors` a global model never saw in training. A global model
    /// classifies any sensor's frames, so these are scored, but as generalisation to a
    /// fingertip it was not fitted on (the paper's global-vs-local question).
    pub fn unseen_sensors(&self, sensors: &[u8]) -> Vec<u8> {
        match self.scope {
            Scope::Global => sensors
                .iter()
                .copied()
                .filter(|s| !self.sensors.contains(s))
                .collect(),
            Scope::Local => Vec::new(),
        }
    }

    /// The classifier that handles `sensor`'s frames.
    pub fn for_sensor(&self, sensor: u8) -> Option<&SensorModel> {
        match self.scope {
            Scope::Global => self.models.first(),
            Scope::Local => self.models.iter().find(|m| m.sensor == Some(sensor)),
        }
    }

    /// Scores on `data` (every row, never down-sampled), overall and per sensor.
    /// A global threshold model calling a frame slip when the mean pin speed reaches
    /// `threshold` px per frame (for tests and benchmarks that need a model without data).
    pub fn threshold_model(pins: usize, sensors: Vec<u8>, threshold: f32) -> Self {
        Self {
            format: MODEL_FORMAT.into(),
            version: MODEL_FORMAT_VERSION,
            classifier: ClassifierKind::Threshold,
            hyperparameters: Default::default(),
            features: FeatureSpec::new(pins),
            labels: LabelSpec {
                n_slip: 5,
                onset: Default::default(),
            },
            downsample: 1.0,
            seed: 0,
            scope: Scope::Global,
            sensors,
            models: vec![SensorModel {
                sensor: None,
                scaler: None,
                classifier: Classifier::Threshold(super::threshold::ThresholdModel { threshold }),
                training_rows: 0,
                training_scores: Default::default(),
            }],
            training_trials: vec![],
            search: None,
            tmo_version: String::new(),
            git_revision: String::new(),
        }
    }

    /// The threshold of a threshold model (its first, usually only, classifier).
    pub fn threshold(&self) -> Option<f32> {
        self.models.iter().find_map(|m| match &m.classifier {
            Classifier::Threshold(t) => Some(t.threshold),
            _ => None,
        })
    }

    pub fn evaluate(&self, data: &Dataset) -> Result<(Scores, Vec<(u8, Scores)>), ModelFileError> {
        score_models(&self.models, self.scope, data).map_err(|sensor| ModelFileError::NoSensor {
            path: "model".into(),
            sensor,
        })
    }
}

/// Scores `models` (of `scope`) on every row of `data`, overall and per sensor; `Err(sensor)`
/// if a local model set has no classifier for a sensor in the data.
pub fn score_models(
    models: &[SensorModel],
    scope: Scope,
    data: &Dataset,
) -> Result<(Scores, Vec<(u8, Scores)>), u8> {
    let rows: Vec<usize> = (0..data.len()).collect();
    score_models_on(models, scope, data, &rows)
}

/// [`score_models`] on `data`'s rows `rows` alone (a sweep's cell scores a narrower
/// labelling of the test set without copying it).
pub fn score_models_on(
    models: &[SensorModel],
    scope: Scope,
    data: &Dataset,
    rows: &[usize],
) -> Result<(Scores, Vec<(u8, Scores)>), u8> {
    let pick = |sensor: u8| match scope {
        Scope::Global => (!models.is_empty()).then_some(0),
        Scope::Local => models.iter().position(|m| m.sensor == Some(sensor)),
    };
    // Each model predicts its rows together (see SensorModel::predict_rows); `predicted[k]`
    // is row `rows[k]`'s class.
    let mut rows_of_model: Vec<Vec<usize>> = vec![Vec::new(); models.len()];
    let mut places_of_model: Vec<Vec<usize>> = vec![Vec::new(); models.len()];
    for (k, &i) in rows.iter().enumerate() {
        let sensor = data.sensor[i];
        let m = pick(sensor).ok_or(sensor)?;
        rows_of_model[m].push(i);
        places_of_model[m].push(k);
    }
    let mut predicted = vec![Class::Static; rows.len()];
    for ((m, model_rows), places) in models.iter().zip(&rows_of_model).zip(&places_of_model) {
        for (&k, p) in places.iter().zip(m.predict_rows(data, model_rows)) {
            predicted[k] = p;
        }
    }
    Ok(scores_by_sensor(data, rows, &predicted))
}

/// Scores of the classes `predicted` for `data`'s rows `rows` (in that order), overall
/// and per sensor (in sensor order).
pub fn scores_by_sensor(
    data: &Dataset,
    rows: &[usize],
    predicted: &[Class],
) -> (Scores, Vec<(u8, Scores)>) {
    let mut overall = Confusion::default();
    let mut per_sensor: Vec<(u8, Confusion)> = Vec::new();
    for (&i, &p) in rows.iter().zip(predicted) {
        let (sensor, truth) = (data.sensor[i], data.y[i]);
        overall.add(truth, p);
        match per_sensor.iter_mut().find(|(s, _)| *s == sensor) {
            Some((_, c)) => c.add(truth, p),
            None => {
                let mut c = Confusion::default();
                c.add(truth, p);
                per_sensor.push((sensor, c));
            }
        }
    }
    per_sensor.sort_by_key(|(s, _)| *s);
    (
        overall.scores(),
        per_sensor
            .into_iter()
            .map(|(s, c)| (s, c.scores()))
            .collect(),
    )
}

/// Trains the models of one file: one per sensor (local) or one for all (global), each on
/// `data` with its static rows down-sampled to `downsample` (seeded).
pub fn train_models(
    data: &Dataset,
    kind: ClassifierKind,
    hyper: Hyperparameters,
    scope: Scope,
    downsample: f64,
    seed: u64,
) -> Result<Vec<SensorModel>, TrainError> {
    fit_models(data, kind, hyper, scope, downsample, seed, SensorModel::fit)
}

/// [`train_models`] with each model's fit started from `starts` (by position: the global
/// model, or the sensors in order; see [`WarmStart`]), returning the fits' solutions in the
/// same order to start the next.
pub fn train_models_from(
    data: &Dataset,
    kind: ClassifierKind,
    hyper: Hyperparameters,
    scope: Scope,
    downsample: f64,
    seed: u64,
    starts: &[Option<WarmStart>],
) -> Result<(Vec<SensorModel>, Vec<Option<WarmStart>>), TrainError> {
    let parts = training_parts(data, scope, downsample, seed);
    parts
        .iter()
        .enumerate()
        .map(|(k, (sensor, rows))| {
            let start = starts.get(k).and_then(Option::as_ref);
            SensorModel::fit_from(rows, *sensor, kind, hyper, start)
        })
        .collect::<Result<Vec<_>, _>>()
        .map(|fits| fits.into_iter().unzip())
}

pub(crate) type Fit =
    fn(&Dataset, Option<u8>, ClassifierKind, Hyperparameters) -> Result<SensorModel, TrainError>;

fn fit_models(
    data: &Dataset,
    kind: ClassifierKind,
    hyper: Hyperparameters,
    scope: Scope,
    downsample: f64,
    seed: u64,
    fit: Fit,
) -> Result<Vec<SensorModel>, TrainError> {
    fit_parts(
        &training_parts(data, scope, downsample, seed),
        kind,
        hyper,
        fit,
    )
}

/// One model fitted by `fit` on each of `parts` (see [`training_parts`]).
pub(crate) fn fit_parts(
    parts: &[(Option<u8>, Dataset)],
    kind: ClassifierKind,
    hyper: Hyperparameters,
    fit: Fit,
) -> Result<Vec<SensorModel>, TrainError> {
    parts
        .iter()
        .map(|(sensor, rows)| fit(rows, *sensor, kind, hyper))
        .collect()
}

/// Each model's training rows: all of `data` (global) or one sensor's (local, sensors in
/// order), static rows down-sampled to `downsample` (seeded).
pub(crate) fn training_parts(
    data: &Dataset,
    scope: Scope,
    downsample: f64,
    seed: u64,
) -> Vec<(Option<u8>, Dataset)> {
    match scope {
        Scope::Global => vec![(None, data.downsample_static(downsample, seed))],
        Scope::Local => data
            .sensors()
            .into_iter()
            .map(|s| {
                (
                    Some(s),
                    data.sensor_only(s).downsample_static(downsample, seed),
                )
            })
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::slip::labels::OnsetSpec;

    /// 400 rows of 30 pins: slip rows have larger first features.
    fn data() -> Dataset {
        let dim = 60;
        let mut ds = Dataset {
            dim,
            trial_ids: vec!["t0".into(), "t1".into()],
            ..Default::default()
        };
        for i in 0..400u32 {
            let slip = i % 4 == 0;
            for j in 0..dim {
                let wobble = ((i as usize * 31 + j * 17) % 13) as f32 / 13.0;
                ds.x.push(if slip && j < 30 { 1.0 + wobble } else { wobble });
            }
            ds.y.push(if slip { Class::Slip } else { Class::Static });
            ds.trial.push(i % 2);
            ds.sensor.push(0);
            ds.seq.push(u64::from(i));
            ds.time_s.push(f64::from(i) / 60.0);
        }
        ds
    }

    #[test]
    fn models_scored_on_some_rows_score_as_on_a_copy_of_those_rows() {
        let mut data = data();
        // two sensors, so each local model predicts only its own rows
        for (i, s) in data.sensor.iter_mut().enumerate() {
            *s = (i % 3 == 0) as u8;
        }
        let rows: Vec<usize> = (0..data.len())
            .filter(|i| i % 7 != 2 && i % 5 != 0)
            .collect();
        let mut keep = vec![false; data.len()];
        for &i in &rows {
            keep[i] = true;
        }
        let copy = data.filter(|i| keep[i]);
        for scope in [Scope::Global, Scope::Local] {
            let models = train_models(
                &data,
                ClassifierKind::SvmRbf,
                Hyperparameters {
                    c: 1.0,
                    gamma: 0.05,
                    max_iterations: None,
                },
                scope,
                0.5,
                3,
            )
            .unwrap();
            let on_rows = score_models_on(&models, scope, &data, &rows).unwrap();
            assert_eq!(on_rows, score_models(&models, scope, &copy).unwrap());
            assert_ne!(on_rows, score_models(&models, scope, &data).unwrap());
            assert_eq!(on_rows.1.len(), 2, "{scope:?}: both sensors scored");
        }
    }

    /// A trained model of `kind` as JSON.
    fn trained(kind: ClassifierKind) -> serde_json::Value {
        let m = ModelFile::train(&data(), &spec(kind), refs(), None).unwrap();
        serde_json::to_value(&m).unwrap()
    }

    /// Global, C 1, gamma 0.05, n_slip 5, every row.
    fn spec(kind: ClassifierKind) -> TrainSpec {
        TrainSpec {
            kind,
            hyper: Hyperparameters {
                c: 1.0,
                gamma: 0.05,
                max_iterations: None,
            },
            scope: Scope::Global,
            features: FeatureSpec::new(30),
            labels: LabelSpec {
                n_slip: 5,
                onset: OnsetSpec::default(),
            },
            downsample: 1.0,
            seed: 0,
        }
    }

    #[test]
    fn a_saved_file_records_only_the_hyperparameters_its_classifier_uses() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.json");
        for (kind, keys) in [
            (ClassifierKind::SvmRbf, &["c", "gamma"][..]),
            (ClassifierKind::SvmLinear, &["c"][..]),
            (ClassifierKind::Logreg, &["c"][..]),
            (ClassifierKind::Threshold, &[][..]),
        ] {
            let m = ModelFile::train(&data(), &spec(kind), refs(), None).unwrap();
            m.save(&path).unwrap();
            let v: serde_json::Value =
                serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
            let mut written: Vec<&str> = v["hyperparameters"]
                .as_object()
                .unwrap()
                .keys()
                .map(String::as_str)
                .collect();
            written.sort_unstable();
            assert_eq!(written, keys, "{kind:?}");
            // it loads, and saves as it was
            let back = ModelFile::load(&path).unwrap();
            let again = dir.path().join("again.json");
            back.save(&again).unwrap();
            assert_eq!(
                std::fs::read_to_string(&again).unwrap(),
                std::fs::read_to_string(&path).unwrap(),
                "{kind:?}"
            );
            if kind.uses_c() {
                assert_eq!(back.hyperparameters.c, 1.0);
            }
        }
    }

    /// The two trials of [`data`], as a model file names them.
    fn refs() -> Vec<TrialRef> {
        (0..2)
            .map(|i| TrialRef {
                trial_id: format!("t{i}"),
                path: format!("t{i}.mcap"),
                sha256: format!("{i:064x}"),
            })
            .collect()
    }

    #[test]
    fn a_model_names_the_trials_it_was_trained_on_each_once_and_says_which_it_meets_again() {
        let v = trained(ClassifierKind::Logreg);
        let model = load(&v).unwrap();
        let mut none = v.clone();
        none["training_trials"] = serde_json::json!([]);
        refused(&none, "training_trials");
        let mut twice = v.clone();
        twice["training_trials"][1] = twice["training_trials"][0].clone();
        refused(&twice, "training_trials.1");
        let mut not_a_hash = v.clone();
        not_a_hash["training_trials"][0]["sha256"] = "abc".into();
        refused(&not_a_hash, "training_trials.0.sha256");
        // the test trials it was trained on are named, by their logs' hashes
        let mut test = refs();
        test[1].sha256 = "f".repeat(64);
        let seen = model.trained_on(&test);
        assert_eq!(seen.len(), 1);
        assert_eq!(seen[0].trial_id, "t0");
        assert!(model.trained_on_log(&refs()[1].sha256.to_uppercase()));
        // a global model trained on sensor 0 meets sensors 1 and 2 as generalisation
        assert_eq!(model.sensors, vec![0]);
        assert_eq!(model.unseen_sensors(&[0, 1, 2]), vec![1, 2]);
        let mut local = model.clone();
        local.scope = Scope::Local;
        assert!(local.unseen_sensors(&[0, 1, 2]).is_empty());
    }

    fn load(v: &serde_json::Value) -> Result<ModelFile, ModelFileError> {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.json");
        std::fs::write(&path, serde_json::to_string(v).unwrap()).unwrap();
        ModelFile::load(&path)
    }

    fn refused(v: &serde_json::Value, field: &str) {
        match load(v) {
            Err(ModelFileError::Inconsistent {
                field: f, message, ..
            }) => {
                assert_eq!(f, field, "{message}")
            }
            other => panic!("expected {field} refused, got {other:?}"),
        }
    }

    #[test]
    fn a_model_fits_only_frames_of_its_pin_count_and_local_sensors() {
        let global = load(&trained(ClassifierKind::Logreg)).unwrap();
        assert!(global.fits(3, 30).is_ok() && global.fits(1, 30).is_ok());
        assert!(global
            .fits(3, 20)
            .unwrap_err()
            .contains("features.pins = 30"));
        // a local model of sensor 0 only: fine for the rail, not for the hand
        let mut local = global.clone();
        local.scope = Scope::Local;
        local.sensors = vec![0];
        assert!(local.fits(1, 30).is_ok());
        assert!(local.fits(3, 30).unwrap_err().contains("sensor 1"));
    }

    #[test]
    fn a_model_file_keeps_its_training_scores_and_a_search_or_sweep_fit_skips_them() {
        let data = data();
        let spec = spec(ClassifierKind::SvmRbf);
        let hyper = spec.hyper;
        let file = ModelFile::train(&data, &spec, refs(), None).unwrap();
        let kept = &file.models[0].training_scores;
        assert_eq!(
            kept.confusion.true_slip
                + kept.confusion.false_slip
                + kept.confusion.true_static
                + kept.confusion.false_static,
            data.len() as u64
        );
        assert!(kept.macro_f1 > 0.9);
        let bare = train_models(&data, spec.kind, hyper, Scope::Global, 1.0, 0).unwrap();
        assert_eq!(bare[0].training_scores, Scores::default());
        // the same fit all the same
        assert_eq!(bare[0].classifier, file.models[0].classifier);
    }

    #[test]
    fn rows_predicted_together_are_the_rows_predicted_one_at_a_time() {
        let data = data();
        // every row but a few, in an order of their own: pieces and remainders of every size
        let rows: Vec<usize> = (0..data.len()).rev().filter(|i| i % 7 != 3).collect();
        for kind in [
            ClassifierKind::SvmRbf,
            ClassifierKind::SvmLinear,
            ClassifierKind::Logreg,
            ClassifierKind::Threshold,
        ] {
            let file = ModelFile::train(&data, &spec(kind), refs(), None).unwrap();
            let model = &file.models[0];
            let mut scratch = Vec::new();
            let one_at_a_time: Vec<Class> = rows
                .iter()
                .map(|&i| model.predict(data.row(i), &mut scratch))
                .collect();
            assert_eq!(model.predict_rows(&data, &rows), one_at_a_time, "{kind:?}");
            assert!(one_at_a_time.contains(&Class::Slip), "{kind:?}");
        }
    }

    #[test]
    fn rows_an_svm_surely_calls_static_are_predicted_as_one_at_a_time() {
        // a few slip rows in a static cloud, so the model's slip support vectors bound most
        // rows (see NegativeBound), and rows near the slip rows, which they do not
        let (n, dim) = (1200, 6);
        let (x, y) = crate::slip::svm::noisy_classes(n, dim, 17, 9, 2.0, 1.5);
        let ds = Dataset {
            dim,
            trial_ids: vec!["t0".into()],
            x,
            y: y.into_iter().map(Class::from_positive).collect(),
            trial: vec![0; n],
            sensor: vec![0; n],
            seq: (0..n as u64).collect(),
            time_s: (0..n).map(|i| i as f64).collect(),
            ..Default::default()
        };
        let hyper = Hyperparameters {
            c: 1.0,
            gamma: 0.5,
            max_iterations: None,
        };
        let model = SensorModel::fit(&ds, None, ClassifierKind::SvmRbf, hyper).unwrap();
        let Classifier::Svm(svm) = &model.classifier else {
            unreachable!()
        };
        let bound = svm.negative_bound().expect("a bound for this model");
        let rows: Vec<usize> = (0..n).collect();
        let scaled = model.scaled_rows(&ds, &rows);
        let sure = bound
            .surely_negative(&scaled)
            .iter()
            .filter(|s| **s)
            .count();
        assert!(sure > n / 4 && sure < n, "{sure} of {n} rows surely static");
        let mut scratch = Vec::new();
        let one_at_a_time: Vec<Class> = rows
            .iter()
            .map(|&i| model.predict(ds.row(i), &mut scratch))
            .collect();
        assert_eq!(model.predict_rows(&ds, &rows), one_at_a_time);
        assert!(one_at_a_time.contains(&Class::Slip));
    }

    #[test]
    fn trained_models_of_every_kind_load() {
        for kind in [
            ClassifierKind::SvmRbf,
            ClassifierKind::SvmLinear,
            ClassifierKind::Logreg,
            ClassifierKind::Threshold,
        ] {
            load(&trained(kind)).unwrap();
        }
    }

    #[test]
    fn inconsistent_svm_files_are_refused_with_the_field() {
        let linear = trained(ClassifierKind::SvmLinear);
        let mut v = linear.clone();
        v["models"][0]["classifier"]["weights"] = serde_json::Value::Null;
        refused(&v, "models.0.classifier.weights");
        let rbf = trained(ClassifierKind::SvmRbf);
        for dim in [0u64, 1, 30, 59, 61, 120, 1_000_000_000_000] {
            let mut v = rbf.clone();
            v["models"][0]["classifier"]["dim"] = dim.into();
            refused(&v, "models.0.classifier.dim");
        }
        let mut v = rbf.clone();
        v["models"][0]["classifier"]["dual_coef"]
            .as_array_mut()
            .unwrap()
            .pop();
        refused(&v, "models.0.classifier.support_vectors");
        let mut v = rbf.clone();
        v["models"][0]["classifier"]["kernel"]["gamma"] = (-1.0).into();
        refused(&v, "models.0.classifier.kernel.gamma");
        let mut v = rbf.clone();
        v["classifier"] = "logreg".into();
        refused(&v, "models.0.classifier");
    }

    #[test]
    fn inconsistent_files_of_any_kind_are_refused_with_the_field() {
        let logreg = trained(ClassifierKind::Logreg);
        let mut v = logreg.clone();
        v["models"][0]["classifier"]["weights"]
            .as_array_mut()
            .unwrap()
            .push(1.0.into());
        refused(&v, "models.0.classifier.weights");
        let mut v = logreg.clone();
        v["models"][0]["scaler"]["scale"][3] = 0.0.into();
        refused(&v, "models.0.scaler");
        let mut v = logreg.clone();
        v["models"][0]["scaler"]["mean"]
            .as_array_mut()
            .unwrap()
            .pop();
        refused(&v, "models.0.scaler");
        let mut v = logreg.clone();
        v["version"] = 0.into();
        refused(&v, "version");
        let mut v = logreg.clone();
        v["models"] = serde_json::json!([]);
        refused(&v, "models");
        let mut v = logreg.clone();
        v["features"]["max_pin_step_px"] = 0.0.into();
        refused(&v, "features.max_pin_step_px");
        let mut v = logreg.clone();
        v["scope"] = "local".into();
        refused(&v, "models.0.sensor");
        let mut v = trained(ClassifierKind::Threshold);
        v["models"][0]["classifier"]["threshold"] = (-0.5).into();
        refused(&v, "models.0.classifier.threshold");
    }

    /// Issue 41, M-a, M-b, M-c: labels no trainer writes, a threshold with a scaler, and
    /// keys the format does not have are refused on load, as every reader loads here.
    #[test]
    fn labels_scalers_and_keys_no_trainer_writes_are_refused() {
        let logreg = trained(ClassifierKind::Logreg);
        for n_slip in [0u64, 1_000_000] {
            let mut v = logreg.clone();
            v["labels"]["n_slip"] = n_slip.into();
            refused(&v, "labels.n_slip");
        }
        let mut v = logreg.clone();
        v["labels"]["onset"]["drop_threshold_mm"] = (-1.0).into();
        refused(&v, "labels.onset");
        let mut v = logreg.clone();
        v["downsample"] = 0.0.into();
        refused(&v, "downsample");
        let mut v = logreg.clone();
        v["sensors"] = serde_json::json!([0, 0]);
        refused(&v, "sensors");
        let mut v = trained(ClassifierKind::Threshold);
        v["models"][0]["scaler"] = logreg["models"][0]["scaler"].clone();
        v["models"][0]["scaler"]["mean"] = serde_json::json!(vec![0.0; 5]);
        v["models"][0]["scaler"]["scale"] = serde_json::json!(vec![1.0; 5]);
        refused(&v, "models.0.scaler");
        for (at, key) in [("", "colour"), ("models.0", "bias")] {
            let mut v = logreg.clone();
            let o = if at.is_empty() {
                &mut v
            } else {
                &mut v["models"][0]
            };
            o[key] = 1.into();
            match load(&v) {
                Err(ModelFileError::Parse { message, .. }) => {
                    assert!(message.contains(key), "{message}")
                }
                other => panic!("expected `{key}` refused, got {other:?}"),
            }
        }
    }
}
