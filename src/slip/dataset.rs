//! Labelled feature rows from recorded trials, and the splits the method needs: by trial
//! (never by frame), seeded down-sampling of the static class (never the slip class, never
//! a test set), and the `local` / `global` scopes.

use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use super::features::{frame_features, FeatureSpec, Units};
use super::labels::{label_frames, trial_slip_window, OnsetSpec};
use super::Class;
use crate::trial::Trial;

#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    #[error(transparent)]
    Trial(#[from] crate::trial::TrialError),
    #[error("no trial logs (.mcap) found in {0}")]
    NoTrials(String),
    #[error("{path}: cannot be used as a trial: {why}")]
    Unusable {
        path: std::path::PathBuf,
        why: &'static str,
    },
    #[error("{path}: {found} pins per sensor, but {first} has {expected}")]
    Pins {
        path: std::path::PathBuf,
        found: usize,
        first: std::path::PathBuf,
        expected: usize,
    },
    #[error("{path}: {message}")]
    Features {
        path: std::path::PathBuf,
        message: String,
    },
}

/// How a trial's frames are read: its element count, units, step limit and frame rate.
pub fn trial_features(t: &Trial) -> Result<FeatureSpec, String> {
    let units = match t.meta.parameters.get("units") {
        None => Units::Px,
        Some(u) => Units::parse(u)
            .ok_or_else(|| format!("parameter units = `{u}`: expected px, counts or mm"))?,
    };
    Ok(FeatureSpec {
        pins: t.meta.pins,
        max_pin_step_px: max_step(t)?,
        units,
        frame_rate_hz: frame_rate_hz(t),
    })
}

/// The rate of a trial's first sensor: one over its median frame interval (per frame
/// number, so lost frames do not count), Hz; `None` with fewer than two frames.
fn frame_rate_hz(t: &Trial) -> Option<f32> {
    let sensor = t.frames.first()?.sensor;
    let mut previous: Option<(u64, f64)> = None;
    let mut intervals = Vec::new();
    for f in t.frames.iter().filter(|f| f.sensor == sensor) {
        if let Some((seq, time)) = previous {
            if f.seq > seq && f.time_s > time {
                intervals.push((f.time_s - time) / (f.seq - seq) as f64);
            }
        }
        previous = Some((f.seq, f.time_s));
    }
    intervals.sort_by(f64::total_cmp);
    let median = *intervals.get(intervals.len() / 2)?;
    Some((1.0 / median) as f32)
}

/// The per-frame step beyond which an element counts as lost, as a trial records it:
/// imported trials carry their sensor's own (`max_element_step`, in its units, or `off`);
/// tmo's own logs use the 20 px guard for tracked pins.
pub fn max_step(t: &Trial) -> Result<f32, String> {
    let name = crate::trial::MAX_STEP_PARAMETER;
    match t.meta.parameters.get(name).map(String::as_str) {
        None => Ok(FeatureSpec::new(0).max_pin_step_px),
        Some("off") => Ok(f32::MAX),
        Some(v) => v
            .parse::<f32>()
            .ok()
            .filter(|m| m.is_finite() && *m > 0.0)
            .ok_or_else(|| {
                format!("parameter {name} = `{v}`: expected a positive number or `off`")
            }),
    }
}

/// Loads trial logs (files or directories of them) and labels their frames; every trial
/// must have the same pin count. Returns the rows, a reference to each trial (path and
/// SHA-256, for the model's provenance) and the feature layout.
pub fn load_labelled(
    paths: &[std::path::PathBuf],
    labels: &LabelSpec,
) -> Result<(Dataset, Vec<TrialRef>, FeatureSpec), LoadError> {
    let loaded = crate::trial::load_trials(paths)?;
    let Some(first) = loaded.first() else {
        return Err(LoadError::NoTrials(
            paths
                .iter()
                .map(|p| p.display().to_string())
                .collect::<Vec<_>>()
                .join(", "),
        ));
    };
    let mut features = trial_features(&first.2).map_err(|message| LoadError::Features {
        path: first.0.clone(),
        message,
    })?;
    let mut rates: Vec<(&str, f64)> = Vec::new();
    for (path, _, t) in &loaded {
        if let Some(why) = t.unusable() {
            return Err(LoadError::Unusable {
                path: path.clone(),
                why,
            });
        }
        let features_err = |message| LoadError::Features {
            path: path.clone(),
            message,
        };
        let own = trial_features(t).map_err(features_err)?;
        if own.pins != features.pins {
            return Err(LoadError::Pins {
                path: path.clone(),
                found: own.pins,
                first: first.0.clone(),
                expected: features.pins,
            });
        }
        if let Some((what, theirs, ours)) = features.mismatch(&own) {
            return Err(features_err(format!(
                "its {what} is {theirs}, {}'s {ours}; the trials of one dataset come from one kind of sensor",
                first.0.display()
            )));
        }
        if let Some(rate) = own.frame_rate_hz {
            rates.push((t.meta.trial_id.as_str(), f64::from(rate)));
        }
    }
    // The dataset's rate (a model records it) is its trials' median; rates may differ
    // between trials, since velocities are per frame within each.
    let mut sorted: Vec<f64> = rates.iter().map(|r| r.1).collect();
    sorted.sort_by(f64::total_cmp);
    features.frame_rate_hz = sorted.get(sorted.len() / 2).map(|&r| r as f32);
    let rate_spread = crate::slip::features::RateSpread::of(&rates);
    let refs = loaded
        .iter()
        .map(|(p, h, t)| TrialRef {
            trial_id: t.meta.trial_id.clone(),
            path: p.display().to_string(),
            sha256: h.clone(),
        })
        .collect();
    let trials: Vec<_> = loaded.into_iter().map(|(_, _, t)| t).collect();
    let mut dataset = Dataset::from_trials(&trials, &features, labels);
    dataset.rate_spread = rate_spread;
    dataset.all_imported = trials
        .iter()
        .all(|t| t.meta.kind == crate::trial::IMPORTED_KIND);
    Ok((dataset, refs, features))
}

/// How frames are labelled.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LabelSpec {
    pub n_slip: usize,
    pub onset: OnsetSpec,
}

impl LabelSpec {
    /// Whether the labels' numbers are ones the labeller can work with: every model (a
    /// file of tmo's own or an ONNX model's `tmo.labels`) is checked here. The error names
    /// the field within the spec and what was expected.
    pub fn check(&self) -> Result<(), (&'static str, String)> {
        let max = super::labels::MAX_N_SLIP;
        if !(1..=max).contains(&self.n_slip) {
            return Err((
                "n_slip",
                format!("expected 1..={max} slip frames, got {}", self.n_slip),
            ));
        }
        self.onset.check().map_err(|why| ("onset", why))
    }
}

/// A training trial, by id and content hash.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TrialRef {
    pub trial_id: String,
    pub path: String,
    pub sha256: String,
}

/// Feature rows with their labels and where each came from.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Dataset {
    pub dim: usize,
    /// Row-major, `dim` values per row.
    pub x: Vec<f32>,
    pub y: Vec<Class>,
    /// Index into `trial_ids`.
    pub trial: Vec<u32>,
    pub sensor: Vec<u8>,
    pub seq: Vec<u64>,
    pub time_s: Vec<f64>,
    /// For rows built from trials: the frame's count since slip onset (1 for the first
    /// slip frame), 0 for static rows; lets a sweep over `n_slip` label its trials once.
    /// Empty for rows made by hand.
    pub slip_frame: Vec<u32>,
    pub trial_ids: Vec<String>,
    /// Frames that gave no features (first frame of a sensor, wrong pin count, ...).
    pub skipped_frames: usize,
    /// Trials in which no slip onset was found in the marker track.
    pub trials_without_onset: Vec<String>,
    /// The trials' frame rates, where they differ by more than 15 % (said, not refused).
    pub rate_spread: Option<crate::slip::features::RateSpread>,
    /// Every trial came from `tmo import`, which said its notes (the rates' spread) when
    /// the data came in: a later command need not say them again.
    pub all_imported: bool,
}

#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize, clap::ValueEnum,
)]
#[serde(rename_all = "snake_case")]
pub enum Scope {
    /// One classifier per sensor, trained on that sensor's frames.
    Local,
    /// One classifier trained on every sensor's frames.
    Global,
}

impl Scope {
    /// The scope as the command line and reports spell it.
    pub fn name(self) -> &'static str {
        match self {
            Scope::Local => "local",
            Scope::Global => "global",
        }
    }
}

impl Dataset {
    pub fn len(&self) -> usize {
        self.y.len()
    }

    /// SHA-256 of what a learner reads: every row's features, class, trial, sensor, frame
    /// and slip-frame count, and the trials' ids. Two datasets with one digest train and
    /// score alike, whenever and wherever their logs were recorded.
    pub fn digest(&self) -> String {
        use sha2::{Digest, Sha256};
        let mut h = Sha256::new();
        h.update((self.dim as u64).to_le_bytes());
        for v in &self.x {
            h.update(v.to_bits().to_le_bytes());
        }
        h.update(
            self.y
                .iter()
                .map(|c| u8::from(*c == super::Class::Slip))
                .collect::<Vec<u8>>(),
        );
        for ((((t, s), q), time), f) in self
            .trial
            .iter()
            .zip(&self.sensor)
            .zip(&self.seq)
            .zip(&self.time_s)
            .zip(self.slip_frame.iter().chain(std::iter::repeat(&0)))
        {
            h.update(t.to_le_bytes());
            h.update([*s]);
            h.update(q.to_le_bytes());
            h.update(time.to_bits().to_le_bytes());
            h.update(f.to_le_bytes());
        }
        for id in &self.trial_ids {
            h.update(id.as_bytes());
            h.update([0]);
        }
        format!("{:x}", h.finalize())
    }

    pub fn is_empty(&self) -> bool {
        self.y.is_empty()
    }

    pub fn row(&self, i: usize) -> &[f32] {
        &self.x[i * self.dim..(i + 1) * self.dim]
    }

    pub fn count(&self, class: Class) -> usize {
        self.y.iter().filter(|c| **c == class).count()
    }

    /// Labelled rows of `trials` (frames after the `n_slip` slip frames are left out).
    pub fn from_trials(trials: &[Trial], features: &FeatureSpec, labels: &LabelSpec) -> Self {
        let mut ds = Dataset {
            dim: features.len(),
            ..Default::default()
        };
        let mut row = Vec::with_capacity(features.len());
        for (ti, trial) in trials.iter().enumerate() {
            ds.trial_ids.push(trial.meta.trial_id.clone());
            let (onset, slip_end) = trial_slip_window(trial, &labels.onset);
            if onset.is_none() {
                ds.trials_without_onset.push(trial.meta.trial_id.clone());
            }
            for sensor in 0..trial.meta.sensors {
                let frames: Vec<_> = trial.frames.iter().filter(|f| f.sensor == sensor).collect();
                let times: Vec<f64> = frames.iter().map(|f| f.time_s).collect();
                let classes = label_frames(&times, onset, slip_end, labels.n_slip);
                let first_slip = classes.iter().position(|c| *c == Some(Class::Slip));
                ds.skipped_frames += usize::from(!frames.is_empty());
                for k in 1..frames.len() {
                    let Some(class) = classes[k] else { continue };
                    if frame_features(features, frames[k - 1], frames[k], &mut row).is_err() {
                        ds.skipped_frames += 1;
                        continue;
                    }
                    ds.x.extend_from_slice(&row);
                    ds.y.push(class);
                    ds.trial.push(ti as u32);
                    ds.sensor.push(sensor);
                    ds.seq.push(frames[k].seq);
                    ds.time_s.push(frames[k].time_s);
                    ds.slip_frame.push(match (class, first_slip) {
                        (Class::Slip, Some(first)) => (k - first + 1) as u32,
                        _ => 0,
                    });
                }
            }
        }
        ds
    }

    /// The rows whose index `keep` returns true for.
    pub fn filter(&self, mut keep: impl FnMut(usize) -> bool) -> Dataset {
        let rows: Vec<usize> = (0..self.len()).filter(|&i| keep(i)).collect();
        self.select(&rows)
    }

    /// The rows `rows`, in that order.
    pub fn select(&self, rows: &[usize]) -> Dataset {
        let mut out = Dataset {
            dim: self.dim,
            trial_ids: self.trial_ids.clone(),
            ..Default::default()
        };
        for &i in rows {
            out.x.extend_from_slice(self.row(i));
            out.y.push(self.y[i]);
            out.trial.push(self.trial[i]);
            out.sensor.push(self.sensor[i]);
            out.seq.push(self.seq[i]);
            out.time_s.push(self.time_s[i]);
            if let Some(f) = self.slip_frame.get(i) {
                out.slip_frame.push(*f);
            }
        }
        out
    }

    /// The rows a labelling with `n_slip` slip frames would give, from rows labelled with
    /// at least that many; `None` for rows without `slip_frame` counts.
    pub fn with_n_slip(&self, n_slip: usize) -> Option<Dataset> {
        (self.slip_frame.len() == self.len())
            .then(|| self.filter(|i| self.within_n_slip(i, n_slip)))
    }

    /// Whether row `i` stays in a labelling with `n_slip` slip frames (see
    /// [`Self::with_n_slip`]).
    fn within_n_slip(&self, i: usize, n_slip: usize) -> bool {
        self.slip_frame[i] as usize <= n_slip
    }

    /// The indices of the rows [`Self::with_n_slip`] keeps, in order.
    pub fn rows_with_n_slip(&self, n_slip: usize) -> Option<Vec<usize>> {
        (self.slip_frame.len() == self.len()).then(|| {
            (0..self.len())
                .filter(|&i| self.within_n_slip(i, n_slip))
                .collect()
        })
    }

    pub fn sensor_only(&self, sensor: u8) -> Dataset {
        self.filter(|i| self.sensor[i] == sensor)
    }

    /// Sensors present, in order.
    pub fn sensors(&self) -> Vec<u8> {
        let mut s: Vec<u8> = self.sensor.clone();
        s.sort_unstable();
        s.dedup();
        s
    }

    /// Keeps every slip row and a random `round(d * N0)` of the `N0` static rows.
    /// A random `fraction` of each class's rows (seeded), so the classes keep their
    /// proportions.
    pub fn subsample_each_class(&self, fraction: f64, seed: u64) -> Dataset {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut chosen = vec![false; self.len()];
        for class in [Class::Static, Class::Slip] {
            let rows: Vec<usize> = (0..self.len()).filter(|&i| self.y[i] == class).collect();
            let keep_n =
                ((fraction.clamp(0.0, 1.0) * rows.len() as f64).round() as usize).min(rows.len());
            for &i in rows.choose_multiple(&mut rng, keep_n) {
                chosen[i] = true;
            }
        }
        self.filter(|i| chosen[i])
    }

    pub fn downsample_static(&self, d: f64, seed: u64) -> Dataset {
        let statics: Vec<usize> = (0..self.len())
            .filter(|&i| self.y[i] == Class::Static)
            .collect();
        let keep_n =
            ((d.clamp(0.0, 1.0) * statics.len() as f64).round() as usize).min(statics.len());
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut chosen = vec![false; self.len()];
        for &i in statics.choose_multiple(&mut rng, keep_n) {
            chosen[i] = true;
        }
        self.filter(|i| self.y[i] == Class::Slip || chosen[i])
    }
}

impl Dataset {
    /// Writes rows as CSV: trial_id, sensor, seq, time_s, label, then `dr_i` and `dtheta_i`.
    pub fn write_csv(&self, path: &std::path::Path) -> Result<(), csv::Error> {
        let file = crate::output::atomic::AtomicFile::create(path)?;
        self.write_csv_to(file)?.commit()?;
        Ok(())
    }

    /// [`Dataset::write_csv`] into any writer (standard output, say); gives it back.
    pub fn write_csv_to<W: std::io::Write>(&self, out: W) -> Result<W, csv::Error> {
        let mut w = csv::Writer::from_writer(out);
        let pins = self.dim / 2;
        let mut head: Vec<String> = ["trial_id", "sensor", "seq", "time_s", "label"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        head.extend((0..pins).map(|i| format!("dr_{i}")));
        head.extend((0..pins).map(|i| format!("dtheta_{i}")));
        w.write_record(&head)?;
        let mut rec: Vec<String> = Vec::with_capacity(head.len());
        for i in 0..self.len() {
            rec.clear();
            rec.push(self.trial_ids[self.trial[i] as usize].clone());
            rec.push(self.sensor[i].to_string());
            rec.push(self.seq[i].to_string());
            rec.push(format!("{:.6}", self.time_s[i]));
            rec.push(match self.y[i] {
                Class::Slip => "slip".into(),
                Class::Static => "static".into(),
            });
            rec.extend(self.row(i).iter().map(|v| format!("{v:.6}")));
            w.write_record(&rec)?;
        }
        w.into_inner().map_err(|e| csv::Error::from(e.into_error()))
    }
}

/// Splits trial indices `0..n` into (train, test) by a seeded shuffle; `test_fraction` of
/// the trials (rounded, at least one of each when n >= 2) go to test.
pub fn split_trials(n: usize, test_fraction: f64, seed: u64) -> (Vec<u32>, Vec<u32>) {
    let mut idx: Vec<u32> = (0..n as u32).collect();
    idx.shuffle(&mut ChaCha8Rng::seed_from_u64(seed));
    let mut n_test = (test_fraction * n as f64).round() as usize;
    if n >= 2 {
        n_test = n_test.clamp(1, n - 1);
    }
    let test = idx[..n_test].to_vec();
    let mut train = idx[n_test..].to_vec();
    train.sort_unstable();
    let mut test = test;
    test.sort_unstable();
    (train, test)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn toy() -> Dataset {
        let mut ds = Dataset {
            dim: 1,
            ..Default::default()
        };
        for i in 0..100 {
            ds.x.push(i as f32);
            ds.y.push(if i % 10 == 0 {
                Class::Slip
            } else {
                Class::Static
            });
            ds.trial.push((i / 25) as u32);
            ds.sensor.push((i % 3) as u8);
            ds.seq.push(i as u64);
            ds.time_s.push(i as f64);
        }
        ds
    }

    #[test]
    fn downsampling_keeps_every_slip_row_and_a_fraction_of_static() {
        let ds = toy();
        let d = ds.downsample_static(0.4, 1);
        assert_eq!(d.count(Class::Slip), 10);
        assert_eq!(d.count(Class::Static), 36); // 0.4 * 90
        assert_eq!(ds.downsample_static(0.4, 1), d, "seeded");
        assert_ne!(ds.downsample_static(0.4, 2).x, d.x);
        assert_eq!(ds.downsample_static(1.0, 5).len(), 100);
    }

    #[test]
    fn trials_split_whole_and_disjoint() {
        let (train, test) = split_trials(10, 0.5, 3);
        assert_eq!((train.len(), test.len()), (5, 5));
        assert!(train.iter().all(|t| !test.contains(t)));
        assert_eq!(split_trials(10, 0.5, 3), (train, test));
        assert_eq!(split_trials(2, 0.0, 1).1.len(), 1);
    }

    #[test]
    fn local_scope_keeps_one_sensor() {
        let ds = toy();
        let s1 = ds.sensor_only(1);
        assert!(s1.sensor.iter().all(|s| *s == 1));
        assert_eq!(ds.sensors(), vec![0, 1, 2]);
    }
}
