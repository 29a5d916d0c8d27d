//! The rig's wire protocols as codecs, with no I/O: both ends use them, the real backends
//! ([`crate::real`]) as hosts and `tmo sim serve`'s emulated devices as the devices. Each is
//! tested on its own and by property tests.

pub mod dynamixel;
pub mod jevois;
pub mod rtde;
pub mod urscript;
