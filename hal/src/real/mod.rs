//! The real rig's device backends: JeVois cameras over serial ports, the Model O's
//! Dynamixel bus, the UR arm over RTDE and URScript, and the clock they share. The codecs
//! they speak are in [`crate::wire`], which the simulator's emulators use too.

pub mod clock;
pub mod jevois_sensor;
pub mod marker_camera;
pub mod model_o;
pub mod ur;
mod watched;
