//! The real rig's wire protocols (issue 7, in progress): parsers and codecs first, each
//! tested on its own and by property tests; the device adapters over serial ports and TCP
//! come on top of them.

pub mod clock;
pub mod dynamixel;
pub mod jevois;
pub mod jevois_sensor;
pub mod marker_camera;
pub mod model_o;
pub mod rtde;
pub mod ur;
pub mod urscript;
mod watched;
