//! Rows the SVM benches fit on: 40 collect-mode hand releases on the simulator, five
//! objects, recorded as `tmo sim collect` and `tmo run` record them (the collect preset
//! through the protocol runner), features and labels as `tmo train` makes them (n_slip
//! 13), static rows down-sampled to 0.4; or every row, for benches that narrow and
//! down-sample per cell.

use tmo::protocol::collect::{CollectPreset, CollectRig};
use tmo::runner::sim_trial::collect_in_memory;
use tmo::slip::dataset::{Dataset, LabelSpec};
use tmo::slip::features::FeatureSpec;
use tmo::slip::labels::OnsetSpec;
use tmo::trial::Trial;

/// The 40 trials (each object at each of `grasps_deg` alike); `seed` the batch seed.
#[allow(dead_code)] // each bench compiles this module on its own and uses part of it
pub fn hand_release_rows(seed: u64, grasps_deg: &[f64]) -> Dataset {
    hand_release_dataset(seed, 13, grasps_deg).downsample_static(0.4, 1)
}

/// Collect-mode hand releases of the five training objects, each at each of `grasps_deg`
/// `repetitions` times; `seed` the batch seed.
#[allow(dead_code)] // each bench compiles this module on its own and uses part of it
pub fn hand_release_trials(seed: u64, repetitions: u32, grasps_deg: &[f64]) -> Vec<Trial> {
    let objects: Vec<String> = [
        "crisps_can",
        "windex_bottle",
        "bleach_bottle",
        "mustard_bottle",
        "banana",
    ]
    .map(String::from)
    .to_vec();
    collect_in_memory(&CollectPreset {
        rig: CollectRig::Hand,
        repetitions,
        seed,
        objects: &objects,
        grasps_deg,
    })
    .expect("collect trials run")
}

/// Every row of the 40 trials, labelled with `n_slip` slip frames (narrowed per cell with
/// [`Dataset::with_n_slip`], as a sweep does).
#[allow(dead_code)] // each bench compiles this module on its own and uses part of it
pub fn hand_release_dataset(seed: u64, n_slip: usize, grasps_deg: &[f64]) -> Dataset {
    let trials = hand_release_trials(seed, (40 / (5 * grasps_deg.len())) as u32, grasps_deg);
    Dataset::from_trials(
        &trials,
        &FeatureSpec::new(30),
        &LabelSpec {
            n_slip,
            onset: OnsetSpec::default(),
        },
    )
}
