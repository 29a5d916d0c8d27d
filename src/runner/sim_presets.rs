//! Ready-made simulated rigs: the worlds the simulated protocol runners start in, and for
//! `tmo sim trace` a world plus a script to run in it.

use tmo_sim::{HandSetup, ObjectLibrary, ObjectStart, RailSetup, RigSetup, SimConfig, SimError};

/// What a scenario does.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Script {
    /// Nothing: hold the starting grasp (drop with an open hand, hold with a closed one).
    Wait,
    /// Hold the start grasp for `hold_s`, then release all fingers at `speed_per_s`
    /// (fraction of range per s).
    Release { speed_per_s: f64, hold_s: f64 },
    /// Retract the arm (slip rail) by `distance_mm` at `speed_mm_s`.
    Retract { speed_mm_s: f64, distance_mm: f64 },
    /// Close until the mean pin deformation reaches `deformation_px`, then raise the arm.
    Lift {
        deformation_px: f64,
        close_speed_per_s: f64,
        lift_speed_mm_s: f64,
    },
}

/// The scenarios `tmo sim trace` knows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Preset {
    /// Open hand, object in the air: it falls.
    Drop,
    /// Firm pinch grasp held still.
    Hold,
    /// Pinch grasp released at 0.5 % of maximum finger speed (collect-mode hand release).
    Release,
    /// Slip rail: the arm retracts and the object slides down the rail.
    Rail,
    /// Object on a table: close to 0.5 px deformation, then raise the arm at 17 mm/s.
    Lift,
    /// Light grasp while rice is poured into the object.
    Pour,
}

/// Choices the user makes on top of a preset.
#[derive(Debug, Clone, PartialEq)]
pub struct PresetOptions {
    pub object: Option<String>,
    pub grasp_deg: f64,
    /// Arm retraction speed on the rail, mm/s.
    pub retract_speed_mm_s: f64,
    /// Rice poured per second, g/s.
    pub pour_rate_g_per_s: f64,
}

impl Default for PresetOptions {
    fn default() -> Self {
        Self {
            object: None,
            grasp_deg: 0.0,
            retract_speed_mm_s: 2.0,
            pour_rate_g_per_s: 40.0,
        }
    }
}

/// Finger position (0..1) where the fingers first touch `object`.
pub fn contact_closure(base: &SimConfig, object: &str) -> Result<f64, SimError> {
    let spec = ObjectLibrary::built_in().get(object)?.clone();
    Ok(1.0 - spec.width_mm / (2.0 * base.physics.finger_travel_mm))
}

/// Finger position (0..1) of a symmetric pinch grasp that holds `object` (plus
/// `extra_mass_g`) with `safety` times the normal force the most loaded contact needs.
///
/// The thumb carries half the weight (the grasp statics of a centred object: see
/// `tmo_sim::statics`) and holds while that is at most `mu_s N_thumb`. The object shifts until each finger presses with half the
/// thumb's force, so with equal finger travel `a` past touch and the contact law's travel
/// `p(N)`: `a + y = p(N_thumb)`, `a - y = p(N_thumb / 2)`. The servos are commanded half
/// the tendon's free play further, as the fingers trail them while closing.
pub fn holding_closure(
    base: &SimConfig,
    object: &str,
    extra_mass_g: f64,
    safety: f64,
) -> Result<f64, SimError> {
    let spec = ObjectLibrary::built_in().get(object)?.clone();
    let p = &base.physics;
    let weight = (spec.mass_g + extra_mass_g) / 1000.0 * p.gravity_m_s2;
    let thumb_force = safety * weight / (2.0 * spec.mu_static);
    let law = tmo_sim::nominal_contact_law(p, &spec);
    let travel = 0.5 * (law.travel_mm(thumb_force) + law.travel_mm(thumb_force / 2.0));
    // Closing from open, each finger trails its motor by half the tendon's free play.
    let trail = 0.5 * base.servo.backlash;
    Ok((contact_closure(base, object)? + travel / p.finger_travel_mm + trail).min(1.0))
}

/// Builds the rig for `preset` on top of `base` (whose physics, sensor, fault and marker
/// parameters are kept) and the script to run on it.
pub fn build(
    preset: Preset,
    options: &PresetOptions,
    base: SimConfig,
) -> Result<(SimConfig, Script), SimError> {
    let mut cfg = base;
    let object = options.object.clone().unwrap_or_else(|| match preset {
        Preset::Rail => "rail_object".into(),
        _ => "crisps_can".into(),
    });
    if preset == Preset::Rail {
        // a configuration's own rail settings (preload, press-in, guides) are kept
        let rail = match &cfg.rig {
            RigSetup::Rail(r) => r.clone(),
            RigSetup::Hand(_) => RailSetup::default(),
        };
        cfg.rig = RigSetup::Rail(RailSetup { object, ..rail });
        let script = Script::Retract {
            speed_mm_s: options.retract_speed_mm_s,
            distance_mm: 10.0,
        };
        return Ok((cfg, script));
    }
    let contact = contact_closure(&cfg, &object)?;
    let (closure, start, script) = match preset {
        Preset::Drop => (0.0, ObjectStart::InHand, Script::Wait),
        Preset::Hold => (
            holding_closure(&cfg, &object, 0.0, 2.0)?,
            ObjectStart::InHand,
            Script::Wait,
        ),
        Preset::Release => (
            holding_closure(&cfg, &object, 0.0, 1.3)?,
            ObjectStart::InHand,
            Script::Release {
                // the paper's release: 0.5 % of the fingers' maximum speed
                speed_per_s: 0.005 * cfg.servo.reference_speed_per_s,
                hold_s: 0.5,
            },
        ),
        Preset::Lift => {
            // as the lifts' protocols close and raise (`protocol.lift.*`)
            let lift = crate::protocol::FirstTimeLift::default();
            (
                (contact - cfg.operator.lift_start_gap).max(0.0),
                ObjectStart::OnTable,
                Script::Lift {
                    deformation_px: 0.5,
                    close_speed_per_s: lift.approach_speed_of_max * cfg.servo.reference_speed_per_s,
                    lift_speed_mm_s: lift.lift_speed_mm_s,
                },
            )
        }
        Preset::Pour => (
            holding_closure(&cfg, &object, 0.0, cfg.operator.pour_grip_safety)?,
            ObjectStart::InHand,
            Script::Wait,
        ),
        Preset::Rail => unreachable!("handled above"),
    };
    let pour = if preset == Preset::Pour {
        options.pour_rate_g_per_s
    } else {
        0.0
    };
    cfg.rig = RigSetup::Hand(HandSetup {
        object,
        grasp_deg: options.grasp_deg,
        initial_closure: closure.min(1.0),
        start,
        pour_rate_g_per_s: pour,
        pour_start_s: 0.5,
        ..Default::default()
    });
    Ok((cfg, script))
}

#[cfg(test)]
mod tests {
    use super::*;
    use tmo_hal::{Clock, Hand};
    use tmo_sim::{FaultRates, HandSetup, ObjectStart, RigSetup, SimRig};

    /// The standard hand release of the crisps can (the grasp that holds it with 1.5 times
    /// the friction it needs, opened at 0.5 % of the fingers' top speed) answered, 50 ms
    /// after the slip begins (three frames at 60 fps), by closing 2 % of the range tighter
    /// than the starting grasp, as the protocol does. The largest normal force any
    /// fingertip presses with from then on, N.
    fn peak_response_force_n(seed: u64, stiffness: Option<f64>) -> f64 {
        let mut base = SimConfig {
            seed,
            faults: FaultRates::none(),
            ..Default::default()
        };
        if let Some(k) = stiffness {
            base.physics.finger_stiffness_n_per_mm = k;
        }
        let closure = holding_closure(&base, "crisps_can", 0.0, 1.5).unwrap();
        let rig = SimRig::new(SimConfig {
            rig: RigSetup::Hand(HandSetup {
                object: "crisps_can".into(),
                initial_closure: closure,
                start: ObjectStart::InHand,
                ..Default::default()
            }),
            ..base.clone()
        })
        .unwrap();
        let (mut clock, mut hand, probe) = (rig.clock(), rig.hand(), rig.probe());
        clock.sleep(0.5);
        let speed = 0.005 * base.servo.reference_speed_per_s;
        let start = clock.now_s();
        let onset = loop {
            if let Some(&t) = probe.events().slip_onsets_s.first() {
                break t;
            }
            let q = closure - speed * (clock.now_s() - start);
            assert!(q > 0.0, "the can never slipped");
            hand.set_targets([q, q, q, 0.0]).unwrap();
            clock.sleep(0.001);
        };
        clock.sleep_until(onset + 0.05);
        let q = (closure + 0.02).min(1.0);
        hand.set_targets([q, q, q, 0.0]).unwrap();
        let mut peak: f64 = 0.0;
        while clock.now_s() < onset + 1.5 {
            clock.sleep(0.001);
            peak = peak.max(probe.state().normal_n.iter().copied().fold(0.0, f64::max));
        }
        peak
    }

    #[test]
    fn the_slip_response_presses_with_about_the_papers_3_n() {
        // The paper measured the peak force of the slip response with a force meter at
        // about 3 N (Discussion).
        for seed in [1, 2, 3] {
            let peak = peak_response_force_n(seed, None);
            eprintln!("seed {seed}: peak response force {peak:.2} N");
            assert!((2.0..=4.0).contains(&peak), "seed {seed}: peak {peak} N");
        }
    }
}
