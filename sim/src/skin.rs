//! Contact mechanics of one TacTip fingertip against an object, as pure functions: Hertzian
//! indentation and contact radius, Cattaneo-Mindlin partial slip under a tangential load,
//! rate-dependent friction, and the skin patch's drag while the object slides over a surface
//! whose friction varies along it. Equations, parameters and their sources: `docs/simulator.md`.

use super::tactip::SkinTimes;

/// Elastic properties of the skin's contact with an object.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SkinContact {
    /// Hertz constant `K = 4/3 E* sqrt(R)`, N/mm^1.5: `N = K delta^1.5`.
    hertz_n_per_mm1_5: f64,
    /// Radius of the dome, mm.
    dome_radius_mm: f64,
    /// Mindlin tangential stiffness per mm of contact radius, `8 G / (2 - nu)`, N/mm^2.
    shear_n_per_mm2: f64,
}

impl SkinContact {
    /// `modulus_kpa` is the effective (plane-strain) modulus `E*` of skin and object together,
    /// `poisson` the skin's Poisson ratio (an elastomer: near 0.5).
    pub fn new(modulus_kpa: f64, poisson: f64, dome_radius_mm: f64) -> Self {
        let e_star = modulus_kpa * 1e-3; // N/mm^2
        let e = e_star * (1.0 - poisson * poisson);
        let g = e / (2.0 * (1.0 + poisson));
        Self {
            hertz_n_per_mm1_5: 4.0 / 3.0 * e_star * dome_radius_mm.sqrt(),
            dome_radius_mm,
            shear_n_per_mm2: 8.0 * g / (2.0 - poisson),
        }
    }

    /// Same contact with its modulus scaled (a stiffer or softer manufactured skin).
    pub fn scaled(self, factor: f64) -> Self {
        Self {
            hertz_n_per_mm1_5: self.hertz_n_per_mm1_5 * factor,
            shear_n_per_mm2: self.shear_n_per_mm2 * factor,
            ..self
        }
    }

    /// Indentation of the skin under normal force `normal_n`, mm (Hertz).
    pub fn indentation_mm(&self, normal_n: f64) -> f64 {
        (normal_n.max(0.0) / self.hertz_n_per_mm1_5).powf(2.0 / 3.0)
    }

    /// Normal force at indentation `delta_mm`, N (Hertz).
    pub fn normal_force_n(&self, delta_mm: f64) -> f64 {
        self.hertz_n_per_mm1_5 * delta_mm.max(0.0).powf(1.5)
    }

    /// Radius of the contact patch, `a = sqrt(R delta)`, mm.
    pub fn contact_radius_mm(&self, normal_n: f64) -> f64 {
        (self.dome_radius_mm * self.indentation_mm(normal_n)).sqrt()
    }

    /// Tangential stiffness of the fully stuck patch, `8 G a / (2 - nu)`, N/mm.
    pub fn tangential_stiffness(&self, normal_n: f64) -> f64 {
        self.shear_n_per_mm2 * self.contact_radius_mm(normal_n)
    }

    /// Tangential displacement at which the whole patch slides, mm: Mindlin's
    /// `3 mu N / (2 k_t)` (1.5 times what the stuck stiffness alone would give).
    pub fn full_slip_shear_mm(&self, normal_n: f64, mu: f64) -> f64 {
        let k = self.tangential_stiffness(normal_n);
        if k <= 0.0 {
            return 0.0;
        }
        1.5 * mu * normal_n / k
    }

    /// Tangential displacement of the patch under load `tangential_n` (signed) while it does
    /// not slide as a whole (Cattaneo-Mindlin): `u = u_max (1 - (1 - |T| / mu N)^(2/3))`.
    /// The edge slips first; as `|T|` nears `mu N` the stuck core shrinks and `u` grows fast.
    pub fn mindlin_shear_mm(&self, tangential_n: f64, normal_n: f64, mu: f64) -> f64 {
        let limit = mu * normal_n;
        if limit <= 0.0 {
            return 0.0;
        }
        let x = (tangential_n.abs() / limit).min(1.0);
        tangential_n.signum()
            * self.full_slip_shear_mm(normal_n, mu)
            * (1.0 - (1.0 - x).powf(2.0 / 3.0))
    }

    /// The inverse of [`Self::mindlin_shear_mm`]: force the patch carries at displacement
    /// `shear_mm`, at most `mu N`.
    pub fn mindlin_force_n(&self, shear_mm: f64, normal_n: f64, mu: f64) -> f64 {
        let u_max = self.full_slip_shear_mm(normal_n, mu);
        if u_max <= 0.0 {
            return 0.0;
        }
        let x = (shear_mm.abs() / u_max).min(1.0);
        shear_mm.signum() * mu * normal_n * (1.0 - (1.0 - x).powf(1.5))
    }

    /// Radius of the stuck core, mm: `c = a (1 - |T| / mu N)^(1/3)`.
    pub fn stick_radius_mm(&self, tangential_n: f64, normal_n: f64, mu: f64) -> f64 {
        let limit = mu * normal_n;
        if limit <= 0.0 {
            return 0.0;
        }
        let x = (tangential_n.abs() / limit).min(1.0);
        self.contact_radius_mm(normal_n) * (1.0 - x).cbrt()
    }
}

/// Rate-dependent sliding friction of an elastomer:
/// `mu(v) = mu_k (1 + beta ln(1 + |v| / v_h)) + (mu_s - mu_k) exp(-|v| / v_s)`.
/// The second term is the static peak that fades within the first mm/s of sliding (so a slip
/// starts at the static level and weakens as it gets going); the first is the viscoelastic
/// (hysteresis) friction of rubber, which grows with the log of sliding speed, so a grasp
/// that has just lost its hold lets the object slide at a speed its friction can balance
/// instead of dropping it at once.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SlidingFriction {
    pub mu_static: f64,
    pub mu_kinetic: f64,
    /// `v_s`, mm/s.
    pub stribeck_mm_s: f64,
    /// `beta`: relative rise per e-fold of speed.
    pub rate_strengthening: f64,
    /// `v_h`, mm/s.
    pub strengthening_from_mm_s: f64,
}

impl SlidingFriction {
    pub fn mu(&self, speed_mm_s: f64) -> f64 {
        let v = speed_mm_s.abs();
        self.mu_kinetic
            * (1.0 + self.rate_strengthening * (v / self.strengthening_from_mm_s).ln_1p())
            + (self.mu_static - self.mu_kinetic) * (-v / self.stribeck_mm_s).exp()
    }
}

/// Friction along the object's surface is not uniform (texture, print lines, labels): a
/// seeded sum of sinusoids in the sliding distance, zero mean, standard deviation `sigma`,
/// wavelengths between `min_mm` and `max_mm`. A sliding contact's drag, and so its skin's
/// shear, follows it: the pins move for as long as the object slides, faster the faster it
/// slides.
#[derive(Debug, Clone, PartialEq)]
pub struct SurfaceTexture {
    /// (wave number rad/mm, phase, amplitude)
    waves: Vec<[f64; 3]>,
    /// `s` in a patch's `exp(-(k a)^2 / s)` ([`Self::patch_at`]).
    patch_smoothing: f64,
    /// `c` in a spot's `min(1, L / (c a))` ([`Self::local_at`]).
    local_length: f64,
}

/// The shape of a [`SurfaceTexture`] beyond its spread and wavelengths: how many waves make
/// it and the two constants of its averaging over a contact (`physics.surface_waves`,
/// `physics.texture_patch_smoothing`, `physics.texture_local_length`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TextureShape {
    pub waves: usize,
    pub patch_smoothing: f64,
    pub local_length: f64,
}

impl Default for TextureShape {
    fn default() -> Self {
        Self {
            waves: 8,
            patch_smoothing: 10.0,
            local_length: 3.8,
        }
    }
}

impl SurfaceTexture {
    pub fn new(sigma: f64, min_mm: f64, max_mm: f64, uniform: impl FnMut() -> f64) -> Self {
        Self::shaped(sigma, min_mm, max_mm, TextureShape::default(), uniform)
    }

    pub fn shaped(
        sigma: f64,
        min_mm: f64,
        max_mm: f64,
        shape: TextureShape,
        mut uniform: impl FnMut() -> f64,
    ) -> Self {
        let count = shape.waves.max(1);
        // Each sinusoid has variance a^2 / 2: a = sigma sqrt(2 / N) gives variance sigma^2.
        let amplitude = sigma * (2.0 / count as f64).sqrt();
        let waves = (0..count)
            .map(|_| {
                let wavelength = min_mm + (max_mm - min_mm) * uniform();
                [
                    std::f64::consts::TAU / wavelength,
                    std::f64::consts::TAU * uniform(),
                    amplitude,
                ]
            })
            .collect();
        Self {
            waves,
            patch_smoothing: shape.patch_smoothing,
            local_length: shape.local_length,
        }
    }

    /// Relative friction variation at `position_mm` along the surface.
    pub fn at(&self, position_mm: f64) -> f64 {
        self.waves
            .iter()
            .map(|[k, phase, a]| a * (k * position_mm + phase).sin())
            .sum()
    }

    /// Relative friction variation of a whole contact patch of radius `contact_radius_mm`
    /// centred at `position_mm`: the variation averaged under the patch's Hertz pressure.
    /// Each wave of wave number `k` survives the average by about `exp(-(k a)^2 / s)`, `s` =
    /// 10 (a Gaussian with the pressure's spread along the surface, `a^2 / 5`), so texture finer
    /// than the contact barely changes the patch's friction, while each spot of skin still
    /// feels it ([`Self::local_at`]).
    pub fn patch_at(&self, position_mm: f64, contact_radius_mm: f64) -> f64 {
        let a2 = contact_radius_mm * contact_radius_mm;
        let s = self.patch_smoothing;
        self.waves
            .iter()
            .map(|[k, phase, a]| a * (-k * k * a2 / s).exp() * (k * position_mm + phase).sin())
            .sum()
    }

    /// How much of the variation at `position_mm` shows as a local displacement of the skin
    /// over a contact of radius `contact_radius_mm`, relative to the patch's mean shear.
    ///
    /// The patch's shear answers the friction summed over the whole contact; the skin over
    /// one spot answers its own. An elastic half-space under a traction varying with
    /// wavelength `L` moves by about `L / 2 pi` times the traction over the modulus, against
    /// about `0.6 a` times the mean traction for the whole patch (Mindlin, `nu` = 0.5), so
    /// each wave shows locally at `min(1, L / (c a))`, `c` = 3.8, of its share: fine texture barely
    /// moves the skin, texture as long as the contact moves it fully. While the surface
    /// slides past at `speed_mm_s`, a wave passes at `v / L` Hz, and the viscoelastic skin
    /// follows it as far as [`SkinTimes::follows_at`] says.
    pub fn local_at(
        &self,
        position_mm: f64,
        contact_radius_mm: f64,
        speed_mm_s: f64,
        skin: &SkinTimes,
    ) -> f64 {
        if contact_radius_mm <= 0.0 {
            return 0.0;
        }
        self.waves
            .iter()
            .map(|[k, phase, a]| {
                let wavelength = std::f64::consts::TAU / k;
                let spatial = (wavelength / (self.local_length * contact_radius_mm)).min(1.0);
                let lag = skin.follows_at(speed_mm_s.abs() / wavelength);
                spatial * lag * a * (k * position_mm + phase).sin()
            })
            .sum()
    }
}

/// The skin patch of one contact while the object slides over it.
///
/// The patch as a whole carries the sliding friction `F = mu(v) (1 + h_a) N` of the surface
/// under it (`h_a` the texture averaged over the patch, [`SurfaceTexture::patch_at`]) and is sheared by `u = 3 F / (2 k_t)` (Mindlin's full-slip shear). Where
/// sliding friction is below the static peak, its elements stick and slip each on their
/// own ([`ElementStickSlip`]); out of phase with each other, their sawtooths average out of
/// the patch's force and shear.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SlidingPatch {
    /// Tangential displacement of the patch, mm (positive: object-down direction).
    pub shear_mm: f64,
    /// Where on the object's surface the patch is, mm of sliding.
    pub position_mm: f64,
}

impl SlidingPatch {
    /// Advances by one step in which the object moved `slide_mm` over the finger (positive
    /// down) at `speed_mm_s`; returns the force the patch carries over the step, N
    /// (positive: holds the object up).
    pub fn step(
        &mut self,
        skin: &SkinContact,
        friction: &SlidingFriction,
        texture: &SurfaceTexture,
        slide_mm: f64,
        speed_mm_s: f64,
        normal_n: f64,
    ) -> f64 {
        self.position_mm += slide_mm;
        let k = skin.tangential_stiffness(normal_n);
        if normal_n <= 0.0 || k <= 0.0 {
            self.shear_mm = 0.0;
            return 0.0;
        }
        // The way the object moves over the patch; at rest, the way the patch is loaded.
        let direction = if slide_mm < 0.0 || (slide_mm == 0.0 && self.shear_mm < 0.0) {
            -1.0
        } else {
            1.0
        };
        let a = skin.contact_radius_mm(normal_n);
        let surface = (1.0 + texture.patch_at(self.position_mm, a)).max(0.0);
        let force = friction.mu(speed_mm_s) * surface * normal_n;
        self.shear_mm = direction * 1.5 * force / k;
        direction * force
    }
}

/// Stick-slip of the skin's elements under a sliding contact (the spots of skin each pin
/// sits over).
///
/// Where sliding friction is below the static peak (velocity weakening, `mu(v) < mu_s`), an
/// element sticks to the surface and is carried along until its force reaches the local
/// peak `mu_s (1 + h) p`, then lets go and springs back as far below the sliding level as
/// the peak is above it, and sticks again: a sawtooth about the patch's shear, of size
/// `cycle = 3 (mu_s - mu(v)) (1 + h) N / k_t` (Mindlin's compliance at the patch's load), one
/// cycle per `cycle` mm of sliding. The elements start in step as the grasp lets go, so the
/// first millimetres of a slip move the pins together; each element's cycle follows the
/// friction `h` of the surface under it, so their phases drift apart within a few cycles
/// and the pins then move each its own way, back and forth along the slip direction, for
/// as long as the object slides slowly enough to stick: per-pin speeds stay high while the
/// pins' mean velocity falls (as real taxel skins show while an object slides). Above the
/// speed where rate strengthening brings sliding friction up to the peak, the elements
/// slide steadily and the sawtooth is gone.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ElementStickSlip {
    /// Each element's phase, cycles since the grasp let go.
    phase: Vec<f64>,
    /// The patch's position on the surface when the phases were last advanced, mm.
    slid_mm: Option<f64>,
}

impl ElementStickSlip {
    /// The grasp holds: every element is stuck at its load, back in step.
    pub fn hold(&mut self) {
        self.phase.iter_mut().for_each(|p| *p = 0.0);
        self.slid_mm = None;
    }

    /// Advances the elements to the patch's position `slid_mm` on the surface and writes
    /// each one's displacement from the patch's shear (mm, along the slip direction) into
    /// `out`. `elements` gives, per element, its weight in the contact (0 outside it) and
    /// its position on the surface relative to the patch's (mm); `cycle_mm(position)` is
    /// the size of the stick-slip cycle over that spot (0 where the skin slides steadily).
    pub fn advance(
        &mut self,
        slid_mm: f64,
        elements: impl ExactSizeIterator<Item = (f64, f64)>,
        cycle_mm: impl Fn(f64) -> f64,
        out: &mut Vec<f64>,
    ) {
        out.clear();
        self.phase.resize(elements.len(), 0.0);
        let moved = (slid_mm - self.slid_mm.unwrap_or(slid_mm)).abs();
        self.slid_mm = Some(slid_mm);
        for ((weight, offset_mm), phase) in elements.zip(&mut self.phase) {
            if weight <= 0.0 {
                out.push(0.0);
                continue;
            }
            let cycle = cycle_mm(slid_mm + offset_mm);
            if cycle <= 1e-9 {
                out.push(0.0);
                continue;
            }
            *phase += moved / cycle;
            // 0 as the element lets go of its stuck load, rising with the surface to half a
            // cycle above the sliding level, then springing back to half below.
            let saw = (*phase + 0.5).fract() - 0.5;
            out.push(weight * cycle * saw);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn skin() -> SkinContact {
        SkinContact::new(350.0, 0.5, 10.0)
    }

    #[test]
    fn hertz_indentation_and_radius_grow_sublinearly_with_force() {
        let s = skin();
        let (d1, d8) = (s.indentation_mm(1.0), s.indentation_mm(8.0));
        assert!((d8 / d1 - 4.0).abs() < 1e-9, "delta ~ N^(2/3)");
        assert!((s.normal_force_n(d1) - 1.0).abs() < 1e-9);
        let (a1, a8) = (s.contact_radius_mm(1.0), s.contact_radius_mm(8.0));
        assert!((a8 / a1 - 2.0).abs() < 1e-9, "a ~ N^(1/3)");
        assert!(s.tangential_stiffness(8.0) > s.tangential_stiffness(1.0));
    }

    #[test]
    fn incipient_slip_shrinks_the_stuck_core_as_load_grows() {
        let s = skin();
        let n = 2.0;
        let a = s.contact_radius_mm(n);
        assert!((s.stick_radius_mm(0.0, n, 0.8) - a).abs() < 1e-12);
        let radii: Vec<f64> = [0.2, 0.5, 0.8, 0.95, 1.0]
            .iter()
            .map(|f| s.stick_radius_mm(f * 0.8 * n, n, 0.8))
            .collect();
        assert!(radii.windows(2).all(|w| w[1] < w[0]), "{radii:?}");
        assert_eq!(radii[4], 0.0);
        // compliance grows towards full slip: the last 10 % of load moves the patch more than
        // the first 20 %
        let u = |f: f64| s.mindlin_shear_mm(f * 0.8 * n, n, 0.8);
        assert!(u(1.0) - u(0.9) > u(0.2) - u(0.0));
        // small loads: the stuck stiffness
        let k = s.tangential_stiffness(n);
        assert!((u(0.001) * k / (0.001 * 0.8 * n) - 1.0).abs() < 1e-3);
        // the force law is the inverse
        for f in [0.1, 0.5, 0.9] {
            assert!((s.mindlin_force_n(u(f), n, 0.8) - f * 0.8 * n).abs() < 1e-9);
        }
    }

    fn friction() -> SlidingFriction {
        SlidingFriction {
            mu_static: 0.9,
            mu_kinetic: 0.8,
            stribeck_mm_s: 2.0,
            rate_strengthening: 0.1,
            strengthening_from_mm_s: 10.0,
        }
    }

    #[test]
    fn friction_weakens_then_strengthens_with_sliding_speed() {
        let f = friction();
        assert!((f.mu(0.0) - 0.9).abs() < 1e-12);
        assert!(f.mu(5.0) < 0.9, "the static peak fades");
        assert!(f.mu(1000.0) > f.mu(100.0) && f.mu(100.0) > f.mu(10.0));
    }

    #[test]
    fn surface_texture_has_the_stated_spread_and_no_mean() {
        let mut state = 7u64;
        let t = SurfaceTexture::new(0.1, 0.5, 4.0, || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        });
        let xs: Vec<f64> = (0..200_000).map(|i| t.at(i as f64 * 0.01)).collect();
        let mean = xs.iter().sum::<f64>() / xs.len() as f64;
        let sd = (xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / xs.len() as f64).sqrt();
        assert!(mean.abs() < 0.01 && (sd - 0.1).abs() < 0.02, "{mean} {sd}");
    }

    fn lag_only() -> SkinTimes {
        SkinTimes {
            fast_s: 0.008,
            creep_s: 0.15,
            creep_fraction: 0.0,
            instant_fraction: 0.0,
        }
    }

    #[test]
    fn fine_texture_moves_the_skin_locally_less_than_coarse() {
        let fine = SurfaceTexture::new(0.2, 0.5, 0.6, || 0.5);
        let coarse = SurfaceTexture::new(0.2, 20.0, 21.0, || 0.5);
        let spread = |t: &SurfaceTexture| {
            (0..2000)
                .map(|i| t.local_at(i as f64 * 0.013, 3.0, 0.0, &lag_only()).abs())
                .fold(0.0, f64::max)
        };
        assert!(spread(&fine) < 0.2 * spread(&coarse));
        // texture longer than the contact shows in full at rest
        assert!((coarse.local_at(1.234, 3.0, 0.0, &lag_only()) - coarse.at(1.234)).abs() < 1e-12);
        assert_eq!(fine.local_at(1.0, 0.0, 0.0, &lag_only()), 0.0);
        // and less the faster it passes
        let at = |v: f64| coarse.local_at(1.234, 3.0, v, &lag_only()).abs();
        assert!(at(1000.0) < 0.5 * at(100.0) && at(100.0) < at(1.0));
    }

    #[test]
    fn texture_finer_than_the_contact_averages_out_of_the_patch() {
        let fine = SurfaceTexture::new(0.2, 1.0, 1.5, || 0.5);
        let long = SurfaceTexture::new(0.2, 40.0, 41.0, || 0.5);
        for x in [0.0, 0.3, 1.7] {
            assert!(fine.patch_at(x, 3.0).abs() < 1e-6 * (1.0 + fine.at(x).abs()));
            assert!((long.patch_at(x, 3.0) - long.at(x)).abs() < 0.05 * 0.2);
            assert_eq!(fine.patch_at(x, 0.0), fine.at(x));
        }
    }

    #[test]
    fn a_sliding_patch_carries_sliding_friction_and_its_shear() {
        let s = skin();
        let flat = SurfaceTexture::new(0.0, 1.0, 2.0, || 0.5);
        let mut p = SlidingPatch::default();
        let f = p.step(&s, &friction(), &flat, 0.02, 20.0, 2.0);
        assert!((f - friction().mu(20.0) * 2.0).abs() < 1e-12);
        assert!((p.shear_mm - 1.5 * f / s.tangential_stiffness(2.0)).abs() < 1e-12);
        assert!((p.position_mm - 0.02).abs() < 1e-12);
    }

    #[test]
    fn elements_start_in_step_then_drift_apart_while_the_mean_stays_small() {
        let t = SurfaceTexture::new(0.2, 0.5, 4.0, {
            let mut k = 0.0;
            move || {
                k += 0.37;
                k % 1.0
            }
        });
        let mut e = ElementStickSlip::default();
        let offsets: Vec<f64> = (0..10).map(|j| j as f64 * 0.7 - 3.0).collect();
        let elements = || offsets.iter().map(|&o| (1.0, o));
        let cycle = |x: f64| 0.4 * (1.0 + t.at(x)).max(0.0);
        let mut out = Vec::new();
        // 0.05 mm in: every element carried forward together
        e.advance(0.0, elements(), cycle, &mut out);
        assert!(out.iter().all(|d| *d == 0.0));
        e.advance(0.05, elements(), cycle, &mut out);
        assert!(out.iter().all(|d| *d > 0.03 && *d < 0.07), "{out:?}");
        // 20 mm on, in 1 mm frames: each element keeps moving, the mean much less
        let (mut per_element, mut of_mean, mut last) = (0.0, 0.0, out.clone());
        for k in 1..=20 {
            e.advance(0.05 + k as f64, elements(), cycle, &mut out);
            let d: Vec<f64> = out.iter().zip(&last).map(|(a, b)| a - b).collect();
            per_element += d.iter().map(|x| x.abs()).sum::<f64>() / 10.0;
            of_mean += (d.iter().sum::<f64>() / 10.0).abs();
            last = out.clone();
        }
        assert!(per_element / 20.0 > 0.1, "{per_element}");
        assert!(of_mean < 0.5 * per_element, "{of_mean} vs {per_element}");
        // elements outside the contact or sliding steadily do not move; a hold re-syncs
        e.advance(30.0, offsets.iter().map(|&o| (0.0, o)), cycle, &mut out);
        assert!(out.iter().all(|d| *d == 0.0));
        e.advance(31.0, elements(), |_| 0.0, &mut out);
        assert!(out.iter().all(|d| *d == 0.0));
        e.hold();
        e.advance(40.0, elements(), cycle, &mut out);
        assert!(out.iter().all(|d| *d == 0.0));
    }
}
