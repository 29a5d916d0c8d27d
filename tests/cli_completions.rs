//! `tmo completions SHELL`: completion scripts generated from the command line's own
//! definition, so they list every subcommand and option as they are.

mod common;

use common::{ok, tmo};

#[test]
fn completion_scripts_name_every_subcommand_and_bash_reads_its_own() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for shell in ["bash", "zsh", "fish", "elvish", "powershell"] {
        let script = ok(&tmo(d, &["completions", shell]));
        for sub in [
            "reproduce",
            "import",
            "train",
            "sweep",
            "replay",
            "n-slip-s",
        ] {
            assert!(script.contains(sub), "{shell} script lacks {sub}");
        }
    }
    let script = ok(&tmo(d, &["completions", "bash"]));
    std::fs::write(d.join("tmo.bash"), script).unwrap();
    let check = std::process::Command::new("bash")
        .args(["-n", "tmo.bash"])
        .current_dir(d)
        .output()
        .unwrap();
    assert!(check.status.success(), "{check:?}");
    let e = tmo(d, &["completions", "tcsh"]);
    assert_eq!(
        e.status.code(),
        Some(2),
        "an unknown shell is a usage error"
    );
}

#[test]
fn help_lists_the_subcommands_in_the_order_of_the_work() {
    let dir = tempfile::tempdir().unwrap();
    let help = ok(&tmo(dir.path(), &["--help"]));
    let at = |name: &str| {
        help.find(&format!("\n  {name} "))
            .unwrap_or_else(|| panic!("{name} missing from\n{help}"))
    };
    let order = [
        "sim",
        "import",
        "dataset",
        "train",
        "evaluate",
        "sweep",
        "run",
        "replay",
        "report",
        "reproduce",
    ];
    for pair in order.windows(2) {
        assert!(at(pair[0]) < at(pair[1]), "{} after {}", pair[0], pair[1]);
    }
}

#[test]
fn the_mock_backend_is_named_in_the_help_it_is_accepted_by() {
    let dir = tempfile::tempdir().unwrap();
    let help = ok(&tmo(dir.path(), &["run", "--help"]));
    assert!(help.contains("`mock` is another name for it"), "{help}");
}

#[test]
fn a_failing_standard_output_is_an_error_not_a_panic() {
    // `> /dev/full`: every write fails with "no space left on device".
    let dir = tempfile::tempdir().unwrap();
    for args in [&["completions", "bash"][..], &["sim", "objects"][..]] {
        let full = std::fs::OpenOptions::new()
            .write(true)
            .open("/dev/full")
            .unwrap();
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_tmo"))
            .current_dir(dir.path())
            .args(args)
            .stdout(full)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(
            stderr.contains("cannot write to standard output") && !stderr.contains("panicked"),
            "{args:?}: {stderr}"
        );
    }
}
