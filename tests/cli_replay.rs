//! Replay: determinism against the live runner, damaged logs, and `tmo run --backend
//! replay`.

mod common;

use std::path::Path;

use common::*;

/// A short online hand-release batch (two strategies) with a freshly trained model.
fn batch(d: &Path) {
    let run = |args: &[&str]| ok(&tmo(d, args));
    collect_and_train(
        d,
        &["--trials", "10", "--seed", "5"],
        "train",
        "global.json",
    );
    std::fs::write(
        d.join("hand.toml"),
        "kind = \"hand_release\"\nobjects = [\"crisps_can\", \"banana\"]\ngrasps_deg = [0, 180]\nmodels = [\"global.json\"]\nstrategies = [\"1x1\", \"2x2\"]\nrepetitions = 2\nseed = 6\n",
    )
    .unwrap();
    run(&["run", "hand.toml", "--out", "b"]);
}

fn csv_rows(path: &Path) -> Vec<std::collections::HashMap<String, String>> {
    csv::Reader::from_path(path)
        .unwrap()
        .deserialize()
        .map(|r| r.unwrap())
        .collect()
}

#[test]
fn replaying_with_the_model_and_strategy_that_ran_reproduces_the_detector_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    batch(d);
    let out = ok(&tmo(
        d,
        &[
            "replay",
            "b",
            "--model",
            "global.json",
            "--strategy",
            "1x1,2x2,1x3",
            "--out",
            "r",
        ],
    ));
    assert!(out.contains("48 replays of 16 trial(s)"), "{out}");
    // every trial is in one of the table's columns: no slip has its own
    assert!(out.contains("missed | no slip | undetermined"), "{out}");
    let rows = csv_rows(&d.join("r/replay.csv"));
    let compared: Vec<_> = rows
        .iter()
        .filter(|r| !r["matches_logged"].is_empty())
        .collect();
    assert_eq!(compared.len(), 16, "each trial once, with its own strategy");
    assert!(
        compared.iter().all(|r| r["matches_logged"] == "true"),
        "{compared:?}"
    );

    // Event by event: every classification up to the reaction, and the reaction itself.
    let model = tmo::slip::slip_model::SlipModel::load(&d.join("global.json")).unwrap();
    for i in 0..16 {
        let trial = tmo::trial::read_trial(&d.join(format!("b/trial-{i:05}.mcap"))).unwrap();
        let strategy = trial.meta.parameters["strategy"].parse().unwrap();
        let (record, window) = tmo::replay::replay_trial(&trial, &model, strategy).unwrap();
        assert_eq!(window, "logged");
        let end = record.reaction.map_or(f64::INFINITY, |r| r.time_s);
        // Classifications are logged at their frame's capture time and detector events at
        // the poll, so a log read back orders them by time; compare them as sets.
        let stream = |events: &[tmo::trial::TrialEvent]| -> Vec<String> {
            let mut v: Vec<String> = events
                .iter()
                .filter(|e| match e.topic.as_str() {
                    "/classifier" => e.time_s <= end,
                    "/detector" => e.data["event"] != "disarmed",
                    _ => false,
                })
                .map(|e| format!("{} {}", e.topic, e.data))
                .collect();
            v.sort();
            v
        };
        let live = stream(&trial.events);
        let replayed = stream(&record.events);
        assert_eq!(replayed.len(), live.len(), "{}", trial.meta.trial_id);
        assert!(
            replayed == live,
            "{}: replay differs from the log",
            trial.meta.trial_id
        );
    }
}

#[test]
fn damaged_logs_are_named_skipped_and_the_rest_evaluated() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    batch(d);
    let log = |i: usize| d.join(format!("b/trial-{i:05}.mcap"));
    let bytes = std::fs::read(log(3)).unwrap();
    std::fs::write(log(3), &bytes[..bytes.len() / 2]).unwrap();
    std::fs::write(log(7), b"not an mcap file at all").unwrap();
    let o = tmo(
        d,
        &["replay", "b", "--model", "global.json", "--strategy", "2x2"],
    );
    assert_eq!(o.status.code(), Some(3), "{o:?}");
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains("skipped") && stderr.contains("trial-00003.mcap"),
        "{stderr}"
    );
    assert!(stderr.contains("trial-00007.mcap"), "{stderr}");
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("14 replays of 14 trial(s)"), "{stdout}");
    // --json: the same replay as one JSON object on standard output, skips still counted
    let o = tmo(
        d,
        &[
            "replay",
            "b",
            "--model",
            "global.json",
            "--strategy",
            "2x2",
            "--json",
        ],
    );
    assert_eq!(o.status.code(), Some(3), "{o:?}");
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("stdout is JSON alone");
    assert_eq!(v["replays"], 14);
    assert_eq!(v["skipped"], 2);
    assert_eq!(v["outcomes"].as_array().unwrap().len(), 14);
    assert_eq!(v["table"]["name"], "replay");
    // Nothing counts twice without a word: a strategy named twice, a copied log (replay and
    // evaluate alike), the same folder given twice.
    let err = fails(&tmo(
        d,
        &[
            "replay",
            "b",
            "--model",
            "global.json",
            "--strategy",
            "2x2,1x1,2x2",
        ],
    ));
    assert!(
        err.contains("2x2") && err.contains("more than once"),
        "{err}"
    );
    std::fs::write(log(3), &bytes).unwrap();
    std::fs::remove_file(log(7)).unwrap();
    std::fs::copy(log(0), d.join("b/copy.mcap")).unwrap();
    for args in [
        &["replay", "b", "--model", "global.json"][..],
        &["evaluate", "global.json", "b"][..],
    ] {
        let err = fails(&tmo(d, args));
        assert!(
            err.contains("copy.mcap")
                && err.contains("trial-00000.mcap")
                && err.contains("same trial log"),
            "{args:?}: {err}"
        );
    }
    std::fs::remove_file(d.join("b/copy.mcap")).unwrap();
    let err = fails(&tmo(d, &["evaluate", "global.json", "b", "b"]));
    assert!(err.contains("same trial log"), "{err}");
}

#[test]
fn run_with_the_replay_backend_uses_the_protocols_models_and_strategies() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    batch(d);
    let out = ok(&tmo(
        d,
        &[
            "run",
            "hand.toml",
            "--backend",
            "replay",
            "--from",
            "b",
            "--out",
            "rb",
        ],
    ));
    assert!(
        out.contains("32 replays of 16 trial(s) x 1 model(s) x 2 strateg"),
        "{out}"
    );
    let rows = csv_rows(&d.join("rb/replay.csv"));
    assert_eq!(rows.len(), 32);
    let e = fails(&tmo(d, &["run", "hand.toml", "--backend", "replay"]));
    assert!(e.contains("--from"), "{e}");
}

/// `tmo replay --live` plays each trial to a Foxglove viewer at wall-clock speed before the
/// replay; Ctrl-C skips the rest of the playing, and the replay still runs and reports.
#[test]
fn a_replay_plays_its_trials_live_and_ctrl_c_skips_to_the_table() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    collect_and_train(d, &["--trials", "5", "--seed", "5"], "t", "m.json");
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_tmo"))
        .current_dir(d)
        .args([
            "replay",
            "t",
            "--model",
            "m.json",
            "--strategy",
            "1x1",
            "--live",
            "127.0.0.1:0",
        ])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let started = std::time::Instant::now();
    let frames = common::live::pin_frames(&mut child, 20);
    // consecutive frames of the recorded trial, at about the camera's 60 fps
    assert!(frames.windows(2).all(|w| w[0] < w[1]), "{frames:?}");
    assert!(
        started.elapsed().as_secs_f64() > 19.0 / 60.0,
        "20 frames in {:?}: not at wall-clock speed",
        started.elapsed()
    );
    // SAFETY: signals a child process this test started and still owns.
    unsafe {
        libc::kill(child.id() as i32, libc::SIGINT);
    }
    let out = child.wait_with_output().unwrap();
    let said = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{said}");
    assert!(said.contains("5 replays of 5 trial(s)"), "{said}");
}

/// Issue 42, Foxglove: `replay --live` with no model plays the trials only; a viewer's
/// clock never runs back between trials; the view ends with a close frame; the SDK's
/// subprotocol is required (the older `foxglove.websocket.v1` is refused, as documented).
#[test]
fn a_live_replay_without_a_model_plays_every_trial_on_one_clock_and_closes() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // two trials of one sensor, 1.5 s each at 60 Hz
    let mut csv = String::from("trial,sensor,frame,t_s,element,x,y,slip\n");
    for trial in ["a", "b"] {
        for f in 0..90 {
            for e in 0..2 {
                csv += &format!("{trial},s,{f},{:.5},{e},{},{e},0\n", f as f64 / 60.0, f + e);
            }
        }
    }
    std::fs::write(d.join("two.csv"), csv).unwrap();
    ok(&tmo(d, &["import", "csv", "two.csv", "--out", "two"]));
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_tmo"))
        .current_dir(d)
        .args(["replay", "two", "--live", "127.0.0.1:0"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let url = common::live::address(&mut child);
    match common::live::connect(&url, "foxglove.websocket.v1") {
        Err(tungstenite::Error::Http(r)) => assert_eq!(r.status(), 400),
        other => panic!("the old subprotocol name: {:?}", other.map(|_| ())),
    }
    let mut ws = common::live::connect(&url, "foxglove.sdk.v1").unwrap();
    let (frames, closed) = common::live::until_closed(&mut ws, "/tactile/0");
    assert!(closed, "no close frame");
    let times: Vec<u64> = frames.iter().map(|f| f.0).collect();
    assert!(times.windows(2).all(|w| w[0] <= w[1]), "{times:?}");
    // both trials: the frame numbers start again
    let seqs: Vec<u64> = frames
        .iter()
        .map(|f| f.1["seq"].as_u64().unwrap())
        .collect();
    assert!(seqs.windows(2).any(|w| w[1] < w[0]), "{seqs:?}");
    assert!(frames.len() > 90, "{} frames", frames.len());
    let out = child.wait_with_output().unwrap();
    assert!(out.status.success(), "{out:?}");
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("nothing was replayed"),
        "{out:?}"
    );
}
