//! The TacTip model: where the 30 pins sit in the camera image, and how they move with
//! indentation, shear and sliding. Pure functions over plain state; the world feeds them.
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

/// Fixed properties of one manufactured sensor in one grasp, with each pin's response to
/// indentation and shear worked out once: the contact centre does not move during a trial,
/// and precomputing the profiles removed all `exp` calls from frame generation.
#[derive(Debug, Clone, PartialEq)]
pub struct SensorOptics {
    pub rest_px: Vec<[f64; 2]>,
    /// Where the object touches the dome, in the image.
    pub contact_centre_px: [f64; 2],
    /// Unit vector in the image along which "object moves down relative to the finger".
    pub slip_direction: [f64; 2],
    /// Displacement of each pin per mm of indentation, px/mm.
    radial_px_per_mm: Vec<[f64; 2]>,
    /// Each pin's share of the contact region's shear, 0..1.
    shear_weight: Vec<f64>,
}

impl SensorOptics {
    /// Pin `j` at rest `P_j`, distance `r` from the contact centre `c`, moves by
    /// `G_r * indentation * g(r/rho) * (P_j - c)/r + shear * exp(-r^2 / (2 (1.3 rho)^2)) * u`
    /// with `g(x) = x * exp((1 - x^2)/2)` (peak 1 at `r = rho`, zero at the centre).
    pub fn new(
        rest_px: Vec<[f64; 2]>,
        contact_centre_px: [f64; 2],
        slip_direction: [f64; 2],
        radial_gain_px_per_mm: f64,
        contact_radius_px: f64,
    ) -> Self {
        let rho = contact_radius_px;
        let shear_rho2 = 2.0 * (1.3 * rho) * (1.3 * rho);
        let [cx, cy] = contact_centre_px;
        let mut radial_px_per_mm = Vec::with_capacity(rest_px.len());
        let mut shear_weight = Vec::with_capacity(rest_px.len());
        for &[px, py] in &rest_px {
            let (dx, dy) = (px - cx, py - cy);
            let r2 = dx * dx + dy * dy;
            let r = r2.sqrt();
            if r > 1e-9 {
                let xr = r / rho;
                let g = radial_gain_px_per_mm * xr * (0.5 * (1.0 - xr * xr)).exp();
                radial_px_per_mm.push([g * dx / r, g * dy / r]);
            } else {
                radial_px_per_mm.push([0.0, 0.0]);
            }
            shear_weight.push((-r2 / shear_rho2).exp());
        }
        Self {
            rest_px,
            contact_centre_px,
            slip_direction,
            radial_px_per_mm,
            shear_weight,
        }
    }
}

/// Noise-free pin positions for a skin indented by `indentation_mm` and sheared by
/// `shear_px` along the slip direction (see [`SensorOptics::new`] for the equation).
pub fn pin_positions(
    optics: &SensorOptics,
    indentation_mm: f64,
    shear_px: f64,
    out: &mut Vec<[f64; 2]>,
) {
    out.clear();
    let [ux, uy] = optics.slip_direction;
    let (sx, sy) = (shear_px * ux, shear_px * uy);
    for ((&[px, py], &[rx, ry]), &w) in optics
        .rest_px
        .iter()
        .zip(&optics.radial_px_per_mm)
        .zip(&optics.shear_weight)
    {
        out.push([
            px + indentation_mm * rx + w * sx,
            py + indentation_mm * ry + w * sy,
        ]);
    }
}

/// First-order (viscoelastic) response of the skin's shear to its target, one step.
pub fn relax_towards(state: f64, target: f64, step_s: f64, time_constant_s: f64) -> f64 {
    state + (target - state) * (1.0 - (-step_s / time_constant_s).exp())
}

/// Shear the skin is driven towards: elastic shear from the tangential load plus drag by an
/// object sliding over it, which builds up over the first `drag_length` mm of sliding and
/// then stays (the skin is stretched as far as the sliding contact takes it).
pub fn shear_target_px(
    tangential_n: f64,
    slid_mm: f64,
    shear_gain: f64,
    drag_px: f64,
    drag_length_mm: f64,
) -> f64 {
    shear_gain * tangential_n + drag_px * (slid_mm / drag_length_mm).tanh()
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
        pin_positions(&o, 0.0, 0.0, &mut out);
        assert_eq!(out, o.rest_px);
    }

    #[test]
    fn indentation_pushes_pins_radially_outward() {
        let o = optics();
        let mut out = Vec::new();
        pin_positions(&o, 1.0, 0.0, &mut out);
        for (p, r) in out.iter().zip(&o.rest_px).skip(1) {
            let (rx, ry) = (r[0] - 170.0, r[1] - 140.0);
            let (mx, my) = (p[0] - r[0], p[1] - r[1]);
            let cross = rx * my - ry * mx;
            let dot = rx * mx + ry * my;
            assert!(dot > 0.0 && cross.abs() < 1e-6 * (1.0 + dot.abs()));
        }
        // the centre pin does not move
        assert_eq!(out[0], o.rest_px[0]);
        // pins at the contact radius move the most: 5 px per mm
        let most = out
            .iter()
            .zip(&o.rest_px)
            .map(|(p, r)| (p[0] - r[0]).hypot(p[1] - r[1]))
            .fold(0.0, f64::max);
        assert!(most > 4.0 && most <= 5.0 + 1e-9, "{most}");
    }

    #[test]
    fn shear_moves_contact_pins_along_the_slip_direction() {
        let o = optics();
        let mut out = Vec::new();
        pin_positions(&o, 0.0, 2.0, &mut out);
        assert!((out[0][1] - o.rest_px[0][1] - 2.0).abs() < 1e-12);
        assert!(out
            .iter()
            .zip(&o.rest_px)
            .all(|(p, r)| p[0] == r[0] && p[1] >= r[1]));
    }

    #[test]
    fn skin_relaxes_exponentially() {
        let s = relax_towards(0.0, 1.0, 0.02, 0.02);
        assert!((s - (1.0 - (-1f64).exp())).abs() < 1e-12);
        assert!(shear_target_px(0.0, 1e6, 0.5, 3.0, 1.0) <= 3.0);
        assert!((shear_target_px(2.0, 0.0, 0.5, 3.0, 1.0) - 1.0).abs() < 1e-12);
    }
}
