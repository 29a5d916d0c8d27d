//! The simulated fingertip cameras served as JeVois cameras on pseudo-terminals, and the
//! real-time loop of `tmo sim serve` that drives every emulated device of one rig.

use std::fs::File;
use std::io::Write;
use std::os::fd::{AsFd, OwnedFd};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use nix::fcntl::{fcntl, FcntlArg, OFlag};
use nix::sys::termios;

use super::serve_dynamixel::PtyServoBus;
use super::serve_ur::UrEmulator;
use super::{SimRig, SimTactileSensor};
use crate::real::jevois::format_fine2;
use crate::{Clock, TactileSensor};

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

impl PtyCamera {
    pub fn open(sensor: SimTactileSensor, id: &str) -> std::io::Result<Self> {
        let pty = nix::pty::openpty(None, None).map_err(io)?;
        // Raw, like a USB serial port: no echo, no line editing, no CR/LF translation.
        let mut t = termios::tcgetattr(pty.slave.as_fd()).map_err(io)?;
        termios::cfmakeraw(&mut t);
        termios::tcsetattr(pty.slave.as_fd(), termios::SetArg::TCSANOW, &t).map_err(io)?;
        let path = nix::unistd::ttyname(pty.slave.as_fd()).map_err(io)?;
        // A camera does not wait for its host: writes that would block are dropped.
        let flags = fcntl(pty.master.as_fd(), FcntlArg::F_GETFL).map_err(io)?;
        fcntl(
            pty.master.as_fd(),
            FcntlArg::F_SETFL(OFlag::from_bits_truncate(flags) | OFlag::O_NONBLOCK),
        )
        .map_err(io)?;
        Ok(Self {
            master: File::from(pty.master),
            _slave: pty.slave,
            path,
            sensor,
            id: id.to_string(),
            dropped_lines: 0,
            sent_lines: 0,
        })
    }

    /// Sends every frame the simulated sensor produced since the last call.
    pub fn step(&mut self) -> std::io::Result<()> {
        while let Ok(Some(f)) = self.sensor.next_frame() {
            let line = format_fine2(None, &self.id, &f.pins);
            match self.master.write(line.as_bytes()) {
                Ok(n) if n == line.len() => self.sent_lines += 1,
                Ok(_) => self.dropped_lines += 1,
                Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => self.dropped_lines += 1,
                Err(e) => return Err(e),
            }
        }
        Ok(())
    }
}

/// Runs the rig in real time until `stop` is set, serving the arm, the cameras and the
/// hand's bus that are given.
pub fn serve(
    rig: &SimRig,
    mut ur: Option<&mut UrEmulator>,
    cameras: &mut [PtyCamera],
    mut bus: Option<&mut PtyServoBus>,
    stop: &AtomicBool,
) -> std::io::Result<()> {
    let mut clock = rig.clock();
    let mut arm = rig.arm();
    let t0_sim = clock.now_s();
    let t0 = Instant::now();
    while !stop.load(Ordering::Relaxed) {
        clock.sleep_until(t0_sim + t0.elapsed().as_secs_f64());
        let now = clock.now_s();
        if let Some(ur) = ur.as_deref_mut() {
            ur.step(now, &mut arm)?;
        }
        for c in cameras.iter_mut() {
            c.step()?;
        }
        if let Some(b) = bus.as_deref_mut() {
            b.step()?;
        }
        std::thread::sleep(Duration::from_micros(500));
    }
    Ok(())
}
