//! The replay backend: the HAL devices of a recorded trial. Sensor frames arrive when the
//! virtual clock passes the time they reached the host in the recording, in the recorded
//! order; marker samples when it passes their time. The hand and arm take commands and
//! keep them (the recorded world cannot follow them).

use std::cell::{Cell, RefCell};
use std::rc::Rc;

use tmo_hal::{
    Arm, Clock, ErrorKind, ErrorType, Hand, HandPositions, MarkerSample, MarkerTracker, PinFrame,
    Pose, TactileSensor,
};

use crate::runner::devices::Devices;
use crate::trial::Trial;

/// Replay devices never fail: the recording is already in memory.
#[derive(Debug, thiserror::Error)]
#[error("replay device error")]
pub struct ReplayError;

impl tmo_hal::Error for ReplayError {
    fn kind(&self) -> ErrorKind {
        ErrorKind::Other
    }
}

/// How far past the clock a recorded arrival may be and still count as arrived, s: the
/// recorded times went through a nanosecond log format and the live clock summed its ticks.
const ARRIVAL_SLACK_S: f64 = 1e-6;

#[derive(Clone)]
pub struct ReplayClock(Rc<Cell<f64>>);

impl Clock for ReplayClock {
    fn now_s(&self) -> f64 {
        self.0.get()
    }
    fn sleep_until(&mut self, time_s: f64) {
        self.0.set(self.0.get().max(time_s));
    }
}

pub struct ReplaySensor {
    frames: Vec<(f64, PinFrame)>,
    next: usize,
    clock: ReplayClock,
}

impl ErrorType for ReplaySensor {
    type Error = ReplayError;
}

impl TactileSensor for ReplaySensor {
    fn next_frame(&mut self) -> Result<Option<PinFrame>, ReplayError> {
        match self.frames.get(self.next) {
            Some((arrival, f)) if *arrival <= self.clock.now_s() + ARRIVAL_SLACK_S => {
                self.next += 1;
                Ok(Some(f.clone()))
            }
            _ => Ok(None),
        }
    }
}

pub struct ReplayMarkers {
    samples: Vec<MarkerSample>,
    next: usize,
    clock: ReplayClock,
}

impl ErrorType for ReplayMarkers {
    type Error = ReplayError;
}

impl MarkerTracker for ReplayMarkers {
    fn next_sample(&mut self) -> Result<Option<MarkerSample>, ReplayError> {
        match self.samples.get(self.next) {
            Some(m) if m.time_s <= self.clock.now_s() + ARRIVAL_SLACK_S => {
                self.next += 1;
                Ok(Some(*m))
            }
            _ => Ok(None),
        }
    }
}

/// Commands the replayed runner sent, with the clock's time.
pub type CommandLog = Rc<RefCell<Vec<(f64, String)>>>;

pub struct ReplayHand {
    positions: HandPositions,
    log: CommandLog,
    clock: ReplayClock,
}

impl ErrorType for ReplayHand {
    type Error = ReplayError;
}

impl Hand for ReplayHand {
    fn set_targets(&mut self, targets: HandPositions) -> Result<(), ReplayError> {
        self.positions = targets;
        self.log
            .borrow_mut()
            .push((self.clock.now_s(), format!("hand targets {targets:?}")));
        Ok(())
    }
    fn set_torque_limit(&mut self, fraction: f64) -> Result<(), ReplayError> {
        self.log
            .borrow_mut()
            .push((self.clock.now_s(), format!("hand torque {fraction}")));
        Ok(())
    }
    fn present_positions(&mut self) -> Result<HandPositions, ReplayError> {
        Ok(self.positions)
    }
}

pub struct ReplayArm {
    log: CommandLog,
    clock: ReplayClock,
}

impl ErrorType for ReplayArm {
    type Error = ReplayError;
}

impl Arm for ReplayArm {
    fn tcp_pose(&mut self) -> Result<Pose, ReplayError> {
        Ok(Pose::default())
    }
    fn move_linear(&mut self, offset_mm: [f64; 3], speed_mm_s: f64) -> Result<(), ReplayError> {
        self.log.borrow_mut().push((
            self.clock.now_s(),
            format!("arm move {offset_mm:?} at {speed_mm_s}"),
        ));
        Ok(())
    }
    fn move_velocity(&mut self, velocity_mm_s: [f64; 3]) -> Result<(), ReplayError> {
        self.log.borrow_mut().push((
            self.clock.now_s(),
            format!("arm velocity {velocity_mm_s:?}"),
        ));
        Ok(())
    }
    fn stop(&mut self) -> Result<(), ReplayError> {
        self.log
            .borrow_mut()
            .push((self.clock.now_s(), "arm stop".into()));
        Ok(())
    }
}

pub type ReplayDevices = Devices<ReplayClock, ReplayHand, ReplayArm, ReplayMarkers, ReplaySensor>;

/// The devices of `trial`, with the clock at `start_s`, and the log their commands go to.
pub fn replay_devices(trial: &Trial, start_s: f64) -> (ReplayDevices, CommandLog) {
    let clock = ReplayClock(Rc::new(Cell::new(start_s)));
    let log: CommandLog = Rc::default();
    let sensors = (0..trial.meta.sensors)
        .map(|s| ReplaySensor {
            frames: trial
                .frames
                .iter()
                .zip(&trial.arrivals_s)
                .filter(|(f, _)| f.sensor == s)
                .map(|(f, &a)| (a, f.clone()))
                .collect(),
            next: 0,
            clock: clock.clone(),
        })
        .collect();
    let devices = Devices {
        clock: clock.clone(),
        hand: ReplayHand {
            positions: [0.0; 4],
            log: log.clone(),
            clock: clock.clone(),
        },
        arm: ReplayArm {
            log: log.clone(),
            clock: clock.clone(),
        },
        markers: ReplayMarkers {
            samples: trial.markers.clone(),
            next: 0,
            clock,
        },
        sensors,
        live: None,
        state_period_s: None,
        in_flight: None,
    };
    (devices, log)
}
