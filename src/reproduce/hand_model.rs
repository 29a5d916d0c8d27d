//! A user's slip model in a reproduction (`tmo reproduce --hand-model FILE`): it stands in
//! for the whole hand's global model in every online hand step (the release at 0 and 180
//! degrees, the eleven objects, the pour, the first-time lift) and in the hand's offline
//! evaluation, so the findings on the hand's global model judge it with the paper's
//! protocols and tmo's scoring. tmo's own global model is still trained beside it and
//! evaluated into [`TMO_GLOBAL_EVALUATION`], for comparison; the local model and the rail
//! model stay tmo's.
//!
//! The model is copied into the hand models' step (so a reproduction holds what it judged)
//! and its SHA-256 is one of that step's inputs, so a changed model remakes the step and,
//! through its outputs' digest, every online hand step after it.

use std::path::Path;

use crate::slip::slip_model::{is_onnx, SlipModel};

/// The record of the user's model in the hand models' step.
pub const RECORD: &str = "user_model.record.json";
/// tmo's own global model's evaluation, when a user's model stands in for it.
pub const TMO_GLOBAL_EVALUATION: &str = "eval_tmo_global.json";

fn read(path: &Path) -> Result<Vec<u8>, HandModelError> {
    std::fs::read(path).map_err(|source| HandModelError::Read {
        path: path.display().to_string(),
        source,
    })
}

#[derive(Debug, thiserror::Error)]
pub enum HandModelError {
    #[error("{path} changed since the reproduction started (SHA-256 {was}, now {now}): start it again to judge the new model")]
    Changed {
        path: String,
        was: String,
        now: String,
    },
    #[error("{path}: {source}")]
    Read {
        path: String,
        source: std::io::Error,
    },
    #[error(transparent)]
    Model(#[from] crate::slip::model::ModelFileError),
    #[error("{path}: a {scope} model cannot stand in for the hand's global model: the whole hand's online steps apply one model to every fingertip (export or train it with global scope)")]
    NotGlobal { path: String, scope: &'static str },
}

/// A user's model, as a reproduction records it.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct HandModel {
    /// The copy's name in the hand models' step (`user_model.onnx`, `user_model.json`): the
    /// name the protocols give.
    pub file: String,
    /// SHA-256 of the model file.
    pub sha256: String,
    /// Where it was read from, as given (not an input of any step: moving the file changes
    /// nothing).
    pub source: String,
    /// `onnx`, `svm`, `logreg` or `threshold`.
    pub classifier: String,
    /// Frames each classification reads.
    pub window: usize,
}

impl HandModel {
    /// Reads and checks the model at `path` (an ONNX model by its extension, else a model
    /// file of tmo's own), before anything runs.
    pub fn read(path: &Path) -> Result<Self, HandModelError> {
        let model = SlipModel::load(path)?;
        let scope = model.scope();
        if scope != crate::slip::dataset::Scope::Global {
            return Err(HandModelError::NotGlobal {
                path: path.display().to_string(),
                scope: scope.name(),
            });
        }
        let bytes = read(path)?;
        // absolute, so that the step finds it from any directory
        let source = std::fs::canonicalize(path).map_err(|source| HandModelError::Read {
            path: path.display().to_string(),
            source,
        })?;
        let ext = if is_onnx(path) { "onnx" } else { "json" };
        Ok(Self {
            file: format!("user_model.{ext}"),
            sha256: crate::trial::sha256_hex(&bytes),
            source: source.display().to_string(),
            classifier: model.classifier_name().into(),
            window: model.window(),
        })
    }

    /// Copies the model into `dir` under its copy's name, refusing one that changed since
    /// it was read (its digest is the step's input).
    pub fn copy_into(&self, dir: &Path) -> Result<std::path::PathBuf, HandModelError> {
        let bytes = read(Path::new(&self.source))?;
        let now = crate::trial::sha256_hex(&bytes);
        if now != self.sha256 {
            return Err(HandModelError::Changed {
                path: self.source.clone(),
                was: self.sha256.clone(),
                now,
            });
        }
        let to = dir.join(&self.file);
        crate::output::atomic::write_atomic(&to, &bytes).map_err(|source| {
            HandModelError::Read {
                path: to.display().to_string(),
                source,
            }
        })?;
        Ok(to)
    }

    /// What the hand models' step adds to its inputs: the model's name and digest.
    pub fn inputs_line(&self) -> String {
        format!("hand model {} {}\n", self.file, self.sha256)
    }

    /// The record in a finished hand models' step directory, if it judged a user's model.
    pub fn recorded(step_dir: &Path) -> Option<Self> {
        let text = std::fs::read_to_string(step_dir.join(RECORD)).ok()?;
        serde_json::from_str(&text).ok()
    }

    /// One line for the page and the terminal: which model the global model's findings
    /// judged.
    pub fn line(&self) -> String {
        format!(
            "The whole hand's global model in this reproduction is the user's `{}` ({}, {} frame{} a classification, SHA-256 {}): every finding on the hand's global model, offline and online, judges it; tmo's own global model's offline scores are in `06_hand_models/{}`.",
            self.source,
            self.classifier,
            self.window,
            if self.window == 1 { "" } else { "s" },
            &self.sha256[..12.min(self.sha256.len())],
            TMO_GLOBAL_EVALUATION
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fixture(name: &str) -> std::path::PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/fixtures/onnx")
            .join(name)
    }

    #[test]
    fn an_onnx_model_is_read_with_its_digest_and_its_copy_name() {
        let path = fixture("window_mlp.onnx");
        let m = HandModel::read(&path).unwrap();
        assert_eq!(m.file, "user_model.onnx");
        assert_eq!(m.classifier, "onnx");
        assert_eq!(m.window, 15);
        assert_eq!(
            m.sha256,
            crate::trial::sha256_hex(&std::fs::read(&path).unwrap())
        );
        assert!(m.inputs_line().starts_with("hand model user_model.onnx "));
        assert!(m.line().contains("15 frames a classification"));
    }

    #[test]
    fn a_model_that_cannot_be_read_is_refused_naming_the_file() {
        let e = HandModel::read(&fixture("svm_skl2onnx.onnx")).unwrap_err();
        assert!(e.to_string().contains("svm_skl2onnx.onnx"), "{e}");
        let dir = tempfile::tempdir().unwrap();
        let missing = dir.path().join("none.json");
        let e = HandModel::read(&missing).unwrap_err();
        assert!(e.to_string().contains("none.json"), "{e}");
    }

    #[test]
    fn a_model_changed_after_it_was_read_is_not_copied() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.onnx");
        std::fs::copy(fixture("logreg.onnx"), &path).unwrap();
        let m = HandModel::read(&path).unwrap();
        let step = dir.path().join("step");
        std::fs::create_dir(&step).unwrap();
        let copy = m.copy_into(&step).unwrap();
        assert_eq!(std::fs::read(&copy).unwrap(), std::fs::read(&path).unwrap());
        std::fs::copy(fixture("frame_mlp.onnx"), &path).unwrap();
        let e = m.copy_into(&step).unwrap_err();
        assert!(
            e.to_string()
                .contains("changed since the reproduction started"),
            "{e}"
        );
    }

    #[test]
    fn a_record_written_is_read_back() {
        let dir = tempfile::tempdir().unwrap();
        let m = HandModel::read(&fixture("logreg.onnx")).unwrap();
        std::fs::write(dir.path().join(RECORD), serde_json::to_string(&m).unwrap()).unwrap();
        assert_eq!(HandModel::recorded(dir.path()), Some(m));
        assert_eq!(HandModel::recorded(&dir.path().join("elsewhere")), None);
    }
}
