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
    for name in ["logreg", "svm_rbf", "frame_mlp", "window_mlp"] {
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
    assert!(e.contains("output `probabilities`: expected a column 2 (tmo.slip_column) in its one row, found 2 value(s)"), "{e}");
    // the features' count against the input: 31 pins are 62 features, the graph takes 60
    let e = refused(
        "logreg.onnx",
        "tmo.features",
        Some("{\"pins\": 31, \"max_pin_step_px\": 20.0, \"units\": \"px\"}"),
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
