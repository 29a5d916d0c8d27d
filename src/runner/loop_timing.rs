//! Each online trial's timing, from its log's `/timing` channel (`timing.csv` beside a
//! batch's outcomes): whether its loop kept its cameras' pace (docs/online.md).

use crate::online::deadline::{FrameTiming, TimingSummary};
use crate::trial::Trial;

/// The file beside a batch's outcomes that holds its trials' timing.
pub const TIMING_CSV: &str = "timing.csv";

/// `rows` as CSV.
pub fn to_csv(rows: &[TimingRow]) -> Result<Vec<u8>, String> {
    let mut w = csv::Writer::from_writer(Vec::new());
    for r in rows {
        w.serialize(r).map_err(|e| e.to_string())?;
    }
    w.into_inner().map_err(|e| e.to_string())
}

/// The rows of a batch's `timing.csv`; none where it has none (collected, or older).
pub fn read_csv(path: &std::path::Path) -> Result<Vec<TimingRow>, String> {
    if !path.is_file() {
        return Ok(Vec::new());
    }
    let mut r = csv::Reader::from_path(path).map_err(|e| e.to_string())?;
    r.deserialize()
        .map(|row| row.map_err(|e| e.to_string()))
        .collect()
}

/// One online trial's timing.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TimingRow {
    pub trial_id: String,
    pub model: String,
    pub strategy: String,
    /// `sim` (lock-step: the lateness is simulated time alone) or `real` (a wall clock).
    pub backend: String,
    pub frames: u64,
    /// Frames decided after their due time.
    pub late: u64,
    pub lateness_p50_ms: f64,
    pub lateness_p99_ms: f64,
    pub lateness_max_ms: f64,
    /// This machine's work from a frame's poll to its decision, p99, ms.
    pub work_p99_ms: f64,
    pub classify_p99_ms: f64,
    /// Frames this machine's work would have made late at the rig's pace (on a wall clock,
    /// the work is in the lateness already).
    pub late_with_work: u64,
    /// The trial faulted on its deadline (and was not scored).
    pub deadline_fault: bool,
}

/// The timing of `trial`, if it timed its frames (an online trial of this version).
pub fn timing_row(trial: &Trial) -> Option<TimingRow> {
    let timings: Vec<FrameTiming> = trial
        .events
        .iter()
        .filter(|e| e.topic == "/timing")
        .filter_map(|e| serde_json::from_value(e.data.clone()).ok())
        .collect();
    let s = TimingSummary::of(&timings)?;
    let param = |k: &str| trial.meta.parameters.get(k).cloned();
    Some(TimingRow {
        trial_id: trial.meta.trial_id.clone(),
        model: super::score::model_name(trial),
        strategy: param("strategy").unwrap_or_else(|| "-".into()),
        backend: trial.meta.backend.clone(),
        frames: s.frames,
        late: s.late,
        lateness_p50_ms: s.lateness_p50_ms,
        lateness_p99_ms: s.lateness_p99_ms,
        lateness_max_ms: s.lateness_max_ms,
        work_p99_ms: s.work_p99_ms,
        classify_p99_ms: s.classify_p99_ms,
        late_with_work: s.late_with_work,
        deadline_fault: param("fault").is_some_and(|f| f.contains("\"deadline\"")),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_trial_with_timings_gives_its_row() {
        let mut t = crate::trial::tests::sample_trial();
        t.events.clear();
        assert_eq!(timing_row(&t), None);
        for (seq, lateness_ms) in [(1u64, -10.0), (2, -12.0), (3, 4.0)] {
            t.events.push(crate::runner::event(
                0.1 * seq as f64,
                "/timing",
                serde_json::json!(FrameTiming {
                    sensor: 0,
                    seq,
                    arrived_s: 0.0,
                    due_s: 0.0,
                    decided_s: 0.0,
                    lateness_ms,
                    work_ms: 0.5,
                    classify_ms: 0.2,
                }),
            ));
        }
        t.meta.parameters.insert(
            "fault".into(),
            r#"{"fault":"deadline","breach":"share"}"#.into(),
        );
        let row = timing_row(&t).unwrap();
        assert_eq!((row.frames, row.late, row.deadline_fault), (3, 1, true));
        assert_eq!(row.lateness_max_ms, 4.0);
        let text = String::from_utf8(to_csv(std::slice::from_ref(&row)).unwrap()).unwrap();
        assert!(
            text.starts_with("trial_id,model,strategy,backend,frames,late,"),
            "{text}"
        );
    }
}
