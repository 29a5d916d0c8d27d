//! The `sim` backend (also called `mock`): a seeded, deterministic physics simulation of the
//! rig on a virtual clock. Model, equations and parameters: `docs/simulator.md`.
//!
//! [`SimRig::new`] builds one world; its device handles share it. Only the [`SimClock`]
//! advances the world, so a runner that waits through the clock drives the simulation, as
//! fast as the CPU allows.

pub mod actuators;
pub mod config;
pub mod curl;
pub mod grasp;
pub mod objects;
pub mod parameters;
pub mod serve;
pub mod skin;
pub mod statics;
pub mod tactip;
pub mod turn;
mod world;

use std::cell::RefCell;
use std::rc::Rc;

pub use config::{
    ArmParams, FaultRates, HandSetup, MarkerParams, ObjectStart, OperatorParams, PhysicsParams,
    RailSetup, RigSetup, ServoParams, SimConfig, TactipParams,
};
pub use objects::{ObjectLibrary, ObjectSpec};
pub use world::{nominal_contact_law, nominal_skin, TruthEvents, TruthState, MEASURABLE_FALL_MM};

use actuators::{ArmCommand, ServoCommand};
use tmo_hal::error::{Error, ErrorKind, ErrorType};
use tmo_hal::traits::{Arm, Clock, Hand, MarkerTracker, TactileSensor};
use tmo_hal::types::{HandPositions, MarkerSample, PinFrame, Pose};
use world::World;

/// Errors of the simulated rig.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    #[error("{origin}: {message}")]
    Config { origin: String, message: String },
    #[error("unknown object `{name}`; the library has: {known}")]
    UnknownObject { name: String, known: String },
    #[error("{what} = {value} is outside {limits}")]
    OutOfLimits {
        what: &'static str,
        value: f64,
        limits: String,
    },
}

impl Error for SimError {
    fn kind(&self) -> ErrorKind {
        match self {
            SimError::OutOfLimits { .. } => ErrorKind::OutOfLimits,
            SimError::Config { .. } | SimError::UnknownObject { .. } => ErrorKind::Other,
        }
    }
}

type Shared = Rc<RefCell<World>>;

/// One simulated rig. Hand out its devices with the accessor methods.
pub struct SimRig {
    world: Shared,
}

impl SimRig {
    /// Builds the rig with objects from the built-in library.
    pub fn new(config: SimConfig) -> Result<Self, SimError> {
        Self::with_library(config, &ObjectLibrary::built_in())
    }

    pub fn with_library(config: SimConfig, library: &ObjectLibrary) -> Result<Self, SimError> {
        Ok(Self {
            world: Rc::new(RefCell::new(World::new(config, library)?)),
        })
    }

    pub fn clock(&self) -> SimClock {
        SimClock {
            world: self.world.clone(),
        }
    }
    pub fn hand(&self) -> SimHand {
        SimHand {
            world: self.world.clone(),
        }
    }
    pub fn arm(&self) -> SimArm {
        SimArm {
            world: self.world.clone(),
        }
    }
    pub fn marker_tracker(&self) -> SimMarkerTracker {
        SimMarkerTracker {
            world: self.world.clone(),
        }
    }
    /// One handle per fingertip sensor: three on the hand, one on the rail rig.
    pub fn tactile_sensors(&self) -> Vec<SimTactileSensor> {
        let n = self.world.borrow().sensor_count();
        (0..n)
            .map(|index| SimTactileSensor {
                world: self.world.clone(),
                index,
            })
            .collect()
    }
    /// Ground truth for diagnostics; never a detector input.
    pub fn probe(&self) -> SimProbe {
        SimProbe {
            world: self.world.clone(),
        }
    }
    pub fn config(&self) -> SimConfig {
        self.world.borrow().config().clone()
    }
}

/// The virtual clock; sleeping on it runs the physics.
pub struct SimClock {
    world: Shared,
}

impl Clock for SimClock {
    fn now_s(&self) -> f64 {
        self.world.borrow().now_s()
    }
    fn sleep_until(&mut self, time_s: f64) {
        self.world.borrow_mut().advance_to(time_s);
    }
}

pub struct SimTactileSensor {
    world: Shared,
    index: usize,
}

impl SimTactileSensor {
    pub fn sensor_id(&self) -> tmo_hal::SensorId {
        self.index as tmo_hal::SensorId
    }
}

impl ErrorType for SimTactileSensor {
    type Error = SimError;
}

impl TactileSensor for SimTactileSensor {
    fn next_frame(&mut self) -> Result<Option<PinFrame>, SimError> {
        Ok(self.world.borrow_mut().pop_frame(self.index))
    }
}

pub struct SimHand {
    world: Shared,
}

impl ErrorType for SimHand {
    type Error = SimError;
}

impl Hand for SimHand {
    fn set_targets(&mut self, targets: HandPositions) -> Result<(), SimError> {
        for &t in &targets {
            if !(0.0..=1.0).contains(&t) {
                return Err(SimError::OutOfLimits {
                    what: "hand target",
                    value: t,
                    limits: "0.0..=1.0".into(),
                });
            }
        }
        let mut w = self.world.borrow_mut();
        let now = w.now_s();
        w.servos.command(now, ServoCommand::Targets(targets));
        Ok(())
    }
    fn set_torque_limit(&mut self, fraction: f64) -> Result<(), SimError> {
        if !(0.0..=1.0).contains(&fraction) {
            return Err(SimError::OutOfLimits {
                what: "torque limit",
                value: fraction,
                limits: "0.0..=1.0".into(),
            });
        }
        let mut w = self.world.borrow_mut();
        let now = w.now_s();
        w.servos.command(now, ServoCommand::TorqueLimit(fraction));
        Ok(())
    }
    /// Within 0..=1, as the real backend reads them: each servo's grid of encoder counts
    /// has its own zero, so the count nearest an end may lie a fraction of a count past it.
    fn present_positions(&mut self) -> Result<HandPositions, SimError> {
        Ok(self
            .world
            .borrow()
            .present_positions()
            .map(|q| q.clamp(0.0, 1.0)))
    }
}

pub struct SimArm {
    world: Shared,
}

impl SimArm {
    fn check_speed(&self, speed: f64) -> Result<(), SimError> {
        let max = self.world.borrow().config().arm.max_speed_mm_s;
        if !(speed.is_finite() && speed >= 0.0 && speed <= max) {
            return Err(SimError::OutOfLimits {
                what: "arm speed (mm/s)",
                value: speed,
                limits: format!("0..={max}"),
            });
        }
        Ok(())
    }
}

impl ErrorType for SimArm {
    type Error = SimError;
}

impl Arm for SimArm {
    fn tcp_pose(&mut self) -> Result<Pose, SimError> {
        let w = self.world.borrow();
        let grasp = match &w.config().rig {
            RigSetup::Hand(h) => h.grasp_deg.to_radians(),
            RigSetup::Rail(_) => 0.0,
        };
        Ok(Pose {
            position_mm: w.arm.position_mm,
            rotation_rad: [0.0, 0.0, grasp],
        })
    }
    fn move_linear(&mut self, offset_mm: [f64; 3], speed_mm_s: f64) -> Result<(), SimError> {
        self.check_speed(speed_mm_s)?;
        let mut w = self.world.borrow_mut();
        let now = w.now_s();
        w.arm.command(
            now,
            ArmCommand::Linear {
                offset_mm,
                speed_mm_s,
            },
        );
        Ok(())
    }
    fn move_velocity(&mut self, velocity_mm_s: [f64; 3]) -> Result<(), SimError> {
        let speed = velocity_mm_s.iter().map(|v| v * v).sum::<f64>().sqrt();
        self.check_speed(speed)?;
        let mut w = self.world.borrow_mut();
        let now = w.now_s();
        w.arm.command(now, ArmCommand::Velocity(velocity_mm_s));
        Ok(())
    }
    fn stop(&mut self) -> Result<(), SimError> {
        let mut w = self.world.borrow_mut();
        let now = w.now_s();
        w.arm.command(now, ArmCommand::Velocity([0.0; 3]));
        Ok(())
    }
}

pub struct SimMarkerTracker {
    world: Shared,
}

impl ErrorType for SimMarkerTracker {
    type Error = SimError;
}

impl MarkerTracker for SimMarkerTracker {
    fn next_sample(&mut self) -> Result<Option<MarkerSample>, SimError> {
        Ok(self.world.borrow_mut().pop_marker())
    }
}

/// Read-only view of the simulation's ground truth.
pub struct SimProbe {
    world: Shared,
}

impl SimProbe {
    pub fn state(&self) -> TruthState {
        self.world.borrow().truth()
    }
    pub fn events(&self) -> TruthEvents {
        self.world.borrow().events().clone()
    }
    /// Finger position (0..1) at which the fingers first touch the object of a hand rig.
    pub fn contact_closure(&self) -> Option<f64> {
        let w = self.world.borrow();
        let cfg = w.config();
        match &cfg.rig {
            // the rig's own object: it may come from a library other than the built-in one
            RigSetup::Hand(_) => {
                Some(1.0 - w.object().width_mm / (2.0 * cfg.physics.finger_travel_mm))
            }
            RigSetup::Rail(_) => None,
        }
    }
}
