//! Closing the open hand until its fingertips touch the object, from the pins alone (the
//! paper's Eq. 4 contact test, [`ContactGauge`]): a pure state machine fed the frames that
//! arrive and the time, so every runner that grasps from contact shares it and it is tested
//! without devices.

use tmo_hal::PinFrame;

use crate::online::contact::ContactGauge;
use crate::slip::features::FeatureSpec;

/// The backend-neutral "closed until stable": approach until every sensor's deformation
/// reaches `deformation_px`, then close `past_contact` more.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactGrasp {
    pub deformation_px: f64,
    pub approach_speed_per_s: f64,
    pub past_contact: f64,
    /// Never close past this (no contact by then is a fault).
    pub max_closure: f64,
}

/// What the approach asks for now.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ApproachStep {
    /// Keep closing: the fingers' target.
    Close(f64),
    /// Every sensor touches at `closure`; grip at `grasp` (past contact, within the limit).
    Contact {
        closure: f64,
        grasp: f64,
        deformation_px: f64,
    },
    /// The closure limit came without contact.
    NoContact { deformation_px: f64 },
}

#[derive(Debug, Clone)]
pub struct ContactApproach {
    grasp: ContactGrasp,
    from: f64,
    t0: f64,
    gauge: ContactGauge,
}

impl ContactApproach {
    /// Starts closing from `from` (the fingers' closure) at time `t0`.
    pub fn new(grasp: ContactGrasp, sensors: usize, from: f64, t0: f64) -> Self {
        Self {
            grasp,
            from,
            t0,
            gauge: ContactGauge::new(sensors, FeatureSpec::new(0).max_pin_step_px as f64),
        }
    }

    pub fn observe(&mut self, frames: &[PinFrame]) {
        for f in frames {
            self.gauge.observe(f);
        }
    }

    /// The fingers' target at `now`: closing at the set speed, never past the limit.
    pub fn target(&self, now: f64) -> f64 {
        let g = &self.grasp;
        (self.from + g.approach_speed_per_s * (now - self.t0)).min(g.max_closure)
    }

    /// What to do at `now`, given the frames observed so far.
    pub fn step(&self, now: f64) -> ApproachStep {
        let g = &self.grasp;
        let q = self.target(now);
        let d = self.gauge.least_deformed().unwrap_or(0.0);
        if d >= g.deformation_px {
            ApproachStep::Contact {
                closure: q,
                grasp: (q + g.past_contact).min(g.max_closure),
                deformation_px: d,
            }
        } else if q >= g.max_closure {
            ApproachStep::NoContact { deformation_px: d }
        } else {
            ApproachStep::Close(q)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const GRASP: ContactGrasp = ContactGrasp {
        deformation_px: 0.5,
        approach_speed_per_s: 0.1,
        past_contact: 0.05,
        max_closure: 0.9,
    };

    fn frames(sensors: u8, seq: u64, shift_px: f32) -> Vec<PinFrame> {
        (0..sensors)
            .map(|sensor| PinFrame {
                sensor,
                seq,
                time_s: 0.0,
                pins: (0..10).map(|i| [10.0 * i as f32 + shift_px, 5.0]).collect(),
            })
            .collect()
    }

    #[test]
    fn closes_at_the_set_speed_until_every_sensor_is_deformed() {
        let mut a = ContactApproach::new(GRASP, 2, 0.2, 10.0);
        for seq in 0..3 {
            a.observe(&frames(2, seq, 0.0));
        }
        assert_eq!(a.step(11.0), ApproachStep::Close(0.2 + 0.1));
        // one sensor deformed is not contact
        a.observe(&frames(1, 4, 0.8));
        assert!(matches!(a.step(11.5), ApproachStep::Close(_)));
        a.observe(&frames(2, 5, 0.8));
        let ApproachStep::Contact {
            closure,
            grasp,
            deformation_px,
        } = a.step(12.0)
        else {
            panic!("{:?}", a.step(12.0))
        };
        assert!((closure - 0.4).abs() < 1e-12 && (grasp - 0.45).abs() < 1e-12);
        assert!((deformation_px - 0.8).abs() < 1e-6);
    }

    #[test]
    fn the_grasp_never_passes_the_limit_and_no_contact_by_then_is_said() {
        let mut a = ContactApproach::new(GRASP, 1, 0.8, 0.0);
        for seq in 0..3 {
            a.observe(&frames(1, seq, 0.0));
        }
        assert_eq!(
            a.step(5.0),
            ApproachStep::NoContact {
                deformation_px: 0.0
            }
        );
        a.observe(&frames(1, 4, 1.0));
        assert!(matches!(
            a.step(0.95),
            ApproachStep::Contact { grasp, .. } if (grasp - 0.9).abs() < 1e-12
        ));
    }
}
