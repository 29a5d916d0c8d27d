//! The JeVois marker camera (DemoArUco, 3D output) as the rig's [`MarkerTracker`]: `N3`/`D3`
//! poses of the object's and the hand's markers, in mm in the camera frame (x right, y
//! down, z forward), become heights (`-y`). A sample is emitted when both markers have
//! been seen in the same camera frame (the camera sends a frame's markers back to back);
//! a marker missing from a frame simply yields no sample for it, as a tracker that lost
//! it would.

use std::sync::mpsc;
use std::time::Instant;

use super::clock::RealClock;
use super::watched::CameraError;
use super::watched::{open_camera_port, Watched};
use crate::wire::jevois::{LineReader, Message};
use crate::{ErrorType, MarkerSample, MarkerTracker};

/// Height above the camera's optical axis of a marker at camera-frame `y`, mm.
pub fn height_mm(y_mm: f64) -> f64 {
    -y_mm
}

/// Pairs consecutive sightings of the two markers into samples.
#[derive(Debug, Clone)]
pub struct MarkerPairing {
    object: String,
    hand: String,
    pending_object: Option<f64>,
    pending_hand: Option<f64>,
}

impl MarkerPairing {
    pub fn new(object: &str, hand: &str) -> Self {
        Self {
            object: object.into(),
            hand: hand.into(),
            pending_object: None,
            pending_hand: None,
        }
    }

    /// Takes one message; returns a sample once both markers are in.
    pub fn push(&mut self, m: &Message, time_s: f64) -> Option<MarkerSample> {
        let (id, y) = match m {
            Message::Named3 {
                id, position_mm, ..
            }
            | Message::Detail3 {
                id, position_mm, ..
            } => (id, position_mm[1]),
            Message::Fine2 { .. } => return None,
        };
        if *id == self.object {
            self.pending_object = Some(height_mm(y));
        } else if *id == self.hand {
            self.pending_hand = Some(height_mm(y));
        } else {
            return None;
        }
        match (self.pending_object, self.pending_hand) {
            (Some(object_mm), Some(hand_mm)) => {
                self.pending_object = None;
                self.pending_hand = None;
                Some(MarkerSample {
                    time_s,
                    object_mm,
                    hand_mm,
                })
            }
            _ => None,
        }
    }
}

pub struct MarkerCamera {
    samples: Watched<MarkerSample>,
}

impl MarkerCamera {
    pub fn open(
        port: &str,
        baud: u32,
        object_marker: &str,
        hand_marker: &str,
        silent_limit_s: f64,
        clock: RealClock,
    ) -> Result<Self, CameraError> {
        let open_err = |source| CameraError::Open {
            port: port.to_string(),
            source,
        };
        let serial = open_camera_port(port, baud)?;
        let (tx, rx) = mpsc::channel();
        let mut pairing = MarkerPairing::new(object_marker, hand_marker);
        let reader_clock = clock.clone();
        std::thread::Builder::new()
            .name(format!("markers {port}"))
            .spawn(move || {
                let mut reader = LineReader::default();
                let mut buf = [0u8; 1024];
                loop {
                    let n = match serial.read(&mut buf) {
                        Ok(n) => n,
                        Err(e) if e.kind() == std::io::ErrorKind::TimedOut => continue,
                        Err(e) => {
                            let _ = tx.send(Err(e.to_string()));
                            return;
                        }
                    };
                    let t = reader_clock.at(Instant::now());
                    for m in reader.push(&buf[..n]) {
                        if let Some(s) = pairing.push(&m.message, t) {
                            if tx.send(Ok(s)).is_err() {
                                return;
                            }
                        }
                    }
                }
            })
            .map_err(open_err)?;
        Ok(Self {
            samples: Watched::new(port, rx, clock, silent_limit_s),
        })
    }
}

impl ErrorType for MarkerCamera {
    type Error = CameraError;
}

impl MarkerTracker for MarkerCamera {
    fn next_sample(&mut self) -> Result<Option<MarkerSample>, CameraError> {
        self.samples.next(|s| s.time_s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::wire::jevois::parse_line;

    #[test]
    fn both_markers_make_a_sample_and_strangers_are_ignored() {
        let mut p = MarkerPairing::new("U42", "U7");
        let m = |l: &str| parse_line(l).unwrap().message;
        assert_eq!(p.push(&m("N3 U42 0 -300 500 40 40 1"), 1.0), None);
        assert_eq!(p.push(&m("N3 U9 0 -10 500 40 40 1"), 1.0), None);
        let s = p.push(&m("D3 U7 0 -360 500 40 40 1 1 0 0 0"), 1.0).unwrap();
        assert_eq!((s.object_mm, s.hand_mm), (300.0, 360.0));
        assert_eq!(
            p.push(&m("N3 U7 0 -361 500 40 40 1"), 1.1),
            None,
            "needs the object again"
        );
    }
}
