//! Our classifiers against scikit-learn's on the same rows and hyperparameters. The
//! reference (`tests/fixtures/sklearn_reference.csv`) is made by
//! `scripts/sklearn_reference.py` from `tests/fixtures/slip_features.csv`; CI needs no Python.

use tmo::slip::dataset::Dataset;
use tmo::slip::metrics::macro_f1;
use tmo::slip::model::{ClassifierKind, Hyperparameters, SensorModel};
use tmo::slip::Class;

const FEATURES: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/tests/fixtures/slip_features.csv"
);
const REFERENCE: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/tests/fixtures/sklearn_reference.csv"
);

fn load() -> (Dataset, Vec<bool>) {
    let mut r = csv::Reader::from_path(FEATURES).unwrap();
    let head = r.headers().unwrap().clone();
    let first_feature = head.iter().position(|h| h == "dr_0").unwrap();
    let mut ds = Dataset {
        dim: head.len() - first_feature,
        ..Default::default()
    };
    let mut trial_names: Vec<String> = Vec::new();
    for rec in r.records() {
        let rec = rec.unwrap();
        let t = rec[0].to_string();
        let ti = match trial_names.iter().position(|n| *n == t) {
            Some(i) => i,
            None => {
                trial_names.push(t);
                trial_names.len() - 1
            }
        };
        ds.trial.push(ti as u32);
        ds.sensor.push(rec[1].parse().unwrap());
        ds.seq.push(rec[2].parse().unwrap());
        ds.time_s.push(rec[3].parse().unwrap());
        ds.y.push(if &rec[4] == "slip" {
            Class::Slip
        } else {
            Class::Static
        });
        ds.x.extend(
            rec.iter()
                .skip(first_feature)
                .map(|v| v.parse::<f32>().unwrap()),
        );
    }
    // The script trains on the first half of the sorted trial ids.
    let mut sorted = trial_names.clone();
    sorted.sort();
    let train_names = &sorted[..sorted.len() / 2];
    let train: Vec<bool> = ds
        .trial
        .iter()
        .map(|t| train_names.contains(&trial_names[*t as usize]))
        .collect();
    ds.trial_ids = trial_names;
    (ds, train)
}

struct Reference {
    rows: Vec<usize>,
    labels: Vec<Class>,
    decision: Vec<f64>,
    predicted: Vec<Class>,
}

fn reference(model: &str) -> Reference {
    let mut r = csv::Reader::from_path(REFERENCE).unwrap();
    let head = r.headers().unwrap().clone();
    let col = |name: &str| head.iter().position(|h| h == name).unwrap();
    let (dc, pc) = (
        col(&format!("{model}_decision")),
        col(&format!("{model}_predicted")),
    );
    let mut out = Reference {
        rows: vec![],
        labels: vec![],
        decision: vec![],
        predicted: vec![],
    };
    let class = |v: &str| if v == "1" { Class::Slip } else { Class::Static };
    for rec in r.records() {
        let rec = rec.unwrap();
        out.rows.push(rec[col("row")].parse().unwrap());
        out.labels.push(class(&rec[col("label")]));
        out.decision.push(rec[dc].parse().unwrap());
        out.predicted.push(class(&rec[pc]));
    }
    out
}

fn check(model: &str, kind: ClassifierKind, hyper: Hyperparameters) {
    let (ds, train) = load();
    let train_ds = ds.filter(|i| train[i]);
    let ours = SensorModel::fit(&train_ds, None, kind, hyper).unwrap();
    let reference = reference(model);
    let mut scratch = Vec::new();
    let mut agree = 0;
    let mut max_decision_gap: f64 = 0.0;
    let mut predicted = Vec::new();
    for (k, &row) in reference.rows.iter().enumerate() {
        assert!(!train[row], "reference row {row} is a training row");
        assert_eq!(ds.y[row], reference.labels[k]);
        let d = ours.decision(ds.row(row), &mut scratch);
        let p = ours.predict(ds.row(row), &mut scratch);
        predicted.push(p);
        agree += usize::from(p == reference.predicted[k]);
        max_decision_gap = max_decision_gap.max((d - reference.decision[k]).abs());
    }
    let n = reference.rows.len();
    let agreement = agree as f64 / n as f64;
    let ours_f1 = macro_f1(&reference.labels, &predicted);
    let theirs_f1 = macro_f1(&reference.labels, &reference.predicted);
    eprintln!("{model}: {agree}/{n} predictions agree ({:.2} %), macro F1 ours {ours_f1:.4} vs scikit-learn {theirs_f1:.4}, largest decision gap {max_decision_gap:.4}", 100.0 * agreement);
    assert!(
        agreement >= 0.995,
        "{model}: only {:.2} % agree",
        100.0 * agreement
    );
    assert!(
        (ours_f1 - theirs_f1).abs() <= 0.01,
        "{model}: F1 {ours_f1} vs {theirs_f1}"
    );
}

#[test]
fn rbf_svm_matches_scikit_learn() {
    check(
        "svm_rbf",
        ClassifierKind::SvmRbf,
        Hyperparameters {
            c: 3.989,
            gamma: 0.02,
            max_iterations: None,
        },
    );
}

#[test]
fn linear_svm_matches_scikit_learn() {
    check(
        "svm_linear",
        ClassifierKind::SvmLinear,
        Hyperparameters {
            c: 0.1,
            gamma: 0.0,
            max_iterations: None,
        },
    );
}

#[test]
fn logistic_regression_matches_scikit_learn() {
    check(
        "logreg",
        ClassifierKind::Logreg,
        Hyperparameters {
            c: 1.0,
            gamma: 0.0,
            max_iterations: None,
        },
    );
}
