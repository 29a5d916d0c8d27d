//! Inputs at and past their limits end with a clear error (exit 2), never a panic, an abort
//! or a hang; a closed stdout ends tmo quietly.

mod common;

use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::*;

#[test]
fn a_search_with_fewer_than_two_folds_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    ok(&tmo(
        d,
        &[
            "sim",
            "collect",
            "--objects",
            "crisps_can",
            "--trials",
            "3",
            "--out",
            "t",
        ],
    ));
    for folds in ["0", "1"] {
        let err = fails(&tmo(
            d,
            &[
                "train",
                "t",
                "--classifier",
                "logreg",
                "--search",
                "bayes",
                "--iters",
                "3",
                "--folds",
                folds,
                "--out",
                "m.json",
            ],
        ));
        assert!(
            err.contains(&format!("--folds {folds}: expected at least 2")),
            "{err}"
        );
        assert!(!err.contains("panicked"), "{err}");
    }
}

#[test]
fn train_checks_where_the_model_goes_before_training() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    ok(&tmo(
        d,
        &[
            "sim",
            "collect",
            "--objects",
            "crisps_can",
            "--trials",
            "3",
            "--out",
            "t",
        ],
    ));
    std::fs::create_dir(d.join("models")).unwrap();
    // a folder as --out is refused at once (before the fit, not after it)
    let err = fails(&tmo(
        d,
        &["train", "t", "--classifier", "logreg", "--out", "models"],
    ));
    assert!(
        err.contains("is a folder; expected the output file's path"),
        "{err}"
    );
    assert!(!d.join("models.json.partial").exists());
    // a missing parent folder is made; the output says what the scores are on
    let out = ok(&tmo(
        d,
        &[
            "train",
            "t",
            "--classifier",
            "logreg",
            "--out",
            "new/dir/m.json",
        ],
    ));
    assert!(d.join("new/dir/m.json").is_file());
    assert!(
        out.contains("fitted") && out.contains("scores on the fitted rows (training data"),
        "{out}"
    );
    // and before them a held-out score, labelled as one
    assert!(
        out.contains("held-out scores, cross-validated by trial (3 folds"),
        "{out}"
    );
}

#[test]
fn a_collection_never_adds_to_another_collections_directory() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let rail = [
        "sim", "collect", "--rig", "rail", "--trials", "2", "--out", "t",
    ];
    ok(&tmo(d, &rail));
    let before: Vec<_> = std::fs::read_dir(d.join("t")).unwrap().collect();
    for args in [
        vec!["--objects", "crisps_can", "--trials", "2"],
        vec!["--rig", "rail", "--trials", "2", "--seed", "9"],
        vec!["--rig", "rail", "--trials", "3"],
    ] {
        let mut all = vec!["sim", "collect", "--out", "t"];
        all.extend(args);
        let err = fails(&tmo(d, &all));
        assert!(
            err.contains("already holds another collection")
                && err.contains("protocol.toml differs"),
            "{err}"
        );
    }
    assert_eq!(
        std::fs::read_dir(d.join("t")).unwrap().count(),
        before.len()
    );
    // the same collection, interrupted, finishes what is missing
    std::fs::remove_file(d.join("t/trial-00001.mcap")).unwrap();
    let out = ok(&tmo(d, &rail));
    assert!(out.contains("2 trials (1 run, 1 already there)"), "{out}");
}

#[test]
fn a_search_range_that_is_not_one_is_refused_naming_the_option() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (option, range) in [
        ("--c-range", "5:1"),
        ("--gamma-range", "0:1"),
        ("--c-range", "1:1e308"),
    ] {
        for command in ["train", "sweep"] {
            let err = fails(&tmo(
                d,
                &[
                    command, "t", "--search", "bayes", option, range, "--out", "m.json",
                ],
            ));
            assert!(
                err.contains(option)
                    && err.contains("expected LOW:HIGH with 0.000001 <= LOW < HIGH <= 1000000"),
                "{command} {option} {range}: {err}"
            );
        }
    }
    // a grid point beyond what a fit can search, refused at once (C 1e308 once ran for minutes)
    let err = fails(&tmo(
        d,
        &[
            "train", "t", "--search", "grid", "--c-grid", "1,1e308", "--out", "m.json",
        ],
    ));
    assert!(
        err.contains("--c-grid")
            && err.contains("expected numbers in 0.000001..=1000000")
            && err.contains("\"1e308\""),
        "{err}"
    );
    // a gamma axis nothing reads is refused rather than ignored
    for (extra, why) in [
        (
            &["--search", "grid", "--classifier", "svm-linear"][..],
            "the svm-linear classifier has no gamma",
        ),
        (
            &["--search", "bayes"][..],
            "--gamma-grid is the gamma axis of --search grid",
        ),
    ] {
        let mut args = vec!["train", "t", "--gamma-grid", "0.1,1", "--out", "m.json"];
        args.extend_from_slice(extra);
        let err = fails(&tmo(d, &args));
        assert!(err.contains(why), "{extra:?}: {err}");
    }
}

#[test]
fn serving_for_a_time_that_is_not_one_is_refused_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let hw = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("hardware/tmo.toml");
    for bad in ["nan", "1e20", "-1", "inf", "soon"] {
        let started = Instant::now();
        let arg = format!("--for={bad}");
        let err = fails(&tmo(
            dir.path(),
            &["sim", "serve", "--hardware", hw.to_str().unwrap(), &arg],
        ));
        assert!(err.contains("--for"), "{bad}: {err}");
        assert!(!err.contains("panicked"), "{bad}: {err}");
        assert!(started.elapsed() < Duration::from_secs(20), "{bad}");
    }
}

#[test]
fn a_batch_too_large_to_list_is_refused_before_it_starts() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("c.toml"),
        "kind = \"hand_release\"\nmode = \"collect\"\n[hand_release]\nlift_mm = 120\n",
    )
    .unwrap();
    let started = Instant::now();
    let err = fails(&tmo(d, &["run", "c.toml", "--repeat", "4294967295"]));
    assert!(err.contains("at most 1000000"), "{err}");
    assert!(started.elapsed() < Duration::from_secs(20));
    assert!(!d.join("results/c").exists(), "nothing was started");
}

#[test]
fn a_closed_stdout_ends_tmo_quietly() {
    use std::os::fd::FromRawFd;
    use std::os::unix::process::ExitStatusExt;
    let mut fds = [0; 2];
    // SAFETY: a plain pipe(2); both ends are owned below.
    assert_eq!(unsafe { libc::pipe(fds.as_mut_ptr()) }, 0);
    // SAFETY: fds[0] and fds[1] were just opened and are owned by nothing else.
    let (read_end, write_end) = unsafe {
        (
            std::fs::File::from_raw_fd(fds[0]),
            std::fs::File::from_raw_fd(fds[1]),
        )
    };
    // The reader is gone before tmo writes: its first line meets a broken pipe.
    drop(read_end);
    let dir = tempfile::tempdir().unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_tmo"))
        .current_dir(dir.path())
        .args(["sim", "objects"])
        .stdout(Stdio::from(write_end))
        .stderr(Stdio::piped())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_ne!(out.status.code(), Some(101), "{stderr}");
    assert_eq!(out.status.signal(), Some(libc::SIGPIPE), "{:?}", out.status);
}

#[test]
fn protocols_and_collections_refuse_what_their_rig_cannot_do() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cases = [
        (
            "kind = \"rail_catch\"\nmode = \"collect\"\nobjects = [\"banana\"]\n",
            "objects.0",
        ),
        (
            "kind = \"hand_release\"\nmode = \"collect\"\nobjects = [\"rail_object\"]\n[hand_release]\nlift_mm = 120\n",
            "objects.0",
        ),
        (
            "kind = \"hand_release\"\nmode = \"collect\"\nstrategies = [\"abc\"]\n[hand_release]\nlift_mm = 120\n",
            "strategies",
        ),
        (
            "kind = \"calibrate_lift\"\nstrategies = [\"0x1\"]\n",
            "strategies",
        ),
    ];
    for (text, field) in cases {
        std::fs::write(d.join("p.toml"), text).unwrap();
        let err = fails(&tmo(d, &["run", "p.toml"]));
        assert!(err.contains(field), "{text}\n{err}");
    }
    let err = fails(&tmo(
        d,
        &[
            "sim",
            "collect",
            "--rig",
            "rail",
            "--objects",
            "banana",
            "--trials",
            "1",
        ],
    ));
    assert!(err.contains("--objects"), "{err}");
    let err = fails(&tmo(
        d,
        &["sim", "collect", "--grasps", "nan", "--trials", "1"],
    ));
    assert!(err.contains("--grasps"), "{err}");
}

#[test]
fn a_replay_of_nothing_readable_is_an_error_not_a_skip() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("m.json"),
        serde_json::to_string(&{
            let mut m = tmo::slip::model::ModelFile::threshold_model(30, vec![0, 1, 2], 0.3);
            m.training_trials = vec![tmo::slip::model::TrialRef {
                trial_id: "t0".into(),
                path: "t0.mcap".into(),
                sha256: "0".repeat(64),
            }];
            m
        })
        .unwrap(),
    )
    .unwrap();
    let err = fails(&tmo(d, &["replay", "no_such_dir", "--model", "m.json"]));
    assert!(err.contains("no_such_dir"), "{err}");
    std::fs::write(d.join("bad.mcap"), "not a log").unwrap();
    let err = fails(&tmo(d, &["replay", "bad.mcap", "--model", "m.json"]));
    assert!(err.contains("could be read"), "{err}");
}

/// Runs `tmo args` in `dir`, killing it if it has not finished in 30 s (a hang fails).
fn tmo_within(dir: &std::path::Path, args: &[&str]) -> std::process::Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_tmo"))
        .current_dir(dir)
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let started = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if started.elapsed() > Duration::from_secs(30) {
            child.kill().unwrap();
            panic!("tmo {args:?} still running after 30 s");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().unwrap()
}

#[test]
fn numbers_a_report_cannot_show_are_refused_naming_the_row_and_field() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let fixture =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/report/hand");
    for (bad, field) in [("1e308", "slip_distance_mm"), ("-3.0", "slip_distance_mm")] {
        let batch = d.join(format!("hand{bad}"));
        std::fs::create_dir_all(&batch).unwrap();
        std::fs::copy(fixture.join("batch.json"), batch.join("batch.json")).unwrap();
        let text = std::fs::read_to_string(fixture.join("outcomes.json"))
            .unwrap()
            .replacen(
                "\"slip_distance_mm\": 4.0",
                &format!("\"slip_distance_mm\": {bad}"),
                1,
            );
        std::fs::write(batch.join("outcomes.json"), text).unwrap();
        let out = tmo_within(d, &["report", batch.to_str().unwrap(), "--plots", "p"]);
        let err = fails(&out);
        assert!(err.contains("row 1") && err.contains(field), "{err}");
    }
    let header = "classifier,scope,n_slip,downsample,c,gamma,cv_macro_f1,train_rows,train_slip_rows,test_rows,macro_f1,slip_precision,slip_recall,slip_f1,static_precision,static_recall,static_f1,true_slip,false_slip,true_static,false_static,seconds";
    for (row, field) in [
        (
            "svm-rbf,global,5,0.400,1,0.02,,10,5,10,NaN,1,1,1,1,1,1,1,0,1,0,0.1",
            "macro_f1",
        ),
        (
            "svm-rbf,global,5,0.400,1,0.02,,10,5,10,inf,1,1,1,1,1,1,1,0,1,0,0.1",
            "macro_f1",
        ),
        (
            "svm-rbf,global,5,nan,1,0.02,,10,5,10,0.9,1,1,1,1,1,1,1,0,1,0,0.1",
            "downsample",
        ),
    ] {
        std::fs::write(d.join("sweep.csv"), format!("{header}\n{row}\n")).unwrap();
        let out = tmo_within(d, &["report", "sweep.csv", "--plots", "p"]);
        let err = fails(&out);
        assert!(err.contains("row 1") && err.contains(field), "{err}");
    }
    // a good row still reports
    std::fs::write(
        d.join("sweep.csv"),
        format!("{header}\nsvm-rbf,global,5,0.400,1,0.02,,10,5,10,0.9,1,1,1,1,1,1,1,0,1,0,0.1\n"),
    )
    .unwrap();
    ok(&tmo_within(d, &["report", "sweep.csv", "--plots", "p"]));
}

#[test]
fn fixed_size_arrays_with_more_or_fewer_values_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (text, field, why) in [
        (
            "kind = \"rail_catch\"\nmode = \"collect\"\n[rail_catch]\nretract_speed_mm_s = [0.1, 5.0, \"garbage\", {x=1}]\n",
            "retract_speed_mm_s",
            "expected f64",
        ),
        (
            "kind = \"rail_catch\"\nmode = \"collect\"\n[rail_catch]\nretract_speed_mm_s = [0.1, 5.0, 7.0]\n",
            "retract_speed_mm_s",
            "exactly 2 values",
        ),
        (
            "kind = \"rail_catch\"\nmode = \"collect\"\n[safety]\nworkspace_mm = [50, 50, 250, 1, 2]\n",
            "workspace_mm",
            "exactly 3 values",
        ),
    ] {
        std::fs::write(d.join("p.toml"), text).unwrap();
        let err = fails(&tmo(d, &["run", "p.toml"]));
        assert!(err.contains(field) && err.contains(why), "{text}\n{err}");
    }
    let hw = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("hardware/tmo.toml"),
    )
    .unwrap();
    for (from, to) in [
        ("ids = [1, 2, 3, 4]", "ids = [1, 2, 3, 4, 5]"),
        ("min = [1200, 1150, 2900, 2048]", "min = [1200, 1150, 2900]"),
    ] {
        assert!(hw.contains(from));
        std::fs::write(d.join("hw.toml"), hw.replace(from, to)).unwrap();
        let err = fails(&tmo(d, &["hardware", "check", "hw.toml"]));
        assert!(
            err.contains("hw.toml") && err.contains("exactly 4"),
            "{to}\n{err}"
        );
    }
}

#[test]
fn a_sweep_resumed_with_other_settings_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    ok(&tmo(
        d,
        &[
            "sim",
            "collect",
            "--objects",
            "crisps_can",
            "--trials",
            "4",
            "--out",
            "t",
        ],
    ));
    let sweep = |c: &str, resume: bool| {
        let mut args = vec![
            "sweep",
            "t",
            "--classifiers",
            "logreg",
            "--downsample",
            "1.0",
            "--n-slip",
            "3",
            "--C",
            c,
            "--out",
            "s/sweep.csv",
        ];
        if resume {
            args.push("--resume");
        }
        tmo(d, &args)
    };
    ok(&sweep("1", false));
    let err = fails(&sweep("2", true));
    assert!(
        err.contains("different sweep") && err.contains("c: 2.0"),
        "{err}"
    );
    // the same settings resume (nothing left to run)
    let out = ok(&sweep("1", true));
    assert!(out.contains("0 cells to run (1 already done)"), "{out}");
}

#[test]
fn every_motion_and_force_a_trial_may_command_is_checked_at_load() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (text, field) in [
        (
            "kind = \"hand_release\"\nmode = \"collect\"\n[hand_release]\nlift_mm = 120\n[safety]\nmax_arm_speed_mm_s = 30\n",
            "hand_release.lift_speed_mm_s",
        ),
        (
            "kind = \"rail_catch\"\nmode = \"collect\"\n[safety]\nmax_arm_speed_mm_s = 10\n",
            "rail_catch (the catch moves forward at a fixed 20 mm/s)",
        ),
        (
            "kind = \"rail_catch\"\nmode = \"collect\"\n[rail_catch]\ninitial_torque = 0.8\ntorque_step = 0.3\n",
            "rail_catch.torque_step",
        ),
    ] {
        std::fs::write(d.join("p.toml"), text).unwrap();
        let err = fails(&tmo(d, &["run", "p.toml"]));
        assert!(err.contains(field), "{text}\n{err}");
    }
}

#[test]
fn a_second_tmo_on_the_same_batch_is_refused_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("c.toml"),
        "kind = \"hand_release\"\nmode = \"collect\"\nrepetitions = 6\n[hand_release]\nlift_mm = 120\n",
    )
    .unwrap();
    let mut first = Command::new(env!("CARGO_BIN_EXE_tmo"))
        .current_dir(d)
        .args(["run", "c.toml", "--out", "b"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let started = Instant::now();
    while !d.join("b.lock").exists() {
        assert!(
            first.try_wait().unwrap().is_none(),
            "the batch ended before it was seen"
        );
        assert!(started.elapsed() < Duration::from_secs(60));
        std::thread::sleep(Duration::from_millis(2));
    }
    let err = fails(&tmo(d, &["run", "c.toml", "--out", "b", "--resume"]));
    assert!(err.contains("another tmo"), "{err}");
    assert!(first.wait().unwrap().success());
    assert!(!d.join("b.lock").exists(), "the lock goes with its writer");
    // and once the first is done, a resume may go ahead (nothing left to run)
    let out = ok(&tmo(d, &["run", "c.toml", "--out", "b", "--resume"]));
    assert!(out.contains("0 run"), "{out}");
}

#[test]
fn a_resume_finishes_only_the_batch_the_directory_holds() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("c.toml"),
        "kind = \"rail_catch\"\nmode = \"collect\"\nrepetitions = 3\nseed = 1\n",
    )
    .unwrap();
    ok(&tmo(d, &["run", "c.toml", "--out", "b"]));
    let err = fails(&tmo(
        d,
        &["run", "c.toml", "--out", "b", "--resume", "--seed", "2"],
    ));
    assert!(err.contains("seed 1 there, 2 now"), "{err}");
    let err = fails(&tmo(
        d,
        &["run", "c.toml", "--out", "b", "--resume", "--repeat", "5"],
    ));
    assert!(err.contains("3 repetitions there, 5 now"), "{err}");
    // a log put under another trial's name
    std::fs::copy(d.join("b/trial-00001.mcap"), d.join("b/trial-00000.mcap")).unwrap();
    let err = fails(&tmo(d, &["run", "c.toml", "--out", "b", "--resume"]));
    assert!(
        err.contains("trial-00000.mcap is not this batch's trial-00000: it is trial-00001"),
        "{err}"
    );
}

#[test]
fn an_error_says_its_cause_once() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    ok(&tmo(
        d,
        &[
            "sim",
            "collect",
            "--objects",
            "crisps_can",
            "--trials",
            "2",
            "--out",
            "t",
        ],
    ));
    let err = fails(&tmo(
        d,
        &[
            "train",
            "t",
            "--classifier",
            "logreg",
            "--C",
            "0",
            "--out",
            "m.json",
        ],
    ));
    assert_eq!(err.matches("invalid C = 0").count(), 1, "{err}");
}

/// Trains `d/rail_local.json`: a local model of the rail's single fingertip.
fn train_rail_local_model(d: &std::path::Path) {
    let collect = [
        "sim", "collect", "--rig", "rail", "--trials", "3", "--seed", "2",
    ];
    ok(&tmo(d, &[&collect[..], &["--out", "rail"]].concat()));
    let train = [
        "train",
        "rail",
        "--classifier",
        "logreg",
        "--C",
        "1",
        "--scope",
        "local",
    ];
    ok(&tmo(
        d,
        &[&train[..], &["--out", "rail_local.json"]].concat(),
    ));
}

/// A model the rig's frames do not fit is refused before the first trial, not run as a
/// detector that never fires (every trial would then be scored a miss).
#[test]
fn a_model_that_does_not_fit_the_rig_is_refused_before_any_trial() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // a local model of the rail's single fingertip, run on the three-fingered hand
    train_rail_local_model(d);
    std::fs::write(
        d.join("release.toml"),
        "kind = \"hand_release\"\nobjects = [\"crisps_can\"]\nmodels = [\"rail_local.json\"]\nstrategies = [\"2x2\"]\nrepetitions = 1\n",
    )
    .unwrap();
    let err = fails(&tmo(d, &["run", "release.toml", "--out", "out"]));
    assert!(
        err.contains("rail_local.json") && err.contains("sensor 1"),
        "{err}"
    );
    assert!(!d.join("out").join("trial-00000.mcap").exists());
}

/// Replaying recorded trials through a model their frames do not fit is an error naming
/// both, not a replay in which the detector never fires.
#[test]
fn a_replay_through_a_model_the_trials_do_not_fit_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    train_rail_local_model(d);
    ok(&tmo(
        d,
        &[
            "sim",
            "collect",
            "--objects",
            "crisps_can",
            "--trials",
            "1",
            "--seed",
            "3",
            "--out",
            "hand",
        ],
    ));
    let err = fails(&tmo(
        d,
        &[
            "replay",
            "hand",
            "--model",
            "rail_local.json",
            "--strategy",
            "2x2",
        ],
    ));
    assert!(
        err.contains("rail_local.json") && err.contains("sensor 1"),
        "{err}"
    );
}

#[test]
fn a_log_with_no_frames_or_no_marker_track_is_refused_not_counted() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    ok(&tmo(
        d,
        &[
            "sim",
            "collect",
            "--objects",
            "crisps_can",
            "--trials",
            "2",
            "--out",
            "t",
        ],
    ));
    let path = d.join("t/trial-00001.mcap");
    let trial = tmo::trial::read_trial(&path).unwrap();
    for (name, edit, says) in [
        (
            "no_frames",
            (|t: &mut tmo::trial::Trial| {
                t.frames.clear();
                t.arrivals_s.clear();
            }) as fn(&mut tmo::trial::Trial),
            "no tactile frames",
        ),
        (
            "no_markers",
            |t| t.markers.clear(),
            "neither a marker track nor slip labels",
        ),
        (
            "pin_far_away",
            |t| t.frames[3].pins[0] = [f32::MAX, -f32::MAX],
            "a pin at (3.4028235e38, -3.4028235e38) px",
        ),
    ] {
        let mut broken = trial.clone();
        edit(&mut broken);
        std::fs::copy(
            d.join("t/trial-00000.mcap"),
            d.join(format!("{name}-good.mcap")),
        )
        .unwrap();
        tmo::trial::write_trial(&d.join(format!("{name}.mcap")), &broken).unwrap();
        let err = fails(&tmo(
            d,
            &[
                "dataset",
                "export",
                &format!("{name}-good.mcap"),
                &format!("{name}.mcap"),
                "--out",
                "x.csv",
            ],
        ));
        assert!(
            err.contains(&format!("{name}.mcap")) && err.contains(says),
            "{err}"
        );
        assert!(!d.join("x.csv").exists());
    }
}

#[test]
fn an_svm_fit_that_stops_at_its_cap_warns_and_under_strict_fails() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    ok(&tmo(
        d,
        &[
            "sim",
            "collect",
            "--objects",
            "crisps_can",
            "--trials",
            "3",
            "--out",
            "t",
        ],
    ));
    let train = |extra: &[&str], out: &str| {
        let mut args = vec![
            "train",
            "t",
            "--classifier",
            "svm-linear",
            "--C",
            "50",
            // the linear SVM's interior-point method needs about 100 Newton steps
            "--max-iterations",
            "5",
            "--out",
            out,
        ];
        args.extend_from_slice(extra);
        tmo(d, &args)
    };
    let lax = train(&[], "lax.json");
    ok(&lax);
    let warned = String::from_utf8_lossy(&lax.stderr).to_string();
    assert!(
        warned.contains("warning: the SVM stopped at its iteration limit (5 iterations)"),
        "{warned}"
    );
    let model = std::fs::read_to_string(d.join("lax.json")).unwrap();
    assert!(model.contains("\"unconverged_gap\"") && model.contains("\"max_iterations\": 5"));
    let err = fails(&train(&["--strict"], "strict.json"));
    assert!(
        err.contains("--strict") && err.contains("no model written"),
        "{err}"
    );
    assert!(!d.join("strict.json").exists());
}

#[test]
fn a_file_of_the_wrong_kind_is_named_with_its_field_and_what_it_is() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    train_rail_local_model(d);
    let cases = [
        (
            "kind = \"rail_catch\"\nmodels = [\"/dev/null\"]\n",
            "models.0: /dev/null is not a regular file",
        ),
        (
            "kind = \"rail_catch\"\nmodels = [\"rail/trial-00000.mcap\"]\n",
            "models.0: rail/trial-00000.mcap: not a tmo model file: not text",
        ),
        (
            "kind = \"first_time_lift\"\nmodels = [\"rail_local.json\"]\n[first_time_lift]\ncalibration = \"rail_local.json\"\n",
            "first_time_lift.calibration: rail_local.json: not a g_min table (it is a model file)",
        ),
    ];
    for (text, says) in cases {
        std::fs::write(d.join("p.toml"), text).unwrap();
        let err = fails(&tmo(d, &["run", "p.toml", "--out", "b"]));
        assert!(err.contains(says), "{text}: {err}");
    }
}

/// T4-2, T4-5, T4-10: an `--out` (or `--plots`) that is empty, `-` where a directory is
/// meant, a symbolic link, a FIFO or a file where a directory is meant is refused with
/// exit 2 before any work, and what it named is left as it was. (A FIFO and links in the
/// test's own directory stand for device nodes: no test touches the machine's devices.)
#[cfg(unix)]
#[test]
fn every_output_that_is_not_a_plain_file_or_directory_is_refused_and_left_alone() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let precious = d.join("precious.csv");
    std::fs::write(&precious, "keep").unwrap();
    std::os::unix::fs::symlink(&precious, d.join("link")).unwrap();
    let fifo = d.join("fifo");
    let name = std::ffi::CString::new(fifo.as_os_str().as_encoded_bytes()).unwrap();
    // SAFETY: a valid C string; mkfifo only creates the node
    assert_eq!(unsafe { libc::mkfifo(name.as_ptr(), 0o600) }, 0);
    // commands whose --out is one file
    let file_outputs: &[&[&str]] = &[
        &["evaluate", "m.json", "t", "--out"],
        &["train", "t", "--out"],
        &["sweep", "t", "--test", "t", "--out"],
        &["sweep", "merge", "a.csv", "--out"],
        &["dataset", "export", "t", "--out"],
        &["sim", "serve", "--hardware", "hw.toml", "--out"],
    ];
    // commands whose --out is a directory
    let dir_outputs: &[&[&str]] = &[
        &["run", "p.toml", "--out"],
        &["sim", "collect", "--out"],
        &["sim", "trace", "--out"],
        &["import", "csv", "x.csv", "--out"],
        &["replay", "t", "--model", "m.json", "--out"],
        &["report", "r", "--out"],
        &["report", "r", "--plots"],
        &["reproduce", "--out"],
        &["reproduce", "merge", "s1", "--out"],
    ];
    let refused = |args: &[&str], out: &str, says: &str| {
        let mut all = args.to_vec();
        all.push(out);
        let e = fails(&tmo(d, &all));
        assert!(e.contains(says), "{all:?}: {e}");
    };
    for args in file_outputs {
        refused(args, "", "unset variable");
        refused(args, "link", "symbolic link");
        refused(args, "fifo", "FIFO");
    }
    for args in dir_outputs {
        refused(args, "", "unset variable");
        refused(args, "-", "standard output");
        refused(args, "fifo", "not a directory");
        refused(args, "precious.csv", "not a directory");
    }
    assert_eq!(std::fs::read(&precious).unwrap(), b"keep");
    let link = std::fs::symlink_metadata(d.join("link")).unwrap();
    assert!(link.file_type().is_symlink());
    use std::os::unix::fs::FileTypeExt;
    assert!(std::fs::symlink_metadata(&fifo)
        .unwrap()
        .file_type()
        .is_fifo());
    // nothing else was made
    let mut names: Vec<String> = std::fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, ["fifo", "link", "precious.csv"]);
}

/// A sensitivity study's second stage needs a finished screen with its noise reference.
#[test]
fn a_second_stage_without_a_screen_or_its_noise_reference_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let e = fails(&tmo(d, &["reproduce", "--screen", "none", "--out", "r"]));
    assert!(
        e.contains("none/sensitivity.json") && e.contains("--sensitivity"),
        "{e}"
    );
    std::fs::create_dir(d.join("s")).unwrap();
    std::fs::write(
        d.join("s/sensitivity.json"),
        r#"[{"variant": {"parameter": "rail.rail_mu", "end": "low", "value": 0.05, "default": 0.11}, "changed": {}}]"#,
    )
    .unwrap();
    let e = fails(&tmo(d, &["reproduce", "--screen", "s", "--out", "r"]));
    assert!(e.contains("no noise reference"), "{e}");
    assert!(!d.join("r").exists());
}

/// T4-12: frames exactly at the fastest rate the importer takes (100 kHz) are taken, though
/// the inverse of their spacing comes out a rounding above it.
#[test]
fn frames_exactly_at_the_fastest_rate_are_imported() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut csv = String::from("trial,sensor,frame,t_s,element,x,y,slip\n");
    for i in 0..21 {
        csv += &format!(
            "a,s,{i},{:.5},0,1,{i},{}\n",
            i as f64 * 1e-5,
            u8::from(i > 10)
        );
    }
    std::fs::write(d.join("r.csv"), csv).unwrap();
    let out = ok(&tmo(d, &["import", "csv", "r.csv", "--out", "logs"]));
    assert!(out.contains("1 trial log(s)"), "{out}");
}
