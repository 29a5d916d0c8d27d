//! The devices a runner drives, what it records from them, and the error a device's
//! failure becomes. Shared by every protocol runner and by `tmo sim trace`'s scenarios.

use tmo_hal::{Arm, Clock, ErrorKind, Hand, MarkerSample, MarkerTracker, PinFrame, TactileSensor};

#[derive(Debug, thiserror::Error)]
pub enum ScenarioError {
    #[error("{device} failed ({kind}): {message}")]
    Device {
        device: &'static str,
        kind: ErrorKind,
        message: String,
    },
    #[error("no contact: deformation stayed at {deformation_px:.3} px up to full closure")]
    NoContact { deformation_px: f64 },
}

/// Maps a device error into a [`ScenarioError`] naming the device.
pub(crate) fn device<E: tmo_hal::Error>(device: &'static str) -> impl Fn(E) -> ScenarioError {
    move |e| ScenarioError::Device {
        device,
        kind: e.kind(),
        message: e.to_string(),
    }
}

/// The devices a scenario drives.
pub struct Devices<C, H, A, M, S> {
    pub clock: C,
    pub hand: H,
    pub arm: A,
    pub markers: M,
    pub sensors: Vec<S>,
    /// Where each tick's new frames, markers and events are also sent as they arrive.
    pub live: Option<crate::live::LivePublisher>,
    /// How often the runners record the hand's and arm's state (see `trial::state`);
    /// `None` where the devices have no state of their own to report (replay).
    pub state_period_s: Option<f64>,
    /// Where a trial that a device error cut short leaves what it had recorded (see
    /// [`InFlight`]); `None` where nobody keeps it.
    pub in_flight: Option<InFlight>,
}

/// Where a trial that ends without `TrialRun::finish` (a device error taken up with `?`
/// anywhere in a runner) leaves what it recorded: the frames, markers and events up to the
/// fault. The real backend keeps it as `*.faulted.mcap`. The trial's run fills it as a
/// drop guard (`super::trial_run`) rather than a wrapper around every runner's body, so
/// that no error path of any runner can miss it.
pub type InFlight = std::sync::Arc<std::sync::Mutex<Option<super::RunRecord>>>;

/// The simulated rig's devices.
pub type SimDevices = Devices<
    tmo_sim::SimClock,
    tmo_sim::SimHand,
    tmo_sim::SimArm,
    tmo_sim::SimMarkerTracker,
    tmo_sim::SimTactileSensor,
>;

impl SimDevices {
    /// Every device of `rig`, each a handle onto the same simulation.
    pub fn of_sim(rig: &tmo_sim::SimRig) -> Self {
        Devices {
            clock: rig.clock(),
            hand: rig.hand(),
            arm: rig.arm(),
            markers: rig.marker_tracker(),
            sensors: rig.tactile_sensors(),
            live: None,
            state_period_s: Some(super::state::STATE_PERIOD_S),
            in_flight: None,
        }
    }
}

/// Everything the devices delivered during a scenario.
#[derive(Debug, Default, Clone, PartialEq)]
pub struct Recording {
    pub frames: Vec<PinFrame>,
    /// When each frame was polled, on the devices' clock, s.
    pub arrivals_s: Vec<f64>,
    pub markers: Vec<MarkerSample>,
    /// When each phase of a script began (scripts that have phases), s.
    pub phases: Vec<(f64, &'static str)>,
}

impl<C, H, A, M, S> Devices<C, H, A, M, S>
where
    C: Clock,
    H: Hand,
    A: Arm,
    M: MarkerTracker,
    S: TactileSensor,
{
    pub(crate) fn poll(&mut self, rec: &mut Recording) -> Result<(), ScenarioError> {
        let now = self.clock.now_s();
        for s in self.sensors.iter_mut() {
            while let Some(f) = s.next_frame().map_err(device("tactile sensor"))? {
                rec.frames.push(f);
                rec.arrivals_s.push(now);
            }
        }
        while let Some(m) = self
            .markers
            .next_sample()
            .map_err(device("marker tracker"))?
        {
            rec.markers.push(m);
        }
        Ok(())
    }
}

/// Why a simulated trial could not run: its world could not be built, or a device failed.
#[derive(Debug, thiserror::Error)]
pub enum SimRigError {
    #[error(transparent)]
    Sim(#[from] tmo_sim::SimError),
    #[error(transparent)]
    Scenario(#[from] ScenarioError),
}
