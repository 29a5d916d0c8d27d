//! Protocol runners: one state machine per protocol kind over the HAL traits, generic over
//! backends (issue 4, in progress).

pub mod batch;
pub mod hand_release;
#[cfg(test)]
pub(crate) mod mocks;
pub mod monitor;
pub mod rail_catch;
pub mod rice_pour;
pub mod safety;

use crate::online::strategy::Strategy;
use crate::slip::model::ModelFile;
use crate::trial::TrialEvent;

/// Why a trial was aborted; the hand held its position and the arm stopped.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(tag = "fault", rename_all = "snake_case")]
pub enum Fault {
    SilentSensor {
        sensor: u8,
        last_frame_s: f64,
    },
    StaleFrames {
        sensor: u8,
        repeats: u32,
    },
    /// The operator stopped the batch (Ctrl-C).
    Interrupted,
}

/// The model and strategy of an online trial.
#[derive(Clone, Copy)]
pub struct Online<'m> {
    pub model: &'m ModelFile,
    pub strategy: Strategy,
}

/// What one trial of any runner recorded.
#[derive(Debug, Clone, PartialEq)]
pub struct RunRecord {
    pub recording: crate::scenario::Recording,
    /// When the detector was armed.
    pub armed_s: Option<f64>,
    pub reaction: Option<crate::online::classify::Reaction>,
    pub fault: Option<Fault>,
    pub ended_s: f64,
    /// Phases, commands, classifier outputs and detector events, for the trial log.
    pub events: Vec<TrialEvent>,
}

/// A runner message for the trial log.
pub fn event(time_s: f64, topic: &str, data: serde_json::Value) -> TrialEvent {
    TrialEvent {
        time_s,
        topic: topic.to_string(),
        data,
    }
}
