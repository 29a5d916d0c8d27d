//! What an import says about its trials beyond their count: names changed for their file
//! names, repeated readings, uneven frame intervals and rates that differ between trials.

use super::{log_file_name, ImportedTrial};
use crate::slip::features::RateSpread;

/// How many examples a note names before it says "and N more".
const EXAMPLES: usize = 3;
/// A share of repeated frames above this is a sensor slower than its log, not chance.
const REPEATS_WORTH_SAYING: f64 = 0.1;
/// A share of uneven intervals above this makes per-frame velocities unreliable.
const UNEVEN_WORTH_SAYING: f64 = 0.05;

/// Frames that repeat the previous frame's readings exactly, when there are so many that
/// the sensor is slower than the log that recorded it: what to say, `None` when few.
/// Said before anything is written, so that the import can be run again as it should be.
pub fn too_many_repeats(trials: &[ImportedTrial]) -> Option<String> {
    let frames: usize = trials.iter().map(|t| t.trial.frames.len()).sum();
    let repeated: u64 = trials.iter().map(|t| t.repeated_frames).sum();
    (repeated as f64 > REPEATS_WORTH_SAYING * (frames as f64 + repeated as f64)).then(|| {
        format!(
            "{repeated} of {frames} frames repeat the previous frame's readings exactly: the sensor seems to update slower than the log, and velocities are per frame"
        )
    })
}

/// What the import tells its user: `(warnings, notes)`. Many repeated frames without
/// `dedupe` are said as a warning (the importer refuses them first unless told to keep
/// them: [`too_many_repeats`]).
pub fn import_notes(trials: &[ImportedTrial], dedupe: bool) -> (Vec<String>, Vec<String>) {
    let (mut warnings, mut notes) = (Vec::new(), Vec::new());
    let renamed: Vec<String> = trials
        .iter()
        .filter(|t| log_file_name(&t.name) != format!("{}.mcap", t.name))
        .map(|t| format!("`{}` -> {}", t.name, log_file_name(&t.name)))
        .collect();
    if !renamed.is_empty() {
        notes.push(format!(
            "{} trial name(s) changed for their file names (the log keeps the name as its trial_id): {}",
            renamed.len(),
            examples(&renamed)
        ));
    }
    if dedupe {
        let dropped: u64 = trials.iter().map(|t| t.dropped_repeats).sum();
        let hit = trials.iter().filter(|t| t.dropped_repeats > 0).count();
        notes.push(format!(
            "--dedupe dropped {dropped} frame(s) that repeated the previous frame's readings, in {hit} of {} trial(s); the rest are numbered anew",
            trials.len()
        ));
    } else if let Some(why) = too_many_repeats(trials) {
        warnings.push(format!("{why}; kept as they are (--keep-repeats)"));
    }
    let uneven: Vec<String> = trials
        .iter()
        .filter(|t| {
            let (n, of) = t.uneven_intervals;
            of > 0 && n as f64 > UNEVEN_WORTH_SAYING * of as f64
        })
        .map(|t| {
            format!(
                "`{}` ({} of {})",
                t.name, t.uneven_intervals.0, t.uneven_intervals.1
            )
        })
        .collect();
    if !uneven.is_empty() {
        warnings.push(format!(
            "{} trial(s) have frame intervals under half or over 1.5 times their median, and velocities are per frame: {}",
            uneven.len(),
            examples(&uneven)
        ));
    }
    let rates: Vec<(&str, f64)> = trials
        .iter()
        .filter_map(|t| Some((t.name.as_str(), t.rate_hz?)))
        .collect();
    if let Some(spread) = RateSpread::of(&rates) {
        warnings.push(spread.to_string());
    }
    (warnings, notes)
}

fn examples(items: &[String]) -> String {
    let shown = items[..items.len().min(EXAMPLES)].join(", ");
    match items.len().saturating_sub(EXAMPLES) {
        0 => shown,
        more => format!("{shown} and {more} more"),
    }
}

/// The trials' median rate and its range, for the import's summary line.
pub fn rate_summary(trials: &[ImportedTrial]) -> String {
    let mut rates: Vec<f64> = trials.iter().filter_map(|t| t.rate_hz).collect();
    rates.sort_by(f64::total_cmp);
    match (rates.first(), rates.get(rates.len() / 2), rates.last()) {
        (Some(lo), Some(mid), Some(hi)) if hi / lo > 1.01 => {
            format!("{mid:.1} Hz (median; {lo:.1} to {hi:.1} Hz)")
        }
        (_, Some(mid), _) => format!("about {mid:.1} Hz"),
        _ => "no frame rate (single frames)".into(),
    }
}
