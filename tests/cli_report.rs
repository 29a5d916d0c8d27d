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
    let csv = ok(&tmo(&d, &["report", "hand", "rail", "--format", "csv"]));
    assert_eq!(csv, golden("expected.csv"));
    let json = ok(&tmo(&d, &["report", "hand", "rail", "--format", "json"]));
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    let overall = &v["hand_online"]["rows"][5];
    assert_eq!(overall[3]["count"], 3);
    assert_eq!(overall[3]["trials"], 6);
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
    // `pandas.read_csv` expects; the same rows as the table's block on standard output
    let all = String::from_utf8_lossy(&o.stdout).to_string();
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
/// first-time lift with calibration (Fig. 9, 10).
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
        "hand_outcomes",
        "hand_slip_distance",
        "fig9_lift_heights",
        "fig10_lift_by_mass_crisps_can_empty",
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
