//! The held object's turn about the pinch axis while it slips (rotational slip).
//!
//! A centre of mass off the pinch axis makes the load a moment `M` about it. The statics
//! ([`crate::statics`]) hold it while friction allows; once the grasp gives way the object
//! is a rigid body that both slides along the slip axis and turns about the pinch axis,
//! and each contact's friction opposes that contact's own slip velocity (Coulomb).
//!
//! Frame as in [`crate::statics`]: the fingers stand `lever = s` either side of the pinch
//! axis along the slip axis, the thumb on it. Turning at rate `omega` while sliding at `v`,
//! a finger's contact slips at `(s omega, v)` (across the slip axis, along it), so its
//! friction `F` splits into a share `F s omega / |v_i|` across, which with the other
//! finger's makes a couple about the pinch axis, and `F v / |v_i|` along, which holds the
//! object up (`|v_i| = sqrt(v^2 + s^2 omega^2)`). Every patch also spins about its normal
//! (the pinch axis) at `omega`: a Hertz patch of radius `a` resists a full spin with
//! `3 pi / 16 mu N a` (Johnson, Contact Mechanics, 1985, section 5.8), here shared with its
//! slip as `a omega / sqrt(|v_i|^2 + a^2 omega^2)` (a stated simplification of Contensou's
//! coupling; the slip's own friction is not reduced by the spin). What the couple takes
//! from the fingers' support the thumb gives up too, keeping the moment about the approach
//! axis balanced (the thumb's support equals the fingers' in the centred slide), as the
//! statics do.
//!
//! The turn is the pivot's equation of motion, `I omega' = M - C(omega)`, with `I` the
//! object's moment of inertia about the pinch axis and `C` the friction's couple. Near
//! `omega = 0` the couple is stiff (it reaches the fingers' full friction within a speed
//! `v / s`), so the step is semi-implicit: `omega' = (omega + h M) / (1 + h C(omega) / omega)`,
//! `h = dt / I`, stable at any step and exact at equilibrium (`C = M`). Slip velocities are
//! taken as at least [`CREEP_MM_S`] along the slip axis, so a grasp that has just given way
//! (`v = 0`) splits its friction as the quasi-static slide does (the couple's share first)
//! instead of swinging it all across the slip axis at the first hint of a turn.

/// The slip speed along the slip axis below which contacts are taken to creep at this
/// speed, mm/s: a numerical floor for the friction's direction, far below any slip the
/// sensors see (the marker's noise alone is 0.2 mm a frame).
pub const CREEP_MM_S: f64 = 0.1;

/// `3 pi / 16`: a Hertz patch's torsional friction per `mu N a`.
const SPIN_FRICTION_PER_MU_N_A: f64 = 3.0 * std::f64::consts::PI / 16.0;

/// One contact's part in the turn.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TurnContact {
    /// The patch's sliding friction along the slip axis, signed as the support it gives, N.
    pub friction_n: f64,
    /// Its distance from the pinch axis, mm (0 for the thumb).
    pub lever_mm: f64,
    /// Its Hertz patch radius, mm (its friction about its normal).
    pub patch_radius_mm: f64,
}

/// One step of a turning slide.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TurnStep {
    /// The turn rate after the step, rad/s (signed as the moment).
    pub rate_rad_s: f64,
    /// What the contacts hold up along the slip axis, N, and each contact's part.
    pub support_n: f64,
    pub each_n: [f64; 3],
    /// Each contact's friction across the slip axis, N (on the object, along the approach
    /// axis `+y` of [`crate::statics`]; the first finger at `w = +s`, the second at `-s`):
    /// the two fingers' make the couple, the thumb's is 0.
    pub across_n: [f64; 3],
}

/// Each contact's slip speed `|v_i|` at turn rate `omega` and slide speed `v`.
fn slip_speeds(contacts: &[TurnContact; 3], omega: f64, v: f64) -> [f64; 3] {
    contacts.map(|c| v.hypot(c.lever_mm * omega))
}

/// The friction's couple per unit of turn rate at `omega` (the limit at 0), N mm s.
fn couple_per_rate(contacts: &[TurnContact; 3], omega: f64, v: f64) -> f64 {
    let speeds = slip_speeds(contacts, omega, v);
    contacts
        .iter()
        .zip(speeds)
        .map(|(c, vi)| {
            let f = c.friction_n.abs();
            let a = c.patch_radius_mm;
            let spin = SPIN_FRICTION_PER_MU_N_A * f * a * a / vi.hypot(a * omega);
            f * c.lever_mm * c.lever_mm / vi + spin
        })
        .sum()
}

/// Advances the turn by `dt_s` under the moment `moment_n_mm` about the pinch axis, for an
/// object of moment of inertia `inertia_kg_mm2` about it sliding at `slide_mm_s` along
/// the slip axis. With no moment and no turn the support is the plain sum of the
/// frictions, bit for bit.
pub fn step(
    contacts: &[TurnContact; 3],
    rate_rad_s: f64,
    moment_n_mm: f64,
    inertia_kg_mm2: f64,
    slide_mm_s: f64,
    dt_s: f64,
) -> TurnStep {
    let friction: [f64; 3] = contacts.map(|c| c.friction_n);
    let total: f64 = friction.iter().sum();
    if moment_n_mm == 0.0 && rate_rad_s == 0.0 {
        return TurnStep {
            rate_rad_s: 0.0,
            support_n: total,
            each_n: friction,
            across_n: [0.0; 3],
        };
    }
    let v = slide_mm_s.abs().max(CREEP_MM_S);
    // N mm / (kg mm^2) = 1000 / s^2
    let h = 1000.0 * dt_s / inertia_kg_mm2;
    let omega =
        (rate_rad_s + h * moment_n_mm) / (1.0 + h * couple_per_rate(contacts, rate_rad_s, v));
    let sign = if total < 0.0 { -1.0 } else { 1.0 };
    let speeds = slip_speeds(contacts, omega, v);
    let mut each = [0.0; 3];
    let mut across = [0.0; 3];
    let mut given_up = 0.0;
    for i in 1..3 {
        let f = (friction[i] * sign).max(0.0);
        each[i] = f * v / speeds[i];
        given_up += f - each[i];
        // The finger at `w = +s` moves along `-y` as the object turns about `+x`, the one
        // at `-s` along `+y`; friction opposes each.
        let side = if i == 1 { 1.0 } else { -1.0 };
        across[i] = side * f * contacts[i].lever_mm * omega / speeds[i];
    }
    each[0] = ((friction[0] * sign).max(0.0) - given_up).max(0.0);
    let each = each.map(|f| sign * f);
    TurnStep {
        rate_rad_s: omega,
        support_n: each.iter().sum(),
        each_n: each,
        across_n: across,
    }
}

/// The friction's couple about the pinch axis, N mm, at turn rate `rate_rad_s` and slide
/// speed `slide_mm_s` (with the same creep floor as [`step`]). Not needed by a step itself,
/// which works with the couple per unit rate; for checking its equilibrium.
pub fn couple_n_mm(contacts: &[TurnContact; 3], rate_rad_s: f64, slide_mm_s: f64) -> f64 {
    let v = slide_mm_s.abs().max(CREEP_MM_S);
    rate_rad_s * couple_per_rate(contacts, rate_rad_s, v)
}

/// An object's moment of inertia about the pinch axis through its grasp, kg mm^2: a box
/// `length` along the slip axis and `width` deep (the depth is not in the object library;
/// its width across the pinch stands in for it), about its centre of mass, plus its mass
/// at `com_offset_mm` (the parallel-axis theorem).
pub fn pivot_inertia_kg_mm2(
    mass_kg: f64,
    length_mm: f64,
    width_mm: f64,
    com_offset_mm: f64,
) -> f64 {
    mass_kg * ((length_mm * length_mm + width_mm * width_mm) / 12.0 + com_offset_mm * com_offset_mm)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::statics::{gravity_direction, limit_loads, pinch_contacts};

    const S: f64 = 32.0;

    fn contacts(friction: [f64; 3], radius: f64) -> [TurnContact; 3] {
        let lever = [0.0, S, S];
        std::array::from_fn(|i| TurnContact {
            friction_n: friction[i],
            lever_mm: lever[i],
            patch_radius_mm: radius,
        })
    }

    /// Steps to equilibrium at a fixed moment and slide speed.
    fn settle(c: &[TurnContact; 3], moment: f64, slide: f64) -> TurnStep {
        let mut s = step(c, 0.0, moment, 200.0, slide, 0.001);
        for _ in 0..20_000 {
            s = step(c, s.rate_rad_s, moment, 200.0, slide, 0.001);
        }
        s
    }

    #[test]
    fn no_moment_no_turn_and_the_plain_sum() {
        let c = contacts([2.0, 1.0, 1.2], 4.0);
        let s = step(&c, 0.0, 0.0, 200.0, 5.0, 0.001);
        assert_eq!((s.rate_rad_s, s.support_n), (0.0, 4.2));
        assert_eq!(s.each_n, [2.0, 1.0, 1.2]);
    }

    #[test]
    fn a_moment_within_friction_is_held_by_the_couple_and_costs_support() {
        // Fingers 1 N each, 32 mm off the axis: up to 64 N mm of couple.
        let c = contacts([2.0, 1.0, 1.0], 0.0);
        for slide in [0.0, 5.0, 50.0] {
            let s = settle(&c, 30.0, slide);
            let couple = couple_n_mm(&c, s.rate_rad_s, slide);
            assert!((couple - 30.0).abs() < 1e-6, "{slide}: {s:?}");
            // each finger gives the couple `30 / 2s` across and the rest along
            let across = 30.0 / (2.0 * S);
            let along = (1.0 - across * across).sqrt();
            assert!((s.each_n[1] - along).abs() < 1e-6, "{s:?}");
            assert!((s.each_n[0] - (2.0 - 2.0 * (1.0 - along))).abs() < 1e-6);
            assert!((s.support_n - s.each_n.iter().sum::<f64>()).abs() < 1e-12);
            // it turns only as fast as its slide lets friction hold the couple
            let v = f64::max(slide, CREEP_MM_S);
            let expected = v * across / along / S;
            assert!(
                (s.rate_rad_s - expected).abs() < 1e-6 * expected.max(1.0),
                "{slide}: {} against {expected}",
                s.rate_rad_s
            );
        }
        // the sign follows the moment
        let s = settle(&c, -30.0, 5.0);
        assert!(s.rate_rad_s < 0.0 && (couple_n_mm(&c, s.rate_rad_s, 5.0) + 30.0).abs() < 1e-6);
    }

    #[test]
    fn the_fingers_friction_across_the_slip_axis_is_the_couple() {
        // Point contacts: the couple is the fingers' alone, `s (a_1 - a_2)`, and each
        // finger's friction keeps its size, split along and across.
        let c = contacts([2.0, 1.0, 1.0], 0.0);
        for (moment, slide) in [(30.0, 5.0), (-30.0, 5.0), (30.0, 0.0), (100.0, 2.0)] {
            let mut s = step(&c, 0.0, moment, 200.0, slide, 0.001);
            for _ in 0..50 {
                s = step(&c, s.rate_rad_s, moment, 200.0, slide, 0.001);
            }
            let [_, a1, a2] = s.across_n;
            assert_eq!(s.across_n[0], 0.0);
            assert!((a1 + a2).abs() < 1e-12, "{s:?}");
            assert_eq!(a1.signum(), moment.signum(), "{s:?}");
            let couple = couple_n_mm(&c, s.rate_rad_s, slide);
            assert!((S * (a1 - a2) - couple).abs() < 1e-9, "{s:?} {couple}");
            for i in 1..3 {
                assert!(
                    (s.each_n[i].hypot(s.across_n[i]) - 1.0).abs() < 1e-12,
                    "{s:?}"
                );
            }
        }
        // no turn, nothing across
        let s = step(&c, 0.0, 0.0, 200.0, 5.0, 0.001);
        assert_eq!(s.across_n, [0.0; 3]);
    }

    #[test]
    fn a_torque_beyond_friction_turns_the_object_ever_faster() {
        // 64 N mm of finger couple and the patches' spin: 100 N mm is more than both.
        let c = contacts([2.0, 1.0, 1.0], 4.0);
        let spin_max = SPIN_FRICTION_PER_MU_N_A * 4.0 * 4.0;
        assert!(2.0 * S + spin_max < 100.0);
        let mut s = step(&c, 0.0, 100.0, 200.0, 0.0, 0.001);
        let mut rates = vec![s.rate_rad_s];
        for _ in 0..200 {
            s = step(&c, s.rate_rad_s, 100.0, 200.0, 0.0, 0.001);
            rates.push(s.rate_rad_s);
        }
        assert!(rates.windows(2).all(|w| w[1] > w[0]), "{rates:?}");
        // after 0.2 s the unbalanced moment (at least 100 - 64 - spin) has spun it up
        let least = (100.0 - 2.0 * S - spin_max) * 1000.0 / 200.0 * 0.2;
        assert!(s.rate_rad_s > least, "{} < {least}", s.rate_rad_s);
        // and the fingers, slipping almost across the slip axis, hold little up
        assert!(s.each_n[1] < 0.05 && s.support_n < 0.2, "{s:?}");
        // within friction it would have settled instead
        let held = settle(&c, 40.0, 0.0);
        assert!(held.rate_rad_s < 0.01, "{held:?}");
    }

    #[test]
    fn at_static_friction_the_turning_slide_holds_what_the_statics_hold() {
        // No texture, no spin (point contacts, as the statics have them), at rest: the
        // support S whose own moment about the pinch axis, S |y_c|, the slide can just
        // balance is the load at which the limit analysis runs out of friction.
        let (yc, n, mu) = (20.0, [6.0, 3.0, 3.0], 0.8);
        let c = contacts(n.map(|n| mu * n), 0.0);
        let support_at = |load: f64| settle(&c, load * yc, 0.0).support_n;
        // support_at(load) - load falls as the load grows: bisect for the fixed point
        let (mut lo, mut hi) = (0.0, 9.6);
        for _ in 0..50 {
            let mid = 0.5 * (lo + hi);
            if support_at(mid) > mid {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let held = 0.5 * (lo + hi);
        assert!(held < 9.6 - 0.5, "{held}");
        let points = pinch_contacts(35.0, S, [0.0, -yc, 0.0], n, mu, mu);
        let ratio = |load: f64| {
            limit_loads(&points, gravity_direction(0.0).map(|g| g * load))
                .unwrap()
                .ratio
        };
        assert!(
            ratio(0.999 * held) <= 1.0 && ratio(1.001 * held) > 1.0,
            "{held}: {} {}",
            ratio(0.999 * held),
            ratio(1.001 * held)
        );
    }

    #[test]
    fn a_slide_the_other_way_carries_its_sign() {
        let up = step(
            &contacts([2.0, 1.0, 1.0], 3.0),
            0.5,
            20.0,
            200.0,
            5.0,
            0.001,
        );
        let down = step(
            &contacts([-2.0, -1.0, -1.0], 3.0),
            0.5,
            20.0,
            200.0,
            5.0,
            0.001,
        );
        assert_eq!(up.rate_rad_s, down.rate_rad_s);
        assert!((up.support_n + down.support_n).abs() < 1e-12);
    }

    #[test]
    fn the_pivot_inertia_adds_the_offset() {
        let centred = pivot_inertia_kg_mm2(0.066, 190.0, 36.0, 0.0);
        assert!((centred - 0.066 * (190.0f64.powi(2) + 36.0f64.powi(2)) / 12.0).abs() < 1e-9);
        assert!(
            (pivot_inertia_kg_mm2(0.066, 190.0, 36.0, 20.0) - centred - 0.066 * 400.0).abs() < 1e-9
        );
    }
}
