//! `tmo sim serve`: the simulated rig served as the real devices, so the real backends can
//! drive it unchanged. Each device's emulator is its own module and speaks its codec from
//! [`tmo_hal::wire`]; this module's real-time loop drives them all and owns the world they
//! share. The emulators import the world and the codecs, never each other.

pub mod control;
pub mod dynamixel;
pub mod jevois;
mod pty;
mod tcp;
pub mod ur;

use std::net::TcpListener;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use crate::{SimConfig, SimRig};
use control::ControlPort;
use dynamixel::PtyServoBus;
use tmo_hal::types::{HandPositions, MarkerSample, PinFrame, Pose};
use tmo_hal::{Arm, Clock, Hand};

pub use jevois::{LinkStall, PtyCamera, PtyMarkerCamera};
pub use pty::open_pty;
pub use ur::{UrEmulator, UrServeStats};

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
        let world_s = clock.now_s();
        for c in devices.cameras.iter_mut() {
            c.step(world_s, |f| {
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

/// Serves the arm until `stop` is set; the sim clock follows the wall clock from the call.
pub fn serve_ur(
    rig: &SimRig,
    rtde: TcpListener,
    script: TcpListener,
    stop: &AtomicBool,
) -> std::io::Result<UrServeStats> {
    let mut devices = ServedDevices {
        ur: Some(UrEmulator::new(rtde, script)?),
        ..Default::default()
    };
    serve(rig, &mut devices, stop)?;
    Ok(devices.ur.map(|u| u.stats).unwrap_or_default())
}
