//! mockall mocks of the HAL traits, for the runners' unit tests.

use std::sync::{Arc, Mutex};

use mockall::mock;
use tmo_hal::{Clock, ErrorKind, ErrorType, HandPositions, MarkerSample, PinFrame, Pose};

use crate::slip::model::ModelFile;

#[derive(Debug, thiserror::Error)]
#[error("mock device failure")]
pub struct MockError;

impl tmo_hal::Error for MockError {
    fn kind(&self) -> ErrorKind {
        ErrorKind::Other
    }
}

mock! {
    pub Hand {}
    impl ErrorType for Hand { type Error = MockError; }
    impl tmo_hal::Hand for Hand {
        fn set_targets(&mut self, targets: HandPositions) -> Result<(), MockError>;
        fn set_torque_limit(&mut self, fraction: f64) -> Result<(), MockError>;
        fn present_positions(&mut self) -> Result<HandPositions, MockError>;
    }
}

mock! {
    pub Arm {}
    impl ErrorType for Arm { type Error = MockError; }
    impl tmo_hal::Arm for Arm {
        fn tcp_pose(&mut self) -> Result<Pose, MockError>;
        fn move_linear(&mut self, offset_mm: [f64; 3], speed_mm_s: f64) -> Result<(), MockError>;
        fn move_velocity(&mut self, velocity_mm_s: [f64; 3]) -> Result<(), MockError>;
        fn stop(&mut self) -> Result<(), MockError>;
    }
}

mock! {
    pub Markers {}
    impl ErrorType for Markers { type Error = MockError; }
    impl tmo_hal::MarkerTracker for Markers {
        fn next_sample(&mut self) -> Result<Option<MarkerSample>, MockError>;
    }
}

mock! {
    pub Sensor {}
    impl ErrorType for Sensor { type Error = MockError; }
    impl tmo_hal::TactileSensor for Sensor {
        fn next_frame(&mut self) -> Result<Option<PinFrame>, MockError>;
    }
}

/// A virtual clock the mocks can read.
#[derive(Clone, Default)]
pub struct SharedClock(Arc<Mutex<f64>>);

impl Clock for SharedClock {
    fn now_s(&self) -> f64 {
        *self.0.lock().unwrap()
    }
    fn sleep_until(&mut self, time_s: f64) {
        let mut t = self.0.lock().unwrap();
        *t = t.max(time_s);
    }
}

/// Pins per mock frame.
pub const PINS: usize = 4;

/// A global model that calls a frame slip when the pins move more than 0.5 px on average.
pub fn threshold_model() -> ModelFile {
    ModelFile::threshold_model(PINS, vec![0, 1, 2], 0.5)
}
