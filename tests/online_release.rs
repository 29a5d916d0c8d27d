//! The online hand release on the simulator, in process: a model trained on collect-mode
//! trials catches releases that, unanswered, end in a fall.

use tmo::online::strategy::Strategy;
use tmo::outcome::{score_catch, CatchSpec, Verdict};
use tmo::protocol::collect::{CollectPreset, CollectRig, COLLECT_RELEASE_SPEED_OF_MAX};
use tmo::runner::devices::Devices;
use tmo::runner::hand_release::{run_release, ReleaseParams};
use tmo::runner::sim_presets::PresetOptions;
use tmo::runner::sim_trial::{collect_in_memory, hand_release_rig};
use tmo::runner::Online;
use tmo::slip::dataset::{Dataset, LabelSpec, Scope};
use tmo::slip::features::FeatureSpec;
use tmo::slip::labels::OnsetSpec;
use tmo::slip::model::{ClassifierKind, Hyperparameters, ModelFile, TrainSpec};
use tmo_sim::{SimConfig, SimRig};

const OBJECTS: [&str; 5] = [
    "crisps_can",
    "windex_bottle",
    "bleach_bottle",
    "mustard_bottle",
    "banana",
];

fn model() -> ModelFile {
    let objects = OBJECTS.map(String::from);
    let trials = collect_in_memory(&CollectPreset {
        rig: CollectRig::Hand,
        repetitions: 4,
        seed: 11,
        objects: &objects,
        grasps_deg: &[0.0],
    })
    .unwrap();
    logreg_on(&trials)
}

/// A global logistic-regression model (n_slip 5, d 0.4) trained on `trials`.
fn logreg_on(trials: &[tmo::trial::Trial]) -> ModelFile {
    let labels = LabelSpec {
        n_slip: 5,
        onset: OnsetSpec::default(),
    };
    let features = FeatureSpec::new(30);
    let data = Dataset::from_trials(trials, &features, &labels);
    ModelFile::train(
        &data,
        &TrainSpec {
            kind: ClassifierKind::Logreg,
            hyper: Hyperparameters {
                c: 1.0,
                gamma: 0.0,
                max_iterations: None,
            },
            scope: Scope::Global,
            features,
            labels,
            downsample: 0.4,
            seed: 1,
        },
        vec![],
        None,
    )
    .unwrap()
}

fn release(object: &str, seed: u64, online: Option<Online<'_>>) -> (Verdict, bool) {
    let base = SimConfig {
        seed,
        ..SimConfig::default()
    };
    let options = PresetOptions {
        object: Some(object.into()),
        ..Default::default()
    };
    let (config, closure, _) = hand_release_rig(&base, &options, 1.5, 0.0).unwrap();
    let rig = SimRig::new(config).unwrap();
    let mut devices = Devices::of_sim(&rig);
    let params = ReleaseParams {
        closure,
        contact: None,
        close_speed_per_s: 0.05,
        lift_mm: 120.0,
        lift_speed_mm_s: 40.0,
        hold_s: 1.0,
        // the collection's release, which the model was trained on
        release_speed_per_s: COLLECT_RELEASE_SPEED_OF_MAX * base.servo.reference_speed_per_s,
        regrasp: 0.02,
        observe_s: 1.5,
        max_duration_s: 40.0,
        watch: Default::default(),
    };
    let record = run_release(
        &mut devices,
        &params,
        online,
        &std::sync::atomic::AtomicBool::new(false),
    )
    .unwrap();
    let reaction = record.reaction.map(|r| r.time_s);
    let o = score_catch(&record.recording.markers, reaction, &CatchSpec::default());
    eprintln!(
        "{object} seed {seed} online {}: {:?}, dropped {}, armed {:?}, latency {:?} s, D {:?} mm, truth {:?}",
        online.is_some(),
        o.verdict,
        o.dropped,
        record.armed_s,
        o.latency_s,
        o.slip_distance_mm,
        rig.probe().events()
    );
    (o.verdict, o.dropped)
}

#[test]
fn a_trained_detector_catches_releases_that_otherwise_fall() {
    let model = model();
    let strategy: Strategy = "2x2".parse().unwrap();
    let mut caught = 0;
    let releases: Vec<(&str, u64)> = OBJECTS
        .iter()
        .enumerate()
        .flat_map(|(i, &object)| [(object, 500 + i as u64), (object, 600 + i as u64)])
        .collect();
    for &(object, seed) in &releases {
        // unanswered, the object slides out and falls (the lift is above the drop limit)
        assert_eq!(release(object, seed, None), (Verdict::FalseNegative, true));
        let online = Online {
            model: &model.clone().into(),
            strategy,
        };
        caught += usize::from(release(object, seed, Some(online)).0 == Verdict::TruePositive);
    }
    // A model from 20 collect trials (the preset `tmo sim collect` and `tmo reproduce` run);
    // the paper's hand catches 74-94 % (Table III) and the reproduce preset's full models
    // about half, a model from so few trials fewer. Ten releases, two per object, so one
    // release's luck does not decide it (five, with three the bar, were passed by exactly
    // three before the servos' encoder counts and by two after; ten at the collection's
    // own release speed, the paper's since prediction 4: five); every release falls
    // unanswered, so every catch is the detector's doing.
    assert!(caught >= 3, "caught {caught} of {}", releases.len());
}

fn rail_model() -> ModelFile {
    let trials = collect_in_memory(&CollectPreset {
        rig: CollectRig::Rail,
        repetitions: 16,
        seed: 12,
        objects: &["rail_object".to_string()],
        grasps_deg: &[],
    })
    .unwrap();
    logreg_on(&trials)
}

/// One rail trial: its verdict, whether the object dropped, and the reaction's latency
/// after the slip onset the markers saw.
/// One rail trial: the marker's verdict, whether the object dropped, the reaction's latency
/// after the marker's onset, and how long after the simulator's onset the object dropped.
fn rail(
    speed: f64,
    seed: u64,
    online: Option<Online<'_>>,
) -> (Verdict, bool, Option<f64>, Option<f64>) {
    use tmo::runner::monitor::WatchLimits;
    use tmo::runner::rail_catch::{run_rail, RailParams};
    use tmo::runner::sim_presets::{build, Preset};
    let options = PresetOptions {
        retract_speed_mm_s: speed,
        ..Default::default()
    };
    let base = SimConfig {
        seed,
        ..SimConfig::default()
    };
    let (config, _) = build(Preset::Rail, &options, base).unwrap();
    let rig = SimRig::new(config).unwrap();
    let mut devices = Devices::of_sim(&rig);
    let params = RailParams {
        retract_speed_mm_s: speed,
        retract_mm: 10.0,
        forward_mm: 1.5,
        forward_speed_mm_s: 20.0,
        torque_limit: 0.8,
        torque_step: 0.05,
        max_torque: 1.0,
        observe_s: 1.5,
        // as the protocol runner does: the whole retraction, then the watch
        max_duration_s: 10.0 / speed + 1.5,
        watch: WatchLimits::default(),
    };
    let record = run_rail(
        &mut devices,
        &params,
        online,
        &std::sync::atomic::AtomicBool::new(false),
    )
    .unwrap();
    let o = score_catch(
        &record.recording.markers,
        record.reaction.map(|r| r.time_s),
        &CatchSpec::default(),
    );
    eprintln!(
        "rail {speed} mm/s online {}: {:?} dropped {} latency {:?} D {:?} truth {:?}",
        online.is_some(),
        o.verdict,
        o.dropped,
        o.latency_s,
        o.slip_distance_mm,
        rig.probe().events()
    );
    let truth = rig.probe().events();
    let fell_after_s = truth
        .drop_s
        .zip(truth.slip_onsets_s.first())
        .map(|(drop, onset)| drop - onset);
    (o.verdict, o.dropped, o.latency_s, fell_after_s)
}

#[test]
fn a_trained_detector_reacts_to_the_rail_object_and_a_quick_reaction_catches_it() {
    let model = rail_model();
    let (mut caught, mut reacted) = (0, 0);
    for (i, speed) in [0.3, 1.0, 2.0, 3.5, 5.0].into_iter().enumerate() {
        let seed = 700 + i as u64;
        let (verdict, dropped, _, fell_after_s) = rail(speed, seed, None);
        assert_eq!((verdict, dropped), (Verdict::FalseNegative, true));
        let fell_after_s = fell_after_s.expect("unanswered, the object slipped and dropped");
        let online = Online {
            model: &model.clone().into(),
            strategy: "1x1".parse().unwrap(),
        };
        let (verdict, dropped, latency, _) = rail(speed, seed, Some(online));
        // The small rail object leaves the fingertip after 30 mm of slide, about 80 ms of
        // fall, and the arm's press comes after its command latency: only the quickest
        // reactions catch it (the paper-scale rows measure how often; the paper's drops
        // rise from 6 % to 28 % when two frames are needed).
        // A reaction before the onset answers the fingertip's own slip along the object
        // (its patch breaks free as the retraction relaxes the grip) and holds it there.
        // A reaction counts if it came before the object would have left the fingertip
        // unanswered (0.15-0.3 s after the onset).
        let early = matches!(verdict, Verdict::FalsePositive | Verdict::HeldNoSlip);
        reacted += usize::from(early || latency.is_some_and(|l| (0.0..fell_after_s).contains(&l)));
        if verdict == Verdict::TruePositive {
            assert!(!dropped, "{speed} mm/s: caught, yet dropped");
        }
        caught += usize::from(!dropped);
    }
    assert!(
        reacted >= 3,
        "reacted before the unanswered object dropped in {reacted} of 5"
    );
    assert!(caught >= 1, "kept {caught} of 5");
}

/// Rice pour on the crisps can: unanswered it falls; with the detector, the hand tightens
/// as the mass grows and holds it.
#[test]
fn responses_keep_a_filling_can_in_the_hand() {
    use tmo::runner::rice_pour::{run_pour, PourParams};
    use tmo::runner::sim_presets::{build, Preset};
    let model = model();
    let pour = |online: Option<Online<'_>>| {
        let options = PresetOptions {
            object: Some("crisps_can".into()),
            pour_rate_g_per_s: 40.0,
            ..Default::default()
        };
        let base = SimConfig {
            seed: 31,
            ..SimConfig::default()
        };
        let (config, _) = build(Preset::Pour, &options, base).unwrap();
        let rig = SimRig::new(config).unwrap();
        let params = PourParams {
            regrasp: 0.02,
            max_closure: 0.95,
            duration_s: 0.5 + 400.0 / 40.0 + 1.0,
            contact: None,
            watch: Default::default(),
        };
        let record = run_pour(
            &mut Devices::of_sim(&rig),
            &params,
            online,
            &std::sync::atomic::AtomicBool::new(false),
        )
        .unwrap();
        let o = score_catch(&record.recording.markers, None, &CatchSpec::default());
        let responses = record
            .events
            .iter()
            .filter(|e| tmo::trial::is_reaction(e))
            .count();
        let truth = rig.probe().events();
        eprintln!(
            "online {}: dropped {}, responses {responses}; truth {truth:?}",
            online.is_some(),
            o.dropped,
        );
        (o.dropped, responses, truth)
    };
    let (dropped, responses, unanswered) = pour(None);
    assert_eq!((dropped, responses), (true, 0));
    assert!(unanswered.catches_s.is_empty());
    // One frame on two sensors. The fingertips' own slips as the can fills (each patch
    // breaks free along it before the can slips) come in frames this small model was
    // trained to call static, and it answers the can's slip itself some tenths of a
    // second late: the responses tighten the hand and catch the can in the hand, though
    // it has fallen about as far as the marker's drop line by then (the paper-scale pour,
    // its own model and 2x2, is `pour-never-dropped`).
    let (_, responses, answered) = pour(Some(Online {
        model: &model.clone().into(),
        strategy: "1x2".parse().unwrap(),
    }));
    assert!(responses >= 1, "responses {responses}");
    assert!(
        !answered.catches_s.is_empty() && answered.max_fall_mm < 0.5 * unanswered.max_fall_mm,
        "{answered:?} against unanswered {unanswered:?}"
    );
}
