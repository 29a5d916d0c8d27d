//! Each fingertip's own slip along the object as its finger curls or uncurls: the contact
//! slip that comes before the object's (`docs/simulator.md`, "Contact slip of one
//! fingertip").
//!
//! An under-actuated finger curls as it presses past first touch, so its fingertip moves
//! along the object's surface (along the hand's approach axis) by `ratio * pressed`, and
//! back again as it relaxes. The patch sticks where it touched: the skin between them
//! shears, `u = ratio * pressed - slid`, where `slid` is how far the patch has slid over
//! the object. Friction is a circle (Coulomb): the load that holds the object up, `T`, is
//! set by the grasp's statics (force-driven: the object falls if it is not carried), while
//! the curl's load is displacement-driven and is what gives way first. So the patch holds
//! the curl's shear up to what the circle leaves, `u_max sqrt(1 - (T / mu_s N)^2)`, with
//! `u_max = 3 mu_s N / 2 k_t` Mindlin's full-slip shear; beyond it the patch breaks free and
//! slides until its shear is down to the kinetic circle's share,
//! `u_max (mu_k / mu_s) sqrt(1 - (T / mu_k N)^2)`, and sticks again. As a grasp relaxes
//! towards its limit (`T / mu_s N` nearing 1) the circle leaves the curl less and less, so
//! each fingertip slips along the object, one at a time as their loads and skins differ,
//! before the object itself can slip: what the paper saw ("one finger may begin to slip
//! before another when a grasp is relaxed and, crucially, before the object starts to
//! drop").

/// What a contact's friction leaves for the curl at one instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CurlLimits {
    /// Mindlin's full-slip shear at this normal force and static friction, mm.
    pub full_slip_mm: f64,
    /// The load holding the object up as a share of the static friction, `T / mu_s N`.
    pub load_share: f64,
    /// `mu_k / mu_s`.
    pub kinetic_ratio: f64,
}

impl CurlLimits {
    /// The curl's shear the stuck patch holds, mm.
    pub fn static_mm(&self) -> f64 {
        self.full_slip_mm * circle_share(self.load_share)
    }

    /// The curl's shear a patch that has broken free slides down to, mm.
    pub fn kinetic_mm(&self) -> f64 {
        let k = self.kinetic_ratio;
        if k <= 0.0 {
            return 0.0;
        }
        self.full_slip_mm * k * circle_share(self.load_share / k)
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
    /// How far the patch has slid over the object from where the fingertip first touched,
    /// mm (signed along the curl).
    slid_mm: f64,
    /// How far it has slid in all, either way, mm.
    travelled_mm: f64,
}

impl CurlContact {
    /// The skin's shear along the curl when the fingertip has moved `demand_mm` along the
    /// object since first touch, mm.
    pub fn shear_mm(&self, demand_mm: f64) -> f64 {
        demand_mm - self.slid_mm
    }

    /// How far the patch has slid over the object in all, either way, mm.
    pub fn travelled_mm(&self) -> f64 {
        self.travelled_mm
    }

    /// A grasp that was made before the simulation starts: the patch has already slid as
    /// far as the stuck circle asked while the grasp was set, with nothing to record.
    pub fn settle(&mut self, demand_mm: f64, limits: &CurlLimits) {
        let u = self.shear_mm(demand_mm);
        let hold = limits.static_mm();
        if u.abs() > hold {
            self.slid_mm = demand_mm - u.signum() * hold;
        }
    }

    /// The fingertip has moved `demand_mm` along the object since first touch: the skin's
    /// shear now, and how far the patch slid if it broke free this step.
    pub fn step(&mut self, demand_mm: f64, limits: &CurlLimits) -> (f64, Option<f64>) {
        let u = self.shear_mm(demand_mm);
        if u.abs() <= limits.static_mm() {
            return (u, None);
        }
        let after = u.signum() * limits.kinetic_mm().min(limits.static_mm());
        let slide = u - after;
        self.slid_mm += slide;
        self.travelled_mm += slide.abs();
        (after, Some(slide.abs()))
    }

    /// The fingertip has left the object: a new touch starts a new patch.
    pub fn lift_off(&mut self) {
        self.slid_mm = 0.0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn limits(load_share: f64) -> CurlLimits {
        CurlLimits {
            full_slip_mm: 1.0,
            load_share,
            kinetic_ratio: 1.0 / 1.15,
        }
    }

    #[test]
    fn the_friction_circle_leaves_the_curl_less_as_the_load_nears_the_limit() {
        assert_eq!(limits(0.0).static_mm(), 1.0);
        assert!((limits(0.6).static_mm() - 0.8).abs() < 1e-12);
        assert_eq!(limits(1.0).static_mm(), 0.0);
        assert_eq!(limits(1.3).static_mm(), 0.0);
        // the kinetic circle is smaller: it leaves nothing once the load passes mu_k N
        assert!((limits(0.0).kinetic_mm() - 1.0 / 1.15).abs() < 1e-12);
        assert!(limits(0.5).kinetic_mm() < limits(0.5).static_mm());
        assert_eq!(limits(0.9).kinetic_mm(), 0.0);
    }

    #[test]
    fn a_stuck_patch_shears_elastically_both_ways_and_breaks_free_only_beyond_the_circle() {
        let mut c = CurlContact::default();
        let l = limits(0.0);
        // curling in: elastic up to 1 mm
        assert_eq!(c.step(0.9, &l), (0.9, None));
        // beyond it the patch slides down to the kinetic share and sticks again
        let (u, slide) = c.step(1.1, &l);
        assert!((u - 1.0 / 1.15).abs() < 1e-12);
        assert!((slide.unwrap() - (1.1 - 1.0 / 1.15)).abs() < 1e-12);
        // uncurling: the skin unloads elastically through zero and the other way
        let (u, slide) = c.step(0.0, &l);
        assert!(slide.is_none() && u < 0.0 && u.abs() <= 1.0, "{u}");
        assert!((c.travelled_mm() - (1.1 - 1.0 / 1.15)).abs() < 1e-12);
    }

    #[test]
    fn as_the_grasp_nears_its_limit_a_held_curl_gives_way_without_any_fingertip_moving() {
        // the fingertip holds still at a shear of 0.5 mm; the load share rises towards 1
        let mut c = CurlContact::default();
        c.settle(0.5, &limits(0.0));
        let mut broke_at = None;
        for k in 0..=100 {
            let share = k as f64 / 100.0;
            if let (_, Some(_)) = c.step(0.5, &limits(share)) {
                broke_at.get_or_insert(share);
            }
        }
        // sqrt(1 - s^2) = 0.5 at s = 0.866: it breaks free there, before the grasp's limit
        let s = broke_at.expect("it breaks free");
        assert!((0.86..0.88).contains(&s), "{s}");
        // and by the limit the curl's shear is gone
        assert!(c.shear_mm(0.5).abs() < 1e-9);
    }

    #[test]
    fn a_grasp_made_before_the_start_records_no_slide() {
        let mut c = CurlContact::default();
        c.settle(2.0, &limits(0.0));
        assert_eq!(c.shear_mm(2.0), 1.0);
        assert_eq!(c.travelled_mm(), 0.0);
        c.lift_off();
        assert_eq!(c.shear_mm(0.0), 0.0);
    }
}
