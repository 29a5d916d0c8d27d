//! Rows the SVM benches fit on: 40 collect-mode hand releases on the simulator, five
//! objects, features and labels as `tmo train` makes them (n_slip 13), static rows
//! down-sampled to 0.4.

use tmo::collect::{collect_trial, trial_seed, CollectRig, CollectSpec};
use tmo::slip::dataset::{Dataset, LabelSpec};
use tmo::slip::features::FeatureSpec;
use tmo::slip::labels::OnsetSpec;
use tmo_hal::sim::SimConfig;

/// `grasp_deg(i)` is trial `i`'s hand roll; `seed` the batch seed.
pub fn hand_release_rows(seed: u64, grasp_deg: impl Fn(u64) -> f64) -> Dataset {
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
            n_slip: 13,
            onset: OnsetSpec::default(),
        },
    )
    .downsample_static(0.4, 1)
}
