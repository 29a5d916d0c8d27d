//! A batch's scored trials and the outcome files they are written to.

use std::path::Path;

use super::BatchError;
use crate::protocol::Kind;
use crate::runner::score::{CalibrationRow, LiftRow, OutcomeRow};

/// The scored trials of a batch, one row type per protocol kind (as `tmo report` reads
/// them back).
#[derive(Debug, Clone, PartialEq)]
pub enum BatchRows {
    Catch(Vec<OutcomeRow>),
    Lift(Vec<LiftRow>),
    Calibration(Vec<CalibrationRow>),
}

/// One kind of row per protocol kind; a batch fills one of them.
#[derive(Debug, Default, Clone, PartialEq)]
pub struct ScoredRows {
    pub catch: Vec<OutcomeRow>,
    pub lift: Vec<LiftRow>,
    pub calibration: Vec<CalibrationRow>,
    /// Each online trial's loop timing (`timing.csv`).
    pub timing: Vec<crate::runner::loop_timing::TimingRow>,
}

fn write_rows<T: serde::Serialize>(
    rows: &[T],
    csv_path: &Path,
    json_path: &Path,
) -> Result<(), BatchError> {
    let mut w = csv::Writer::from_writer(Vec::new());
    for r in rows {
        w.serialize(r).map_err(|e| BatchError::Csv {
            path: csv_path.to_path_buf(),
            message: e.to_string(),
        })?;
    }
    let bytes = w.into_inner().map_err(|e| BatchError::Csv {
        path: csv_path.to_path_buf(),
        message: e.to_string(),
    })?;
    write_atomic(csv_path, &bytes)?;
    write_atomic(
        json_path,
        serde_json::to_string_pretty(rows)
            .expect("rows serialise")
            .as_bytes(),
    )
}

impl ScoredRows {
    pub fn into_batch_rows(self, kind: Kind) -> BatchRows {
        match kind {
            Kind::FirstTimeLift => BatchRows::Lift(self.lift),
            Kind::CalibrateLift => BatchRows::Calibration(self.calibration),
            _ => BatchRows::Catch(self.catch),
        }
    }

    /// Trials a fault aborted.
    pub fn aborted(&self) -> usize {
        self.catch.iter().filter(|r| r.fault.is_some()).count()
            + self.lift.iter().filter(|r| r.fault.is_some()).count()
            + self
                .calibration
                .iter()
                .filter(|r| r.fault.is_some())
                .count()
    }

    /// How many scored catch trials carry a ground-truth verdict, and in how many the
    /// marker-scored verdict agrees with it (simulated trials only).
    pub fn truth_agreement(&self) -> Option<(usize, usize)> {
        crate::outcome::truth_agreement(self.catch.iter().map(|r| (r.verdict, r.truth_verdict)))
    }

    pub fn write(&self, csv_path: &Path, json_path: &Path) -> Result<(), BatchError> {
        if !self.lift.is_empty() {
            write_rows(&self.lift, csv_path, json_path)
        } else if !self.calibration.is_empty() {
            write_rows(&self.calibration, csv_path, json_path)
        } else {
            write_rows(&self.catch, csv_path, json_path)
        }
    }
}

/// Writes `bytes` to `path` through a temporary file renamed into place, so a reader (or a
/// crash) sees the old file or the new one, never half of one.
pub(crate) fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), BatchError> {
    crate::output::atomic::write_atomic(path, bytes).map_err(|source| BatchError::Io {
        path: path.to_path_buf(),
        source,
    })
}
