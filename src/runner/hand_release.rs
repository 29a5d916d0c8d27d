//! Whole-hand release (SPEC.md "hand_release"): close on the object standing on the table,
//! lift it, hold it, then open the fingers slowly; with a model, classify every frame as it
//! arrives and, when the strategy fires, close to `regrasp` tighter than the starting grasp.
//!
//! The detector is armed only while releasing: closing and lifting make large pin motions
//! that are not slip, and the paper's hand reacts only during the release.

use tmo_hal::{Arm, Clock, Hand, MarkerTracker, TactileSensor};

use crate::online::classify::{FrameClassifier, Reaction};
use crate::online::strategy::{Detector, Strategy};
use crate::scenario::{Devices, Recording, ScenarioError};
use crate::slip::model::ModelFile;

/// Control period, s (1 kHz).
const TICK_S: f64 = 0.001;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReleaseParams {
    /// Starting grasp, fraction of the closing range.
    pub closure: f64,
    pub close_speed_per_s: f64,
    pub lift_mm: f64,
    pub lift_speed_mm_s: f64,
    pub hold_s: f64,
    /// Opening speed, fraction of the range per s.
    pub release_speed_per_s: f64,
    /// On slip: close to `closure + regrasp`.
    pub regrasp: f64,
    /// How long to watch after the reaction, s.
    pub observe_s: f64,
    pub max_duration_s: f64,
}

/// The model and strategy of an online trial.
#[derive(Clone, Copy)]
pub struct Online<'m> {
    pub model: &'m ModelFile,
    pub strategy: Strategy,
}

#[derive(Debug, Clone, PartialEq)]
pub struct ReleaseRecord {
    pub recording: Recording,
    /// When the release (and the detector) started.
    pub armed_s: Option<f64>,
    pub reaction: Option<Reaction>,
    pub ended_s: f64,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Phase {
    Closing,
    Settling,
    Lifting,
    Releasing,
    Reacted,
}

pub fn run_release<C, H, A, M, S>(
    dev: &mut Devices<C, H, A, M, S>,
    p: &ReleaseParams,
    online: Option<Online<'_>>,
) -> Result<ReleaseRecord, ScenarioError>
where
    C: Clock,
    H: Hand,
    A: Arm,
    M: MarkerTracker,
    S: TactileSensor,
{
    let sensors = dev.sensors.len();
    let mut classifier = online.map(|o| FrameClassifier::new(o.model, sensors));
    let mut detector = online.map(|o| Detector::new(o.strategy, sensors));
    let start = dev.hand.present_positions().map_err(hand)?;
    let mut rec = Recording::default();
    let (mut phase, mut phase_t0) = (Phase::Closing, dev.clock.now_s());
    let mut armed_s = None;
    let mut reaction: Option<Reaction> = None;
    loop {
        let now = dev.clock.now_s();
        let elapsed = now - phase_t0;
        if now >= p.max_duration_s || reaction.is_some_and(|r| now >= r.time_s + p.observe_s) {
            break;
        }
        match phase {
            Phase::Closing => {
                let q = |i: usize| (start[i] + p.close_speed_per_s * elapsed).min(p.closure);
                dev.hand
                    .set_targets([q(0), q(1), q(2), start[3]])
                    .map_err(hand)?;
                if q(0) >= p.closure {
                    (phase, phase_t0) = (Phase::Settling, now);
                }
            }
            Phase::Settling if elapsed >= 0.3 => {
                dev.arm
                    .move_linear([0.0, 0.0, p.lift_mm], p.lift_speed_mm_s)
                    .map_err(arm)?;
                (phase, phase_t0) = (Phase::Lifting, now);
            }
            Phase::Lifting if elapsed >= p.lift_mm / p.lift_speed_mm_s + 0.2 + p.hold_s => {
                (phase, phase_t0) = (Phase::Releasing, now);
                armed_s = Some(now);
            }
            Phase::Releasing => {
                let q = (p.closure - p.release_speed_per_s * elapsed).max(0.0);
                dev.hand.set_targets([q, q, q, start[3]]).map_err(hand)?;
            }
            _ => {}
        }
        dev.clock.sleep(TICK_S);
        let first_new = rec.frames.len();
        dev.poll(&mut rec)?;
        if let (Some(c), Some(d)) = (classifier.as_mut(), detector.as_mut()) {
            for f in &rec.frames[first_new..] {
                // Every frame is classified so each sensor has its previous frame ready;
                // only frames of the release count towards a reaction.
                let Some(class) = c.classify(f) else { continue };
                if phase == Phase::Releasing && d.observe(usize::from(f.sensor), class) {
                    reaction = Some(Reaction {
                        time_s: f.time_s,
                        sensor: f.sensor,
                        seq: f.seq,
                    });
                    let q = (p.closure + p.regrasp).min(1.0);
                    dev.hand.set_targets([q, q, q, start[3]]).map_err(hand)?;
                    phase = Phase::Reacted;
                    break;
                }
            }
        }
    }
    dev.arm.stop().map_err(arm)?;
    Ok(ReleaseRecord {
        recording: rec,
        armed_s,
        reaction,
        ended_s: dev.clock.now_s(),
    })
}

fn hand<E: tmo_hal::Error>(e: E) -> ScenarioError {
    ScenarioError::Device {
        device: "hand",
        kind: e.kind(),
        message: e.to_string(),
    }
}

fn arm<E: tmo_hal::Error>(e: E) -> ScenarioError {
    ScenarioError::Device {
        device: "arm",
        kind: e.kind(),
        message: e.to_string(),
    }
}
