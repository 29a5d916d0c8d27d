//! `hardware.toml`: where the real rig's devices are and how they are set up. Parsed
//! into serde structs that reject unknown fields, then checked; errors name the file, line,
//! column and field, as protocol errors do.

use std::path::Path;

use serde::Deserialize;

use crate::protocol::{field_span, line_column, parse_toml, ProtocolError, SafetyLimits};

/// Errors of hardware files have the protocol files' shape: `file:line:column: field: ...`.
pub type HardwareError = ProtocolError;

/// A serial port.
#[derive(Debug, Clone, PartialEq, Eq, Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct SerialPort {
    pub port: String,
    pub baud: u32,
}

#[derive(Debug, Clone, PartialEq, Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct Cameras {
    /// One per fingertip, in sensor order (thumb first).
    pub fingertips: Vec<SerialPort>,
    /// Pins each fingertip camera reports (`F2 ... <n>`).
    #[serde(default = "default_pins")]
    pub pins: usize,
    /// A camera silent this long is a fault, s.
    #[serde(default = "default_silent")]
    pub silent_limit_s: f64,
    /// The cameras' frame rate, Hz: what the online loop's deadline is counted in (a
    /// JeVois tracking pins runs at 60 fps).
    #[serde(default = "default_frame_rate")]
    pub frame_rate_hz: f64,
}

fn default_frame_rate() -> f64 {
    tmo_hal::TMO_FRAME_RATE_HZ
}

fn default_pins() -> usize {
    tmo_hal::TMO_PINS_PER_SENSOR
}

fn default_silent() -> f64 {
    0.25
}

#[derive(Debug, Clone, PartialEq, Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct MarkerCamera {
    pub port: String,
    pub baud: u32,
    /// ArUco ids (as DemoArUco names them, e.g. `U42`) on the object and on the hand.
    pub object_marker: String,
    pub hand_marker: String,
}

/// The OpenHand Model O's Dynamixel bus, as its driver sets it up.
#[derive(Debug, Clone, PartialEq, Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct HandBus {
    pub port: String,
    pub baud: u32,
    /// Servo ids: the three fingers (thumb first), then the thumb's rotation.
    #[serde(deserialize_with = "crate::protocol::exact::exactly")]
    pub ids: [u8; 4],
    /// +1 or -1: which way each servo turns to close.
    #[serde(deserialize_with = "crate::protocol::exact::exactly")]
    pub directions: [i8; 4],
    /// Encoder counts at open (0) and at closed (1) for each servo.
    #[serde(deserialize_with = "crate::protocol::exact::exactly")]
    pub min: [u32; 4],
    #[serde(deserialize_with = "crate::protocol::exact::exactly")]
    pub max: [u32; 4],
    /// Encoder counts per revolution (4096 for the X series).
    #[serde(default = "default_encoder")]
    pub encoder_range: u32,
    /// Current limit written at start, mA.
    pub current_limit_ma: u32,
    /// The speed protocol speeds are fractions of, fraction of the range per s: the paper's
    /// "maximum finger movement speed", of which its release (0.5 %) is ~0.07 rad/s at the
    /// servo. Not the motor's limit, which the servo keeps itself.
    #[serde(default = "default_hand_speed")]
    pub max_speed_per_s: f64,
}

fn default_hand_speed() -> f64 {
    // The paper's release, ~0.07 rad/s at the servo, is 0.5 % of its maximum; a Model O
    // finger spans 0.7 turn of its servo (4.40 rad, the OpenHand driver's max_close), so
    // the maximum is 0.07 / 0.005 / 4.40 = 3.18 ranges a second. The simulator's
    // servo.reference_speed_per_s is the same value (sim/data/parameters.toml).
    3.18
}

fn default_encoder() -> u32 {
    4096
}

#[derive(Debug, Clone, PartialEq, Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct ArmHost {
    pub host: String,
    #[serde(default = "default_rtde_port")]
    pub rtde_port: u16,
    /// The secondary interface, where URScript lines go.
    #[serde(default = "default_script_port")]
    pub script_port: u16,
    /// RTDE output rate: 125 (CB3) or 500 (e-Series), Hz.
    #[serde(default = "default_frequency")]
    pub frequency_hz: u32,
}

fn default_rtde_port() -> u16 {
    30004
}

fn default_script_port() -> u16 {
    30002
}

fn default_frequency() -> u32 {
    125
}

#[derive(Debug, Clone, PartialEq, Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct HardwareFile {
    pub cameras: Cameras,
    pub marker_camera: MarkerCamera,
    pub hand: HandBus,
    pub arm: ArmHost,
    #[serde(default)]
    pub safety: SafetyLimits,
    /// Written by `tmo sim serve` only: the rig is the simulator, which sets each trial up
    /// itself (see [`ServedSimulator`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub served_simulator: Option<ServedSimulator>,
    /// The file as read, kept in every trial log the rig records.
    #[serde(skip)]
    pub source: Option<crate::trial::SourceFile>,
}

/// The served simulator's control port: between trials a batch sends it the next trial's
/// world (object, grasp, mass) where on hardware an operator sets the rig up.
#[derive(Debug, Clone, PartialEq, Eq, Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct ServedSimulator {
    /// `host:port` on loopback.
    pub control: String,
}

/// Baud rates the JeVois and Dynamixel ports are used at.
const BAUDS: [u32; 9] = [
    9600, 57600, 115200, 230400, 460800, 921600, 1000000, 2000000, 3000000,
];

impl HardwareFile {
    /// The first problem: (dotted field, what was expected).
    fn check(&self) -> Result<(), (String, String)> {
        let err = |f: &str, m: String| Err((f.to_string(), m));
        if !matches!(self.cameras.fingertips.len(), 1 | 3) {
            return err(
                "cameras.fingertips",
                format!(
                    "expected 3 fingertip cameras (thumb, then the two fingers), or 1 for the single-finger rail rig, got {}",
                    self.cameras.fingertips.len()
                ),
            );
        }
        let mut ports: Vec<(String, &str)> = Vec::new();
        for (i, c) in self.cameras.fingertips.iter().enumerate() {
            ports.push((format!("cameras.fingertips.{i}"), &c.port));
            if !BAUDS.contains(&c.baud) {
                return err(
                    &format!("cameras.fingertips.{i}"),
                    format!("baud {} is not one of {BAUDS:?}", c.baud),
                );
            }
        }
        ports.push(("marker_camera.port".into(), &self.marker_camera.port));
        ports.push(("hand.port".into(), &self.hand.port));
        for (i, (field, p)) in ports.iter().enumerate() {
            if p.trim().is_empty() {
                return err(
                    field,
                    "expected a serial port path, got an empty string".into(),
                );
            }
            if let Some((other, _)) = ports[..i].iter().find(|(_, q)| q == p) {
                return err(field, format!("port {p} is already used by {other}"));
            }
        }
        if !(1..=64).contains(&self.cameras.pins) {
            return err(
                "cameras.pins",
                format!("expected 1..=64 pins, got {}", self.cameras.pins),
            );
        }
        if !(0.02..=5.0).contains(&self.cameras.silent_limit_s) {
            return err(
                "cameras.silent_limit_s",
                format!("expected 0.02..=5 s, got {}", self.cameras.silent_limit_s),
            );
        }
        if !(1.0..=1000.0).contains(&self.cameras.frame_rate_hz) {
            return err(
                "cameras.frame_rate_hz",
                format!(
                    "expected 1..=1000 Hz, got {}",
                    crate::quote::number(self.cameras.frame_rate_hz)
                ),
            );
        }
        for (field, b) in [
            ("marker_camera.baud", self.marker_camera.baud),
            ("hand.baud", self.hand.baud),
        ] {
            if !BAUDS.contains(&b) {
                return err(field, format!("baud {b} is not one of {BAUDS:?}"));
            }
        }
        for (field, id) in [
            (
                "marker_camera.object_marker",
                &self.marker_camera.object_marker,
            ),
            ("marker_camera.hand_marker", &self.marker_camera.hand_marker),
        ] {
            if id.trim().is_empty() {
                return err(
                    field,
                    "expected the marker's id as DemoArUco reports it (e.g. \"U42\")".into(),
                );
            }
        }
        if self.marker_camera.object_marker == self.marker_camera.hand_marker {
            return err(
                "marker_camera.hand_marker",
                "expected a different marker from the object's".into(),
            );
        }
        let h = &self.hand;
        for (i, id) in h.ids.iter().enumerate() {
            if *id > 252 {
                return err(
                    &format!("hand.ids.{i}"),
                    format!("expected a Dynamixel id 0..=252, got {id}"),
                );
            }
            if h.ids[..i].contains(id) {
                return err(&format!("hand.ids.{i}"), format!("id {id} appears twice"));
            }
            if !matches!(h.directions[i], 1 | -1) {
                return err(
                    &format!("hand.directions.{i}"),
                    format!("expected 1 or -1, got {}", h.directions[i]),
                );
            }
            if h.min[i] >= h.encoder_range || h.max[i] >= h.encoder_range {
                let which = if h.min[i] >= h.encoder_range {
                    "min"
                } else {
                    "max"
                };
                return err(
                    &format!("hand.{which}.{i}"),
                    format!(
                        "expected encoder counts below hand.encoder_range ({})",
                        h.encoder_range
                    ),
                );
            }
            if h.min[i] == h.max[i] {
                return err(
                    &format!("hand.max.{i}"),
                    "expected max to differ from min".into(),
                );
            }
        }
        if !(0.05..=20.0).contains(&h.max_speed_per_s) {
            return err(
                "hand.max_speed_per_s",
                format!(
                    "expected 0.05..=20 (fraction of the range per s), got {}",
                    h.max_speed_per_s
                ),
            );
        }
        if !(1..=6000).contains(&h.current_limit_ma) {
            return err(
                "hand.current_limit_ma",
                format!("expected 1..=6000 mA, got {}", h.current_limit_ma),
            );
        }
        if !is_host(&self.arm.host) {
            return err(
                "arm.host",
                format!(
                    "expected the UR controller's address (an IP address or host name), got {:?}",
                    self.arm.host
                ),
            );
        }
        for (field, port) in [
            ("arm.rtde_port", self.arm.rtde_port),
            ("arm.script_port", self.arm.script_port),
        ] {
            if port == 0 {
                return err(field, "expected a TCP port 1..=65535, got 0".into());
            }
        }
        if self.arm.rtde_port == self.arm.script_port {
            return err(
                "arm.script_port",
                format!(
                    "expected a different port from arm.rtde_port ({}): RTDE and URScript are separate interfaces",
                    self.arm.rtde_port
                ),
            );
        }
        if let Some(served) = &self.served_simulator {
            let ok = served.control.rsplit_once(':').is_some_and(|(host, port)| {
                is_host(host) && port.parse::<u16>().is_ok_and(|p| p > 0)
            });
            if !ok {
                return err(
                    "served_simulator.control",
                    format!(
                        "expected host:port of `tmo sim serve`'s control port (e.g. \"127.0.0.1:30010\"), got {:?}",
                        served.control
                    ),
                );
            }
        }
        if !matches!(self.arm.frequency_hz, 125 | 500) {
            return err(
                "arm.frequency_hz",
                format!(
                    "expected 125 (CB3) or 500 (e-Series), got {}",
                    self.arm.frequency_hz
                ),
            );
        }
        self.safety
            .check()
            .map_err(|(s, f, m)| (format!("{s}.{f}"), m))
    }
}

/// An IP address or a host name (letters, digits, `-` and `.`; no spaces).
fn is_host(host: &str) -> bool {
    host.parse::<std::net::IpAddr>().is_ok()
        || (!host.is_empty()
            && host.len() <= 253
            && host.split('.').all(|label| {
                !label.is_empty()
                    && label.len() <= 63
                    && !label.starts_with('-')
                    && !label.ends_with('-')
                    && label.chars().all(|c| c.is_ascii_alphanumeric() || c == '-')
            }))
}

/// Reads, parses and checks a hardware file.
pub fn load(path: &Path) -> Result<HardwareFile, HardwareError> {
    let text = std::fs::read_to_string(path).map_err(|e| ProtocolError::unreadable(path, &e))?;
    parse(path, &text)
}

pub fn parse(path: &Path, text: &str) -> Result<HardwareFile, HardwareError> {
    let mut file: HardwareFile = parse_toml(path, text)?;
    file.source = Some(crate::trial::SourceFile::new("hardware", path, text));
    file.check().map_err(|(field, message)| {
        let (line, column) =
            field_span(text, &field).map_or((1, 1), |s| line_column(text, s.start));
        ProtocolError {
            path: path.to_path_buf(),
            line,
            column,
            field,
            message,
        }
    })?;
    Ok(file)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn example() -> String {
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("hardware/tmo.toml"))
            .unwrap()
    }

    fn check(text: &str) -> Result<HardwareFile, HardwareError> {
        parse(Path::new("hw.toml"), text)
    }

    #[test]
    fn the_example_is_valid() {
        let hw = check(&example()).unwrap();
        assert_eq!(hw.cameras.fingertips.len(), 3);
        assert_eq!(hw.arm.rtde_port, 30004);
        assert_eq!(hw.safety.max_grip, 0.95);
    }

    #[test]
    fn addresses_ports_and_marker_ids_must_be_usable() {
        let cases = [
            (
                "host = \"192.168.1.10\"",
                "host = \"not a host!!\"",
                "arm.host",
            ),
            ("rtde_port = 30004", "rtde_port = 0", "arm.rtde_port"),
            (
                "script_port = 30002",
                "script_port = 30004",
                "arm.script_port",
            ),
            (
                "object_marker = \"U42\"",
                "object_marker = \"\"",
                "marker_camera.object_marker",
            ),
            ("min = [1200,", "min = [9000,", "hand.min.0"),
        ];
        for (good, bad, field) in cases {
            let text = example().replace(good, bad);
            assert_ne!(text, example(), "{good}");
            let e = check(&text).unwrap_err();
            assert_eq!(e.field, field, "{e}");
        }
        let served = format!("{}\n[served_simulator]\ncontrol = \"garbage\"\n", example());
        assert_eq!(
            check(&served).unwrap_err().field,
            "served_simulator.control"
        );
        let served = format!(
            "{}\n[served_simulator]\ncontrol = \"127.0.0.1:30010\"\n",
            example()
        );
        check(&served).unwrap();
        let named = example().replace("host = \"192.168.1.10\"", "host = \"ur5.lab-2.local\"");
        check(&named).unwrap();
    }

    #[test]
    fn mistakes_are_named_with_their_place() {
        let bad = example().replace("frequency_hz = 125", "frequency_hz = 200");
        let e = check(&bad).unwrap_err();
        assert_eq!(e.field, "arm.frequency_hz", "{e}");
        assert!(e.message.contains("125"), "{e}");
        assert!(e.line > 1, "{e}");

        let bad = example().replace("ids = [1, 2, 3, 4]", "ids = [1, 2, 2, 4]");
        let e = check(&bad).unwrap_err();
        assert_eq!(e.field, "hand.ids.2", "{e}");

        let bad = example().replace("baud = 57600", "baud = 12345");
        assert_eq!(check(&bad).unwrap_err().field, "hand.baud");

        let bad = example().replace("[arm]", "[arm]\nspeed = 3");
        let e = check(&bad).unwrap_err();
        assert!(e.message.contains("speed"), "{e}");

        let bad = example().replace("/dev/ttyACM3", "/dev/ttyACM0");
        let e = check(&bad).unwrap_err();
        assert_eq!(e.field, "marker_camera.port", "{e}");
        assert!(e.message.contains("cameras.fingertips.0"), "{e}");

        let bad = example().replace("max_grip = 0.95", "max_grip = 2.0");
        assert_eq!(check(&bad).unwrap_err().field, "safety.max_grip");
    }
}
