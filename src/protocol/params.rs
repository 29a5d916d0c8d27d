//! Per-kind protocol parameters with the paper's values as defaults, and their checks.
//! A check failure is `(section, field, what was expected)`.

use serde::{Deserialize, Serialize};

use super::{Kind, KindParams};

type Check = Result<(), (&'static str, &'static str, String)>;

fn in_range(section: &'static str, field: &'static str, v: f64, lo: f64, hi: f64) -> Check {
    if v.is_finite() && v >= lo && v <= hi {
        Ok(())
    } else {
        Err((
            section,
            field,
            format!(
                "expected a value in {lo}..={hi}, got {}",
                crate::quote::number(v)
            ),
        ))
    }
}

/// Slip onset and drop, as scored from the marker track.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct Outcome {
    /// Fall below the held height that marks slip onset, mm.
    pub onset_threshold_mm: f64,
    /// Fall below the held height that counts as dropped, mm.
    pub drop_limit_mm: f64,
}

impl Default for Outcome {
    fn default() -> Self {
        Self {
            onset_threshold_mm: 1.0,
            drop_limit_mm: 80.0,
        }
    }
}

impl Outcome {
    pub fn check(&self) -> Result<(), (&'static str, String)> {
        in_range(
            "outcome",
            "onset_threshold_mm",
            self.onset_threshold_mm,
            0.1,
            50.0,
        )
        .and_then(|_| in_range("outcome", "drop_limit_mm", self.drop_limit_mm, 1.0, 1000.0))
        .map_err(|(_, f, m)| (f, m))?;
        if self.drop_limit_mm <= self.onset_threshold_mm {
            return Err((
                "drop_limit_mm",
                format!(
                    "expected more than onset_threshold_mm ({}), got {}",
                    self.onset_threshold_mm,
                    crate::quote::number(self.drop_limit_mm)
                ),
            ));
        }
        Ok(())
    }
}

/// Limits the runner checks before any command reaches a device (`[safety]`).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct SafetyLimits {
    /// Largest finger target, fraction of the closing range.
    pub max_grip: f64,
    /// Largest finger torque limit, fraction of the maximum.
    pub max_torque: f64,
    /// Fastest arm motion, mm/s.
    pub max_arm_speed_mm_s: f64,
    /// Furthest the TCP may be from where it started, per axis, mm.
    #[serde(deserialize_with = "super::exact::exactly")]
    pub workspace_mm: [f64; 3],
}

impl Default for SafetyLimits {
    fn default() -> Self {
        Self {
            max_grip: 0.95,
            max_torque: 1.0,
            max_arm_speed_mm_s: 100.0,
            workspace_mm: [50.0, 50.0, 250.0],
        }
    }
}

impl SafetyLimits {
    /// The stricter of two sets of limits, limit by limit (a protocol's within a rig's).
    pub fn tightest(&self, other: &SafetyLimits) -> SafetyLimits {
        let w = |k: usize| self.workspace_mm[k].min(other.workspace_mm[k]);
        SafetyLimits {
            max_grip: self.max_grip.min(other.max_grip),
            max_torque: self.max_torque.min(other.max_torque),
            max_arm_speed_mm_s: self.max_arm_speed_mm_s.min(other.max_arm_speed_mm_s),
            workspace_mm: [w(0), w(1), w(2)],
        }
    }

    pub fn check(&self) -> Check {
        let s = "safety";
        in_range(s, "max_grip", self.max_grip, 0.05, 1.0)?;
        in_range(s, "max_torque", self.max_torque, 0.05, 1.0)?;
        in_range(s, "max_arm_speed_mm_s", self.max_arm_speed_mm_s, 1.0, 250.0)?;
        self.workspace_mm
            .iter()
            .try_for_each(|w| in_range(s, "workspace_mm", *w, 1.0, 1000.0))
    }
}

/// Single finger on the slip rail.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct RailCatch {
    /// Arm retraction speed drawn uniformly from this range, mm/s.
    #[serde(deserialize_with = "super::exact::exactly")]
    pub retract_speed_mm_s: [f64; 2],
    /// On slip: arm moves this far forward, mm.
    pub forward_mm: f64,
    /// Finger torque limit at the start, fraction of the maximum: what presses the object
    /// against the rail.
    pub initial_torque: f64,
    /// On slip: finger torque limit rises by this fraction of its maximum.
    pub torque_step: f64,
    /// Trial length limit, s.
    pub max_duration_s: f64,
}

impl Default for RailCatch {
    fn default() -> Self {
        Self {
            retract_speed_mm_s: [0.1, 5.0],
            forward_mm: 1.5,
            // ours: the paper does not give it
            initial_torque: 0.8,
            // "rises a little" in the paper; 5 % is ours
            torque_step: 0.05,
            max_duration_s: 30.0,
        }
    }
}

/// Whole-hand pinch grasp released slowly until slip.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct HandRelease {
    /// Finger opening speed as a fraction of the servos' maximum speed.
    pub release_speed_of_max: f64,
    /// On slip: close to this fraction of the range tighter than the starting grasp.
    pub regrasp: f64,
    /// Lift before the release, mm; online trials must lift above the drop limit so a
    /// drop can be told from the marker track.
    pub lift_mm: f64,
    /// Hold before the release, s.
    pub hold_s: f64,
    pub max_duration_s: f64,
    /// The starting grasp as found on any rig: close until contact (every sensor's
    /// deformation at `contact_deformation_px`), then this much further, fraction of the
    /// range — one value, or a table per object (`default` for the rest). Without it the
    /// simulator uses its own holding closure (x 1.2..1.8); the real backend needs it.
    pub grasp_past_contact: Option<PerObject>,
    pub contact_deformation_px: f64,
    /// Closing speed while looking for contact, fraction of the servos' maximum speed.
    pub approach_speed_of_max: f64,
    /// Masses added to the object, g, each a level of the grid (the paper's cat with a
    /// 100 g mass adhered to it).
    pub masses_g: Vec<f64>,
    /// Speed of the lift before the release, mm/s.
    pub lift_speed_mm_s: f64,
}

impl Default for HandRelease {
    fn default() -> Self {
        Self {
            release_speed_of_max: 0.005,
            regrasp: 0.02,
            lift_mm: 120.0,
            hold_s: 1.0,
            max_duration_s: 60.0,
            grasp_past_contact: None,
            contact_deformation_px: 0.5,
            approach_speed_of_max: 0.01,
            masses_g: vec![0.0],
            lift_speed_mm_s: 40.0,
        }
    }
}

/// A value for every object, or per object with an optional `default`.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(untagged)]
pub enum PerObject {
    All(f64),
    Each(std::collections::BTreeMap<String, f64>),
}

impl PerObject {
    pub fn get(&self, object: &str) -> Option<f64> {
        match self {
            PerObject::All(v) => Some(*v),
            PerObject::Each(m) => m.get(object).or_else(|| m.get("default")).copied(),
        }
    }
}

/// Light grasp while rice is poured in.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct RicePour {
    /// Mass added per second, g/s (ours: the paper pours by hand).
    pub pour_rate_g_per_s: f64,
    /// Mass poured in all, g.
    pub total_g: f64,
    /// On slip: tighten by this fraction of the range.
    pub regrasp: f64,
    pub max_duration_s: f64,
    /// The light grasp as found on any rig (an operator holds the empty container between
    /// the open fingers): close until contact, then this much further, fraction of the
    /// range (one value, or per object). Without it the trial starts from the grasp the
    /// hand has (the simulator's: 1.2 x the friction the object needs); the real backend
    /// needs it.
    pub grasp_past_contact: Option<PerObject>,
    pub contact_deformation_px: f64,
    pub approach_speed_of_max: f64,
}

impl Default for RicePour {
    fn default() -> Self {
        Self {
            pour_rate_g_per_s: 40.0,
            total_g: 400.0,
            regrasp: 0.02,
            max_duration_s: 60.0,
            grasp_past_contact: None,
            contact_deformation_px: 0.5,
            approach_speed_of_max: 0.01,
        }
    }
}

/// Close until contact, lift, tighten on every slip.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct FirstTimeLift {
    /// Mean pin displacement that counts as contact, px (on every sensor).
    pub deformation_px: f64,
    /// Closing speed while looking for contact, fraction of the servos' maximum speed.
    pub approach_speed_of_max: f64,
    pub lift_speed_mm_s: f64,
    pub lift_height_mm: f64,
    /// Hold at the top before the lift is judged and the object lowered, s.
    pub hold_s: f64,
    /// On slip: close by this fraction of the range, then pause.
    pub close_step: f64,
    pub pause_s: f64,
    /// Masses added to the object, g (one grid level each). The paper's crisps can, empty
    /// (50 g) and filled, weighs 50, 100, 150, 200, 300, 400 and 500 g in all.
    pub masses_g: Vec<f64>,
    /// The g_min table a `calibrate_lift` batch wrote (`g_min.json`), for overgrasp;
    /// relative to the protocol file.
    pub calibration: Option<std::path::PathBuf>,
}

impl Default for FirstTimeLift {
    fn default() -> Self {
        Self {
            deformation_px: 0.5,
            // "slowly closing the hand" in the paper; 1 % of full speed is ours
            approach_speed_of_max: 0.01,
            lift_speed_mm_s: 17.0,
            lift_height_mm: 50.0,
            hold_s: 1.0,
            close_step: 0.01,
            pause_s: 0.1,
            // the paper's seven totals, 50..500 g, on the empty can (50 g)
            masses_g: vec![0.0, 50.0, 100.0, 150.0, 250.0, 350.0, 450.0],
            calibration: None,
        }
    }
}

/// The systematic sweep that finds g_min: the smallest closure that lifts the object.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct Calibration {
    pub deformation_px: f64,
    pub approach_speed_of_max: f64,
    /// Closure step between attempts past contact, fraction of the range.
    pub step: f64,
    pub lift_speed_mm_s: f64,
    pub lift_height_mm: f64,
    pub hold_s: f64,
    /// An attempt lifts the object if the hand slid up it by at most this, mm.
    pub max_slide_mm: f64,
    pub masses_g: Vec<f64>,
}

impl Default for Calibration {
    fn default() -> Self {
        let lift = FirstTimeLift::default();
        Self {
            deformation_px: lift.deformation_px,
            approach_speed_of_max: lift.approach_speed_of_max,
            step: 0.005,
            lift_speed_mm_s: lift.lift_speed_mm_s,
            lift_height_mm: lift.lift_height_mm,
            hold_s: lift.hold_s,
            // ours: twice the marker tracker's noise, well below a slide
            max_slide_mm: 2.0,
            masses_g: lift.masses_g,
        }
    }
}

fn masses(section: &'static str, m: &[f64]) -> Check {
    if m.is_empty() {
        return Err((section, "masses_g", "expected at least one mass".into()));
    }
    m.iter()
        .try_for_each(|v| in_range(section, "masses_g", *v, 0.0, 2000.0))
}

/// Speed of the rail's catch move forward, mm/s (not a protocol field: checked against
/// `safety.max_arm_speed_mm_s` at load all the same).
pub const RAIL_FORWARD_SPEED_MM_S: f64 = 20.0;

impl KindParams {
    /// The longest a trial of this kind runs, s, where the protocol sets one.
    pub fn max_duration_s(&self) -> Option<f64> {
        match self {
            KindParams::RailCatch(p) => Some(p.max_duration_s),
            KindParams::HandRelease(p) => Some(p.max_duration_s),
            KindParams::RicePour(p) => Some(p.max_duration_s),
            KindParams::FirstTimeLift(_) | KindParams::CalibrateLift(_) => None,
        }
    }

    /// Motions and forces the protocol asks for, against the safety limit each must respect:
    /// `(field, value, limit, limit's field)`. Every motion a trial may command is here, so
    /// a protocol the limits refuse is refused at load, not mid-trial.
    pub fn demands(&self, l: &SafetyLimits) -> Vec<(&'static str, f64, f64, &'static str)> {
        let (speed, reach) = ("safety.max_arm_speed_mm_s", "safety.workspace_mm");
        let (v, z) = (l.max_arm_speed_mm_s, l.workspace_mm[2]);
        match self {
            KindParams::RailCatch(p) => vec![
                (
                    "rail_catch.retract_speed_mm_s",
                    p.retract_speed_mm_s[1],
                    v,
                    speed,
                ),
                (
                    "rail_catch.forward_mm",
                    p.forward_mm,
                    l.workspace_mm[0],
                    reach,
                ),
                (
                    "rail_catch.initial_torque",
                    p.initial_torque,
                    l.max_torque,
                    "safety.max_torque",
                ),
                // the reaction raises the torque once: refused, never clipped
                (
                    "rail_catch.torque_step",
                    p.initial_torque + p.torque_step,
                    l.max_torque,
                    "safety.max_torque (initial_torque + torque_step)",
                ),
                (
                    "rail_catch (the catch moves forward at a fixed 20 mm/s)",
                    RAIL_FORWARD_SPEED_MM_S,
                    v,
                    speed,
                ),
            ],
            KindParams::HandRelease(p) => vec![
                ("hand_release.lift_mm", p.lift_mm, z, reach),
                ("hand_release.lift_speed_mm_s", p.lift_speed_mm_s, v, speed),
            ],
            KindParams::RicePour(_) => vec![],
            KindParams::FirstTimeLift(p) => vec![
                (
                    "first_time_lift.lift_speed_mm_s",
                    p.lift_speed_mm_s,
                    v,
                    speed,
                ),
                ("first_time_lift.lift_height_mm", p.lift_height_mm, z, reach),
            ],
            KindParams::CalibrateLift(p) => vec![
                (
                    "calibrate_lift.lift_speed_mm_s",
                    p.lift_speed_mm_s,
                    v,
                    speed,
                ),
                ("calibrate_lift.lift_height_mm", p.lift_height_mm, z, reach),
            ],
        }
    }

    pub fn check(&self) -> Check {
        match self {
            KindParams::RailCatch(p) => {
                let s = "rail_catch";
                let [lo, hi] = p.retract_speed_mm_s;
                in_range(s, "retract_speed_mm_s", lo, 0.01, 50.0)?;
                in_range(s, "retract_speed_mm_s", hi, lo, 50.0)?;
                in_range(s, "forward_mm", p.forward_mm, 0.0, 10.0)?;
                in_range(s, "initial_torque", p.initial_torque, 0.05, 1.0)?;
                in_range(s, "torque_step", p.torque_step, 0.0, 0.5)?;
                in_range(s, "max_duration_s", p.max_duration_s, 1.0, 600.0)
            }
            KindParams::HandRelease(p) => {
                let s = "hand_release";
                in_range(s, "release_speed_of_max", p.release_speed_of_max, 1e-4, 0.5)?;
                in_range(s, "regrasp", p.regrasp, 0.0, 0.2)?;
                in_range(s, "lift_mm", p.lift_mm, 0.0, 300.0)?;
                in_range(s, "lift_speed_mm_s", p.lift_speed_mm_s, 1.0, 250.0)?;
                in_range(s, "hold_s", p.hold_s, 0.0, 60.0)?;
                in_range(s, "max_duration_s", p.max_duration_s, 1.0, 600.0)?;
                masses(s, &p.masses_g)?;
                contact_grasp_check(
                    s,
                    p.grasp_past_contact.as_ref(),
                    p.contact_deformation_px,
                    p.approach_speed_of_max,
                )
            }
            KindParams::RicePour(p) => {
                let s = "rice_pour";
                in_range(s, "pour_rate_g_per_s", p.pour_rate_g_per_s, 0.1, 1000.0)?;
                in_range(s, "total_g", p.total_g, 1.0, 2000.0)?;
                in_range(s, "regrasp", p.regrasp, 0.0, 0.2)?;
                in_range(s, "max_duration_s", p.max_duration_s, 1.0, 600.0)?;
                contact_grasp_check(
                    s,
                    p.grasp_past_contact.as_ref(),
                    p.contact_deformation_px,
                    p.approach_speed_of_max,
                )
            }
            KindParams::FirstTimeLift(p) => {
                let s = "first_time_lift";
                in_range(s, "deformation_px", p.deformation_px, 0.01, 20.0)?;
                in_range(s, "lift_speed_mm_s", p.lift_speed_mm_s, 0.1, 250.0)?;
                in_range(s, "lift_height_mm", p.lift_height_mm, 1.0, 300.0)?;
                in_range(s, "close_step", p.close_step, 1e-4, 0.2)?;
                in_range(
                    s,
                    "approach_speed_of_max",
                    p.approach_speed_of_max,
                    1e-4,
                    0.5,
                )?;
                in_range(s, "hold_s", p.hold_s, 0.0, 60.0)?;
                in_range(s, "pause_s", p.pause_s, 0.0, 10.0)?;
                masses(s, &p.masses_g)
            }
            KindParams::CalibrateLift(p) => {
                let s = "calibrate_lift";
                in_range(s, "deformation_px", p.deformation_px, 0.01, 20.0)?;
                in_range(s, "step", p.step, 1e-4, 0.2)?;
                in_range(
                    s,
                    "approach_speed_of_max",
                    p.approach_speed_of_max,
                    1e-4,
                    0.5,
                )?;
                in_range(s, "hold_s", p.hold_s, 0.0, 60.0)?;
                in_range(s, "max_slide_mm", p.max_slide_mm, 0.1, 100.0)?;
                in_range(s, "lift_speed_mm_s", p.lift_speed_mm_s, 0.1, 250.0)?;
                in_range(s, "lift_height_mm", p.lift_height_mm, 1.0, 300.0)?;
                masses(s, &p.masses_g)
            }
        }
    }
}

/// The fields of a grasp from contact (hand release, rice pour).
fn contact_grasp_check(
    s: &'static str,
    past_contact: Option<&PerObject>,
    deformation_px: f64,
    approach_speed_of_max: f64,
) -> Check {
    let past = match past_contact {
        None => vec![],
        Some(PerObject::All(v)) => vec![*v],
        Some(PerObject::Each(m)) => m.values().copied().collect(),
    };
    for v in past {
        in_range(s, "grasp_past_contact", v, 0.0, 0.5)?;
    }
    in_range(s, "contact_deformation_px", deformation_px, 0.01, 20.0)?;
    in_range(s, "approach_speed_of_max", approach_speed_of_max, 1e-4, 0.5)
}

/// The paper's five whole-hand training objects (black titles in its Fig. 6).
pub const PAPER_TRAINING_OBJECTS: [&str; 5] = [
    "crisps_can",
    "windex_bottle",
    "bleach_bottle",
    "mustard_bottle",
    "banana",
];

/// The paper's objects for each kind.
pub fn default_objects(kind: Kind) -> Vec<String> {
    let names: &[&str] = match kind {
        Kind::RailCatch => &["rail_object"],
        Kind::HandRelease => &PAPER_TRAINING_OBJECTS,
        // the paper pours rice into the empty can
        Kind::RicePour => &["crisps_can_empty"],
        Kind::FirstTimeLift | Kind::CalibrateLift => &["crisps_can_empty"],
    };
    names.iter().map(|s| s.to_string()).collect()
}

/// The paper's strategy grid for each kind.
pub fn default_strategies(kind: Kind) -> Vec<String> {
    let names: &[&str] = match kind {
        Kind::RailCatch => &["1x1", "2x1"],
        Kind::HandRelease => &["1x1", "2x1", "1x2", "2x2", "1x3", "2x3"],
        Kind::RicePour => &["2x2"],
        Kind::FirstTimeLift => &["1x1"],
        Kind::CalibrateLift => &[],
    };
    names.iter().map(|s| s.to_string()).collect()
}
