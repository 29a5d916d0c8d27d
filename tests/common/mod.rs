//! Running the real `tmo` binary from integration tests.

#![allow(dead_code)] // each test file uses its own subset

pub mod live;
pub mod logs;
pub mod slow_model;

use std::path::Path;
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

/// Runs `tmo args...` in `dir`.
pub fn tmo(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_tmo"))
        .current_dir(dir)
        .args(args)
        .output()
        .expect("tmo runs")
}

/// Runs `tmo` in `dir` `n` times side by side, as a cluster's jobs run a plan's shards,
/// run `k` (1..=n) with the arguments `args_of(k)`: the outputs in the order of `k`.
pub fn tmo_side_by_side(
    dir: &Path,
    n: u32,
    args_of: impl Fn(u32) -> Vec<String> + Sync,
) -> Vec<Output> {
    let args_of = &args_of;
    std::thread::scope(|scope| {
        let running: Vec<_> = (1..=n)
            .map(|k| {
                scope.spawn(move || {
                    let args = args_of(k);
                    let args: Vec<&str> = args.iter().map(String::as_str).collect();
                    tmo(dir, &args)
                })
            })
            .collect();
        running
            .into_iter()
            .map(|run| run.join().expect("tmo ran"))
            .collect()
    })
}

/// `args` as owned strings (for `tmo_side_by_side`).
pub fn owned(args: &[&str]) -> Vec<String> {
    args.iter().map(|a| a.to_string()).collect()
}

/// Starts `tmo args...` in `dir`, its stdout dropped and its stderr piped (where a live
/// view says its address and notes go).
pub fn spawn_tmo(dir: &Path, args: &[&str]) -> Child {
    Command::new(env!("CARGO_BIN_EXE_tmo"))
        .current_dir(dir)
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("tmo starts")
}

/// Stdout of a run that must succeed (both streams shown if it did not).
pub fn ok(out: &Output) -> String {
    assert!(
        out.status.success(),
        "{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// Stderr of a run that must fail with exit code 2.
pub fn fails(out: &Output) -> String {
    assert_eq!(out.status.code(), Some(2), "{out:?}");
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Collects trials on the simulator into `d/trials_dir` (`collect` adds to `tmo sim collect`,
/// e.g. the trial count and seed) and trains a logistic-regression model on them as `d/model`:
/// a quick model for tests of what runs on top of one.
pub fn collect_and_train(d: &Path, collect: &[&str], trials_dir: &str, model: &str) {
    let mut args = vec!["sim", "collect"];
    args.extend_from_slice(collect);
    args.extend_from_slice(&["--out", trials_dir]);
    ok(&tmo(d, &args));
    ok(&tmo(
        d,
        &[
            "train",
            trials_dir,
            "--classifier",
            "logreg",
            "--C",
            "1",
            "--n-slip",
            "5",
            "--out",
            model,
        ],
    ));
}

/// A process the test started (`tmo sim serve`), stopped when the test ends however it ends.
pub struct Server(pub Child);

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// `tmo run PROTOCOL --backend real --hardware served.toml --out OUT` plus `extra`, in `d`
/// (beside a [`serve_sim`]).
pub fn run_real(d: &Path, protocol: &str, out: &str, extra: &[&str]) -> Output {
    let mut args = vec![
        "run",
        protocol,
        "--backend",
        "real",
        "--hardware",
        "served.toml",
        "--out",
        out,
    ];
    args.extend_from_slice(extra);
    tmo(d, &args)
}

/// A `[deadline]` for protocols run against the served simulator by tests of something
/// else than the loop's pace: tests share this machine, and a starved runner is no fault of
/// the backend under test (the contract itself: tests/cli_deadline.rs).
pub const LOOSE_DEADLINE: &str = "\n[deadline]\nlimit_periods = 600.0\nmax_late_share = 1.0\n";

/// `tmo sim serve --hardware hardware/tmo.toml --out served.toml` in `d` (plus `extra`),
/// once its served hardware file is written. A loaded CI machine can starve the emulator's
/// real-time loop for a few hundred ms, which real cameras do not do: the served file's
/// watchdog is given room.
pub fn serve_sim(d: &Path, extra: &[&str]) -> Server {
    let hw = Path::new(env!("CARGO_MANIFEST_DIR")).join("hardware/tmo.toml");
    let server = Server(
        Command::new(env!("CARGO_BIN_EXE_tmo"))
            .current_dir(d)
            .args(["sim", "serve", "--hardware"])
            .arg(&hw)
            .args(["--out", "served.toml", "--for", "300"])
            .args(extra)
            .stdout(Stdio::null())
            .spawn()
            .unwrap(),
    );
    let deadline = Instant::now() + Duration::from_secs(20);
    while !d.join("served.toml").exists() && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(20));
    }
    let served = std::fs::read_to_string(d.join("served.toml")).unwrap();
    std::fs::write(
        d.join("served.toml"),
        served.replace("silent_limit_s = 0.25", "silent_limit_s = 2.0"),
    )
    .unwrap();
    server
}
