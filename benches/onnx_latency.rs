//! What an ONNX slip model costs in the 60 fps loop (issue 57): the time from a frame
//! reaching the online classifier (`FrameClassifier::classify`: features from the
//! sensor's previous frame, the model, the class) to its class, per frame, for tmo's own
//! RBF SVM and logistic regression (the anchors, trained here on the benches' 40 hand
//! releases, seed 1, with the README's hyperparameters) and the ONNX fixtures
//! (tests/fixtures/onnx: a logistic regression, an RBF SVC of 246 support vectors, a
//! per-frame MLP and an MLP over a 15-frame window), all in the same run, on the frames of
//! 10 other hand releases (seed 2) fed in arrival order as the runner feeds them.
//!
//! Frame-in to command-out on a rig is the backend's own path (`cargo bench --bench
//! backend_latency`: median 0.10 ms, p99 0.17 ms with a threshold model, whose
//! classification is about 1 us) plus the classification measured here.
//!
//! Run: `cargo bench --bench onnx_latency` (`ANCHOR_MODEL=global.json` adds a model file of
//! tmo's own, e.g. the paper preset's hand SVM).

mod common;

use std::path::Path;
use std::time::Instant;

use tmo::online::classify::FrameClassifier;
use tmo::slip::dataset::{LabelSpec, Scope};
use tmo::slip::features::FeatureSpec;
use tmo::slip::labels::OnsetSpec;
use tmo::slip::model::{ClassifierKind, Hyperparameters, ModelFile, TrainSpec};
use tmo::slip::slip_model::SlipModel;

fn tmo_model(kind: ClassifierKind, hyper: Hyperparameters) -> SlipModel {
    let rows = common::hand_release_rows(1, &[0.0]);
    let spec = TrainSpec {
        kind,
        hyper,
        scope: Scope::Global,
        features: FeatureSpec::new(30),
        labels: LabelSpec {
            n_slip: 13,
            onset: OnsetSpec::default(),
        },
        downsample: 1.0,
        seed: 1,
    };
    ModelFile::train(&rows, &spec, vec![], None)
        .expect("the anchor trains")
        .into()
}

/// Per-frame classification times, us, sorted; and how many frames got a class.
fn time(model: &SlipModel, trials: &[tmo::trial::Trial]) -> (Vec<f64>, usize) {
    let mut us = Vec::new();
    let mut classified = 0;
    for _ in 0..3 {
        for trial in trials {
            let mut classifier = FrameClassifier::new(model, 3);
            for frame in &trial.frames {
                let t = Instant::now();
                let class = std::hint::black_box(classifier.classify(frame));
                us.push(t.elapsed().as_secs_f64() * 1e6);
                classified += usize::from(class.expect("a finite slip value").is_some());
            }
        }
    }
    us.sort_by(f64::total_cmp);
    (us, classified / 3)
}

/// The fixtures' reference rows (tests/fixtures/onnx/rows.csv): each row's features.
fn reference_rows(fixtures: &Path) -> Vec<Vec<f32>> {
    let mut reader = csv::Reader::from_path(fixtures.join("rows.csv")).expect("rows.csv");
    let header = reader.headers().expect("a header").clone();
    let columns: Vec<usize> = header
        .iter()
        .enumerate()
        .filter(|(_, h)| h.starts_with("dr_") || h.starts_with("dtheta_"))
        .map(|(i, _)| i)
        .collect();
    reader
        .records()
        .map(|r| {
            let r = r.expect("a row");
            columns
                .iter()
                .map(|&i| r[i].parse().expect("a number"))
                .collect()
        })
        .collect()
}

/// The model alone on one row (batch of one), us, sorted: what onnxruntime's figure in
/// onnxruntime_timing.json (scripts/time_onnxruntime.py, the same rows) measures.
fn time_model_alone(model: &tmo::slip::onnx::OnnxModel, rows: &[Vec<f32>]) -> Vec<f64> {
    let mut us = Vec::new();
    for _ in 0..20 {
        for row in rows {
            let t = Instant::now();
            std::hint::black_box(
                model
                    .slip_value(std::hint::black_box(row))
                    .expect("a value"),
            );
            us.push(t.elapsed().as_secs_f64() * 1e6);
        }
    }
    us.sort_by(f64::total_cmp);
    us
}

/// The model alone against onnxruntime's committed figure on the same rows, for the
/// per-frame fixtures.
fn model_alone_against_onnxruntime(fixtures: &Path) {
    let rows = reference_rows(fixtures);
    let ort: serde_json::Value = std::fs::read_to_string(fixtures.join("onnxruntime_timing.json"))
        .ok()
        .and_then(|t| serde_json::from_str(&t).ok())
        .unwrap_or_default();
    println!(
        "the model alone, one row (batch of one), {} rows x 20; onnxruntime {} on the same rows ({}):",
        rows.len(),
        ort["onnxruntime"].as_str().unwrap_or("?"),
        ort["machine"].as_str().unwrap_or("not measured: run scripts/time_onnxruntime.py tests/fixtures/onnx/onnxruntime_timing.json")
    );
    for name in [
        "logreg",
        "svm_rbf",
        "frame_mlp",
        "mlp_pipeline",
        "forest",
        "boosted",
    ] {
        let model = tmo::slip::onnx::OnnxModel::load(&fixtures.join(format!("{name}.onnx")))
            .expect("fixture");
        let us = time_model_alone(&model, &rows);
        let at = |q: f64| us[((q * us.len() as f64).ceil() as usize).clamp(1, us.len()) - 1];
        let theirs = ort["models"][name]["median_us"].as_f64();
        println!(
            "  {name:<14} {:<22} median {:>7.2} us  p99 {:>7.2} us  onnxruntime median {}  ratio {}",
            model.engine(),
            at(0.5),
            at(0.99),
            theirs.map_or("?".into(), |t| format!("{t:.2} us")),
            theirs.map_or("?".into(), |t| format!("x{:.2}", at(0.5) / t))
        );
    }
}

fn main() {
    let trials = common::hand_release_trials(2, 2, &[0.0]);
    let frames: usize = trials.iter().map(|t| t.frames.len()).sum();
    let fixtures = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/onnx");
    let mut models: Vec<(String, SlipModel)> = vec![
        (
            "tmo svm-rbf (C 3.989, gamma 1/60)".into(),
            tmo_model(
                ClassifierKind::SvmRbf,
                Hyperparameters {
                    c: 3.989,
                    gamma: 1.0 / 60.0,
                    max_iterations: None,
                },
            ),
        ),
        (
            "tmo logreg (C 3.989)".into(),
            tmo_model(
                ClassifierKind::Logreg,
                Hyperparameters {
                    c: 3.989,
                    ..Default::default()
                },
            ),
        ),
    ];
    if let Ok(path) = std::env::var("ANCHOR_MODEL") {
        let model = SlipModel::load(Path::new(&path)).expect("ANCHOR_MODEL loads");
        models.push((format!("tmo {} ({path})", model.classifier_name()), model));
    }
    for name in [
        "logreg",
        "svm_rbf",
        "frame_mlp",
        "window_mlp",
        "mlp_pipeline",
        "forest",
        "boosted",
        "window_rows",
    ] {
        let model = SlipModel::load(&fixtures.join(format!("{name}.onnx"))).expect("fixture");
        models.push((format!("onnx {name} (K {})", model.window()), model));
    }
    model_alone_against_onnxruntime(&fixtures);
    println!(
        "per-frame classification, frame in -> class out ({} trials, {frames} frames, each timed 3 times):",
        trials.len()
    );
    let mut anchor = None;
    for (name, model) in &models {
        let (us, classified) = time(model, &trials);
        let at = |q: f64| us[((q * us.len() as f64).ceil() as usize).clamp(1, us.len()) - 1];
        let (median, p99) = (at(0.5), at(0.99));
        let (m0, p0) = *anchor.get_or_insert((median, p99));
        println!(
            "  {name:<44} median {median:>7.1} us  p99 {p99:>7.1} us  max {:>8.1} us  (x{:.2} / x{:.2} the tmo SVM's)  {classified} frames classified",
            us.last().copied().unwrap_or(f64::NAN),
            median / m0,
            p99 / p0
        );
    }
}
