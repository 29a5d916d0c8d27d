//! Each fingertip's own slip along the object as its finger curls or uncurls: the contact
//! slip that comes before the object's (`docs/simulator.md`, "Contact slip of one
//! fingertip").
//!
//! An under-actuated finger curls as it presses past first touch, so its fingertip moves
//! along the object's surface (along the hand's approach axis, towards the palm) by
//! `ratio * pressed`, and back again as it relaxes. The patch sticks where it touched. All
//! three fingertips curl towards the palm, so their drags on the object add: an object held
//! only by the fingertips (free along the approach axis) goes where their shears balance,
//! the stiffness-weighted mean curl, and each skin keeps only its curl's difference from
//! that, `u = ratio * pressed - object - slid`, where `slid` is how far the patch has slid
//! over the object. On the slip rail the guides hold the object along that axis, and the
//! table's friction does while the object rests on it, so there each skin keeps its whole
//! curl.
//!
//! Friction is a circle (Coulomb): the load that holds the object, `T = (T_y, T_w)`, is
//! set by the grasp's statics (force-driven: the object falls if it is not carried), while
//! the curl's load is displacement-driven and is what gives way first. The curl's load lies
//! along the approach axis, so it adds to the grasp's part along that axis with its sign
//! (a centre of mass off the grasp loads the upper and lower fingers oppositely there):
//! the patch holds the curl's shear `c u_max` while `(c + T_c / mu_s N)^2 + (T_w / mu_s N)^2
//! <= 1`, `T_c` the grasp's load along the approach axis in the curl's sense, with `u_max = 3 mu_s N / 2 k_t` Mindlin's full-slip shear (the curl's load taken
//! as linear in its shear up to it). Beyond that the patch breaks free and slides to the
//! kinetic circle's edge on the same side (radius `mu_k / mu_s`), and sticks again. As a
//! grasp relaxes towards its limit the circle leaves the curl less and less, so each
//! fingertip slips along the object, one at a time as their loads and skins differ, before
//! the object itself can slip: what the paper saw ("one finger may begin to slip before
//! another when a grasp is relaxed and, crucially, before the object starts to drop").
//!
//! Left out: a rigid object held at three points could also turn (pitch about the axis
//! across the palm, roll about the pinch axis) to follow the thumb's curl against the
//! fingers' and one finger's against the other's; the grasp's statics would let it, and
//! then no curl shear would be left at all. What holds those turns in a real grasp (the
//! domes rolling on the object, the objects' faces and curvature) has no value here yet,
//! so the object only translates.

/// What a contact's friction leaves for the curl at one instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CurlLimits {
    /// Mindlin's full-slip shear at this normal force and static friction, mm.
    pub full_slip_mm: f64,
    /// The grasp's load on this contact along the approach axis, in the curl's sense (the
    /// sense in which the curl's shear pulls the object: towards the palm), as a share of
    /// the static friction, `T_y / mu_s N` signed. The curl's own load adds to it.
    pub along_share: f64,
    /// The rest of the grasp's load (across the approach axis: the slip axis's), as a
    /// share of the static friction, `|T_w| / mu_s N`.
    pub across_share: f64,
    /// `mu_k / mu_s`.
    pub kinetic_ratio: f64,
}

impl CurlLimits {
    /// The curl's shear the stuck patch holds, mm: the interval in which the curl's load
    /// and the grasp's together stay inside Coulomb's circle, `(c + a)^2 + b^2 <= 1` with
    /// `c` the curl's shear over the full-slip shear, `a` and `b` the grasp's shares.
    pub fn static_range_mm(&self) -> (f64, f64) {
        let r = circle_share(self.across_share);
        let a = self.along_share;
        (self.full_slip_mm * (-a - r), self.full_slip_mm * (-a + r))
    }

    /// Where a patch that broke free towards `sense` (the sign of its shear's excess)
    /// slides to: the kinetic circle's edge on that side, mm (its centre when the rest of
    /// the load leaves the kinetic circle nothing along the curl).
    pub fn kinetic_mm(&self, sense: f64) -> f64 {
        let k = self.kinetic_ratio.max(0.0);
        let r = if k > 0.0 {
            k * circle_share(self.across_share / k)
        } else {
            0.0
        };
        self.full_slip_mm * (-self.along_share + sense.signum() * r)
    }
}

/// `sqrt(1 - x^2)` for `x` in [0, 1]; 0 beyond.
fn circle_share(x: f64) -> f64 {
    let x = x.abs();
    if x >= 1.0 {
        0.0
    } else {
        (1.0 - x * x).sqrt()
    }
}

/// One fingertip's contact along the approach axis.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CurlContact {
    /// Whether the fingertip touches the object.
    touching: bool,
    /// Where the patch sits on the object, along the approach axis, relative to where the
    /// fingertip's curl would hold it with no shear, mm: the patch's slide over the object
    /// since it touched, less where the object stood then.
    slid_mm: f64,
    /// How far it has slid in all, either way, mm.
    travelled_mm: f64,
}

impl CurlContact {
    /// How far the patch has slid over the object in all, either way, mm.
    pub fn travelled_mm(&self) -> f64 {
        self.travelled_mm
    }
}

/// One fingertip's state for a [`CurlGrasp::step`]: `None` when it does not touch the
/// object.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CurlInput {
    /// How far the fingertip has moved along the object since first touch, mm (the curl).
    pub demand_mm: f64,
    pub limits: CurlLimits,
    /// The patch's tangential stiffness, any unit common to the grasp's contacts
    /// (Mindlin's initial stiffness `3 mu N / 2 u_max`: what weighs each curl in where a
    /// free object goes).
    pub stiffness: f64,
}

/// How the object sits along the approach axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ApproachAxis {
    /// Held by something other than the fingertips (the rail's guides): the curls' shears
    /// are each fingertip's own.
    Held,
    /// Free: held only by the fingertips, it goes where their curls' shears balance.
    Free,
}

/// What a step gives each fingertip.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CurlOutcome {
    /// The skin's shear along the curl, mm (positive: the curl's sense).
    pub shear_mm: f64,
    /// How far the patch slid this step if it broke free, mm.
    pub slide_mm: Option<f64>,
}

/// The fingertips' contacts along the approach axis and where the object sits on it.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CurlGrasp {
    contacts: [CurlContact; 3],
    /// The object's displacement along the approach axis (the curl's sense) since the
    /// grasp was made, mm.
    object_mm: f64,
}

/// A free object is balanced again after each break-free: a few rounds settle it (each
/// round a patch breaks free only if the object's move pushed it past its circle).
const BALANCE_ROUNDS: usize = 8;

impl CurlGrasp {
    pub fn contact(&self, i: usize) -> &CurlContact {
        &self.contacts[i]
    }

    /// The object's displacement along the approach axis since the grasp was made, mm.
    pub fn object_mm(&self) -> f64 {
        self.object_mm
    }

    /// One step: each fingertip `inputs[i]` (`None` off the object). A free object goes
    /// where the stuck patches' shears balance (their stiffness-weighted mean curl), so each
    /// skin keeps only its difference from that; a patch whose shear leaves its circle
    /// breaks free and slides to the kinetic circle's edge, and the object balances again.
    /// `settle`: a grasp made before the simulation starts, whose patches slid only as far
    /// as their stuck circles asked, with nothing to record.
    pub fn step(
        &mut self,
        inputs: &[Option<CurlInput>; 3],
        axis: ApproachAxis,
        settle: bool,
    ) -> [CurlOutcome; 3] {
        for (c, input) in self.contacts.iter_mut().zip(inputs) {
            match input {
                Some(_) if !c.touching => {
                    // A new touch starts a new patch where the object now is, unsheared at
                    // first touch (no curl yet): what the finger has pressed past it since
                    // shears the skin.
                    c.touching = true;
                    c.slid_mm = -self.object_mm;
                }
                None => c.touching = false,
                Some(_) => {}
            }
        }
        if self.contacts.iter().all(|c| !c.touching) {
            self.object_mm = 0.0;
            return [CurlOutcome::default(); 3];
        }
        let mut slides = [None::<f64>; 3];
        for _ in 0..BALANCE_ROUNDS {
            if axis == ApproachAxis::Free {
                self.balance(inputs);
            }
            let mut any = false;
            for (i, (c, input)) in self.contacts.iter_mut().zip(inputs).enumerate() {
                let Some(input) = input else { continue };
                let u = input.demand_mm - self.object_mm - c.slid_mm;
                let (lo, hi) = input.limits.static_range_mm();
                if (lo..=hi).contains(&u) {
                    continue;
                }
                let sense = if u > hi { 1.0 } else { -1.0 };
                let after = if settle {
                    u.clamp(lo, hi)
                } else {
                    input.limits.kinetic_mm(sense).clamp(lo, hi)
                };
                let slide = u - after;
                c.slid_mm += slide;
                if !settle {
                    c.travelled_mm += slide.abs();
                    *slides[i].get_or_insert(0.0) += slide.abs();
                }
                any = true;
            }
            if !any {
                break;
            }
        }
        std::array::from_fn(|i| match inputs[i] {
            Some(input) => CurlOutcome {
                shear_mm: input.demand_mm - self.object_mm - self.contacts[i].slid_mm,
                slide_mm: slides[i],
            },
            None => CurlOutcome::default(),
        })
    }

    /// Moves a free object to where the patches' shears balance.
    fn balance(&mut self, inputs: &[Option<CurlInput>; 3]) {
        let (mut weighted, mut total) = (0.0, 0.0);
        for (c, input) in self.contacts.iter().zip(inputs) {
            if let Some(input) = input {
                weighted += input.stiffness * (input.demand_mm - c.slid_mm);
                total += input.stiffness;
            }
        }
        if total > 0.0 {
            self.object_mm = weighted / total;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn limits(along: f64, across: f64) -> CurlLimits {
        CurlLimits {
            full_slip_mm: 1.0,
            along_share: along,
            across_share: across,
            kinetic_ratio: 1.0 / 1.15,
        }
    }

    fn input(demand_mm: f64, l: CurlLimits, stiffness: f64) -> Option<CurlInput> {
        Some(CurlInput {
            demand_mm,
            limits: l,
            stiffness,
        })
    }

    #[test]
    fn the_friction_circle_leaves_the_curl_less_as_the_load_across_nears_the_limit() {
        assert_eq!(limits(0.0, 0.0).static_range_mm(), (-1.0, 1.0));
        let (lo, hi) = limits(0.0, 0.6).static_range_mm();
        assert!((hi - 0.8).abs() < 1e-12 && (lo + 0.8).abs() < 1e-12);
        assert_eq!(limits(0.0, 1.0).static_range_mm(), (0.0, 0.0));
        assert_eq!(limits(0.0, 1.3).static_range_mm(), (0.0, 0.0));
        // the kinetic circle is smaller: it leaves nothing once the load passes mu_k N
        assert!((limits(0.0, 0.0).kinetic_mm(1.0) - 1.0 / 1.15).abs() < 1e-12);
        assert!(limits(0.0, 0.5).kinetic_mm(1.0) < limits(0.0, 0.5).static_range_mm().1);
        assert_eq!(limits(0.0, 0.9).kinetic_mm(1.0), 0.0);
    }

    #[test]
    fn a_load_along_the_approach_axis_adds_to_the_curl_with_its_sign() {
        // the grasp already pulls this contact half its friction in the curl's sense: the
        // curl has half its room that way and one and a half the other
        let (lo, hi) = limits(0.5, 0.0).static_range_mm();
        assert!((hi - 0.5).abs() < 1e-12 && (lo + 1.5).abs() < 1e-12);
        // and the contact loaded the other way has it mirrored: not the same room, as the
        // friction circle's |T| gave both before
        let (lo, hi) = limits(-0.5, 0.0).static_range_mm();
        assert!((hi - 1.5).abs() < 1e-12 && (lo + 0.5).abs() < 1e-12);
        // a patch broken free slides to the kinetic circle's edge on its side
        assert!((limits(0.5, 0.0).kinetic_mm(1.0) - (1.0 / 1.15 - 0.5)).abs() < 1e-12);
        assert!((limits(0.5, 0.0).kinetic_mm(-1.0) - (-1.0 / 1.15 - 0.5)).abs() < 1e-12);
    }

    #[test]
    fn a_free_object_follows_the_stiffness_weighted_mean_curl_and_each_skin_keeps_its_difference() {
        // the audit's arithmetic: the thumb curls 2d, each finger d; the thumb's patch is
        // 2^(1/3) times as stiff (twice the normal force); the object moves 1.39 d, the
        // thumb's skin keeps +0.61 d and each finger's -0.39 d
        let d = 0.1;
        let l = limits(0.0, 0.0);
        let k0 = 2f64.powf(1.0 / 3.0);
        let mut grasp = CurlGrasp::default();
        grasp.step(
            &[input(0.0, l, k0), input(0.0, l, 1.0), input(0.0, l, 1.0)],
            ApproachAxis::Free,
            true,
        );
        let out = grasp.step(
            &[input(2.0 * d, l, k0), input(d, l, 1.0), input(d, l, 1.0)],
            ApproachAxis::Free,
            false,
        );
        let object = (2.0 * k0 + 2.0) / (k0 + 2.0) * d;
        assert!((grasp.object_mm() - object).abs() < 1e-12);
        assert!((object / d - 1.387).abs() < 1e-3);
        assert!((out[0].shear_mm - (2.0 * d - object)).abs() < 1e-12);
        assert!((out[0].shear_mm / d - 0.613).abs() < 1e-3);
        assert!((out[1].shear_mm / d + 0.387).abs() < 1e-3);
        assert_eq!(out[1].shear_mm, out[2].shear_mm);
        // the shears balance on the object
        let net = k0 * out[0].shear_mm + out[1].shear_mm + out[2].shear_mm;
        assert!(net.abs() < 1e-12);
        assert!(out.iter().all(|o| o.slide_mm.is_none()));
        // held along the axis (the rail's guides), each skin keeps its whole curl
        let mut held = CurlGrasp::default();
        let out = held.step(
            &[input(2.0 * d, l, k0), input(d, l, 1.0), input(d, l, 1.0)],
            ApproachAxis::Held,
            false,
        );
        assert_eq!(held.object_mm(), 0.0);
        assert!((out[0].shear_mm - 2.0 * d).abs() < 1e-12 && (out[1].shear_mm - d).abs() < 1e-12);
    }

    #[test]
    fn a_stuck_patch_shears_elastically_both_ways_and_breaks_free_only_beyond_the_circle() {
        let l = limits(0.0, 0.0);
        let mut grasp = CurlGrasp::default();
        let one = |g: &mut CurlGrasp, d: f64| {
            g.step(&[input(d, l, 1.0), None, None], ApproachAxis::Held, false)[0]
        };
        one(&mut grasp, 0.0);
        // curling in: elastic up to 1 mm
        assert_eq!(
            one(&mut grasp, 0.9),
            CurlOutcome {
                shear_mm: 0.9,
                slide_mm: None
            }
        );
        // beyond it the patch slides down to the kinetic share and sticks again
        let o = one(&mut grasp, 1.1);
        assert!((o.shear_mm - 1.0 / 1.15).abs() < 1e-12);
        assert!((o.slide_mm.unwrap() - (1.1 - 1.0 / 1.15)).abs() < 1e-12);
        // uncurling: the skin unloads elastically through zero and the other way
        let o = one(&mut grasp, 0.0);
        assert!(
            o.slide_mm.is_none() && o.shear_mm < 0.0 && o.shear_mm.abs() <= 1.0,
            "{o:?}"
        );
        assert!((grasp.contact(0).travelled_mm() - (1.1 - 1.0 / 1.15)).abs() < 1e-12);
    }

    #[test]
    fn as_the_grasp_nears_its_limit_a_held_curl_gives_way_without_any_fingertip_moving() {
        // the fingertip holds still at a shear of 0.5 mm; the load across rises towards 1
        let mut grasp = CurlGrasp::default();
        let at = |share: f64| [input(0.5, limits(0.0, share), 1.0), None, None];
        grasp.step(
            &[input(0.0, limits(0.0, 0.0), 1.0), None, None],
            ApproachAxis::Held,
            true,
        );
        grasp.step(&at(0.0), ApproachAxis::Held, true);
        let mut broke_at = None;
        let mut last = 0.0;
        for k in 0..=100 {
            let share = k as f64 / 100.0;
            let o = grasp.step(&at(share), ApproachAxis::Held, false)[0];
            if o.slide_mm.is_some() {
                broke_at.get_or_insert(share);
            }
            last = o.shear_mm;
        }
        // sqrt(1 - s^2) = 0.5 at s = 0.866: it breaks free there, before the grasp's limit
        let s = broke_at.expect("it breaks free");
        assert!((0.86..0.88).contains(&s), "{s}");
        // and by the limit the curl's shear is gone
        assert!(last.abs() < 1e-9);
    }

    #[test]
    fn a_grasp_made_before_the_start_records_no_slide_and_a_new_touch_starts_a_new_patch() {
        let l = limits(0.0, 0.0);
        let mut grasp = CurlGrasp::default();
        grasp.step(&[input(0.0, l, 1.0), None, None], ApproachAxis::Held, true);
        let o = grasp.step(&[input(2.0, l, 1.0), None, None], ApproachAxis::Held, true)[0];
        assert_eq!(
            o,
            CurlOutcome {
                shear_mm: 1.0,
                slide_mm: None
            }
        );
        assert_eq!(grasp.contact(0).travelled_mm(), 0.0);
        grasp.step(&[None, None, None], ApproachAxis::Held, false);
        let o = grasp.step(&[input(0.5, l, 1.0), None, None], ApproachAxis::Held, false)[0];
        assert_eq!(
            o,
            CurlOutcome {
                shear_mm: 0.5,
                slide_mm: None
            }
        );
    }
}
