//! Recordings of other tactile sensors, in the interchange CSV (`docs/formats.md`,
//! "Interchange CSV"), turned into tmo trial logs so that the whole pipeline (datasets,
//! training, sweeps, evaluation, replay) runs on them.
//!
//! One row per element per frame: `trial, sensor, frame, t_s, element, x, y`, plus exactly
//! one label source: a `slip` column (0/1 per frame), an `onset_s` column (per trial, empty
//! for a trial without slip), or `object_mm` and `hand_mm` (marker heights per frame, then
//! tmo's own marker labelling applies). A trial's elements are its "pins": `x`, `y` are
//! whatever 2-D displacement the sensor reports, in its own units.
//!
//! Labels from a `slip` or `onset_s` column are kept as the trial's `/label` track (one
//! event per frame time, `{"slip": true|false}`); [`crate::slip::labels::trial_slip_window`]
//! reads them in place of the marker track.

mod notes;
mod parse;
mod write;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use tmo_hal::{MarkerSample, PinFrame};

use crate::trial::{Trial, TrialEvent, TrialMeta, TRIAL_FORMAT_VERSION};

pub use notes::{import_notes, rate_summary, too_many_repeats};
pub use parse::{read_interchange, INTERCHANGE_COLUMNS};
pub use write::{export_interchange, write_interchange, z_by_frame, ExportError};

pub use crate::trial::LABEL_TOPIC;
/// Topics of an imported sensor's third coordinate (`z`: a taxel's normal reading), one per
/// sensor (`/element_z/0`, ...): one event per frame, `{"seq": N, "z": [...]}`. Carried
/// along for the user; features use `x` and `y` only.
pub const Z_TOPIC_PREFIX: &str = "/element_z/";
pub use crate::trial::{IMPORTED_KIND, MAX_STEP_PARAMETER};

pub use crate::slip::features::Units;

/// How a file is read.
#[derive(Debug, Clone, PartialEq)]
pub struct ImportOptions {
    /// What the sensor is (e.g. `xela-uskin-4x4`), recorded with each trial.
    pub sensor_name: String,
    pub units: Units,
    /// A column naming each trial's split (e.g. `train`, `test`); trials go into a
    /// sub-directory of that name.
    pub split_column: Option<String>,
    /// Largest per-frame step of an element that is a measurement, in `units`; `None`: no
    /// limit (tmo's own 20 px guard is for tracked pins only).
    pub max_step: Option<f64>,
    /// The file's own names of interchange columns (`element` -> `taxel`, say).
    pub columns: BTreeMap<String, String>,
    /// Element indices count from 1 in the file.
    pub one_based: bool,
    /// Drop frames whose readings repeat the previous frame's exactly (a sensor that
    /// updates slower than the log that recorded it), numbering the rest anew.
    pub dedupe: bool,
}

impl Default for ImportOptions {
    fn default() -> Self {
        Self {
            sensor_name: "unnamed".into(),
            units: Units::Px,
            split_column: None,
            max_step: None,
            columns: BTreeMap::new(),
            one_based: false,
            dedupe: false,
        }
    }
}

/// Slowest and fastest plausible frame rates, Hz: a median interval outside them is a time
/// column in other units (ms, ticks) or a typo, not a sensor.
pub const RATE_RANGE_HZ: (f64, f64) = (0.1, 100_000.0);
/// Largest `t_s` magnitude, s (Unix times in seconds fit; nanoseconds do not).
pub const MAX_TIME_S: f64 = 1e10;

/// Where a trial's slip labels come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LabelSource {
    SlipColumn,
    OnsetColumn,
    MarkerHeights,
}

impl LabelSource {
    pub fn name(self) -> &'static str {
        match self {
            LabelSource::SlipColumn => "slip column",
            LabelSource::OnsetColumn => "onset_s column",
            LabelSource::MarkerHeights => "object_mm and hand_mm (marker labelling)",
        }
    }
}

/// Bad input, named by file and line (1-based, the header is line 1) or by trial.
#[derive(Debug, thiserror::Error)]
pub enum ImportError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}:{line}: {message}")]
    Row {
        path: PathBuf,
        line: u64,
        message: String,
    },
    #[error("{path}: {message}")]
    File { path: PathBuf, message: String },
}

/// One trial read from a file, ready to be written as a log.
#[derive(Debug, Clone, PartialEq)]
pub struct ImportedTrial {
    /// The trial's name in the file (also its log's file name, made safe).
    pub name: String,
    pub split: Option<String>,
    pub trial: Trial,
    /// Frames whose readings repeat the previous frame's exactly: dropped with
    /// [`ImportOptions::dedupe`], else counted so the importer can say so.
    pub repeated_frames: u64,
    pub dropped_repeats: u64,
    /// Frame intervals more than half again or less than half the trial's median, of all.
    pub uneven_intervals: (usize, usize),
    /// The trial's frame rate (one over its median interval per frame number), Hz.
    pub rate_hz: Option<f64>,
}

/// What a file held, beside its trials.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ImportSummary {
    pub trials: Vec<ImportedTrial>,
    /// Columns the interchange format does not use (read past, not stored).
    pub ignored_columns: Vec<String>,
    pub rows: u64,
}

/// One trial's frames, labels and heights as read, before it becomes a [`Trial`].
#[derive(Debug, Default)]
pub(crate) struct TrialRows {
    /// Per sensor name (in first-seen order), per frame number: time and elements.
    pub sensors: Vec<(String, BTreeMap<u64, FrameRows>)>,
    /// Per frame time (as bits, exact): slip label.
    pub labels: BTreeMap<u64, (f64, bool)>,
    /// Per trial: the onset (f64 bits, compared exactly), `Some(None)` for no slip.
    pub onset_s: Option<Option<u64>>,
    pub markers: BTreeMap<u64, MarkerSample>,
    pub split: Option<String>,
    pub object: Option<String>,
}

#[derive(Debug, Default)]
pub(crate) struct FrameRows {
    pub time_s: f64,
    /// First line of the frame (for messages).
    pub line: u64,
    pub elements: Vec<Option<[f32; 2]>>,
    /// The elements' `z` when the file has a `z` column; a frame has z on all its rows or on
    /// none (an empty cell: e.g. a trial without z exported beside one with it).
    pub z: Vec<Option<f32>>,
}

/// Builds the trial log of one trial. `elements` is the file's element count, `sensors`
/// its sensor names in id order.
pub(crate) fn build_trial(
    name: &str,
    rows: TrialRows,
    sensors: &[String],
    elements: usize,
    source: LabelSource,
    file: (&Path, &str),
    opts: &ImportOptions,
) -> Result<ImportedTrial, String> {
    if log_file_name(name) == ".mcap" {
        return Err(format!(
            "trial `{name}`: its name gives its log no file name; name trials with a letter or digit"
        ));
    }
    if let Some(split) = &rows.split {
        if log_file_name(split) == ".mcap" {
            return Err(format!(
                "trial `{name}`: split `{split}` gives its folder no name; name splits with a letter or digit"
            ));
        }
    }
    let mut frames = Vec::new();
    let mut z_events = Vec::new();
    let mut intervals = Vec::new();
    let (mut repeated_frames, mut dropped_repeats) = (0u64, 0u64);
    for (sensor_name, by_frame) in &rows.sensors {
        let sensor = sensors
            .iter()
            .position(|s| s == sensor_name)
            .expect("sensor names come from the file") as u8;
        let mut previous: Option<(u64, f64)> = None;
        let mut last_reading: Option<&FrameRows> = None;
        let mut last_kept: Option<(u64, f64)> = None;
        // With --dedupe, frames are numbered anew from the first frame's number.
        let mut next_seq = by_frame.keys().next().copied().unwrap_or(0);
        for (&file_seq, f) in by_frame {
            if let Some(missing) =
                (0..elements).find(|&e| f.elements.get(e).is_none_or(Option::is_none))
            {
                return Err(format!(
                    "trial `{name}`, sensor `{sensor_name}`, frame {file_seq} (from line {}): element {missing} is missing; every frame needs elements 0..{}",
                    f.line,
                    elements - 1
                ));
            }
            if let Some((prev_seq, prev_t)) = previous {
                if f.time_s <= prev_t {
                    return Err(format!(
                        "trial `{name}`, sensor `{sensor_name}`: frame {file_seq} (line {}) has t_s {} but frame {prev_seq} had {prev_t}; times must rise with frame numbers",
                        f.line, f.time_s
                    ));
                }
            }
            previous = Some((file_seq, f.time_s));
            let repeats =
                last_reading.is_some_and(|last| last.elements == f.elements && last.z == f.z);
            last_reading = Some(f);
            if repeats {
                repeated_frames += 1;
                if opts.dedupe {
                    dropped_repeats += 1;
                    continue;
                }
            }
            let seq = if opts.dedupe { next_seq } else { file_seq };
            next_seq = seq + 1;
            // per frame number: a lost frame's gap is not an uneven interval
            if let Some((kept_seq, kept_t)) = last_kept {
                intervals.push((f.time_s - kept_t) / (seq - kept_seq) as f64);
            }
            last_kept = Some((seq, f.time_s));
            let z: Option<Vec<f32>> = f.z.iter().copied().collect();
            match z {
                Some(z) if z.len() == elements => z_events.push(TrialEvent {
                    time_s: f.time_s,
                    topic: format!("{Z_TOPIC_PREFIX}{sensor}"),
                    data: serde_json::json!({ "seq": seq, "z": z }),
                }),
                _ if f.z.iter().all(Option::is_none) => {}
                _ => {
                    return Err(format!(
                        "trial `{name}`, sensor `{sensor_name}`, frame {file_seq} (from line {}): `z` is given for some elements and not others; give it for all of a frame's elements or none",
                        f.line
                    ))
                }
            }
            frames.push(PinFrame {
                sensor,
                seq,
                time_s: f.time_s,
                pins: f
                    .elements
                    .iter()
                    .map(|e| e.expect("checked above"))
                    .collect(),
            });
        }
    }
    for s in sensors {
        if !rows.sensors.iter().any(|(n, _)| n == s) {
            return Err(format!(
                "trial `{name}` has no frames of sensor `{s}` (other trials have them)"
            ));
        }
    }
    // Arrival order across sensors, as a rig's host would have seen them.
    frames.sort_by(|a, b| a.time_s.total_cmp(&b.time_s).then(a.sensor.cmp(&b.sensor)));
    let t_first = frames.first().map_or(0.0, |f| f.time_s);
    let t_last = frames.last().map_or(0.0, |f| f.time_s);
    if let Some(onset) = rows.onset_s.flatten().map(f64::from_bits) {
        if !(t_first..=t_last).contains(&onset) {
            return Err(format!(
                "trial `{name}`: onset_s {} is outside its frames' times ({} to {} s); an onset is a frame time of the trial's slip (leave onset_s empty for a trial without slip)",
                crate::quote::number(onset),
                crate::quote::number(t_first),
                crate::quote::number(t_last)
            ));
        }
    }
    intervals.sort_by(f64::total_cmp);
    let median_interval = intervals.get(intervals.len() / 2).copied();
    let rate_hz = median_interval.map(|dt| 1.0 / dt);
    if let Some(rate) = rate_hz {
        let (slowest, fastest) = RATE_RANGE_HZ;
        // the rate is the inverse of a difference of times: exactly 100 kHz in the file can
        // come out a rounding above it (T4-12), so the edges allow one part in 10^9
        let within = rate >= slowest * (1.0 - 1e-9) && rate <= fastest * (1.0 + 1e-9);
        if !within {
            return Err(format!(
                "trial `{name}`: its frames are {} s apart (median), a rate of {rate:.3e} Hz; expected {slowest} to {fastest} Hz (is t_s in seconds?)",
                crate::quote::number(1.0 / rate)
            ));
        }
    }
    let uneven = median_interval.map_or(0, |m| {
        intervals
            .iter()
            .filter(|&&dt| !(0.5 * m..=1.5 * m).contains(&dt))
            .count()
    });
    let mut events = Vec::new();
    match source {
        LabelSource::SlipColumn => {
            events.extend(rows.labels.values().map(|&(t, slip)| label_event(t, slip)));
        }
        LabelSource::OnsetColumn => {
            let onset = rows.onset_s.flatten().map(f64::from_bits);
            // static from the first frame until the onset (a slip from before the first
            // frame has no static part: a static label after it would end the slip)
            if onset.is_none_or(|o| o > t_first) {
                events.push(label_event(t_first, false));
            }
            if let Some(onset) = onset {
                events.push(label_event(onset, true));
            }
        }
        LabelSource::MarkerHeights => {}
    }
    z_events.sort_by(|a, b| a.time_s.total_cmp(&b.time_s));
    let has_z = !z_events.is_empty();
    events.extend(z_events);
    let mut parameters = BTreeMap::from([
        ("source_file".to_string(), file.0.display().to_string()),
        ("source_sha256".to_string(), file.1.to_string()),
        ("sensor_name".to_string(), opts.sensor_name.clone()),
        ("sensor_names".to_string(), sensors.join(",")),
        ("units".to_string(), opts.units.name().to_string()),
        (
            "rate_hz".to_string(),
            rate_hz.map_or(String::new(), |r| format!("{r:.3}")),
        ),
        ("label_source".to_string(), source.name().to_string()),
        (
            MAX_STEP_PARAMETER.to_string(),
            opts.max_step.map_or("off".to_string(), |m| m.to_string()),
        ),
    ]);
    if let Some(split) = &rows.split {
        parameters.insert("split".to_string(), split.clone());
    }
    if has_z {
        parameters.insert("z".to_string(), format!("{Z_TOPIC_PREFIX}<sensor>"));
    }
    if opts.dedupe {
        parameters.insert(
            "repeated_frames_dropped".to_string(),
            dropped_repeats.to_string(),
        );
    }
    let arrivals_s = frames.iter().map(|f| f.time_s).collect();
    let trial = Trial {
        meta: imported_meta(
            name,
            rows.object.clone().unwrap_or_else(|| "unknown".to_string()),
            sensors.len() as u8,
            elements,
            parameters,
        ),
        frames,
        arrivals_s,
        markers: rows.markers.into_values().collect(),
        events,
        sources: Vec::new(),
    };
    Ok(ImportedTrial {
        name: name.to_string(),
        split: rows.split,
        trial,
        repeated_frames,
        dropped_repeats,
        uneven_intervals: (uneven, intervals.len()),
        rate_hz,
    })
}

/// The metadata of an imported trial: no seed, protocol or model ran it, and when it was
/// recorded is unknown (`started_unix_s` 0).
pub fn imported_meta(
    name: &str,
    object: String,
    sensors: u8,
    elements: usize,
    parameters: BTreeMap<String, String>,
) -> TrialMeta {
    let (tmo_version, git_revision) = TrialMeta::code_version();
    TrialMeta {
        format_version: TRIAL_FORMAT_VERSION,
        trial_id: name.to_string(),
        kind: IMPORTED_KIND.to_string(),
        backend: "import".to_string(),
        seed: 0,
        object,
        grasp_deg: 0.0,
        sensors,
        pins: elements,
        tmo_version,
        git_revision,
        protocol: None,
        protocol_sha256: None,
        model_sha256: None,
        started_unix_s: 0,
        parameters,
    }
}

fn label_event(time_s: f64, slip: bool) -> TrialEvent {
    TrialEvent {
        time_s,
        topic: LABEL_TOPIC.to_string(),
        data: serde_json::json!({ "slip": slip }),
    }
}

/// The file name of a trial's log: its name with anything but letters, digits, `-`, `_`
/// and `.` replaced by `_`.
pub fn log_file_name(name: &str) -> String {
    let safe: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.') {
                c
            } else {
                '_'
            }
        })
        .collect();
    format!("{}.mcap", safe.trim_start_matches('.'))
}

/// Where each trial's log goes under `out` (a split's sub-directory when it has one).
pub fn log_path(out: &Path, t: &ImportedTrial) -> PathBuf {
    match &t.split {
        Some(split) => out.join(log_file_name(split).trim_end_matches(".mcap")),
        None => out.to_path_buf(),
    }
    .join(log_file_name(&t.name))
}
