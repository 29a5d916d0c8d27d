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
