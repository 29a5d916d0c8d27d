//! Grasp statics: how the tangential load on a held object is shared between the thumb and
//! the fingers, from force **and moment** balance of the object as a rigid body.
//!
//! Frame (the hand's): `x` the pinch axis (the thumb presses along +x, the fingers along
//! -x), `y` the approach axis (out of the palm), `w` across the palm, along which the two
//! fingers stand apart. Rolling the hand by `grasp_deg` about `y` turns gravity in this
//! frame; at 0 degrees gravity is -w, at 180 degrees +w. The normal forces come from the
//! pinch solve ([`crate::grasp::pinch_normal_forces`]); they balance along `x`.
//!
//! The object may move in the tangent plane and rotate: `q = (u_y, u_w, theta_x, theta_y,
//! theta_w)`. A stuck contact at `p` resists its tangential displacement `J(p) q` with a
//! spring `kappa` (proportional to its normal force, so a light load is shared by normal
//! force, as in [`crate::grasp::share_stuck_load`]); the external load (weight and inertia
//! at the centre of mass) and the normal forces' moments are balanced by `K q = G`, with
//! `K = sum kappa J^T J` and `G` the generalised forces (the virtual work of each force on
//! `q`). Three stuck contacts hold five degrees of freedom; the statics of three point
//! contacts is indeterminate, and the springs resolve it. A contact whose load exceeds
//! `mu_static N` slips and then carries `mu_kinetic N` in the direction it was loaded;
//! the rest share again. When the stuck contacts left cannot hold the object in every
//! direction (`K` singular), the grasp slips as a whole, and [`GrossSlip`] says whether
//! it would slide or turn.

/// One contact of a grasp, in the hand frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactPoint {
    /// Where the fingertip touches the object, relative to the object's centre of mass, mm.
    pub position_mm: [f64; 3],
    /// +1 where the contact pushes the object along +x (the thumb), -1 along -x.
    pub normal_x: f64,
    pub normal_n: f64,
    pub mu_static: f64,
    pub mu_kinetic: f64,
}

/// The tangential load of each contact, `(y, w)` in the hand frame, N.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct HeldLoads {
    pub tangential_n: [[f64; 2]; 3],
    /// Contacts that slip locally while the grasp as a whole holds.
    pub local_slip: [bool; 3],
}

impl HeldLoads {
    /// Each contact's tangential load, N.
    pub fn magnitude_n(&self, i: usize) -> f64 {
        let [y, w] = self.tangential_n[i];
        y.hypot(w)
    }
}

/// How a grasp that cannot hold its load gives way: the free motion of the object.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum GrossSlip {
    /// Mostly a slide through the fingers.
    Slide,
    /// Mostly a turn about the axis (hand frame, unit) given.
    Turn { axis: [f64; 3] },
}

/// The generalised force of force `f` (hand frame, N) acting at `p` (mm from the centre
/// of mass) on `q = (u_y, u_w, theta_x, theta_y, theta_w)`.
fn generalised(p: [f64; 3], f: [f64; 3]) -> [f64; 5] {
    let ([x, y, w], [fx, fy, fw]) = (p, f);
    [fy, fw, y * fw - w * fy, w * fx - x * fw, x * fy - y * fx]
}

/// The tangential displacement `(y, w)` at `p` per unit of each of `q`'s components.
fn jacobian(p: [f64; 3]) -> [[f64; 5]; 2] {
    let [x, y, w] = p;
    [[1.0, 0.0, -w, 0.0, x], [0.0, 1.0, y, -x, 0.0]]
}

/// Solves `k q = g` by Gaussian elimination with partial pivoting; `None` when `k` is
/// singular relative to its own scale.
fn solve5(mut k: [[f64; 5]; 5], mut g: [f64; 5]) -> Option<[f64; 5]> {
    let scale = k
        .iter()
        .flatten()
        .fold(0.0f64, |m, v| m.max(v.abs()))
        .max(1e-300);
    for col in 0..5 {
        let pivot = (col..5).max_by(|&a, &b| k[a][col].abs().total_cmp(&k[b][col].abs()))?;
        if k[pivot][col].abs() < 1e-9 * scale {
            return None;
        }
        k.swap(col, pivot);
        g.swap(col, pivot);
        let (pivot_row, g_pivot) = (k[col], g[col]);
        for row in col + 1..5 {
            let f = k[row][col] / pivot_row[col];
            for (v, p) in k[row].iter_mut().zip(&pivot_row).skip(col) {
                *v -= f * p;
            }
            g[row] -= f * g_pivot;
        }
    }
    let mut q = [0.0; 5];
    for row in (0..5).rev() {
        let s: f64 = (row + 1..5).map(|c| k[row][c] * q[c]).sum();
        q[row] = (g[row] - s) / k[row][row];
    }
    Some(q)
}

/// The stiffness of the stuck contacts on `q`.
fn stiffness(contacts: &[ContactPoint], stuck: &[bool]) -> [[f64; 5]; 5] {
    let mut k = [[0.0; 5]; 5];
    for (c, _) in contacts
        .iter()
        .zip(stuck)
        .filter(|(c, s)| **s && c.normal_n > 0.0)
    {
        let j = jacobian(c.position_mm);
        for a in 0..5 {
            for b in 0..5 {
                k[a][b] += c.normal_n * (j[0][a] * j[0][b] + j[1][a] * j[1][b]);
            }
        }
    }
    k
}

/// The free motion of an object held by `k` alone: the eigenvector of its smallest
/// eigenvalue (inverse iteration on `k` shifted by a little stiffness), with rotations
/// measured in mm at `lever_mm` so that slides and turns compare.
fn free_motion(k: [[f64; 5]; 5], lever_mm: f64) -> GrossSlip {
    let scale = k
        .iter()
        .flatten()
        .fold(0.0f64, |m, v| m.max(v.abs()))
        .max(1.0);
    let mut shifted = k;
    for (i, row) in shifted.iter_mut().enumerate() {
        row[i] += 1e-6 * scale;
    }
    let mut v = [1.0, 1.0, 1.0, 1.0, 1.0];
    for _ in 0..50 {
        let Some(next) = solve5(shifted, v) else {
            break;
        };
        let norm = next.iter().map(|a| a * a).sum::<f64>().sqrt();
        if norm == 0.0 {
            break;
        }
        v = next.map(|a| a / norm);
    }
    let slide = v[0].hypot(v[1]);
    let turn = (v[2] * v[2] + v[3] * v[3] + v[4] * v[4]).sqrt();
    if turn * lever_mm > slide {
        let axis = [v[2], v[3], v[4]].map(|a| a / turn);
        GrossSlip::Turn { axis }
    } else {
        GrossSlip::Slide
    }
}

/// The loads of a held object: `load_n` (hand frame, N; weight and inertia) acts at the
/// centre of mass, which every contact's position is measured from. Contacts slip one at a
/// time, the most overloaded first; [`GrossSlip`] when the stuck ones left cannot hold.
pub fn held_loads(contacts: &[ContactPoint], load_n: [f64; 3]) -> Result<HeldLoads, GrossSlip> {
    assert!(contacts.len() <= 3);
    let lever_mm = contacts
        .iter()
        .map(|c| c.position_mm.iter().map(|a| a * a).sum::<f64>().sqrt())
        .fold(1.0, f64::max);
    let mut stuck = [true; 3];
    for (s, c) in stuck.iter_mut().zip(contacts) {
        *s = c.normal_n > 0.0;
    }
    stuck[contacts.len()..].fill(false);
    let mut sliding: [Option<[f64; 2]>; 3] = [None; 3];
    loop {
        // What the stuck springs must balance: the load at the centre of mass, every
        // normal force's moment and the sliding contacts' friction.
        let mut g = generalised([0.0; 3], load_n);
        for (i, c) in contacts.iter().enumerate() {
            let f_slide = sliding[i].unwrap_or([0.0, 0.0]);
            let f = [c.normal_x * c.normal_n, f_slide[0], f_slide[1]];
            let gi = generalised(c.position_mm, f);
            for a in 0..5 {
                g[a] += gi[a];
            }
        }
        let k = stiffness(contacts, &stuck);
        let Some(q) = solve5(k, g) else {
            // More load along the grasp than all its contacts' friction: it slides,
            // whatever else it might do.
            let capacity: f64 = contacts.iter().map(|c| c.mu_static * c.normal_n).sum();
            if load_n[1].hypot(load_n[2]) > capacity {
                return Err(GrossSlip::Slide);
            }
            // The contacts that slipped locally move a little and the loads redistribute:
            // the grasp holds if some balanced loads keep every contact within its static
            // friction (the elastic cascade alone would call a slip that friction,
            // redirected, still holds).
            if let Some(limit) = limit_loads(contacts, load_n).filter(|l| l.ratio <= 1.0) {
                let local_slip = sliding.map(|s| s.is_some());
                return Ok(HeldLoads {
                    tangential_n: limit.tangential_n,
                    local_slip,
                });
            }
            // Otherwise it gives way as the stuck contacts left let it most easily.
            return Err(free_motion(k, lever_mm));
        };
        let mut loads = HeldLoads::default();
        let mut worst: Option<(usize, f64)> = None;
        for (i, c) in contacts.iter().enumerate() {
            if let Some(f) = sliding[i] {
                loads.tangential_n[i] = f;
                loads.local_slip[i] = true;
                continue;
            }
            if !stuck[i] {
                continue;
            }
            // The spring pulls the object back against its displacement.
            let j = jacobian(c.position_mm);
            let d = [0, 1].map(|r| (0..5).map(|a| j[r][a] * q[a]).sum::<f64>());
            let t = d.map(|v| -c.normal_n * v);
            loads.tangential_n[i] = t;
            let ratio = t[0].hypot(t[1]) / (c.mu_static * c.normal_n);
            if ratio > 1.0 && worst.is_none_or(|(_, r)| ratio > r) {
                worst = Some((i, ratio));
            }
        }
        let Some((i, _)) = worst else {
            return Ok(loads);
        };
        let [ty, tw] = loads.tangential_n[i];
        let m = ty.hypot(tw);
        let c = &contacts[i];
        sliding[i] = Some([ty, tw].map(|v| v / m * c.mu_kinetic * c.normal_n));
        stuck[i] = false;
    }
}

/// Balanced tangential loads found by limit analysis: see [`limit_loads`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LimitLoads {
    pub tangential_n: [[f64; 2]; 3],
    /// The largest `|T_i| / (mu_s N_i)` over the contacts: at most 1 where the grasp holds.
    pub ratio: f64,
}

/// Of all tangential loads that balance force and moment on the object (with the normal
/// forces and `load_n` at the centre of mass), the one whose most loaded contact is
/// furthest from its static friction limit: the lower bound of limit analysis, which
/// holds the object if any distribution within the friction cones does. Three contacts
/// have six tangential components for five balance equations, so the balanced loads are
/// a line `t_p + s n`; the largest ratio along it is convex in `s` and found by golden
/// section. `None` when fewer than three contacts press or the line does not exist.
pub fn limit_loads(contacts: &[ContactPoint], load_n: [f64; 3]) -> Option<LimitLoads> {
    if contacts.len() != 3 || contacts.iter().any(|c| c.normal_n <= 0.0) {
        return None;
    }
    let mut g = generalised([0.0; 3], load_n);
    for c in contacts {
        let gi = generalised(c.position_mm, [c.normal_x * c.normal_n, 0.0, 0.0]);
        for a in 0..5 {
            g[a] += gi[a];
        }
    }
    // Columns of the balance `A t = -g`: contact i's y and w loads act through the rows
    // of its Jacobian (A = [J_1^T J_2^T J_3^T]), so `A A^T` is the unit stiffness.
    let columns: Vec<[f64; 5]> = contacts
        .iter()
        .flat_map(|c| jacobian(c.position_mm))
        .collect();
    let mut unit = [[0.0; 5]; 5];
    for col in &columns {
        for a in 0..5 {
            for b in 0..5 {
                unit[a][b] += col[a] * col[b];
            }
        }
    }
    let dot = |a: &[f64; 5], b: &[f64; 5]| (0..5).map(|i| a[i] * b[i]).sum::<f64>();
    // Least-norm balanced loads: t_p = A^T y with (A A^T) y = -g.
    let y = solve5(unit, g.map(|v| -v))?;
    let t_p: Vec<f64> = columns.iter().map(|c| dot(c, &y)).collect();
    // The line's direction: a unit vector's part outside the columns' span, the largest.
    let null = (0..6)
        .filter_map(|e| {
            let a_e = columns[e];
            let z = solve5(unit, a_e)?;
            let v: Vec<f64> = (0..6)
                .map(|i| f64::from(u8::from(i == e)) - dot(&columns[i], &z))
                .collect();
            let norm = v.iter().map(|a| a * a).sum::<f64>().sqrt();
            Some((norm, v))
        })
        .max_by(|a, b| a.0.total_cmp(&b.0))?;
    if null.0 < 1e-9 {
        return None;
    }
    let n: Vec<f64> = null.1.iter().map(|v| v / null.0).collect();
    let caps = [0, 1, 2].map(|i| contacts[i].mu_static * contacts[i].normal_n);
    let loads_at =
        |s: f64| [0, 1, 2].map(|i| [t_p[2 * i] + s * n[2 * i], t_p[2 * i + 1] + s * n[2 * i + 1]]);
    let ratio_at = |s: f64| {
        loads_at(s)
            .iter()
            .zip(&caps)
            .map(|(t, cap)| t[0].hypot(t[1]) / cap)
            .fold(0.0, f64::max)
    };
    // Beyond `bound` some contact's ratio exceeds the ratio at s = 0.
    let r0 = ratio_at(0.0);
    let bound = (0..3)
        .filter_map(|i| {
            let along = n[2 * i].hypot(n[2 * i + 1]);
            (along > 1e-12).then(|| (t_p[2 * i].hypot(t_p[2 * i + 1]) + r0 * caps[i]) / along)
        })
        .fold(f64::INFINITY, f64::min);
    let (mut lo, mut hi) = if bound.is_finite() {
        (-bound, bound)
    } else {
        (0.0, 0.0)
    };
    let phi = (5f64.sqrt() - 1.0) / 2.0;
    for _ in 0..100 {
        let (a, b) = (hi - phi * (hi - lo), lo + phi * (hi - lo));
        if ratio_at(a) <= ratio_at(b) {
            hi = b;
        } else {
            lo = a;
        }
    }
    let s = 0.5 * (lo + hi);
    Some(LimitLoads {
        tangential_n: loads_at(s),
        ratio: ratio_at(s),
    })
}

/// Gravity in the hand frame for a hand rolled by `grasp_deg` about its approach axis:
/// -w at 0 degrees, +w at 180, along the pinch axis between.
pub fn gravity_direction(grasp_deg: f64) -> [f64; 3] {
    let (s, c) = grasp_deg.to_radians().sin_cos();
    [s, 0.0, -c]
}

/// The three contacts of a pinch: the thumb at `x = -half_width`, midway between the two
/// fingers across the palm, the fingers at `x = +half_width`, `w = +-finger_half_spacing`;
/// `grasp_point_mm` is where the grasp's centre sits relative to the centre of mass.
pub fn pinch_contacts(
    half_width_mm: f64,
    finger_half_spacing_mm: f64,
    grasp_point_mm: [f64; 3],
    normal_n: [f64; 3],
    mu_static: f64,
    mu_kinetic: f64,
) -> [ContactPoint; 3] {
    let [gx, gy, gw] = grasp_point_mm;
    let at = |x: f64, w: f64, normal_x: f64, n: f64| ContactPoint {
        position_mm: [gx + x, gy, gw + w],
        normal_x,
        normal_n: n,
        mu_static,
        mu_kinetic,
    };
    [
        at(-half_width_mm, 0.0, 1.0, normal_n[0]),
        at(half_width_mm, finger_half_spacing_mm, -1.0, normal_n[1]),
        at(half_width_mm, -finger_half_spacing_mm, -1.0, normal_n[2]),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    const MU: (f64, f64) = (0.8, 0.7);

    fn pinch(grasp_point: [f64; 3], n: [f64; 3]) -> [ContactPoint; 3] {
        pinch_contacts(35.0, 30.0, grasp_point, n, MU.0, MU.1)
    }

    fn weight(grasp_deg: f64, newtons: f64) -> [f64; 3] {
        gravity_direction(grasp_deg).map(|g| g * newtons)
    }

    /// Every force and moment on the object: load, normals and tangential loads.
    fn residual(contacts: &[ContactPoint], load: [f64; 3], loads: &HeldLoads) -> [f64; 6] {
        let mut r = [load[0], load[1], load[2], 0.0, 0.0, 0.0];
        for (i, c) in contacts.iter().enumerate() {
            let [ty, tw] = loads.tangential_n[i];
            let f = [c.normal_x * c.normal_n, ty, tw];
            let [x, y, w] = c.position_mm;
            let m = [
                y * f[2] - w * f[1],
                w * f[0] - x * f[2],
                x * f[1] - y * f[0],
            ];
            for a in 0..3 {
                r[a] += f[a];
                r[3 + a] += m[a];
            }
        }
        r
    }

    #[test]
    fn forces_and_moments_balance_at_0_and_180_degrees() {
        for deg in [0.0, 180.0] {
            for grasp_point in [[0.0; 3], [0.0, 0.0, 20.0], [3.0, 5.0, -10.0]] {
                let c = pinch(grasp_point, [4.0, 2.0, 2.0]);
                let load = weight(deg, 1.5);
                let held = held_loads(&c, load).unwrap();
                let r = residual(&c, load, &held);
                // Along x the normals balance each other; the x load is the pinch's.
                for (a, v) in r.iter().enumerate().skip(1) {
                    assert!(
                        v.abs() < 1e-9,
                        "{deg} deg, {grasp_point:?}: residual {a} = {v}"
                    );
                }
            }
        }
    }

    #[test]
    fn a_centred_symmetric_grasp_shares_symmetrically_and_an_off_centre_one_does_not() {
        let c = pinch([0.0; 3], [4.0, 2.0, 2.0]);
        let held = held_loads(&c, weight(0.0, 2.0)).unwrap();
        // Thumb half, each finger a quarter, all upwards.
        assert!((held.tangential_n[0][1] - 1.0).abs() < 1e-9, "{held:?}");
        assert!((held.tangential_n[1][1] - 0.5).abs() < 1e-9);
        assert!((held.tangential_n[2][1] - 0.5).abs() < 1e-9);
        assert!(held.tangential_n.iter().all(|t| t[0].abs() < 1e-9));
        // Centre of mass off the pinch axis towards the fingers: they carry more, the
        // thumb less; a moment about w needs no couple across the palm.
        let c = pinch([-10.0, 0.0, 0.0], [4.0, 2.0, 2.0]);
        let held = held_loads(&c, weight(0.0, 2.0)).unwrap();
        let fingers = held.tangential_n[1][1] + held.tangential_n[2][1];
        assert!(
            fingers > 1.0 + 0.1 && held.tangential_n[0][1] < 1.0 - 0.1,
            "{held:?}"
        );
        // Centre of mass behind the grasp (along the approach axis): the two fingers carry
        // opposite loads along y, a couple about the pinch axis.
        let c = pinch([0.0, 15.0, 0.0], [4.0, 2.0, 2.0]);
        let held = held_loads(&c, weight(0.0, 2.0)).unwrap();
        let (f1, f2) = (held.tangential_n[1], held.tangential_n[2]);
        assert!(
            f1[0].abs() > 0.1 && (f1[0] + f2[0]).abs() < 1e-9,
            "{held:?}"
        );
    }

    #[test]
    fn the_roll_mirrors_the_loads_of_a_symmetric_grasp() {
        // A symmetric grasp rolled through 180 degrees carries the same loads reversed:
        // the roll alone moves no load between thumb and fingers.
        let c = pinch([0.0; 3], [4.0, 2.0, 2.0]);
        let at0 = held_loads(&c, weight(0.0, 2.0)).unwrap();
        let at180 = held_loads(&c, weight(180.0, 2.0)).unwrap();
        for i in 0..3 {
            assert!((at0.magnitude_n(i) - at180.magnitude_n(i)).abs() < 1e-9);
        }
        // Unequal finger forces (a thumb not midway) put the thumb's share on one side of
        // a half at 0 degrees and on the other at 180.
        let c = pinch([0.0; 3], [4.0, 2.6, 1.4]);
        let (a, b) = (
            held_loads(&c, weight(0.0, 2.0)).unwrap(),
            held_loads(&c, weight(180.0, 2.0)).unwrap(),
        );
        assert!(
            (a.magnitude_n(0) - 1.0) * (b.magnitude_n(0) - 1.0) < 0.0,
            "{a:?} {b:?}"
        );
    }

    #[test]
    fn a_torque_about_the_pinch_axis_turns_the_object_once_friction_is_exceeded() {
        // Weight 2 N, 30 mm behind the grasp: 60 N mm about x, against the fingers'
        // couple across 60 mm.
        let light = pinch([0.0, 30.0, 0.0], [6.0, 3.0, 3.0]);
        assert!(held_loads(&light, weight(0.0, 2.0)).is_ok());
        let far = pinch([0.0, 120.0, 0.0], [6.0, 3.0, 3.0]);
        match held_loads(&far, weight(0.0, 2.0)) {
            Err(GrossSlip::Turn { axis }) => {
                assert!(axis[0].abs() > 0.9, "turns about the pinch axis: {axis:?}")
            }
            other => panic!("expected a turn, got {other:?}"),
        }
    }

    #[test]
    fn limit_loads_balance_and_share_a_centred_load_by_normal_force() {
        let c = pinch([0.0; 3], [6.0, 3.0, 3.0]);
        let limit = limit_loads(&c, weight(0.0, 2.0)).unwrap();
        let held = HeldLoads {
            tangential_n: limit.tangential_n,
            local_slip: [false; 3],
        };
        for (a, v) in residual(&c, weight(0.0, 2.0), &held)
            .iter()
            .enumerate()
            .skip(1)
        {
            assert!(v.abs() < 1e-9, "residual {a} = {v}");
        }
        // Thumb 1 N of 4.8, fingers 0.5 N of 2.4 each.
        assert!((limit.ratio - 1.0 / 4.8).abs() < 1e-9, "{limit:?}");
    }

    #[test]
    fn an_off_centre_grasp_holds_as_long_as_balanced_loads_within_friction_exist() {
        // Centre of mass 20 mm from the grasp along the approach axis: the fingers' couple
        // takes a share of their friction. The grasp holds exactly up to the load at which
        // limit analysis runs out of friction, although the elastic cascade gives up
        // earlier, and it lets go there sooner than a centred grasp would (9.6 N).
        let c = pinch([0.0, -20.0, 0.0], [6.0, 3.0, 3.0]);
        let ratio = |newtons: f64| limit_loads(&c, weight(0.0, newtons)).unwrap().ratio;
        let (mut lo, mut hi) = (0.0, 20.0);
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if ratio(mid) <= 1.0 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        assert!(lo > 3.0 && lo < 9.6 - 0.5, "limit load {lo}");
        let held = held_loads(&c, weight(0.0, 0.99 * lo)).unwrap();
        for (a, v) in residual(&c, weight(0.0, 0.99 * lo), &held)
            .iter()
            .enumerate()
            .skip(1)
        {
            assert!(v.abs() < 1e-9, "residual {a} = {v}");
        }
        for (i, contact) in c.iter().enumerate() {
            let cap = contact.mu_static * contact.normal_n;
            assert!(held.magnitude_n(i) <= cap * (1.0 + 1e-9), "{i}: {held:?}");
        }
        assert!(held_loads(&c, weight(0.0, 1.01 * lo)).is_err());
    }

    #[test]
    fn an_overload_along_the_grasp_slides_it() {
        // Capacity 0.8 * 12 = 9.6 N.
        let c = pinch([0.0; 3], [6.0, 3.0, 3.0]);
        assert!(held_loads(&c, weight(0.0, 9.0)).is_ok());
        assert_eq!(held_loads(&c, weight(0.0, 10.0)), Err(GrossSlip::Slide));
    }
}
