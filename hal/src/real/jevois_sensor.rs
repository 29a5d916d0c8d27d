//! A JeVois fingertip camera on a serial port as the rig's [`TactileSensor`]. A reader
//! thread turns the byte stream into pin frames (timestamped on arrival by the backend's
//! clock); `next_frame` never blocks. Lines that are not `F2` frames with the expected pin
//! count are counted and dropped; a camera silent for longer than the limit is a
//! [`crate::ErrorKind::Timeout`].

use std::sync::mpsc;
use std::sync::{Arc, Mutex};
use std::time::Instant;

use super::clock::RealClock;
pub use super::watched::CameraError;
use super::watched::{open_camera_port, Watched};
use crate::wire::jevois::{LineReader, Message, ReaderStats};
use crate::{ErrorType, PinFrame, TactileSensor};

/// What a camera's stream held, beyond its frames.
#[derive(Debug, Default, Clone, PartialEq, Eq)]
pub struct CameraStats {
    pub reader: ReaderStats,
    /// `F2` frames with another pin count than expected.
    pub wrong_pin_count: u64,
    /// Messages that were not `F2` frames.
    pub other_messages: u64,
}

pub struct JevoisSensor {
    sensor: u8,
    frames: Watched<PinFrame>,
    stats: Arc<Mutex<CameraStats>>,
}

impl JevoisSensor {
    /// Opens `port` and starts reading; frames carry `sensor` and `clock` times.
    pub fn open(
        port: &str,
        baud: u32,
        sensor: u8,
        pins: usize,
        silent_limit_s: f64,
        clock: RealClock,
    ) -> Result<Self, CameraError> {
        let open_err = |source| CameraError::Open {
            port: port.to_string(),
            source,
        };
        let serial = open_camera_port(port, baud)?;
        let (tx, rx) = mpsc::channel();
        let stats = Arc::new(Mutex::new(CameraStats::default()));
        let shared = stats.clone();
        let reader_clock = clock.clone();
        std::thread::Builder::new()
            .name(format!("jevois {port}"))
            .spawn(move || {
                let mut reader = LineReader::default();
                let mut buf = [0u8; 2048];
                let mut seq = 0u64;
                loop {
                    let n = match serial.read(&mut buf) {
                        Ok(0) => continue,
                        Ok(n) => n,
                        Err(e) if e.kind() == std::io::ErrorKind::TimedOut => continue,
                        Err(e) => {
                            let _ = tx.send(Err(e.to_string()));
                            return;
                        }
                    };
                    let arrived = reader_clock.at(Instant::now());
                    let messages = reader.push(&buf[..n]);
                    let mut s = shared.lock().expect("stats lock");
                    s.reader = reader.stats().clone();
                    for m in messages {
                        match m.message {
                            Message::Fine2 { points, .. } if points.len() == pins => {
                                seq += 1;
                                let f = PinFrame {
                                    sensor,
                                    seq,
                                    time_s: arrived,
                                    pins: points,
                                };
                                if tx.send(Ok(f)).is_err() {
                                    return; // the sensor was dropped
                                }
                                reader_clock.input_arrived();
                            }
                            Message::Fine2 { .. } => s.wrong_pin_count += 1,
                            _ => s.other_messages += 1,
                        }
                    }
                }
            })
            .map_err(open_err)?;
        Ok(Self {
            sensor,
            frames: Watched::new(port, rx, clock, silent_limit_s),
            stats,
        })
    }

    pub fn stats(&self) -> CameraStats {
        self.stats.lock().expect("stats lock").clone()
    }

    pub fn sensor(&self) -> u8 {
        self.sensor
    }
}

impl ErrorType for JevoisSensor {
    type Error = CameraError;
}

impl TactileSensor for JevoisSensor {
    fn next_frame(&mut self) -> Result<Option<PinFrame>, CameraError> {
        self.frames.next(|f| f.time_s)
    }
}
