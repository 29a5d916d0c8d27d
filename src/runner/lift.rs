//! First-time lift (SPEC.md "first_time_lift"; paper Sec. VI-B): close the open hand
//! until every sensor shows contact (deformation `d(t)` at the set value), raise the arm;
//! whenever the strategy fires, close by `close_step` and ignore the detector for `pause_s`
//! (the fingers move and fresh frames arrive). After the hold the arm lowers the object
//! back to the table and the hand opens, ready for the next trial.
//!
//! Phases logged on `/phase`: `approaching`, `contact` (with `closure`, the paper's
//! g_cont), `lifting` (the scoring window opens), `holding`, `hold_end` (with `closure`,
//! g_slip; the window closes), `lowering`, `opening`. Scoring reads these and the marker
//! track only ([`crate::outcome::lift`]).

use std::sync::atomic::AtomicBool;

use serde_json::json;
use tmo_hal::{Arm, Clock, Hand, MarkerTracker, TactileSensor};

use super::approach::{ApproachStep, ContactApproach, ContactGrasp};
use super::monitor::{Verdict, WatchLimits};
use super::trial_run::TrialRun;
use super::{Fault, Online, RunRecord};
use crate::online::classify::Reaction;
use crate::runner::devices::{device, Devices, ScenarioError};

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LiftParams {
    /// Deformation of the least-deformed sensor that counts as contact, px.
    pub deformation_px: f64,
    /// Closing speed while looking for contact, fraction of the range per s.
    pub approach_speed_per_s: f64,
    /// Never close past this.
    pub max_closure: f64,
    pub lift_mm: f64,
    pub lift_speed_mm_s: f64,
    /// On slip: close by this fraction of the range.
    pub close_step: f64,
    /// After a response the detector ignores frames this long, s.
    pub pause_s: f64,
    /// Hold at the top before scoring and lowering, s.
    pub hold_s: f64,
    pub watch: WatchLimits,
}

/// Time the arm needs for a move of `mm` at `speed` (plus its acceleration), s.
pub(super) fn move_time_s(mm: f64, speed_mm_s: f64) -> f64 {
    mm.abs() / speed_mm_s + 0.3
}

/// What a lift runner carries through its phases, with the devices it drives.
pub(super) struct LiftRun<'m, 'd, C, H, A, M, S> {
    pub dev: &'d mut Devices<C, H, A, M, S>,
    pub trial: TrialRun<'m>,
    /// The fourth servo (the thumb's rotation) is left where it started.
    pub start: [f64; 4],
}

impl<'m, 'd, C, H, A, M, S> LiftRun<'m, 'd, C, H, A, M, S>
where
    C: Clock,
    H: Hand,
    A: Arm,
    M: MarkerTracker,
    S: TactileSensor,
{
    pub fn new(
        dev: &'d mut Devices<C, H, A, M, S>,
        online: Option<Online<'m>>,
        watch: WatchLimits,
    ) -> Result<Self, ScenarioError> {
        let trial = TrialRun::begin(dev, online, watch);
        let start = dev.hand.present_positions().map_err(device("hand"))?;
        Ok(Self { dev, trial, start })
    }

    pub fn phase(&mut self, now: f64, phase: &str, data: serde_json::Value) {
        let mut d = json!({ "phase": phase });
        if let (Some(d), Some(extra)) = (d.as_object_mut(), data.as_object()) {
            d.extend(extra.clone());
        }
        self.trial.log(now, "/phase", d);
    }

    /// Sets the three fingers to `closure` (the thumb rotation stays).
    pub fn grip(&mut self, closure: f64) -> Result<(), ScenarioError> {
        let targets = [closure, closure, closure, self.start[3]];
        self.dev.hand.set_targets(targets).map_err(device("hand"))?;
        let now = self.dev.clock.now_s();
        self.trial
            .log(now, "/command/hand", json!({ "targets": targets }));
        Ok(())
    }

    /// Moves the arm up (or down, negative) by `mm`.
    pub fn raise(&mut self, mm: f64, speed_mm_s: f64) -> Result<(), ScenarioError> {
        self.dev
            .arm
            .move_linear([0.0, 0.0, mm], speed_mm_s)
            .map_err(device("arm"))?;
        let now = self.dev.clock.now_s();
        self.trial.log(
            now,
            "/command/arm",
            json!({"move_linear_mm": [0.0, 0.0, mm], "speed_mm_s": speed_mm_s}),
        );
        Ok(())
    }

    /// One tick; `armed` frames count towards a reaction.
    pub fn step(
        &mut self,
        armed: bool,
        stop: &AtomicBool,
    ) -> Result<(Verdict, f64, usize), ScenarioError> {
        let step = self.trial.step(self.dev, armed, |_| armed, stop)?;
        Ok((step.verdict, step.now, step.first_new))
    }

    /// Ticks with the detector disarmed until `until_s`; `Some(fault)` if one ended it.
    pub fn idle_until(
        &mut self,
        until_s: f64,
        stop: &AtomicBool,
    ) -> Result<Option<Fault>, ScenarioError> {
        while self.dev.clock.now_s() < until_s {
            if let (Verdict::Abort(f), _, _) = self.step(false, stop)? {
                return Ok(Some(f));
            }
        }
        Ok(None)
    }

    /// Closes all three fingers from where they are until every sensor's deformation reaches
    /// `goal_px`; the closure there (g_cont), or the fault that stopped it.
    pub fn close_to_contact(
        &mut self,
        goal_px: f64,
        speed_per_s: f64,
        max_closure: f64,
        stop: &AtomicBool,
    ) -> Result<Result<f64, Fault>, ScenarioError> {
        let t0 = self.dev.clock.now_s();
        let from = self.start[..3]
            .iter()
            .copied()
            .fold(f64::INFINITY, f64::min);
        self.phase(t0, "approaching", json!({ "speed_per_s": speed_per_s }));
        let grasp = ContactGrasp {
            deformation_px: goal_px,
            approach_speed_per_s: speed_per_s,
            past_contact: 0.0,
            max_closure,
        };
        let mut approach = ContactApproach::new(grasp, self.dev.sensors.len(), from, t0);
        loop {
            // the target is set, then the frames that arrive with it are judged
            let set_at = self.dev.clock.now_s();
            let q = approach.target(set_at);
            self.dev
                .hand
                .set_targets([q, q, q, self.start[3]])
                .map_err(device("hand"))?;
            let (v, now, first_new) = self.step(false, stop)?;
            if let Verdict::Abort(f) = v {
                return Ok(Err(f));
            }
            approach.observe(&self.trial.rec.frames[first_new..]);
            match approach.step(set_at) {
                ApproachStep::Close(_) => {}
                ApproachStep::Contact {
                    closure: q,
                    deformation_px: d,
                    ..
                } => {
                    self.phase(now, "contact", json!({ "closure": q, "deformation_px": d }));
                    self.grip(q)?;
                    return Ok(Ok(q));
                }
                ApproachStep::NoContact { deformation_px } => {
                    let f = Fault::NoContact { deformation_px };
                    self.trial.log(now, "/fault", json!(f));
                    return Ok(Err(f));
                }
            }
        }
    }

    /// Ends a trial: the arm stops; after a fault the fingers hold where they are.
    pub fn finish(
        mut self,
        armed_s: Option<f64>,
        reaction: Option<Reaction>,
        fault: Option<Fault>,
    ) -> Result<RunRecord, ScenarioError> {
        let now = self.dev.clock.now_s();
        if fault.is_some() {
            self.dev.hold_hand(now, &mut self.trial.events)?;
        }
        self.dev.arm.stop().map_err(device("arm"))?;
        self.trial.log(now, "/command/arm", json!({"stop": true}));
        Ok(self.trial.finish(now, armed_s, reaction, fault))
    }
}

/// Runs one first-time lift; with no model (collect) the hand never tightens.
pub fn run_first_time_lift<C, H, A, M, S>(
    dev: &mut Devices<C, H, A, M, S>,
    p: &LiftParams,
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
    let mut run = LiftRun::new(dev, online, p.watch)?;
    let mut closure = match run.close_to_contact(
        p.deformation_px,
        p.approach_speed_per_s,
        p.max_closure,
        stop,
    )? {
        Ok(q) => q,
        Err(f) => return run.finish(None, None, Some(f)),
    };
    // Let the skin settle after closing before the arm moves.
    let now = run.dev.clock.now_s();
    if let Some(f) = run.idle_until(now + 0.3, stop)? {
        return run.finish(None, None, Some(f));
    }
    let lift_start = run.dev.clock.now_s();
    run.phase(lift_start, "lifting", json!({}));
    run.raise(p.lift_mm, p.lift_speed_mm_s)?;
    let top = lift_start + move_time_s(p.lift_mm, p.lift_speed_mm_s);
    let hold_end = top + p.hold_s;
    let (mut first, mut pause_until, mut holding) = (None::<Reaction>, lift_start, false);
    while run.dev.clock.now_s() < hold_end {
        let armed = run.dev.clock.now_s() >= pause_until;
        let (v, now, _) = run.step(armed, stop)?;
        if !holding && now >= top {
            holding = true;
            run.phase(now, "holding", json!({}));
        }
        match v {
            Verdict::Continue => {}
            Verdict::Abort(f) => return run.finish(Some(lift_start), first, Some(f)),
            Verdict::React(r) => {
                first.get_or_insert(r);
                closure = (closure + p.close_step).min(p.max_closure);
                run.grip(closure)?;
                pause_until = now + p.pause_s;
                run.trial.monitor.rearm();
            }
        }
    }
    let now = run.dev.clock.now_s();
    run.phase(now, "hold_end", json!({ "closure": closure }));
    run.phase(now, "lowering", json!({}));
    run.raise(-p.lift_mm, p.lift_speed_mm_s)?;
    if let Some(f) = run.idle_until(now + move_time_s(p.lift_mm, p.lift_speed_mm_s), stop)? {
        return run.finish(Some(lift_start), first, Some(f));
    }
    let now = run.dev.clock.now_s();
    run.phase(now, "opening", json!({}));
    let open = run.start[0];
    run.grip(open)?;
    let fault = run.idle_until(now + 0.5, stop)?;
    run.finish(Some(lift_start), first, fault)
}

#[cfg(test)]
mod tests {
    use std::sync::{Arc, Mutex};

    use tmo_hal::PinFrame;

    use super::*;
    use crate::runner::mocks::{
        threshold_model, MockArm, MockHand, MockMarkers, MockSensor, SharedClock, PINS,
    };

    /// What the mock rig shares: the last finger target and whether the arm is up.
    #[derive(Default)]
    struct World {
        closure: f64,
        lifted: bool,
        targets: Vec<(f64, [f64; 4])>,
    }

    const OPEN: f64 = 0.25;
    /// Pins shift this many px per unit of closure past the touch point (0.3).
    const GAIN_PX: f64 = 20.0;
    /// g_cont: where the pins have moved 0.5 px.
    const CONTACT: f64 = 0.3 + 0.5 / GAIN_PX;

    fn params() -> LiftParams {
        LiftParams {
            deformation_px: 0.5,
            approach_speed_per_s: 0.1,
            max_closure: 0.95,
            lift_mm: 20.0,
            lift_speed_mm_s: 20.0,
            close_step: 0.01,
            pause_s: 0.1,
            hold_s: 0.5,
            watch: WatchLimits::default(),
        }
    }

    /// A sensor whose pins are pressed in by the closure past 0.3 and, while the arm is up
    /// and the closure is below `holds_at`, drag 2 px per frame (slip).
    fn sensor(
        id: u8,
        world: Arc<Mutex<World>>,
        clock: SharedClock,
        gain: f64,
        holds_at: f64,
    ) -> MockSensor {
        let mut s = MockSensor::new();
        let (mut next, mut x) = (0u64, 0.0f32);
        s.expect_next_frame().returning(move || {
            let t = 0.003 * f64::from(id) + next as f64 / 60.0;
            if t > clock.now_s() {
                return Ok(None);
            }
            next += 1;
            let w = world.lock().unwrap();
            if w.lifted && w.closure < holds_at {
                x += 2.0;
            }
            let press = (gain * (w.closure - 0.3).max(0.0)) as f32;
            let noise = 0.01 * (next % 2) as f32;
            Ok(Some(PinFrame {
                sensor: id,
                seq: next,
                time_s: t,
                pins: (0..PINS)
                    .map(|i| [x + 10.0 * i as f32, 50.0 + press + noise])
                    .collect(),
            }))
        });
        s
    }

    fn run(gain: f64, holds_at: f64) -> (RunRecord, Vec<(f64, [f64; 4])>, usize) {
        let clock = SharedClock::default();
        let world = Arc::new(Mutex::new(World {
            closure: OPEN,
            ..Default::default()
        }));
        let mut hand = MockHand::new();
        let w = world.clone();
        hand.expect_present_positions().returning(move || {
            let q = w.lock().unwrap().closure;
            Ok([q, q, q, 0.0])
        });
        let (w, c) = (world.clone(), clock.clone());
        hand.expect_set_targets().returning(move |t| {
            let mut w = w.lock().unwrap();
            w.closure = t[0];
            w.targets.push((c.now_s(), t));
            Ok(())
        });
        let moves = Arc::new(Mutex::new(0usize));
        let mut arm = MockArm::new();
        let (w, m) = (world.clone(), moves.clone());
        arm.expect_move_linear().returning(move |offset, _| {
            w.lock().unwrap().lifted = offset[2] > 0.0;
            *m.lock().unwrap() += 1;
            Ok(())
        });
        arm.expect_stop().times(1).returning(|| Ok(()));
        let mut markers = MockMarkers::new();
        markers.expect_next_sample().returning(|| Ok(None));
        let sensors = (0..3)
            .map(|k| sensor(k, world.clone(), clock.clone(), gain, holds_at))
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
        let model = threshold_model().into();
        let online = Online {
            model: &model,
            strategy: "1x1".parse().unwrap(),
        };
        let record = run_first_time_lift(
            &mut devices,
            &params(),
            Some(online),
            &AtomicBool::new(false),
        )
        .unwrap();
        let targets = world.lock().unwrap().targets.clone();
        let moves = *moves.lock().unwrap();
        (record, targets, moves)
    }

    fn phase_data(r: &RunRecord, name: &str) -> Option<(f64, serde_json::Value)> {
        r.events
            .iter()
            .find(|e| e.topic == "/phase" && e.data["phase"] == name)
            .map(|e| (e.time_s, e.data.clone()))
    }

    #[test]
    fn each_slip_closes_one_step_never_inside_the_pause_until_the_object_holds() {
        // the grasp holds 0.035 past contact: four 1 % steps
        let (r, _, moves) = run(GAIN_PX, CONTACT + 0.035);
        assert_eq!(r.fault, None);
        let (_, contact) = phase_data(&r, "contact").unwrap();
        let g_cont = contact["closure"].as_f64().unwrap();
        assert!((g_cont - CONTACT).abs() < 0.002, "g_cont {g_cont}");
        let reactions: Vec<f64> = r
            .events
            .iter()
            .filter(|e| e.topic == "/detector" && e.data["event"] == "reaction")
            .map(|e| e.time_s)
            .collect();
        assert_eq!(reactions.len(), 4, "{reactions:?}");
        assert!(
            reactions.windows(2).all(|w| w[1] - w[0] >= 0.1),
            "a response inside the pause: {reactions:?}"
        );
        let (lift_t, _) = phase_data(&r, "lifting").unwrap();
        assert!(reactions[0] > lift_t, "no response before the lift");
        let (_, end) = phase_data(&r, "hold_end").unwrap();
        let g_slip = end["closure"].as_f64().unwrap();
        assert!((g_slip - (g_cont + 0.04)).abs() < 1e-9, "g_slip {g_slip}");
        assert_eq!(moves, 2, "up, then down again");
        assert!(phase_data(&r, "opening").is_some());
    }

    #[test]
    fn a_grasp_that_holds_at_contact_never_tightens() {
        let (r, targets, _) = run(GAIN_PX, 0.0);
        assert_eq!(r.reaction, None);
        let after_contact = targets
            .iter()
            .filter(|(_, t)| t[0] > CONTACT + 0.005)
            .count();
        assert_eq!(after_contact, 0, "{targets:?}");
    }

    #[test]
    fn no_contact_up_to_the_closure_limit_aborts_before_lifting() {
        let (r, targets, moves) = run(0.0, 1.0);
        assert!(
            matches!(r.fault, Some(Fault::NoContact { .. })),
            "{:?}",
            r.fault
        );
        assert_eq!(moves, 0, "the arm never moved");
        let last = targets.last().unwrap().1;
        assert!(
            (last[0] - 0.95).abs() < 1e-9,
            "holds where it stopped: {last:?}"
        );
    }
}
