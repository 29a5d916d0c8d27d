//! `tmo report`: golden tables from a fixed small batch, every figure from simulator
//! batches, and clear errors for inputs it cannot read.

mod common;

use std::path::{Path, PathBuf};

use common::*;

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/report")
}

fn golden(name: &str) -> String {
    std::fs::read_to_string(fixtures().join(name)).unwrap()
}

/// The fixture batches hold hand-written outcome rows (one aborted trial among them); the
/// expected files were checked by hand (Wilson intervals against R's `prop.test` without
/// continuity correction, means and sample sds by hand).
#[test]
fn a_fixed_batch_gives_the_expected_markdown_and_csv() {
    let d = fixtures();
    let md = ok(&tmo(&d, &["report", "hand", "rail"]));
    assert_eq!(md, golden("expected.md"));
    // CSV on standard output is one table (issue 42): several are refused with their
    // names, and --table picks each, which is its section of the golden file
    let e = fails(&tmo(&d, &["report", "hand", "rail", "--format", "csv"]));
    assert!(
        e.contains("--table NAME") && e.contains("hand_online"),
        "{e}"
    );
    let golden_csv = golden("expected.csv");
    let sections: Vec<&str> = golden_csv.split("\n\n").collect();
    assert!(sections.len() > 1);
    for section in sections {
        let (name, table) = section
            .strip_prefix("# ")
            .unwrap()
            .split_once('\n')
            .unwrap();
        let csv = ok(&tmo(
            &d,
            &["report", "hand", "rail", "--format", "csv", "--table", name],
        ));
        assert_eq!(csv.trim_end(), table.trim_end(), "{name}");
    }
    let e = fails(&tmo(&d, &["report", "hand", "--table", "nope"]));
    assert!(e.contains("no such table"), "{e}");
    let json = ok(&tmo(&d, &["report", "hand", "rail", "--format", "json"]));
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    // the two objects' batches are kept apart (T4-7): the crisps can's own totals
    let can = &v["hand_online"]["rows"][6];
    assert_eq!(can[0], "crisps_can: all", "{can}");
    assert_eq!(can[3]["count"], 2);
    assert_eq!(can[3]["trials"], 4);
}

#[test]
fn out_writes_one_file_per_table() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("tables");
    let o = tmo(
        &fixtures(),
        &[
            "report",
            "hand",
            "rail",
            "--format",
            "csv",
            "--out",
            out.to_str().unwrap(),
        ],
    );
    ok(&o);
    // each file is plain CSV (the file names the table), its first line the header, as
    // `pandas.read_csv` expects; the same rows as the table's section of the golden file
    let all = golden("expected.csv");
    for name in ["rail_catch", "hand_online", "hand_objects"] {
        let text = std::fs::read_to_string(out.join(format!("{name}.csv"))).unwrap();
        assert!(!text.starts_with('#'), "{text}");
        assert!(all.contains(&format!("# {name}\n{text}")), "{name}");
        let mut r = csv::Reader::from_reader(text.as_bytes());
        let width = r.headers().unwrap().len();
        assert!(r.records().all(|rec| rec.unwrap().len() == width));
    }
    assert!(String::from_utf8_lossy(&o.stderr).contains("hand_online.csv"));
}

#[test]
fn inputs_it_cannot_read_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir(d.join("empty")).unwrap();
    let e = fails(&tmo(d, &["report", "empty"]));
    assert!(e.contains("empty: expected a batch directory"), "{e}");
    std::fs::create_dir(d.join("half")).unwrap();
    std::fs::write(d.join("half/batch.json"), "{\"kind\": 3}").unwrap();
    let e = fails(&tmo(d, &["report", "half"]));
    assert!(e.contains("batch.json: line 1"), "{e}");
    let e = fails(&tmo(d, &["report", "gone"]));
    assert!(e.contains("gone: cannot read"), "{e}");
}

fn png_size(path: &Path) -> (u32, u32) {
    let b = std::fs::read(path).unwrap();
    assert_eq!(&b[1..4], b"PNG", "{}", path.display());
    let be = |i: usize| u32::from_be_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]]);
    (be(16), be(20))
}

/// Every figure from short simulator batches: collected trials (Fig. 4a, 4b), a sweep
/// (Fig. 5, drawn by `tmo sweep` itself), online hand releases (bars, box plots) and a
/// first-time lift with calibration (Fig. 12, 13).
#[test]
fn every_figure_is_drawn_from_simulator_batches() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let run = |args: &[&str]| ok(&tmo(d, args));
    collect_and_train(d, &["--trials", "5", "--seed", "8"], "train", "global.json");
    run(&[
        "sweep",
        "train",
        "--classifiers",
        "logreg,threshold",
        "--n-slip",
        "2:3",
        "--downsample",
        "0.5:1.0:0.5",
        "--out",
        "sweep/sweep.csv",
    ]);
    run(&[
        "train",
        "train",
        "--classifier",
        "threshold",
        "--out",
        "threshold.json",
    ]);
    std::fs::write(
        d.join("hand.toml"),
        "kind = \"hand_release\"\nobjects = [\"crisps_can\"]\nmodels = [\"global.json\"]\nstrategies = [\"1x1\", \"2x2\"]\nrepetitions = 2\n",
    )
    .unwrap();
    run(&["run", "hand.toml", "--out", "hand"]);
    std::fs::write(
        d.join("cal.toml"),
        "kind = \"calibrate_lift\"\n[calibrate_lift]\nmasses_g = [0, 450]\n",
    )
    .unwrap();
    run(&["run", "cal.toml", "--out", "cal"]);
    std::fs::write(
        d.join("lift.toml"),
        "kind = \"first_time_lift\"\nmodels = [\"global.json\"]\nrepetitions = 2\n[first_time_lift]\nmasses_g = [0, 450]\ncalibration = \"cal/g_min.json\"\n",
    )
    .unwrap();
    run(&["run", "lift.toml", "--out", "lift"]);
    run(&["evaluate", "global.json", "train", "--out", "eval.json"]);

    let md = run(&[
        "report",
        "train",
        "threshold.json",
        "sweep",
        "eval.json",
        "hand",
        "cal",
        "lift",
        "--plots",
        "plots",
    ]);
    for title in [
        "Offline: test macro F1",
        "Offline: models on test trials",
        "Whole hand: online release",
        "Whole hand: per object",
        "calibration of g_min",
        "### First-time lift",
    ] {
        assert!(md.contains(title), "{title} missing:\n{md}");
    }
    for stem in [
        "fig4a_pin_speed",
        "fig4b_pin_velocities",
        "fig5_f1_logreg",
        "fig5_f1_threshold",
        "fig7_hand_outcomes",
        "fig8_hand_slip_distance",
        "fig12_lift_heights",
        "fig13_lift_by_mass_crisps_can_empty",
    ] {
        let svg = std::fs::read_to_string(d.join(format!("plots/{stem}.svg"))).unwrap();
        assert!(
            svg.contains("<svg") && svg.contains("<text"),
            "{stem}.svg has no text"
        );
        assert!(
            svg.contains("font-family=\"DejaVu Sans, sans-serif\""),
            "{stem}.svg names the bundled font"
        );
        let (w, h) = png_size(&d.join(format!("plots/{stem}.png")));
        assert!(w >= 800 && h >= 500, "{stem}.png is {w}x{h}");
        let png = std::fs::read(d.join(format!("plots/{stem}.png"))).unwrap();
        assert!(
            png.windows(4).any(|w| w == b"pHYs"),
            "{stem}.png states its DPI"
        );
        let pdf = std::fs::read(d.join(format!("plots/{stem}.pdf"))).unwrap();
        assert!(
            pdf.starts_with(b"%PDF-") && pdf.windows(8).any(|w| w == b"FontFile"),
            "{stem}.pdf is a PDF with its font embedded"
        );
    }
    assert!(
        d.join("sweep/sweep_fig5_f1_logreg.png").is_file(),
        "tmo sweep draws Fig. 5 itself"
    );
}

/// A copy of a fixture batch under `d`, its `outcomes.json` (or `batch.json`) edited.
fn edited_batch(d: &Path, name: &str, file: &str, edit: impl Fn(&mut serde_json::Value)) {
    let to = d.join(name);
    std::fs::create_dir_all(&to).unwrap();
    for f in ["batch.json", "outcomes.json"] {
        std::fs::copy(fixtures().join(name).join(f), to.join(f)).unwrap();
    }
    let path = to.join(file);
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    edit(&mut v);
    std::fs::write(&path, v.to_string()).unwrap();
}

/// Rows that would count a trial twice, or that no trial of the batch made, are refused
/// (issue 41, R-a, R-b, R-c, R-d).
#[test]
fn rows_that_are_not_the_batchs_trials_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // R-a: rows repeated
    edited_batch(d, "hand", "outcomes.json", |v| {
        let rows = v.as_array().unwrap().clone();
        v.as_array_mut().unwrap().extend(rows);
    });
    let e = fails(&tmo(d, &["report", "hand"]));
    assert!(e.contains("outcomes.json") && e.contains("again"), "{e}");
    // R-d: a batch.json that names no trials, with rows
    edited_batch(d, "hand", "batch.json", |v| {
        v["trials"] = serde_json::json!([])
    });
    let e = fails(&tmo(d, &["report", "hand"]));
    assert!(e.contains("is not one of the 0 trials"), "{e}");
    // R-d: a negative time, a latency that is not reaction - onset
    edited_batch(d, "hand", "outcomes.json", |v| {
        v[0]["onset_s"] = (-3.0).into()
    });
    let e = fails(&tmo(d, &["report", "hand"]));
    assert!(e.contains("row 1: `onset_s` = -3"), "{e}");
    edited_batch(d, "hand", "outcomes.json", |v| {
        v[0]["latency_s"] = 7.0.into()
    });
    let e = fails(&tmo(d, &["report", "hand"]));
    assert!(e.contains("`latency_s` = 7"), "{e}");
    // R-c: hand-release rows under a batch.json that says rail catch
    edited_batch(d, "hand", "batch.json", |v| v["kind"] = "rail_catch".into());
    let e = fails(&tmo(d, &["report", "hand"]));
    assert!(e.contains("not a rail strategy"), "{e}");
    // R-b: the same batch twice, or a copy of it
    let e = fails(&tmo(&fixtures(), &["report", "rail", "rail"]));
    assert!(e.contains("given again"), "{e}");
    edited_batch(d, "rail", "batch.json", |_| {});
    let copy = d.join("rail");
    let e = fails(&tmo(
        &fixtures(),
        &["report", "rail", copy.to_str().unwrap()],
    ));
    assert!(e.contains("given again"), "{e}");
    // R-d: an evaluation of a classifier tmo does not have
    let eval = d.join("eval.json");
    std::fs::write(
        &eval,
        serde_json::json!({
            "format": tmo::slip::evaluation::EVALUATION_FORMAT, "model": "m.json",
            "model_sha256": "0", "classifier": "bogus", "scope": "global", "n_slip": 5,
            "trials": 1, "rows": 10,
            "overall": tmo::slip::metrics::Scores::default(), "per_sensor": []
        })
        .to_string(),
    )
    .unwrap();
    let e = fails(&tmo(d, &["report", "eval.json"]));
    assert!(
        e.contains("eval.json") && e.contains("\"bogus\"") && e.contains("svm-rbf"),
        "{e}"
    );
}

/// Issue 42: `--out -` is standard output where a command writes one file, and refused
/// (not a file named `-`) where it writes a directory or several files.
#[test]
fn out_dash_is_standard_output_or_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let e = fails(&tmo(d, &["report", "x", "--out", "-"]));
    assert!(
        e.contains("standard output") && e.contains("give a path"),
        "{e}"
    );
    let e = fails(&tmo(d, &["sim", "collect", "--out", "-"]));
    assert!(e.contains("give a path"), "{e}");
    assert!(!d.join("-").exists());
    collect_and_train(d, &["--trials", "5", "--seed", "3"], "t", "m.json");
    let out = tmo(d, &["dataset", "export", "t", "--out", "-"]);
    let csv = ok(&out);
    assert!(
        csv.starts_with("trial_id,sensor,seq,time_s,label,dr_0"),
        "{csv}"
    );
    assert!(String::from_utf8_lossy(&out.stderr).contains("to standard output"));
    let exported = tmo(
        d,
        &[
            "dataset",
            "export",
            "t",
            "--format",
            "interchange",
            "--out",
            "-",
        ],
    );
    assert!(ok(&exported).starts_with("trial,sensor,frame,t_s,element,x,y,onset_s"));
    let json = ok(&tmo(d, &["evaluate", "m.json", "t", "--out", "-"]));
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert!(v["overall"]["macro_f1"].is_number(), "{v}");
    assert!(!d.join("-").exists());
}
