//! `tmo hardware check`: a valid file is summarised, a bad one named with its line.

mod common;

use std::path::Path;

#[test]
fn the_example_hardware_file_checks_and_a_broken_one_says_where() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let example = Path::new(env!("CARGO_MANIFEST_DIR")).join("hardware/tmo.toml");
    let text = std::fs::read_to_string(&example).unwrap();
    std::fs::write(d.join("rig.toml"), &text).unwrap();
    let out = common::ok(&common::tmo(d, &["hardware", "check", "rig.toml"]));
    assert!(out.contains("rig.toml: valid"), "{out}");
    assert!(out.contains("an operator sets the rig up"), "{out}");

    let broken = text.replacen("frequency_hz = 125", "frequency_hz = 200", 1);
    assert_ne!(broken, text, "the example sets frequency_hz = 125");
    std::fs::write(d.join("bad.toml"), &broken).unwrap();
    let err = common::fails(&common::tmo(d, &["hardware", "check", "bad.toml"]));
    let line = text
        .lines()
        .position(|l| l.starts_with("frequency_hz"))
        .unwrap()
        + 1;
    assert!(
        err.contains(&format!("bad.toml:{line}:")) && err.contains("arm.frequency_hz"),
        "{err}"
    );
    assert!(
        err.contains("expected 125 (CB3) or 500 (e-Series), got 200"),
        "{err}"
    );
}
