//! The slip commands on the real binary: collect on the simulator, export, train, evaluate,
//! sweep (including an interrupted one) and their errors.

mod common;

use std::path::Path;

use common::*;

fn collect(dir: &Path, n: &str, out: &str, seed: &str) {
    ok(&tmo(
        dir,
        &[
            "sim", "collect", "--trials", n, "--seed", seed, "--out", out,
        ],
    ));
}

fn csv_rows(path: &Path) -> usize {
    csv::Reader::from_path(path).unwrap().records().count()
}

#[test]
fn export_train_evaluate_and_a_model_from_the_future() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    collect(d, "6", "train", "3");
    collect(d, "4", "test", "4");

    let stdout = ok(&tmo(
        d,
        &[
            "dataset",
            "export",
            "train",
            "--n-slip",
            "5",
            "--downsample",
            "0.5",
            "--out",
            "f.csv",
        ],
    ));
    assert!(stdout.contains("f.csv"), "{stdout}");
    let mut reader = csv::Reader::from_path(d.join("f.csv")).unwrap();
    let labels: Vec<String> = reader
        .records()
        .map(|r| r.unwrap()[4].to_string())
        .collect();
    let slip = labels.iter().filter(|l| *l == "slip").count();
    assert_eq!(
        slip,
        6 * 3 * 5,
        "every sensor of every trial gives n_slip slip rows"
    );
    assert!(labels.len() > 10 * slip);

    for classifier in ["logreg", "threshold"] {
        let model = format!("{classifier}.json");
        let stdout = ok(&tmo(
            d,
            &[
                "train",
                "train",
                "--classifier",
                classifier,
                "--C",
                "1",
                "--out",
                &model,
            ],
        ));
        assert!(stdout.contains(&model), "{stdout}");
        let stdout = ok(&tmo(d, &["evaluate", &model, "test"]));
        assert!(
            stdout.contains("overall") && stdout.contains("macro F1"),
            "{stdout}"
        );
    }

    let text = std::fs::read_to_string(d.join("logreg.json")).unwrap();
    let mut json: serde_json::Value = serde_json::from_str(&text).unwrap();
    json["version"] = serde_json::json!(999);
    std::fs::write(d.join("future.json"), json.to_string()).unwrap();
    let err = fails(&tmo(d, &["evaluate", "future.json", "test"]));
    assert!(err.contains("future.json") && err.contains("999"), "{err}");

    let err = fails(&tmo(
        d,
        &["train", "train", "--downsample", "1.5", "--out", "m.json"],
    ));
    assert!(err.contains("--downsample"), "{err}");
    let err = fails(&tmo(d, &["train", "nowhere", "--out", "m.json"]));
    assert!(err.contains("nowhere"), "{err}");
}

#[test]
fn a_sweep_fills_its_grid_and_resumes_after_an_interruption() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    collect(d, "8", "trials", "5");
    let sweep = |extra: &[&str]| {
        let mut args = vec![
            "sweep",
            "trials",
            "--classifiers",
            "logreg,threshold",
            "--downsample",
            "0.5,1.0",
            "--n-slip",
            "3:5",
            "--C",
            "1",
            "--out",
            "out/sweep.csv",
        ];
        args.extend_from_slice(extra);
        tmo(d, &args)
    };
    let stdout = ok(&sweep(&[]));
    assert!(stdout.contains("12 cells to run"), "{stdout}");
    let csv_path = d.join("out/sweep.csv");
    assert_eq!(csv_rows(&csv_path), 12);
    let full = std::fs::read_to_string(&csv_path).unwrap();
    assert!(d.join("out/sweep.json").exists());
    assert!(!d.join("out/sweep.csv.partial").exists());

    // An interruption leaves finished cells in the partial file and no final CSV.
    let partial: Vec<&str> = full.lines().take(5).collect();
    std::fs::write(d.join("out/sweep.csv.partial"), partial.join("\n") + "\n").unwrap();
    std::fs::remove_file(&csv_path).unwrap();
    let err = fails(&sweep(&[]));
    assert!(err.contains("--resume"), "{err}");
    let stdout = ok(&sweep(&["--resume"]));
    assert!(
        stdout.contains("8 cells to run (4 already done)"),
        "{stdout}"
    );
    let resumed = std::fs::read_to_string(&csv_path).unwrap();
    let strip_seconds = |s: &str| -> Vec<String> {
        s.lines()
            .map(|l| l.rsplit_once(',').unwrap().0.to_string())
            .collect()
    };
    assert_eq!(
        strip_seconds(&resumed),
        strip_seconds(&full),
        "same cells, same scores"
    );

    // A write cut short (full disk, kill) leaves a torn last line: the resume drops it and
    // runs that cell again instead of failing on it for ever.
    let torn = format!(
        "{}\n{}",
        partial.join("\n"),
        &full.lines().nth(5).unwrap()[..9]
    );
    std::fs::write(d.join("out/sweep.csv.partial"), torn).unwrap();
    std::fs::remove_file(&csv_path).unwrap();
    let resumed = sweep(&["--resume"]);
    let stdout = ok(&resumed);
    assert!(
        stdout.contains("8 cells to run (4 already done)"),
        "{stdout}"
    );
    assert!(String::from_utf8_lossy(&resumed.stderr).contains("cut short"));
    assert_eq!(
        strip_seconds(&std::fs::read_to_string(&csv_path).unwrap()),
        strip_seconds(&full)
    );

    let err = fails(&sweep(&["--n-slip", "0:x"]));
    assert!(err.contains("--n-slip"), "{err}");
}
