//! mockall mocks of the HAL traits, for the runners' unit tests.

use std::sync::{Arc, Mutex};

use mockall::mock;
use tmo_hal::{Clock, ErrorKind, ErrorType, HandPositions, MarkerSample, PinFrame, Pose};

use crate::slip::dataset::{LabelSpec, Scope};
use crate::slip::features::FeatureSpec;
use crate::slip::model::{Classifier, ClassifierKind, ModelFile, SensorModel, MODEL_FORMAT};
use crate::slip::threshold::ThresholdModel;

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
    ModelFile {
        format: MODEL_FORMAT.into(),
        version: crate::slip::model::MODEL_FORMAT_VERSION,
        classifier: ClassifierKind::Threshold,
        hyperparameters: Default::default(),
        features: FeatureSpec::new(PINS),
        labels: LabelSpec {
            n_slip: 5,
            onset: Default::default(),
        },
        downsample: 1.0,
        seed: 0,
        scope: Scope::Global,
        sensors: vec![0, 1, 2],
        models: vec![SensorModel {
            sensor: None,
            scaler: None,
            classifier: Classifier::Threshold(ThresholdModel { threshold: 0.5 }),
            training_rows: 0,
            training_scores: Default::default(),
        }],
        training_trials: vec![],
        search: None,
        tmo_version: String::new(),
        git_revision: String::new(),
    }
}
