//! `tmo import csv` on real recordings from another lab (two Xela uSkin 4x4 taxel skins,
//! 16 elements in raw counts at about 60 Hz, the lab's own per-frame slip labels), then the
//! whole offline pipeline and replay on them.

mod common;

use std::path::{Path, PathBuf};

use common::{fails, ok, tmo};

fn fixture() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/xela/xela-4-trials.csv")
}

/// `tmo import csv FIXTURE --out xela --split-column split` with `extra` flags, in `d`.
fn import_fixture(d: &Path, extra: &[&str]) -> std::process::Output {
    let fixture = fixture();
    let mut args = vec![
        "import",
        "csv",
        fixture.to_str().unwrap(),
        "--out",
        "xela",
        "--split-column",
        "split",
    ];
    args.extend(extra);
    tmo(d, &args)
}

fn import(d: &Path) {
    let out = ok(&import_fixture(
        d,
        &["--units", "counts", "--sensor-name", "xela-uskin-4x4"],
    ));
    assert!(
        out.contains(
            "4 trial(s): 2 sensor(s) (as tmo numbers them: 0 = xela1, 1 = xela2) of 16 elements, counts"
        ),
        "{out}"
    );
    assert!(out.contains("3 trial log(s) in xela/train"), "{out}");
    assert!(out.contains("1 trial log(s) in xela/test"), "{out}");
}

/// Test-set macro F1 from `tmo evaluate`'s `overall` line.
fn macro_f1(evaluate_output: &str) -> f64 {
    let line = evaluate_output
        .lines()
        .find(|l| l.starts_with("overall"))
        .unwrap_or_else(|| panic!("{evaluate_output}"));
    line.split("macro F1 ").nth(1).unwrap()[..5]
        .parse()
        .unwrap()
}

/// A committed scikit-learn reference (`scripts/sklearn_grid_reference.py`) from the Xela
/// fixture's folder.
fn sklearn_reference(name: &str) -> serde_json::Value {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/xela")
        .join(name);
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// One axis of a reference's grid (its points' distinct values, in order), comma-separated.
fn grid_axis(reference: &serde_json::Value, axis: &str) -> String {
    let mut values = Vec::<f64>::new();
    for p in reference["points"].as_array().unwrap() {
        let v = p[axis].as_f64().unwrap();
        if !values.contains(&v) {
            values.push(v);
        }
    }
    let values: Vec<String> = values.iter().map(|v| v.to_string()).collect();
    values.join(",")
}

/// `tmo train TRIALS --search grid` over a reference's grid and folds, on the rows the
/// reference script read (`--n-slip 30 --downsample 1`), writing `out`.
fn grid_search(trials: &str, reference: &serde_json::Value, out: &str) -> Vec<String> {
    [
        "train",
        trials,
        "--n-slip",
        "30",
        "--downsample",
        "1",
        "--search",
        "grid",
        "--c-grid",
        &grid_axis(reference, "C"),
        "--gamma-grid",
        &grid_axis(reference, "gamma"),
        "--folds",
        &reference["folds"].to_string(),
        "--out",
        out,
    ]
    .map(str::to_string)
    .to_vec()
}

/// With `--fold-assignment group-k-fold`, every point of a grid search over all four trials
/// (three folds, so one fold holds two trials and the assignment matters) scores what
/// `GridSearchCV(cv=GroupKFold(3))` scores, to 1e-6 macro F1 (identical when written),
/// and the pick is scikit-learn's (its best beats the runner-up by 0.006). The
/// default, shuffled by the seed, splits the trials another way.
#[test]
fn group_k_fold_folds_score_every_grid_point_as_scikit_learn() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let fixture = fixture();
    ok(&tmo(
        d,
        &[
            "import",
            "csv",
            fixture.to_str().unwrap(),
            "--out",
            "all",
            "--units",
            "counts",
            "--sensor-name",
            "xela-uskin-4x4",
        ],
    ));
    let reference = sklearn_reference("sklearn_group_k_fold_reference.json");
    let train = |assignment: &str, out: &str| -> serde_json::Value {
        let grid = grid_search("all", &reference, out);
        let mut args: Vec<&str> = grid.iter().map(String::as_str).collect();
        args.extend(["--fold-assignment", assignment]);
        ok(&tmo(d, &args));
        serde_json::from_str(&std::fs::read_to_string(d.join(out)).unwrap()).unwrap()
    };
    let scores = |model: &serde_json::Value| -> Vec<f64> {
        let evaluations = model["search"]["evaluations"].as_array().unwrap();
        evaluations
            .iter()
            .map(|e| e["score"].as_f64().unwrap())
            .collect()
    };
    let expected: Vec<f64> = reference["points"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p["cv_macro_f1"].as_f64().unwrap())
        .collect();

    let model = train("group-k-fold", "gkf.json");
    let got = scores(&model);
    assert_eq!(got.len(), expected.len());
    for (i, (t, s)) in got.iter().zip(&expected).enumerate() {
        assert!(
            (t - s).abs() <= 1e-6,
            "point {i}: tmo {t}, scikit-learn {s}\n{got:?}\n{expected:?}"
        );
    }
    let best = &reference["best"];
    assert_eq!(model["hyperparameters"]["c"], best["C"], "{model}");
    assert_eq!(model["hyperparameters"]["gamma"], best["gamma"]);
    assert!(
        model["search"]["method"]
            .as_str()
            .unwrap()
            .ends_with("as GroupKFold"),
        "{}",
        model["search"]["method"]
    );

    let shuffled = scores(&train("shuffled", "shuffled.json"));
    assert!(
        shuffled
            .iter()
            .zip(&expected)
            .any(|(t, s)| (t - s).abs() > 0.01),
        "the seed's shuffle is another split: {shuffled:?}"
    );
}

/// `tmo train --search grid` on another lab's taxel data picks the point scikit-learn's
/// GridSearchCV picks over the same grid and folds (one training trial per fold, by
/// trial), and its model scores the test trial as scikit-learn's does, within 0.01 macro
/// F1. The reference is committed (`scripts/sklearn_grid_reference.py`, on these rows).
#[test]
fn a_grid_search_on_a_new_sensors_data_agrees_with_scikit_learns() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    import(d);
    let reference = sklearn_reference("sklearn_grid_reference.json");
    let grid = grid_search("xela/train", &reference, "grid.json");
    let said = ok(&tmo(
        d,
        &grid.iter().map(String::as_str).collect::<Vec<_>>(),
    ));
    let best = &reference["best"];
    let picked = said
        .lines()
        .find(|l| l.starts_with("grid:"))
        .unwrap_or_else(|| panic!("{said}"));
    let expected = format!(
        "C = {:.4}, gamma = {:.5}",
        best["C"].as_f64().unwrap(),
        best["gamma"].as_f64().unwrap()
    );
    assert!(
        picked.contains(&expected),
        "{picked}: scikit-learn picked {best}"
    );
    let tmo_f1 = macro_f1(&ok(&tmo(d, &["evaluate", "grid.json", "xela/test"])));
    let sklearn_f1 = reference["test_macro_f1"].as_f64().unwrap();
    assert!(
        (tmo_f1 - sklearn_f1).abs() <= 0.01,
        "test macro F1: tmo {tmo_f1}, scikit-learn {sklearn_f1}"
    );
}

#[test]
fn imported_taxel_recordings_train_evaluate_sweep_and_replay() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    import(d);

    // the training trials' rows, n_slip 30, with `extra` options
    let export = |out: &str, extra: &[&str]| {
        let mut args = vec![
            "dataset",
            "export",
            "xela/train",
            "--n-slip",
            "30",
            "--out",
            out,
        ];
        args.extend_from_slice(extra);
        ok(&tmo(d, &args));
        std::fs::read_to_string(d.join(out)).unwrap()
    };
    let csv = export("train.csv", &["--downsample", "1"]);
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    assert_eq!(header.iter().filter(|h| h.starts_with("dr_")).count(), 16);
    assert_eq!(
        header.iter().filter(|h| h.starts_with("dtheta_")).count(),
        16
    );
    let slip_rows = csv.lines().filter(|l| l.contains(",slip,")).count();
    assert_eq!(
        slip_rows,
        2 * 2 * 30,
        "two slipping trials, two sensors, n_slip 30"
    );
    // export keeps every frame unless told to down-sample (train's default is 0.4)
    assert_eq!(export("all.csv", &[]), csv);

    // The paper's balancing (static frames down-sampled to 0.1) and, for the RBF kernel, a
    // gamma for z-scored features of this width.
    let mut scores = Vec::new();
    for (classifier, extra) in [
        ("threshold", &[][..]),
        ("logreg", &[][..]),
        ("svm-linear", &[][..]),
        ("svm-rbf", &["--gamma", "0.02"][..]),
    ] {
        let model = format!("{classifier}.json");
        let mut args = vec![
            "train",
            "xela/train",
            "--classifier",
            classifier,
            "--n-slip",
            "30",
            "--downsample",
            "0.1",
            "--out",
            &model,
        ];
        args.extend_from_slice(extra);
        ok(&tmo(d, &args));
        let f1 = macro_f1(&ok(&tmo(d, &["evaluate", &model, "xela/test"])));
        scores.push((classifier, f1));
    }
    // Every classifier finds slip on the held-out trial (all-static scores 0.44 here).
    assert!(scores.iter().all(|s| s.1 > 0.6), "{scores:?}");

    // the grid's slip windows in seconds: 0.34 s and 0.51 s are 20 and 30 frames at 58.8 Hz
    let sweep = [
        "sweep",
        "xela/train",
        "--test",
        "xela/test",
        "--classifiers",
        "threshold,logreg",
        "--n-slip-s",
        "0.34,0.51",
        "--downsample",
        "0.1",
        "--out",
        "sweep.csv",
    ];
    let swept = tmo(d, &sweep);
    let out = ok(&swept);
    let said = String::from_utf8_lossy(&swept.stderr);
    assert!(said.contains("n_slip [20, 30] frames at 58.8 Hz"), "{said}");
    let rows = std::fs::read_to_string(d.join("sweep.csv")).unwrap();
    assert_eq!(rows.lines().count(), 1 + 2 * 2, "{out}\n{rows}");
    // --json: the same grid (finished, so resumed at once), its best cells as JSON alone
    let out = ok(&tmo(d, &[&sweep[..], &["--resume", "--json"]].concat()));
    let v: serde_json::Value = serde_json::from_str(&out).expect("stdout is JSON alone");
    assert_eq!(v["cells"], 4, "{v}");
    let best = v["best"].as_array().unwrap();
    assert_eq!(best.len(), 2, "{v}");
    assert!(
        best.iter()
            .all(|b| b["best_macro_f1"].as_f64().unwrap() > 0.0),
        "{v}"
    );
    assert!(
        best.iter().any(|b| b["c"].is_null()),
        "the threshold has no C: {v}"
    );

    let out = ok(&tmo(
        d,
        &[
            "replay",
            "xela/test",
            "--model",
            "svm-rbf.json",
            "--strategy",
            "1x1,2x2",
        ],
    ));
    assert!(out.contains("2 replays of 1 trial(s)"), "{out}");
    assert!(
        out.contains("| 1Fr1Sen |") && out.contains("| 2Fr2Sen |"),
        "{out}"
    );

    // the paper's figures of the imported trials, in the sensor's own units
    let out = ok(&tmo(
        d,
        &["report", "xela/train", "sweep.csv", "--plots", "figures"],
    ));
    assert!(out.contains("| threshold |"), "{out}");
    for figure in ["fig4a_pin_speed", "fig4b_pin_velocities", "fig5_f1_logreg"] {
        assert!(
            d.join(format!("figures/{figure}.png")).is_file(),
            "{figure}"
        );
    }
    let fig4a = std::fs::read_to_string(d.join("figures/fig4a_pin_speed.svg")).unwrap();
    assert!(
        fig4a.contains("counts per frame"),
        "fig4a's axis names the units"
    );

    // exported back as interchange CSV and imported again: the same feature rows
    let said = ok(&tmo(
        d,
        &[
            "dataset",
            "export",
            "xela/train",
            "--format",
            "interchange",
            "--out",
            "again.csv",
        ],
    ));
    assert!(
        said.contains("wrote 3 trial(s) as interchange CSV"),
        "{said}"
    );
    ok(&tmo(
        d,
        &[
            "import",
            "csv",
            "again.csv",
            "--out",
            "again",
            "--units",
            "counts",
        ],
    ));
    let rows = |dir: &str, out: &str| {
        let args = ["dataset", "export", dir, "--n-slip", "30", "--out", out];
        ok(&tmo(d, &args));
        std::fs::read_to_string(d.join(out)).unwrap()
    };
    assert_eq!(
        rows("again", "again-rows.csv"),
        rows("xela/train", "rows.csv")
    );
}

#[test]
fn a_model_of_sixteen_taxels_refuses_thirty_pin_trials() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    import(d);
    // the slip window in seconds: 0.5 s at the first trial's 58.8 Hz
    let trained = tmo(
        d,
        &[
            "train",
            "xela/train",
            "--classifier",
            "logreg",
            "--n-slip-s",
            "0.5",
            "--out",
            "xela.json",
        ],
    );
    ok(&trained);
    let said = String::from_utf8_lossy(&trained.stderr);
    assert!(said.contains("n_slip 29 frames at 58.8 Hz"), "{said}");
    let model = std::fs::read_to_string(d.join("xela.json")).unwrap();
    assert!(
        model.contains("\"units\": \"counts\""),
        "the model records its units"
    );
    ok(&tmo(
        d,
        &[
            "sim", "collect", "--rig", "rail", "--trials", "1", "--out", "rail",
        ],
    ));
    let e = fails(&tmo(d, &["evaluate", "xela.json", "rail"]));
    assert!(
        e.contains("elements (pins) per sensor is 30, the model's 16"),
        "{e}"
    );
    let e = fails(&tmo(
        d,
        &[
            "replay",
            "rail",
            "--model",
            "xela.json",
            "--strategy",
            "1x1",
        ],
    ));
    assert!(e.contains("30 pins each"), "{e}");
}

#[test]
fn a_bad_row_is_named_and_nothing_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let good = std::fs::read_to_string(fixture()).unwrap();
    // line 5000 of the file gets a taxel value that is not a number
    let mut lines: Vec<String> = good.lines().map(String::from).collect();
    let mut fields: Vec<&str> = lines[4999].split(',').collect();
    fields[5] = "16k";
    lines[4999] = fields.join(",");
    std::fs::write(d.join("bad.csv"), lines.join("\n") + "\n").unwrap();
    let e = fails(&tmo(
        d,
        &[
            "import",
            "csv",
            "bad.csv",
            "--out",
            "xela",
            "--split-column",
            "split",
        ],
    ));
    assert!(
        e.contains("bad.csv:5000:") && e.contains("column `x`: `16k` is not a finite number"),
        "{e}"
    );
    assert!(
        !d.join("xela").exists(),
        "nothing is written from a bad file"
    );
}

/// The fixture as another lab might hand it over: its own column names (`run`, `taxel`),
/// 1-based taxels, a trial name with a `/`, one trial logged at twice its sensor's update
/// rate (every reading twice) and one at two thirds of the others' rate.
fn foreign_variant() -> String {
    let good = std::fs::read_to_string(fixture()).unwrap();
    let mut lines = good.lines();
    let header = lines
        .next()
        .unwrap()
        .replace("trial,", "run,")
        .replace(",element,", ",taxel,");
    let mut out = vec![header];
    for line in lines {
        let mut f: Vec<String> = line.split(',').map(String::from).collect();
        f[4] = (f[4].parse::<u64>().unwrap() + 1).to_string();
        let (frame, t): (u64, f64) = (f[2].parse().unwrap(), f[3].parse().unwrap());
        match f[0].as_str() {
            "2022-02-21-17-22-56" => f[0] = "lab/2022-02-21-17-22-56".into(),
            "2022-02-22-08-10-01" => {
                // the logger saw each reading twice (0.1 ms apart: within the fixture's
                // own uneven intervals)
                f[2] = (2 * frame).to_string();
                out.push(f.join(","));
                f[2] = (2 * frame + 1).to_string();
                f[3] = format!("{:.5}", t + 0.0001);
            }
            "2022-02-22-15-15-00" => f[3] = format!("{:.5}", t * 1.5),
            _ => {}
        }
        out.push(f.join(","));
    }
    out.join("\n") + "\n"
}

#[test]
fn another_labs_file_imports_with_flags_only() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("theirs.csv"), foreign_variant()).unwrap();
    let import = |extra: &[&str]| {
        let mut args = vec![
            "import",
            "csv",
            "theirs.csv",
            "--out",
            "theirs",
            "--units",
            "counts",
            "--split-column",
            "split",
        ];
        args.extend_from_slice(extra);
        tmo(d, &args)
    };
    // each step of the way, the message names the flag that reads the file as it is
    // every missing column at once, with the one flag that maps them all
    let e = fails(&import(&[]));
    assert!(
        e.contains("no `trial` or `element` column")
            && e.contains("--columns trial=<its name>,element=<its name>"),
        "{e}"
    );
    let e = fails(&import(&[
        "--columns",
        "trial=run",
        "--columns",
        "element=taxel",
    ]));
    assert!(e.contains("look 1-based; pass --one-based"), "{e}");
    assert!(!d.join("theirs").exists());
    let e = fails(&import(&["--columns", "trial=run,element=tax"]));
    assert!(e.contains("--columns element=tax: no `tax` column"), "{e}");

    let flags = ["--columns", "trial=run,element=taxel", "--one-based"];
    // repeated readings are found before anything is written, with the commands to run
    let e = fails(&import(&flags));
    assert!(
        e.contains("repeat the previous frame's readings") && e.contains("nothing was written"),
        "{e}"
    );
    assert!(
        e.contains("tmo import csv theirs.csv --out theirs --units counts --split-column split --columns 'trial=run,element=taxel' --one-based --dedupe"),
        "{e}"
    );
    assert!(e.contains("--one-based --keep-repeats"), "{e}");
    assert!(!d.join("theirs").exists());
    let mut keeping = flags.to_vec();
    keeping.push("--keep-repeats");
    let first = import(&keeping);
    let (stdout, stderr) = (ok(&first), String::from_utf8_lossy(&first.stderr));
    assert!(stdout.contains("4 trial(s)"), "{stdout}");
    assert!(
        stderr.contains("repeat the previous frame's readings")
            && stderr.contains("kept as they are (--keep-repeats)"),
        "{stderr}"
    );
    assert!(
        stderr.contains("frame rates differ between the 4 trials"),
        "{stderr}"
    );
    assert!(
        stderr.contains("`lab/2022-02-21-17-22-56` -> lab_2022-02-21-17-22-56.mcap"),
        "{stderr}"
    );
    std::fs::remove_dir_all(d.join("theirs")).unwrap();

    let mut with_dedupe = flags.to_vec();
    with_dedupe.push("--dedupe");
    let second = import(&with_dedupe);
    let (stdout, stderr) = (ok(&second), String::from_utf8_lossy(&second.stderr));
    assert!(!stderr.contains("repeat the previous"), "{stderr}");
    assert!(
        stderr.contains("--dedupe dropped") && stderr.contains("in 4 of 4 trial(s)"),
        "{stderr}"
    );
    assert!(stdout.contains("Hz (median; "), "{stdout}");

    // the doubled trial, deduplicated, is the fixture's own trial deduplicated (the
    // fixture repeats some readings itself)
    let plain = tempfile::tempdir().unwrap();
    ok(&tmo(
        plain.path(),
        &[
            "import",
            "csv",
            fixture().to_str().unwrap(),
            "--out",
            "xela",
            "--split-column",
            "split",
            "--dedupe",
        ],
    ));
    let frames = |path: &Path| {
        let csv = d.join("one.csv");
        ok(&tmo(
            d,
            &[
                "dataset",
                "export",
                path.to_str().unwrap(),
                "--format",
                "interchange",
                "--out",
                csv.to_str().unwrap(),
            ],
        ));
        // sensor, frame, t_s, element, x, y
        std::fs::read_to_string(&csv)
            .unwrap()
            .lines()
            .skip(1)
            .map(|l| l.split(',').skip(1).take(6).collect::<Vec<_>>().join(","))
            .collect::<Vec<_>>()
    };
    let ours = frames(&plain.path().join("xela/train/2022-02-22-08-10-01.mcap"));
    let theirs = frames(&d.join("theirs/train/2022-02-22-08-10-01.mcap"));
    assert_eq!(ours.len(), theirs.len());
    assert_eq!(ours, theirs);

    // rates that differ between trials are said, not refused
    let trained = tmo(
        d,
        &[
            "train",
            "theirs/train",
            "--classifier",
            "logreg",
            "--n-slip",
            "30",
            "--out",
            "m.json",
        ],
    );
    ok(&trained);
    // said at import: not again on every later command, only with -v
    assert!(
        !String::from_utf8_lossy(&trained.stderr).contains("frame rates differ"),
        "{trained:?}"
    );
    let told = tmo(
        d,
        &[
            "-v",
            "train",
            "theirs/train",
            "--classifier",
            "logreg",
            "--n-slip",
            "30",
            "--out",
            "m2.json",
        ],
    );
    ok(&told);
    assert!(
        String::from_utf8_lossy(&told.stderr).contains("frame rates differ")
            && String::from_utf8_lossy(&told.stderr).contains("(as the import said)"),
        "{told:?}"
    );
}

/// Issue 41, I-d: a write that fails part way (here: the third trial's temporary path is
/// taken by a directory, as a full disk would fail it) leaves nothing imported, and the
/// message says to run the same command again (import has no --resume).
#[test]
fn an_import_that_cannot_finish_writing_leaves_nothing_and_says_run_again() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir_all(d.join("xela/train/2022-02-21-17-22-56.mcap.partial")).unwrap();
    let e = fails(&import_fixture(d, &[]));
    assert!(
        e.contains("nothing was imported")
            && e.contains("the 2 log(s) written before it were removed")
            && e.contains("run the same command again"),
        "{e}"
    );
    assert!(!e.contains("--resume"), "{e}");
    let logs: Vec<_> = walk_mcap(&d.join("xela"));
    assert!(logs.is_empty(), "{logs:?}");
}

fn walk_mcap(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir(dir).into_iter().flatten().flatten() {
        let p = entry.path();
        if p.is_dir() {
            out.extend(walk_mcap(&p));
        } else if p.extension().is_some_and(|x| x == "mcap") {
            out.push(p);
        }
    }
    out
}
