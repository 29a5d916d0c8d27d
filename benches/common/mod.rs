//! Rows the SVM benches fit on: 40 collect-mode hand releases on the simulator, five
//! objects, features and labels as `tmo train` makes them (n_slip 13), static rows
//! down-sampled to 0.4; or every row, for benches that narrow and down-sample per cell.

use tmo::collect::{collect_trial, trial_seed, CollectRig, CollectSpec};
use tmo::slip::dataset::{Dataset, LabelSpec};
use tmo::slip::features::FeatureSpec;
use tmo::slip::labels::OnsetSpec;
use tmo_sim::SimConfig;

/// `grasp_deg(i)` is trial `i`'s hand roll; `seed` the batch seed.
#[allow(dead_code)] // each bench compiles this module on its own and uses part of it
pub fn hand_release_rows(seed: u64, grasp_deg: impl Fn(u64) -> f64) -> Dataset {
    hand_release_dataset(seed, 13, grasp_deg).downsample_static(0.4, 1)
}

/// Every row of the 40 trials, labelled with `n_slip` slip frames (narrowed per cell with
/// [`Dataset::with_n_slip`], as a sweep does).
#[allow(dead_code)] // each bench compiles this module on its own and uses part of it
pub fn hand_release_dataset(seed: u64, n_slip: usize, grasp_deg: impl Fn(u64) -> f64) -> Dataset {
    let objects = [
        "crisps_can",
        "windex_bottle",
        "bleach_bottle",
        "mustard_bottle",
        "banana",
    ];
    let trials: Vec<_> = (0..40u64)
        .map(|i| {
            let spec = CollectSpec {
                rig: CollectRig::Hand,
                object: objects[(i % 5) as usize].into(),
                grasp_deg: grasp_deg(i),
                seed: trial_seed(seed, i),
                base: SimConfig::default(),
            };
            collect_trial(&spec, &format!("trial-{i:04}"), 0).unwrap()
        })
        .collect();
    Dataset::from_trials(
        &trials,
        &FeatureSpec::new(30),
        &LabelSpec {
            n_slip,
            onset: OnsetSpec::default(),
        },
    )
}
