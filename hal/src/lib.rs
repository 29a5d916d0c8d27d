//! Hardware abstraction layer of `tmo`.
//!
//! One small trait per device role of the Tactile Model O rig ([`TactileSensor`], [`Hand`],
//! [`Arm`], [`MarkerTracker`], [`Clock`]), each taking its error type from [`ErrorType`], and
//! every backend error mapping onto the shared [`ErrorKind`] so generic code (the protocol
//! runner) can react to "timeout" or "out of limits" without knowing the backend.
//!
//! Traits only do I/O. Building a backend (opening ports, loading a log, building a simulated
//! world) is the job of that backend's constructor (the simulated rig is the `tmo-sim` crate's).

pub mod error;
pub mod real;
pub mod traits;
pub mod types;
pub mod wire;

pub use error::{Error, ErrorKind, ErrorType};
pub use traits::{Arm, Clock, Hand, MarkerTracker, TactileSensor};
pub use types::{
    HandPositions, MarkerSample, PinFrame, Pose, SensorId, HAND_ACTUATORS, TMO_FRAME_RATE_HZ,
    TMO_PINS_PER_SENSOR,
};
