//! Plain data that crosses the HAL: frames, samples, poses.

use serde::{Deserialize, Serialize};

/// Pins tracked by each TacTip fingertip of the Tactile Model O.
pub const TMO_PINS_PER_SENSOR: usize = 30;

/// Frames a second each TacTip's camera (a JeVois) streams: the rig's nominal rate, and the
/// simulator's default.
pub const TMO_FRAME_RATE_HZ: f64 = 60.0;

/// Actuators of the Model O: three fingers (thumb first) and the coupled finger rotation.
pub const HAND_ACTUATORS: usize = 4;

/// Which tactile sensor a frame came from (0 = thumb, 1 and 2 = the rotating fingers).
pub type SensorId = u8;

/// Normalised actuator positions, 0.0 open .. 1.0 closed; index 3 is the finger rotation.
pub type HandPositions = [f64; HAND_ACTUATORS];

/// One camera frame of one tactile sensor: the tracked pin centres in image pixels.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PinFrame {
    pub sensor: SensorId,
    /// The sensor's own frame counter; a gap means frames were lost on the way.
    pub seq: u64,
    /// Arrival time on the rig clock, seconds.
    pub time_s: f64,
    /// Pin centres `(x, y)` in pixels, in the sensor's fixed pin order.
    pub pins: Vec<[f32; 2]>,
}

/// One marker-tracker sample: heights of the object and hand markers, mm.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MarkerSample {
    pub time_s: f64,
    pub object_mm: f64,
    pub hand_mm: f64,
}

/// Tool-centre-point pose of the arm: position in mm, rotation vector in rad.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Pose {
    pub position_mm: [f64; 3],
    pub rotation_rad: [f64; 3],
}
