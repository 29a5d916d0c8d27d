//! What the camera backends share: items from a reader thread, handed out without blocking,
//! with a watchdog that turns silence into an error.

use std::sync::mpsc::{Receiver, TryRecvError};

use super::clock::RealClock;
use crate::{Clock, ErrorKind};

/// What can go wrong with a camera (fingertip or marker) on its serial port.
#[derive(Debug, thiserror::Error)]
pub enum CameraError {
    #[error("camera {port}: {source}")]
    Open {
        port: String,
        source: std::io::Error,
    },
    #[error("camera {port} silent for {silent_s:.2} s")]
    Silent { port: String, silent_s: f64 },
    #[error("camera {port}: the port closed ({reason})")]
    Closed { port: String, reason: String },
}

impl crate::Error for CameraError {
    fn kind(&self) -> ErrorKind {
        match self {
            CameraError::Silent { .. } => ErrorKind::Timeout,
            CameraError::Closed { .. } | CameraError::Open { .. } => ErrorKind::Disconnected,
        }
    }
}

/// Opens a camera's serial port with the short read timeout the reader threads poll with.
pub(crate) fn open_camera_port(port: &str, baud: u32) -> Result<serial2::SerialPort, CameraError> {
    let open_err = |source| CameraError::Open {
        port: port.to_string(),
        source,
    };
    let mut serial = serial2::SerialPort::open(port, baud).map_err(open_err)?;
    serial
        .set_read_timeout(std::time::Duration::from_millis(100))
        .map_err(open_err)?;
    Ok(serial)
}

pub(crate) struct Watched<T> {
    port: String,
    items: Receiver<Result<T, String>>,
    clock: RealClock,
    last_s: f64,
    silent_limit_s: f64,
}

impl<T> Watched<T> {
    pub fn new(
        port: &str,
        items: Receiver<Result<T, String>>,
        clock: RealClock,
        silent_limit_s: f64,
    ) -> Self {
        Self {
            port: port.to_string(),
            items,
            last_s: clock.now_s(),
            clock,
            silent_limit_s,
        }
    }

    /// The next item, if one arrived; `time_of` gives its arrival time.
    pub fn next(&mut self, time_of: impl Fn(&T) -> f64) -> Result<Option<T>, CameraError> {
        let closed = |reason: String| CameraError::Closed {
            port: self.port.clone(),
            reason,
        };
        match self.items.try_recv() {
            Ok(Ok(item)) => {
                self.last_s = time_of(&item);
                Ok(Some(item))
            }
            Ok(Err(reason)) => Err(closed(reason)),
            Err(TryRecvError::Empty) => {
                let silent_s = self.clock.now_s() - self.last_s;
                if silent_s > self.silent_limit_s {
                    Err(CameraError::Silent {
                        port: self.port.clone(),
                        silent_s,
                    })
                } else {
                    Ok(None)
                }
            }
            Err(TryRecvError::Disconnected) => Err(closed("reader stopped".into())),
        }
    }
}
