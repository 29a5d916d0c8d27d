//! The hand's and the arm's state in the trial log: `/state/hand` (the servos' present
//! positions and the torque limit in force) and `/state/arm` (the tool centre point's pose),
//! sampled every [`STATE_PERIOD_S`] of the trial clock.
//!
//! Never while the detector waits for slip: on the real rig, reading the servos' positions is
//! a round trip on their bus (about a millisecond at 1 Mbaud, more at slower rates), and a
//! slipping frame arriving meanwhile would wait for it. The reaction's latency matters more
//! than the state, which the commands in the log describe for that window anyway. Outside it
//! (approach, closing, lifting, after a reaction) every backend samples alike.

use serde_json::json;
use tmo_hal::{HandPositions, Pose};

use crate::trial::TrialEvent;

/// Trial-clock time between state samples, s (20 Hz: enough to draw the fingers' and the
/// arm's motion, little bus time on the real rig).
pub const STATE_PERIOD_S: f64 = 0.05;

pub const HAND_STATE: &str = "/state/hand";
pub const ARM_STATE: &str = "/state/arm";

/// Whether a state sample is due at `now`: the detector is not waiting for slip and the
/// last `/state/hand` in `events` (a trial's log so far, in time order) is at least
/// `period_s` old, or there is none.
pub fn state_due(events: &[TrialEvent], now: f64, period_s: f64, waiting_for_slip: bool) -> bool {
    if waiting_for_slip {
        return false;
    }
    for e in events.iter().rev() {
        if now - e.time_s >= period_s {
            // everything earlier is older still
            return true;
        }
        if e.topic == HAND_STATE {
            return false;
        }
    }
    true
}

/// The torque limit in force at the end of `events`: the last one commanded, or the last
/// state sample's; `None` when the trial has set none (the servos keep their own setting).
pub fn torque_limit_in_force(events: &[TrialEvent]) -> Option<f64> {
    for e in events.iter().rev() {
        match e.topic.as_str() {
            "/command/hand" => {
                if let Some(t) = e.data.get("torque_limit").and_then(|t| t.as_f64()) {
                    return Some(t);
                }
            }
            HAND_STATE => return e.data.get("torque_limit").and_then(|t| t.as_f64()),
            _ => {}
        }
    }
    None
}

/// The two state events of one sample at `now`, after `events`.
pub fn state_events(
    now: f64,
    positions: HandPositions,
    pose: Pose,
    events: &[TrialEvent],
) -> [TrialEvent; 2] {
    let mut hand = json!({ "positions": positions });
    if let Some(t) = torque_limit_in_force(events) {
        hand["torque_limit"] = json!(t);
    }
    [
        event(now, HAND_STATE, hand),
        event(
            now,
            ARM_STATE,
            json!({ "position_mm": pose.position_mm, "rotation_rad": pose.rotation_rad }),
        ),
    ]
}

/// A runner message for the trial log.
pub fn event(time_s: f64, topic: &str, data: serde_json::Value) -> TrialEvent {
    TrialEvent {
        time_s,
        topic: topic.to_string(),
        data,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(time_s: f64, topic: &str, data: serde_json::Value) -> TrialEvent {
        event(time_s, topic, data)
    }

    #[test]
    fn a_sample_is_due_a_period_after_the_last_and_never_while_waiting_for_slip() {
        let mut events = vec![at(0.0, "/phase", json!({"phase": "closing"}))];
        assert!(state_due(&events, 0.0, 0.05, false), "none yet");
        assert!(!state_due(&events, 0.0, 0.05, true), "waiting for slip");
        events.extend(state_events(0.0, [0.0; 4], Pose::default(), &events));
        for k in 1..40 {
            events.push(at(f64::from(k) * 0.001, "/classifier", json!({})));
        }
        assert!(!state_due(&events, 0.049, 0.05, false));
        assert!(state_due(&events, 0.05, 0.05, false));
        assert!(!state_due(&events, 0.05, 0.05, true));
    }

    #[test]
    fn the_torque_limit_in_force_is_the_last_commanded_and_carries_over_samples() {
        let mut events = vec![at(
            0.0,
            "/command/hand",
            json!({"targets": [0.1, 0.1, 0.1, 0.0]}),
        )];
        assert_eq!(torque_limit_in_force(&events), None);
        events.push(at(0.1, "/command/hand", json!({"torque_limit": 0.4})));
        events.push(at(
            0.2,
            "/command/hand",
            json!({"targets": [0.2, 0.2, 0.2, 0.0]}),
        ));
        let [hand, arm] = state_events(0.3, [0.5; 4], Pose::default(), &events);
        assert_eq!(hand.data["torque_limit"], json!(0.4));
        assert_eq!(hand.data["positions"], json!([0.5, 0.5, 0.5, 0.5]));
        assert_eq!(arm.topic, ARM_STATE);
        events.extend([hand, arm]);
        events.push(at(0.4, "/classifier", json!({})));
        assert_eq!(torque_limit_in_force(&events), Some(0.4), "from the sample");
        events.push(at(0.5, "/command/hand", json!({"torque_limit": 0.6})));
        assert_eq!(torque_limit_in_force(&events), Some(0.6));
    }
}
