//! The second stage of a sensitivity study. A study of every parameter at the paper's
//! counts is some 40 CPU-hours, so it runs in two stages: a **screen**, every parameter at
//! both ends with its noise reference at the quick preset's counts (`--sensitivity`), and
//! a **second stage** at the paper's counts (`--screen DIR`) of the parameters the screen
//! cannot clear: every calibrated parameter (a value chosen while looking at findings is
//! where a finding may hinge on a choice), and every parameter one of whose ends changed
//! more verdicts in the screen than the screen's noise reference did (the seeds alone).

use std::collections::BTreeMap;
use std::path::Path;

use tmo_sim::parameters::ParameterRecord;

use super::sensitivity::RESEEDED;

/// One variant's outcome as `sensitivity.json` holds it.
#[derive(Debug, Clone, serde::Deserialize)]
struct ScreenOutcome {
    variant: ScreenVariant,
    #[serde(default)]
    changed: BTreeMap<String, serde_json::Value>,
    #[serde(default)]
    failed: Option<String>,
}

#[derive(Debug, Clone, serde::Deserialize)]
struct ScreenVariant {
    parameter: String,
    #[serde(default)]
    reseeded: bool,
}

#[derive(Debug, thiserror::Error)]
pub enum ScreenError {
    #[error("{path}: cannot read the screen's outcomes ({message}): give the --out of a finished `tmo reproduce --sensitivity` run")]
    Read { path: String, message: String },
    #[error("{path}: the screen has no noise reference, so no parameter can be told from the seeds: run the screen with --sensitivity (every parameter and the reference)")]
    NoReference { path: String },
    #[error("{path}: the screen's noise reference failed ({why}): run it again")]
    ReferenceFailed { path: String, why: String },
}

/// Why a parameter is in the second stage.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Selected {
    pub parameter: String,
    /// Findings its value was calibrated against (empty if it was not).
    pub calibrated_against: Vec<String>,
    /// The most verdicts one of its ends changed in the screen (`None`: not screened, or
    /// its variants failed there).
    pub screen_changes: Option<usize>,
}

/// The screen read from `dir/sensitivity.json`: the noise reference's count of changed
/// verdicts, and each parameter's largest count over its ends.
pub fn read(dir: &Path) -> Result<(usize, BTreeMap<String, Option<usize>>), ScreenError> {
    let path = dir.join("sensitivity.json");
    let shown = path.display().to_string();
    let text = std::fs::read_to_string(&path).map_err(|e| ScreenError::Read {
        path: shown.clone(),
        message: e.to_string(),
    })?;
    let outcomes: Vec<ScreenOutcome> =
        serde_json::from_str(&text).map_err(|e| ScreenError::Read {
            path: shown.clone(),
            message: e.to_string(),
        })?;
    let reference = outcomes
        .iter()
        .find(|o| o.variant.reseeded || o.variant.parameter == RESEEDED)
        .ok_or_else(|| ScreenError::NoReference {
            path: shown.clone(),
        })?;
    if let Some(why) = &reference.failed {
        return Err(ScreenError::ReferenceFailed {
            path: shown,
            why: why.clone(),
        });
    }
    let mut by_parameter: BTreeMap<String, Option<usize>> = BTreeMap::new();
    for o in outcomes.iter().filter(|o| !o.variant.reseeded) {
        let here = o.failed.is_none().then_some(o.changed.len());
        let entry = by_parameter
            .entry(o.variant.parameter.clone())
            .or_insert(None);
        *entry = match (*entry, here) {
            (Some(a), Some(b)) => Some(a.max(b)),
            (a, b) => a.or(b),
        };
    }
    Ok((reference.changed.len(), by_parameter))
}

/// The second stage's parameters, in the records' order: the calibrated ones and those
/// whose screen changed more verdicts than the reference did, among the `variable` ones
/// (a study cannot vary an object's property: a calibrated one is left out, and the
/// caller says so). A parameter the screen could not judge (its variants failed) is
/// kept: it was not cleared.
pub fn second_stage(
    records: &[ParameterRecord],
    variable: &[String],
    reference: usize,
    screened: &BTreeMap<String, Option<usize>>,
) -> Vec<Selected> {
    records
        .iter()
        .filter(|r| variable.contains(&r.name))
        .filter_map(|r| {
            let changes = screened.get(&r.name).copied();
            let calibrated = !r.calibrated_against.is_empty();
            let above_noise = match changes {
                Some(Some(c)) => c > reference,
                Some(None) => true,
                None => false,
            };
            (calibrated || above_noise).then(|| Selected {
                parameter: r.name.clone(),
                calibrated_against: r.calibrated_against.clone(),
                screen_changes: changes.flatten(),
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(name: &str, calibrated: &[&str]) -> ParameterRecord {
        ParameterRecord {
            name: name.into(),
            value: Some(1.0),
            unit: "1".into(),
            range: [0.5, 2.0],
            basis: tmo_sim::parameters::Basis::Estimate,
            source: "a stated estimate".into(),
            calibrated_against: calibrated.iter().map(|s| s.to_string()).collect(),
        }
    }

    #[test]
    fn the_second_stage_takes_calibrated_parameters_and_those_above_the_seeds_noise() {
        let dir = tempfile::tempdir().unwrap();
        let outcome = |parameter: &str, reseeded: bool, changed: usize, failed: bool| {
            let changed: serde_json::Map<String, serde_json::Value> = (0..changed)
                .map(|i| (format!("f{i}"), serde_json::json!(["yes", "no"])))
                .collect();
            serde_json::json!({
                "variant": {"parameter": parameter, "end": "low", "value": 0.0, "default": 0.0, "reseeded": reseeded},
                "changed": changed,
                "failed": if failed { serde_json::json!("it broke") } else { serde_json::Value::Null },
            })
        };
        let outcomes = serde_json::json!([
            outcome("reseeded", true, 3, false),
            outcome("a", false, 2, false),
            outcome("a", false, 3, false), // equal to the reference: cleared
            outcome("b", false, 4, false), // above it
            outcome("c", false, 0, false), // calibrated: kept whatever its screen
            outcome("d", false, 0, true),  // failed: not cleared
        ]);
        std::fs::write(dir.path().join("sensitivity.json"), outcomes.to_string()).unwrap();
        let (reference, screened) = read(dir.path()).unwrap();
        assert_eq!(reference, 3);
        assert_eq!(screened["a"], Some(3));
        assert_eq!(screened["d"], None);
        let records = [
            record("a", &[]),
            record("b", &[]),
            record("c", &["sf-best-n-slip"]),
            record("d", &[]),
            record("e", &[]), // never screened: not selected
        ];
        let variable: Vec<String> = records.iter().map(|r| r.name.clone()).collect();
        let chosen: Vec<String> = second_stage(&records, &variable, reference, &screened)
            .into_iter()
            .map(|s| s.parameter)
            .collect();
        assert_eq!(chosen, ["b", "c", "d"]);
        // a calibrated record a study cannot vary (an object's property) is left out
        let variable: Vec<String> = ["a", "b", "d", "e"].iter().map(|s| s.to_string()).collect();
        let chosen: Vec<String> = second_stage(&records, &variable, reference, &screened)
            .into_iter()
            .map(|s| s.parameter)
            .collect();
        assert_eq!(chosen, ["b", "d"]);
    }

    #[test]
    fn a_screen_without_a_noise_reference_or_with_a_failed_one_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let e = read(dir.path()).unwrap_err();
        assert!(matches!(e, ScreenError::Read { .. }), "{e}");
        std::fs::write(
            dir.path().join("sensitivity.json"),
            r#"[{"variant": {"parameter": "a", "end": "low", "value": 0, "default": 1}, "changed": {}}]"#,
        )
        .unwrap();
        let e = read(dir.path()).unwrap_err();
        assert!(e.to_string().contains("no noise reference"), "{e}");
        std::fs::write(
            dir.path().join("sensitivity.json"),
            r#"[{"variant": {"parameter": "reseeded", "end": "other seeds", "value": 0, "default": 0, "reseeded": true}, "changed": {}, "failed": "killed"}]"#,
        )
        .unwrap();
        let e = read(dir.path()).unwrap_err();
        assert!(e.to_string().contains("killed"), "{e}");
    }
}
