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
        &[
            "evaluate",
            "logreg.onnx",
            "t",
            "--out",
            "eval.json",
            "--rows",
            "rows.csv",
        ],
    ));
    // the model by its tmo.name
    assert!(
        out.contains("logreg (scikit-learn, skl2onnx): onnx (global scope) on"),
        "{out}"
    );
    // every row's value and class: slip exactly where the value reaches the threshold 0.5
    let mut reader = csv::Reader::from_path(d.join("rows.csv")).unwrap();
    assert_eq!(
        reader.headers().unwrap(),
        vec!["trial_id", "sensor", "seq", "time_s", "label", "value", "class"]
    );
    let rows: Vec<csv::StringRecord> = reader.records().map(|r| r.unwrap()).collect();
    let mut slips = 0;
    for r in &rows {
        let value: f32 = r[5].parse().unwrap();
        assert_eq!(&r[6] == "slip", value >= 0.5, "{r:?}");
        slips += usize::from(&r[6] == "slip");
    }
    assert!(slips > 0 && slips < rows.len(), "{slips} of {}", rows.len());
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
    // every frame's value through replay: each value the live loop logged, the same
    ok(&tmo(
        d,
        &[
            "replay",
            "b",
            "--model",
            "logreg.onnx",
            "--strategy",
            "1x1",
            "--rows",
            "v.csv",
        ],
    ));
    let mut reader = csv::Reader::from_path(d.join("v.csv")).unwrap();
    assert_eq!(
        reader.headers().unwrap(),
        vec!["model", "trial_id", "sensor", "seq", "time_s", "value", "class"]
    );
    let mut replayed = std::collections::HashMap::new();
    for r in reader.records().map(|r| r.unwrap()) {
        assert_eq!(&r[0], "logreg (scikit-learn, skl2onnx)");
        let value: f32 = r[5].parse().unwrap();
        assert_eq!(&r[6] == "slip", value >= 0.5, "{r:?}");
        replayed.insert(
            (r[1].to_string(), r[2].to_string(), r[3].to_string()),
            value,
        );
    }
    let mut compared = 0;
    for path in std::fs::read_dir(d.join("b")).unwrap() {
        let path = path.unwrap().path();
        if path.extension().is_none_or(|e| e != "mcap") {
            continue;
        }
        let trial = tmo::trial::read_trial(&path).unwrap();
        if trial.meta.parameters.get("model_name").map(String::as_str)
            != Some("logreg (scikit-learn, skl2onnx)")
        {
            continue;
        }
        for e in trial.events.iter().filter(|e| e.topic == "/classifier") {
            let key = (
                trial.meta.trial_id.clone(),
                e.data["sensor"].to_string(),
                e.data["seq"].to_string(),
            );
            let logged = e.data["value"].as_f64().unwrap() as f32;
            assert_eq!(replayed[&key], logged, "{key:?}");
            compared += 1;
        }
    }
    assert!(compared > 100, "{compared}");
}

#[test]
fn each_of_a_protocols_models_is_a_row_of_its_own() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let models = ["window_mlp", "logreg", "forest", "boosted", "mlp_pipeline"];
    for m in models {
        copy_fixture(d, &format!("{m}.onnx"));
    }
    let list: Vec<String> = models.iter().map(|m| format!("\"{m}.onnx\"")).collect();
    std::fs::write(
        d.join("hand.toml"),
        format!("kind = \"hand_release\"\nobjects = [\"crisps_can\"]\ngrasps_deg = [0]\nmodels = [{}]\nstrategies = [\"1x1\"]\nrepetitions = 1\nseed = 6\n", list.join(", ")),
    )
    .unwrap();
    let out = ok(&tmo(d, &["run", "hand.toml", "--out", "b"]));
    let mut reader = csv::Reader::from_path(d.join("b/outcomes.csv")).unwrap();
    let rows: Vec<std::collections::HashMap<String, String>> =
        reader.deserialize().map(|r| r.unwrap()).collect();
    let named: std::collections::BTreeSet<&str> =
        rows.iter().map(|r| r["model"].as_str()).collect();
    // each model by its tmo.name, once
    let expected: std::collections::BTreeSet<&str> = [
        "gradient boosting, 50 trees (skl2onnx)",
        "random forest, 50 trees (skl2onnx)",
        "logreg (scikit-learn, skl2onnx)",
        "mlp pipeline (skl2onnx)",
        "window mlp, 15 frames (scikit-learn)",
    ]
    .into();
    assert_eq!(rows.len(), 5);
    assert_eq!(named, expected);
    // the summary's table has a model column and a row per model, none pooled
    assert!(out.contains("| model | scope |"), "{out}");
    for n in &named {
        assert!(
            out.contains(&format!("| {n} | global | 1Fr1Sen |")),
            "{n}: {out}"
        );
    }
}

#[test]
fn a_protocol_whose_trials_cannot_fill_the_window_is_refused_before_its_first_trial() {
    use prost::Message;
    use tract_onnx::pb;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // the per-frame-rows model over a window of 100 frames (its operators work on any K)
    let bytes = std::fs::read(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/onnx/window_rows.onnx"),
    )
    .unwrap();
    let mut proto = pb::ModelProto::decode(bytes.as_slice()).unwrap();
    let graph = proto.graph.as_mut().unwrap();
    for v in graph.input.iter_mut().chain(graph.output.iter_mut()) {
        if let Some(pb::type_proto::Value::TensorType(t)) =
            v.r#type.as_mut().and_then(|t| t.value.as_mut())
        {
            t.shape.as_mut().unwrap().dim[1].value =
                Some(pb::tensor_shape_proto::dimension::Value::DimValue(100));
        }
    }
    for e in proto.metadata_props.iter_mut() {
        if e.key == "tmo.window" {
            e.value = "100".into();
        }
    }
    std::fs::write(d.join("long.onnx"), proto.encode_to_vec()).unwrap();
    // a rail trial lasts at most 1 s here: 60 frames
    std::fs::write(
        d.join("rail.toml"),
        "kind = \"rail_catch\"\nobjects = [\"rail_object\"]\nmodels = [\"long.onnx\"]\nstrategies = [\"1x1\"]\nrepetitions = 1\nseed = 3\n[rail_catch]\nmax_duration_s = 1.0\n",
    )
    .unwrap();
    let e = fails(&tmo(d, &["run", "rail.toml", "--out", "b"]));
    assert!(
        e.contains("the model reads a window of 100 frames (tmo.window), longer than the trial (60 frames per sensor)"),
        "{e}"
    );
    assert!(
        e.contains("this protocol's trials last at most 1 s (60 frames at 60 fps)"),
        "{e}"
    );
    assert!(!d.join("b").join("trial-00000.mcap").exists());
    // a model trained at 30 fps runs on the 60 fps rig, with a warning before the first trial
    let bytes = std::fs::read(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/onnx/logreg.onnx"),
    )
    .unwrap();
    let mut proto = pb::ModelProto::decode(bytes.as_slice()).unwrap();
    for e in proto.metadata_props.iter_mut() {
        if e.key == "tmo.features" {
            let mut spec: serde_json::Value = serde_json::from_str(&e.value).unwrap();
            spec["frame_rate_hz"] = 30.0.into();
            e.value = spec.to_string();
        }
    }
    std::fs::write(d.join("slow.onnx"), proto.encode_to_vec()).unwrap();
    std::fs::write(
        d.join("rail30.toml"),
        "kind = \"rail_catch\"\nobjects = [\"rail_object\"]\nmodels = [\"slow.onnx\"]\nstrategies = [\"1x1\"]\nrepetitions = 1\nseed = 3\n[rail_catch]\nmax_duration_s = 1.0\n",
    )
    .unwrap();
    let run = tmo(d, &["run", "rail30.toml", "--out", "b30"]);
    ok(&run);
    let warnings = String::from_utf8_lossy(&run.stderr);
    assert!(
        warnings.contains("warning: slow.onnx: the rig's frame rate is 60.0 Hz, the model's training data's 30.0 Hz: velocities are per frame"),
        "{warnings}"
    );
}

#[test]
fn a_model_that_gives_nan_on_a_recorded_frame_stops_the_replay_naming_the_frame() {
    use prost::Message;
    use tract_onnx::pb;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // the square root of the first pin's centred angle: NaN wherever that angle is negative
    let bytes = std::fs::read(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/onnx/logreg.onnx"),
    )
    .unwrap();
    let mut proto = pb::ModelProto::decode(bytes.as_slice()).unwrap();
    let graph = proto.graph.as_mut().unwrap();
    graph.node = vec![pb::NodeProto {
        op_type: "Sqrt".into(),
        input: vec!["features".into()],
        output: vec!["out".into()],
        ..Default::default()
    }];
    graph.initializer.clear();
    graph.output = vec![pb::ValueInfoProto {
        name: "out".into(),
        ..graph.input[0].clone()
    }];
    proto.opset_import.retain(|o| o.domain.is_empty());
    for e in proto.metadata_props.iter_mut() {
        match e.key.as_str() {
            "tmo.slip_output" => e.value = "out".into(),
            "tmo.slip_column" => e.value = "30".into(),
            "tmo.name" => e.value = "sqrt".into(),
            _ => {}
        }
    }
    std::fs::write(d.join("sqrt.onnx"), proto.encode_to_vec()).unwrap();
    ok(&tmo(
        d,
        &[
            "-q", "sim", "collect", "--trials", "5", "--seed", "9", "--out", "t",
        ],
    ));
    let e = fails(&tmo(
        d,
        &["replay", "t", "--model", "sqrt.onnx", "--strategy", "1x1"],
    ));
    assert!(e.contains("replaying t/"), "{e}");
    assert!(e.contains("sqrt: the slip value of sensor "), "{e}");
    assert!(e.contains(" is NaN, not a finite number"), "{e}");
}

#[test]
fn a_windowed_model_longer_than_a_trial_is_refused_before_replaying() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    copy_fixture(d, "window_mlp.onnx");
    // one sensor of 30 pins, 10 frames: shorter than the model's 15-frame window
    let mut csv = String::from("trial,sensor,frame,t_s,element,x,y,slip\n");
    for f in 0..10 {
        for e in 0..30 {
            csv += &format!(
                "a,s,{f},{:.4},{e},{},{},{}\n",
                f as f64 / 60.0,
                10.0 + 3.0 * e as f64 + 0.1 * f as f64,
                20.0 + 0.05 * f as f64,
                u8::from(f > 6)
            );
        }
    }
    std::fs::write(d.join("short.csv"), csv).unwrap();
    ok(&tmo(
        d,
        &["-q", "import", "csv", "short.csv", "--out", "short"],
    ));
    let e = fails(&tmo(d, &["replay", "short", "--model", "window_mlp.onnx"]));
    assert!(
        e.contains("window_mlp.onnx cannot replay short/a.mcap: the model reads a window of 15 frames (tmo.window), longer than the trial (10 frames per sensor)"),
        "{e}"
    );
}

/// On the smoke preset: the model's path through the steps is under test, not the findings.
#[test]
fn a_reproduction_judges_a_users_model_as_the_hands_global_model() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    copy_fixture(d, "logreg.onnx");
    let out = ok(&tmo(
        d,
        &[
            "reproduce",
            "--preset",
            "smoke",
            "--hand-model",
            "logreg.onnx",
            "--out",
            "q",
        ],
    ));
    assert!(
        out.contains("The whole hand's global model in this reproduction is the user's"),
        "{out}"
    );
    let models = d.join("q/replicate-01/06_hand_models");
    let sha = tmo::trial::sha256_hex(&std::fs::read(d.join("logreg.onnx")).unwrap());
    assert_eq!(
        std::fs::read(models.join("user_model.onnx")).unwrap(),
        std::fs::read(d.join("logreg.onnx")).unwrap()
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("q/findings.json")).unwrap()).unwrap();
    assert_eq!(json["hand_model"]["file"], "user_model.onnx");
    assert_eq!(json["hand_model"]["sha256"], sha.as_str());
    let eval = |f: &str| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(models.join(f)).unwrap()).unwrap()
    };
    assert_eq!(eval("eval_global.json")["classifier"], "onnx");
    assert_eq!(eval("eval_tmo_global.json")["classifier"], "svm-rbf");
    // every online hand step ran the user's model in place of tmo's global one
    for protocol in [
        "07_hand_online/protocol.toml",
        "08_hand_objects/all/protocol.toml",
        "09_rice_pour/protocol.toml",
        "11_first_time_lift/can/protocol.toml",
    ] {
        let text = std::fs::read_to_string(d.join("q/replicate-01").join(protocol)).unwrap();
        assert!(
            text.contains("06_hand_models/user_model.onnx\""),
            "{protocol}: {text}"
        );
        assert!(!text.contains("global.json"), "{protocol}: {text}");
    }
    let page = std::fs::read_to_string(d.join("q/findings.md")).unwrap();
    assert!(
        page.contains("logreg.onnx` (onnx, 1 frame a classification"),
        "{page}"
    );

    // the page written again checks the steps against the model they recorded
    let again = ok(&tmo(
        d,
        &[
            "reproduce",
            "--preset",
            "smoke",
            "--out",
            "q",
            "--findings-only",
        ],
    ));
    assert!(!again.contains("other inputs"), "{again}");
    // without the model, the hand's steps are made again with tmo's own; the rail's kept
    let resumed = ok(&tmo(
        d,
        &["reproduce", "--preset", "smoke", "--out", "q", "--resume"],
    ));
    assert!(
        resumed.contains("5 step(s) run, 6 already done"),
        "{resumed}"
    );
    assert!(!models.join("user_model.onnx").exists());
    assert!(!resumed.contains("user's"), "{resumed}");

    // a model that cannot stand in is refused before anything runs, naming the file
    copy_fixture(d, "svm_skl2onnx.onnx");
    let e = fails(&tmo(
        d,
        &[
            "reproduce",
            "--preset",
            "smoke",
            "--hand-model",
            "svm_skl2onnx.onnx",
            "--out",
            "r",
        ],
    ));
    assert!(
        e.contains("svm_skl2onnx.onnx: operator(s) SVMClassifier"),
        "{e}"
    );
    assert!(!d.join("r").exists());
}

#[test]
fn a_directory_or_a_model_with_external_data_is_refused_saying_what_it_is() {
    use prost::Message;
    use tract_onnx::pb;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir(d.join("models")).unwrap();
    let e = fails(&tmo(
        d,
        &["reproduce", "--hand-model", "models", "--out", "r"],
    ));
    assert!(
        e.contains("models is a directory; a model is one file"),
        "{e}"
    );
    // logreg with its first weights moved to a file beside it, as onnx.save_model's
    // save_as_external_data writes them
    let bytes = std::fs::read(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/onnx/logreg.onnx"),
    )
    .unwrap();
    let mut proto = pb::ModelProto::decode(bytes.as_slice()).unwrap();
    let t = &mut proto.graph.as_mut().unwrap().initializer[0];
    t.float_data.clear();
    t.raw_data.clear();
    t.data_location = Some(pb::tensor_proto::DataLocation::External as i32);
    t.external_data = vec![pb::StringStringEntryProto {
        key: "location".into(),
        value: "weights.bin".into(),
    }];
    std::fs::write(d.join("external.onnx"), proto.encode_to_vec()).unwrap();
    let e = fails(&tmo(
        d,
        &["reproduce", "--hand-model", "external.onnx", "--out", "r"],
    ));
    assert!(
        e.contains("external.onnx")
            && e.contains("kept in external data files beside it (ONNX external data)"),
        "{e}"
    );
    assert!(!d.join("r").exists());
}
