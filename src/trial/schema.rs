//! What each channel of a trial log carries: the JSON schema written beside its messages,
//! and the tactile frame's shape on the wire.
//!
//! Format 2 stores a frame's pins as two arrays `x[]` and `y[]` (Foxglove's message paths
//! take one index per field, so `/tactile/0.x[12]` plots pin 12) and gives every event
//! channel a schema that names its fields and their types. Format 1 stored pins as
//! `[[x, y], ...]` and every event as an untyped `data: {}`; readers still take both.

use serde::{Deserialize, Serialize};
use tmo_hal::PinFrame;

pub const PIN_FRAME: (&str, &str) = (
    "tmo.PinFrame",
    r#"{"title":"tmo.PinFrame","description":"Pin centres of one tactile frame, image pixels, in the sensor's fixed pin order","type":"object","properties":{"sensor":{"type":"integer","minimum":0},"seq":{"type":"integer","minimum":0,"description":"the sensor's own frame counter"},"time_s":{"type":"number","description":"capture time on the trial clock, s"},"x":{"type":"array","items":{"type":"number"},"description":"px"},"y":{"type":"array","items":{"type":"number"},"description":"px"}},"required":["sensor","seq","time_s","x","y"],"additionalProperties":false}"#,
);

pub const MARKER: (&str, &str) = (
    "tmo.MarkerSample",
    r#"{"title":"tmo.MarkerSample","description":"Heights of the object's and the hand's markers","type":"object","properties":{"time_s":{"type":"number","description":"trial clock, s"},"object_mm":{"type":"number"},"hand_mm":{"type":"number"}},"required":["time_s","object_mm","hand_mm"],"additionalProperties":false}"#,
);

/// An event's body: `{ "time_s": ..., "data": { <fields> } }`.
fn event_schema(title: &str, description: &str, data: &str) -> String {
    format!(
        r#"{{"title":"{title}","description":"{description}","type":"object","properties":{{"time_s":{{"type":"number","description":"trial clock, s"}},"data":{data}}},"required":["time_s","data"],"additionalProperties":false}}"#
    )
}

const NUMBER: &str = r#"{"type":"number"}"#;

/// The schema name and JSON schema of the event channel `topic`.
pub fn event_channel_schema(topic: &str) -> (&'static str, String) {
    let vec = |n: usize, unit: &str| {
        format!(
            r#"{{"type":"array","items":{NUMBER},"minItems":{n},"maxItems":{n},"description":"{unit}"}}"#
        )
    };
    match topic {
        "/phase" => (
            "tmo.Phase",
            event_schema(
                "tmo.Phase",
                "The protocol's phase from this time on; some phases carry their parameters",
                r#"{"type":"object","properties":{"phase":{"type":"string"}},"required":["phase"]}"#,
            ),
        ),
        "/command/hand" => (
            "tmo.HandCommand",
            event_schema(
                "tmo.HandCommand",
                "A command sent to the hand's servos",
                &format!(
                    r#"{{"type":"object","properties":{{"targets":{},"torque_limit":{{"type":"number","minimum":0,"maximum":1,"description":"fraction of the servos' maximum"}},"ramp_to":{{"type":"number","description":"the fingers ramp towards this closure"}},"speed_per_s":{{"type":"number","description":"at this rate, fraction of the range per s (negative: opening)"}}}},"additionalProperties":false}}"#,
                    vec(
                        4,
                        "goal positions, 0 open .. 1 closed: three fingers, thumb rotation"
                    )
                ),
            ),
        ),
        "/command/arm" => (
            "tmo.ArmCommand",
            event_schema(
                "tmo.ArmCommand",
                "A motion command sent to the arm",
                &format!(
                    r#"{{"type":"object","properties":{{"move_linear_mm":{},"move_velocity_mm_s":{},"speed_mm_s":{{"type":"number"}},"stop":{{"type":"boolean"}}}},"additionalProperties":false}}"#,
                    vec(3, "offset of the tool centre point, mm"),
                    vec(3, "tool velocity, mm/s")
                ),
            ),
        ),
        "/classifier" => (
            "tmo.Classification",
            event_schema(
                "tmo.Classification",
                "The slip classifier's output for one frame",
                r#"{"type":"object","properties":{"sensor":{"type":"integer","minimum":0},"seq":{"type":"integer","minimum":0},"class":{"type":"string","enum":["static","slip"]},"slip":{"type":"integer","minimum":0,"maximum":1,"description":"1 for slip, 0 for static (plottable)"},"value":{"type":"number","description":"the model's slip value the class was read from: an ONNX model's output as its metadata states it, a tmo model's decision value (positive for slip)"},"mean_velocity_px":{"type":"number","description":"norm of the frame's mean pin velocity, px per frame (what the threshold classifier thresholds)"}},"required":["sensor","seq","class"],"additionalProperties":false}"#,
            ),
        ),
        "/timing" => (
            "tmo.FrameTiming",
            event_schema(
                "tmo.FrameTiming",
                "One classified frame against the online loop's deadline (docs/online.md): when it arrived, when its decision was due and made, and this machine's work on it",
                r#"{"type":"object","properties":{"sensor":{"type":"integer","minimum":0},"seq":{"type":"integer","minimum":0},"arrived_s":{"type":"number","description":"when the frame reached the host (the simulator: when it was taken), rig clock, s"},"due_s":{"type":"number","description":"when its decision was due, rig clock, s"},"decided_s":{"type":"number","description":"when the loop had acted on it, rig clock, s"},"lateness_ms":{"type":"number","description":"decided_s - due_s, ms (positive: late; negative: the slack left)"},"work_ms":{"type":"number","description":"this machine's time from the poll that brought the frame to its decision, ms"},"classify_ms":{"type":"number","description":"this machine's time for the frame's classification, ms"}},"required":["sensor","seq","arrived_s","due_s","decided_s","lateness_ms","work_ms","classify_ms"],"additionalProperties":false}"#,
            ),
        ),
        "/detector" => (
            "tmo.DetectorEvent",
            event_schema(
                "tmo.DetectorEvent",
                "The slip detector armed, disarmed, or reacting to a frame",
                r#"{"type":"object","properties":{"event":{"type":"string","enum":["armed","disarmed","reaction"]},"frame_time_s":{"type":"number"},"sensor":{"type":"integer","minimum":0},"seq":{"type":"integer","minimum":0},"strategy":{"type":"string"}},"required":["event"],"additionalProperties":false}"#,
            ),
        ),
        "/fault" => (
            "tmo.Fault",
            event_schema(
                "tmo.Fault",
                "Why the trial was aborted",
                r#"{"type":"object","properties":{"fault":{"type":"string","enum":["silent_sensor","stale_frames","interrupted","no_contact","model_output","deadline","phase_not_reached","device"]},"sensor":{"type":"integer","minimum":0},"last_frame_s":{"type":"number"},"repeats":{"type":"integer","minimum":0},"deformation_px":{"type":"number"},"seq":{"type":"integer","minimum":0},"output":{"type":"string","enum":["nan","positive_infinity","negative_infinity","run_failed"],"description":"what the slip model gave for the frame instead of a finite value"},"breach":{"type":"string","enum":["frame","share"],"description":"deadline: one frame past the limit, or too many frames late"},"latency_ms":{"type":"number","description":"deadline: from when the frame was due to arrive to its decision, ms"},"limit_ms":{"type":"number"},"late":{"type":"integer","minimum":0},"frames":{"type":"integer","minimum":0},"max_late_share":{"type":"number"},"reached":{"type":"string","description":"phase_not_reached: the last phase the trial reached"},"needed":{"type":"string","description":"phase_not_reached: the phase its outcome is judged in"},"message":{"type":"string"}},"required":["fault"],"additionalProperties":false}"#,
            ),
        ),
        "/state/hand" => (
            "tmo.HandState",
            event_schema(
                "tmo.HandState",
                "The hand's servos as they report themselves (not sampled while the detector waits for slip)",
                &format!(
                    r#"{{"type":"object","properties":{{"positions":{},"torque_limit":{{"type":"number","minimum":0,"maximum":1,"description":"the torque limit in force, fraction of the servos' maximum (the last commanded; absent: none set this trial)"}}}},"required":["positions"],"additionalProperties":false}}"#,
                    vec(
                        4,
                        "present positions, 0 open .. 1 closed: three fingers, thumb rotation"
                    )
                ),
            ),
        ),
        "/state/arm" => (
            "tmo.ArmState",
            event_schema(
                "tmo.ArmState",
                "The arm's tool centre point as the arm reports it (not sampled while the detector waits for slip)",
                &format!(
                    r#"{{"type":"object","properties":{{"position_mm":{},"rotation_rad":{}}},"required":["position_mm","rotation_rad"],"additionalProperties":false}}"#,
                    vec(3, "position in the arm's base frame, mm"),
                    vec(3, "rotation vector, rad")
                ),
            ),
        ),
        "/label" => (
            "tmo.SlipLabel",
            event_schema(
                "tmo.SlipLabel",
                "An imported recording's own slip label from this time on",
                r#"{"type":"object","properties":{"slip":{"type":"boolean"}},"required":["slip"],"additionalProperties":false}"#,
            ),
        ),
        _ => (
            "tmo.Event",
            event_schema("tmo.Event", "A runner event", r#"{"type":"object"}"#),
        ),
    }
}

/// A tactile frame as format 2 writes it.
#[derive(Serialize)]
pub struct PinFrameOut {
    sensor: u8,
    seq: u64,
    time_s: f64,
    x: Vec<f32>,
    y: Vec<f32>,
}

impl From<&PinFrame> for PinFrameOut {
    fn from(f: &PinFrame) -> Self {
        Self {
            sensor: f.sensor,
            seq: f.seq,
            time_s: f.time_s,
            x: f.pins.iter().map(|p| p[0]).collect(),
            y: f.pins.iter().map(|p| p[1]).collect(),
        }
    }
}

/// A tactile frame of either format: `pins` (format 1) or `x` and `y` (format 2).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PinFrameIn {
    sensor: u8,
    seq: u64,
    time_s: f64,
    #[serde(default)]
    pins: Option<Vec<[f32; 2]>>,
    #[serde(default)]
    x: Option<Vec<f32>>,
    #[serde(default)]
    y: Option<Vec<f32>>,
}

impl TryFrom<PinFrameIn> for PinFrame {
    type Error = String;

    fn try_from(f: PinFrameIn) -> Result<Self, String> {
        let pins = match (f.pins, f.x, f.y) {
            (Some(pins), None, None) => pins,
            (None, Some(x), Some(y)) if x.len() == y.len() => {
                x.into_iter().zip(y).map(|(x, y)| [x, y]).collect()
            }
            (None, Some(x), Some(y)) => {
                return Err(format!(
                    "{} x coordinates but {} y coordinates",
                    x.len(),
                    y.len()
                ))
            }
            _ => return Err("expected either `pins` or both `x` and `y`".into()),
        };
        Ok(PinFrame {
            sensor: f.sensor,
            seq: f.seq,
            time_s: f.time_s,
            pins,
        })
    }
}
