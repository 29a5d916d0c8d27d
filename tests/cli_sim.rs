//! Runs the real `tmo` binary on the simulator in a fresh directory per test.

mod common;

use std::path::Path;

use common::*;

fn read_csv(path: &Path) -> (Vec<String>, Vec<Vec<String>>) {
    let mut r = csv::Reader::from_path(path).unwrap();
    let head = r.headers().unwrap().iter().map(String::from).collect();
    let rows = r
        .records()
        .map(|x| x.unwrap().iter().map(String::from).collect())
        .collect();
    (head, rows)
}

#[test]
fn trace_of_a_release_shows_the_slip_in_truth_markers_and_pins() {
    let dir = tempfile::tempdir().unwrap();
    let out = tmo(
        dir.path(),
        &[
            "sim",
            "trace",
            "--scenario",
            "release",
            "--seed",
            "4",
            "--duration",
            "6",
            "--out",
            "t",
        ],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("wrote") && stdout.contains("truth.csv"),
        "{stdout}"
    );

    let (head, truth) = read_csv(&dir.path().join("t/truth.csv"));
    let col = |name: &str| head.iter().position(|h| h == name).unwrap();
    // the release takes up the fingers' free play (2 s at 1 % of range per second) first
    assert_eq!(truth.len(), 6000);
    let sliding = truth
        .iter()
        .position(|r| r[col("sliding")] == "1")
        .expect("the object slips");
    assert!(sliding > 100, "slipped at tick {sliding}");

    let (_, markers) = read_csv(&dir.path().join("t/markers.csv"));
    assert!((markers.len() as i64 - 360).abs() <= 1);
    let first: f64 = markers[0][1].parse().unwrap();
    let last: f64 = markers.last().unwrap()[1].parse().unwrap();
    assert!(
        first - last > 50.0,
        "marker did not see the fall: {first} -> {last}"
    );

    let (head, pins) = read_csv(&dir.path().join("t/pins.csv"));
    assert_eq!(head.len(), 3 + 60);
    assert!(pins.len() > 3 * 350);
    assert!(dir.path().join("t/sim.toml").exists());
}

#[test]
fn same_seed_same_trace() {
    let dir = tempfile::tempdir().unwrap();
    for out in ["a", "b"] {
        let o = tmo(
            dir.path(),
            &[
                "sim",
                "trace",
                "--scenario",
                "rail",
                "--seed",
                "9",
                "--duration",
                "2",
                "--out",
                out,
            ],
        );
        assert!(o.status.success());
    }
    let a = std::fs::read(dir.path().join("a/pins.csv")).unwrap();
    let b = std::fs::read(dir.path().join("b/pins.csv")).unwrap();
    assert_eq!(a, b);
}

#[test]
fn every_scenario_runs() {
    let dir = tempfile::tempdir().unwrap();
    for s in ["drop", "hold", "release", "rail", "lift", "pour"] {
        let o = tmo(
            dir.path(),
            &[
                "sim",
                "trace",
                "--scenario",
                s,
                "--duration",
                "1",
                "--out",
                s,
            ],
        );
        assert!(
            o.status.success(),
            "{s}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
    }
}

#[test]
fn unknown_object_is_an_error_naming_the_choices() {
    let dir = tempfile::tempdir().unwrap();
    let o = tmo(
        dir.path(),
        &["sim", "trace", "--scenario", "hold", "--object", "teapot"],
    );
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("teapot") && err.contains("soup_can"), "{err}");
}

#[test]
fn bad_config_names_the_file_line_and_field() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("sim.toml"),
        "seed = 1\n[tactip]\nnoise_pixels = 0.1\n",
    )
    .unwrap();
    let o = tmo(
        dir.path(),
        &["sim", "trace", "--scenario", "hold", "--config", "sim.toml"],
    );
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("sim.toml") && err.contains("line 3") && err.contains("noise_pixels"),
        "{err}"
    );

    std::fs::write(
        dir.path().join("neg.toml"),
        "[physics]\nskin_modulus_kpa = -1.0\n",
    )
    .unwrap();
    let o = tmo(
        dir.path(),
        &["sim", "trace", "--scenario", "hold", "--config", "neg.toml"],
    );
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("neg.toml") && err.contains("skin_modulus_kpa") && err.contains("positive"),
        "{err}"
    );
}

#[test]
fn quiet_says_only_results_verbose_says_each_trial_and_color_is_as_asked() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let collect = |flag: &str, out: &str| {
        let o = tmo(
            d,
            &[
                flag,
                "sim",
                "collect",
                "--objects",
                "crisps_can",
                "--trials",
                "2",
                "--seed",
                "5",
                "--out",
                out,
            ],
        );
        let said = ok(&o);
        (said, String::from_utf8_lossy(&o.stderr).into_owned())
    };
    let (said, noted) = collect("-q", "quiet");
    assert!(said.contains("2 trials (2 run, 0 already there)"), "{said}");
    assert_eq!(noted, "", "-q says nothing on standard error");
    let (said, noted) = collect("-v", "verbose");
    assert!(said.contains("2 trials (2 run, 0 already there)"), "{said}");
    let lines: Vec<&str> = noted.lines().collect();
    assert_eq!(lines.len(), 2, "{noted}");
    assert!(lines[0].starts_with("trial-00000: ") && lines[1].starts_with("trial-00001: "));
    // the same trials either way: -v only says more
    for i in 0..2 {
        let name = format!("trial-{i:05}.mcap");
        let a = tmo::trial::read_trial(&d.join("quiet").join(&name)).unwrap();
        let b = tmo::trial::read_trial(&d.join("verbose").join(&name)).unwrap();
        assert_eq!(a.frames, b.frames);
    }

    let error = |color: &str| {
        let o = tmo(d, &["--color", color, "sim", "bogus"]);
        fails(&o)
    };
    assert!(error("always").contains('\x1b'), "{}", error("always"));
    assert!(!error("never").contains('\x1b'), "{}", error("never"));
}

/// `tmo sim collect` is the collect preset over the protocol runner: `tmo run` on the
/// protocol it wrote, with the same seed, records the very same trials.
#[test]
fn a_collection_is_the_protocol_tmo_run_runs() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    ok(&tmo(
        d,
        &[
            "sim", "collect", "--rig", "rail", "--trials", "2", "--seed", "4", "--out", "a",
        ],
    ));
    let protocol = std::fs::read_to_string(d.join("a/protocol.toml")).unwrap();
    assert!(protocol.contains("mode = \"collect\""), "{protocol}");
    ok(&tmo(d, &["run", "a/protocol.toml", "--out", "b"]));
    for i in 0..2 {
        let name = format!("trial-{i:05}.mcap");
        let a = tmo::trial::read_trial(&d.join("a").join(&name)).unwrap();
        let b = tmo::trial::read_trial(&d.join("b").join(&name)).unwrap();
        assert_eq!(a.meta.seed, b.meta.seed);
        assert_eq!(a.meta.kind, "rail_catch_collect");
        // the object's length travels with the trial (the labels read it from there)
        let library = tmo_sim::ObjectLibrary::built_in();
        let length = library.get("rail_object").unwrap().length_mm;
        assert_eq!(a.meta.object_length_mm(), Some(length));
        assert_eq!(a.frames, b.frames);
        assert_eq!(a.markers, b.markers);
        assert_eq!(a.events, b.events);
    }
}
