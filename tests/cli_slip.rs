//! The slip commands on the real binary: collect on the simulator, export, train, evaluate,
//! sweep (including an interrupted one) and their errors.

mod common;

use std::path::Path;

use common::*;

fn collect(dir: &Path, n: &str, out: &str, seed: &str) {
    ok(&tmo(
        dir,
        &[
            "sim",
            "collect",
            "--objects",
            "crisps_can",
            "--trials",
            n,
            "--seed",
            seed,
            "--out",
            out,
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

    // M-c: a model met again on its own training trials says so; on held-out ones it does not
    let stderr = |o: &std::process::Output| String::from_utf8_lossy(&o.stderr).into_owned();
    let on_train = tmo(d, &["evaluate", "logreg.json", "train"]);
    ok(&on_train);
    assert!(
        stderr(&on_train).contains("among its training trials"),
        "{}",
        stderr(&on_train)
    );
    let on_test = tmo(d, &["evaluate", "logreg.json", "test"]);
    ok(&on_test);
    assert!(
        !stderr(&on_test).contains("training trials"),
        "{}",
        stderr(&on_test)
    );

    // --json prints the evaluation file's contents alone, so a pipe can read it
    let stdout = ok(&tmo(
        d,
        &[
            "evaluate",
            "logreg.json",
            "test",
            "--json",
            "--out",
            "eval.json",
        ],
    ));
    let printed: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    let written: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("eval.json")).unwrap()).unwrap();
    assert_eq!(printed, written);
    assert!(printed.to_string().contains("macro_f1"), "{printed}");

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
fn three_shards_merged_give_the_sweep_one_run_gives() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    collect(d, "8", "trials", "5");
    let grid = [
        "sweep",
        "trials",
        "--classifiers",
        "logreg,threshold",
        "--downsample",
        "0.5,0.75,1.0",
        "--n-slip",
        "3:4",
        "--C",
        "1",
    ];
    ok(&tmo(d, &[&grid[..], &["--out", "one/sweep.csv"]].concat()));
    // three processes, as three cluster jobs would be
    let shards: Vec<_> = (1..=3)
        .map(|k| {
            let (shard, out) = (format!("{k}/3"), format!("parts/s{k}.csv"));
            std::process::Command::new(env!("CARGO_BIN_EXE_tmo"))
                .current_dir(d)
                .args(grid)
                .args(["--shard", &shard, "--out", &out])
                .output()
                .unwrap()
        })
        .collect();
    for (k, out) in shards.iter().enumerate() {
        let stdout = ok(out);
        assert!(
            stdout.contains("4 cells to run"),
            "shard {}: {stdout}",
            k + 1
        );
    }
    let merge = |parts: &[&str]| {
        let mut args = vec!["sweep", "merge"];
        args.extend_from_slice(parts);
        args.extend_from_slice(&["--out", "merged/sweep.csv"]);
        tmo(d, &args)
    };
    let stdout = ok(&merge(&["parts/s3.csv", "parts/s1.csv", "parts/s2.csv"]));
    assert!(stdout.contains("merged 3 shards into 12 cells"), "{stdout}");
    // identical apart from the timing column
    let strip_seconds = |path: &str| -> Vec<String> {
        std::fs::read_to_string(d.join(path))
            .unwrap()
            .lines()
            .map(|l| l.rsplit_once(',').unwrap().0.to_string())
            .collect()
    };
    assert_eq!(
        strip_seconds("merged/sweep.csv"),
        strip_seconds("one/sweep.csv")
    );
    let provenance = |path: &str| {
        let mut v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(d.join(path)).unwrap()).unwrap();
        let o = v.as_object_mut().unwrap();
        o.remove("command");
        o.remove("wall_seconds");
        v
    };
    assert_eq!(
        provenance("merged/sweep.json"),
        provenance("one/sweep.json")
    );
    assert!(d.join("merged/sweep_fig5_f1_logreg.png").exists());

    // parts missing, repeated, or of another sweep are refused
    let err = fails(&merge(&["parts/s1.csv", "parts/s2.csv"]));
    assert!(err.contains("shard(s) 3/3 not given"), "{err}");
    let err = fails(&merge(&["parts/s1.csv", "parts/s1.csv", "parts/s2.csv"]));
    assert!(err.contains("are both shard 1/3"), "{err}");
    let err = fails(&merge(&["one/sweep.csv"]));
    assert!(err.contains("not a shard"), "{err}");
    let err = fails(&tmo(d, &[&grid[..], &["--shard", "4/3"]].concat()));
    assert!(err.contains("K/N with 1 <= K <= N"), "{err}");

    // --out on one of the shards would write over an input
    let err = fails(&tmo(
        d,
        &[
            "sweep",
            "merge",
            "parts/s1.csv",
            "parts/s2.csv",
            "parts/s3.csv",
            "--out",
            "parts/s2.csv",
        ],
    ));
    assert!(err.contains("is the shard parts/s2.csv"), "{err}");
    // a tampered score is refused as the report would refuse it, naming file, row and field
    let s2 = d.join("parts/s2.csv");
    let text = std::fs::read_to_string(&s2).unwrap();
    let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    let f1 = header.iter().position(|h| *h == "macro_f1").unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let mut cells: Vec<&str> = lines[1].split(',').collect();
    cells[f1] = "NaN";
    lines[1] = cells.join(",");
    std::fs::write(&s2, lines.join("\n") + "\n").unwrap();
    let err = fails(&merge(&["parts/s1.csv", "parts/s2.csv", "parts/s3.csv"]));
    assert!(
        err.contains("parts/s2.csv") && err.contains("row 1") && err.contains("macro_f1"),
        "{err}"
    );
    // and so is a provenance whose numbers no sweep writes
    std::fs::write(&s2, text).unwrap();
    let meta = d.join("parts/s3.json");
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&meta).unwrap()).unwrap();
    v["wall_seconds"] = serde_json::json!(-5.0);
    std::fs::write(&meta, v.to_string()).unwrap();
    let err = fails(&merge(&["parts/s1.csv", "parts/s2.csv", "parts/s3.csv"]));
    assert!(
        err.contains("s3.json") && err.contains("wall_seconds"),
        "{err}"
    );
}

/// A stand-in for Slurm's `sbatch`: runs each job at once, array tasks one after another,
/// with the environment Slurm gives them.
const FAKE_SBATCH: &str = r#"#!/usr/bin/env bash
set -euo pipefail
array="" wrap="" script=""
for a in "$@"; do
  case "$a" in
    --array=*) array="${a#--array=}";;
    --wrap=*) wrap="${a#--wrap=}";;
    --*) ;;
    *) script="$a";;
  esac
done
echo "$*" >> sbatch.calls
if [[ -n "$wrap" ]]; then bash -c "$wrap" >&2; echo 2; exit; fi
lo="${array%-*}"; hi="${array#*-}"
for k in $(seq "$lo" "$hi"); do
  SLURM_ARRAY_TASK_ID=$k SLURM_ARRAY_TASK_COUNT=$((hi - lo + 1)) bash "$script" >&2
done
echo 1
"#;

#[test]
fn the_slurm_scripts_run_an_array_of_shards_then_the_merge() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    collect(d, "8", "trials", "5");
    collect(d, "8", "test", "6");
    std::fs::create_dir(d.join("bin")).unwrap();
    let sbatch = d.join("bin/sbatch");
    std::fs::write(&sbatch, FAKE_SBATCH).unwrap();
    std::process::Command::new("chmod")
        .args(["+x", sbatch.to_str().unwrap()])
        .status()
        .unwrap();
    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/scripts/slurm/submit-sweep.sh");
    let path = format!(
        "{}:{}",
        d.join("bin").display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let out = std::process::Command::new("bash")
        .arg(script)
        .current_dir(d)
        .env("PATH", path)
        .env("SHARDS", "2")
        .env("TMO", env!("CARGO_BIN_EXE_tmo"))
        .env("TRIALS", "trials")
        .env("TEST", "test")
        .env("OUT", "res/sweep.csv")
        .env(
            "SWEEP_ARGS",
            "--classifiers logreg,threshold --downsample 0.5,1.0 --n-slip 3:4 --C 1",
        )
        .output()
        .unwrap();
    let stdout = ok(&out);
    assert!(
        stdout.contains("queued shards as job 1 (array 1-2)"),
        "{stdout}"
    );
    let calls = std::fs::read_to_string(d.join("sbatch.calls")).unwrap();
    assert!(calls.contains("--dependency=afterok:1"), "{calls}");
    assert_eq!(csv_rows(&d.join("res/sweep.csv")), 8);
    assert!(d.join("res/shard-2-of-2.csv").exists());
    assert!(d.join("res/sweep_fig5_f1_logreg.png").exists());
    assert!(!d.join("res/shard-1-of-2_fig5_f1_logreg.png").exists());
}

#[test]
fn a_sweep_fills_its_grid_and_resumes_after_an_interruption() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    collect(d, "8", "trials", "5");
    let fixed = [
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
    let sweep = |extra: &[&str]| sweep_trials(d, &fixed, extra);
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

    // A searched sweep's resume refits the finished cells at the points their rows record
    // (read back to the bit), so the rest start as they did in one run.
    let search = [
        "--classifiers",
        "logreg",
        "--downsample",
        "1.0",
        "--n-slip",
        "3:5",
        "--search",
        "bayes",
        "--iters",
        "3",
        "--folds",
        "2",
        "--out",
        "s/sweep.csv",
    ];
    let searched = |extra: &[&str]| sweep_trials(d, &search, extra);
    ok(&searched(&[]));
    let full = std::fs::read_to_string(d.join("s/sweep.csv")).unwrap();
    let partial: Vec<&str> = full.lines().take(3).collect();
    std::fs::write(d.join("s/sweep.csv.partial"), partial.join("\n") + "\n").unwrap();
    std::fs::remove_file(d.join("s/sweep.csv")).unwrap();
    let stdout = ok(&searched(&["--resume"]));
    assert!(
        stdout.contains("1 cells to run (2 already done)"),
        "{stdout}"
    );
    assert_eq!(
        strip_seconds(&std::fs::read_to_string(d.join("s/sweep.csv")).unwrap()),
        strip_seconds(&full)
    );

    // Held-out folds scored on down-sampled rows: a resume of the every-row sweep with
    // them is refused, and a run of its own names them in its provenance.
    std::fs::write(d.join("s/sweep.csv.partial"), partial.join("\n") + "\n").unwrap();
    std::fs::remove_file(d.join("s/sweep.csv")).unwrap();
    let err = fails(&searched(&["--resume", "--held-out-rows", "downsampled"]));
    assert!(
        err.contains("different sweep") && err.contains("Downsampled"),
        "{err}"
    );
    std::fs::remove_file(d.join("s/sweep.csv.partial")).unwrap();
    ok(&searched(&["--held-out-rows", "downsampled"]));
    let provenance = std::fs::read_to_string(d.join("s/sweep.json")).unwrap();
    assert!(provenance.contains("down-sampled by d"), "{provenance}");
    let err = fails(&searched(&["--held-out-rows", "some"]));
    assert!(err.contains("--held-out-rows"), "{err}");
}

/// `tmo sweep trials` with the grid's arguments, then `extra`.
fn sweep_trials(d: &Path, grid: &[&str], extra: &[&str]) -> std::process::Output {
    let mut args = vec!["sweep", "trials"];
    args.extend_from_slice(grid);
    args.extend_from_slice(extra);
    tmo(d, &args)
}

/// Issue 41, C-c and C-d: a trial path that is a device or a pipe is refused at once, not
/// read until memory runs out (`/dev/zero`) or for ever (a FIFO named `*.mcap`).
#[test]
fn trial_paths_that_are_not_files_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let e = fails(&tmo(d, &["train", "/dev/zero", "--out", "m.json"]));
    assert!(e.contains("/dev/zero: a device"), "{e}");
    std::os::unix::fs::symlink("/dev/zero", d.join("zero.mcap")).unwrap();
    let e = fails(&tmo(
        d,
        &["dataset", "export", "zero.mcap", "--out", "f.csv"],
    ));
    assert!(e.contains("zero.mcap: a device"), "{e}");
    std::fs::create_dir(d.join("trials")).unwrap();
    let made = std::process::Command::new("mkfifo")
        .arg(d.join("trials/t.mcap"))
        .status()
        .unwrap();
    assert!(made.success());
    let e = fails(&tmo(d, &["train", "trials", "--out", "m.json"]));
    assert!(e.contains("t.mcap: a named pipe"), "{e}");
}

/// Issue 41, item 13: `train --out` takes the output lock, as `run`, `sweep` and
/// `reproduce` do: a second writer of the same model file is refused while the first runs.
#[test]
fn a_model_file_has_one_writer() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // a live tmo (a served simulator) stands in for a first training of m.json
    let mut first = std::process::Command::new(env!("CARGO_BIN_EXE_tmo"))
        .current_dir(d)
        .args(["sim", "serve", "--hardware"])
        .arg(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("hardware/tmo.toml"))
        .args(["--out", "served.toml", "--for", "60"])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    // until it has exec'd, the child bears this test thread's name, not tmo's
    let comm = format!("/proc/{}/comm", first.id());
    for _ in 0..500 {
        if std::fs::read_to_string(&comm).is_ok_and(|c| c.trim() == "tmo") {
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    std::fs::write(d.join("m.json.lock"), first.id().to_string()).unwrap();
    let e = fails(&tmo(d, &["train", "nowhere", "--out", "m.json"]));
    assert!(e.contains("another tmo"), "{e}");
    first.kill().unwrap();
    first.wait().unwrap();
    // its writer gone, the lock is taken over (and the missing trials are the error)
    let e = fails(&tmo(d, &["train", "nowhere", "--out", "m.json"]));
    assert!(e.contains("nowhere") && !e.contains("another tmo"), "{e}");
}

/// Issue 41, item 13: Ctrl-C during a sweep starts no more cells, keeps every finished one
/// and exits 130 with the way on; `--resume` finishes the grid.
#[test]
fn ctrl_c_stops_a_sweep_that_resumes() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    collect(d, "8", "trials", "5");
    let grid = [
        "sweep",
        "trials",
        "--classifiers",
        "logreg",
        "--downsample",
        "0.2:1.0:0.1",
        "--n-slip",
        "1:15",
        "--search",
        "bayes",
        "--iters",
        "4",
        "--folds",
        "2",
        "--out",
        "s/sweep.csv",
    ];
    let child = std::process::Command::new(env!("CARGO_BIN_EXE_tmo"))
        .current_dir(d)
        .args(grid)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let partial = d.join("s/sweep.csv.partial");
    let started = std::time::Instant::now();
    while std::fs::read_to_string(&partial).map_or(0, |t| t.lines().count()) < 3 {
        assert!(started.elapsed().as_secs() < 120, "no cells finished");
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    unsafe {
        libc::kill(child.id() as i32, libc::SIGINT);
    }
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(130), "{err}");
    assert!(
        err.contains("interrupted") && err.contains("--resume"),
        "{err}"
    );
    let kept = std::fs::read_to_string(&partial).unwrap().lines().count();
    assert!(kept >= 3 && !d.join("s/sweep.csv").exists(), "{kept}");
    let mut resume = grid.to_vec();
    resume.push("--resume");
    let stdout = ok(&tmo(d, &resume));
    assert!(stdout.contains("already done"), "{stdout}");
    assert_eq!(csv_rows(&d.join("s/sweep.csv")), 9 * 15);
}
