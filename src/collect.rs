//! Collect-mode trials on the simulator: the training data of the paper's experiments, with
//! no reaction to slip. Hand release: a pinch grasp a little past contact is released at
//! 0.5 % of maximum finger speed until the object falls. Slip rail: the arm retracts at a
//! random speed in 0.1..5 mm/s. (The protocol runner will record the same trials from
//! protocol files; this is the direct path until then.)

use std::collections::BTreeMap;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use tmo_sim::{SimConfig, SimRig};

use crate::scenario::{Devices, ScenarioError, Script};
use crate::sim_presets::{self, Preset, PresetOptions};
use crate::trial::{Trial, TrialMeta, TRIAL_FORMAT_VERSION};

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum CollectRig {
    Hand,
    Rail,
}

/// One collect-mode trial to run.
#[derive(Debug, Clone, PartialEq)]
pub struct CollectSpec {
    pub rig: CollectRig,
    pub object: String,
    pub grasp_deg: f64,
    pub seed: u64,
    pub base: SimConfig,
}

impl CollectSpec {
    /// The `kind` its trial logs record.
    pub fn kind(&self) -> &'static str {
        match self.rig {
            CollectRig::Hand => "hand_release_collect",
            CollectRig::Rail => "rail_catch_collect",
        }
    }

    /// Why a trial log already in the output directory is not the trial this collection
    /// would make under its name (another rig, object, grasp or seed), if it is not: a
    /// collection never mixes with another one.
    pub fn differs_from(&self, kept: &TrialMeta) -> Option<String> {
        if kept.kind != self.kind() {
            return Some(format!(
                "it is a {} trial, this collection makes {}",
                kept.kind,
                self.kind()
            ));
        }
        if kept.object != self.object || kept.grasp_deg != self.grasp_deg {
            return Some(format!(
                "it holds {} at {} deg, this collection puts {} at {} deg under that name",
                kept.object, kept.grasp_deg, self.object, self.grasp_deg
            ));
        }
        if kept.seed != self.seed {
            return Some(format!(
                "it ran with seed {}, this collection's trial has seed {} (another --seed?)",
                kept.seed, self.seed
            ));
        }
        None
    }
}

#[derive(Debug, thiserror::Error)]
pub enum CollectError {
    #[error(transparent)]
    Sim(#[from] tmo_sim::SimError),
    #[error(transparent)]
    Scenario(#[from] ScenarioError),
}

/// How high a collect-mode hand trial lifts the object before the release: high enough
/// that a released object slides for more than 15 frames before it lands (the paper
/// labels up to 15), and above the 80 mm drop limit.
pub const COLLECT_LIFT_MM: f64 = 120.0;

/// Seed of trial `index` of a batch seeded with `batch_seed` (documented so a single trial
/// can be re-run alone).
pub fn trial_seed(batch_seed: u64, index: u64) -> u64 {
    batch_seed.wrapping_mul(1_000_003).wrapping_add(index)
}

/// The simulated hand-release rig: the object stands on the table with the fingers just
/// open of contact; returns the configuration, a grasp that holds the object with `safety`
/// times the friction it needs ("closed until stable"), and the contact closure.
pub fn hand_release_rig(
    base: &SimConfig,
    options: &PresetOptions,
    safety: f64,
    extra_mass_g: f64,
) -> Result<(SimConfig, f64, f64), CollectError> {
    let object = options
        .object
        .clone()
        .unwrap_or_else(|| "crisps_can".into());
    let (mut config, _) = sim_presets::build(Preset::Release, options, base.clone())?;
    let closure = sim_presets::holding_closure(base, &object, extra_mass_g, safety)?;
    let contact = sim_presets::contact_closure(base, &object)?;
    if let tmo_sim::RigSetup::Hand(h) = &mut config.rig {
        h.start = tmo_sim::ObjectStart::OnTable;
        h.extra_mass_g = extra_mass_g;
        h.initial_closure = (contact - 0.02).max(0.0);
    }
    Ok((config, closure, contact))
}

/// Runs one trial on the simulator.
pub fn collect_trial(
    spec: &CollectSpec,
    trial_id: &str,
    started_unix_s: u64,
) -> Result<Trial, CollectError> {
    let mut rng = ChaCha8Rng::seed_from_u64(spec.seed);
    rng.set_stream(99);
    let mut base = spec.base.clone();
    base.seed = spec.seed;
    let mut parameters = BTreeMap::new();
    let (config, script, duration) = match spec.rig {
        CollectRig::Hand => {
            let options = PresetOptions {
                object: Some(spec.object.clone()),
                grasp_deg: spec.grasp_deg,
                ..Default::default()
            };
            let safety: f64 = rng.gen_range(1.2..1.8);
            let (config, closure, contact) = hand_release_rig(&base, &options, safety, 0.0)?;
            let hold_s: f64 = rng.gen_range(0.5..2.0);
            let script = Script::GraspLiftRelease {
                closure,
                close_speed_per_s: 0.05,
                lift_mm: COLLECT_LIFT_MM,
                lift_speed_mm_s: 20.0, // the duration below assumes this speed
                hold_s,
                release_speed_per_s: 0.01,
            };
            for (k, v) in [
                ("grip_safety", safety),
                ("closure", closure),
                ("hold_s", hold_s),
                ("release_speed_per_s", 0.01),
            ] {
                parameters.insert(k.into(), format!("{v:.4}"));
            }
            let duration = (closure - contact + 0.02) / 0.05
                + 0.3
                + COLLECT_LIFT_MM / 20.0
                + 0.2
                + hold_s
                + (closure - contact + base.servo.backlash) / 0.01
                + 1.5;
            (config, script, duration)
        }
        CollectRig::Rail => {
            let speed: f64 = rng.gen_range(0.1..5.0);
            let options = PresetOptions {
                object: Some(spec.object.clone()),
                retract_speed_mm_s: speed,
                ..Default::default()
            };
            let (config, script) = sim_presets::build(Preset::Rail, &options, base)?;
            parameters.insert("retract_speed_mm_s".into(), format!("{speed:.4}"));
            // Slip comes after about 1.2 mm of retraction; stop 1.5 s later.
            (config, script, 3.0 / speed + 1.5)
        }
    };
    let rig = SimRig::new(config.clone())?;
    let mut devices = Devices::of_sim(&rig);
    let recording = devices.run(script, duration, |_| {})?;
    // Ground truth goes along for diagnostics (how late the marker onset is); labels never
    // use it.
    let events = rig.probe().events();
    crate::runner::sim_trial::put_truth(
        &mut |k: &str, v: String| {
            parameters.insert(k.into(), v);
        },
        &events,
    );
    let (tmo_version, git_revision) = TrialMeta::code_version();
    parameters.insert("duration_s".into(), format!("{duration:.3}"));
    let meta = TrialMeta {
        format_version: TRIAL_FORMAT_VERSION,
        trial_id: trial_id.to_string(),
        kind: spec.kind().into(),
        backend: "sim".into(),
        seed: spec.seed,
        object: spec.object.clone(),
        grasp_deg: spec.grasp_deg,
        sensors: rig.tactile_sensors().len() as u8,
        pins: config.tactip.pins,
        tmo_version,
        git_revision,
        protocol: None,
        protocol_sha256: None,
        model_sha256: None,
        started_unix_s,
        parameters,
    };
    Ok(Trial {
        meta,
        frames: recording.frames,
        arrivals_s: recording.arrivals_s,
        markers: recording.markers,
        // The script's phases, as a runner logs them: replay arms its detector from the
        // release, as the online hand-release runner does.
        events: recording
            .phases
            .iter()
            .map(|&(t, phase)| {
                crate::runner::event(t, "/phase", serde_json::json!({ "phase": phase }))
            })
            .collect(),
        // a bare `sim collect` runs from its command line, not from a file
        sources: Vec::new(),
    })
}
