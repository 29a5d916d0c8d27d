//! Contact mechanics of a grasp, as pure functions: normal forces from finger travel, and
//! how a tangential load is shared between contacts and when they slip.
//!
//! The model (see `docs/simulator.md`): each contact is a linear spring (finger, skin and
//! object compliance in series) capped at the force the finger's torque limit allows. In a
//! pinch grasp the object shifts sideways until the thumb's force balances the two fingers'.
//! A tangential load is shared between stuck contacts in proportion to `weight * normal`;
//! a contact whose share exceeds `mu_static * normal` slips locally and then carries only
//! `mu_kinetic * normal`, which can cascade into gross slip of the whole grasp.

/// Most contacts any grasp of the rig has (three fingertips and the slip rail).
pub const MAX_CONTACTS: usize = 4;

use super::skin::SkinContact;

/// Force against travel of one fingertip contact: the finger and the object as linear
/// springs, in series with the skin's Hertzian indentation, so
/// `travel(N) = N / k_lin + (N / K)^(2/3)`. Soft at first touch (the skin), then dominated by
/// the finger's compliance. Its inverse is tabulated once per contact on a uniform travel
/// grid: the pinch balance evaluates it hundreds of times a step, and a lookup is ~50x
/// cheaper than solving the power law each time.
#[derive(Debug, Clone)]
pub struct ContactLaw {
    linear_n_per_mm: f64,
    skin: SkinContact,
    step_mm: f64,
    force_n: Vec<f64>,
}

impl ContactLaw {
    const ENTRIES: usize = 2048;

    /// `linear_n_per_mm`: finger and object stiffness in series; tabulated up to `max_force_n`
    /// (beyond it the law continues with the linear stiffness alone).
    pub fn new(linear_n_per_mm: f64, skin: SkinContact, max_force_n: f64) -> Self {
        let mut law = Self {
            linear_n_per_mm,
            skin,
            step_mm: 0.0,
            force_n: Vec::with_capacity(Self::ENTRIES),
        };
        let max_travel = law.travel_mm(max_force_n.max(1e-6));
        law.step_mm = max_travel / (Self::ENTRIES - 1) as f64;
        let mut n: f64 = 0.0;
        for j in 0..Self::ENTRIES {
            let p = j as f64 * law.step_mm;
            // travel(N) is increasing and concave, so Newton from below stays below the root.
            if j > 0 {
                n = n.max(1e-12);
                for _ in 0..8 {
                    let d = law.skin.indentation_mm(n);
                    let f = n / linear_n_per_mm + d - p;
                    let df = 1.0 / linear_n_per_mm + 2.0 / 3.0 * d / n;
                    n = (n - f / df).max(1e-12);
                }
            }
            law.force_n.push(n);
        }
        law
    }

    pub fn skin(&self) -> &SkinContact {
        &self.skin
    }

    /// Travel past first touch at which the contact presses with `normal_n`, mm.
    pub fn travel_mm(&self, normal_n: f64) -> f64 {
        normal_n / self.linear_n_per_mm + self.skin.indentation_mm(normal_n)
    }

    /// Normal force at `travel_mm` past first touch, N (0 before touch).
    pub fn force_n(&self, travel_mm: f64) -> f64 {
        if travel_mm <= 0.0 {
            return 0.0;
        }
        let x = travel_mm / self.step_mm;
        let last = Self::ENTRIES - 1;
        if x >= last as f64 {
            return self.force_n[last]
                + (travel_mm - last as f64 * self.step_mm) * self.linear_n_per_mm;
        }
        let i = x as usize;
        let f = x - i as f64;
        self.force_n[i] + f * (self.force_n[i + 1] - self.force_n[i])
    }
}

/// Normal forces (N) of a pinch grasp, thumb (index 0) opposed to two fingers.
///
/// `travel_mm[i]` is how far finger `i` has moved past the point where it would touch the
/// object if the object were centred (negative: not there yet). The object shifts sideways
/// by `y` until `N_thumb = N_1 + N_2`, with `N_i = min(force_i(penetration_i), cap_i)`.
/// `force` must be non-decreasing in travel and 0 at or before touch.
pub fn pinch_normal_forces(
    travel_mm: [f64; 3],
    force: impl Fn(usize, f64) -> f64,
    cap_n: [f64; 3],
) -> [f64; 3] {
    let forces = |y: f64| {
        [
            force(0, travel_mm[0] + y).clamp(0.0, cap_n[0]),
            force(1, travel_mm[1] - y).clamp(0.0, cap_n[1]),
            force(2, travel_mm[2] - y).clamp(0.0, cap_n[2]),
        ]
    };
    let imbalance = |y: f64| {
        let n = forces(y);
        n[0] - n[1] - n[2]
    };
    // The imbalance never decreases with y: bisect between the shift that takes the thumb
    // off the object and the one that takes both fingers off it.
    let mut lo = -travel_mm[0];
    let mut hi = travel_mm[1].max(travel_mm[2]);
    if hi <= lo || imbalance(lo) >= 0.0 {
        return forces(lo.min(hi));
    }
    if imbalance(hi) <= 0.0 {
        return forces(hi);
    }
    for _ in 0..48 {
        let mid = 0.5 * (lo + hi);
        if imbalance(mid) < 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    forces(0.5 * (lo + hi))
}

/// One contact's properties for sharing a tangential load.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Contact {
    pub normal_n: f64,
    /// Relative share of load per newton of normal force (grasp geometry).
    pub weight: f64,
    pub mu_static: f64,
    pub mu_kinetic: f64,
}

/// How a load is carried while the object does not move relative to the fingers.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct StuckShare {
    /// Each contact's tangential load, signed as the support it gives, N.
    pub tangential_n: [f64; MAX_CONTACTS],
    /// The part of it across the slip axis, N (on the object, along the hand's approach
    /// axis; see [`crate::statics`]). 0 on the rail and in a centred grasp.
    pub across_n: [f64; MAX_CONTACTS],
    /// Contacts that slip locally (incipient slip) although the grasp as a whole holds.
    pub local_slip: [bool; MAX_CONTACTS],
}

/// Shares `load_n` (N, > 0 pulls the object down through the grasp) between `contacts`.
/// Returns `None` when the grasp cannot hold it: gross slip.
pub fn share_stuck_load(load_n: f64, contacts: &[Contact]) -> Option<StuckShare> {
    assert!(contacts.len() <= MAX_CONTACTS);
    let mut share = StuckShare::default();
    if load_n <= 0.0 {
        return Some(share);
    }
    let mut slipping = [false; MAX_CONTACTS];
    loop {
        let carried_by_slipping: f64 = contacts
            .iter()
            .zip(&slipping)
            .filter(|(_, s)| **s)
            .map(|(c, _)| c.mu_kinetic * c.normal_n)
            .sum();
        let remaining = load_n - carried_by_slipping;
        let stuck_weight: f64 = contacts
            .iter()
            .zip(&slipping)
            .filter(|(c, s)| !**s && c.normal_n > 0.0)
            .map(|(c, _)| c.weight * c.normal_n)
            .sum();
        if stuck_weight <= 0.0 {
            return None;
        }
        // The contact most over its static limit slips first; then the load is shared again.
        let mut worst: Option<(usize, f64)> = None;
        for (i, c) in contacts.iter().enumerate() {
            if slipping[i] || c.normal_n <= 0.0 {
                continue;
            }
            let t = remaining * c.weight * c.normal_n / stuck_weight;
            share.tangential_n[i] = t;
            let ratio = t / (c.mu_static * c.normal_n);
            if ratio > 1.0 && worst.is_none_or(|(_, r)| ratio > r) {
                worst = Some((i, ratio));
            }
        }
        match worst {
            None => {
                for (i, c) in contacts.iter().enumerate() {
                    if slipping[i] {
                        share.tangential_n[i] = c.mu_kinetic * c.normal_n;
                    } else if c.normal_n <= 0.0 {
                        share.tangential_n[i] = 0.0;
                    }
                }
                share.local_slip = slipping;
                return Some(share);
            }
            Some((i, _)) => slipping[i] = true,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn linear(k: [f64; 3]) -> impl Fn(usize, f64) -> f64 {
        move |i, p| (k[i] * p).max(0.0)
    }

    #[test]
    fn contact_law_is_soft_at_touch_and_inverts_its_travel() {
        let law = ContactLaw::new(1.2, SkinContact::new(350.0, 0.5, 10.0), 25.0);
        for n in [0.05, 0.3, 1.0, 5.0, 20.0] {
            let p = law.travel_mm(n);
            assert!(
                (law.force_n(p) - n).abs() < 0.01 * n + 1e-3,
                "{n}: {}",
                law.force_n(p)
            );
        }
        assert_eq!(law.force_n(-1.0), 0.0);
        // the first tenth of a millimetre is far softer than the finger alone
        assert!(law.force_n(0.1) < 0.1 * 1.2);
        // beyond the table the finger's stiffness carries on
        let p = law.travel_mm(25.0);
        assert!((law.force_n(p + 1.0) - law.force_n(p) - 1.2).abs() < 1e-6);
    }

    fn contact(n: f64) -> Contact {
        Contact {
            normal_n: n,
            weight: 1.0,
            mu_static: 0.8,
            mu_kinetic: 0.6,
        }
    }

    #[test]
    fn symmetric_pinch_balances_thumb_against_two_fingers() {
        let n = pinch_normal_forces([2.0, 2.0, 2.0], linear([1.0; 3]), [100.0; 3]);
        assert!((n[0] - n[1] - n[2]).abs() < 1e-9);
        // y solves 2 + y = 2 * (2 - y): y = 2/3, thumb 8/3 N.
        assert!((n[0] - 8.0 / 3.0).abs() < 1e-9, "{n:?}");
    }

    #[test]
    fn no_force_without_opposition() {
        // The thumb is 1 mm past centre-contact but the fingers 2 mm short: a 1 mm gap remains.
        let n = pinch_normal_forces([1.0, -2.0, -2.0], linear([1.0; 3]), [100.0; 3]);
        assert!(n.iter().all(|f| f.abs() < 1e-6), "{n:?}");
    }

    #[test]
    fn torque_cap_limits_the_squeeze() {
        let n = pinch_normal_forces([10.0, 10.0, 10.0], linear([1.0; 3]), [2.0, 100.0, 100.0]);
        assert!(
            (n[0] - 2.0).abs() < 1e-9 && (n[1] - 1.0).abs() < 1e-6,
            "{n:?}"
        );
    }

    #[test]
    fn exact_balance_matches_a_bisection() {
        let mut state = 12345u64;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..1000 {
            let travel = [
                next() * 10.0 - 4.0,
                next() * 10.0 - 4.0,
                next() * 10.0 - 4.0,
            ];
            let k = [0.2 + next(), 0.2 + next(), 0.2 + next()];
            let cap = [next() * 8.0, next() * 8.0, next() * 8.0];
            let n = pinch_normal_forces(travel, linear(k), cap);
            let forces = |y: f64| {
                [
                    (k[0] * (travel[0] + y)).clamp(0.0, cap[0]),
                    (k[1] * (travel[1] - y)).clamp(0.0, cap[1]),
                    (k[2] * (travel[2] - y)).clamp(0.0, cap[2]),
                ]
            };
            let (mut lo, mut hi) = (-100.0, 100.0);
            for _ in 0..200 {
                let mid = 0.5 * (lo + hi);
                let f = forces(mid);
                if f[0] - f[1] - f[2] < 0.0 {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            let reference = forces(0.5 * (lo + hi));
            for i in 0..3 {
                assert!(
                    (n[i] - reference[i]).abs() < 1e-9,
                    "{travel:?} {k:?} {cap:?}: {n:?} vs {reference:?}"
                );
            }
        }
    }

    #[test]
    fn light_load_is_shared_by_normal_force() {
        let s = share_stuck_load(1.0, &[contact(2.0), contact(1.0), contact(1.0)]).unwrap();
        assert!((s.tangential_n[0] - 0.5).abs() < 1e-12);
        assert!((s.tangential_n[1] - 0.25).abs() < 1e-12);
        assert!(!s.local_slip.iter().any(|s| *s));
    }

    #[test]
    fn heavy_load_slips_grossly() {
        // capacity 0.8 * 4 = 3.2 N
        assert!(share_stuck_load(3.3, &[contact(2.0), contact(1.0), contact(1.0)]).is_none());
        assert!(share_stuck_load(3.1, &[contact(2.0), contact(1.0), contact(1.0)]).is_some());
    }

    #[test]
    fn overloaded_contact_slips_locally_and_sheds_load() {
        let mut light = contact(1.0);
        light.weight = 4.0;
        let s = share_stuck_load(1.5, &[contact(2.0), light]).unwrap();
        assert!(s.local_slip[1] && !s.local_slip[0]);
        assert!((s.tangential_n[1] - 0.6).abs() < 1e-12);
        assert!((s.tangential_n[0] - 0.9).abs() < 1e-12);
    }
}
