//! Whole-hand release (SPEC.md "hand_release"): close on the object standing on the table,
//! lift it, hold it, then open the fingers slowly; with a model, classify every frame as it
//! arrives and, when the strategy fires, close to `regrasp` tighter than the starting grasp.
//!
//! The detector is armed only while releasing: closing and lifting make large pin motions
//! that are not slip, and the paper's hand reacts only during the release.

use std::sync::atomic::AtomicBool;

use tmo_hal::{Arm, Clock, Hand, MarkerTracker, TactileSensor};

pub use super::approach::ContactGrasp;
use super::approach::{ApproachStep, ContactApproach};
use super::monitor::{Verdict, WatchLimits};
use super::trial_run::TrialRun;
use super::{Fault, Online, RunRecord};
use crate::online::classify::Reaction;
use crate::runner::devices::{device, Devices, ScenarioError};
use serde_json::json;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReleaseParams {
    /// Starting grasp, fraction of the closing range (with `contact`, found at run time).
    pub closure: f64,
    /// Find the starting grasp from the pins instead: close until contact, then further.
    pub contact: Option<ContactGrasp>,
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
    pub watch: WatchLimits,
}

use super::TrialPhase as Phase;

/// Runs one release; `stop` set (by a Ctrl-C handler) ends it safely as [`Fault::Interrupted`].
pub fn run_release<C, H, A, M, S>(
    dev: &mut Devices<C, H, A, M, S>,
    p: &ReleaseParams,
    online: Option<Online<'_>>,
    stop: &AtomicBool,
) -> Result<RunRecord, ScenarioError>
where
    C: Clock,
    H: Hand,
    A: Arm,
    M: MarkerTracker,
    S: TactileSensor,
{
    let mut run = TrialRun::begin(dev, online, p.watch);
    let t0 = run.t0;
    let start = dev.hand.present_positions().map_err(device("hand"))?;
    let mut armed_s = None;
    let mut reaction: Option<Reaction> = None;
    let mut fault = None;
    let (mut phase, mut phase_t0) = (Phase::Closing, t0);
    // Where the closing ramp starts and ends; with a contact grasp, set at contact.
    let (mut close_from, mut closure) = ([start[0], start[1], start[2]], p.closure);
    let mut approach = None;
    if let Some(c) = p.contact {
        phase = Phase::Approaching;
        let from = start[..3].iter().copied().fold(f64::INFINITY, f64::min);
        approach = Some(ContactApproach::new(c, dev.sensors.len(), from, t0));
        run.log(
            t0,
            "/phase",
            json!({"phase": phase, "speed_per_s": c.approach_speed_per_s}),
        );
    } else {
        run.log(t0, "/phase", json!({"phase": phase}));
        run.log(
            t0,
            "/command/hand",
            json!({"ramp_to": closure, "speed_per_s": p.close_speed_per_s}),
        );
    }
    loop {
        let now = dev.clock.now_s();
        let elapsed = now - phase_t0;
        // The time limit counts from the trial's start: a real rig's clock runs on across a
        // batch, only the simulator's starts at zero with each trial.
        if now - t0 >= p.max_duration_s || reaction.is_some_and(|r| now >= r.time_s + p.observe_s) {
            break;
        }
        match phase {
            Phase::Approaching => match approach.as_ref().map(|a| a.step(now)) {
                Some(ApproachStep::Close(q)) => {
                    dev.hand
                        .set_targets([q, q, q, start[3]])
                        .map_err(device("hand"))?;
                }
                Some(ApproachStep::Contact {
                    closure: q,
                    grasp,
                    deformation_px,
                }) => {
                    (closure, close_from) = (grasp, [q; 3]);
                    (phase, phase_t0) = (Phase::Closing, now);
                    run.log(
                        now,
                        "/phase",
                        json!({"phase": "contact", "closure": q, "deformation_px": deformation_px}),
                    );
                    run.log(now, "/phase", json!({"phase": phase}));
                    run.log(
                        now,
                        "/command/hand",
                        json!({"ramp_to": closure, "speed_per_s": p.close_speed_per_s}),
                    );
                }
                Some(ApproachStep::NoContact { deformation_px }) => {
                    let f = Fault::NoContact { deformation_px };
                    run.log(now, "/fault", json!(f));
                    fault = Some(f);
                    dev.hold_hand(now, &mut run.events)?;
                    break;
                }
                None => unreachable!("approaching only with a contact grasp"),
            },
            Phase::Closing => {
                let q = |i: usize| (close_from[i] + p.close_speed_per_s * elapsed).min(closure);
                dev.hand
                    .set_targets([q(0), q(1), q(2), start[3]])
                    .map_err(device("hand"))?;
                if q(0) >= closure {
                    (phase, phase_t0) = (Phase::Settling, now);
                    run.log(now, "/phase", json!({"phase": phase}));
                }
            }
            Phase::Settling if elapsed >= 0.3 => {
                dev.arm
                    .move_linear([0.0, 0.0, p.lift_mm], p.lift_speed_mm_s)
                    .map_err(device("arm"))?;
                run.log(
                    now,
                    "/command/arm",
                    json!({"move_linear_mm": [0.0, 0.0, p.lift_mm], "speed_mm_s": p.lift_speed_mm_s}),
                );
                (phase, phase_t0) = (Phase::Lifting, now);
                run.log(now, "/phase", json!({"phase": phase}));
            }
            Phase::Lifting if elapsed >= p.lift_mm / p.lift_speed_mm_s + 0.2 + p.hold_s => {
                (phase, phase_t0) = (Phase::Releasing, now);
                armed_s = Some(now);
                run.log(now, "/phase", json!({"phase": phase}));
                run.log(
                    now,
                    "/command/hand",
                    json!({"ramp_to": 0.0, "speed_per_s": -p.release_speed_per_s}),
                );
            }
            Phase::Releasing => {
                let q = (closure - p.release_speed_per_s * elapsed).max(0.0);
                dev.hand
                    .set_targets([q, q, q, start[3]])
                    .map_err(device("hand"))?;
            }
            _ => {}
        }
        let releasing = phase == Phase::Releasing;
        let step = run.step(dev, releasing, |_| releasing, stop)?;
        if let Some(a) = approach.as_mut() {
            a.observe(&run.rec.frames[step.first_new..]);
        }
        let now = step.now;
        match step.verdict {
            Verdict::Continue => {}
            Verdict::Abort(f) => {
                // Make safe: the fingers hold; the arm stops below.
                fault = Some(f);
                dev.hold_hand(now, &mut run.events)?;
                break;
            }
            Verdict::React(r) => {
                reaction = Some(r);
                let q = (closure + p.regrasp).min(1.0);
                dev.hand
                    .set_targets([q, q, q, start[3]])
                    .map_err(device("hand"))?;
                phase = Phase::Reacted;
                run.log(
                    now,
                    "/command/hand",
                    json!({ "targets": [q, q, q, start[3]] }),
                );
                run.log(now, "/phase", json!({"phase": phase}));
            }
        }
    }
    // A release judged without its release phase would be scored "held, no slip".
    if fault.is_none() && phase < Phase::Releasing {
        let f = Fault::PhaseNotReached {
            reached: phase,
            needed: Phase::Releasing,
        };
        run.log(dev.clock.now_s(), "/fault", json!(f));
        fault = Some(f);
        dev.hold_hand(dev.clock.now_s(), &mut run.events)?;
    }
    dev.arm.stop().map_err(device("arm"))?;
    run.log(dev.clock.now_s(), "/command/arm", json!({"stop": true}));
    Ok(run.finish(dev.clock.now_s(), armed_s, reaction, fault))
}

#[cfg(test)]
mod tests {
    use std::sync::{Arc, Mutex};

    use tmo_hal::{HandPositions, PinFrame};

    use super::*;
    use crate::runner::mocks::{
        threshold_model, MockArm, MockHand, MockMarkers, MockSensor, SharedClock, PINS,
    };
    use crate::runner::Fault;

    /// What a mock sensor does: from `slip_from_s` all pins move 2 px per frame (slip for
    /// a threshold of 0.5 px/frame); from `silent_from_s` it sends nothing; from
    /// `frozen_from_s` it repeats its last frame exactly.
    #[derive(Clone, Copy)]
    struct Script {
        slip_from_s: f64,
        silent_from_s: f64,
        frozen_from_s: f64,
    }

    fn slips_from(t: f64) -> Script {
        Script {
            slip_from_s: t,
            silent_from_s: 99.0,
            frozen_from_s: 99.0,
        }
    }

    /// A sensor delivering 60 fps from `phase_s` as `script` says.
    fn sensor(id: u8, phase_s: f64, script: Script, clock: SharedClock) -> MockSensor {
        let mut s = MockSensor::new();
        let mut next = 0u64;
        let mut x = 0.0f32;
        let mut y = 50.0f32;
        s.expect_next_frame().returning(move || {
            let t = phase_s + next as f64 / 60.0;
            if t > clock.now_s() || t >= script.silent_from_s {
                return Ok(None);
            }
            next += 1;
            if t < script.frozen_from_s {
                if t >= script.slip_from_s {
                    x += 2.0;
                }
                // a hair of noise, as real frames have, so still pins are not stale frames
                y = 50.0 + 0.01 * (next % 2) as f32;
            }
            Ok(Some(PinFrame {
                sensor: id,
                seq: next,
                time_s: t,
                pins: (0..PINS).map(|i| [x + 10.0 * i as f32, y]).collect(),
            }))
        });
        s
    }

    const CLOSURE: f64 = 0.4;

    fn params() -> ReleaseParams {
        ReleaseParams {
            closure: CLOSURE,
            contact: None,
            close_speed_per_s: 0.05,
            lift_mm: 10.0,
            lift_speed_mm_s: 100.0,
            hold_s: 0.0,
            release_speed_per_s: 0.01,
            regrasp: 0.02,
            observe_s: 0.2,
            max_duration_s: 3.0,
            watch: WatchLimits::default(),
        }
    }

    /// Runs a release with sensors that start slipping at the given times; returns the
    /// record and every target the hand was sent.
    fn run(scripts: [Script; 3], strategy: &str) -> (RunRecord, Vec<HandPositions>) {
        run_sampling_state(scripts, strategy, None)
    }

    /// [`run`] with the devices' state sampled every `state_period_s`.
    fn run_sampling_state(
        scripts: [Script; 3],
        strategy: &str,
        state_period_s: Option<f64>,
    ) -> (RunRecord, Vec<HandPositions>) {
        run_with(scripts, strategy, state_period_s, params(), 0.0)
    }

    /// [`run_sampling_state`] with other parameters, each hand command taking `command_s`
    /// of the clock's time (a slow bus, a loop that falls behind).
    fn run_with(
        scripts: [Script; 3],
        strategy: &str,
        state_period_s: Option<f64>,
        p: ReleaseParams,
        command_s: f64,
    ) -> (RunRecord, Vec<HandPositions>) {
        let clock = SharedClock::default();
        let sent = Arc::new(Mutex::new(Vec::new()));
        let mut hand = MockHand::new();
        hand.expect_present_positions()
            .returning(|| Ok([CLOSURE, CLOSURE, CLOSURE, 0.0]));
        let log = sent.clone();
        let mut bus = clock.clone();
        hand.expect_set_targets().returning(move |t| {
            log.lock().unwrap().push(t);
            let now = bus.now_s();
            bus.sleep_until(now + command_s);
            Ok(())
        });
        let mut arm = MockArm::new();
        arm.expect_move_linear()
            .withf(|offset, speed| *offset == [0.0, 0.0, 10.0] && *speed == 100.0)
            // a loop held up by its commands may fault before it lifts
            .times(if command_s > 0.0 { 0..=1 } else { 1..=1 })
            .returning(|_, _| Ok(()));
        arm.expect_stop().times(1).returning(|| Ok(()));
        arm.expect_tcp_pose().returning(|| {
            Ok(tmo_hal::Pose {
                position_mm: [1.0, 2.0, 3.0],
                rotation_rad: [0.0, 0.0, 0.5],
            })
        });
        let mut markers = MockMarkers::new();
        markers.expect_next_sample().returning(|| Ok(None));
        let sensors = (0..3)
            .map(|k| sensor(k as u8, 0.004 * k as f64, scripts[k], clock.clone()))
            .collect();
        let mut devices = Devices {
            clock,
            hand,
            arm,
            markers,
            sensors,
            live: None,
            state_period_s,
            in_flight: None,
        };
        let model = threshold_model().into();
        let online = Online {
            model: &model,
            strategy: strategy.parse().unwrap(),
        };
        let record = run_release(&mut devices, &p, Some(online), &AtomicBool::new(false)).unwrap();
        let targets = sent.lock().unwrap().clone();
        (record, targets)
    }

    fn with_deadline(p: ReleaseParams) -> ReleaseParams {
        ReleaseParams {
            watch: WatchLimits {
                deadline: Some(crate::online::deadline::Deadline::at_rate(
                    Default::default(),
                    60.0,
                )),
                ..p.watch
            },
            ..p
        }
    }

    #[test]
    fn a_release_cut_short_before_it_releases_faults_naming_the_phase_it_reached() {
        let p = ReleaseParams {
            max_duration_s: 0.4,
            ..params()
        };
        let scripts = [slips_from(99.0); 3];
        let (record, _) = run_with(scripts, "1x1", None, p, 0.0);
        assert_eq!(
            record.fault,
            Some(Fault::PhaseNotReached {
                reached: Phase::Lifting,
                needed: Phase::Releasing
            })
        );
        assert_eq!(record.reaction, None);
        let logged = record.events.iter().find(|e| e.topic == "/fault").unwrap();
        assert_eq!(logged.data["fault"], "phase_not_reached");
        assert_eq!(logged.data["reached"], "lifting");
    }

    #[test]
    fn every_classified_frame_is_timed_and_a_loop_on_time_keeps_its_deadline() {
        let scripts = [slips_from(1.0), slips_from(1.1), slips_from(99.0)];
        let (record, _) = run_with(scripts, "2x2", None, with_deadline(params()), 0.0);
        assert_eq!(record.fault, None);
        assert!(record.reaction.is_some());
        let timed: Vec<&serde_json::Value> = record
            .events
            .iter()
            .filter(|e| e.topic == "/timing")
            .map(|e| &e.data)
            .collect();
        assert!(timed.len() > 100, "{}", timed.len());
        // the mock clock waits for the computer: every frame within its period
        assert!(timed
            .iter()
            .all(|t| t["lateness_ms"].as_f64().unwrap() < 0.0));
        // and without a deadline (replay), nothing is timed
        let (plain, _) = run_with(scripts, "2x2", None, params(), 0.0);
        assert!(plain.events.iter().all(|e| e.topic != "/timing"));
        assert_eq!(plain.reaction, record.reaction);
    }

    #[test]
    fn a_loop_held_up_by_its_commands_faults_on_its_deadline_and_is_never_scored() {
        // each hand command takes 40 ms: closing (a command every tick), the loop falls
        // more than two periods behind its frames
        let scripts = [slips_from(99.0); 3];
        let (record, _) = run_with(scripts, "1x1", None, with_deadline(params()), 0.04);
        let Some(Fault::Deadline(crate::online::deadline::DeadlineBreach::Frame {
            latency_ms,
            limit_ms,
            ..
        })) = record.fault
        else {
            panic!("{:?}", record.fault);
        };
        assert!(latency_ms > limit_ms && (limit_ms - 33.33).abs() < 0.01);
        assert_eq!(record.reaction, None);
        let logged = record.events.iter().find(|e| e.topic == "/fault").unwrap();
        assert_eq!(logged.data["fault"], "deadline");
        assert_eq!(logged.data["breach"], "frame");
    }

    fn regrasps(targets: &[HandPositions]) -> usize {
        let q = CLOSURE + 0.02;
        targets
            .iter()
            .filter(|t| t[..3].iter().all(|v| (v - q).abs() < 1e-12))
            .count()
    }

    #[test]
    fn two_by_two_regrasps_once_on_the_second_slip_frame_of_the_second_sensor() {
        // Sensor 0 slips from 1.0 s, sensor 1 from 1.1 s, sensor 2 never.
        let (record, targets) = run([slips_from(1.0), slips_from(1.1), slips_from(99.0)], "2x2");
        let armed = record.armed_s.unwrap();
        assert!((armed - 0.6).abs() < 0.01, "armed at {armed}");
        let reaction = record.reaction.expect("reacted");
        assert_eq!(reaction.sensor, 1);
        // sensor 1's frames fall at 0.004 + k/60; its first slip frame is the first at or
        // after 1.1 s, the reaction comes on the next one
        let first_slip = (((1.1 - 0.004) * 60.0_f64).ceil()) / 60.0 + 0.004;
        assert!(
            (reaction.time_s - (first_slip + 1.0 / 60.0)).abs() < 1e-9,
            "reacted at {}",
            reaction.time_s
        );
        assert_eq!(regrasps(&targets), 1, "exactly one regrasp");
        let topics = |t: &str| record.events.iter().filter(|e| e.topic == t).count();
        let detector: Vec<&serde_json::Value> = record
            .events
            .iter()
            .filter(|e| e.topic == "/detector")
            .map(|e| &e.data["event"])
            .collect();
        assert_eq!(detector, ["armed", "reaction", "disarmed"]);
        assert_eq!(
            topics("/phase"),
            5,
            "closing, settling, lifting, releasing, reacted"
        );
        assert!(topics("/classifier") > 100);
        // nothing is sent after the regrasp: the hand holds the new grasp
        assert_eq!(regrasps(&targets[targets.len() - 1..]), 1);
        assert!(record.ended_s >= reaction.time_s + 0.2);
    }

    #[test]
    fn state_is_sampled_at_its_period_but_never_while_the_detector_waits_for_slip() {
        let (record, _) = run_sampling_state(
            [slips_from(1.0), slips_from(1.1), slips_from(99.0)],
            "2x2",
            Some(0.05),
        );
        let (armed, reacted) = (record.armed_s.unwrap(), record.reaction.unwrap().time_s);
        let times = |topic: &str| -> Vec<f64> {
            record
                .events
                .iter()
                .filter(|e| e.topic == topic)
                .map(|e| e.time_s)
                .collect()
        };
        let hand = times("/state/hand");
        assert_eq!(hand, times("/state/arm"), "hand and arm sampled together");
        assert!(
            hand.iter().all(|&t| t < armed || t >= reacted),
            "sampled while waiting for slip: {hand:?}"
        );
        // every 50 ms (or the tick after) from the start to the arming at 0.6 s, and again
        // over the 0.2 s observed after the reaction
        let before = hand.iter().filter(|&&t| t < armed).count();
        assert!(
            (11..=12).contains(&before),
            "{before} before arming: {hand:?}"
        );
        assert!(
            hand.iter().filter(|&&t| t >= reacted).count() >= 3,
            "{hand:?}"
        );
        for pair in hand.windows(2) {
            assert!(pair[1] - pair[0] >= 0.05 - 1e-9, "{hand:?}");
        }
        let first = |topic: &str| record.events.iter().find(|e| e.topic == topic).unwrap();
        assert_eq!(
            first("/state/arm").data["position_mm"],
            serde_json::json!([1.0, 2.0, 3.0])
        );
        let hand_sample = first("/state/hand");
        assert_eq!(
            hand_sample.data["positions"],
            serde_json::json!([CLOSURE, CLOSURE, CLOSURE, 0.0])
        );
        assert!(hand_sample.data.get("torque_limit").is_none(), "none set");
    }

    #[test]
    fn one_sensor_slipping_never_fires_a_two_sensor_strategy() {
        let (record, targets) = run([slips_from(1.0), slips_from(99.0), slips_from(99.0)], "2x2");
        assert_eq!(record.reaction, None);
        assert_eq!(regrasps(&targets), 0);
        // the release ran to the time limit, opening the fingers
        assert!(targets.last().unwrap()[0] < CLOSURE);
        let (record, _) = run([slips_from(1.0), slips_from(99.0), slips_from(99.0)], "1x1");
        let r = record.reaction.unwrap();
        assert_eq!(r.sensor, 0);
        assert!(r.time_s >= 1.0 && r.time_s < 1.0 + 1.0 / 60.0 + 1e-9);
    }

    #[test]
    fn slip_before_the_release_is_not_acted_on() {
        // Pins moving from the start (closing, lifting): no reaction until armed.
        let (record, _) = run([slips_from(0.0); 3], "1x1");
        let r = record.reaction.unwrap();
        assert!(r.time_s >= record.armed_s.unwrap(), "{r:?}");
    }

    #[test]
    fn a_silent_or_frozen_sensor_aborts_the_trial_safely() {
        let silent = Script {
            silent_from_s: 1.0,
            ..slips_from(99.0)
        };
        let (record, targets) = run([slips_from(99.0), silent, slips_from(99.0)], "2x2");
        let Some(Fault::SilentSensor {
            sensor,
            last_frame_s,
        }) = record.fault
        else {
            panic!("{:?}", record.fault)
        };
        assert_eq!(sensor, 1);
        assert!(last_frame_s < 1.0 + 1e-9);
        assert!((record.ended_s - (last_frame_s + 0.25)).abs() < 0.01);
        // the hand was told to hold where it was
        assert_eq!(targets.last().unwrap(), &[CLOSURE, CLOSURE, CLOSURE, 0.0]);

        let frozen = Script {
            frozen_from_s: 1.0,
            ..slips_from(99.0)
        };
        let (record, _) = run([frozen, slips_from(99.0), slips_from(99.0)], "2x2");
        assert!(
            matches!(
                record.fault,
                Some(Fault::StaleFrames {
                    sensor: 0,
                    repeats: 10
                })
            ),
            "{:?}",
            record.fault
        );
        assert!(record.ended_s > 1.0 + 9.0 / 60.0 && record.ended_s < 1.0 + 12.0 / 60.0);
    }

    /// A hand whose fingertips touch the object at `touch` closure: past it, every pin
    /// shifts 20 px per unit of closure (the sensors deform). Returns the record and the
    /// targets the hand was sent.
    fn run_contact_grasp(touch: f64, max_closure: f64) -> (RunRecord, Vec<HandPositions>) {
        run_contact_grasp_from(0.0, touch, max_closure)
    }

    /// [`run_contact_grasp`] on a clock that reads `start_s` when the trial begins.
    fn run_contact_grasp_from(
        start_s: f64,
        touch: f64,
        max_closure: f64,
    ) -> (RunRecord, Vec<HandPositions>) {
        let mut clock = SharedClock::default();
        clock.sleep_until(start_s);
        let sent = Arc::new(Mutex::new(Vec::<HandPositions>::new()));
        let mut hand = MockHand::new();
        hand.expect_present_positions()
            .returning(|| Ok([0.2, 0.2, 0.2, 0.0]));
        let log = sent.clone();
        hand.expect_set_targets().returning(move |t| {
            log.lock().unwrap().push(t);
            Ok(())
        });
        let mut arm = MockArm::new();
        arm.expect_move_linear().returning(|_, _| Ok(()));
        arm.expect_stop().returning(|| Ok(()));
        let mut markers = MockMarkers::new();
        markers.expect_next_sample().returning(|| Ok(None));
        let sensors = (0..3u8)
            .map(|id| {
                let (clock, sent) = (clock.clone(), sent.clone());
                let mut s = MockSensor::new();
                let mut next = 0u64;
                s.expect_next_frame().returning(move || {
                    let t = start_s + next as f64 / 60.0;
                    if t > clock.now_s() {
                        return Ok(None);
                    }
                    next += 1;
                    let q = sent.lock().unwrap().last().map_or(0.2, |t| t[0]);
                    let x = (20.0 * (q - touch).max(0.0)) as f32;
                    let y = 50.0 + 0.01 * (next % 2) as f32;
                    Ok(Some(PinFrame {
                        sensor: id,
                        seq: next,
                        time_s: t,
                        pins: (0..PINS).map(|i| [x + 10.0 * i as f32, y]).collect(),
                    }))
                });
                s
            })
            .collect();
        let mut devices = Devices {
            clock,
            hand,
            arm,
            markers,
            sensors,
            live: None,
            state_period_s: None,
            in_flight: None,
        };
        let p = ReleaseParams {
            contact: Some(ContactGrasp {
                deformation_px: 0.5,
                approach_speed_per_s: 0.05,
                past_contact: 0.05,
                max_closure,
            }),
            max_duration_s: 8.0,
            ..params()
        };
        let record = run_release(&mut devices, &p, None, &AtomicBool::new(false)).unwrap();
        let targets = sent.lock().unwrap().clone();
        (record, targets)
    }

    #[test]
    fn a_contact_grasp_closes_past_the_closure_where_the_pins_deform() {
        let (record, targets) = run_contact_grasp(0.3, 0.95);
        let contact = record
            .events
            .iter()
            .find(|e| e.topic == "/phase" && e.data["phase"] == "contact")
            .expect("contact found");
        let at = contact.data["closure"].as_f64().unwrap();
        // 0.5 px of deformation is 0.025 past the touch; one tick and one frame late at most
        assert!(
            (0.325..0.325 + 0.05 * (1.0 / 60.0 + 0.002) + 1e-9).contains(&at),
            "{at}"
        );
        let grasp = targets
            .iter()
            .map(|t| t[0])
            .fold(f64::NEG_INFINITY, f64::max);
        assert!(
            (grasp - (at + 0.05)).abs() < 1e-9,
            "grasp {grasp}, contact {at}"
        );
        assert!(record.armed_s.is_some(), "lifted and released");
        assert_eq!(record.fault, None);
    }

    #[test]
    fn a_contact_grasp_that_finds_nothing_stops_at_the_closure_limit_before_lifting() {
        let (record, targets) = run_contact_grasp(0.9, 0.45);
        assert!(
            matches!(record.fault, Some(Fault::NoContact { .. })),
            "{:?}",
            record.fault
        );
        assert!(targets.iter().all(|t| t[0] <= 0.45 + 1e-12));
        assert_eq!(record.armed_s, None);
    }

    #[test]
    fn a_trial_late_on_a_batch_clock_gets_its_whole_time_limit() {
        // the real backend's clock starts with the batch, not with each trial
        let (early, _) = run_contact_grasp(0.3, 0.95);
        let (late, _) = run_contact_grasp_from(100.0, 0.3, 0.95);
        let late_armed = late.armed_s.expect("lifted and released") - 100.0;
        // the same run, give or take a frame (ticks and frames fall differently at 100 s)
        assert!(
            (late_armed - early.armed_s.unwrap()).abs() < 0.02,
            "{late_armed} vs {:?}",
            early.armed_s
        );
        assert!((late.ended_s - 100.0 - early.ended_s).abs() < 0.02);
    }
}
