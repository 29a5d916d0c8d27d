//! Outcomes of trials, computed from their logs alone (markers, metadata and runner
//! events), so sim, replay and real trials are scored by the same code.

use std::collections::BTreeMap;
use std::path::Path;

use crate::outcome::lift::{overgrasp, rise, score_lift, LiftSpec, LiftWindow};
use crate::outcome::{score_catch, truth_verdict, CatchOutcome, CatchSpec, TruthRecord, Verdict};
use crate::runner::calibrate::lifted;
use crate::trial::Trial;

/// One line of a batch's outcome table, computed from a trial log alone.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct OutcomeRow {
    pub trial_id: String,
    pub object: String,
    pub grasp_deg: f64,
    /// The slip model's name (`tmo.name`, else its file's stem): each of a protocol's
    /// models is kept apart in every table.
    #[serde(default = "no_model")]
    pub model: String,
    pub scope: String,
    pub strategy: String,
    pub verdict: Verdict,
    pub onset_s: Option<f64>,
    pub reaction_s: Option<f64>,
    pub latency_s: Option<f64>,
    pub dropped: bool,
    pub slip_distance_mm: Option<f64>,
    /// Why the trial was aborted, if it was (JSON).
    pub fault: Option<String>,
    /// Reactions of the hand (the detector's events in the log).
    pub responses: usize,
    /// The verdict by the simulator's ground truth (diagnostic; simulated trials only).
    #[serde(default)]
    pub truth_verdict: Option<Verdict>,
    /// Mass added to the object, g.
    #[serde(default)]
    pub extra_mass_g: f64,
}

/// The ground truth a simulated trial's log records, if it records one.
pub fn truth_record(trial: &Trial) -> Option<TruthRecord> {
    let time = |k: &str| -> Option<Option<f64>> {
        let v = param(trial, k)?;
        Some(v.parse().ok())
    };
    Some(TruthRecord {
        measurable_slip_s: time("sim_truth_measurable_slip_s")?,
        first_slip_s: param(trial, "sim_truth_slip_onsets_s")
            .and_then(|v| v.split(',').next().and_then(|t| t.parse().ok())),
        drop_s: time("sim_truth_drop_s")?,
    })
}

pub fn score_trial(trial: &Trial, spec: &CatchSpec) -> OutcomeRow {
    let param = |k: &str| param(trial, k);
    let reaction_s = param("reaction_s").and_then(|v| v.parse().ok());
    let o: CatchOutcome = score_catch(&trial.markers, reaction_s, spec);
    OutcomeRow {
        trial_id: trial.meta.trial_id.clone(),
        object: trial.meta.object.clone(),
        grasp_deg: trial.meta.grasp_deg,
        model: model_name(trial),
        scope: param("scope").unwrap_or_else(|| "-".into()),
        strategy: param("strategy").unwrap_or_else(|| "-".into()),
        verdict: o.verdict,
        onset_s: o.onset_s,
        reaction_s,
        latency_s: o.latency_s,
        dropped: o.dropped,
        slip_distance_mm: o.slip_distance_mm,
        fault: param("fault"),
        responses: responses(trial),
        truth_verdict: truth_record(trial).map(|t| truth_verdict(&t, reaction_s)),
        extra_mass_g: mass(trial),
    }
}

/// What a row without a model says (a collect trial, or an outcome file from before models
/// were named).
fn no_model() -> String {
    "-".into()
}

/// The name of the model a trial ran: as the batch named it, else (a log from before
/// names were recorded) its file's stem.
pub fn model_name(trial: &Trial) -> String {
    param(trial, MODEL_NAME_PARAMETER)
        .or_else(|| {
            param(trial, "model").map(|p| crate::slip::slip_model::file_stem(Path::new(&p)))
        })
        .unwrap_or_else(no_model)
}

/// The trial parameter that names the model it ran, as its batch's tables name it.
pub const MODEL_NAME_PARAMETER: &str = "model_name";

fn param(trial: &Trial, key: &str) -> Option<String> {
    trial.meta.parameters.get(key).cloned()
}

/// Reactions of the hand (not the detector's being armed or disarmed).
fn responses(trial: &Trial) -> usize {
    trial
        .events
        .iter()
        .filter(|e| crate::trial::is_reaction(e))
        .count()
}

/// The `/phase` events of a trial: (time, name, data).
fn phases(trial: &Trial) -> impl Iterator<Item = (f64, &str, &serde_json::Value)> {
    trial
        .events
        .iter()
        .filter(|e| e.topic == "/phase")
        .filter_map(|e| Some((e.time_s, e.data.get("phase")?.as_str()?, &e.data)))
}

fn number(v: &serde_json::Value, key: &str) -> Option<f64> {
    v.get(key)?.as_f64()
}

/// One first-time lift, as the paper's Fig. 13 needs it.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LiftRow {
    pub trial_id: String,
    pub object: String,
    pub mass_g: f64,
    #[serde(default = "no_model")]
    pub model: String,
    pub scope: String,
    pub strategy: String,
    pub success: bool,
    /// Responses of the hand (each closed it by the close step).
    pub slips: usize,
    pub g_cont: Option<f64>,
    pub g_slip: Option<f64>,
    /// Needs the calibration table; `None` for a failed lift.
    pub overgrasp: Option<f64>,
    pub object_rise_mm: Option<f64>,
    pub hand_rise_mm: Option<f64>,
    /// How far the hand rose before the object left the table, mm.
    pub lag_mm: Option<f64>,
    pub fault: Option<String>,
}

/// One calibration sweep: the smallest closure that lifted the object.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CalibrationRow {
    pub trial_id: String,
    pub object: String,
    pub mass_g: f64,
    pub g_cont: Option<f64>,
    pub g_min: Option<f64>,
    pub attempts: usize,
    pub fault: Option<String>,
}

fn mass(trial: &Trial) -> f64 {
    param(trial, "extra_mass_g")
        .and_then(|v| v.parse().ok())
        .unwrap_or(0.0)
}

fn lift_spec(onset_threshold_mm: f64) -> LiftSpec {
    LiftSpec {
        onset_threshold_mm,
        ..Default::default()
    }
}

pub fn score_first_time_lift(
    trial: &Trial,
    onset_threshold_mm: f64,
    table: Option<&GMinTable>,
) -> LiftRow {
    let (mut g_cont, mut g_slip, mut lift_start, mut hold_end) = (None, None, None, None);
    for (t, name, data) in phases(trial) {
        match name {
            "contact" => g_cont = number(data, "closure"),
            "lifting" => lift_start = Some(t),
            "hold_end" => (hold_end, g_slip) = (Some(t), number(data, "closure")),
            _ => {}
        }
    }
    let outcome = lift_start.zip(hold_end).and_then(|(a, b)| {
        let w = LiftWindow {
            lift_start_s: a,
            hold_end_s: b,
        };
        score_lift(&trial.markers, &w, &lift_spec(onset_threshold_mm))
    });
    let success = outcome.is_some_and(|o| o.success);
    let mass_g = mass(trial);
    let min_past_contact = table.and_then(|t| t.min_past_contact(&trial.meta.object, mass_g));
    LiftRow {
        trial_id: trial.meta.trial_id.clone(),
        object: trial.meta.object.clone(),
        mass_g,
        model: model_name(trial),
        scope: param(trial, "scope").unwrap_or_else(|| "-".into()),
        strategy: param(trial, "strategy").unwrap_or_else(|| "-".into()),
        success,
        slips: responses(trial),
        g_cont,
        g_slip,
        overgrasp: match (success, g_slip, g_cont, min_past_contact) {
            (true, Some(s), Some(c), Some(m)) => overgrasp(s, c, m),
            _ => None,
        },
        object_rise_mm: outcome.map(|o| o.rise.object_mm),
        hand_rise_mm: outcome.map(|o| o.rise.hand_mm),
        lag_mm: outcome.and_then(|o| o.lag_mm),
        fault: param(trial, "fault"),
    }
}

/// Re-judges every attempt from the marker track, as the runner did.
pub fn score_calibration(
    trial: &Trial,
    onset_threshold_mm: f64,
    max_slide_mm: f64,
) -> CalibrationRow {
    let (mut g_cont, mut g_min, mut attempts) = (None, None, 0);
    let (mut closure, mut lift_start) = (None, None);
    for (t, name, data) in phases(trial) {
        match name {
            "contact" => g_cont = number(data, "closure"),
            "attempt" => {
                attempts += 1;
                closure = number(data, "closure");
            }
            "lifting" => lift_start = Some(t),
            "hold_end" if g_min.is_none() => {
                let w = lift_start.map(|a| LiftWindow {
                    lift_start_s: a,
                    hold_end_s: t,
                });
                let r = w.and_then(|w| rise(&trial.markers, &w, &lift_spec(onset_threshold_mm)));
                if r.is_some_and(|r| lifted(&r, max_slide_mm)) {
                    g_min = closure;
                }
            }
            _ => {}
        }
    }
    CalibrationRow {
        trial_id: trial.meta.trial_id.clone(),
        object: trial.meta.object.clone(),
        mass_g: mass(trial),
        g_cont,
        g_min,
        attempts,
        fault: param(trial, "fault"),
    }
}

/// Version of the g_min table format.
pub const GMIN_FORMAT_VERSION: u32 = 1;

/// What a calibration batch found, per object and mass: what the first-time lift's
/// overgrasp is measured against.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct GMinTable {
    pub format_version: u32,
    pub entries: Vec<GMinEntry>,
}

#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct GMinEntry {
    pub object: String,
    pub mass_g: f64,
    /// Medians over the calibration trials that found a g_min.
    pub g_cont: f64,
    pub g_min: f64,
    /// Median of `g_min - g_cont` per trial: the minimal grasp strength past contact.
    pub min_past_contact: f64,
    pub trials: usize,
}

#[derive(Debug, thiserror::Error)]
pub enum GMinError {
    #[error("cannot read {path}: {source}")]
    Io {
        path: String,
        source: std::io::Error,
    },
    #[error("{path}: not a g_min table: {source}")]
    Parse {
        path: String,
        source: serde_json::Error,
    },
    #[error("{path}: g_min table format {found}, this tmo reads {GMIN_FORMAT_VERSION}")]
    Version { path: String, found: u32 },
    #[error("{path}: not a g_min table ({what}); a calibration batch writes one as g_min.json")]
    NotATable { path: String, what: &'static str },
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

impl GMinTable {
    /// One entry per object and mass, from the calibration rows that found a g_min.
    /// The table of `rows`; trials a fault aborted are left out, as the report leaves them
    /// out of its calibration table.
    pub fn from_rows(rows: &[CalibrationRow]) -> Self {
        let mut cells: BTreeMap<(String, u64), Vec<(f64, f64)>> = BTreeMap::new();
        for r in rows.iter().filter(|r| r.fault.is_none()) {
            if let (Some(c), Some(m)) = (r.g_cont, r.g_min) {
                cells
                    .entry((r.object.clone(), r.mass_g.to_bits()))
                    .or_default()
                    .push((c, m));
            }
        }
        let entries = cells
            .into_iter()
            .map(|((object, mass), v)| GMinEntry {
                object,
                mass_g: f64::from_bits(mass),
                g_cont: median(v.iter().map(|p| p.0).collect()),
                g_min: median(v.iter().map(|p| p.1).collect()),
                min_past_contact: median(v.iter().map(|p| p.1 - p.0).collect()),
                trials: v.len(),
            })
            .collect();
        Self {
            format_version: GMIN_FORMAT_VERSION,
            entries,
        }
    }

    pub fn min_past_contact(&self, object: &str, mass_g: f64) -> Option<f64> {
        self.entries
            .iter()
            .find(|e| e.object == object && (e.mass_g - mass_g).abs() < 1e-6)
            .map(|e| e.min_past_contact)
    }

    pub fn load(path: &Path) -> Result<Self, GMinError> {
        let p = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|source| GMinError::Io {
            path: p.clone(),
            source,
        })?;
        let version: serde_json::Value =
            serde_json::from_str(&text).map_err(|source| GMinError::Parse {
                path: p.clone(),
                source,
            })?;
        let Some(found) = version.get("format_version").and_then(|v| v.as_u64()) else {
            return Err(GMinError::NotATable {
                path: p,
                what: if version.get("format").and_then(|f| f.as_str())
                    == Some(crate::slip::model::MODEL_FORMAT)
                {
                    "it is a model file"
                } else {
                    "it has no format_version"
                },
            });
        };
        let found = found.min(u64::from(u32::MAX)) as u32;
        if found != GMIN_FORMAT_VERSION {
            return Err(GMinError::Version { path: p, found });
        }
        serde_json::from_str(&text).map_err(|source| GMinError::Parse { path: p, source })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn responses_count_reactions_only() {
        let mut t = crate::trial::tests::sample_trial();
        let at = |time_s: f64, event: &str| {
            crate::runner::event(time_s, "/detector", serde_json::json!({ "event": event }))
        };
        t.events = vec![
            at(1.0, "armed"),
            at(1.5, "reaction"),
            at(1.6, "disarmed"),
            at(2.0, "armed"),
            at(2.5, "reaction"),
        ];
        assert_eq!(responses(&t), 2);
    }

    #[test]
    fn a_calibration_a_fault_aborted_is_not_in_the_g_min_table() {
        let row = |g_min: f64, fault: Option<&str>| CalibrationRow {
            trial_id: "t".into(),
            object: "crisps_can_empty".into(),
            mass_g: 100.0,
            g_cont: Some(0.50),
            g_min: Some(g_min),
            attempts: 3,
            fault: fault.map(String::from),
        };
        let table =
            GMinTable::from_rows(&[row(0.52, None), row(0.90, Some("{\"NoContact\":null}"))]);
        assert_eq!(table.entries.len(), 1);
        assert_eq!(table.entries[0].trials, 1);
        assert!((table.entries[0].g_min - 0.52).abs() < 1e-12);
    }
}
