//! What each finding hinges on: every physical parameter of the simulator set in turn to
//! the low and the high end of its plausible range (`sim/data/parameters.toml`), the
//! reproduction run again with the same seeds (steps the parameter does not touch are taken
//! from the baseline), and each finding's verdict compared with the baseline's. A finding
//! whose verdict changes anywhere inside its parameters' plausible ranges is fragile.
//!
//! Beside them runs one noise reference: the baseline's parameters with other seeds (as
//! many replicates again, seeded as replicates K+1..2K). A finding whose verdict changes
//! there changes with the seeds alone: at this many replicates its verdict is not decided,
//! and a parameter that changes it says no more than a new seed would. The table keeps
//! such findings apart from the fragile and the robust ones.
//!
//! A study may also set a parameter to a value of its own, inside or outside its range
//! (`NAME=VALUE`): a **switch**, the configuration under which a finding kept as evidence
//! is shown able to fail (a row that no switch can fail is a pipeline check, not evidence).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use tmo_sim::parameters::{Basis, ParameterRecord};
use tmo_sim::SimConfig;

use super::findings::{Judged, Reproduced};

/// The file in a variant's directory that says why it could not be run to the end.
pub const FAILED: &str = "failed.txt";

/// One end of one parameter's plausible range.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Variant {
    pub parameter: String,
    /// "low" or "high" ("other seeds" for the noise reference).
    pub end: &'static str,
    pub value: f64,
    pub default: f64,
    /// The noise reference: no parameter changed, the seeds of other replicates.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub reseeded: bool,
    /// A switch's further settings, made together with the first (`A=1+B=2`): the null
    /// simulator, for one, is a mechanism off and the pin noise matched at once.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub also: Vec<(String, f64)>,
}

/// The noise reference's directory name under `<out>/sensitivity/`.
pub const RESEEDED: &str = "reseeded";

/// The `end` of a switch: a value given with the parameter's name, not an end of its range.
pub const SWITCH: &str = "switch";

impl Variant {
    /// The noise reference: the baseline's parameters, other seeds.
    pub fn reseeded() -> Self {
        Self {
            parameter: RESEEDED.into(),
            end: "other seeds",
            value: 0.0,
            default: 0.0,
            reseeded: true,
            also: Vec::new(),
        }
    }

    /// Its directory under `<out>/sensitivity/`.
    pub fn dir_name(&self) -> String {
        if self.reseeded {
            return RESEEDED.into();
        }
        if self.end == SWITCH {
            return std::iter::once((&self.parameter, self.value))
                .chain(self.also.iter().map(|(n, v)| (n, *v)))
                .map(|(n, v)| format!("{n}={v}"))
                .collect::<Vec<_>>()
                .join("+");
        }
        format!("{}@{}", self.parameter, self.end)
    }

    /// How many replicates its seeds are shifted by, in a study of `replicates`: the noise
    /// reference's replicate r is seeded as replicate `replicates + r`.
    pub fn seed_offset(&self, replicates: u32) -> u32 {
        if self.reseeded {
            replicates
        } else {
            0
        }
    }

    /// An end of the parameter's plausible range (not the noise reference, not a switch):
    /// what a finding's fragility is judged on.
    pub fn in_range(&self) -> bool {
        !self.reseeded && self.end != SWITCH
    }

    pub fn dir(&self, out: &Path) -> PathBuf {
        out.join("sensitivity").join(self.dir_name())
    }

    /// The parameters the variant sets: the simulator's, and protocol values
    /// ([`PROTOCOL_PREFIX`]) that the steps write into their protocols instead.
    pub fn sim(&self) -> BTreeMap<String, f64> {
        if self.reseeded {
            return BTreeMap::new();
        }
        std::iter::once((self.parameter.clone(), self.value))
            .chain(self.also.iter().cloned())
            .collect()
    }
}

/// Records of protocol values the reproduction's protocols use (the lifts' closing and
/// lifting speeds): procedure, not physics, but unsourced choices all the same, so a study
/// varies them. Each names a field of the lifts' protocol sections.
pub const PROTOCOL_PREFIX: &str = "protocol.";

/// The protocol values a study can vary, with the defaults the protocols take.
pub fn protocol_parameters() -> Vec<(String, f64)> {
    let lift = crate::protocol::FirstTimeLift::default();
    vec![
        (
            "protocol.lift.approach_speed_of_max".into(),
            lift.approach_speed_of_max,
        ),
        ("protocol.lift.lift_speed_mm_s".into(), lift.lift_speed_mm_s),
    ]
}

/// Every name a study can set: the simulator's parameters and the protocol values.
fn settable() -> Vec<String> {
    SimConfig::parameters()
        .into_iter()
        .chain(protocol_parameters())
        .map(|(n, _)| n)
        .collect()
}

/// Whether a record is a physical parameter with a range to vary, which the protocols can
/// set (`objects.*` records are not varied yet: the object library is not a protocol
/// parameter).
fn varied(r: &ParameterRecord, settable: &[String]) -> bool {
    r.basis != Basis::Convention
        && r.range[0] < r.range[1]
        && r.value.is_some()
        && settable.contains(&r.name)
}

/// The names of the records a study can vary (see [`variants`]).
pub fn variable(records: &[ParameterRecord]) -> Vec<String> {
    let settable = settable();
    records
        .iter()
        .filter(|r| varied(r, &settable))
        .map(|r| r.name.clone())
        .collect()
}

/// The variants to run: both ends of every varied parameter, or of the parameters named
/// in `only` (an unknown or unvaried name is an error naming it).
/// The parameters a study names, each once and in one order: `x,x` is the study `x`, and
/// `y,x` the study `x,y` (shards of one study named either way merge).
pub fn parameters_named(given: &[String]) -> Vec<String> {
    let mut named = given.to_vec();
    named.sort();
    named.dedup();
    named
}

pub fn variants(records: &[ParameterRecord], only: &[String]) -> Result<Vec<Variant>, String> {
    let settable = settable();
    for name in only {
        match records.iter().find(|r| &r.name == name) {
            None => {
                return Err(format!(
                    "`{name}` is not a simulator parameter (`tmo sim parameters` lists them)"
                ))
            }
            Some(r) if !varied(r, &settable) => {
                return Err(format!(
                    "`{name}` is not varied: a convention, a range of one value, or an object's property"
                ))
            }
            Some(_) => {}
        }
    }
    let mut out = Vec::new();
    for r in records {
        if !varied(r, &settable) || !(only.is_empty() || only.contains(&r.name)) {
            continue;
        }
        let default = r.value.expect("varied records have a value");
        for (end, value) in [("low", r.range[0]), ("high", r.range[1])] {
            if value != default {
                out.push(Variant {
                    parameter: r.name.clone(),
                    end,
                    value,
                    default,
                    reseeded: false,
                    also: Vec::new(),
                });
            }
        }
    }
    Ok(out)
}

/// A switch, `NAME=VALUE`: the parameter (any the study could vary, or any setting the
/// protocols take) at the given value, which may lie outside its plausible range. Several
/// settings made at once are joined by `+` (`NAME=VALUE+NAME2=VALUE2`), each checked alike.
pub fn switch(records: &[ParameterRecord], given: &str) -> Result<Variant, String> {
    // a `+` joins settings only before a name: `1e+3` stays one number
    let mut starts = vec![0];
    starts.extend(
        given
            .char_indices()
            .zip(given.chars().skip(1))
            .filter(|((_, c), next)| *c == '+' && next.is_ascii_alphabetic())
            .map(|((i, _), _)| i + 1),
    );
    let ends = starts.iter().skip(1).map(|s| s - 1).chain([given.len()]);
    let mut parts = starts
        .iter()
        .zip(ends)
        .map(|(&a, b)| one_setting(records, &given[a..b]));
    let mut first = parts.next().expect("split gives at least one part")?;
    for part in parts {
        let part = part?;
        if part.parameter == first.parameter || first.also.iter().any(|(n, _)| *n == part.parameter)
        {
            return Err(format!("`{given}`: `{}` is set twice", part.parameter));
        }
        first.also.push((part.parameter, part.value));
    }
    Ok(first)
}

/// One `NAME=VALUE` of a switch.
fn one_setting(records: &[ParameterRecord], given: &str) -> Result<Variant, String> {
    let (name, value) = given
        .split_once('=')
        .ok_or_else(|| format!("`{given}`: expected NAME=VALUE"))?;
    let (name, value) = (name.trim(), value.trim());
    let value: f64 = value
        .parse()
        .ok()
        .filter(|v: &f64| v.is_finite())
        .ok_or_else(|| format!("`{given}`: the value `{value}` is not a finite number"))?;
    let default = SimConfig::parameters()
        .into_iter()
        .chain(protocol_parameters())
        .find(|(n, _)| n == name)
        .map(|(_, d)| d)
        .ok_or_else(|| {
            format!("`{name}` is not a simulator parameter (`tmo sim parameters` lists them)")
        })?;
    match records.iter().find(|r| r.name == name) {
        Some(r) if r.basis == Basis::Convention => Err(format!(
            "`{name}` is a convention of the simulation, not a physical parameter a switch can set"
        )),
        _ if value == default => Err(format!(
            "`{given}`: that is the default, so nothing is switched"
        )),
        _ => Ok(Variant {
            parameter: name.to_string(),
            end: SWITCH,
            value,
            default,
            reseeded: false,
            also: Vec::new(),
        }),
    }
}

/// A study: the noise reference first, then [`variants`] of the parameters in `only` (all
/// when it is empty; none when it names only the reference, `reseeded`), then the
/// switches `only` gives as `NAME=VALUE`.
pub fn study(records: &[ParameterRecord], only: &[String]) -> Result<Vec<Variant>, String> {
    let (switches, named): (Vec<&String>, Vec<&String>) =
        only.iter().partition(|n| n.contains('='));
    // a name given twice is one parameter (else `x` and `x,x` would be different plans)
    let mut parameters: Vec<String> = Vec::new();
    for n in named.into_iter().filter(|n| *n != RESEEDED) {
        if !parameters.contains(n) {
            parameters.push(n.clone());
        }
    }
    let mut all = vec![Variant::reseeded()];
    if only.is_empty() || !parameters.is_empty() {
        all.extend(variants(records, &parameters)?);
    }
    for given in switches {
        let v = switch(records, given)?;
        if !all.contains(&v) {
            all.push(v);
        }
    }
    Ok(all)
}

/// A variant's verdicts beside the baseline's.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Outcome {
    pub variant: Variant,
    /// Findings whose verdict differs from the baseline's: (baseline, here).
    pub changed: BTreeMap<String, (Reproduced, Reproduced)>,
    /// Why the variant could not be run to the end (its findings are then not compared).
    pub failed: Option<String>,
}

/// The outcome of a variant that could not be run to the end.
pub fn failed(variant: Variant, why: String) -> Outcome {
    Outcome {
        variant,
        changed: BTreeMap::new(),
        failed: Some(why),
    }
}

/// Compares a variant's verdicts with the baseline's.
pub fn compare(variant: Variant, baseline: &[Judged], here: &[Judged]) -> Outcome {
    let changed = baseline
        .iter()
        .filter_map(|b| {
            let h = here.iter().find(|h| h.finding.id == b.finding.id)?;
            (h.reproduced != b.reproduced)
                .then(|| (b.finding.id.clone(), (b.reproduced, h.reproduced)))
        })
        .collect();
    Outcome {
        variant,
        changed,
        failed: None,
    }
}

/// Marks each baseline finding with the parameter variants that change its verdict
/// (empty: robust; `None` where the study varied no parameter within its range, only the
/// seeds or switches), and with whether other seeds alone change it (the noise reference,
/// where one was run). A switch may lie outside the plausible range, so it makes nothing
/// fragile.
pub fn mark_fragile(baseline: &mut [Judged], outcomes: &[Outcome]) {
    let reference = outcomes
        .iter()
        .find(|o| o.variant.reseeded && o.failed.is_none());
    let any_varied = outcomes.iter().any(|o| o.variant.in_range());
    for j in baseline.iter_mut() {
        j.sensitive_to = any_varied.then(|| {
            outcomes
                .iter()
                .filter(|o| o.variant.in_range() && o.changed.contains_key(&j.finding.id))
                .map(|o| o.variant.dir_name())
                .collect()
        });
        j.changes_with_seeds = reference.map(|o| o.changed.contains_key(&j.finding.id));
    }
}

/// How a study classes a finding.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Standing {
    /// No parameter end changes its verdict (nor do other seeds).
    Robust,
    /// Some parameter end changes it; other seeds alone do not.
    Fragile,
    /// Other seeds alone change it: not decided at this many replicates.
    Undecided,
    /// Other seeds keep it, and the study varied no parameter (the noise reference alone):
    /// nothing is known of the parameters, so neither robust nor fragile.
    SeedStable,
}

/// The class of a marked finding (`None`: no study).
pub fn standing(j: &Judged) -> Option<Standing> {
    if j.changes_with_seeds == Some(true) {
        return Some(Standing::Undecided);
    }
    Some(match (&j.sensitive_to, j.changes_with_seeds) {
        (None, None) => return None,
        (None, Some(_)) => Standing::SeedStable,
        (Some(sensitive), _) if sensitive.is_empty() => Standing::Robust,
        (Some(_), _) => Standing::Fragile,
    })
}

/// The parameter x finding table as markdown: one row per variant that changed anything
/// (the noise reference first), one column per finding that changed anywhere; then the
/// findings by standing.
pub fn markdown(baseline: &[Judged], outcomes: &[Outcome]) -> String {
    let ids: Vec<&str> = baseline
        .iter()
        .map(|j| j.finding.id.as_str())
        .filter(|id| outcomes.iter().any(|o| o.changed.contains_key(*id)))
        .collect();
    let varied: Vec<&Outcome> = outcomes.iter().filter(|o| !o.variant.reseeded).collect();
    let reference = outcomes.iter().find(|o| o.variant.reseeded);
    let parameters = varied
        .iter()
        .map(|o| o.variant.parameter.as_str())
        .collect::<std::collections::BTreeSet<_>>()
        .len();
    // "1 parameter", "2 parameters": the count as a reader says it
    let parameters_varied = match parameters {
        1 => "the 1 parameter varied".to_string(),
        n => format!("the {n} parameters varied"),
    };
    let mut s = if varied.is_empty() {
        "# Sensitivity: which verdicts change with the seeds alone\n\nOnly the noise reference was run (`--sensitivity-parameters reseeded`): no parameter was varied, so this says how firmly each verdict is decided at this many replicates, not what it hinges on. A cell gives the verdict there (baseline -> reference).\n\n".to_string()
    } else {
        format!(
            "# Sensitivity: which verdicts change within the parameters' plausible ranges\n\n{} variants ({} at each end of {} range{}) were run with the baseline's seeds; {} changed at least one verdict. A cell gives the verdict there (baseline -> variant).\n\n",
            varied.len(),
            if parameters == 1 {
                "1 parameter".to_string()
            } else {
                format!("{parameters} parameters")
            },
            if parameters == 1 { "its" } else { "their" },
            match varied.iter().filter(|o| o.variant.end == SWITCH).count() {
                0 => String::new(),
                n => format!(
                    ", or at a value of the study's own: {n} switch(es), which may lie outside the range"
                ),
            },
            varied.iter().filter(|o| !o.changed.is_empty()).count()
        )
    };
    match reference {
        Some(o) if o.failed.is_none() => {
            s += &format!(
                "The noise reference (`{RESEEDED}`: the baseline's parameters, as many replicates again with other seeds) changed {} verdict(s)",
                o.changed.len()
            );
            s += if varied.is_empty() {
                ".\n\n"
            } else {
                ": that many change with the seeds alone, so a parameter that changes no more than that says little. Findings it changes are not decided at this many replicates and are listed apart.\n\n"
            };
        }
        _ => s += "No noise reference was run: a change below may be the seeds' as much as the parameter's.\n\n",
    }
    let failed: Vec<String> = outcomes
        .iter()
        .filter_map(|o| {
            o.failed
                .as_ref()
                .map(|why| format!("- {} = {}: {why}\n", o.variant.parameter, o.variant.value))
        })
        .collect();
    if !failed.is_empty() {
        s += &format!(
            "These variants could not be run to the end (the simulated rig cannot work there, a result in itself), and are left out of the table:\n\n{}\n",
            failed.concat()
        );
    }
    if ids.is_empty() {
        s += "No verdict changed.\n";
        return s;
    }
    s += &format!("| parameter | value (default) | {} |\n", ids.join(" | "));
    s += &format!("|{}\n", " --- |".repeat(ids.len() + 2));
    let rows = reference
        .into_iter()
        .chain(varied.iter().copied())
        .filter(|o| !o.changed.is_empty());
    for o in rows {
        let cells: Vec<String> = ids
            .iter()
            .map(|id| {
                o.changed.get(*id).map_or(String::new(), |(b, h)| {
                    format!("{} -> {}", b.label(), h.label())
                })
            })
            .collect();
        let (name, value) = if o.variant.reseeded {
            (format!("({RESEEDED})"), "other seeds".to_string())
        } else if !o.variant.also.is_empty() {
            (
                o.variant.dir_name(),
                "switch (several settings)".to_string(),
            )
        } else {
            (
                o.variant.parameter.clone(),
                format!("{} ({})", o.variant.value, o.variant.default),
            )
        };
        s += &format!("| {name} | {value} | {} |\n", cells.join(" | "));
    }
    // The findings as `mark_fragile` classes them against these outcomes.
    let mut marked = baseline.to_vec();
    mark_fragile(&mut marked, outcomes);
    const UNDECIDED: (&str, Standing) = (
        "Not decided at this many replicates (other seeds alone change the verdict)",
        Standing::Undecided,
    );
    let robust = format!("Robust to {parameters_varied}");
    let classes: &[(&str, Standing)] = if !varied.iter().any(|o| o.variant.in_range()) {
        &[
            UNDECIDED,
            (
                "Stable under other seeds (no parameter varied)",
                Standing::SeedStable,
            ),
        ]
    } else {
        &[
            ("Fragile", Standing::Fragile),
            UNDECIDED,
            (robust.as_str(), Standing::Robust),
        ]
    };
    for &(label, class) in classes {
        let ids: Vec<&str> = marked
            .iter()
            .filter(|j| standing(j) == Some(class))
            .map(|j| j.finding.id.as_str())
            .collect();
        s += &format!("\n{label} ({}): {}.\n", ids.len(), ids.join(", "));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::reproduce::findings::{judge_all, paper, Measures};

    #[test]
    fn every_physical_parameter_is_varied_at_both_ends_and_conventions_are_not() {
        let records = tmo_sim::parameters::built_in();
        let all = variants(&records, &[]).unwrap();
        let names: std::collections::BTreeSet<&str> =
            all.iter().map(|v| v.parameter.as_str()).collect();
        assert!(names.contains("physics.finger_stiffness_n_per_mm"));
        assert!(names.contains("rail.rail_mu"));
        assert!(!names.contains("physics.step_s"), "a convention");
        assert!(!names.contains("tactip.pins"), "a range of one value");
        assert!(names.len() > 30, "{}", names.len());
        for v in &all {
            assert_ne!(v.value, v.default, "{v:?}");
        }
        // a study leads with the noise reference, which may also run alone
        let with_reference = study(&records, &[]).unwrap();
        assert!(with_reference[0].reseeded && with_reference[1..] == all[..]);
        let alone = study(&records, &[RESEEDED.to_string()]).unwrap();
        assert_eq!(alone, vec![Variant::reseeded()]);
        let one = variants(&records, &["rail.rail_mu".to_string()]).unwrap();
        assert_eq!(one.len(), 2);
        assert_eq!(one[0].dir_name(), "rail.rail_mu@low");
        assert!(variants(&records, &["physics.step_s".to_string()])
            .unwrap_err()
            .contains("not varied"));
        assert!(variants(&records, &["nonsense".to_string()])
            .unwrap_err()
            .contains("`nonsense`"));
    }

    #[test]
    fn the_lifts_protocol_values_have_records_at_the_protocols_defaults_and_are_varied() {
        let records = tmo_sim::parameters::built_in();
        let calibration = crate::protocol::Calibration::default();
        let known = protocol_parameters();
        assert_eq!(
            known,
            [
                (
                    "protocol.lift.approach_speed_of_max".to_string(),
                    calibration.approach_speed_of_max
                ),
                (
                    "protocol.lift.lift_speed_mm_s".to_string(),
                    calibration.lift_speed_mm_s
                )
            ]
        );
        for (name, default) in &known {
            let r = records
                .iter()
                .find(|r| &r.name == name)
                .unwrap_or_else(|| panic!("no record for `{name}`"));
            assert_eq!(r.value, Some(*default), "{name}");
        }
        // and every protocol record is one the protocols take
        for r in records
            .iter()
            .filter(|r| r.name.starts_with(PROTOCOL_PREFIX))
        {
            assert!(known.iter().any(|(n, _)| n == &r.name), "`{}`", r.name);
        }
        let speed = variants(&records, &["protocol.lift.lift_speed_mm_s".to_string()]).unwrap();
        assert_eq!(
            speed.iter().map(|v| v.value).collect::<Vec<_>>(),
            [8.0, 40.0]
        );
    }

    /// Every finding judged on a reproduction that measured only the rail's catches with
    /// one frame: `caught` of 500.
    fn judged_with_rail_catches(caught: u64) -> Vec<Judged> {
        use crate::reproduce::evidence::Measure;
        let mut m = Measures::new();
        m.insert(
            "rail.online.caught.1fr".into(),
            Measure::proportion(caught, 500),
        );
        judge_all(&paper(), &m, std::slice::from_ref(&m))
    }

    #[test]
    fn a_finding_whose_verdict_changes_in_a_variant_is_fragile() {
        let at = judged_with_rail_catches;
        let mut baseline = at(370);
        let variant = |end| Variant {
            parameter: "rail.rail_mu".into(),
            end,
            value: 0.1,
            default: 0.05,
            reseeded: false,
            also: Vec::new(),
        };
        let outcomes = vec![
            compare(variant("low"), &baseline, &at(375)),
            compare(variant("high"), &baseline, &at(100)),
        ];
        assert!(outcomes[0].changed.is_empty());
        assert_eq!(
            outcomes[1].changed["sf-rail-caught"],
            (Reproduced::Yes, Reproduced::No)
        );
        mark_fragile(&mut baseline, &outcomes);
        let caught = baseline
            .iter()
            .find(|j| j.finding.id == "sf-rail-caught")
            .unwrap();
        assert_eq!(caught.sensitive_to, Some(vec!["rail.rail_mu@high".into()]));
        let mut with_failure = outcomes.clone();
        with_failure.push(failed(
            Variant {
                parameter: "physics.finger_stiffness_n_per_mm".into(),
                end: "low",
                value: 0.2,
                default: 0.5,
                reseeded: false,
                also: Vec::new(),
            },
            "step hand_collect: out of limits".into(),
        ));
        let md = markdown(&baseline, &with_failure);
        assert!(
            md.contains(
                "- physics.finger_stiffness_n_per_mm = 0.2: step hand_collect: out of limits"
            ),
            "{md}"
        );
        let md = markdown(&baseline, &outcomes);
        assert!(md.contains("| sf-rail-caught |"), "{md}");
        assert!(md.contains("yes -> no"), "{md}");
        assert!(md.contains("Fragile (1): sf-rail-caught."), "{md}");
        assert!(md.contains("No noise reference was run"), "{md}");
    }

    #[test]
    fn a_switch_sets_a_value_outside_the_range_and_shows_a_finding_can_fail_without_making_it_fragile(
    ) {
        let records = tmo_sim::parameters::built_in();
        let plan = study(
            &records,
            &[
                "reseeded".into(),
                "tactip.noise_px=0.6".into(),
                "tactip.noise_px=0.6".into(),
            ],
        )
        .unwrap();
        assert_eq!(plan.len(), 2, "the reference and one switch: {plan:?}");
        let s = &plan[1];
        assert_eq!((s.end, s.value, s.default), (SWITCH, 0.6, 0.08));
        assert_eq!(s.dir_name(), "tactip.noise_px=0.6");
        assert!(!s.in_range() && plan[0].reseeded);
        // a protocol value may be switched too
        assert!(switch(&records, "protocol.lift.lift_speed_mm_s=100").is_ok());
        // several settings at once: the null simulator's mechanism off and noise matched
        let null = switch(&records, "physics.finger_roll_ratio=0+tactip.noise_px=1e-1").unwrap();
        assert_eq!(
            null.dir_name(),
            "physics.finger_roll_ratio=0+tactip.noise_px=0.1"
        );
        assert_eq!(
            null.sim(),
            [
                ("physics.finger_roll_ratio".to_string(), 0.0),
                ("tactip.noise_px".to_string(), 0.1)
            ]
            .into()
        );
        assert_eq!(switch(&records, "tactip.noise_px=1e+0").unwrap().value, 1.0);
        assert!(switch(&records, "tactip.noise_px=0.1+tactip.noise_px=0.2")
            .unwrap_err()
            .contains("set twice"));
        assert!(switch(&records, "tactip.noise_px=0.1+nonsense=1")
            .unwrap_err()
            .contains("`nonsense` is not a simulator parameter"));
        // refusals, each naming what is wrong
        assert!(switch(&records, "tactip.noise_px")
            .unwrap_err()
            .contains("expected NAME=VALUE"));
        for (given, says) in [
            ("tactip.noise_px=fast", "not a finite number"),
            ("tactip.noise_px=inf", "not a finite number"),
            ("nonsense=1", "`nonsense` is not a simulator parameter"),
            ("physics.step_s=0.002", "a convention"),
            ("tactip.noise_px=0.08", "the default"),
        ] {
            let e = study(&records, &[given.to_string()]).unwrap_err();
            assert!(e.contains(says), "{given}: {e}");
        }

        // the switch fails a finding; being outside the range, it makes nothing fragile
        let at = judged_with_rail_catches;
        let mut baseline = at(370);
        let switched = Variant {
            parameter: "rail.rail_mu".into(),
            end: SWITCH,
            value: 0.6,
            default: 0.11,
            reseeded: false,
            also: Vec::new(),
        };
        let outcomes = vec![compare(switched, &baseline, &at(100))];
        assert_eq!(
            outcomes[0].changed["sf-rail-caught"],
            (Reproduced::Yes, Reproduced::No)
        );
        mark_fragile(&mut baseline, &outcomes);
        assert!(baseline.iter().all(|j| j.sensitive_to.is_none()));
        let md = markdown(&baseline, &outcomes);
        assert!(md.contains("1 switch(es)"), "{md}");
        assert!(
            md.contains("| rail.rail_mu | 0.6 (0.11) | yes -> no |"),
            "{md}"
        );
        assert!(!md.contains("Fragile"), "{md}");
    }

    #[test]
    fn a_finding_other_seeds_alone_change_is_undecided_not_fragile() {
        let at = judged_with_rail_catches;
        let mut baseline = at(370);
        let high = Variant {
            parameter: "rail.rail_mu".into(),
            end: "high",
            value: 0.1,
            default: 0.05,
            reseeded: false,
            also: Vec::new(),
        };
        let reference = Variant::reseeded();
        assert_eq!(reference.dir_name(), RESEEDED);
        assert!(reference.sim().is_empty());
        assert_eq!((reference.seed_offset(5), high.seed_offset(5)), (5, 0));
        // The parameter changes the verdict; so do other seeds alone.
        let outcomes = vec![
            compare(reference.clone(), &baseline, &at(100)),
            compare(high.clone(), &baseline, &at(100)),
        ];
        mark_fragile(&mut baseline, &outcomes);
        let caught = |b: &[Judged]| {
            b.iter()
                .find(|j| j.finding.id == "sf-rail-caught")
                .unwrap()
                .clone()
        };
        let j = caught(&baseline);
        assert_eq!(j.sensitive_to, Some(vec!["rail.rail_mu@high".into()]));
        assert_eq!(j.changes_with_seeds, Some(true));
        assert_eq!(standing(&j), Some(Standing::Undecided));
        let md = markdown(&baseline, &outcomes);
        assert!(
            md.contains("| (reseeded) | other seeds | yes -> no |"),
            "{md}"
        );
        assert!(md.contains("changed 1 verdict(s)"), "{md}");
        assert!(md.contains("Fragile (0): ."), "{md}");
        assert!(
            md.contains("replicates (other seeds alone change the verdict) (1): sf-rail-caught."),
            "{md}"
        );
        // Other seeds keep it: then the parameter's change makes it fragile.
        let mut baseline = at(370);
        let outcomes = vec![
            compare(reference, &baseline, &at(372)),
            compare(high, &baseline, &at(100)),
        ];
        mark_fragile(&mut baseline, &outcomes);
        assert_eq!(standing(&caught(&baseline)), Some(Standing::Fragile));
        let robust = baseline
            .iter()
            .find(|j| j.finding.id == "sf-offline-order")
            .unwrap();
        assert_eq!(standing(robust), Some(Standing::Robust));
        // robust to what was varied, counted as a reader says it
        let md = markdown(&baseline, &outcomes);
        assert!(
            md.contains("(1 parameter at each end of its range)"),
            "{md}"
        );
        assert!(md.contains("\nRobust to the 1 parameter varied ("), "{md}");
    }

    #[test]
    fn a_parameter_named_twice_or_in_another_order_is_the_same_study() {
        let s = |v: &[&str]| v.iter().map(|x| x.to_string()).collect::<Vec<_>>();
        assert_eq!(parameters_named(&s(&["x", "x"])), s(&["x"]));
        assert_eq!(parameters_named(&s(&["y", "x", "y"])), s(&["x", "y"]));
        assert_eq!(parameters_named(&[]), Vec::<String>::new());
    }

    #[test]
    fn a_study_of_the_seeds_alone_calls_nothing_robust_or_fragile() {
        let at = judged_with_rail_catches;
        let mut baseline = at(370);
        let outcomes = vec![compare(Variant::reseeded(), &baseline, &at(100))];
        mark_fragile(&mut baseline, &outcomes);
        let by_id = |id: &str| baseline.iter().find(|j| j.finding.id == id).unwrap();
        assert_eq!(by_id("sf-rail-caught").sensitive_to, None);
        assert_eq!(standing(by_id("sf-rail-caught")), Some(Standing::Undecided));
        assert_eq!(
            standing(by_id("sf-offline-order")),
            Some(Standing::SeedStable)
        );
        let md = markdown(&baseline, &outcomes);
        assert!(md.contains("Only the noise reference was run"), "{md}");
        assert!(
            md.contains("Stable under other seeds (no parameter varied) ("),
            "{md}"
        );
        assert!(!md.contains("Robust"), "{md}");
        assert!(!md.contains("Fragile"), "{md}");
    }
}
