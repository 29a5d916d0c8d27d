//! The inverse of reading: a trial log as interchange CSV rows, so that tmo's own trials can
//! go wherever other labs' recordings come from (and the round trip can be checked).

use std::collections::BTreeMap;
use std::io::Write;

use serde::Deserialize;

use super::Z_TOPIC_PREFIX;
use crate::slip::labels::{trial_slip_window, OnsetSpec};
use crate::trial::Trial;

/// Writes `trials` as one interchange CSV (header included): one row per element per frame,
/// each trial named by its `trial_id`, its sensors by its `sensor_names` parameter (else
/// `s0`, `s1`, ...), an `onset_s` column holding the trial's onset (empty for a trial
/// without slip), and a `z` column when any trial carries its elements' z (an imported
/// trial's `/element_z/<sensor>` events; a frame without them gets an empty `z`).
pub fn write_interchange(
    trials: &[(&Trial, Option<f64>)],
    out: impl Write,
) -> Result<(), csv::Error> {
    let z: Vec<_> = trials.iter().map(|(t, _)| z_by_frame(t)).collect();
    let with_z = z.iter().any(|z| !z.is_empty());
    let mut w = csv::Writer::from_writer(out);
    let mut header = vec![
        "trial", "sensor", "frame", "t_s", "element", "x", "y", "onset_s",
    ];
    if with_z {
        header.push("z");
    }
    w.write_record(&header)?;
    for ((trial, onset_s), z) in trials.iter().zip(&z) {
        let names: Vec<String> = match trial.meta.parameters.get("sensor_names") {
            Some(n) if n.split(',').count() == usize::from(trial.meta.sensors) => {
                n.split(',').map(String::from).collect()
            }
            _ => (0..trial.meta.sensors).map(|s| format!("s{s}")).collect(),
        };
        let onset = onset_s.map_or(String::new(), |o| o.to_string());
        for f in &trial.frames {
            let sensor = names
                .get(usize::from(f.sensor))
                .map_or("unknown", String::as_str);
            let (frame, t) = (f.seq.to_string(), f.time_s.to_string());
            let frame_z = z.get(&(f.sensor, f.seq));
            // field by field: one row per element of every frame, so no row is allocated
            for (e, [x, y]) in f.pins.iter().enumerate() {
                w.write_field(&trial.meta.trial_id)?;
                w.write_field(sensor)?;
                w.write_field(&frame)?;
                w.write_field(&t)?;
                w.write_field(e.to_string())?;
                w.write_field(x.to_string())?;
                w.write_field(y.to_string())?;
                w.write_field(&onset)?;
                if with_z {
                    match frame_z.and_then(|z| z.get(e)) {
                        Some(v) => w.write_field(v.to_string())?,
                        None => w.write_field("")?,
                    }
                }
                w.write_record(None::<&[u8]>)?;
            }
        }
    }
    w.flush()?;
    Ok(())
}

/// Why trials could not be written as interchange CSV.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    #[error("two trials are both named `{0}`; the interchange CSV names trials by their trial_id (export them to separate files)")]
    DuplicateTrial(String),
    #[error(transparent)]
    Csv(#[from] csv::Error),
}

/// Writes `trials` as one interchange CSV, each with the slip onset tmo's own labelling
/// finds in it (its label track, or its marker track by `onset`), so that another tool sees
/// the labels tmo trains on.
pub fn export_interchange(
    trials: &[Trial],
    onset: &OnsetSpec,
    out: impl Write,
) -> Result<(), ExportError> {
    let mut seen = std::collections::BTreeSet::new();
    if let Some(t) = trials.iter().find(|t| !seen.insert(&t.meta.trial_id)) {
        return Err(ExportError::DuplicateTrial(t.meta.trial_id.clone()));
    }
    let rows: Vec<_> = trials
        .iter()
        .map(|t| (t, trial_slip_window(t, onset).0))
        .collect();
    write_interchange(&rows, out)?;
    Ok(())
}

/// An imported trial's z readings by (sensor, frame number); empty when it has none.
pub fn z_by_frame(trial: &Trial) -> BTreeMap<(u8, u64), Vec<f32>> {
    #[derive(Deserialize)]
    struct ZEvent {
        seq: u64,
        z: Vec<f32>,
    }
    trial
        .events
        .iter()
        .filter_map(|e| {
            let sensor = e.topic.strip_prefix(Z_TOPIC_PREFIX)?.parse::<u8>().ok()?;
            let z = ZEvent::deserialize(&e.data).ok()?;
            Some(((sensor, z.seq), z.z))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;

    use proptest::prelude::*;
    use tmo_hal::PinFrame;

    use super::*;
    use crate::import::{imported_meta, read_interchange, ImportOptions, Units};
    use crate::slip::dataset::trial_features;
    use crate::slip::features::{frame_features, FeatureSpec};

    /// A trial of `sensors` sensors of `elements` elements at `rate_hz`, frames numbered with
    /// gaps (lost frames), positions from `values`.
    fn trial(sensors: u8, elements: usize, rate_hz: f64, gaps: &[u64], values: &[f32]) -> Trial {
        let mut frames = Vec::new();
        let mut v = values.iter().cycle();
        for s in 0..sensors {
            let mut seq = 0;
            for gap in gaps {
                seq += gap;
                frames.push(PinFrame {
                    sensor: s,
                    seq,
                    time_s: seq as f64 / rate_hz,
                    pins: (0..elements)
                        .map(|_| [*v.next().unwrap(), *v.next().unwrap()])
                        .collect(),
                });
            }
        }
        frames.sort_by(|a, b| a.time_s.total_cmp(&b.time_s).then(a.sensor.cmp(&b.sensor)));
        Trial {
            meta: imported_meta("t", "unknown".into(), sensors, elements, BTreeMap::new()),
            arrivals_s: frames.iter().map(|f| f.time_s).collect(),
            frames,
            markers: Vec::new(),
            events: Vec::new(),
            sources: Vec::new(),
        }
    }

    /// Each sensor's features, frame by frame.
    fn features(t: &Trial, spec: &FeatureSpec) -> Vec<Vec<f32>> {
        let mut out = Vec::new();
        for s in 0..t.meta.sensors {
            let frames: Vec<_> = t.frames.iter().filter(|f| f.sensor == s).collect();
            for pair in frames.windows(2) {
                let mut row = Vec::new();
                frame_features(spec, pair[0], pair[1], &mut row).unwrap();
                out.push(row);
            }
        }
        out
    }

    #[test]
    fn trials_with_and_without_z_export_to_one_file_that_imports_again() {
        let mut with = trial(1, 3, 50.0, &[1, 1, 1], &[1.0, 2.0, 3.0]);
        with.events = with
            .frames
            .iter()
            .map(|f| crate::trial::TrialEvent {
                time_s: f.time_s,
                topic: format!("{Z_TOPIC_PREFIX}{}", f.sensor),
                data: serde_json::json!({ "seq": f.seq, "z": [7.0, 8.0, 9.0] }),
            })
            .collect();
        let mut without = trial(1, 3, 50.0, &[1, 1, 1], &[4.0, 5.0]);
        without.meta.trial_id = "u".into();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("both.csv");
        let file = std::fs::File::create(&path).unwrap();
        export_interchange(&[with.clone(), without.clone()], &Default::default(), file).unwrap();
        let opts = ImportOptions {
            sensor_name: "any".into(),
            units: Units::Mm,
            split_column: None,
            max_step: None,
            ..Default::default()
        };
        let back = read_interchange(&path, &opts).unwrap().trials;
        assert_eq!(back.len(), 2);
        assert_eq!(z_by_frame(&back[0].trial), z_by_frame(&with));
        assert!(z_by_frame(&back[1].trial).is_empty());
        assert_eq!(back[1].trial.frames, without.frames);
        // one name twice is refused
        let e =
            export_interchange(&[with.clone(), with], &Default::default(), Vec::new()).unwrap_err();
        assert!(e.to_string().contains("`t`"), "{e}");
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        #[test]
        fn a_trial_exported_to_the_interchange_csv_and_imported_gives_the_same_features(
            sensors in 1u8..4,
            elements in 1usize..40,
            rate_hz in 20.0f64..200.0,
            gaps in proptest::collection::vec(1u64..4, 2..20),
            values in proptest::collection::vec(-5000.0f32..5000.0, 1..64),
            onset in proptest::option::of(0.0f64..1.0),
            with_z in any::<bool>(),
        ) {
            let mut original = trial(sensors, elements, rate_hz, &gaps, &values);
            // an onset is one of the trial's times (the importer refuses others)
            let (t0, t1) = (original.frames[0].time_s, original.frames.last().unwrap().time_s);
            let onset = onset.map(|share| t0 + share * (t1 - t0));
            if with_z {
                // each frame's z: its x values reversed (any numbers will do)
                let z: Vec<_> = original
                    .frames
                    .iter()
                    .map(|f| crate::trial::TrialEvent {
                        time_s: f.time_s,
                        topic: format!("{Z_TOPIC_PREFIX}{}", f.sensor),
                        data: serde_json::json!({
                            "seq": f.seq,
                            "z": f.pins.iter().rev().map(|p| p[0]).collect::<Vec<_>>(),
                        }),
                    })
                    .collect();
                original.events = z;
            }
            let dir = tempfile::tempdir().unwrap();
            let path = dir.path().join("t.csv");
            write_interchange(&[(&original, onset)], std::fs::File::create(&path).unwrap())
                .unwrap();
            let opts = ImportOptions {
                sensor_name: "any".into(),
                units: Units::Mm,
                split_column: None,
                max_step: None,
                ..Default::default()
            };
            let back = read_interchange(&path, &opts).unwrap().trials.remove(0).trial;
            prop_assert_eq!(&back.frames, &original.frames);
            prop_assert_eq!(z_by_frame(&back), z_by_frame(&original));
            prop_assert_eq!(z_by_frame(&back).len(), if with_z { back.frames.len() } else { 0 });
            let spec = trial_features(&back).unwrap();
            prop_assert_eq!(spec.pins, elements);
            prop_assert_eq!(spec.units, Units::Mm);
            let rate = f64::from(spec.frame_rate_hz.unwrap());
            prop_assert!((rate - rate_hz).abs() < 1e-3 * rate_hz, "{} vs {}", rate, rate_hz);
            prop_assert_eq!(features(&back, &spec), features(&original, &spec));
            // written and read back as a log, the labels still give the onset and no end
            let log = dir.path().join("t.mcap");
            crate::trial::write_trial(&log, &back).unwrap();
            let back = crate::trial::read_trial(&log).unwrap();
            prop_assert_eq!(z_by_frame(&back), z_by_frame(&original));
            // (serde_json's default float parsing may be one ulp off)
            let (read_onset, end) =
                crate::slip::labels::trial_slip_window(&back, &Default::default());
            prop_assert_eq!(end, None);
            prop_assert_eq!(read_onset.is_some(), onset.is_some());
            if let (Some(a), Some(b)) = (read_onset, onset) {
                prop_assert!((a - b).abs() <= 1e-12, "{} vs {}", a, b);
            }
        }
    }
}
