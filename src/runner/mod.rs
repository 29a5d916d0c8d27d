//! Protocol runners: one state machine per protocol kind over the HAL traits, generic over
//! backends.

pub mod approach;
pub mod batch;
pub mod batch_run;
pub mod calibrate;
pub mod devices;
pub mod hand_release;
pub mod hardware;
pub mod lift;
pub mod loop_timing;
#[cfg(test)]
pub(crate) mod mocks;
pub mod monitor;
pub mod params;
pub mod rail_catch;
pub mod real_trial;
pub mod replay;
pub mod rice_pour;
pub mod safety;
pub mod score;
pub mod sim_presets;
pub mod sim_trial;
pub mod staging;
mod trial_run;

use serde_json::json;
use tmo_hal::{Arm, Clock, Hand, MarkerTracker, TactileSensor};

use crate::online::strategy::Strategy;
use crate::slip::slip_model::SlipModel;
pub use crate::trial::state::event;
use crate::trial::TrialEvent;
use devices::{device, Devices, Recording, ScenarioError};
// The trial log's state events (`trial::state`), as the runners record them.
use crate::trial::state;
pub use devices::InFlight;

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
    /// The fingers closed as far as allowed without the pins showing contact.
    NoContact {
        deformation_px: f64,
    },
    /// The slip model gave no class for a frame (a non-finite value): never read as static.
    ModelOutput {
        sensor: u8,
        seq: u64,
        output: crate::online::classify::BadOutput,
    },
    /// The loop fell behind its frames (docs/online.md, "The deadline"): never scored.
    Deadline(crate::online::deadline::DeadlineBreach),
    /// The trial ended before the phase its outcome is judged in (a release never
    /// released): never scored as if that phase had run.
    PhaseNotReached {
        reached: TrialPhase,
        needed: TrialPhase,
    },
}

/// A runner's phases, as `/phase` names them.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "snake_case")]
pub enum TrialPhase {
    Approaching,
    Closing,
    Settling,
    Lifting,
    Releasing,
    Reacted,
}

/// The model and strategy of an online trial.
#[derive(Clone, Copy)]
pub struct Online<'m> {
    pub model: &'m SlipModel,
    pub strategy: Strategy,
}

/// What one trial of any runner recorded.
#[derive(Debug, Clone, PartialEq)]
pub struct RunRecord {
    pub recording: Recording,
    /// When the detector was armed.
    pub armed_s: Option<f64>,
    pub reaction: Option<crate::online::classify::Reaction>,
    pub fault: Option<Fault>,
    pub ended_s: f64,
    /// Phases, commands, classifier outputs and detector events, for the trial log.
    pub events: Vec<TrialEvent>,
}

/// Control period of every runner, s (1 kHz).
pub const TICK_S: f64 = 0.001;
/// How long a runner waits before arming its detector: the classifier needs a previous
/// frame from every sensor.
pub const SETTLE_S: f64 = 0.2;

impl<C, H, A, M, S> Devices<C, H, A, M, S>
where
    C: Clock,
    H: Hand,
    A: Arm,
    M: MarkerTracker,
    S: TactileSensor,
{
    /// One control tick: records the hand's and arm's state if a sample is due (see
    /// [`state`]; never while `waiting_for_slip`), sends what the last tick recorded and
    /// decided (`events` so far) to the live view if there is one, waits, then collects what
    /// arrived. Returns the index in `rec.frames` of the first new frame, and the time.
    fn tick(
        &mut self,
        rec: &mut Recording,
        events: &mut Vec<TrialEvent>,
        waiting_for_slip: bool,
    ) -> Result<(usize, f64), ScenarioError> {
        let now = self.clock.now_s();
        if let Some(period) = self.state_period_s {
            if state::state_due(events, now, period, waiting_for_slip) {
                let positions = self.hand.present_positions().map_err(device("hand"))?;
                let pose = self.arm.tcp_pose().map_err(device("arm"))?;
                let sample = state::state_events(now, positions, pose, events);
                events.extend(sample);
            }
        }
        if let Some(live) = &mut self.live {
            live.publish(now, &rec.frames, &rec.arrivals_s, &rec.markers, events);
        }
        control_wait(&mut self.clock);
        let first_new = rec.frames.len();
        self.poll(rec)?;
        Ok((first_new, self.clock.now_s()))
    }

    /// After a fault: the fingers hold where they are (the caller stops the arm).
    fn hold_hand(&mut self, now: f64, events: &mut Vec<TrialEvent>) -> Result<(), ScenarioError> {
        let held = self.hand.present_positions().map_err(device("hand"))?;
        self.hand.set_targets(held).map_err(device("hand"))?;
        events.push(event(now, "/command/hand", json!({ "targets": held })));
        Ok(())
    }
}

/// The wait between control ticks: until the next tick, or until a device has new input,
/// whichever is first. On the real rig a slipping frame is acted on as it arrives (the
/// reaction leaves within the I/O time, not up to a tick later); on virtual clocks (the
/// simulator, replay) input comes only as the clock advances, so the runner ticks as before.
pub fn control_wait(clock: &mut impl Clock) {
    let next = clock.now_s() + TICK_S;
    clock.wait_for_input_until(next);
}
