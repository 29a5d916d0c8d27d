//! Parameters of the simulated rig. Every field has a default; the defaults are the values
//! documented in `docs/simulator.md`. Unknown fields are rejected.

use serde::{Deserialize, Serialize};

/// Everything that defines one simulated trial.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SimConfig {
    pub seed: u64,
    pub rig: RigSetup,
    pub physics: PhysicsParams,
    pub servo: ServoParams,
    pub arm: ArmParams,
    pub tactip: TactipParams,
    pub faults: FaultRates,
    pub marker: MarkerParams,
    pub operator: OperatorParams,
}

impl Default for SimConfig {
    fn default() -> Self {
        Self {
            seed: 0,
            rig: RigSetup::Hand(HandSetup::default()),
            physics: PhysicsParams::default(),
            servo: ServoParams::default(),
            arm: ArmParams::default(),
            tactip: TactipParams::default(),
            faults: FaultRates::default(),
            marker: MarkerParams::default(),
            operator: OperatorParams::default(),
        }
    }
}

/// A field of a [`SimConfig`] outside the range the simulator can stand for.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("`{field}` = {value}: expected {expected}")]
pub struct ConfigProblem {
    pub field: String,
    pub value: String,
    pub expected: String,
}

/// Inclusive lower bound, or exclusive when `open`.
#[derive(Clone, Copy)]
struct Low(f64, bool);

impl SimConfig {
    /// Every numeric field inside the range of a physical rig, so that a world built from
    /// it neither divides by zero nor overflows (a configuration may come from a file or
    /// over `sim serve`'s control port). The ranges are generous: they catch mistakes and
    /// garbage, not unusual rigs.
    pub fn check(&self) -> Result<(), ConfigProblem> {
        let positive = Low(0.0, true);
        let zero = Low(0.0, false);
        let mut fields: Vec<(&str, f64, Low, f64)> = Vec::with_capacity(64);
        let p = &self.physics;
        fields.extend([
            ("physics.step_s", p.step_s, positive, 0.005),
            ("physics.gravity_m_s2", p.gravity_m_s2, positive, 100.0),
            (
                "physics.finger_travel_mm",
                p.finger_travel_mm,
                positive,
                1e3,
            ),
            (
                "physics.finger_stiffness_n_per_mm",
                p.finger_stiffness_n_per_mm,
                positive,
                1e5,
            ),
            (
                "physics.skin_modulus_kpa",
                p.skin_modulus_kpa,
                positive,
                1e7,
            ),
            ("physics.skin_poisson", p.skin_poisson, zero, 0.5),
            ("physics.dome_radius_mm", p.dome_radius_mm, positive, 1e3),
            ("physics.stall_force_n", p.stall_force_n, positive, 1e4),
            (
                "physics.finger_half_spacing_mm",
                p.finger_half_spacing_mm,
                positive,
                1e3,
            ),
            (
                "physics.stribeck_speed_mm_s",
                p.stribeck_speed_mm_s,
                positive,
                1e5,
            ),
            (
                "physics.rate_strengthening",
                p.rate_strengthening,
                zero,
                10.0,
            ),
            (
                "physics.strengthening_from_mm_s",
                p.strengthening_from_mm_s,
                positive,
                1e5,
            ),
            (
                "physics.surface_friction_sd",
                p.surface_friction_sd,
                zero,
                1.0,
            ),
            (
                "physics.surface_wavelength_mm[0]",
                p.surface_wavelength_mm[0],
                positive,
                1e3,
            ),
            (
                "physics.surface_wavelength_mm[1]",
                p.surface_wavelength_mm[1],
                Low(p.surface_wavelength_mm[0], false),
                1e3,
            ),
            (
                "physics.surface_waves",
                p.surface_waves,
                Low(1.0, false),
                64.0,
            ),
            (
                "physics.texture_patch_smoothing",
                p.texture_patch_smoothing,
                positive,
                1e3,
            ),
            (
                "physics.texture_local_length",
                p.texture_local_length,
                positive,
                1e3,
            ),
            ("physics.finger_roll_ratio", p.finger_roll_ratio, zero, 10.0),
            ("physics.load_transfer_s", p.load_transfer_s, zero, 10.0),
            ("physics.drop_limit_mm", p.drop_limit_mm, positive, 1e4),
            ("physics.floor_mm", p.floor_mm, Low(-1e4, false), 1e4),
        ]);
        let s = &self.servo;
        fields.extend([
            ("servo.latency_s", s.latency_s, zero, 1.0),
            ("servo.max_speed_per_s", s.max_speed_per_s, positive, 100.0),
            (
                "servo.reference_speed_per_s",
                s.reference_speed_per_s,
                positive,
                100.0,
            ),
            ("servo.position_time_s", s.position_time_s, positive, 10.0),
            ("servo.backlash", s.backlash, zero, 1.0),
            (
                "servo.encoder_counts_per_range",
                s.encoder_counts_per_range,
                zero,
                1e6,
            ),
            (
                "servo.initial_torque_limit",
                s.initial_torque_limit,
                zero,
                1.0,
            ),
        ]);
        let a = &self.arm;
        fields.extend([
            ("arm.max_speed_mm_s", a.max_speed_mm_s, positive, 1e4),
            (
                "arm.acceleration_mm_s2",
                a.acceleration_mm_s2,
                positive,
                1e6,
            ),
            ("arm.latency_s", a.latency_s, zero, 1.0),
            ("arm.start_mm[0]", a.start_mm[0], Low(-1e4, false), 1e4),
            ("arm.start_mm[1]", a.start_mm[1], Low(-1e4, false), 1e4),
            ("arm.start_mm[2]", a.start_mm[2], Low(-1e4, false), 1e4),
            (
                "arm.hand_marker_offset_mm",
                a.hand_marker_offset_mm,
                Low(-1e4, false),
                1e4,
            ),
        ]);
        let t = &self.tactip;
        fields.extend([
            ("tactip.pins", t.pins as f64, Low(1.0, false), 1000.0),
            ("tactip.image_px[0]", t.image_px[0], positive, 1e5),
            ("tactip.image_px[1]", t.image_px[1], positive, 1e5),
            ("tactip.dome_radius_px", t.dome_radius_px, positive, 1e5),
            ("tactip.frame_rate_hz", t.frame_rate_hz, positive, 1e4),
            ("tactip.frame_jitter_s", t.frame_jitter_s, zero, 1.0),
            ("tactip.clock_error_ppm", t.clock_error_ppm, zero, 1e5),
            ("tactip.noise_px", t.noise_px, zero, 1e3),
            (
                "tactip.radial_gain_px_per_mm",
                t.radial_gain_px_per_mm,
                zero,
                1e4,
            ),
            ("tactip.spread_radius_px", t.spread_radius_px, positive, 1e5),
            ("tactip.skin_time_s", t.skin_time_s, positive, 10.0),
            ("tactip.creep_fraction", t.creep_fraction, zero, 1.0),
            ("tactip.creep_time_s", t.creep_time_s, positive, 100.0),
            (
                "tactip.instant_fraction",
                t.instant_fraction,
                zero,
                1.0 - t.creep_fraction,
            ),
            ("tactip.contact_offset_px", t.contact_offset_px, zero, 1e5),
            ("tactip.unit_variation", t.unit_variation, zero, 0.9),
            ("tactip.mount_scatter_deg", t.mount_scatter_deg, zero, 90.0),
            (
                "tactip.shear_spread_factor",
                t.shear_spread_factor,
                positive,
                100.0,
            ),
        ]);
        let o = &self.operator;
        fields.extend([
            (
                "operator.release_grip_safety[0]",
                o.release_grip_safety[0],
                Low(1.0, false),
                10.0,
            ),
            (
                "operator.release_grip_safety[1]",
                o.release_grip_safety[1],
                Low(o.release_grip_safety[0], false),
                10.0,
            ),
            (
                "operator.pour_grip_safety",
                o.pour_grip_safety,
                Low(1.0, false),
                10.0,
            ),
            ("operator.lift_start_gap", o.lift_start_gap, zero, 1.0),
        ]);
        let f = &self.faults;
        fields.extend([
            ("faults.pin_misdetect", f.pin_misdetect, zero, 1.0),
            ("faults.dropped_frame", f.dropped_frame, zero, 1.0),
            ("faults.stale_frame", f.stale_frame, zero, 1.0),
            ("marker.rate_hz", self.marker.rate_hz, positive, 1e4),
            ("marker.noise_mm", self.marker.noise_mm, zero, 1e3),
        ]);
        match &self.rig {
            RigSetup::Hand(h) => fields.extend([
                ("rig.extra_mass_g", h.extra_mass_g, zero, 1e5),
                ("rig.grasp_deg", h.grasp_deg, Low(-360.0, false), 360.0),
                ("rig.initial_closure", h.initial_closure, zero, 1.0),
                ("rig.pour_rate_g_per_s", h.pour_rate_g_per_s, zero, 1e5),
                ("rig.pour_start_s", h.pour_start_s, zero, 1e6),
            ]),
            RigSetup::Rail(r) => fields.extend([
                ("rig.preload_mm", r.preload_mm, zero, 100.0),
                ("rig.rail_mu", r.rail_mu, zero, 10.0),
                (
                    "rig.rail_static_factor",
                    r.rail_static_factor,
                    Low(1.0, false),
                    100.0,
                ),
                ("rig.guide_load_share", r.guide_load_share, zero, 100.0),
                ("rig.end_stop_mm", r.end_stop_mm, positive, 1e4),
                ("rig.finger_closure", r.finger_closure, zero, 1.0),
                ("rig.press_in_mm", r.press_in_mm, zero, 100.0),
                ("rig.support_release_s", r.support_release_s, zero, 1e6),
            ]),
        }
        for (field, value, Low(lo, open), hi) in fields {
            let above = if open { value > lo } else { value >= lo };
            // NaN fails both comparisons
            if !(above && value <= hi) {
                let expected = match (lo, open) {
                    (0.0, true) => format!("a positive number, at most {hi}"),
                    (lo, true) => format!("a number above {lo}, at most {hi}"),
                    (lo, false) => format!("a number from {lo} to {hi}"),
                };
                return Err(ConfigProblem {
                    field: field.to_string(),
                    // 1e300 as 1e300, not three hundred digits
                    value: if value == 0.0 || (1e-4..1e6).contains(&value.abs()) {
                        value.to_string()
                    } else {
                        format!("{value:e}")
                    },
                    expected,
                });
            }
        }
        Ok(())
    }
}

/// Every number in `v` by its dotted name, arrays by element (`arm.start_mm[2]`), and the
/// names of the leaves that are not numbers.
pub fn numbers_by_name(v: &serde_json::Value) -> (Vec<(String, f64)>, Vec<String>) {
    fn walk(prefix: &str, v: &serde_json::Value, out: &mut (Vec<(String, f64)>, Vec<String>)) {
        match v {
            serde_json::Value::Object(map) => {
                for (k, x) in map {
                    let name = if prefix.is_empty() {
                        k.clone()
                    } else {
                        format!("{prefix}.{k}")
                    };
                    walk(&name, x, out);
                }
            }
            serde_json::Value::Array(items) => {
                for (i, x) in items.iter().enumerate() {
                    walk(&format!("{prefix}[{i}]"), x, out);
                }
            }
            serde_json::Value::Number(n) => match n.as_f64() {
                Some(x) => out.0.push((prefix.to_string(), x)),
                None => out.1.push(prefix.to_string()),
            },
            _ => out.1.push(prefix.to_string()),
        }
    }
    let mut out = (Vec::new(), Vec::new());
    walk("", v, &mut out);
    out
}

/// The slot a dotted name (`physics.x`, `arm.start_mm[2]`) names in `v`.
fn slot<'v>(v: &'v mut serde_json::Value, name: &str) -> Option<&'v mut serde_json::Value> {
    let mut at = v;
    for part in name.split('.') {
        let (key, index) = match part.split_once('[') {
            Some((k, rest)) => (k, Some(rest.strip_suffix(']')?.parse::<usize>().ok()?)),
            None => (part, None),
        };
        at = at.as_object_mut()?.get_mut(key)?;
        if let Some(i) = index {
            at = at.as_array_mut()?.get_mut(i)?;
        }
    }
    at.is_number().then_some(at)
}

impl SimConfig {
    /// The simulator's parameters with their default values, by the names
    /// `data/parameters.toml` records them under: every numeric field but the seed and the
    /// trial's own setup (object, grasp, masses: the protocol sets those), and the rail
    /// rig's fields as `rail.*`.
    pub fn parameters() -> Vec<(String, f64)> {
        let mut config = serde_json::to_value(SimConfig::default()).expect("a config serialises");
        let map = config.as_object_mut().expect("a config is a table");
        map.remove("seed");
        map.remove("rig");
        let mut out = numbers_by_name(&config).0;
        let rail = serde_json::to_value(RailSetup::default()).expect("a rail setup serialises");
        out.extend(
            numbers_by_name(&rail)
                .0
                .into_iter()
                .map(|(name, x)| (format!("rail.{name}"), x)),
        );
        out
    }

    /// Sets the named parameters (names as [`SimConfig::parameters`] gives them). `rail.*`
    /// parameters apply to the rail rig and are passed over on the hand. The result is
    /// checked as [`SimConfig::check`] does.
    pub fn set_parameters<'a>(
        &mut self,
        values: impl IntoIterator<Item = (&'a str, f64)>,
    ) -> Result<(), ConfigProblem> {
        let mut v = serde_json::to_value(&*self).expect("a config serialises");
        let rail = matches!(self.rig, RigSetup::Rail(_));
        for (name, value) in values {
            let unknown = || ConfigProblem {
                field: name.to_string(),
                value: value.to_string(),
                expected: "a simulator parameter (`tmo sim parameters` lists them)".into(),
            };
            let path = match name.strip_prefix("rail.") {
                Some(field) if RailSetup::default_has(field) => {
                    if !rail {
                        continue;
                    }
                    format!("rig.{field}")
                }
                Some(_) => return Err(unknown()),
                None if name.starts_with("rig.") || name == "seed" => return Err(unknown()),
                None => name.to_string(),
            };
            let at = slot(&mut v, &path).ok_or_else(unknown)?;
            *at = serde_json::Value::from(value);
        }
        let mut updated: SimConfig = serde_json::from_value(v).map_err(|e| ConfigProblem {
            field: "sim".into(),
            value: String::new(),
            expected: e.to_string(),
        })?;
        if let (RigSetup::Hand(_), RigSetup::Hand(_)) = (&self.rig, &updated.rig) {
            updated.rig = self.rig.clone();
        }
        updated.check()?;
        *self = updated;
        Ok(())
    }
}

impl RailSetup {
    fn default_has(field: &str) -> bool {
        serde_json::to_value(RailSetup::default())
            .ok()
            .and_then(|v| v.get(field).map(serde_json::Value::is_number))
            .unwrap_or(false)
    }
}

/// Which rig is built.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum RigSetup {
    /// The whole hand in a pinch grasp: thumb against two fingers, three sensors.
    Hand(HandSetup),
    /// One finger pressing an object against the low-friction vertical rail; one sensor.
    Rail(RailSetup),
}

/// How the object starts relative to the hand.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ObjectStart {
    /// Between the fingers, in the air, not moving: held if the grip suffices.
    InHand,
    /// Standing on a table, centred between the open fingers.
    OnTable,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct HandSetup {
    /// Name in the object library.
    pub object: String,
    /// Extra mass fixed to the object (the paper's cat with 100 g), g.
    pub extra_mass_g: f64,
    /// Hand roll about the arm's tool axis: 0 or 180 in the paper; it changes how the load
    /// is shared between thumb and fingers and flips the slip direction in the images.
    pub grasp_deg: f64,
    /// Initial position of the three fingers, 0..1.
    pub initial_closure: f64,
    pub start: ObjectStart,
    /// Mass poured into the object (rice), g/s, from `pour_start_s` on.
    pub pour_rate_g_per_s: f64,
    pub pour_start_s: f64,
}

impl Default for HandSetup {
    fn default() -> Self {
        Self {
            object: "crisps_can".into(),
            extra_mass_g: 0.0,
            grasp_deg: 0.0,
            initial_closure: 0.0,
            start: ObjectStart::InHand,
            pour_rate_g_per_s: 0.0,
            pour_start_s: 0.0,
        }
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RailSetup {
    pub object: String,
    /// How far (mm) the arm starts past the point where the fingertip touches the object.
    pub preload_mm: f64,
    /// Sliding friction coefficient of the rail's guides (acts with the finger's normal
    /// force).
    pub rail_mu: f64,
    /// Their friction at rest as a multiple of `rail_mu` (1 or more): the guides' share
    /// of the grasp's static capacity is `rail_static_factor * rail_mu * N`. A factor, so
    /// that either can be varied alone.
    pub rail_static_factor: f64,
    /// The guides' weight in sharing the stuck object's load with the finger (the finger's
    /// is 1): each carries a share in proportion to weight times normal force.
    pub guide_load_share: f64,
    /// The rail's end stop, mm below the start height.
    pub end_stop_mm: f64,
    /// Finger position, 0..1 (the finger holds still; the arm sets the normal force).
    pub finger_closure: f64,
    /// How much further (mm of fingertip travel) the finger is still pressing in when the
    /// trial starts: the rig's reset leaves it closing onto the object, so every trial begins
    /// with the contact being made (the paper's "initial contact" static frames).
    pub press_in_mm: f64,
    /// When (s from the trial's start) the rig's support lets go of the object, which then
    /// passes to the fingertip over `physics.load_transfer_s`.
    pub support_release_s: f64,
}

impl Default for RailSetup {
    fn default() -> Self {
        Self {
            object: "rail_object".into(),
            preload_mm: 0.0,
            rail_mu: 0.11,
            rail_static_factor: 1.0,
            guide_load_share: 0.2,
            end_stop_mm: 150.0,
            finger_closure: 0.5,
            press_in_mm: 7.5,
            support_release_s: 0.25,
        }
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PhysicsParams {
    /// Integration step, s.
    pub step_s: f64,
    pub gravity_m_s2: f64,
    /// Travel of one fingertip from open (0) to closed (1), mm.
    pub finger_travel_mm: f64,
    /// Compliance of the under-actuated finger at its tip, N/mm.
    pub finger_stiffness_n_per_mm: f64,
    /// Effective (plane-strain) modulus of the skin-object contact, kPa (Hertz).
    pub skin_modulus_kpa: f64,
    /// Poisson ratio of the skin (elastomer).
    pub skin_poisson: f64,
    /// Radius of the fingertip dome, mm.
    pub dome_radius_mm: f64,
    /// Largest normal force a finger can press with at full torque, N.
    pub stall_force_n: f64,
    /// Half the distance across the palm between the two fingers' contacts, which stand
    /// either side of the thumb's, mm (grasp statics: `statics`).
    pub finger_half_spacing_mm: f64,
    /// Sliding speed over which friction falls from static to kinetic (Stribeck), mm/s.
    pub stribeck_speed_mm_s: f64,
    /// Rise of sliding friction per e-fold of sliding speed (rubber's hysteresis friction),
    /// relative to kinetic.
    pub rate_strengthening: f64,
    /// Sliding speed from which that rise starts, mm/s.
    pub strengthening_from_mm_s: f64,
    /// Standard deviation of friction along an object's surface, relative.
    pub surface_friction_sd: f64,
    /// Shortest and longest wavelength of that variation, mm.
    pub surface_wavelength_mm: [f64; 2],
    /// Sinusoids that make that variation (rounded to a whole number).
    pub surface_waves: f64,
    /// `s` in `exp(-(k a)^2 / s)`, how far a wave of wave number `k` survives the average
    /// of friction under a Hertz patch of radius `a` (Gaussian approximation: 10).
    pub texture_patch_smoothing: f64,
    /// `c` in `min(1, L / (c a))`, the share of a wave of wavelength `L` a spot of skin
    /// shows against the whole patch's shear (Mindlin half-space: 3.8).
    pub texture_local_length: f64,
    /// How far the fingertip rolls along the object per mm it presses past first touch
    /// (the under-actuated finger curls as its proximal link stops), mm/mm.
    pub finger_roll_ratio: f64,
    /// Time over which an object that starts held passes from whatever held it before the
    /// trial (the operator's hand, the rail's support) to the fingertips, s.
    pub load_transfer_s: f64,
    /// Fall below the held height that counts as a drop, mm.
    pub drop_limit_mm: f64,
    /// Height of the floor a dropped object lands on, mm.
    pub floor_mm: f64,
}

impl Default for PhysicsParams {
    fn default() -> Self {
        Self {
            step_s: 0.001,
            gravity_m_s2: 9.81,
            finger_travel_mm: 75.0,
            finger_stiffness_n_per_mm: 0.8,
            skin_modulus_kpa: 350.0,
            skin_poisson: 0.5,
            dome_radius_mm: 10.0,
            stall_force_n: 25.0,
            finger_half_spacing_mm: 32.0,
            stribeck_speed_mm_s: 2.0,
            rate_strengthening: 0.05,
            strengthening_from_mm_s: 10.0,
            surface_friction_sd: 0.2,
            surface_wavelength_mm: [0.5, 20.0],
            surface_waves: 8.0,
            texture_patch_smoothing: 10.0,
            texture_local_length: 3.8,
            finger_roll_ratio: 0.3,
            load_transfer_s: 0.2,
            drop_limit_mm: 80.0,
            floor_mm: 0.0,
        }
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ServoParams {
    /// Delay from a command to the servo starting to act on it (bus + firmware), s.
    pub latency_s: f64,
    /// Fastest finger motion, fraction of range per s: the motor's no-load speed, which
    /// no command can exceed.
    pub max_speed_per_s: f64,
    /// The speed the protocols' `*_of_max` fractions are of, fraction of range per s (a
    /// real hand's hardware file's `hand.max_speed_per_s`): the paper's "maximum finger
    /// movement speed", of which its release is 0.5 %. Not a limit: it may exceed
    /// `max_speed_per_s`, as the paper's does the motor's.
    pub reference_speed_per_s: f64,
    /// Time constant of the servo's position loop (proportional control), s: a step in the
    /// target is 63 % done after this long unless the speed limit binds.
    pub position_time_s: f64,
    /// Free play between each motor and its finger (tendon slack and gear backlash),
    /// fraction of the range: after a reversal the motor turns this far before the finger
    /// follows.
    pub backlash: f64,
    /// Torque limit at start, fraction of maximum.
    pub initial_torque_limit: f64,
    /// Encoder counts over a finger's range: each servo's shaft moves in whole counts, so a
    /// slow move is a staircase (0: a smooth servo without counts).
    pub encoder_counts_per_range: f64,
}

impl Default for ServoParams {
    fn default() -> Self {
        Self {
            latency_s: 0.008,
            max_speed_per_s: 1.10,
            reference_speed_per_s: 3.18,
            position_time_s: 0.05,
            backlash: 0.02,
            initial_torque_limit: 1.0,
            encoder_counts_per_range: 2866.5,
        }
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ArmParams {
    /// Refuse moves faster than this, mm/s.
    pub max_speed_mm_s: f64,
    pub acceleration_mm_s2: f64,
    /// Delay from a motion command leaving the host to the controller starting it, s: each
    /// URScript line the host sends starts as a new program on the controller.
    pub latency_s: f64,
    /// TCP position at start, mm.
    pub start_mm: [f64; 3],
    /// Height of the hand's marker above the TCP, mm.
    pub hand_marker_offset_mm: f64,
}

impl Default for ArmParams {
    fn default() -> Self {
        Self {
            max_speed_mm_s: 250.0,
            acceleration_mm_s2: 1200.0,
            latency_s: 0.024,
            start_mm: [400.0, 0.0, 300.0],
            hand_marker_offset_mm: 60.0,
        }
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TactipParams {
    pub pins: usize,
    pub image_px: [f64; 2],
    /// Radius of the pin dome in the image, px.
    pub dome_radius_px: f64,
    pub frame_rate_hz: f64,
    /// Arrival-time jitter (standard deviation), s.
    pub frame_jitter_s: f64,
    /// Largest deviation of a sensor's frame clock from nominal, parts per million.
    pub clock_error_ppm: f64,
    /// Pixel noise of each pin coordinate (standard deviation), px.
    pub noise_px: f64,
    /// Peak radial pin displacement per mm of skin indentation, px/mm.
    pub radial_gain_px_per_mm: f64,
    /// How far beyond the contact patch the gel spreads an indentation, px.
    pub spread_radius_px: f64,
    /// Viscoelastic time constant of the skin, s.
    pub skin_time_s: f64,
    /// Share of the skin's displacement that creeps (the slow term of its Prony series).
    pub creep_fraction: f64,
    /// Time constant of that creep, s.
    pub creep_time_s: f64,
    /// Share of the skin's displacement that follows a load at once (its instantaneous,
    /// glassy compliance); the rest follows within `skin_time_s` or creeps.
    pub instant_fraction: f64,
    /// Spread of the contact centre from the image centre (standard deviation), px.
    pub contact_offset_px: f64,
    /// Unit-to-unit variation of the gains (uniform, +-), fraction.
    pub unit_variation: f64,
    /// How much wider than the carried region the patch's shear spreads in the image: the
    /// shear field falls as `exp(-r^2 / 2 (f rho_c)^2)`.
    pub shear_spread_factor: f64,
    /// Each sensor's mounting error about its axis (standard deviation, deg): its image's
    /// directions sit this far off nominal, unit by unit.
    pub mount_scatter_deg: f64,
}

impl Default for TactipParams {
    fn default() -> Self {
        Self {
            pins: tmo_hal::TMO_PINS_PER_SENSOR,
            image_px: [340.0, 280.0],
            dome_radius_px: 120.0,
            frame_rate_hz: 60.0,
            frame_jitter_s: 0.0008,
            clock_error_ppm: 300.0,
            noise_px: 0.08,
            radial_gain_px_per_mm: 8.0,
            spread_radius_px: 30.0,
            skin_time_s: 0.008,
            creep_fraction: 0.3,
            creep_time_s: 0.15,
            instant_fraction: 0.3,
            contact_offset_px: 20.0,
            unit_variation: 0.25,
            shear_spread_factor: 1.3,
            mount_scatter_deg: 5.0,
        }
    }
}

/// What the simulated operator does where a person would set the rig up by hand: how firmly
/// a grasp is set before a trial. (The runners of the simulated rig read these; the
/// simulator itself does not.)
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct OperatorParams {
    /// The hand release's starting grasp, as a factor on the grasp that just holds the
    /// object: drawn uniformly between the two, trial by trial, as a hand-set grasp varies.
    pub release_grip_safety: [f64; 2],
    /// The rice pour's starting grasp, as a factor on the grasp that just holds the empty
    /// can ("a light grasp").
    pub pour_grip_safety: f64,
    /// How far open of the contact (fraction of the closing range) the fingers stand when
    /// a lift starts, the object on the table: the lift's approach closes from there.
    pub lift_start_gap: f64,
}

impl Default for OperatorParams {
    fn default() -> Self {
        Self {
            release_grip_safety: [1.2, 1.8],
            pour_grip_safety: 1.2,
            lift_start_gap: 0.04,
        }
    }
}

/// Rates of the faults real pin trackers show.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FaultRates {
    /// Probability per pin per frame that the blob detector reports a wrong position.
    pub pin_misdetect: f64,
    /// Probability per frame that the frame is lost.
    pub dropped_frame: f64,
    /// Probability per frame that the camera repeats its previous pin positions.
    pub stale_frame: f64,
}

impl Default for FaultRates {
    fn default() -> Self {
        Self {
            pin_misdetect: 0.0005,
            dropped_frame: 0.002,
            stale_frame: 0.002,
        }
    }
}

impl FaultRates {
    pub fn none() -> Self {
        Self {
            pin_misdetect: 0.0,
            dropped_frame: 0.0,
            stale_frame: 0.0,
        }
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MarkerParams {
    pub rate_hz: f64,
    pub noise_mm: f64,
}

impl Default for MarkerParams {
    fn default() -> Self {
        Self {
            rate_hz: 60.0,
            noise_mm: 0.3,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_defaults_and_the_rail_pass_the_check() {
        SimConfig::default().check().unwrap();
        let rail = SimConfig {
            rig: RigSetup::Rail(RailSetup::default()),
            ..SimConfig::default()
        };
        rail.check().unwrap();
    }

    #[test]
    fn named_parameters_are_set_and_checked() {
        let names: Vec<String> = SimConfig::parameters()
            .into_iter()
            .map(|(n, _)| n)
            .collect();
        assert!(names.contains(&"physics.finger_stiffness_n_per_mm".to_string()));
        assert!(names.contains(&"arm.start_mm[2]".to_string()));
        assert!(names.contains(&"rail.rail_mu".to_string()));
        let mut hand = SimConfig::default();
        hand.set_parameters([
            ("physics.finger_stiffness_n_per_mm", 1.2),
            ("arm.start_mm[2]", 250.0),
            ("rail.rail_mu", 0.1),
        ])
        .unwrap();
        assert_eq!(hand.physics.finger_stiffness_n_per_mm, 1.2);
        assert_eq!(hand.arm.start_mm[2], 250.0);
        // the rail's parameter is passed over on the hand
        assert_eq!(hand.rig, SimConfig::default().rig);
        let mut rail = SimConfig {
            rig: RigSetup::Rail(RailSetup::default()),
            ..SimConfig::default()
        };
        rail.set_parameters([("rail.rail_mu", 0.1)]).unwrap();
        assert!(matches!(rail.rig, RigSetup::Rail(ref r) if r.rail_mu == 0.1));
        // unknown names and values the simulator cannot stand for are refused by name
        for (name, value) in [
            ("physics.stiffness", 1.0),
            ("rail.object", 1.0),
            ("seed", 3.0),
            ("arm.start_mm[3]", 1.0),
            ("rig.grasp_deg", 180.0),
        ] {
            let e = SimConfig::default()
                .set_parameters([(name, value)])
                .unwrap_err();
            assert_eq!(e.field, name, "{e}");
        }
        let e = SimConfig::default()
            .set_parameters([("physics.gravity_m_s2", -1.0)])
            .unwrap_err();
        assert_eq!(e.field, "physics.gravity_m_s2");
    }

    #[test]
    fn garbage_is_refused_with_the_field_named() {
        let refused = |edit: &dyn Fn(&mut SimConfig)| {
            let mut c = SimConfig::default();
            edit(&mut c);
            c.check().unwrap_err()
        };
        let e = refused(&|c| c.physics.gravity_m_s2 = 1e300);
        assert_eq!(e.field, "physics.gravity_m_s2");
        assert_eq!(
            e.to_string(),
            "`physics.gravity_m_s2` = 1e300: expected a positive number, at most 100"
        );
        let e = refused(&|c| {
            c.rig = RigSetup::Hand(HandSetup {
                extra_mass_g: -1e9,
                ..HandSetup::default()
            })
        });
        assert_eq!(e.field, "rig.extra_mass_g");
        assert_eq!(
            refused(&|c| c.arm.max_speed_mm_s = -5.0).field,
            "arm.max_speed_mm_s"
        );
        assert_eq!(
            refused(&|c| c.tactip.noise_px = f64::NAN).field,
            "tactip.noise_px"
        );
        assert_eq!(refused(&|c| c.tactip.pins = 0).field, "tactip.pins");
        assert_eq!(
            refused(&|c| c.physics.surface_wavelength_mm = [4.0, 0.5]).field,
            "physics.surface_wavelength_mm[1]"
        );
    }
}
