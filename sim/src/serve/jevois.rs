//! The simulated fingertip cameras and the marker camera served as JeVois cameras on
//! pseudo-terminals, each sending its lines as the real camera does.

use std::fs::File;
use std::io::Write;
use std::os::fd::OwnedFd;
use std::path::PathBuf;

use super::pty::open_pty;
use crate::{SimMarkerTracker, SimTactileSensor};
use tmo_hal::types::{MarkerSample, PinFrame};
use tmo_hal::wire::jevois::{format_detail3, format_fine2};
use tmo_hal::{MarkerTracker, TactileSensor};

/// One fingertip camera on a pseudo-terminal: clients open [`PtyCamera::path`] as they
/// would `/dev/ttyACM0`.
pub struct PtyCamera {
    master: File,
    // Kept open so the terminal does not hang up while no client has it open.
    _slave: OwnedFd,
    pub path: PathBuf,
    sensor: SimTactileSensor,
    id: String,
    /// Lines the client was too slow to take (the terminal buffer was full).
    pub dropped_lines: u64,
    pub sent_lines: u64,
    /// A link that stalls: from this time of each world's clock, for this long, s, frames
    /// are held back, then sent at once (a fault to provoke, for tests of the online
    /// loop's deadline).
    pub stall: Option<LinkStall>,
    held: std::collections::VecDeque<PinFrame>,
}

/// When a served camera's link stalls, on each world's clock (every trial's reset starts
/// one at zero), s.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinkStall {
    pub from_s: f64,
    pub for_s: f64,
}

/// Writes a line; a camera does not wait for its host, so a full terminal drops it.
fn send_line(
    master: &mut File,
    line: &str,
    sent: &mut u64,
    dropped: &mut u64,
) -> std::io::Result<()> {
    match master.write(line.as_bytes()) {
        Ok(n) if n == line.len() => *sent += 1,
        Ok(_) => *dropped += 1,
        Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => *dropped += 1,
        Err(e) => return Err(e),
    }
    Ok(())
}

impl PtyCamera {
    pub fn open(sensor: SimTactileSensor, id: &str) -> std::io::Result<Self> {
        let (master, slave, path) = open_pty()?;
        Ok(Self {
            master,
            _slave: slave,
            path,
            sensor,
            id: id.to_string(),
            dropped_lines: 0,
            sent_lines: 0,
            stall: None,
            held: Default::default(),
        })
    }

    /// Serves another world's sensor (after a reset) on the same terminal.
    pub fn rebind(&mut self, sensor: SimTactileSensor) {
        self.sensor = sensor;
        self.held.clear();
    }

    /// Sends the frames the sensor has made since the last step (those a stalled link
    /// holds at `world_s`, once it ends); `sent` sees each.
    pub fn step(&mut self, world_s: f64, mut sent: impl FnMut(&PinFrame)) -> std::io::Result<()> {
        while let Ok(Some(f)) = self.sensor.next_frame() {
            self.held.push_back(f);
        }
        let stalled = self
            .stall
            .is_some_and(|s| world_s >= s.from_s && world_s < s.from_s + s.for_s);
        if stalled {
            return Ok(());
        }
        while let Some(f) = self.held.pop_front() {
            let line = format_fine2(None, &self.id, &f.pins);
            send_line(
                &mut self.master,
                &line,
                &mut self.sent_lines,
                &mut self.dropped_lines,
            )?;
            sent(&f);
        }
        Ok(())
    }
}

/// The marker camera on a pseudo-terminal: DemoArUco `D3` lines for the object's and the
/// hand's markers, heights as camera-frame `-y`.
pub struct PtyMarkerCamera {
    master: File,
    _slave: OwnedFd,
    pub path: PathBuf,
    markers: SimMarkerTracker,
    object_id: String,
    hand_id: String,
    pub sent_lines: u64,
    pub dropped_lines: u64,
}

impl PtyMarkerCamera {
    pub fn open(
        markers: SimMarkerTracker,
        object_id: &str,
        hand_id: &str,
    ) -> std::io::Result<Self> {
        let (master, slave, path) = open_pty()?;
        Ok(Self {
            master,
            _slave: slave,
            path,
            markers,
            object_id: object_id.into(),
            hand_id: hand_id.into(),
            sent_lines: 0,
            dropped_lines: 0,
        })
    }

    /// Tracks another world's markers (after a reset) on the same terminal.
    pub fn rebind(&mut self, markers: SimMarkerTracker) {
        self.markers = markers;
    }

    /// Sends the samples the tracker has made since the last step; `sent` sees each.
    pub fn step(&mut self, mut sent: impl FnMut(&MarkerSample)) -> std::io::Result<()> {
        while let Ok(Some(m)) = self.markers.next_sample() {
            sent(&m);
            for (id, height) in [(&self.object_id, m.object_mm), (&self.hand_id, m.hand_mm)] {
                let line = format_detail3(
                    id,
                    [0.0, -height, 500.0],
                    [40.0, 40.0, 1.0],
                    [1.0, 0.0, 0.0, 0.0],
                );
                send_line(
                    &mut self.master,
                    &line,
                    &mut self.sent_lines,
                    &mut self.dropped_lines,
                )?;
            }
        }
        Ok(())
    }
}
