//! The vendors' own client libraries against `tmo sim serve` (issue 7): ROBOTIS
//! DynamixelSDK on the served bus, SDU's ur_rtde on the served UR controller (with a raw
//! URScript line on its secondary interface), pyserial on the JeVois streams. What each
//! does is in `scripts/vendor_clients.py`; `scripts/vendor-env.sh` installs them (pinned in
//! `scripts/vendor-requirements.txt`) into `target/vendor-venv`.

mod common;

use std::path::Path;
use std::process::Command;

#[test]
fn vendor_clients_drive_the_served_simulator() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let env = Command::new("bash")
        .arg(root.join("scripts/vendor-env.sh"))
        .output()
        .unwrap();
    assert!(
        env.status.success(),
        "scripts/vendor-env.sh: {}",
        String::from_utf8_lossy(&env.stderr)
    );
    let python = String::from_utf8(env.stdout).unwrap().trim().to_string();

    let dir = tempfile::tempdir().unwrap();
    let served = dir.path().join("served.toml");
    // ur_rtde always dials port 30004: the controller gets a loopback address of its own,
    // picked from the process id so that two test runs on one machine do not collide.
    let pid = std::process::id();
    let address = format!("127.77.{}.{}", (pid >> 8) & 0xff, (pid & 0xff).max(1));
    let _server = common::serve_sim(dir.path(), &["--ur-address", &address]);
    let out = Command::new(&python)
        .arg(root.join("scripts/vendor_clients.py"))
        .arg(&served)
        .output()
        .unwrap();
    let text =
        String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{text}");
    for client in ["jevois:", "dynamixel:", "ur_rtde:"] {
        assert!(text.contains(client), "{text}");
    }
}
