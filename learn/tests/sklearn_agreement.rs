//! Our classifiers against scikit-learn's on the same rows and hyperparameters, row for row.
//!
//! The rows (`fixtures/slip_features.csv`) are tactile features that `tmo dataset export`
//! wrote; here they are only numbers, a label and a group. The reference
//! (`fixtures/sklearn_reference.csv`) is made by `scripts/sklearn_reference.py` in the
//! workspace root: the first half of the groups (sorted) train, the rest are scored,
//! features standardised on the training rows. This test needs no Python.

use tmo_learn::logreg::LogRegParams;
use tmo_learn::metrics::macro_f1;
use tmo_learn::scaler::Scaler;
use tmo_learn::svm::SvmParams;

const FEATURES: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/tests/fixtures/slip_features.csv"
);
const REFERENCE: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/tests/fixtures/sklearn_reference.csv"
);

/// Every row of the features file: its values, its label (positive = "slip") and group.
struct Rows {
    dim: usize,
    x: Vec<f32>,
    y: Vec<bool>,
    group: Vec<String>,
}

impl Rows {
    fn row(&self, i: usize) -> &[f32] {
        &self.x[i * self.dim..(i + 1) * self.dim]
    }
}

/// A fixture we write ourselves: plain comma-separated values, no quoting.
fn read_table(path: &str) -> (Vec<String>, Vec<Vec<String>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let split = |l: &str| l.split(',').map(str::to_string).collect::<Vec<_>>();
    let head = split(lines.next().unwrap());
    (head, lines.filter(|l| !l.is_empty()).map(split).collect())
}

fn load() -> Rows {
    let (head, records) = read_table(FEATURES);
    let column = |name: &str| head.iter().position(|h| h == name).unwrap();
    let (first_feature, label, trial) = (column("dr_0"), column("label"), column("trial_id"));
    let mut rows = Rows {
        dim: head.len() - first_feature,
        x: vec![],
        y: vec![],
        group: vec![],
    };
    for rec in records {
        rows.group.push(rec[trial].clone());
        rows.y.push(rec[label] == "slip");
        rows.x.extend(
            rec[first_feature..]
                .iter()
                .map(|v| v.parse::<f32>().unwrap()),
        );
    }
    rows
}

/// The training rows as the script chose them: the first half of the sorted groups.
fn training_mask(rows: &Rows) -> Vec<bool> {
    let mut groups = rows.group.clone();
    groups.sort();
    groups.dedup();
    let train = &groups[..groups.len() / 2];
    rows.group.iter().map(|g| train.contains(g)).collect()
}

struct Reference {
    rows: Vec<usize>,
    labels: Vec<bool>,
    decision: Vec<f64>,
    predicted: Vec<bool>,
}

fn reference(model: &str) -> Reference {
    let (head, records) = read_table(REFERENCE);
    let column = |name: &str| head.iter().position(|h| h == name).unwrap();
    let (row, label) = (column("row"), column("label"));
    let (dc, pc) = (
        column(&format!("{model}_decision")),
        column(&format!("{model}_predicted")),
    );
    let mut out = Reference {
        rows: vec![],
        labels: vec![],
        decision: vec![],
        predicted: vec![],
    };
    for rec in records {
        out.rows.push(rec[row].parse().unwrap());
        out.labels.push(rec[label] == "1");
        out.decision.push(rec[dc].parse().unwrap());
        out.predicted.push(rec[pc] == "1");
    }
    out
}

/// A fitted model's decision value of one scaled row.
type Decide = Box<dyn Fn(&[f32]) -> f64>;

fn check(model: &str, fit: impl Fn(usize, &[f32], &[bool]) -> Decide) {
    let rows = load();
    let train = training_mask(&rows);
    let (mut x, mut y) = (Vec::new(), Vec::new());
    for i in (0..rows.y.len()).filter(|&i| train[i]) {
        x.extend_from_slice(rows.row(i));
        y.push(rows.y[i]);
    }
    let scaler = Scaler::fit(rows.dim, &x);
    let decide = fit(rows.dim, &scaler.transform(&x), &y);
    let reference = reference(model);
    let mut scaled = vec![0.0f32; rows.dim];
    let (mut agree, mut max_decision_gap) = (0, 0.0f64);
    let mut predicted = Vec::new();
    for (k, &row) in reference.rows.iter().enumerate() {
        assert!(!train[row], "reference row {row} is a training row");
        assert_eq!(rows.y[row], reference.labels[k], "row {row}'s label");
        scaler.transform_into(rows.row(row), &mut scaled);
        let d = decide(&scaled);
        predicted.push(d > 0.0);
        agree += usize::from((d > 0.0) == reference.predicted[k]);
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
    check("svm_rbf", |dim, x, y| {
        let model = SvmParams::rbf(3.989, 0.02)
            .check()
            .unwrap()
            .fit(dim, x, y)
            .unwrap();
        Box::new(move |row| model.decision(row))
    });
}

#[test]
fn linear_svm_matches_scikit_learn() {
    check("svm_linear", |dim, x, y| {
        let model = SvmParams::linear(0.1)
            .check()
            .unwrap()
            .fit(dim, x, y)
            .unwrap();
        Box::new(move |row| model.decision(row))
    });
}

#[test]
fn logistic_regression_matches_scikit_learn() {
    check("logreg", |dim, x, y| {
        let model = LogRegParams::new(1.0)
            .check()
            .unwrap()
            .fit(dim, x, y)
            .unwrap();
        Box::new(move |row| model.decision(row))
    });
}
