//! ONNX slip models (issue 57): tmo's outputs against onnxruntime's on the committed
//! fixtures (scripts/onnx-fixtures.sh), and the refusals of models that cannot be run.

use std::path::{Path, PathBuf};

use prost::Message;
use tmo::slip::dataset::Dataset;
use tmo::slip::model::ModelFileError;
use tmo::slip::onnx::{OnnxError, OnnxModel};
use tmo::slip::slip_model::SlipModel;
use tmo::slip::Class;
use tract_onnx::pb;

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/onnx")
        .join(name)
}

/// The reference rows as a dataset, in the file's order (two sensors of one trial).
fn rows() -> Dataset {
    let mut reader = csv::Reader::from_path(fixture("rows.csv")).unwrap();
    let header = reader.headers().unwrap().clone();
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    let features: Vec<usize> = header
        .iter()
        .enumerate()
        .filter(|(_, h)| h.starts_with("dr_") || h.starts_with("dtheta_"))
        .map(|(i, _)| i)
        .collect();
    let mut ds = Dataset {
        dim: features.len(),
        ..Default::default()
    };
    for record in reader.records() {
        let r = record.unwrap();
        let trial = r[col("trial_id")].to_string();
        let t = match ds.trial_ids.iter().position(|id| *id == trial) {
            Some(t) => t,
            None => {
                ds.trial_ids.push(trial);
                ds.trial_ids.len() - 1
            }
        };
        ds.trial.push(t as u32);
        ds.sensor.push(r[col("sensor")].parse().unwrap());
        ds.seq.push(r[col("seq")].parse().unwrap());
        ds.time_s.push(r[col("time_s")].parse().unwrap());
        ds.y.push(if &r[col("label")] == "slip" {
            Class::Slip
        } else {
            Class::Static
        });
        ds.x.extend(features.iter().map(|&i| r[i].parse::<f32>().unwrap()));
    }
    ds
}

fn reference() -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(fixture("reference.json")).unwrap()).unwrap()
}

#[test]
fn every_fixture_model_gives_onnxruntimes_values_within_1e_5_and_the_same_classes() {
    let data = rows();
    let reference = reference();
    assert_eq!(data.len(), reference["rows"].as_u64().unwrap() as usize);
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
        let model = OnnxModel::load(&fixture(&format!("{name}.onnx"))).unwrap();
        let ours = model.slip_values(&data).unwrap();
        let theirs = reference["models"][name]["values"].as_array().unwrap();
        let threshold = reference["models"][name]["threshold"].as_f64().unwrap() as f32;
        assert_eq!(model.meta.threshold, threshold, "{name}");
        assert_eq!(ours.len(), theirs.len(), "{name}");
        let mut compared = 0;
        let mut slips = 0;
        for (i, (o, t)) in ours.iter().zip(theirs).enumerate() {
            match (o, t.as_f64()) {
                (None, None) => {}
                (Some(o), Some(t)) => {
                    let t = t as f32;
                    let tolerance = 1e-5 * t.abs().max(1.0);
                    assert!(
                        (o - t).abs() <= tolerance,
                        "{name} row {i}: tmo {o}, onnxruntime {t}"
                    );
                    assert_eq!(
                        model.class_of(*o),
                        model.class_of(t),
                        "{name} row {i}: {o} against {t}"
                    );
                    compared += 1;
                    slips += usize::from(model.class_of(*o) == Class::Slip);
                }
                (o, t) => panic!("{name} row {i}: tmo {o:?}, onnxruntime {t:?}"),
            }
        }
        // the comparison covers both classes, and the window's first frames have no value
        assert!(compared > 150, "{name}: {compared}");
        assert!(
            slips > 0 && slips < compared,
            "{name}: {slips} of {compared}"
        );
        if name == "window_mlp" {
            assert_eq!(model.meta.window, 15);
            assert_eq!(compared, data.len() - 2 * 14, "each sensor's first 14 rows");
        }
        if name == "window_rows" {
            assert_eq!(model.meta.window, 10);
            assert_eq!(compared, data.len() - 2 * 9, "each sensor's first 9 rows");
        }
        // scikit-learn's tree ensembles, as skl2onnx writes them, run on tmo's own evaluator
        let trees = matches!(name, "forest" | "boosted");
        assert_eq!(
            model.engine() == "tmo's tree evaluator",
            trees,
            "{name}: {}",
            model.engine()
        );
    }
}

#[test]
fn a_model_with_an_operator_the_runtime_lacks_is_refused_naming_it() {
    let e = OnnxModel::load(&fixture("svm_skl2onnx.onnx")).unwrap_err();
    let text = e.to_string();
    assert!(
        matches!(e, OnnxError::UnsupportedOperators { .. }),
        "{text}"
    );
    assert!(text.contains("svm_skl2onnx.onnx"), "{text}");
    assert!(text.contains("SVMClassifier (ai.onnx.ml)"), "{text}");
    assert!(
        text.contains("not supported by tmo's ONNX runtime"),
        "{text}"
    );
    // through the loader every command uses, the same message
    let e = SlipModel::load(&fixture("svm_skl2onnx.onnx")).unwrap_err();
    assert!(matches!(e, ModelFileError::Onnx(_)));
    assert!(e.to_string().contains("SVMClassifier"), "{e}");
}

/// The fixture `name` changed by `edit`, written under `dir`.
fn edited(dir: &Path, name: &str, edit: impl FnOnce(&mut pb::ModelProto)) -> PathBuf {
    let bytes = std::fs::read(fixture(name)).unwrap();
    let mut proto = pb::ModelProto::decode(bytes.as_slice()).unwrap();
    edit(&mut proto);
    let path = dir.join(name);
    std::fs::write(&path, proto.encode_to_vec()).unwrap();
    path
}

fn set_prop(proto: &mut pb::ModelProto, key: &str, value: Option<&str>) {
    proto.metadata_props.retain(|e| e.key != key);
    if let Some(v) = value {
        proto.metadata_props.push(pb::StringStringEntryProto {
            key: key.into(),
            value: v.into(),
        });
    }
}

#[test]
fn missing_or_inconsistent_metadata_and_wrong_shapes_are_refused_with_what_was_expected() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let refused = |name: &str, key: &str, value: Option<&str>| {
        let path = edited(d, name, |p| set_prop(p, key, value));
        OnnxModel::load(&path).unwrap_err().to_string()
    };
    let e = refused("logreg.onnx", "tmo.format", None);
    assert!(
        e.contains("logreg.onnx: metadata `tmo.format`: expected `tmo-onnx-slip-model`, found nothing (the key is missing)"),
        "{e}"
    );
    let e = refused("logreg.onnx", "tmo.version", Some("2"));
    assert!(
        e.contains("`tmo.version`: expected 1..=1 (a newer tmo reads newer files), found 2"),
        "{e}"
    );
    let e = refused("logreg.onnx", "tmo.features", Some("{\"pins\": 30}"));
    assert!(
        e.contains("`tmo.features`: expected a JSON feature spec"),
        "{e}"
    );
    assert!(e.contains("max_pin_step_px"), "{e}");
    let e = refused("logreg.onnx", "tmo.threshold", Some("half"));
    assert!(
        e.contains("`tmo.threshold`: expected a finite number"),
        "{e}"
    );
    let e = refused("logreg.onnx", "tmo.slip_output", Some("slip"));
    assert!(e.contains("`tmo.slip_output`: expected one of the graph's outputs (label, probabilities), found `slip`"), "{e}");
    let e = refused("logreg.onnx", "tmo.slip_column", Some("2"));
    assert!(e.contains("output `probabilities`: expected the slip value where tmo.output_rows and tmo.slip_column say, found one row for the batch of one with column 2 (tmo.slip_column): [1], or [1, C] with C > 2; found shape [1, 2]"), "{e}");
    // the features' count against the input: 31 pins are 62 features, the graph takes 60
    let e = refused(
        "logreg.onnx",
        "tmo.features",
        Some(
            "{\"pins\": 31, \"max_pin_step_px\": 20.0, \"units\": \"px\", \"frame_rate_hz\": 60.0}",
        ),
    );
    assert!(
        e.contains("input `features`: expected [N, 62] (62 features of 31 pins, per tmo.features and tmo.window), found [N, 60]"),
        "{e}"
    );
    // a per-frame model said to be windowed, and a windowed one said to be per frame
    let e = refused("logreg.onnx", "tmo.window", Some("15"));
    assert!(e.contains("expected [N, 15, 60]"), "{e}");
    let e = refused("window_mlp.onnx", "tmo.window", None);
    assert!(
        e.contains("expected [N, 60]") && e.contains("found [N, 15, 60]"),
        "{e}"
    );
    let e = refused("window_mlp.onnx", "tmo.window", Some("0"));
    assert!(
        e.contains("`tmo.window`: expected 1..=600 frames, found 0"),
        "{e}"
    );
    // not ONNX at all
    let junk = d.join("junk.onnx");
    std::fs::write(&junk, b"{\"format\": \"tmo-slip-model\"}").unwrap();
    let e = OnnxModel::load(&junk).unwrap_err().to_string();
    assert!(e.contains("junk.onnx: not an ONNX model"), "{e}");
}

#[test]
fn a_window_longer_than_a_trial_is_refused() {
    let model = SlipModel::load(&fixture("window_mlp.onnx")).unwrap();
    assert_eq!(model.window(), 15);
    let e = model.fits_frames(10).unwrap_err();
    assert!(
        e.contains(
            "a window of 15 frames (tmo.window), longer than the trial (10 frames per sensor)"
        ),
        "{e}"
    );
    assert!(model.fits_frames(15).is_ok());
    assert!(model.fits(3, 30).is_ok());
    let e = model.fits(3, 40).unwrap_err();
    assert!(
        e.contains("tmo.features pins = 30, but the fingertips report 40 pins"),
        "{e}"
    );
}

/// tmo's metadata of `logreg.onnx` with `key` set to `value`, and the load's message.
fn refusal(d: &Path, name: &str, key: &str, value: Option<&str>) -> String {
    let path = edited(d, name, |p| set_prop(p, key, value));
    OnnxModel::load(&path).unwrap_err().to_string()
}

#[test]
fn onnx_metadata_gets_the_checks_a_tmo_model_file_gets() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let labels = |n_slip: &str, drop: &str, resolution: &str| {
        format!("{{\"n_slip\": {n_slip}, \"onset\": {{\"drop_threshold_mm\": {drop}, \"hold_window_s\": 0.5, \"confirm_samples\": 5, \"relative_to_hand\": true, \"resolution_mm\": {resolution}, \"rest_samples\": 6}}}}")
    };
    for (value, expected) in [
        (
            labels("0", "1.0", "0.5"),
            "`tmo.labels`, `n_slip`: expected 1..=10000 slip frames, got 0",
        ),
        (
            labels("1000000000", "1.0", "0.5"),
            "expected 1..=10000 slip frames, got 1000000000",
        ),
        (
            labels("13", "-1", "0.5"),
            "`tmo.labels`, `onset`: `drop_threshold_mm` = -1: expected a positive number",
        ),
        (
            labels("13", "1.0", "0"),
            "`resolution_mm` = 0: expected a positive number",
        ),
    ] {
        let e = refusal(d, "logreg.onnx", "tmo.labels", Some(&value));
        assert!(e.contains(expected), "{value}: {e}");
        assert!(e.contains("the same check as a tmo model file's"), "{e}");
    }
    for (rate, expected) in [
        (
            "0",
            "`frame_rate_hz`: expected the frames' rate in Hz, above 0 and at most 10000, got 0",
        ),
        ("-60", "got -60"),
        ("1e6", "got 1000000"),
    ] {
        let spec = format!("{{\"pins\": 30, \"max_pin_step_px\": 20.0, \"units\": \"px\", \"frame_rate_hz\": {rate}}}");
        let e = refusal(d, "logreg.onnx", "tmo.features", Some(&spec));
        assert!(e.contains(expected), "{rate}: {e}");
    }
    // 1e308 is no f32: refused as no feature spec at all
    let spec =
        "{\"pins\": 30, \"max_pin_step_px\": 20.0, \"units\": \"px\", \"frame_rate_hz\": 1e308}";
    let e = refusal(d, "logreg.onnx", "tmo.features", Some(spec));
    assert!(e.contains("`tmo.features`"), "{e}");
    // a model from elsewhere states its rate
    let spec = "{\"pins\": 30, \"max_pin_step_px\": 20.0, \"units\": \"px\"}";
    let e = refusal(d, "logreg.onnx", "tmo.features", Some(spec));
    assert!(
        e.contains("`frame_rate_hz`: expected the frames' rate in Hz that the model was trained at, got none"),
        "{e}"
    );
    // a key inside the JSON given twice
    let spec = "{\"pins\": 30, \"pins\": 31, \"max_pin_step_px\": 20.0, \"units\": \"px\", \"frame_rate_hz\": 60.0}";
    let e = refusal(d, "logreg.onnx", "tmo.features", Some(spec));
    assert!(e.contains("duplicate field `pins`"), "{e}");
    // sensors each once
    let e = refusal(d, "logreg.onnx", "tmo.sensors", Some("[0, 0, 1]"));
    assert!(e.contains("each once") && e.contains("[0, 0, 1]"), "{e}");
    // tmo.output_rows
    let e = refusal(d, "logreg.onnx", "tmo.output_rows", Some("newest"));
    assert!(e.contains("`tmo.output_rows`: expected `one`"), "{e}");
    let e = refusal(d, "logreg.onnx", "tmo.output_rows", Some("per_frame"));
    assert!(e.contains("`per_frame` is for a window's rows"), "{e}");
}

#[test]
fn a_key_given_twice_or_one_tmo_does_not_read_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let path = edited(d, "logreg.onnx", |p| {
        p.metadata_props.push(pb::StringStringEntryProto {
            key: "tmo.threshold".into(),
            value: "0.9".into(),
        })
    });
    let e = OnnxModel::load(&path).unwrap_err().to_string();
    assert!(
        e.contains("metadata `tmo.threshold`: expected each key once, found the key twice"),
        "{e}"
    );
    let e = refusal(d, "logreg.onnx", "tmo.treshold", Some("0.5"));
    assert!(
        e.contains("metadata `tmo.treshold`: expected one of tmo's keys"),
        "{e}"
    );
}

#[test]
fn an_output_of_several_rows_is_read_where_the_metadata_says_or_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // one row per frame of the window, read as a batch's one row: refused with its shape
    let e = refusal(d, "window_rows.onnx", "tmo.output_rows", None);
    assert!(e.contains("found shape [1, 10, 1]"), "{e}");
    // as the metadata says, the newest frame's row: the frame MLP's value on that frame
    let per_row = OnnxModel::load(&fixture("window_rows.onnx")).unwrap();
    let frame = OnnxModel::load(&fixture("frame_mlp.onnx")).unwrap();
    let data = rows();
    let windowed = per_row.slip_values(&data).unwrap();
    let per_frame = frame.slip_values(&data).unwrap();
    for (i, (w, f)) in windowed.iter().zip(&per_frame).enumerate() {
        if let Some(w) = w {
            assert!((w - f.unwrap()).abs() < 1e-5, "row {i}: {w} against {f:?}");
        }
    }
    // the shapes a batch of one may have
    use tmo::slip::onnx::{slip_value_in, OutputRows};
    assert_eq!(slip_value_in(&[1], &[0.7], OutputRows::One, 0, 1), Ok(0.7));
    assert_eq!(
        slip_value_in(&[1, 2], &[0.3, 0.7], OutputRows::One, 1, 1),
        Ok(0.7)
    );
    assert!(slip_value_in(&[2, 2], &[0.3, 0.7, 0.1, 0.9], OutputRows::One, 1, 1).is_err());
    assert!(slip_value_in(&[1, 15, 2], &[0.0; 30], OutputRows::One, 1, 15).is_err());
    let mut values = vec![0.0; 30];
    values[29] = 0.9;
    assert_eq!(
        slip_value_in(&[1, 15, 2], &values, OutputRows::PerFrame, 1, 15),
        Ok(0.9)
    );
    assert!(slip_value_in(&[1, 14, 2], &values[..28], OutputRows::PerFrame, 1, 15).is_err());
}

/// A graph whose output is `op` of the features (shape [N, 60]), read at `column`.
fn elementwise(d: &Path, op: &str, column: usize) -> PathBuf {
    edited(d, "logreg.onnx", |p| {
        let graph = p.graph.as_mut().unwrap();
        graph.node = vec![pb::NodeProto {
            op_type: op.into(),
            input: vec!["features".into()],
            output: vec!["out".into()],
            ..Default::default()
        }];
        graph.initializer.clear();
        graph.output = vec![pb::ValueInfoProto {
            name: "out".into(),
            ..graph.input[0].clone()
        }];
        p.opset_import.retain(|o| o.domain.is_empty());
        set_prop(p, "tmo.slip_output", Some("out"));
        set_prop(p, "tmo.slip_column", Some(&column.to_string()));
        set_prop(p, "tmo.threshold", Some("0.5"));
    })
}

#[test]
fn a_non_finite_slip_value_is_refused_at_load_and_named_with_its_frame_at_run_time() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Log(0) is -inf: the run on zeros at load refuses it
    let e = OnnxModel::load(&elementwise(d, "Log", 0))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("the slip value is -inf for an input of zeros (the run at load)"),
        "{e}"
    );
    // Sqrt of an angle: fine on zeros, NaN on the first negative dtheta
    let model = OnnxModel::load(&elementwise(d, "Sqrt", 30)).unwrap();
    let e = model.slip_values(&rows()).unwrap_err().to_string();
    assert!(e.contains("the slip value is NaN at trial "), "{e}");
    assert!(e.contains(", sensor ") && e.contains(", frame "), "{e}");
    // online: the frame faults, never reads as static
    let slip = SlipModel::Onnx(model);
    let mut classifier = tmo::online::classify::FrameClassifier::new(&slip, 1);
    // pin 0 moves right (angle 0), the others up (pi/2): pin 0's centred angle is
    // negative, so its square root is NaN
    let frame = |seq: u64, step: f32| tmo_hal::PinFrame {
        sensor: 0,
        seq,
        time_s: seq as f64 / 60.0,
        pins: (0..30)
            .map(|i| {
                if i == 0 {
                    [step, 10.0]
                } else {
                    [3.0 * i as f32, 10.0 + step]
                }
            })
            .collect(),
    };
    assert_eq!(classifier.classify(&frame(0, 0.0)), Ok(None));
    assert_eq!(
        classifier.classify(&frame(1, 1.0)),
        Err(tmo::online::classify::BadOutput::Nan)
    );
}

#[test]
fn operators_are_looked_up_with_their_domain_and_newer_opsets_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // a custom domain's operator named like a standard one is not that operator
    let path = edited(d, "frame_mlp.onnx", |p| {
        let graph = p.graph.as_mut().unwrap();
        graph
            .node
            .iter_mut()
            .find(|n| n.op_type == "Relu")
            .unwrap()
            .domain = "com.example".into();
        p.opset_import.push(pb::OperatorSetIdProto {
            domain: "com.example".into(),
            version: 1,
        });
    });
    let e = OnnxModel::load(&path).unwrap_err().to_string();
    assert!(
        e.contains("operator(s) Relu (com.example) not supported"),
        "{e}"
    );
    // an operator set from the future
    let path = edited(d, "frame_mlp.onnx", |p| {
        p.opset_import[0].version = 99;
    });
    let e = OnnxModel::load(&path).unwrap_err().to_string();
    assert!(
        e.contains("operator set of `ai.onnx`: expected 1..=25") && e.contains("found 99"),
        "{e}"
    );
}
