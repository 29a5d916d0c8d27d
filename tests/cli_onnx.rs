//! ONNX slip models through the real binary (issue 57): evaluate, a protocol's models on
//! the simulator, replay with the same model, and the refusals, each with exit code 2.

mod common;

use std::path::Path;

use common::*;

fn copy_fixture(d: &Path, name: &str) {
    let from = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/onnx")
        .join(name);
    std::fs::copy(from, d.join(name)).unwrap();
}

#[test]
fn evaluate_scores_an_onnx_model_per_frame_and_over_a_window() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for name in ["logreg.onnx", "window_mlp.onnx", "svm_skl2onnx.onnx"] {
        copy_fixture(d, name);
    }
    ok(&tmo(
        d,
        &[
            "-q", "sim", "collect", "--trials", "5", "--seed", "9", "--out", "t",
        ],
    ));
    let out = ok(&tmo(
        d,
        &["evaluate", "logreg.onnx", "t", "--out", "eval.json"],
    ));
    assert!(out.contains("onnx (global scope) on"), "{out}");
    assert!(out.contains("overall"), "{out}");
    let eval: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("eval.json")).unwrap()).unwrap();
    assert_eq!(eval["classifier"], "onnx");
    assert_eq!(eval["n_slip"], 13, "the labels the model was trained with");
    let f1 = eval["overall"]["macro_f1"].as_f64().unwrap();
    assert!(f1 > 0.5 && f1 <= 1.0, "{f1}");

    let window = tmo(d, &["evaluate", "window_mlp.onnx", "t"]);
    let out = ok(&window);
    assert!(out.contains("onnx (global scope) on"), "{out}");
    let notes = String::from_utf8_lossy(&window.stderr);
    assert!(
        notes.contains("come before a full window of 15 frames of their trial and sensor"),
        "{notes}"
    );

    // refusals: exit 2, the file named, what it lacks
    let e = fails(&tmo(d, &["evaluate", "svm_skl2onnx.onnx", "t"]));
    assert!(
        e.contains("svm_skl2onnx.onnx: operator(s) SVMClassifier (ai.onnx.ml) not supported"),
        "{e}"
    );
}

#[test]
fn a_protocol_runs_an_onnx_model_on_the_simulator_and_replay_gives_the_same_reactions() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    copy_fixture(d, "window_mlp.onnx");
    copy_fixture(d, "logreg.onnx");
    std::fs::write(
        d.join("hand.toml"),
        "kind = \"hand_release\"\nobjects = [\"crisps_can\", \"banana\"]\ngrasps_deg = [0, 180]\nmodels = [\"window_mlp.onnx\", \"logreg.onnx\"]\nstrategies = [\"1x1\", \"2x2\"]\nrepetitions = 1\nseed = 6\n",
    )
    .unwrap();
    let out = ok(&tmo(d, &["run", "hand.toml", "--out", "b"]));
    assert!(out.contains("16 trial"), "{out}");
    let outcomes = std::fs::read_to_string(d.join("b/outcomes.csv")).unwrap();
    assert_eq!(outcomes.lines().count(), 17, "{outcomes}");
    for model in ["window_mlp.onnx", "logreg.onnx"] {
        let out = ok(&tmo(
            d,
            &[
                "replay",
                "b",
                "--model",
                model,
                "--strategy",
                "1x1,2x2",
                "--out",
                "r",
            ],
        ));
        assert!(out.contains("32 replays of 16 trial(s)"), "{out}");
        let mut reader = csv::Reader::from_path(d.join("r/replay.csv")).unwrap();
        let rows: Vec<std::collections::HashMap<String, String>> =
            reader.deserialize().map(|r| r.unwrap()).collect();
        let compared: Vec<_> = rows
            .iter()
            .filter(|r| !r["matches_logged"].is_empty())
            .collect();
        // each trial that ran this model, once, with its own strategy
        assert_eq!(compared.len(), 8, "{model}: {compared:?}");
        assert!(
            compared.iter().all(|r| r["matches_logged"] == "true"),
            "{model}: {compared:?}"
        );
        std::fs::remove_dir_all(d.join("r")).unwrap();
    }
}
