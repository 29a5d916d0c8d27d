//! Where each of the simulator's values comes from (`data/parameters.toml`): its unit, a
//! plausible range, its source or the reasoning behind an estimate, and the findings it
//! was calibrated against, if it was chosen while looking at them. A test here checks the
//! file against the defaults the simulator runs with, so the two cannot drift apart.

use serde::Deserialize;

use super::SimError;

const BUILT_IN: &str = include_str!("../data/parameters.toml");

/// How a value was arrived at.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Basis {
    Citation,
    Datasheet,
    Measurement,
    /// A value the paper states.
    Paper,
    /// A stated estimate; the record's source gives its reasoning.
    Estimate,
    /// A choice of the rig or the numerics, not a physical quantity.
    Convention,
}

/// One parameter's record.
#[derive(Debug, Clone, PartialEq, Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct ParameterRecord {
    /// `physics.skin_modulus_kpa`, `arm.start_mm[2]`, `objects.rail_object.length_mm`, or
    /// `objects.*.mu_static` for every object without a record of its own.
    pub name: String,
    /// The value the simulator uses (none for `objects.*` records: each object has its own).
    #[serde(default)]
    pub value: Option<f64>,
    pub unit: String,
    /// Plausible low and high ends; factors on each object's value for `objects.*`.
    pub range: [f64; 2],
    pub basis: Basis,
    pub source: String,
    /// Findings this value was chosen while looking at.
    #[serde(default)]
    pub calibrated_against: Vec<String>,
}

impl ParameterRecord {
    /// A record that stands for one property of every object.
    pub fn is_object_wide(&self) -> bool {
        self.name.starts_with("objects.*.")
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ParametersFile {
    parameter: Vec<ParameterRecord>,
}

/// Parses a parameters file; `origin` names it in errors.
pub fn parse(text: &str, origin: &str) -> Result<Vec<ParameterRecord>, SimError> {
    let file: ParametersFile = toml::from_str(text).map_err(|e| SimError::Config {
        origin: origin.to_string(),
        message: e.to_string(),
    })?;
    let mut seen = std::collections::BTreeSet::new();
    for r in &file.parameter {
        let bad = |what: String| SimError::Config {
            origin: origin.to_string(),
            message: format!("parameter `{}`: {what}", r.name),
        };
        if !seen.insert(r.name.as_str()) {
            return Err(bad("appears twice".into()));
        }
        let [lo, hi] = r.range;
        if !(lo.is_finite() && hi.is_finite() && lo <= hi) {
            return Err(bad(format!("range [{lo}, {hi}]: expected low <= high")));
        }
        match (r.value, r.is_object_wide()) {
            (None, false) => return Err(bad("has no value".into())),
            (Some(_), true) => {
                return Err(bad(
                    "an objects.* record has no value of its own (each object has one)".into(),
                ))
            }
            (Some(v), false) if !(lo..=hi).contains(&v) => {
                return Err(bad(format!("value {v} outside its range [{lo}, {hi}]")))
            }
            _ => {}
        }
        if r.source.trim().len() < 10 {
            return Err(bad(
                "needs a source, or the reasoning of its estimate".into()
            ));
        }
    }
    Ok(file.parameter)
}

/// The shipped records.
pub fn built_in() -> Vec<ParameterRecord> {
    parse(BUILT_IN, "built-in parameters.toml").expect("the built-in parameters are valid")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{ObjectLibrary, RigSetup, SimConfig};

    fn simulator_fields() -> Vec<(String, f64)> {
        SimConfig::parameters()
    }

    #[test]
    fn the_shipped_records_parse() {
        let records = built_in();
        assert!(records.len() > 50, "{}", records.len());
        // SimConfig::default() builds the hand rig; the rail's fields come from RailSetup
        assert!(matches!(SimConfig::default().rig, RigSetup::Hand(_)));
    }

    #[test]
    fn every_simulator_parameter_has_a_record_with_its_value_and_a_source() {
        let records = built_in();
        let fields = simulator_fields();
        assert!(fields.len() > 50, "{}", fields.len());
        for (name, value) in &fields {
            let record = records
                .iter()
                .find(|r| &r.name == name)
                .unwrap_or_else(|| panic!("no record for `{name}` in data/parameters.toml"));
            let recorded = record.value.unwrap();
            assert!(
                (recorded - value).abs() <= 1e-12 * value.abs().max(1.0),
                "`{name}`: the record says {recorded}, the simulator uses {value}"
            );
        }
        // and no record names a field that does not exist
        // (`protocol.*` records are protocol values: tmo's reproduction checks those)
        for r in records
            .iter()
            .filter(|r| !r.name.starts_with("objects.") && !r.name.starts_with("protocol."))
        {
            assert!(
                fields.iter().any(|(name, _)| name == &r.name),
                "`{}` is not a simulator parameter",
                r.name
            );
        }
    }

    #[test]
    fn every_object_property_has_a_record_of_its_own_or_for_all_objects() {
        let records = built_in();
        let library =
            serde_json::to_value(ObjectLibrary::built_in().iter().collect::<Vec<_>>()).unwrap();
        for object in library.as_array().unwrap() {
            let name = object["name"].as_str().unwrap();
            for (field, value) in crate::config::numbers_by_name(object).0 {
                let own = records
                    .iter()
                    .find(|r| r.name == format!("objects.{name}.{field}"));
                match own {
                    Some(r) => assert_eq!(r.value, Some(value), "objects.{name}.{field}"),
                    None => assert!(
                        records
                            .iter()
                            .any(|r| r.name == format!("objects.*.{field}")),
                        "no record for objects.{name}.{field} or objects.*.{field}"
                    ),
                }
            }
        }
        for r in records.iter().filter(|r| r.name.starts_with("objects.")) {
            let parts: Vec<&str> = r.name.splitn(3, '.').collect();
            assert_eq!(parts.len(), 3, "{}", r.name);
            if parts[1] != "*" {
                assert!(
                    ObjectLibrary::built_in().get(parts[1]).is_ok(),
                    "{}: no such object",
                    r.name
                );
            }
        }
    }

    #[test]
    fn a_bad_record_is_named() {
        let row = |extra: &str| {
            format!(
                "[[parameter]]\nname = \"a.b\"\nunit = \"s\"\nrange = [0, 1]\nbasis = \"estimate\"\nsource = \"a stated reason for it\"\n{extra}"
            )
        };
        assert!(parse(&row("value = 0.5\n"), "p.toml").is_ok());
        let e = parse(&row("value = 2\n"), "p.toml")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("p.toml") && e.contains("`a.b`") && e.contains("outside"),
            "{e}"
        );
        assert!(parse(&row(""), "p.toml").is_err());
        let e = parse(
            &row("value = 0.5\n").replace("a stated reason for it", "?"),
            "p.toml",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("source"), "{e}");
        let twice = format!("{}{}", row("value = 0.5\n"), row("value = 0.5\n"));
        assert!(parse(&twice, "p.toml")
            .unwrap_err()
            .to_string()
            .contains("twice"));
    }
}
