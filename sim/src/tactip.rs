//! The TacTip model: where the 30 pins sit in the camera image, and how they move with the
//! skin's indentation, contact size, shear and roll. Pure functions over plain state; the
//! world feeds them.
//! Equations and parameters: `docs/simulator.md`.

/// Rest positions of `pins` pins on a hemispherical dome seen by a camera above it: a centre
/// pin, then rings of up to 6k pins (k = 1, 2, ...), evenly spaced in polar angle on the dome
/// up to 75 degrees and projected orthographically into the image.
pub fn dome_layout(pins: usize, centre_px: [f64; 2], dome_radius_px: f64) -> Vec<[f64; 2]> {
    let mut counts = Vec::new();
    let mut left = pins.saturating_sub(1);
    let mut ring = 1;
    while left > 0 {
        let n = left.min(6 * ring);
        counts.push(n);
        left -= n;
        ring += 1;
    }
    let mut out = Vec::with_capacity(pins);
    if pins > 0 {
        out.push(centre_px);
    }
    let rings = counts.len().max(1) as f64;
    for (k, &n) in counts.iter().enumerate() {
        let polar = (k as f64 + 1.0) / rings * 75f64.to_radians();
        let r = dome_radius_px * polar.sin();
        // Alternate rings are rotated half a pitch, as the printed pin pattern is.
        let offset = if k % 2 == 1 { 0.5 } else { 0.0 };
        for i in 0..n {
            let a = (i as f64 + offset) / n as f64 * std::f64::consts::TAU;
            out.push([centre_px[0] + r * a.cos(), centre_px[1] + r * a.sin()]);
        }
    }
    out
}

/// Fixed properties of one manufactured sensor in one grasp: where its pins are relative to
/// the contact (the contact centre does not move during a trial, so the offsets are worked
/// out once) and its gains.
#[derive(Debug, Clone, PartialEq)]
pub struct SensorOptics {
    pub rest_px: Vec<[f64; 2]>,
    /// Where the object touches the dome, in the image.
    pub contact_centre_px: [f64; 2],
    /// Unit vector in the image along which "object moves down relative to the finger".
    pub slip_direction: [f64; 2],
    /// Unit vector in the image along which the fingertip rolls as the finger curls.
    pub roll_direction: [f64; 2],
    /// Peak radial pin displacement per mm of indentation, px/mm.
    radial_gain_px_per_mm: f64,
    /// How far the gel spreads an indentation beyond the contact patch, px.
    spread_px: f64,
    /// `f` in the shear's spread `f rho_c` around the carried region ([`pin_positions`]).
    shear_spread_factor: f64,
    /// Each pin's offset from the contact centre and its distance, px.
    offsets: Vec<[f64; 3]>,
    /// How much of a skin element's displacement under pin `k` moves pin `j` (row `j`,
    /// column `k`): `exp(-d_jk^2 / 2 rho_0^2)`, the gel's spread.
    element_kernel: Vec<f64>,
}

/// The skin's state that the pins show, for one frame.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SkinState {
    pub indentation_mm: f64,
    /// Radius of the contact patch in the image, px.
    pub contact_radius_px: f64,
    /// Radius of the region that moves with the object, px: the stuck core while the patch
    /// holds (Cattaneo-Mindlin), the whole patch while it slides.
    pub carried_radius_px: f64,
    /// Tangential displacement of the patch along the slip direction, px.
    pub shear_px: f64,
    /// Tangential displacement along the roll direction, px.
    pub roll_px: f64,
}

impl SensorOptics {
    pub fn new(
        rest_px: Vec<[f64; 2]>,
        contact_centre_px: [f64; 2],
        slip_direction: [f64; 2],
        radial_gain_px_per_mm: f64,
        spread_px: f64,
    ) -> Self {
        let [cx, cy] = contact_centre_px;
        let offsets = rest_px
            .iter()
            .map(|&[px, py]| {
                let (dx, dy) = (px - cx, py - cy);
                [dx, dy, dx.hypot(dy)]
            })
            .collect();
        let two_s2 = 2.0 * spread_px * spread_px;
        let element_kernel = rest_px
            .iter()
            .flat_map(|&[xj, yj]| {
                rest_px.iter().map(move |&[xk, yk]| {
                    let d2 = (xj - xk).powi(2) + (yj - yk).powi(2);
                    if two_s2 > 0.0 {
                        (-d2 / two_s2).exp()
                    } else {
                        f64::from(u8::from(d2 == 0.0))
                    }
                })
            })
            .collect();
        Self {
            rest_px,
            contact_centre_px,
            slip_direction,
            roll_direction: [-slip_direction[1], slip_direction[0]],
            radial_gain_px_per_mm,
            spread_px,
            shear_spread_factor: 1.3,
            offsets,
            element_kernel,
        }
    }

    /// The same optics with the shear's spread factor `f` (`tactip.shear_spread_factor`).
    pub fn with_shear_spread(mut self, factor: f64) -> Self {
        self.shear_spread_factor = factor;
        self
    }

    /// What the pins show of the skin elements' own displacements `elements` (one per pin,
    /// the spot of skin under it): each element's displacement reaches the pins around it
    /// through the elastic skin and gel as it spreads an indentation, by
    /// `exp(-d^2 / 2 rho_0^2)` at distance `d`, so a spot that sticks and lets go also
    /// moves its neighbours, less the further they are. Written into `out`.
    pub fn spread_elements(&self, elements: &[f64], out: &mut Vec<f64>) {
        let n = self.rest_px.len();
        out.clear();
        out.resize(n, 0.0);
        for (k, &e) in elements.iter().enumerate().take(n) {
            if e == 0.0 {
                continue;
            }
            for (j, o) in out.iter_mut().enumerate() {
                *o += self.element_kernel[j * n + k] * e;
            }
        }
    }

    /// The skin element under each pin: its weight in a contact of radius
    /// `contact_radius_px` (`exp(-r^2 / 2 a^2)`, 0 well outside it) and its offset from the
    /// contact centre along the slip direction, in px divided by `px_per_mm` (so mm with the
    /// image's scale, px with 1).
    pub fn contact_elements(
        &self,
        contact_radius_px: f64,
        px_per_mm: f64,
    ) -> impl ExactSizeIterator<Item = (f64, f64)> + '_ {
        let [ux, uy] = self.slip_direction;
        let inv_two_a2 = 1.0 / (2.0 * contact_radius_px * contact_radius_px).max(1e-12);
        self.offsets.iter().map(move |&[dx, dy, r]| {
            let w = (-r * r * inv_two_a2).exp();
            let w = if w < 1e-3 || contact_radius_px <= 0.0 {
                0.0
            } else {
                w
            };
            (w, (dx * ux + dy * uy) / px_per_mm)
        })
    }
}

/// Noise-free pin positions for the skin state `skin`.
///
/// Pin `j` at offset `d_j` (distance `r`) from the contact centre moves by
/// `G delta g(r / rho) d_j / r + exp(-r^2 / (2 (f rho_c)^2)) (s u + l v)`, `f` = 1.3
/// (`tactip.shear_spread_factor`), where
/// `rho = sqrt(rho_0^2 + a^2)` grows with the contact radius `a`, `g(x) = x exp((1 - x^2) / 2)`
/// (0 at the centre, peak 1 at `r = rho`), `s` and `l` the patch's shear and roll along the
/// slip and roll directions `u` and `v`, and `rho_c = sqrt(rho_0^2 + c^2)` with `c` the
/// radius carried with the object: partial slip moves a narrow field, gross slip a wide one.
pub fn pin_positions(optics: &SensorOptics, skin: &SkinState, out: &mut Vec<[f64; 2]>) {
    out.clear();
    let rho = optics.spread_px.hypot(skin.contact_radius_px);
    let radial = optics.radial_gain_px_per_mm * skin.indentation_mm;
    let inv_rho = 1.0 / rho;
    let carried = optics.spread_px.hypot(skin.carried_radius_px);
    let inv_two_sigma2 = 1.0 / (2.0 * (optics.shear_spread_factor * carried).powi(2));
    let [ux, uy] = optics.slip_direction;
    let [vx, vy] = optics.roll_direction;
    let (tx, ty) = (
        skin.shear_px * ux + skin.roll_px * vx,
        skin.shear_px * uy + skin.roll_px * vy,
    );
    for (&[px, py], &[dx, dy, r]) in optics.rest_px.iter().zip(&optics.offsets) {
        let w = (-r * r * inv_two_sigma2).exp();
        let (mut x, mut y) = (px + w * tx, py + w * ty);
        if r > 1e-9 && radial != 0.0 {
            let xr = r * inv_rho;
            let g = radial * xr * (0.5 * (1.0 - xr * xr)).exp() / r;
            x += g * dx;
            y += g * dy;
        }
        out.push([x, y]);
    }
}

/// The skin's local deviations from the patch's shear, per unit of that shear: pin `j`
/// moves along the slip direction by `shear w_j local(xi_j)`, where `xi_j` is its offset
/// from the contact centre along the slip direction (px) and `w_j = exp(-r_j^2 / (2 a^2))`
/// fades it outside the contact of radius `a` (px). Over a sliding contact this is the
/// spot-to-spot variation of friction the object's surface drags each part of the skin
/// with: pins in the contact move each their own way, so much of it cancels in the pins'
/// mean. Worked out into `out` (one factor a pin) so that a frame whose contact has not
/// moved reuses them.
pub fn local_shear_factors(
    optics: &SensorOptics,
    contact_radius_px: f64,
    local: impl Fn(f64) -> f64,
    out: &mut Vec<f64>,
) {
    out.clear();
    // pins far outside the contact do not move (and cost no texture evaluation)
    out.extend(
        optics
            .contact_elements(contact_radius_px, 1.0)
            .map(|(w, xi_px)| if w == 0.0 { 0.0 } else { w * local(xi_px) }),
    );
}

/// Moves pins `out` (as [`pin_positions`] left them) by `shear_px` times their
/// [`local_shear_factors`], along the slip direction.
pub fn add_local_shear(
    optics: &SensorOptics,
    factors: &[f64],
    shear_px: f64,
    out: &mut [[f64; 2]],
) {
    let [ux, uy] = optics.slip_direction;
    for (pin, f) in out.iter_mut().zip(factors) {
        let shift = shear_px * f;
        pin[0] += shift * ux;
        pin[1] += shift * uy;
    }
}

/// First-order (viscoelastic) response of the skin to its target, one step.
pub fn relax_towards(state: f64, target: f64, step_s: f64, time_constant_s: f64) -> f64 {
    state + (target - state) * (1.0 - (-step_s / time_constant_s).exp())
}

/// One displacement of the skin that the pins show, with the elastomer's two time scales:
/// a fraction `1 - g` follows its target within milliseconds and a fraction `g` creeps
/// towards it over a slower time (a two-term Prony series of the gel-filled skin). A change
/// of load therefore keeps the pins moving, ever more slowly, for some frames after it.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CreepingDisplacement {
    target: f64,
    fast: f64,
    slow: f64,
}

/// The two time scales of [`CreepingDisplacement`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SkinTimes {
    pub fast_s: f64,
    pub creep_s: f64,
    /// Share `g` of the displacement that creeps.
    pub creep_fraction: f64,
    /// Share `i` that follows at once (the instantaneous compliance).
    pub instant_fraction: f64,
}

impl SkinTimes {
    /// How much of a displacement varying at `hz` the skin shows: the magnitude of
    /// `i + (1 - i - g) / (1 + j w tau_f) + g / (1 + j w tau_c)`.
    pub fn follows_at(&self, hz: f64) -> f64 {
        let w = std::f64::consts::TAU * hz;
        let (i, g) = (self.instant_fraction, self.creep_fraction);
        let term = |share: f64, tau: f64| {
            let x = w * tau;
            let d = 1.0 + x * x;
            (share / d, -share * x / d)
        };
        let (fr, fi) = term(1.0 - i - g, self.fast_s);
        let (cr, ci) = term(g, self.creep_s);
        (i + fr + cr).hypot(fi + ci)
    }
}

impl SkinTimes {
    /// How far a spot of skin springs back within `period_s` after the grip on it lets go,
    /// as a share of the strain it held: each share of the response relaxes as
    /// `1 - exp(-T / tau)` (the instantaneous share at once). This bounds a stick-slip
    /// sawtooth: the stick phase is imposed by the surface (the spot moves with the
    /// object), only the release is driven by the skin's own elasticity.
    pub fn releases_within(&self, period_s: f64) -> f64 {
        let (i, g) = (self.instant_fraction, self.creep_fraction);
        let share = |tau: f64| 1.0 - (-period_s / tau.max(1e-12)).exp();
        i + (1.0 - i - g) * share(self.fast_s) + g * share(self.creep_s)
    }
}

impl CreepingDisplacement {
    pub fn step(&mut self, target: f64, step_s: f64, times: &SkinTimes) {
        self.target = target;
        self.fast = relax_towards(self.fast, target, step_s, times.fast_s);
        self.slow = relax_towards(self.slow, target, step_s, times.creep_s);
    }

    /// What the pins show.
    pub fn shown(&self, times: &SkinTimes) -> f64 {
        let (i, g) = (times.instant_fraction, times.creep_fraction);
        i * self.target + (1.0 - i - g) * self.fast + g * self.slow
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn optics() -> SensorOptics {
        SensorOptics::new(
            dome_layout(30, [170.0, 140.0], 120.0),
            [170.0, 140.0],
            [0.0, 1.0],
            5.0,
            40.0,
        )
    }

    fn state(indentation_mm: f64, shear_px: f64) -> SkinState {
        SkinState {
            indentation_mm,
            contact_radius_px: 0.0,
            carried_radius_px: 0.0,
            shear_px,
            roll_px: 0.0,
        }
    }

    #[test]
    fn layout_has_centre_pin_and_rings_inside_the_dome() {
        let pins = dome_layout(30, [170.0, 140.0], 120.0);
        assert_eq!(pins.len(), 30);
        assert_eq!(pins[0], [170.0, 140.0]);
        for p in &pins {
            let r = ((p[0] - 170.0).powi(2) + (p[1] - 140.0).powi(2)).sqrt();
            assert!(r <= 120.0 + 1e-9);
        }
        assert_eq!(dome_layout(7, [0.0, 0.0], 1.0).len(), 7);
    }

    #[test]
    fn no_load_leaves_pins_at_rest() {
        let o = optics();
        let mut out = Vec::new();
        pin_positions(&o, &state(0.0, 0.0), &mut out);
        assert_eq!(out, o.rest_px);
    }

    #[test]
    fn indentation_pushes_pins_radially_outward() {
        let o = optics();
        let mut out = Vec::new();
        pin_positions(&o, &state(1.0, 0.0), &mut out);
        for (p, r) in out.iter().zip(&o.rest_px).skip(1) {
            let (rx, ry) = (r[0] - 170.0, r[1] - 140.0);
            let (mx, my) = (p[0] - r[0], p[1] - r[1]);
            let cross = rx * my - ry * mx;
            let dot = rx * mx + ry * my;
            assert!(dot > 0.0 && cross.abs() < 1e-6 * (1.0 + dot.abs()));
        }
        // the centre pin does not move
        assert_eq!(out[0], o.rest_px[0]);
        // pins near the spread radius move the most: 5 px per mm
        let most = out
            .iter()
            .zip(&o.rest_px)
            .map(|(p, r)| (p[0] - r[0]).hypot(p[1] - r[1]))
            .fold(0.0, f64::max);
        assert!(most > 4.0 && most <= 5.0 + 1e-9, "{most}");
    }

    #[test]
    fn a_larger_contact_moves_more_pins() {
        let o = optics();
        let moved = |a_px: f64| {
            let mut out = Vec::new();
            let s = SkinState {
                contact_radius_px: a_px,
                ..state(1.0, 0.0)
            };
            pin_positions(&o, &s, &mut out);
            out.iter()
                .zip(&o.rest_px)
                .filter(|(p, r)| (p[0] - r[0]).hypot(p[1] - r[1]) > 1.0)
                .count()
        };
        assert!(moved(60.0) > moved(0.0));
    }

    #[test]
    fn shear_moves_contact_pins_along_the_slip_direction() {
        let o = optics();
        let mut out = Vec::new();
        pin_positions(&o, &state(0.0, 2.0), &mut out);
        assert!((out[0][1] - o.rest_px[0][1] - 2.0).abs() < 1e-12);
        assert!(out
            .iter()
            .zip(&o.rest_px)
            .all(|(p, r)| p[0] == r[0] && p[1] >= r[1]));
    }

    #[test]
    fn local_shear_moves_only_pins_in_the_contact_and_along_the_slip_direction() {
        let o = optics();
        let mut pins = o.rest_px.clone();
        let mut factors = Vec::new();
        local_shear_factors(&o, 20.0, |xi| 1.0 + 0.01 * xi, &mut factors);
        add_local_shear(&o, &factors, 1.0, &mut pins);
        let [ux, uy] = o.slip_direction;
        let mut moved = 0;
        for (p, r) in pins.iter().zip(&o.rest_px) {
            let (dx, dy) = (p[0] - r[0], p[1] - r[1]);
            // along the slip direction only
            assert!((dx * uy - dy * ux).abs() < 1e-9);
            let d = dx.hypot(dy);
            let from_centre = (r[0] - o.contact_centre_px[0]).hypot(r[1] - o.contact_centre_px[1]);
            if from_centre > 80.0 {
                assert_eq!(d, 0.0);
            } else if d > 0.1 {
                moved += 1;
            }
        }
        assert!(moved >= 1);
        let before = pins.clone();
        local_shear_factors(&o, 0.0, |_| 1.0, &mut factors);
        add_local_shear(&o, &factors, 1.0, &mut pins);
        assert_eq!(pins, before);
    }

    #[test]
    fn a_step_of_load_shows_at_once_in_part_then_creeps_the_rest_of_the_way() {
        let times = SkinTimes {
            fast_s: 0.008,
            creep_s: 0.15,
            creep_fraction: 0.3,
            instant_fraction: 0.0,
        };
        let mut d = CreepingDisplacement::default();
        let mut shown = Vec::new();
        for _ in 0..1000 {
            d.step(1.0, 0.001, &times);
            shown.push(d.shown(&times));
        }
        // after 50 ms the fast part is there and the creep is on its way
        assert!((0.7..0.85).contains(&shown[49]), "{}", shown[49]);
        // it keeps moving for frames afterwards, ever more slowly
        let frame = |k: usize| shown[(k + 1) * 17] - shown[k * 17];
        assert!(frame(3) > 0.01 && frame(8) > 0.005 && frame(8) < frame(3));
        assert!((shown[999] - 1.0).abs() < 0.01);
    }

    #[test]
    fn a_stick_slip_cycle_shows_as_far_as_the_skin_springs_back_within_it() {
        let times = SkinTimes {
            fast_s: 0.008,
            creep_s: 0.15,
            creep_fraction: 0.3,
            instant_fraction: 0.3,
        };
        // a slow cycle springs back all the way; a 100 Hz one by its instantaneous share and
        // most of its fast share, far more than a force that oscillates at 100 Hz moves it
        assert!((times.releases_within(10.0) - 1.0).abs() < 1e-6);
        let fast = times.releases_within(0.01);
        assert!((0.55..0.65).contains(&fast), "{fast}");
        assert!(fast > times.follows_at(100.0) + 0.15);
        // never less than the instantaneous share, and more the longer the cycle
        assert!(times.releases_within(1e-6) >= 0.3);
        assert!(times.releases_within(0.02) > fast);
    }

    #[test]
    fn an_element_moves_its_own_pin_fully_and_its_neighbours_less_with_distance() {
        let o = optics();
        let mut elements = vec![0.0; 30];
        elements[0] = 1.0; // the centre pin's spot
        let mut out = Vec::new();
        o.spread_elements(&elements, &mut out);
        assert!((out[0] - 1.0).abs() < 1e-12);
        let by_distance = |j: usize| {
            let [x0, y0] = o.rest_px[0];
            let [x, y] = o.rest_px[j];
            (x - x0).hypot(y - y0)
        };
        let (inner, outer) = (1, 7); // first pins of the first and second rings
        assert!(by_distance(inner) < by_distance(outer));
        assert!(out[inner] > out[outer] && out[outer] > 0.0 && out[inner] < 1.0);
        // no spot displaced, no pin moved
        elements[0] = 0.0;
        o.spread_elements(&elements, &mut out);
        assert!(out.iter().all(|&v| v == 0.0));
    }

    #[test]
    fn skin_relaxes_exponentially() {
        let s = relax_towards(0.0, 1.0, 0.02, 0.02);
        assert!((s - (1.0 - (-1f64).exp())).abs() < 1e-12);
    }
}
