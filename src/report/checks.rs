//! What the report accepts as numbers: every value it tabulates or plots is finite and in
//! its range, or the input is refused naming the file, the row and the field. (A NaN, an
//! infinity or a 1e308 used to be tabulated as if it were a number, and sent the plotting
//! library's axis computation into an endless loop.)

use std::path::Path;

/// What is wrong with a report's input (a batch, sweep, evaluation, model or trials).
#[derive(Debug, thiserror::Error)]
pub enum InputError {
    #[error("{path}: cannot read: {message}")]
    Read {
        path: std::path::PathBuf,
        message: String,
    },
    #[error("{path}: {message}")]
    Format {
        path: std::path::PathBuf,
        message: String,
    },
    #[error(
        "{0}: expected a batch directory (with batch.json), a sweep (sweep.csv or a directory holding one), a directory of trial logs (.mcap), an evaluation (.json from `tmo evaluate --out`) or a model (.json from `tmo train`)"
    )]
    Unknown(std::path::PathBuf),
}

use crate::runner::score::{CalibrationRow, LiftRow, OutcomeRow};
use crate::slip::evaluation::Evaluation;
use crate::slip::metrics::Scores;
use crate::slip::sweep::SweepRow;

/// Largest magnitude of a distance, height or time the report takes (mm or s): far past any
/// rig, far inside what a plot axis can lay out.
const LARGEST: f64 = 1e6;

struct Rows<'a> {
    path: &'a Path,
}

impl Rows<'_> {
    fn check(
        &self,
        row: usize,
        field: &str,
        value: f64,
        lo: f64,
        hi: f64,
    ) -> Result<(), InputError> {
        if value.is_finite() && (lo..=hi).contains(&value) {
            return Ok(());
        }
        Err(InputError::Format {
            path: self.path.to_path_buf(),
            message: format!("row {row}: `{field}` = {value}: expected a number in {lo}..={hi}"),
        })
    }

    fn optional(
        &self,
        row: usize,
        field: &str,
        value: Option<f64>,
        lo: f64,
        hi: f64,
    ) -> Result<(), InputError> {
        value.map_or(Ok(()), |v| self.check(row, field, v, lo, hi))
    }

    fn scores(&self, row: usize, prefix: &str, s: &Scores) -> Result<(), InputError> {
        // scores over no frames at all say nothing (R-d)
        let c = &s.confusion;
        if c.true_slip + c.false_slip + c.true_static + c.false_static == 0 {
            return Err(InputError::Format {
                path: self.path.to_path_buf(),
                message: format!(
                    "`{prefix}confusion`: every count is 0: expected the scored frames of an evaluation"
                ),
            });
        }
        for (name, v) in [
            ("macro_f1", s.macro_f1),
            ("slip.precision", s.slip.precision),
            ("slip.recall", s.slip.recall),
            ("slip.f1", s.slip.f1),
            ("static.precision", s.static_.precision),
            ("static.recall", s.static_.recall),
            ("static.f1", s.static_.f1),
        ] {
            self.check(row, &format!("{prefix}{name}"), v, 0.0, 1.0)?;
        }
        Ok(())
    }
}

pub fn sweep(path: &Path, rows: &[SweepRow]) -> Result<(), InputError> {
    // a header alone is no sweep (R-d)
    if rows.is_empty() {
        return Err(InputError::Format {
            path: path.to_path_buf(),
            message: "a header and no rows: expected the cells of a finished `tmo sweep`".into(),
        });
    }
    let c = Rows { path };
    for (i, r) in rows.iter().enumerate() {
        let row = i + 1;
        for (name, v) in [
            ("macro_f1", r.macro_f1),
            ("slip_precision", r.slip_precision),
            ("slip_recall", r.slip_recall),
            ("slip_f1", r.slip_f1),
            ("static_precision", r.static_precision),
            ("static_recall", r.static_recall),
            ("static_f1", r.static_f1),
        ] {
            c.check(row, name, v, 0.0, 1.0)?;
        }
        c.optional(row, "cv_macro_f1", r.cv_macro_f1, 0.0, 1.0)?;
        c.optional(row, "c", r.c, 0.0, f64::MAX)?;
        c.optional(row, "gamma", r.gamma, 0.0, f64::MAX)?;
        c.check(row, "seconds", r.seconds, 0.0, f64::MAX)?;
        let cell = (&r.classifier, &r.scope, &r.downsample, &r.n_slip);
        if let Some(k) = rows[..i]
            .iter()
            .position(|o| (&o.classifier, &o.scope, &o.downsample, &o.n_slip) == cell)
        {
            return Err(InputError::Format {
                path: path.to_path_buf(),
                message: format!(
                    "row {row}: the cell {} d {} n_slip {} again (row {}): each cell is scored once",
                    r.classifier,
                    r.downsample,
                    r.n_slip,
                    k + 1
                ),
            });
        }
        let d = r.downsample.parse::<f64>().unwrap_or(f64::NAN);
        if !(d.is_finite() && d > 0.0 && d <= 1.0) {
            return Err(InputError::Format {
                path: path.to_path_buf(),
                message: format!(
                    "row {row}: `downsample` = {}: expected a proportion in (0, 1]",
                    r.downsample
                ),
            });
        }
    }
    Ok(())
}

/// A batch's rows against its `batch.json`: one row for each trial it names, none twice,
/// none it does not name (rows copied or left over would otherwise count as trials).
pub fn rows_are_the_trials<'a>(
    path: &Path,
    trials: &[String],
    ids: impl Iterator<Item = &'a str>,
) -> Result<(), InputError> {
    let bad = |message: String| InputError::Format {
        path: path.to_path_buf(),
        message,
    };
    let mut seen = std::collections::HashSet::new();
    for (i, id) in ids.enumerate() {
        if !seen.insert(id) {
            return Err(bad(format!(
                "row {}: trial `{id}` again: each trial is scored once",
                i + 1
            )));
        }
        if !trials.iter().any(|t| t == id) {
            return Err(bad(format!(
                "row {}: trial `{id}` is not one of the {} trials batch.json names",
                i + 1,
                trials.len()
            )));
        }
    }
    if let Some(missing) = trials.iter().find(|t| !seen.contains(t.as_str())) {
        return Err(bad(format!(
            "no row for trial `{missing}`, which batch.json names ({} rows for {} trials)",
            seen.len(),
            trials.len()
        )));
    }
    Ok(())
}

/// Catch rows of a batch of `kind`. Times are from each trial's start, so never negative;
/// a latency is the reaction's time less the onset's.
pub fn catches(
    path: &Path,
    kind: crate::protocol::Kind,
    rows: &[OutcomeRow],
) -> Result<(), InputError> {
    let c = Rows { path };
    for (i, r) in rows.iter().enumerate() {
        let row = i + 1;
        c.check(row, "grasp_deg", r.grasp_deg, -360.0, 360.0)?;
        c.check(row, "extra_mass_g", r.extra_mass_g, 0.0, LARGEST)?;
        c.optional(row, "onset_s", r.onset_s, 0.0, LARGEST)?;
        c.optional(row, "reaction_s", r.reaction_s, 0.0, LARGEST)?;
        c.optional(row, "latency_s", r.latency_s, -LARGEST, LARGEST)?;
        c.optional(row, "slip_distance_mm", r.slip_distance_mm, 0.0, LARGEST)?;
        let bad = |message: String| InputError::Format {
            path: path.to_path_buf(),
            message: format!("row {row}: {message}"),
        };
        if let (Some(o), Some(t), Some(l)) = (r.onset_s, r.reaction_s, r.latency_s) {
            if (t - o - l).abs() > 1e-6 * (1.0 + t.abs()) {
                return Err(bad(format!(
                    "`latency_s` = {l}: expected reaction_s - onset_s = {}",
                    t - o
                )));
            }
        }
        // The rail rig has one fingertip: a row whose strategy needs more is another
        // kind's (a batch.json whose kind was changed).
        // (collect trials have no strategy: `-`)
        if kind == crate::protocol::Kind::RailCatch && !matches!(r.strategy.as_str(), "" | "-") {
            let strategy: Result<crate::online::strategy::Strategy, _> = r.strategy.parse();
            if !strategy.is_ok_and(|s| s.sensors == 1) {
                return Err(bad(format!(
                    "strategy `{}` is not a rail strategy (one fingertip, NFr1Sen): is batch.json's kind right?",
                    r.strategy
                )));
            }
        }
    }
    Ok(())
}

pub fn lifts(path: &Path, rows: &[LiftRow]) -> Result<(), InputError> {
    let c = Rows { path };
    for (i, r) in rows.iter().enumerate() {
        let row = i + 1;
        c.check(row, "mass_g", r.mass_g, 0.0, LARGEST)?;
        c.optional(row, "g_cont", r.g_cont, 0.0, 1.0)?;
        c.optional(row, "g_slip", r.g_slip, 0.0, 1.0)?;
        c.optional(row, "overgrasp", r.overgrasp, -LARGEST, LARGEST)?;
        c.optional(row, "object_rise_mm", r.object_rise_mm, -LARGEST, LARGEST)?;
        c.optional(row, "hand_rise_mm", r.hand_rise_mm, -LARGEST, LARGEST)?;
        c.optional(row, "lag_mm", r.lag_mm, -LARGEST, LARGEST)?;
    }
    Ok(())
}

pub fn calibrations(path: &Path, rows: &[CalibrationRow]) -> Result<(), InputError> {
    let c = Rows { path };
    for (i, r) in rows.iter().enumerate() {
        let row = i + 1;
        c.check(row, "mass_g", r.mass_g, 0.0, LARGEST)?;
        c.optional(row, "g_cont", r.g_cont, 0.0, 1.0)?;
        c.optional(row, "g_min", r.g_min, 0.0, 1.0)?;
    }
    Ok(())
}

pub fn evaluation(path: &Path, e: &Evaluation) -> Result<(), InputError> {
    use clap::ValueEnum;
    // tmo's own classifiers, and any ONNX model (docs/onnx.md)
    let known: Vec<&str> = crate::slip::classifier::ClassifierKind::value_variants()
        .iter()
        .map(|k| k.name())
        .chain([crate::slip::slip_model::ONNX_CLASSIFIER])
        .collect();
    if !known.contains(&e.classifier.as_str()) {
        return Err(InputError::Format {
            path: path.to_path_buf(),
            message: format!(
                "`classifier` = {:?}: expected one of {}",
                e.classifier,
                known.join(", ")
            ),
        });
    }
    let c = Rows { path };
    c.scores(1, "overall.", &e.overall)?;
    for (i, s) in e.per_sensor.iter().enumerate() {
        c.scores(1, &format!("per_sensor.{i}.scores."), &s.scores)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_header_only_sweep_and_scores_of_no_frames_are_refused() {
        let path = Path::new("s.csv");
        let e = sweep(path, &[]).unwrap_err();
        assert!(e.to_string().contains("a header and no rows"), "{e}");
        let zero = Scores {
            confusion: Default::default(),
            slip: Default::default(),
            static_: Default::default(),
            macro_f1: 0.0,
        };
        let e = Rows { path }.scores(1, "overall.", &zero).unwrap_err();
        assert!(e.to_string().contains("every count is 0"), "{e}");
    }

    #[test]
    fn an_onnx_models_evaluation_is_read_and_an_unknown_classifier_is_refused() {
        let mut scores = Scores::default();
        scores.confusion.true_slip = 3;
        scores.confusion.true_static = 5;
        let mut e = Evaluation {
            format: crate::slip::evaluation::EVALUATION_FORMAT.into(),
            model: "mine.onnx".into(),
            model_sha256: String::new(),
            classifier: "onnx".into(),
            scope: crate::slip::dataset::Scope::Global,
            n_slip: 13,
            trials: 1,
            rows: 8,
            overall: scores,
            per_sensor: vec![],
        };
        evaluation(Path::new("e.json"), &e).unwrap();
        e.classifier = "forest".into();
        let err = evaluation(Path::new("e.json"), &e).unwrap_err().to_string();
        assert!(
            err.contains("expected one of svm-rbf") && err.contains("onnx"),
            "{err}"
        );
    }
}
