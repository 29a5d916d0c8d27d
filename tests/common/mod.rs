//! Running the real `tmo` binary from integration tests.

#![allow(dead_code)] // each test file uses its own subset

use std::path::Path;
use std::process::{Child, Command, Output};

/// Runs `tmo args...` in `dir`.
pub fn tmo(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_tmo"))
        .current_dir(dir)
        .args(args)
        .output()
        .expect("tmo runs")
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
