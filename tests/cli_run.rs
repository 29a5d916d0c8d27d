//! `tmo run` on the simulator: a short online hand-release batch, resuming an interrupted
//! batch, and malformed protocols.

mod common;

use std::path::Path;

use common::*;

const PROTOCOL: &str = r#"
kind = "hand_release"
objects = ["crisps_can", "banana"]
grasps_deg = [0, 180]
models = ["global.json"]
strategies = ["2x2"]
repetitions = 2
seed = 4
"#;

fn setup(d: &Path) {
    // The default classifier (an RBF SVM), as a user trains it: the batch below checks
    // that catches are scored, and a logistic regression on ten trials catches one release
    // in eight or none, as small a margin as a simulator change can take away.
    ok(&tmo(
        d,
        &[
            "sim", "collect", "--trials", "10", "--seed", "8", "--out", "train",
        ],
    ));
    ok(&tmo(
        d,
        &["train", "train", "--n-slip", "5", "--out", "global.json"],
    ));
    std::fs::write(d.join("release.toml"), PROTOCOL).unwrap();
}

fn sorted_logs(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".mcap"))
        .collect();
    v.sort();
    v
}

#[test]
fn a_batch_runs_scores_and_resumes_to_the_same_trials() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    setup(d);
    let stdout = ok(&tmo(d, &["run", "release.toml", "--out", "a"]));
    assert!(
        stdout.contains("8 trials (8 run, 0 already there)"),
        "{stdout}"
    );
    assert!(
        stdout.contains("TP") && stdout.contains("2Fr2Sen"),
        "{stdout}"
    );
    assert_eq!(sorted_logs(&d.join("a")).len(), 8);
    let full = std::fs::read_to_string(d.join("a/outcomes.csv")).unwrap();
    assert_eq!(full.lines().count(), 9);
    assert!(
        full.contains("true_positive"),
        "the detector catches something:\n{full}"
    );

    // The same batch interrupted after some trials (their logs complete, the rest missing),
    // then resumed, gives the same trials and outcomes.
    ok(&tmo(d, &["run", "release.toml", "--out", "b"]));
    for t in ["trial-00002.mcap", "trial-00005.mcap", "trial-00007.mcap"] {
        std::fs::remove_file(d.join("b").join(t)).unwrap();
    }
    let err = fails(&tmo(d, &["run", "release.toml", "--out", "b"]));
    assert!(err.contains("--resume"), "{err}");
    let stdout = ok(&tmo(d, &["run", "release.toml", "--out", "b", "--resume"]));
    assert!(stdout.contains("(3 run, 5 already there)"), "{stdout}");
    assert_eq!(sorted_logs(&d.join("b")), sorted_logs(&d.join("a")));
    assert_eq!(
        std::fs::read_to_string(d.join("b/outcomes.csv")).unwrap(),
        full
    );
}

#[test]
fn trials_run_in_parallel_give_the_outcomes_of_a_sequential_run() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    setup(d);
    let run = |threads: &str, out: &str| {
        let output = std::process::Command::new(env!("CARGO_BIN_EXE_tmo"))
            .current_dir(d)
            .env("RAYON_NUM_THREADS", threads)
            .args(["run", "release.toml", "--repeat", "3", "--out", out])
            .output()
            .unwrap();
        ok(&output);
        std::fs::read_to_string(d.join(out).join("outcomes.csv")).unwrap()
    };
    let sequential = run("1", "one");
    assert_eq!(sequential.lines().count(), 13);
    assert_eq!(run("3", "three"), sequential);
    assert_eq!(sorted_logs(&d.join("three")), sorted_logs(&d.join("one")));
}

#[test]
fn run_json_is_the_summary_as_one_json_object() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    setup(d);
    let run = [
        "run",
        "release.toml",
        "--repeat",
        "1",
        "--out",
        "b",
        "--json",
    ];
    let stdout = ok(&tmo(d, &run));
    let v: serde_json::Value = serde_json::from_str(&stdout).expect("stdout is JSON alone");
    assert_eq!(v["kind"], "hand_release");
    assert_eq!(v["trials"], v["ran"]);
    assert!(v["trials"].as_u64().unwrap() >= 1, "{v}");
    assert!(
        v["tables"].as_object().is_some_and(|t| !t.is_empty()),
        "{v}"
    );
    assert!(
        v["outputs"]
            .as_array()
            .unwrap()
            .iter()
            .any(|o| o.as_str().unwrap().ends_with("outcomes.csv")),
        "{v}"
    );
    // a second run finds every trial there
    let again: serde_json::Value =
        serde_json::from_str(&ok(&tmo(d, &[&run[..], &["--resume"]].concat()))).unwrap();
    assert_eq!(again["ran"], 0);
    assert_eq!(again["already_there"], v["trials"]);
}

/// A viewer connected to `tmo run --live` (loopback, port 0: the address tmo prints) while
/// the batch runs, subscribes to the thumb's pin channel and receives its frames.
#[test]
fn a_live_viewer_receives_pin_frames_while_the_batch_runs() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    setup(d);
    let mut child = spawn_tmo(
        d,
        &[
            "run",
            "release.toml",
            "--repeat",
            "2",
            "--out",
            "live",
            "--live",
            "127.0.0.1:0",
        ],
    );
    let frames = common::live::pin_frames(&mut child, 10);
    assert!(frames.windows(2).all(|w| w[0] < w[1]), "{frames:?}");
    child.kill().unwrap();
    child.wait().unwrap();
}

/// `--live-wait`: the batch waits for a viewer before its first trial, so the viewer sees
/// that trial from its first frame; with no viewer it starts anyway when the wait is over.
#[test]
fn a_batch_can_wait_for_its_first_viewer() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    setup(d);
    let mut child = spawn_tmo(
        d,
        &[
            "run",
            "release.toml",
            "--repeat",
            "1",
            "--out",
            "waited",
            "--live",
            "127.0.0.1:0",
            "--live-wait",
            "60",
        ],
    );
    let frames = common::live::pin_frames(&mut child, 5);
    // a fingertip camera's first frame is number 1
    assert_eq!(
        frames[0], 1,
        "the viewer missed the first frames: {frames:?}"
    );
    child.kill().unwrap();
    child.wait().unwrap();

    // no viewer: the batch says so and starts (its trials then run at wall-clock speed,
    // so the test stops it there)
    let mut alone = spawn_tmo(
        d,
        &[
            "run",
            "release.toml",
            "--out",
            "alone",
            "--live",
            "127.0.0.1:0",
            "--live-wait",
            "0.2",
        ],
    );
    let mut said = String::new();
    let mut stderr = std::io::BufReader::new(alone.stderr.take().unwrap());
    while !said.contains("starting without one") {
        let mut line = String::new();
        let read = std::io::BufRead::read_line(&mut stderr, &mut line).unwrap();
        assert!(read > 0, "tmo ended without saying it started: {said}");
        said.push_str(&line);
    }
    alone.kill().unwrap();
    alone.wait().unwrap();
    assert!(
        said.contains("no viewer subscribed within 0.2 s; starting without one"),
        "{said}"
    );
    assert!(said.contains("foxglove.sdk.v1"), "{said}");
    let e = fails(&tmo(
        d,
        &[
            "run",
            "release.toml",
            "--live",
            "127.0.0.1:0",
            "--live-wait",
            "0",
        ],
    ));
    assert!(
        e.contains("--live-wait") && e.contains("more than 0"),
        "{e}"
    );
}

#[test]
fn a_batch_run_in_shards_reports_as_the_whole_batch() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    setup(d);
    ok(&tmo(d, &["run", "release.toml", "--out", "whole"]));
    for k in 1..=3 {
        let stdout = ok(&tmo(
            d,
            &[
                "run",
                "release.toml",
                "--shard",
                &format!("{k}/3"),
                "--out",
                &format!("s{k}"),
            ],
        ));
        assert!(
            stdout.contains(if k < 3 { "3 trials" } else { "2 trials" }),
            "{stdout}"
        );
    }
    let mut parts: Vec<String> = (1..=3)
        .flat_map(|k| sorted_logs(&d.join(format!("s{k}"))))
        .collect();
    parts.sort();
    assert_eq!(
        parts,
        sorted_logs(&d.join("whole")),
        "every trial once, same names"
    );
    let report = |dirs: &[&str]| {
        let mut args = vec!["report"];
        args.extend_from_slice(dirs);
        args.extend_from_slice(&["--format", "json"]);
        ok(&tmo(d, &args))
    };
    // the loop's timing table is this machine's measurements of each run: its trials and
    // frames are the same, its times are not
    let tables = |text: String| {
        let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
        let timing = v.as_object_mut().unwrap().remove("loop_timing").unwrap();
        let counts: Vec<serde_json::Value> = timing["rows"][0].as_array().unwrap()[..5].to_vec();
        (v, counts)
    };
    let whole = tables(report(&["whole"]));
    let joined = tables(report(&["s2", "s1", "s3"]).replace("\"s2\"", "\"whole\""));
    assert_eq!(joined, whole);
    let err = fails(&tmo(d, &["report", "s1", "s2"]));
    assert!(err.contains("shard(s) 3/3 not given"), "{err}");
    let err = fails(&tmo(
        d,
        &[
            "run",
            "release.toml",
            "--shard",
            "1/3",
            "--out",
            "s2",
            "--resume",
        ],
    ));
    assert!(err.contains("it holds 2/3, this run 1/3"), "{err}");
}

#[test]
fn malformed_protocols_are_refused_with_their_place() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("m.json"), "{}").unwrap();
    let cases = [
        (
            "kind = \"hand_release\"\nmodels = [\"m.json\"]\nrepetitions = \"two\"\n",
            "bad.toml:3:15",
        ),
        (
            "kind = \"hand_release\"\nmodels = [\"m.json\"]\nspeed = 1\n",
            "bad.toml:3:1",
        ),
        (
            "kind = \"hand_release\"\nmodels = [\"m.json\"]\n[hand_release]\nregrasp = 2.0\n",
            "hand_release.regrasp",
        ),
        (
            "kind = \"hand_release\"\nmodels = [\"gone.json\"]\n",
            "gone.json not found; make one from collected trials with `tmo train TRIALS --out",
        ),
        (
            "kind = \"hand_release\"\nmodels = [\"m.json\"]\nstrategies = [\"1x5\"]\n",
            "strategies.0",
        ),
    ];
    for (text, expected) in cases {
        std::fs::write(d.join("bad.toml"), text).unwrap();
        let err = fails(&tmo(d, &["run", "bad.toml"]));
        assert!(err.contains(expected), "{text}\n{err}");
    }
}

#[test]
fn a_batch_killed_mid_run_resumes_to_the_same_trials() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    setup(d);
    let args = |out: &'static str| vec!["run", "release.toml", "--repeat", "10", "--out", out];
    ok(&tmo(d, &args("whole")));
    let whole = std::fs::read_to_string(d.join("whole/outcomes.csv")).unwrap();
    assert_eq!(whole.lines().count(), 41);

    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_tmo"))
        .current_dir(d)
        .args(args("killed"))
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let killed = d.join("killed");
    let started = std::time::Instant::now();
    while (!killed.exists() || sorted_logs(&killed).len() < 5) && started.elapsed().as_secs() < 60 {
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
    child.kill().unwrap(); // SIGKILL: no chance to tidy up
    child.wait().unwrap();
    let survivors = sorted_logs(&killed).len();
    assert!(
        (5..40).contains(&survivors),
        "killed after {survivors} trials"
    );
    assert!(!killed.join("outcomes.csv").exists());

    let stdout = ok(&tmo(d, &[&args("killed")[..], &["--resume"]].concat()));
    assert!(
        stdout.contains(&format!(
            "({} run, {survivors} already there)",
            40 - survivors
        )),
        "{stdout}"
    );
    assert_eq!(sorted_logs(&killed), sorted_logs(&d.join("whole")));
    assert_eq!(
        std::fs::read_to_string(killed.join("outcomes.csv")).unwrap(),
        whole
    );
}

/// Starts a 40-trial batch in `d/out_name`, waits for three finished trials and sends
/// Ctrl-C (SIGINT); returns the logs left and the exit's stderr.
fn interrupt_a_batch(d: &Path, out_name: &str) -> (Vec<String>, String) {
    let child = std::process::Command::new(env!("CARGO_BIN_EXE_tmo"))
        .current_dir(d)
        .args(["run", "release.toml", "--repeat", "10", "--out", out_name])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let out = d.join(out_name);
    let started = std::time::Instant::now();
    while (!out.exists() || sorted_logs(&out).len() < 3) && started.elapsed().as_secs() < 60 {
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
    // the shell's own `kill`, so no procps package is needed
    let status = std::process::Command::new("sh")
        .args(["-c", &format!("kill -INT {}", child.id())])
        .status()
        .unwrap();
    assert!(status.success());
    let output = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    assert_eq!(output.status.code(), Some(130), "{stderr}");
    assert!(stderr.contains("--resume"), "{stderr}");
    (sorted_logs(&out), stderr)
}

#[test]
fn ctrl_c_keeps_finished_trials_and_the_batch_resumes() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    setup(d);
    // Each trial that was running when Ctrl-C came is kept as aborted. A Ctrl-C that lands
    // while every worker is between trials (writing a finished log) leaves none: correct,
    // but it does not test the aborted path, so the batch is interrupted again, in a new
    // directory, until one lands inside a trial (CI once saw the first attempt miss).
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let mut attempt = 0;
    let (out_name, logs) = loop {
        let out_name = format!("b{attempt}");
        let (logs, stderr) = interrupt_a_batch(d, &out_name);
        let aborted = logs.iter().filter(|l| l.ends_with(".aborted.mcap")).count();
        assert!(aborted <= cores, "{logs:?}");
        if aborted > 0 {
            assert!(stderr.contains("kept as aborted"), "{stderr}");
            break (out_name, logs);
        }
        attempt += 1;
        assert!(
            attempt < 5,
            "five Ctrl-Cs all landed between trials: {logs:?}"
        );
    };
    let out = d.join(&out_name);
    let aborted: Vec<_> = logs
        .iter()
        .filter(|l| l.ends_with(".aborted.mcap"))
        .collect();
    for log in &aborted {
        let trial = tmo::trial::read_trial(&out.join(log)).unwrap();
        assert!(trial.events.iter().any(|e| e.topic == "/fault"));
    }

    let done = logs.len() - aborted.len();
    let stdout = ok(&tmo(
        d,
        &[
            "run",
            "release.toml",
            "--repeat",
            "10",
            "--out",
            &out_name,
            "--resume",
        ],
    ));
    assert!(
        stdout.contains(&format!("{done} already there")),
        "{stdout}"
    );
    let csv = std::fs::read_to_string(out.join("outcomes.csv")).unwrap();
    assert_eq!(csv.lines().count(), 41);
}

#[test]
fn a_rail_catch_batch_runs_on_the_simulator() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    collect_and_train(
        d,
        &["--rig", "rail", "--trials", "12", "--seed", "2"],
        "rail",
        "rail.json",
    );
    std::fs::write(
        d.join("rail.toml"),
        "kind = \"rail_catch\"\nmodels = [\"rail.json\"]\nstrategies = [\"1x1\", \"2x1\"]\nrepetitions = 4\nseed = 3\n",
    )
    .unwrap();
    let stdout = ok(&tmo(d, &["run", "rail.toml", "--out", "b"]));
    assert!(stdout.contains("8 trials (8 run"), "{stdout}");
    let csv = std::fs::read_to_string(d.join("b/outcomes.csv")).unwrap();
    assert_eq!(csv.lines().count(), 9);
    assert!(csv.contains("true_positive"), "{csv}");
    let trial = tmo::trial::read_trial(&d.join("b/trial-00000.mcap")).unwrap();
    assert_eq!(trial.meta.kind, "rail_catch");
    assert!(trial.meta.parameters.contains_key("retract_speed_mm_s"));
}

#[test]
fn a_rice_pour_batch_counts_responses() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    setup(d);
    std::fs::write(
        d.join("pour.toml"),
        "kind = \"rice_pour\"\nmodels = [\"global.json\"]\nrepetitions = 2\n[rice_pour]\ntotal_g = 300\n",
    )
    .unwrap();
    let stdout = ok(&tmo(d, &["run", "pour.toml", "--out", "p"]));
    assert!(
        stdout.contains("responses") && stdout.contains("crisps_can"),
        "{stdout}"
    );
    let csv = std::fs::read_to_string(d.join("p/outcomes.csv")).unwrap();
    assert_eq!(csv.lines().count(), 3, "{csv}");
}

/// The paper's first-time lift pipeline: calibrate g_min, then lift with slip detection and
/// score overgrasp against the calibration.
#[test]
fn a_calibration_then_a_first_time_lift_batch() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    setup(d);
    let masses = "masses_g = [0, 450]\n";
    std::fs::write(
        d.join("cal.toml"),
        format!("kind = \"calibrate_lift\"\nrepetitions = 2\n[calibrate_lift]\n{masses}"),
    )
    .unwrap();
    let stdout = ok(&tmo(d, &["run", "cal.toml", "--out", "cal"]));
    assert!(stdout.contains("g_min.json"), "{stdout}");
    let table: tmo::runner::score::GMinTable =
        serde_json::from_str(&std::fs::read_to_string(d.join("cal/g_min.json")).unwrap()).unwrap();
    assert_eq!(table.entries.len(), 2, "{table:?}");
    let past = |m: f64| table.min_past_contact("crisps_can_empty", m).unwrap();
    assert!(past(450.0) > past(0.0) + 0.01, "{table:?}");
    // scoring the log re-judges every attempt and agrees with the runner's own verdict
    let rows: Vec<serde_json::Value> =
        serde_json::from_str(&std::fs::read_to_string(d.join("cal/outcomes.json")).unwrap())
            .unwrap();
    for (i, row) in rows.iter().enumerate() {
        let trial = tmo::trial::read_trial(&d.join(format!("cal/trial-{i:05}.mcap"))).unwrap();
        let calibrated = trial
            .events
            .iter()
            .find(|e| e.topic == "/phase" && e.data["phase"] == "calibrated")
            .expect("every sweep found its g_min");
        assert_eq!(row["g_min"], calibrated.data["g_min"], "{row}");
    }

    std::fs::write(
        d.join("lift.toml"),
        format!(
            "kind = \"first_time_lift\"\nmodels = [\"global.json\"]\nrepetitions = 3\n[first_time_lift]\n{masses}calibration = \"cal/g_min.json\"\n"
        ),
    )
    .unwrap();
    let stdout = ok(&tmo(d, &["run", "lift.toml", "--out", "lift"]));
    assert!(stdout.contains("overgrasp"), "{stdout}");
    let rows: Vec<serde_json::Value> =
        serde_json::from_str(&std::fs::read_to_string(d.join("lift/outcomes.json")).unwrap())
            .unwrap();
    assert_eq!(rows.len(), 6);
    let heavy: Vec<_> = rows.iter().filter(|r| r["mass_g"] == 450.0).collect();
    // The empty can is lifted every time. A heavy can slides through the light contact
    // grasp, and a slow steady slide at a light grip moves the pins weakly, so with this
    // test's small model the hand may not tighten often enough and the can is left behind
    // (the paper preset's full models carry 6 in 10 of the 350-450 g cans). Whether or not it
    // was carried, the hand saw it slip and tightened.
    assert!(
        rows.iter()
            .filter(|r| r["mass_g"] == 0.0)
            .all(|r| r["success"] == true),
        "{rows:?}"
    );
    // the heavy can slips off the contact grasp, so the hand tightened in most attempts
    // (this test's small model misses some slow slides: one of three at 134c0b6, since the
    // fingertip-held object follows the curl and the collection it learns from changed)
    // and, where it was lifted, overgrasp is known
    assert!(
        heavy
            .iter()
            .filter(|r| r["slips"].as_u64().unwrap() >= 1)
            .count()
            >= 2,
        "{heavy:?}"
    );
    assert!(
        heavy
            .iter()
            .filter(|r| r["success"] == true)
            .all(|r| r["overgrasp"].is_number()),
        "{heavy:?}"
    );
    let trial = tmo::trial::read_trial(&d.join("lift/trial-00005.mcap")).unwrap();
    assert_eq!(trial.meta.kind, "first_time_lift");
    assert_eq!(trial.meta.parameters["extra_mass_g"], "450.0");
}

#[test]
fn a_resume_keeps_faulted_trials_unless_asked_to_run_them_again() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let protocol =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("protocols/rail_collect.toml");
    let protocol = protocol.to_str().unwrap();
    ok(&tmo(d, &["run", protocol, "--repeat", "2", "--out", "b"]));
    let log = d.join("b/trial-00001.mcap");
    let clean = std::fs::read(&log).unwrap();
    // as if the trial had ended on a device error
    let mut trial = tmo::trial::read_trial(&log).unwrap();
    trial
        .meta
        .parameters
        .insert("fault".into(), "servo bus: no answer".into());
    tmo::trial::write_trial(&log, &trial).unwrap();

    let run = |extra: &[&str]| {
        let mut args = vec!["run", protocol, "--repeat", "2", "--out", "b"];
        args.extend_from_slice(extra);
        tmo(d, &args)
    };
    let kept = ok(&run(&["--resume"]));
    assert!(kept.contains("(0 run, 2 already there)"), "{kept}");
    assert!(kept.contains("1 trial(s) aborted by a fault"), "{kept}");

    let err = fails(&run(&["--rerun-faulted"]));
    assert!(err.contains("--resume"), "{err}");

    let rerun = ok(&run(&["--resume", "--rerun-faulted"]));
    assert!(rerun.contains("(1 run, 1 already there)"), "{rerun}");
    assert!(rerun.contains("1 faulted trial(s) run again"), "{rerun}");
    assert!(!rerun.contains("aborted by a fault"), "{rerun}");
    // the same seed gives the same trial; the faulted log is kept beside the batch
    let again = tmo::trial::read_trial(&log).unwrap();
    let first = {
        let p = d.join("clean.mcap");
        std::fs::write(&p, &clean).unwrap();
        tmo::trial::read_trial(&p).unwrap()
    };
    assert_eq!(again.frames, first.frames);
    assert!(d.join("b/trial-00001.faulted-1.mcap").exists());
}

#[test]
fn a_resume_refuses_an_empty_trial_log_rather_than_scoring_it() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let protocol =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("protocols/rail_collect.toml");
    let protocol = protocol.to_str().unwrap();
    ok(&tmo(d, &["run", protocol, "--repeat", "2", "--out", "b"]));
    // a valid log with the trial's metadata and no messages
    let log = d.join("b/trial-00001.mcap");
    let mut trial = tmo::trial::read_trial(&log).unwrap();
    trial.frames.clear();
    trial.markers.clear();
    trial.events.clear();
    tmo::trial::write_trial(&log, &trial).unwrap();
    let err = fails(&tmo(
        d,
        &["run", protocol, "--repeat", "2", "--out", "b", "--resume"],
    ));
    assert!(
        err.contains("trial-00001.mcap") && err.contains("holds no messages"),
        "{err}"
    );
    // moved away, the trial is recorded anew
    std::fs::rename(&log, d.join("empty.mcap")).unwrap();
    let again = ok(&tmo(
        d,
        &["run", protocol, "--repeat", "2", "--out", "b", "--resume"],
    ));
    assert!(again.contains("(1 run, 1 already there)"), "{again}");
}
