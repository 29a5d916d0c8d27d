//! The simulated world: one fixed-step integrator over hand, arm, object, skins, cameras and
//! marker tracker. Device handles (see `mod.rs`) read from and command this state; only the
//! virtual clock advances it.

use std::cell::Cell;
use std::collections::VecDeque;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal, StandardNormal};

use super::actuators::{ArmState, Encoders, Servos};
use super::config::{ObjectStart, PhysicsParams, RigSetup, SimConfig};
use super::curl::{ApproachAxis, CurlGrasp, CurlInput, CurlLimits};
use super::grasp::{
    pinch_normal_forces, share_stuck_load, Contact, ContactLaw, StuckShare, MAX_CONTACTS,
};
use super::objects::{ObjectLibrary, ObjectSpec};
use super::skin::{
    ElementStickSlip, SkinContact, SlidingFriction, SlidingPatch, SurfaceTexture, TextureShape,
};
use super::statics;
use super::tactip::{
    add_local_shear, dome_layout, local_shear_factors, pin_positions, CreepingDisplacement,
    SensorOptics, SkinState, SkinTimes,
};
use super::turn;
use super::SimError;
use tmo_hal::types::{HandPositions, MarkerSample, PinFrame, HAND_ACTUATORS};

/// Frames a sensor buffers before the oldest are lost, as a serial buffer overflows.
const SENSOR_QUEUE_LIMIT: usize = 4096;

/// Ground truth at one instant, for diagnostics and tests only: never a detector input.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TruthState {
    pub time_s: f64,
    pub object_mm: f64,
    pub object_velocity_mm_s: f64,
    pub hand_mm: f64,
    pub hand_velocity_mm_s: f64,
    pub mass_g: f64,
    /// Normal and tangential force at each fingertip sensor, N.
    pub normal_n: Vec<f64>,
    pub tangential_n: Vec<f64>,
    pub local_slip: Vec<bool>,
    pub indentation_mm: Vec<f64>,
    pub shear_px: Vec<f64>,
    /// Each skin's shown shear along the roll's image direction (the fingertip's curl and
    /// the shear across the slip axis), px.
    pub roll_px: Vec<f64>,
    /// The object slides relative to the fingers (gross slip).
    pub sliding: bool,
    /// Static friction capacity of the grasp, N (rail friction included on the rail).
    pub capacity_n: f64,
    /// Weight of the object, N.
    pub weight_n: f64,
    pub in_grasp: bool,
    pub dropped: bool,
    pub finger_positions: HandPositions,
    /// What each servo's encoder reads, fraction of the range (on a whole count when the
    /// servos have encoders).
    pub servo_positions: HandPositions,
    /// How far the object has turned about the pinch axis since it was grasped, degrees
    /// (signed as the turn about the hand frame's pinch axis).
    pub turn_deg: f64,
    /// How far each fingertip's patch has slid along the object in all, mm.
    pub contact_slid_mm: Vec<f64>,
}

/// Events the simulation knows for certain, for diagnostics and tests only.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TruthEvents {
    /// Times gross slip began.
    pub slip_onsets_s: Vec<f64>,
    /// Times the grasp stuck again after slipping.
    pub catches_s: Vec<f64>,
    pub drop_s: Option<f64>,
    /// Onset of the first slip in which the object fell more than
    /// [`MEASURABLE_FALL_MM`] below where the grasp last held it (relative to the hand).
    pub measurable_slip_s: Option<f64>,
    /// Furthest the object fell below where the grasp last held it, relative to the hand, mm.
    pub max_fall_mm: f64,
    /// Per fingertip: when its patch first broke free along the object while the grasp
    /// held, and how many times it did ([`crate::curl`]).
    pub contact_first_slip_s: Vec<Option<f64>>,
    pub contact_slips: Vec<u32>,
    /// Per fingertip: when each of its first `MAX_SLIP_TIMES` (32) break-frees was, so a
    /// reaction can be set against the break-free it followed, not only the first.
    pub contact_slip_times_s: Vec<Vec<f64>>,
}

/// How many break-free times a fingertip's truth keeps (a trial's log stays small).
pub const MAX_SLIP_TIMES: usize = 32;

/// The fall (mm, relative to the hand) below which a slip counts as not measurable: the
/// marker scorer's default drop threshold (a slip is only detected once the object is 1 mm
/// down), so truth and marker verdicts ask the same question.
pub const MEASURABLE_FALL_MM: f64 = 1.0;

struct SensorUnit {
    optics: SensorOptics,
    /// This unit's skin (manufactured skins differ in stiffness).
    skin: SkinContact,
    /// Image pixels per mm on the dome.
    px_per_mm: f64,
    /// Tangential displacement of the contact patch the pins show, after the skin's
    /// viscoelastic lag and creep, mm: along the slip direction and along the roll direction.
    shear_mm: CreepingDisplacement,
    roll_mm: CreepingDisplacement,
    /// Indentation the pins show, mm, and the normal force it was last worked out for.
    indentation_mm: CreepingDisplacement,
    indentation_target: (f64, f64),
    period_s: f64,
    next_capture_s: f64,
    seq: u64,
    last_time_s: f64,
    last_pins: Option<Vec<[f32; 2]>>,
    queue: VecDeque<PinFrame>,
    rng: ChaCha8Rng,
    scratch: Vec<[f64; 2]>,
    /// The local drag's factors per pin and the (slid mm, contact radius mm, sliding
    /// speed) they were worked out for.
    local_factors: Vec<f64>,
    local_key: Option<[f64; 3]>,
    /// Stick-slip of the skin's elements under the pins, and their displacements this frame.
    elements: ElementStickSlip,
    element_shift_mm: Vec<f64>,
    /// The same as the pins show them, each spread through the gel to its neighbours.
    element_spread_mm: Vec<f64>,
}

struct MarkerUnit {
    period_s: f64,
    next_s: f64,
    queue: VecDeque<MarkerSample>,
    rng: ChaCha8Rng,
}

enum Geometry {
    Hand {
        /// Gravity's direction in the hand frame (see [`statics`]).
        gravity: [f64; 3],
    },
    Rail {
        arm_touch_x_mm: f64,
        finger_touch: f64,
        rail_mu: f64,
        rail_mu_static: f64,
        /// The guides' weight in sharing the stuck object's load (the finger's is 1).
        guide_share: f64,
    },
}

/// A grasp statics solve: the load, the normal forces, the object's turn, and the share
/// (`None`: gross slip).
type SolvedStatics = (f64, [f64; 3], f64, Option<StuckShare>);

pub(crate) struct World {
    cfg: SimConfig,
    object: ObjectSpec,
    geometry: Geometry,
    step_index: u64,
    pub(crate) servos: Servos,
    pub(crate) arm: ArmState,
    /// Force against travel of each fingertip contact.
    laws: Vec<ContactLaw>,
    /// Travels and force cap the normal forces were last solved for.
    solved_for: Option<([f64; 3], f64)>,
    /// How far each contact is pressed in at its normal force, mm: read by every poll of
    /// the hand's positions, so worked out once per solve rather than per call.
    pressed_mm: [f64; 3],
    // Object state along the vertical axis (mm, mm/s) and its relation to the hand.
    z_mm: f64,
    vz_mm_s: f64,
    stuck: bool,
    in_grasp: bool,
    /// The object's turn about the pinch axis (rad) and its rate (rad/s), and the grasp
    /// point's acceleration along the vertical at the last step (mm/s^2): see [`turn`].
    turn_rad: f64,
    turn_rate_rad_s: f64,
    accel_mm_s2: f64,
    /// Object height minus hand height when the grasp started; contact is lost once the
    /// object has slid half its length from there.
    grasp_offset_mm: f64,
    /// Height below which the object cannot go: table, rail end stop or floor.
    support_mm: Option<f64>,
    held_mm: f64,
    normal_n: [f64; 3],
    tangential_n: [f64; 3],
    local_slip: [bool; 3],
    capacity_n: f64,
    /// Each skin patch while the object slides over it, and the strip of the object's
    /// surface it slides on.
    patches: [SlidingPatch; 3],
    textures: Vec<SurfaceTexture>,
    friction: SlidingFriction,
    /// Where each patch's shear and roll are driven, mm (the pins follow with a lag): the
    /// shear along the slip axis, the fingertip's roll from its curl, and the shear across
    /// the slip axis (a turning object's, shown along the roll's image direction).
    shear_target_mm: [f64; 3],
    roll_target_mm: [f64; 3],
    across_target_mm: [f64; 3],
    /// Radius of each patch's region carried with the object, mm.
    carried_mm: [f64; 3],
    /// Normal force each fingertip's full-slip shear was last worked out for, N, and that
    /// shear, mm.
    rolled_at_n: [f64; 3],
    full_slip_mm: [f64; 3],
    /// Each fingertip's own slip along the object as its finger curls ([`crate::curl`]).
    curl: CurlGrasp,
    /// Each contact's load along the approach axis (on the object, `+y` of
    /// [`crate::statics`]) and along the slip axis, N: how the curl's load combines with
    /// the grasp's in the friction circle.
    approach_n: [f64; 3],
    slip_axis_n: [f64; 3],
    /// Tangential, normal and across-slip load each stuck patch's shear was last worked
    /// out for.
    stuck_load: [Option<(f64, f64, f64)>; 3],
    /// The last grasp statics solved: load, normal forces and the share (`None`: gross
    /// slip). A held grasp keeps both most of the time, and the solve was most of a step.
    statics_solved: Cell<Option<SolvedStatics>>,
    sensors: Vec<SensorUnit>,
    markers: MarkerUnit,
    events: TruthEvents,
    /// Object height relative to the hand when the grasp last held it, mm.
    held_relative_mm: Option<f64>,
}

fn series(k: &[f64]) -> f64 {
    1.0 / k.iter().map(|k| 1.0 / k).sum::<f64>()
}

/// The roll's image direction is the approach axis; its positive sense is the one the
/// fingertip's curl drags the skin in, which pulls the object towards the palm (`-y`). A
/// friction `across_n` on the object along `+y` shows as this much roll per newton.
fn roll_sense(across_n: f64) -> f64 {
    -across_n
}

/// Splits a stuck patch's shear `shear_mm` (signed as `load_n`, the patch's whole
/// tangential load) along that load: the part along the slip axis and, in the roll's
/// image direction, the part across it (`across_n` of the load, on the object along `+y`).
fn split_along_load(shear_mm: f64, load_n: f64, across_n: f64) -> (f64, f64) {
    if across_n == 0.0 || load_n == 0.0 {
        return (shear_mm, 0.0);
    }
    let whole = load_n.abs();
    let along = (whole * whole - across_n * across_n).max(0.0).sqrt();
    let per_n = shear_mm.abs() / whole;
    (
        shear_mm.signum() * per_n * along,
        per_n * roll_sense(across_n),
    )
}

/// The skin of a nominal (average) unit.
pub fn nominal_skin(p: &PhysicsParams) -> SkinContact {
    SkinContact::new(p.skin_modulus_kpa, p.skin_poisson, p.dome_radius_mm)
}

/// Force against travel of a nominal fingertip on `object`: finger and object springs in
/// series with the skin's Hertz contact.
pub fn nominal_contact_law(p: &PhysicsParams, object: &ObjectSpec) -> ContactLaw {
    contact_law(p, object, nominal_skin(p))
}

fn contact_law(p: &PhysicsParams, object: &ObjectSpec, skin: SkinContact) -> ContactLaw {
    ContactLaw::new(
        series(&[p.finger_stiffness_n_per_mm, object.stiffness_n_per_mm]),
        skin,
        p.stall_force_n,
    )
}

impl World {
    pub(crate) fn new(cfg: SimConfig, library: &ObjectLibrary) -> Result<Self, SimError> {
        validate(&cfg)?;
        let p = &cfg.physics;
        let (object_name, sensor_count) = match &cfg.rig {
            RigSetup::Hand(h) => (h.object.as_str(), 3),
            RigSetup::Rail(r) => (r.object.as_str(), 1),
        };
        let object = library.get(object_name)?.clone();
        let arm = ArmState::new(cfg.arm.start_mm, cfg.arm.acceleration_mm_s2)
            .with_latency(cfg.arm.latency_s);
        let hand_z = cfg.arm.start_mm[2];
        let (geometry, start_positions, support_mm, grasp_deg) = match &cfg.rig {
            RigSetup::Hand(h) => {
                let support = (h.start == ObjectStart::OnTable).then_some(hand_z);
                let q = h.initial_closure;
                (
                    Geometry::Hand {
                        gravity: statics::gravity_direction(h.grasp_deg),
                    },
                    [q, q, q, 0.0],
                    support,
                    h.grasp_deg,
                )
            }
            RigSetup::Rail(r) => (
                Geometry::Rail {
                    arm_touch_x_mm: cfg.arm.start_mm[0] - r.preload_mm,
                    finger_touch: r.finger_closure,
                    rail_mu: r.rail_mu,
                    rail_mu_static: r.rail_mu * r.rail_static_factor,
                    guide_share: r.guide_load_share,
                },
                [r.finger_closure, 0.0, 0.0, 0.0],
                Some(hand_z - r.end_stop_mm),
                0.0,
            ),
        };
        let support_mm = Some(support_mm.map_or(p.floor_mm, |s: f64| s.max(p.floor_mm)));
        let mut servos = Servos::new(
            start_positions,
            cfg.servo.initial_torque_limit,
            cfg.servo.latency_s,
            cfg.servo.max_speed_per_s,
            cfg.servo.position_time_s,
        )
        .with_backlash(cfg.servo.backlash);
        if cfg.servo.encoder_counts_per_range > 0.0 {
            // Each servo's zero is calibrated on its own: its grid sits a fraction of a
            // count off the others'.
            let mut erng = ChaCha8Rng::seed_from_u64(cfg.seed);
            erng.set_stream(4);
            servos = servos.with_encoders(Encoders {
                counts_per_range: cfg.servo.encoder_counts_per_range,
                phase: [(); HAND_ACTUATORS].map(|_| erng.gen_range(0.0..1.0)),
            });
        }
        if let RigSetup::Rail(r) = &cfg.rig {
            // The rig's reset leaves the finger still pressing in as the trial starts.
            servos.target[0] = (r.finger_closure + r.press_in_mm / p.finger_travel_mm).min(1.0);
        }
        let t = &cfg.tactip;
        let centre = [t.image_px[0] / 2.0, t.image_px[1] / 2.0];
        let rest = dome_layout(t.pins, centre, t.dome_radius_px);
        // Thumb and fingers face each other, so their cameras see "down" in opposite
        // directions; each mount is a few degrees off nominal.
        let mount_deg = [0.0, 180.0, 180.0];
        let offset = Normal::new(0.0, t.contact_offset_px.max(1e-12)).expect("valid normal");
        let sensors = (0..sensor_count)
            .map(|i| {
                let mut srng = ChaCha8Rng::seed_from_u64(cfg.seed);
                srng.set_stream(10 + i as u64);
                let vary = |r: &mut ChaCha8Rng| 1.0 + t.unit_variation * r.gen_range(-1.0..=1.0);
                let angle = (mount_deg[i]
                    + grasp_deg
                    + t.mount_scatter_deg * srng.sample::<f64, _>(StandardNormal))
                .to_radians();
                let optics = SensorOptics::new(
                    rest.clone(),
                    [
                        centre[0] + offset.sample(&mut srng),
                        centre[1] + offset.sample(&mut srng),
                    ],
                    [angle.sin(), angle.cos()],
                    t.radial_gain_px_per_mm * vary(&mut srng),
                    t.spread_radius_px * vary(&mut srng),
                )
                .with_shear_spread(t.shear_spread_factor);
                let skin = nominal_skin(p).scaled(vary(&mut srng));
                let period =
                    (1.0 + t.clock_error_ppm * 1e-6 * srng.gen_range(-1.0..=1.0)) / t.frame_rate_hz;
                SensorUnit {
                    optics,
                    skin,
                    px_per_mm: t.dome_radius_px / p.dome_radius_mm,
                    shear_mm: CreepingDisplacement::default(),
                    roll_mm: CreepingDisplacement::default(),
                    indentation_mm: CreepingDisplacement::default(),
                    indentation_target: (0.0, 0.0),
                    period_s: period,
                    next_capture_s: srng.gen_range(0.0..period),
                    seq: 0,
                    last_time_s: 0.0,
                    last_pins: None,
                    queue: VecDeque::new(),
                    rng: srng,
                    scratch: Vec::with_capacity(t.pins),
                    local_factors: Vec::with_capacity(t.pins),
                    local_key: None,
                    elements: ElementStickSlip::default(),
                    element_shift_mm: Vec::with_capacity(t.pins),
                    element_spread_mm: Vec::with_capacity(t.pins),
                }
            })
            .collect::<Vec<SensorUnit>>();
        let laws = sensors
            .iter()
            .map(|s| contact_law(p, &object, s.skin))
            .collect();
        let mut trng = ChaCha8Rng::seed_from_u64(cfg.seed);
        trng.set_stream(3);
        let textures = (0..sensor_count)
            .map(|_| {
                let [lo, hi] = p.surface_wavelength_mm;
                let shape = TextureShape {
                    waves: p.surface_waves.round().max(1.0) as usize,
                    patch_smoothing: p.texture_patch_smoothing,
                    local_length: p.texture_local_length,
                };
                SurfaceTexture::shaped(p.surface_friction_sd, lo, hi, shape, || {
                    trng.gen_range(0.0..1.0)
                })
            })
            .collect();
        let friction = SlidingFriction {
            mu_static: object.mu_static,
            mu_kinetic: object.mu_kinetic,
            stribeck_mm_s: p.stribeck_speed_mm_s,
            rate_strengthening: p.rate_strengthening,
            strengthening_from_mm_s: p.strengthening_from_mm_s,
        };
        let mut mrng = ChaCha8Rng::seed_from_u64(cfg.seed);
        mrng.set_stream(1);
        let marker_period = 1.0 / cfg.marker.rate_hz;
        let markers = MarkerUnit {
            period_s: marker_period,
            next_s: mrng.gen_range(0.0..marker_period),
            queue: VecDeque::new(),
            rng: mrng,
        };
        let mut world = Self {
            object,
            geometry,
            step_index: 0,
            servos,
            arm,
            laws,
            solved_for: None,
            pressed_mm: [0.0; 3],
            z_mm: hand_z,
            vz_mm_s: 0.0,
            stuck: true,
            in_grasp: true,
            grasp_offset_mm: 0.0,
            support_mm,
            held_mm: hand_z,
            normal_n: [0.0; 3],
            tangential_n: [0.0; 3],
            local_slip: [false; 3],
            capacity_n: 0.0,
            patches: [SlidingPatch::default(); 3],
            textures,
            friction,
            shear_target_mm: [0.0; 3],
            roll_target_mm: [0.0; 3],
            across_target_mm: [0.0; 3],
            carried_mm: [0.0; 3],
            stuck_load: [None; 3],
            statics_solved: Cell::new(None),
            rolled_at_n: [f64::NAN; 3],
            full_slip_mm: [0.0; 3],
            curl: CurlGrasp::default(),
            approach_n: [0.0; 3],
            slip_axis_n: [0.0; 3],
            sensors,
            markers,
            events: TruthEvents {
                contact_first_slip_s: vec![None; sensor_count],
                contact_slips: vec![0; sensor_count],
                contact_slip_times_s: vec![Vec::new(); sensor_count],
                ..TruthEvents::default()
            },
            held_relative_mm: None,
            turn_rad: 0.0,
            turn_rate_rad_s: 0.0,
            accel_mm_s2: 0.0,
            cfg,
        };
        world.update_normal_forces();
        // A grasp set before the start has slid its patches already.
        world.update_curls(false);
        // A grip too weak for the object starts slipping at once, and that is not an onset
        // the experiment caused: only hand-held starts can slip at t = 0.
        Ok(world)
    }

    pub(crate) fn now_s(&self) -> f64 {
        self.step_index as f64 * self.cfg.physics.step_s
    }

    pub(crate) fn sensor_count(&self) -> usize {
        self.sensors.len()
    }

    pub(crate) fn config(&self) -> &SimConfig {
        &self.cfg
    }

    /// The object of the rig, as its library gave it.
    pub(crate) fn object(&self) -> &ObjectSpec {
        &self.object
    }

    pub(crate) fn advance_to(&mut self, time_s: f64) {
        let dt = self.cfg.physics.step_s;
        let target = (time_s / dt - 1e-9).ceil().max(0.0) as u64;
        while self.step_index < target {
            self.step();
        }
    }

    pub(crate) fn pop_frame(&mut self, sensor: usize) -> Option<PinFrame> {
        self.sensors[sensor].queue.pop_front()
    }

    pub(crate) fn pop_marker(&mut self) -> Option<MarkerSample> {
        self.markers.queue.pop_front()
    }

    pub(crate) fn events(&self) -> &TruthEvents {
        &self.events
    }

    fn mass_kg(&self) -> f64 {
        let extra = match &self.cfg.rig {
            RigSetup::Hand(h) => {
                h.extra_mass_g + h.pour_rate_g_per_s * (self.now_s() - h.pour_start_s).max(0.0)
            }
            RigSetup::Rail(_) => 0.0,
        };
        (self.object.mass_g + extra) / 1000.0
    }

    fn hand_z(&self) -> f64 {
        self.arm.position_mm[2]
    }

    /// Present finger positions: a finger whose force is capped by its torque limit is held
    /// back by the object, short of where its servo is driving.
    pub(crate) fn present_positions(&self) -> HandPositions {
        // The servos report their motors' positions; the fingers are behind by the free
        // play and, when pressing, by how far the object holds them back.
        let mut q = self.servos.position;
        let travel = self.cfg.physics.finger_travel_mm;
        for (i, qi) in q.iter_mut().enumerate().take(self.sensors.len()) {
            if self.in_grasp && self.normal_n[i] > 0.0 {
                let excess = (self.travel_past_contact(i) - self.pressed_mm[i]).max(0.0);
                *qi -= excess / travel;
            }
        }
        q
    }

    /// How far finger `i` has pressed past first touch, mm (negative: not touching).
    fn travel_past_contact(&self, i: usize) -> f64 {
        let travel = self.cfg.physics.finger_travel_mm;
        match self.geometry {
            Geometry::Hand { .. } => {
                self.object.width_mm / 2.0 - travel * (1.0 - self.servos.finger[i])
            }
            Geometry::Rail {
                arm_touch_x_mm,
                finger_touch,
                ..
            } => {
                (self.arm.position_mm[0] - arm_touch_x_mm)
                    + (self.servos.finger[0] - finger_touch) * travel
            }
        }
    }

    fn update_normal_forces(&mut self) {
        let cap = self.servos.torque_limit * self.cfg.physics.stall_force_n;
        if !self.in_grasp {
            self.normal_n = [0.0; 3];
            self.pressed_mm = [0.0; 3];
            return;
        }
        let travel = match self.geometry {
            Geometry::Hand { .. } => [0, 1, 2].map(|i| self.travel_past_contact(i)),
            Geometry::Rail { .. } => [self.travel_past_contact(0), 0.0, 0.0],
        };
        // Fingers and arm hold still most of the time: solve only when something moved.
        if self.solved_for == Some((travel, cap)) {
            return;
        }
        self.solved_for = Some((travel, cap));
        let laws = &self.laws;
        self.normal_n = match self.geometry {
            Geometry::Hand { .. } => {
                pinch_normal_forces(travel, |i, p| laws[i].force_n(p), [cap; 3])
            }
            Geometry::Rail { .. } => [laws[0].force_n(travel[0]).clamp(0.0, cap), 0.0, 0.0],
        };
        for (i, law) in self.laws.iter().enumerate() {
            self.pressed_mm[i] = law.travel_mm(self.normal_n[i]);
        }
    }

    fn contacts(&self) -> ([Contact; MAX_CONTACTS], usize) {
        let mut c = [Contact::default(); MAX_CONTACTS];
        let o = &self.object;
        match self.geometry {
            Geometry::Hand { .. } => {
                for (c, &normal_n) in c.iter_mut().zip(&self.normal_n) {
                    *c = Contact {
                        normal_n,
                        weight: 1.0,
                        mu_static: o.mu_static,
                        mu_kinetic: o.mu_kinetic,
                    };
                }
                (c, 3)
            }
            Geometry::Rail {
                rail_mu,
                rail_mu_static,
                guide_share,
                ..
            } => {
                c[0] = Contact {
                    normal_n: self.normal_n[0],
                    weight: 1.0,
                    mu_static: o.mu_static,
                    mu_kinetic: o.mu_kinetic,
                };
                // The rail's guides press back with the same normal force; their polymer
                // sliders' friction is low, and higher at rest than sliding.
                c[1] = Contact {
                    normal_n: self.normal_n[0],
                    weight: guide_share,
                    mu_static: rail_mu_static,
                    mu_kinetic: rail_mu,
                };
                (c, 2)
            }
        }
    }

    /// How the contacts carry `need_n` (N, > 0 pulls the object down through the grasp)
    /// while the object does not move relative to the fingers; `None`: gross slip. The
    /// hand's by force and moment balance ([`statics`]): each contact's tangential load is
    /// given as its size, signed by whether it holds the object up. The rail's guides by
    /// [`share_stuck_load`] (they keep the object from turning).
    fn stuck_share(&self, need_n: f64, contacts: &[Contact]) -> Option<StuckShare> {
        let Geometry::Hand { gravity } = self.geometry else {
            return share_stuck_load(need_n, contacts);
        };
        if need_n <= 0.0 {
            return Some(StuckShare::default());
        }
        if let Some((load, normals, turn, solved)) = self.statics_solved.get() {
            if load == need_n && normals == self.normal_n && turn == self.turn_rad {
                return solved;
            }
        }
        let solved = self.solve_statics(need_n, gravity);
        self.statics_solved
            .set(Some((need_n, self.normal_n, self.turn_rad, solved)));
        solved
    }

    /// Where the grasp's centre sits relative to the object's centre of mass (hand frame,
    /// mm): the object's centre of mass lies `com_offset_mm` deeper than the contacts when
    /// grasped, and turns about the pinch axis with the object.
    fn grasp_point_mm(&self) -> [f64; 3] {
        let [_, y, w] = self.com_from_grasp_mm();
        [0.0, -y, -w]
    }

    /// The centre of mass relative to the grasp's centre (hand frame, mm).
    fn com_from_grasp_mm(&self) -> [f64; 3] {
        let r = self.object.com_offset_mm;
        let (sin, cos) = self.turn_rad.sin_cos();
        [0.0, r * cos, r * sin]
    }

    /// [`Self::stuck_share`]'s solve.
    fn solve_statics(&self, need_n: f64, gravity: [f64; 3]) -> Option<StuckShare> {
        let points = statics::pinch_contacts(
            self.object.width_mm / 2.0,
            self.cfg.physics.finger_half_spacing_mm,
            self.grasp_point_mm(),
            self.normal_n,
            self.object.mu_static,
            self.object.mu_kinetic,
        );
        let held = statics::held_loads(&points, gravity.map(|g| g * need_n)).ok()?;
        let mut share = StuckShare::default();
        for i in 0..3 {
            let [ty, tw] = held.tangential_n[i];
            let up = -(ty * gravity[1] + tw * gravity[2]);
            share.tangential_n[i] = held.magnitude_n(i).copysign(up);
            share.across_n[i] = ty;
        }
        share.local_slip[..3].copy_from_slice(&held.local_slip);
        Some(share)
    }

    fn step(&mut self) {
        let p = &self.cfg.physics;
        let (dt, drop_limit, g) = (p.step_s, p.drop_limit_mm, p.gravity_m_s2);
        self.step_index += 1;
        let now = self.now_s();
        self.servos.step(now, dt);
        let hand_z_before = self.hand_z();
        self.arm.receive(now);
        self.arm.step(dt);
        let hand_v = self.arm.velocity_mm_s[2];
        let hand_a = self.arm.acceleration_mm_s2[2];
        let hand_dz = self.hand_z() - hand_z_before;

        self.update_normal_forces();
        let (contacts, n_contacts) = self.contacts();
        let contacts = &contacts[..n_contacts];
        self.capacity_n = contacts.iter().map(|c| c.mu_static * c.normal_n).sum();
        let m = self.mass_kg();
        let on_support = self.support_mm.is_some_and(|s| self.z_mm <= s + 1e-9);
        // Force the fingers must supply for the object to move with the hand.
        let need_n = if on_support && hand_v <= 0.0 && hand_a <= 0.0 {
            0.0
        } else {
            m * (g + hand_a / 1000.0) * self.load_transferred(now)
        };
        let skins = self.sensors.len();
        let mu_s = self.object.mu_static;

        let mut tangential = [0.0; MAX_CONTACTS];
        let mut local_slip = [false; MAX_CONTACTS];
        let (mut approach, mut slip_axis) = ([0.0; 3], [0.0; 3]);
        if self.stuck {
            match self.stuck_share(need_n, contacts) {
                Some(share) => {
                    tangential = share.tangential_n;
                    local_slip = share.local_slip;
                    for i in 0..3 {
                        let (whole, y) = (tangential[i], share.across_n[i]);
                        approach[i] = y;
                        slip_axis[i] = (whole * whole - y * y).max(0.0).sqrt();
                    }
                    self.z_mm += hand_dz;
                    self.vz_mm_s = hand_v;
                    self.accel_mm_s2 = hand_a;
                    if let Some(s) = self.support_mm {
                        self.z_mm = self.z_mm.max(s);
                    }
                    self.held_mm = self.z_mm;
                    // Stuck: each patch carries its share with Cattaneo-Mindlin compliance.
                    for (i, sensor) in self.sensors.iter().enumerate() {
                        // The power laws cost most of a step; a held grasp keeps its loads.
                        let load = (tangential[i], self.normal_n[i], share.across_n[i]);
                        if self.stuck_load[i] == Some(load) {
                            continue;
                        }
                        self.stuck_load[i] = Some(load);
                        let u = sensor.skin.mindlin_shear_mm(load.0, load.1, mu_s);
                        // The shear lies along the load: its part along the slip axis and
                        // its part across (a moment held by the fingers' couple).
                        let (along, across) = split_along_load(u, load.0, load.2);
                        self.shear_target_mm[i] = along;
                        self.across_target_mm[i] = across;
                        self.carried_mm[i] = sensor.skin.stick_radius_mm(load.0, load.1, mu_s);
                        self.patches[i].shear_mm = u;
                    }
                }
                None => {
                    self.stuck = false;
                    self.events.slip_onsets_s.push(now);
                }
            }
        }
        if !self.stuck {
            let v_rel = self.vz_mm_s - hand_v;
            let speed = v_rel.abs();
            // Each patch slides over its strip of the object; the friction it carries is
            // what holds the object up.
            let mut up_n = 0.0;
            for (i, (sensor, patch)) in self.sensors.iter().zip(&mut self.patches).enumerate() {
                let f = patch.step(
                    &sensor.skin,
                    &self.friction,
                    &self.textures[i],
                    -v_rel * dt,
                    speed,
                    self.normal_n[i],
                );
                tangential[i] = f;
                up_n += f;
                self.shear_target_mm[i] = patch.shear_mm;
                self.across_target_mm[i] = 0.0;
                self.carried_mm[i] = sensor.skin.contact_radius_mm(self.normal_n[i]);
                self.stuck_load[i] = None;
            }
            // A centre of mass off the pinch axis: the object turns about it as it slides,
            // and the fingers' friction, opposing each contact's slip, also makes a couple.
            let mut turn_accel = 0.0;
            if let Geometry::Hand { gravity } = self.geometry {
                if self.object.com_offset_mm != 0.0 {
                    let before = self.turn_rate_rad_s;
                    let step = self.turn_step(&tangential, gravity, m, g, v_rel, on_support, dt);
                    up_n = step.support_n;
                    // Each patch's shear follows its friction's split: along the slip
                    // axis what holds the object up, across it the couple's share.
                    for (i, friction) in tangential.iter().enumerate().take(skins.min(3)) {
                        let whole = friction.abs();
                        if whole > 0.0 {
                            let u = self.patches[i].shear_mm.abs() / whole;
                            self.shear_target_mm[i] = u * step.each_n[i];
                            self.across_target_mm[i] = u * roll_sense(step.across_n[i]);
                        }
                    }
                    tangential[..3].copy_from_slice(&step.each_n);
                    approach = step.across_n;
                    turn_accel = self.vertical_turn_accel_mm_s2(gravity, before, dt);
                }
            }
            // The rail's guides: plain sliding friction against the object's motion.
            let direction = if v_rel < -1e-9 {
                1.0
            } else if v_rel > 1e-9 {
                -1.0
            } else {
                need_n.signum()
            };
            for (i, c) in contacts.iter().enumerate().skip(skins) {
                tangential[i] = direction * c.mu_kinetic * c.normal_n;
                up_n += tangential[i];
            }
            slip_axis.copy_from_slice(&tangential[..3]);
            // The centre of mass moves as the forces say; the grasp point less what the
            // turn moves the centre of mass relative to it.
            let a = (up_n / m - g) * 1000.0 - turn_accel;
            self.accel_mm_s2 = a;
            self.z_mm += self.vz_mm_s * dt + 0.5 * a * dt * dt;
            self.vz_mm_s += a * dt;
            if let Some(s) = self.support_mm {
                if self.z_mm <= s {
                    self.z_mm = s;
                    self.vz_mm_s = self.vz_mm_s.max(0.0);
                }
            }
            let v_rel_new = self.vz_mm_s - hand_v;
            let crossed = v_rel_new.abs() < 1e-9 || v_rel_new.signum() != v_rel.signum();
            if self.in_grasp
                && crossed
                && v_rel.abs() > 1e-9
                && self.stuck_share(need_n, contacts).is_some()
            {
                self.stuck = true;
                self.vz_mm_s = hand_v;
                self.turn_rate_rad_s = 0.0;
                self.events.catches_s.push(now);
            }
        }
        if self.in_grasp {
            let slid = (self.z_mm - self.hand_z()) - self.grasp_offset_mm;
            if slid.abs() > self.object.length_mm / 2.0 {
                self.in_grasp = false;
                self.stuck = false;
            }
        }
        self.track_fall();
        if self.events.drop_s.is_none() && (!self.in_grasp || self.held_mm - self.z_mm > drop_limit)
        {
            self.events.drop_s = Some(now);
        }
        self.tangential_n.copy_from_slice(&tangential[..3]);
        self.approach_n = approach;
        self.slip_axis_n = slip_axis;
        self.local_slip.copy_from_slice(&local_slip[..3]);
        self.update_curls(true);
        self.update_skins(dt);
        self.capture_frames(now);
        self.capture_markers(now);
    }

    /// One step of the object's turn about the pinch axis while it slides ([`turn`]): the
    /// load at the centre of mass (its weight and what the grasp point's acceleration
    /// asks) is a moment about the pinch axis; the contacts' frictions `tangential` (along
    /// the slip axis) hold it as far as they can. Updates the turn and its rate; gives the
    /// contacts' support.
    #[allow(clippy::too_many_arguments)]
    fn turn_step(
        &mut self,
        tangential: &[f64; MAX_CONTACTS],
        gravity: [f64; 3],
        mass_kg: f64,
        g: f64,
        v_rel: f64,
        on_support: bool,
        dt: f64,
    ) -> turn::TurnStep {
        let load_n = mass_kg * (g + self.accel_mm_s2 / 1000.0);
        let [_, y, w] = self.com_from_grasp_mm();
        let moment_n_mm = load_n * (y * gravity[2] - w * gravity[1]);
        let lever = [
            0.0,
            self.cfg.physics.finger_half_spacing_mm,
            self.cfg.physics.finger_half_spacing_mm,
        ];
        let contacts: [turn::TurnContact; 3] = std::array::from_fn(|i| turn::TurnContact {
            friction_n: tangential[i],
            lever_mm: lever[i],
            patch_radius_mm: self
                .sensors
                .get(i)
                .map_or(0.0, |s| s.skin.contact_radius_mm(self.normal_n[i])),
        });
        let inertia = turn::pivot_inertia_kg_mm2(
            mass_kg,
            self.object.length_mm,
            self.object.width_mm,
            self.object.com_offset_mm,
        );
        let step = turn::step(
            &contacts,
            self.turn_rate_rad_s,
            moment_n_mm,
            inertia,
            v_rel,
            dt,
        );
        // an object resting on the table does not swing through it
        let rate = if on_support { 0.0 } else { step.rate_rad_s };
        self.turn_rad += 0.5 * (self.turn_rate_rad_s + rate) * dt;
        self.turn_rate_rad_s = rate;
        step
    }

    /// The vertical (world, up) acceleration of the centre of mass relative to the grasp
    /// point that the turn gives, from the rate `before` this step to now, mm/s^2.
    fn vertical_turn_accel_mm_s2(&self, gravity: [f64; 3], before: f64, dt: f64) -> f64 {
        let omega = self.turn_rate_rad_s;
        let alpha = (omega - before) / dt;
        let [_, y, w] = self.com_from_grasp_mm();
        // d'' = alpha (x cross d) - omega^2 d, with x cross (0, y, w) = (0, -w, y)
        let accel = [
            0.0,
            -alpha * w - omega * omega * y,
            alpha * y - omega * omega * w,
        ];
        -(accel[1] * gravity[1] + accel[2] * gravity[2])
    }

    /// The under-actuated fingers curl as they press past first touch, so each fingertip
    /// moves along the object and shears its skin, less what the object's own move along
    /// the approach axis takes up (a fingertip-held object is free along it; the rail's
    /// guides hold it), and slips along the object on its own where friction, after the
    /// load it carries for the grasp, cannot hold that shear ([`crate::curl`]). `record`:
    /// note each patch that breaks free while the grasp holds (false when the grasp is set
    /// before the simulation starts).
    fn update_curls(&mut self, record: bool) {
        let ratio = self.cfg.physics.finger_roll_ratio;
        let (mu_s, mu_k) = (self.object.mu_static, self.object.mu_kinetic);
        let now = self.now_s();
        let mut inputs = [None; 3];
        for (i, input) in inputs.iter_mut().enumerate().take(self.sensors.len()) {
            let n = self.normal_n[i];
            if n <= 0.0 || !self.in_grasp {
                continue;
            }
            // The power law of the patch's stiffness costs most of this: only a change of
            // normal force changes the full-slip shear.
            if self.rolled_at_n[i] != n {
                self.rolled_at_n[i] = n;
                self.full_slip_mm[i] = self.sensors[i].skin.full_slip_shear_mm(n, mu_s);
            }
            let friction = mu_s * n;
            *input = Some(CurlInput {
                demand_mm: ratio * self.pressed_mm[i],
                limits: CurlLimits {
                    full_slip_mm: self.full_slip_mm[i],
                    // the curl pulls the object towards the palm, -y
                    along_share: -self.approach_n[i] / friction,
                    across_share: self.slip_axis_n[i].abs() / friction,
                    kinetic_ratio: mu_k / mu_s,
                },
                stiffness: n / self.full_slip_mm[i].max(1e-12),
            });
        }
        // Held by the fingertips alone the object is free along the approach axis; the
        // rail's guides hold it there, and so does the table's friction while it rests on
        // the table (before a lift, or once it has fallen back).
        let on_support = self.support_mm.is_some_and(|s| self.z_mm <= s + 1e-9);
        let axis = match self.geometry {
            Geometry::Hand { .. } if !on_support => ApproachAxis::Free,
            _ => ApproachAxis::Held,
        };
        let outcomes = self.curl.step(&inputs, axis, !record);
        for (i, outcome) in outcomes.iter().enumerate().take(self.sensors.len()) {
            self.roll_target_mm[i] = outcome.shear_mm;
            if outcome.slide_mm.is_some() && self.stuck {
                let e = &mut self.events;
                e.contact_slips[i] += 1;
                e.contact_first_slip_s[i].get_or_insert(now);
                if e.contact_slip_times_s[i].len() < MAX_SLIP_TIMES {
                    e.contact_slip_times_s[i].push(now);
                }
            }
        }
    }

    /// Share of the object's weight the grasp carries at `now`. An object that starts held
    /// (on the rail, or in the hand) is let go by whatever held it before the trial (the
    /// operator's hand, the rig's support) over `physics.load_transfer_s`, smoothly: its
    /// weight passes to the fingertips over that time, not in one step.
    fn load_transferred(&self, now: f64) -> f64 {
        let released_at = match &self.cfg.rig {
            RigSetup::Rail(r) => r.support_release_s,
            RigSetup::Hand(h) if h.start == ObjectStart::InHand => 0.0,
            RigSetup::Hand(_) => return 1.0,
        };
        let span = self.cfg.physics.load_transfer_s;
        if now >= released_at + span {
            return 1.0;
        }
        let x = (now - released_at).max(0.0) / span;
        x * x * (3.0 - 2.0 * x)
    }

    /// Ground truth of how far the object has fallen in the grasp (diagnostics only).
    fn track_fall(&mut self) {
        let relative = self.z_mm - self.hand_z();
        if self.stuck && self.in_grasp {
            self.held_relative_mm = Some(relative);
            return;
        }
        let Some(held) = self.held_relative_mm else {
            return;
        };
        let fall = held - relative;
        self.events.max_fall_mm = self.events.max_fall_mm.max(fall);
        if fall > MEASURABLE_FALL_MM && self.events.measurable_slip_s.is_none() {
            self.events.measurable_slip_s = self.events.slip_onsets_s.last().copied();
        }
    }

    fn skin_times(&self) -> SkinTimes {
        let t = &self.cfg.tactip;
        SkinTimes {
            fast_s: t.skin_time_s,
            creep_s: t.creep_time_s,
            creep_fraction: t.creep_fraction,
            instant_fraction: t.instant_fraction,
        }
    }

    /// The pins follow the patch with the skin's viscoelastic lag and creep.
    fn update_skins(&mut self, dt: f64) {
        let times = self.skin_times();
        for (i, s) in self.sensors.iter_mut().enumerate() {
            let n = self.normal_n[i];
            let (shear, roll) = if n > 0.0 {
                (
                    self.shear_target_mm[i],
                    self.roll_target_mm[i] + self.across_target_mm[i],
                )
            } else {
                (0.0, 0.0)
            };
            // The Hertz power law costs most of a step; a steady grip keeps its indentation.
            if s.indentation_target.0 != n {
                s.indentation_target = (n, s.skin.indentation_mm(n));
            }
            s.shear_mm.step(shear, dt, &times);
            s.roll_mm.step(roll, dt, &times);
            s.indentation_mm.step(s.indentation_target.1, dt, &times);
        }
    }

    fn capture_frames(&mut self, now: f64) {
        let times = self.skin_times();
        let t = &self.cfg.tactip;
        let faults = &self.cfg.faults;
        let noise = Normal::new(0.0, t.noise_px.max(1e-12)).expect("valid normal");
        let jitter = Normal::new(0.0, t.frame_jitter_s.max(1e-12)).expect("valid normal");
        let sliding_mm_s = if self.stuck {
            0.0
        } else {
            (self.vz_mm_s - self.arm.velocity_mm_s[2]).abs()
        };
        for (i, s) in self.sensors.iter_mut().enumerate() {
            while s.next_capture_s <= now {
                s.next_capture_s += s.period_s;
                s.seq += 1;
                let time = (now + jitter.sample(&mut s.rng).abs()).max(s.last_time_s);
                if s.rng.gen_bool(faults.dropped_frame) {
                    continue;
                }
                let pins: Vec<[f32; 2]> = match (&s.last_pins, s.rng.gen_bool(faults.stale_frame)) {
                    (Some(last), true) => last.clone(),
                    _ => {
                        let n = self.normal_n[i];
                        let skin = SkinState {
                            indentation_mm: s.indentation_mm.shown(&times),
                            contact_radius_px: s.skin.contact_radius_mm(n) * s.px_per_mm,
                            carried_radius_px: self.carried_mm[i] * s.px_per_mm,
                            shear_px: s.shear_mm.shown(&times) * s.px_per_mm,
                            roll_px: s.roll_mm.shown(&times) * s.px_per_mm,
                        };
                        pin_positions(&s.optics, &skin, &mut s.scratch);
                        // Each spot of the contact is dragged by the friction of the surface
                        // under it, not the patch's mean. The texture sums cost more than the
                        // rest of a frame: a contact that has not moved reuses them.
                        let (texture, slid_mm) = (&self.textures[i], self.patches[i].position_mm);
                        let (a_mm, px_per_mm) = (s.skin.contact_radius_mm(n), s.px_per_mm);
                        let key = [slid_mm, a_mm, sliding_mm_s];
                        if s.local_key != Some(key) {
                            s.local_key = Some(key);
                            local_shear_factors(
                                &s.optics,
                                skin.contact_radius_px,
                                |xi_px| {
                                    texture.local_at(
                                        slid_mm + xi_px / px_per_mm,
                                        a_mm,
                                        sliding_mm_s,
                                        &times,
                                    )
                                },
                                &mut s.local_factors,
                            );
                        }
                        add_local_shear(&s.optics, &s.local_factors, skin.shear_px, &mut s.scratch);
                        if self.stuck {
                            s.elements.hold();
                        } else {
                            let friction = &self.friction;
                            let k = s.skin.tangential_stiffness(n);
                            let excess = friction.mu_static - friction.mu(sliding_mm_s);
                            let cycle_mm = if k > 0.0 && excess > 0.0 {
                                3.0 * excess * n / k
                            } else {
                                0.0
                            };
                            s.elements.advance(
                                slid_mm,
                                s.optics.contact_elements(skin.contact_radius_px, px_per_mm),
                                |x| cycle_mm * (1.0 + texture.at(x)).max(0.0),
                                &mut s.element_shift_mm,
                            );
                            // A cycle lasts `cycle / v`: the spot is carried with the
                            // surface while it sticks, and shows as much of the sawtooth as
                            // the skin springs back within one cycle.
                            let shown = if cycle_mm > 0.0 && sliding_mm_s > 0.0 {
                                times.releases_within(cycle_mm / sliding_mm_s)
                            } else {
                                0.0
                            };
                            let direction = self.patches[i].shear_mm.signum();
                            s.optics
                                .spread_elements(&s.element_shift_mm, &mut s.element_spread_mm);
                            add_local_shear(
                                &s.optics,
                                &s.element_spread_mm,
                                direction * shown * px_per_mm,
                                &mut s.scratch,
                            );
                        }
                        let mut pins = Vec::with_capacity(s.scratch.len());
                        // At most one pin per frame is mis-detected: with the rates seen on
                        // real trackers (well under 1 %) two in one frame are negligible, and one
                        // draw per frame instead of per pin keeps frame generation cheap.
                        let misdetected = if faults.pin_misdetect > 0.0 {
                            let p_frame =
                                1.0 - (1.0 - faults.pin_misdetect).powi(s.scratch.len() as i32);
                            s.rng
                                .gen_bool(p_frame)
                                .then(|| s.rng.gen_range(0..s.scratch.len()))
                        } else {
                            None
                        };
                        for (j, &[x, y]) in s.scratch.iter().enumerate() {
                            let (mut x, mut y) =
                                (x + noise.sample(&mut s.rng), y + noise.sample(&mut s.rng));
                            if misdetected == Some(j) {
                                // The blob detector latched onto something else in the image.
                                x = s.rng.gen_range(0.0..t.image_px[0]);
                                y = s.rng.gen_range(0.0..t.image_px[1]);
                            }
                            pins.push([x as f32, y as f32]);
                        }
                        pins
                    }
                };
                s.last_pins = Some(pins.clone());
                s.last_time_s = time;
                if s.queue.len() >= SENSOR_QUEUE_LIMIT {
                    s.queue.pop_front();
                }
                s.queue.push_back(PinFrame {
                    sensor: i as u8,
                    seq: s.seq,
                    time_s: time,
                    pins,
                });
            }
        }
    }

    fn capture_markers(&mut self, now: f64) {
        let noise = Normal::new(0.0, self.cfg.marker.noise_mm.max(1e-12)).expect("valid normal");
        let hand_marker = self.hand_z() + self.cfg.arm.hand_marker_offset_mm;
        let mk = &mut self.markers;
        while mk.next_s <= now {
            mk.next_s += mk.period_s;
            let sample = MarkerSample {
                time_s: now,
                object_mm: self.z_mm + noise.sample(&mut mk.rng),
                hand_mm: hand_marker + noise.sample(&mut mk.rng),
            };
            if mk.queue.len() >= SENSOR_QUEUE_LIMIT {
                mk.queue.pop_front();
            }
            mk.queue.push_back(sample);
        }
    }

    pub(crate) fn truth(&self) -> TruthState {
        let times = self.skin_times();
        let n = self.sensors.len();
        TruthState {
            time_s: self.now_s(),
            object_mm: self.z_mm,
            object_velocity_mm_s: self.vz_mm_s,
            hand_mm: self.hand_z(),
            hand_velocity_mm_s: self.arm.velocity_mm_s[2],
            mass_g: self.mass_kg() * 1000.0,
            normal_n: self.normal_n[..n].to_vec(),
            tangential_n: self.tangential_n[..n].to_vec(),
            local_slip: self.local_slip[..n].to_vec(),
            indentation_mm: self
                .sensors
                .iter()
                .zip(&self.normal_n)
                .map(|(s, f)| s.skin.indentation_mm(*f))
                .collect(),
            shear_px: self
                .sensors
                .iter()
                .map(|s| s.shear_mm.shown(&times) * s.px_per_mm)
                .collect(),
            roll_px: self
                .sensors
                .iter()
                .map(|s| s.roll_mm.shown(&times) * s.px_per_mm)
                .collect(),
            sliding: !self.stuck,
            capacity_n: self.capacity_n,
            weight_n: self.mass_kg() * self.cfg.physics.gravity_m_s2,
            in_grasp: self.in_grasp,
            dropped: self.events.drop_s.is_some(),
            finger_positions: self.present_positions(),
            servo_positions: self.servos.position,
            turn_deg: self.turn_rad.to_degrees(),
            contact_slid_mm: (0..n)
                .map(|i| self.curl.contact(i).travelled_mm())
                .collect(),
        }
    }
}

fn validate(cfg: &SimConfig) -> Result<(), SimError> {
    cfg.check().map_err(|problem| SimError::Config {
        origin: "sim config".into(),
        message: problem.to_string(),
    })
}
