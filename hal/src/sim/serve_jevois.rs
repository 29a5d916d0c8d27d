//! The simulated fingertip cameras served as JeVois cameras on pseudo-terminals, and the
//! real-time loop of `tmo sim serve` that drives every emulated device of one rig.

use std::fs::File;
use std::io::Write;
use std::os::fd::{AsFd, OwnedFd};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use nix::fcntl::{fcntl, FcntlArg, FdFlag, OFlag};
use nix::sys::termios;

use super::serve_control::ControlPort;
use super::serve_dynamixel::PtyServoBus;
use super::serve_ur::UrEmulator;
use super::{SimConfig, SimMarkerTracker, SimRig, SimTactileSensor};
use crate::types::{HandPositions, MarkerSample, PinFrame, Pose};
use crate::wire::jevois::{format_detail3, format_fine2};
use crate::{Arm, Clock, Hand, MarkerTracker, TactileSensor};

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
}

fn io(e: nix::Error) -> std::io::Error {
    std::io::Error::from(e)
}

/// A raw pseudo-terminal (like a USB serial port: no echo, no line editing, no CR/LF
/// translation) with a non-blocking master: the master, the slave (kept open so the
/// terminal does not hang up between clients) and the slave's path. Both ends are closed
/// on exec, as Rust's own files are: a child process holding the master would keep the
/// terminal from hanging up when its owner closes it.
pub fn open_pty() -> std::io::Result<(File, OwnedFd, PathBuf)> {
    let pty = nix::pty::openpty(None, None).map_err(io)?;
    for fd in [pty.master.as_fd(), pty.slave.as_fd()] {
        fcntl(fd, FcntlArg::F_SETFD(FdFlag::FD_CLOEXEC)).map_err(io)?;
    }
    let mut t = termios::tcgetattr(pty.slave.as_fd()).map_err(io)?;
    termios::cfmakeraw(&mut t);
    termios::tcsetattr(pty.slave.as_fd(), termios::SetArg::TCSANOW, &t).map_err(io)?;
    let path = nix::unistd::ttyname(pty.slave.as_fd()).map_err(io)?;
    let flags = fcntl(pty.master.as_fd(), FcntlArg::F_GETFL).map_err(io)?;
    fcntl(
        pty.master.as_fd(),
        FcntlArg::F_SETFL(OFlag::from_bits_truncate(flags) | OFlag::O_NONBLOCK),
    )
    .map_err(io)?;
    Ok((File::from(pty.master), pty.slave, path))
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
        })
    }

    /// Serves another world's sensor (after a reset) on the same terminal.
    pub fn rebind(&mut self, sensor: SimTactileSensor) {
        self.sensor = sensor;
    }

    /// Sends every frame the simulated sensor produced since the last call.
    /// Sends the frames the sensor has made since the last step; `sent` sees each.
    pub fn step(&mut self, mut sent: impl FnMut(&PinFrame)) -> std::io::Result<()> {
        while let Ok(Some(f)) = self.sensor.next_frame() {
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

/// Every device `tmo sim serve` emulates for one rig; absent ones are not served.
#[derive(Default)]
pub struct ServedDevices {
    pub ur: Option<UrEmulator>,
    pub cameras: Vec<PtyCamera>,
    pub markers: Option<PtyMarkerCamera>,
    pub bus: Option<PtyServoBus>,
}

/// Runs the rig in real time until `stop` is set, serving its devices.
pub fn serve(rig: &SimRig, devices: &mut ServedDevices, stop: &AtomicBool) -> std::io::Result<()> {
    serve_controlled(rig, devices, None, None, stop)
}

/// Sees what the served rig does as it is served: a live view of `tmo sim serve`. Times
/// are on the served clock, s since serving began (it runs on across resets, as a real
/// rig's does); the messages' own times are on the current world's clock.
pub trait ServeTap {
    /// A fingertip frame, as its camera sends it.
    fn frame(&mut self, served_s: f64, frame: &PinFrame);
    /// A marker sample, as the marker camera sends it.
    fn marker(&mut self, served_s: f64, sample: &MarkerSample);
    /// The hand's present positions and the arm's tool centre point, every
    /// [`TAP_STATE_PERIOD_S`].
    fn state(&mut self, served_s: f64, world_s: f64, hand: HandPositions, tcp: Pose);
}

/// Served time between the tap's state samples, s.
pub const TAP_STATE_PERIOD_S: f64 = 0.05;

/// Builds the world a reset asks for, if the served devices fit it.
fn reset_world(config: SimConfig, devices: &ServedDevices) -> Result<SimRig, String> {
    let rig = SimRig::new(config).map_err(|e| e.to_string())?;
    let sensors = rig.tactile_sensors().len();
    if sensors != devices.cameras.len() {
        return Err(format!(
            "this rig serves {} fingertip camera(s) but the reset's world has {sensors} (serve the other rig: `tmo sim serve --rig`)",
            devices.cameras.len()
        ));
    }
    Ok(rig)
}

/// [`serve`], with a control port through which each trial resets the world. The UR
/// controller's clock runs on across resets (a real controller does not restart between
/// trials); each new world's own clock starts at zero.
pub fn serve_controlled(
    rig: &SimRig,
    devices: &mut ServedDevices,
    mut control: Option<&mut ControlPort>,
    mut tap: Option<&mut dyn ServeTap>,
    stop: &AtomicBool,
) -> std::io::Result<()> {
    let mut next_state_s = 0.0;
    let mut replaced: Option<SimRig> = None;
    let mut clock = rig.clock();
    let mut arm = rig.arm();
    let (mut t0_sim, mut t0) = (clock.now_s(), Instant::now());
    // served time = offset + the current world's time
    let mut offset = 0.0;
    while !stop.load(Ordering::Relaxed) {
        if let Some(c) = control.as_deref_mut() {
            if let Some((client, config)) = c.poll()? {
                match reset_world(config, devices) {
                    Ok(new) => {
                        offset += clock.now_s();
                        for (cam, sensor) in devices.cameras.iter_mut().zip(new.tactile_sensors()) {
                            cam.rebind(sensor);
                        }
                        if let Some(m) = devices.markers.as_mut() {
                            m.rebind(new.marker_tracker());
                        }
                        if let Some(b) = devices.bus.as_mut() {
                            b.rebind(new.hand());
                        }
                        (clock, arm) = (new.clock(), new.arm());
                        (t0_sim, t0) = (clock.now_s(), Instant::now());
                        replaced = Some(new);
                        c.answer(client, Ok(()))?;
                    }
                    Err(e) => c.answer(client, Err(e))?,
                }
            }
        }
        clock.sleep_until(t0_sim + t0.elapsed().as_secs_f64());
        let now = offset + clock.now_s();
        if let Some(ur) = devices.ur.as_mut() {
            ur.step(now, &mut arm)?;
        }
        for c in devices.cameras.iter_mut() {
            c.step(|f| {
                if let Some(t) = tap.as_deref_mut() {
                    t.frame(now, f);
                }
            })?;
        }
        if let Some(m) = devices.markers.as_mut() {
            m.step(|sample| {
                if let Some(t) = tap.as_deref_mut() {
                    t.marker(now, sample);
                }
            })?;
        }
        if let Some(b) = devices.bus.as_mut() {
            b.step()?;
        }
        if let Some(t) = tap.as_deref_mut() {
            if now >= next_state_s {
                next_state_s = now + TAP_STATE_PERIOD_S;
                let world = replaced.as_ref().unwrap_or(rig);
                // the simulated devices' reads cannot fail
                if let (Ok(hand), Ok(tcp)) = (world.hand().present_positions(), arm.tcp_pose()) {
                    t.state(now, clock.now_s(), hand, tcp);
                }
            }
        }
        std::thread::sleep(Duration::from_micros(500));
    }
    drop(replaced);
    Ok(())
}
