//! What each finding hinges on: every physical parameter of the simulator set in turn to
//! the low and the high end of its plausible range (`sim/data/parameters.toml`), the
//! reproduction run again with the same seeds (steps the parameter does not touch are taken
//! from the baseline), and each finding's verdict compared with the baseline's. A finding
//! whose verdict changes anywhere inside its parameters' plausible ranges is fragile.

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
    /// "low" or "high".
    pub end: &'static str,
    pub value: f64,
    pub default: f64,
}

impl Variant {
    /// Its directory under `<out>/sensitivity/`.
    pub fn dir_name(&self) -> String {
        format!("{}@{}", self.parameter, self.end)
    }

    pub fn dir(&self, out: &Path) -> PathBuf {
        out.join("sensitivity").join(self.dir_name())
    }

    /// The simulator parameters the variant sets.
    pub fn sim(&self) -> BTreeMap<String, f64> {
        [(self.parameter.clone(), self.value)].into()
    }
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

/// The variants to run: both ends of every varied parameter, or of the parameters named
/// in `only` (an unknown or unvaried name is an error naming it).
pub fn variants(records: &[ParameterRecord], only: &[String]) -> Result<Vec<Variant>, String> {
    let settable: Vec<String> = SimConfig::parameters()
        .into_iter()
        .map(|(n, _)| n)
        .collect();
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
                });
            }
        }
    }
    Ok(out)
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

/// Marks each baseline finding with the variants that change its verdict (empty: robust).
pub fn mark_fragile(baseline: &mut [Judged], outcomes: &[Outcome]) {
    for j in baseline.iter_mut() {
        j.sensitive_to = Some(
            outcomes
                .iter()
                .filter(|o| o.changed.contains_key(&j.finding.id))
                .map(|o| o.variant.dir_name())
                .collect(),
        );
    }
}

/// The parameter x finding table as markdown: one row per variant that changed anything,
/// one column per finding that changed anywhere.
pub fn markdown(baseline: &[Judged], outcomes: &[Outcome]) -> String {
    let ids: Vec<&str> = baseline
        .iter()
        .map(|j| j.finding.id.as_str())
        .filter(|id| outcomes.iter().any(|o| o.changed.contains_key(*id)))
        .collect();
    let mut s = format!(
        "# Sensitivity: which verdicts change within the parameters' plausible ranges\n\n{} variants ({} parameters at each end of their range) were run with the baseline's seeds; {} changed at least one verdict. A cell gives the verdict there (baseline -> variant).\n\n",
        outcomes.len(),
        outcomes
            .iter()
            .map(|o| o.variant.parameter.as_str())
            .collect::<std::collections::BTreeSet<_>>()
            .len(),
        outcomes.iter().filter(|o| !o.changed.is_empty()).count()
    );
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
    for o in outcomes.iter().filter(|o| !o.changed.is_empty()) {
        let cells: Vec<String> = ids
            .iter()
            .map(|id| {
                o.changed.get(*id).map_or(String::new(), |(b, h)| {
                    format!("{} -> {}", b.label(), h.label())
                })
            })
            .collect();
        s += &format!(
            "| {} | {} ({}) | {} |\n",
            o.variant.parameter,
            o.variant.value,
            o.variant.default,
            cells.join(" | ")
        );
    }
    let robust: Vec<&str> = baseline
        .iter()
        .map(|j| j.finding.id.as_str())
        .filter(|id| !ids.contains(id))
        .collect();
    s += &format!(
        "\nFragile ({}): {}.\n\nRobust ({}): {}.\n",
        ids.len(),
        ids.join(", "),
        robust.len(),
        robust.join(", ")
    );
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
    fn a_finding_whose_verdict_changes_in_a_variant_is_fragile() {
        use crate::reproduce::evidence::Measure;
        let findings = paper();
        let at = |k| {
            let mut m = Measures::new();
            m.insert("rail.online.caught.1fr".into(), Measure::proportion(k, 500));
            judge_all(&findings, &m, std::slice::from_ref(&m))
        };
        let mut baseline = at(370);
        let variant = |end| Variant {
            parameter: "rail.rail_mu".into(),
            end,
            value: 0.1,
            default: 0.05,
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
    }
}
