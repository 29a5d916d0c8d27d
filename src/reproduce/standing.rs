//! What was seen of each finding while the simulator was chosen: its standing, derived
//! from the records in `docs/standings.toml` and the parameter records' `calibrated_against`.
//! Only pre-registered and never-seen findings count as evidence that the simulator
//! predicts what the paper found; the rest are reported, and counted apart.

use std::collections::BTreeMap;

/// The records file, as shipped.
pub const STANDINGS: &str = include_str!("../../docs/standings.toml");

/// A finding's standing: the first of these that applies.
#[derive(
    Debug,
    Clone,
    Copy,
    PartialEq,
    Eq,
    PartialOrd,
    Ord,
    Default,
    serde::Serialize,
    serde::Deserialize,
)]
#[serde(rename_all = "snake_case")]
pub enum Standing {
    /// Its expected verdict under a change was committed before the run that judged it.
    PreRegistered,
    /// Never seen while a simulator value or mechanism was chosen.
    #[default]
    NeverSeen,
    /// Pre-registered or never seen, but not shown to be its physics' (issue 70, items 1
    /// and 2): the null simulator gives its verdict alike, or no configuration inside the
    /// plausible ranges changes it, beyond what other seeds alone change.
    Unshown,
    /// Shown in a table while a value or mechanism was chosen, though not its target.
    InView,
    /// A simulator value or mechanism was chosen to move it.
    Calibrated,
    /// The simulator as built cannot fail it: a check of the pipeline, not the physics.
    PipelineCheck,
}

impl Standing {
    /// Every standing, evidence first (the page's order).
    pub const ALL: [Standing; 6] = [
        Standing::PreRegistered,
        Standing::NeverSeen,
        Standing::Unshown,
        Standing::InView,
        Standing::Calibrated,
        Standing::PipelineCheck,
    ];

    pub fn is_evidence(self) -> bool {
        matches!(self, Standing::PreRegistered | Standing::NeverSeen)
    }

    pub fn label(self) -> &'static str {
        match self {
            Standing::PreRegistered => "pre-registered",
            Standing::NeverSeen => "never seen",
            Standing::Unshown => "unshown",
            Standing::InView => "in view",
            Standing::Calibrated => "calibrated",
            Standing::PipelineCheck => "pipeline check",
        }
    }

    /// What the standing means, for the page's legend.
    pub fn meaning(self) -> &'static str {
        match self {
            Standing::PreRegistered => "its expected verdict under a simulator change was committed, with the change's sourced values and reasoning, before the run that judged it: evidence",
            Standing::NeverSeen => "never shown while a simulator value or mechanism was chosen: evidence",
            Standing::Unshown => "pre-registered or never seen, but not shown to be decided by its physics: the null simulator (its mechanism off, the pin noise matched) gives its verdict alike, or no configuration inside the plausible ranges changes it beyond what other seeds alone change: not evidence",
            Standing::InView => "shown in a table while a simulator value or mechanism was chosen, though not its target: not evidence",
            Standing::Calibrated => "a simulator value or mechanism was chosen to move it: not evidence",
            Standing::PipelineCheck => "the simulator as built cannot fail it: it checks the pipeline, not the physics; never evidence",
        }
    }
}

#[derive(Debug, Clone, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PipelineCheck {
    pub finding: String,
    pub why: String,
}

/// A pipeline check whose reason no longer holds (a mechanism now lets the simulator fail
/// the row): records are never taken back, so this one says the check is withdrawn, by
/// which change and why. The row then takes the next standing that applies.
#[derive(Debug, Clone, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WithdrawnPipelineCheck {
    pub finding: String,
    pub commits: Vec<String>,
    pub why: String,
}

#[derive(Debug, Clone, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CalibratedMechanism {
    pub mechanism: String,
    pub commits: Vec<String>,
    pub findings: Vec<String>,
    pub why: String,
}

/// The findings a record names: every one, or a list.
#[derive(Debug, Clone, serde::Deserialize)]
#[serde(untagged)]
pub enum Named {
    /// `"all"`.
    All(String),
    Some(Vec<String>),
}

impl Named {
    fn names(&self, id: &str) -> bool {
        match self {
            Named::All(all) => all == "all",
            Named::Some(ids) => ids.iter().any(|i| i == id),
        }
    }
}

#[derive(Debug, Clone, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InView {
    pub commits: Vec<String>,
    pub chose: String,
    pub findings: Named,
}

#[derive(Debug, Clone, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Prediction {
    pub change: String,
    pub values: String,
    pub reasoning: String,
    /// The expected verdict of each finding, by id.
    pub expect: BTreeMap<String, String>,
    /// The band each measure is expected within, `[lo, hi]`, by metric (the prediction's
    /// tolerances: issue 70). A verdict says which side of a rule a value fell; a band
    /// says how far the change was expected to move it.
    #[serde(default)]
    pub bands: BTreeMap<String, [f64; 2]>,
}

/// A mechanism of the simulator and the predictions that expected something of it: one
/// mechanism's rows are one piece of evidence, however many rows it decides.
#[derive(Debug, Clone, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Mechanism {
    /// What it is, in a few words (the headline's name for it).
    pub name: String,
    /// Its `[[prediction]]`s, counting from 1 in the file's order.
    pub predictions: Vec<usize>,
}

/// Expectations a prediction gave of the verdict a row already had in the run before it:
/// they check how far the change reaches, not the row, so they leave its standing as it
/// was (a row in view stays in view). Added beside its prediction, which is never edited.
#[derive(Debug, Clone, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct UnchangedExpectation {
    /// Which `[[prediction]]`, counting from 1 in the file's order.
    pub prediction: usize,
    pub findings: Vec<String>,
    pub why: String,
}

/// A configuration run to show that findings can fail in this simulator (issue 53: a row
/// kept as evidence that no configuration can fail would be a pipeline check): a switch,
/// a parameter set outside its range or a mechanism turned off, run beside a baseline with
/// the same seeds, and each finding's verdict in both.
#[derive(Debug, Clone, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Switch {
    /// What was switched, e.g. `tactip.noise_px=0.6`.
    pub switch: String,
    /// What kind of configuration it is (out of range unless said).
    #[serde(default)]
    pub kind: SwitchKind,
    /// The run: preset, replicates, commit, date, where its outputs were.
    pub run: String,
    /// Each finding's verdict `[baseline, switched]`.
    pub verdicts: BTreeMap<String, [String; 2]>,
    pub why: String,
}

/// What a switch's configuration says of a row's standing (issue 70, items 1 and 2).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum SwitchKind {
    /// Some value outside its plausible range (a broken rig): it shows only that the row
    /// can fail at all.
    #[default]
    OutOfRange,
    /// Every value inside its plausible range (`sim/data/parameters.toml`): a rig could
    /// be so, so a verdict it changes is one the physics could have given either way.
    InRange,
    /// The null simulator: the row's mechanism off and the pin noise matched to the pin
    /// motion the mechanism made. A verdict that holds there is not the mechanism's.
    Null,
    /// The noise reference run beside switches: their baseline's parameters, other seeds.
    /// A verdict it changes is not decided at that size, so no switch of the same run
    /// shows anything of it.
    OtherSeeds,
}

impl SwitchKind {
    pub fn label(self) -> &'static str {
        match self {
            SwitchKind::OutOfRange => "out of range",
            SwitchKind::InRange => "in range",
            SwitchKind::Null => "null simulator",
            SwitchKind::OtherSeeds => "other seeds",
        }
    }
}

/// A row's verdict under one switch, beside its baseline with the same seeds.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SwitchOutcome {
    pub switch: String,
    pub kind: SwitchKind,
    /// `[baseline, switched]`.
    pub verdicts: [String; 2],
}

/// Everything `docs/standings.toml` records.
#[derive(Debug, Clone, Default, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Records {
    #[serde(default)]
    pub pipeline_check: Vec<PipelineCheck>,
    #[serde(default)]
    pub withdrawn_pipeline_check: Vec<WithdrawnPipelineCheck>,
    #[serde(default)]
    pub calibrated_mechanism: Vec<CalibratedMechanism>,
    #[serde(default)]
    pub in_view: Vec<InView>,
    #[serde(default)]
    pub prediction: Vec<Prediction>,
    #[serde(default)]
    pub unchanged_expectation: Vec<UnchangedExpectation>,
    #[serde(default)]
    pub switch: Vec<Switch>,
    #[serde(default)]
    pub mechanism: Vec<Mechanism>,
}

impl Records {
    /// The mechanism prediction `number` (counting from 1) is of, if a record names it.
    pub fn mechanism_of(&self, number: usize) -> Option<&str> {
        self.mechanism
            .iter()
            .find(|m| m.predictions.contains(&number))
            .map(|m| m.name.as_str())
    }

    /// The predictions that pre-register `id`, the latest first: those that expect a
    /// verdict of it, leaving out an expectation of the verdict it already had.
    /// Each with its number (counting from 1 in the file's order).
    fn pre_registering_numbered<'a>(
        &'a self,
        id: &'a str,
    ) -> impl Iterator<Item = (usize, &'a Prediction)> + 'a {
        self.prediction
            .iter()
            .enumerate()
            .rev()
            .filter(move |(i, p)| {
                p.expect.contains_key(id)
                    && !self
                        .unchanged_expectation
                        .iter()
                        .any(|u| u.prediction == i + 1 && u.findings.iter().any(|f| f == id))
            })
            .map(|(i, p)| (i + 1, p))
    }
}

#[derive(Debug, thiserror::Error)]
#[error("{origin}: {message}")]
pub struct RecordsError {
    origin: String,
    message: String,
}

const VERDICTS: [&str; 4] = ["yes", "no", "partly", "not resolved"];

/// What a run may find of a row: a verdict, or nothing measured.
const FOUND: [&str; 5] = ["yes", "no", "partly", "not resolved", "not measured"];

/// Parses a records file against the findings' ids (`origin` names it in errors): every
/// id a record names exists, every `all` is spelled so, every expectation is a verdict.
pub fn parse(text: &str, origin: &str, ids: &[&str]) -> Result<Records, RecordsError> {
    let bad = |message: String| RecordsError {
        origin: origin.into(),
        message,
    };
    let r: Records = toml::from_str(text).map_err(|e| bad(e.to_string()))?;
    let known = |id: &str, what: &str| {
        if ids.contains(&id) {
            Ok(())
        } else {
            Err(bad(format!("{what} names `{id}`, which is no finding")))
        }
    };
    for p in &r.pipeline_check {
        known(&p.finding, "a pipeline check")?;
    }
    for w in &r.withdrawn_pipeline_check {
        if !r.pipeline_check.iter().any(|p| p.finding == w.finding) {
            return Err(bad(format!(
                "a withdrawn pipeline check names `{}`, which no pipeline check names",
                w.finding
            )));
        }
    }
    for m in &r.calibrated_mechanism {
        for id in &m.findings {
            known(id, "a calibrated mechanism")?;
        }
    }
    for v in &r.in_view {
        match &v.findings {
            Named::All(all) if all != "all" => {
                return Err(bad(format!(
                    "an in-view record's findings: expected \"all\" or a list, found \"{all}\""
                )))
            }
            Named::All(_) => {}
            Named::Some(list) => {
                for id in list {
                    known(id, "an in-view record")?;
                }
            }
        }
    }
    for p in &r.prediction {
        for (id, verdict) in &p.expect {
            known(id, "a prediction")?;
            if !VERDICTS.contains(&verdict.as_str()) {
                return Err(bad(format!(
                    "a prediction expects `{verdict}` of `{id}`: expected one of {VERDICTS:?}"
                )));
            }
        }
    }
    for (n, p) in r.prediction.iter().enumerate() {
        for (metric, [lo, hi]) in &p.bands {
            if !(lo.is_finite() && hi.is_finite() && lo <= hi) {
                return Err(bad(format!(
                    "prediction {}'s band of `{metric}` is [{lo}, {hi}]: expected finite bounds, the lower first",
                    n + 1
                )));
            }
        }
    }
    let mut mechanism_of = vec![None::<&str>; r.prediction.len()];
    for m in &r.mechanism {
        for &n in &m.predictions {
            let Some(slot) = n.checked_sub(1).and_then(|i| mechanism_of.get_mut(i)) else {
                return Err(bad(format!(
                    "the mechanism `{}` names prediction {n}: expected 1 to {}",
                    m.name,
                    r.prediction.len()
                )));
            };
            if let Some(other) = slot.replace(&m.name) {
                return Err(bad(format!(
                    "prediction {n} is named by two mechanisms, `{other}` and `{}`: expected one",
                    m.name
                )));
            }
        }
    }
    for u in &r.unchanged_expectation {
        let Some(p) = u
            .prediction
            .checked_sub(1)
            .and_then(|i| r.prediction.get(i))
        else {
            return Err(bad(format!(
                "an unchanged-expectation record names prediction {}: expected 1 to {}",
                u.prediction,
                r.prediction.len()
            )));
        };
        for id in &u.findings {
            if !p.expect.contains_key(id) {
                return Err(bad(format!(
                    "an unchanged-expectation record names `{id}`, which prediction {} does not expect",
                    u.prediction
                )));
            }
        }
    }
    for sw in &r.switch {
        for (id, verdicts) in &sw.verdicts {
            known(id, "a switch record")?;
            if let Some(v) = verdicts.iter().find(|v| !FOUND.contains(&v.as_str())) {
                return Err(bad(format!(
                    "the switch `{}` records `{v}` of `{id}`: expected one of {FOUND:?}",
                    sw.switch
                )));
            }
        }
    }
    Ok(r)
}

/// Whether a switch record shows finding `id` failing: not "yes" under the switch, or
/// already not "yes" in its baseline (a row that reads "no" fails as it stands).
pub fn can_fail(id: &str, records: &Records) -> bool {
    records.switch.iter().any(|sw| {
        sw.verdicts
            .get(id)
            .is_some_and(|[baseline, switched]| baseline != "yes" || switched != "yes")
    })
}

/// Row `id`'s verdict under every switch that recorded it, in the file's order.
pub fn switch_outcomes(id: &str, records: &Records) -> Vec<SwitchOutcome> {
    records
        .switch
        .iter()
        .filter_map(|sw| {
            sw.verdicts.get(id).map(|v| SwitchOutcome {
                switch: sw.switch.clone(),
                kind: sw.kind,
                verdicts: v.clone(),
            })
        })
        .collect()
}

/// Whether the null simulator was run for row `id` and did not give its verdict: the
/// row's verdict is its mechanism's, not one pin noise or a definition would give.
pub fn null_differs(id: &str, records: &Records) -> bool {
    records.switch.iter().any(|sw| {
        sw.kind == SwitchKind::Null
            && sw.verdicts.get(id).is_some_and(|v| v[0] != v[1])
            && !seeds_change(id, &sw.run, records)
    })
}

/// Whether the noise reference of run `run` (a `kind = "other_seeds"` record with the same
/// `run`) changes row `id`'s verdict: at that size the verdict is not decided.
fn seeds_change(id: &str, run: &str, records: &Records) -> bool {
    records.switch.iter().any(|sw| {
        sw.kind == SwitchKind::OtherSeeds
            && sw.run == run
            && sw.verdicts.get(id).is_some_and(|v| v[0] != v[1])
    })
}

/// Whether a configuration a rig could have (every value in its plausible range) changes
/// row `id`'s verdict: a "yes" row fails there, a "no" row passes, a "not resolved" row
/// resolves. A row with no such switch is not evidence (issue 70, item 2).
pub fn plausibly_changed(id: &str, records: &Records) -> bool {
    records.switch.iter().any(|sw| {
        sw.kind == SwitchKind::InRange
            && !seeds_change(id, &sw.run, records)
            && sw.verdicts.get(id).is_some_and(|v| match v[0].as_str() {
                "yes" => v[1] != "yes",
                "no" => v[1] == "yes",
                _ => v[1] == "yes" || v[1] == "no",
            })
    })
}

/// Test records that show every row in `ids` to be its physics': a null simulator and an
/// in-range configuration that each turn it from yes to no. Tests of the other standings
/// add these so that their evidence rows stay evidence.
#[cfg(test)]
pub fn shown_switches(ids: &[&str]) -> String {
    let verdicts: Vec<String> = ids
        .iter()
        .map(|id| format!("\"{id}\" = [\"yes\", \"no\"]"))
        .collect();
    let verdicts = verdicts.join(", ");
    ["null", "in_range"]
        .iter()
        .map(|kind| {
            format!(
                "\n[[switch]]\nswitch = \"{kind}\"\nkind = \"{kind}\"\nrun = \"test\"\nverdicts = {{ {verdicts} }}\nwhy = \"w\"\n"
            )
        })
        .collect()
}

/// The shipped records, checked against the findings whose ids are `ids` (the shipped
/// findings: [`super::findings::shipped_standings`]).
pub fn shipped(ids: &[&str]) -> Records {
    parse(STANDINGS, "docs/standings.toml", ids).expect("the shipped standings parse")
}

/// The standing of finding `id`, with the record that gave it, in words; `parameters` are
/// the simulator parameters calibrated against it.
pub fn of(id: &str, parameters: &[String], records: &Records) -> (Standing, String) {
    let (standing, why) = seen_or_chosen(id, parameters, records);
    if !standing.is_evidence() {
        return (standing, why);
    }
    match unshown_because(id, records) {
        None => (standing, why),
        Some(because) => (
            Standing::Unshown,
            format!("{} ({because})", standing.label()),
        ),
    }
}

/// Why an otherwise-evidence row is not shown to be its physics' (`None`: it is shown):
/// the null simulator must change its verdict and a configuration inside the plausible
/// ranges must change it (a yes row fails, a no row passes, a not-resolved row resolves),
/// each beyond what the same run's other seeds change (a verdict other seeds change is
/// not decided at that size, so a switch that changes it says nothing).
pub fn unshown_because(id: &str, records: &Records) -> Option<String> {
    let mut missing = Vec::new();
    if !null_differs(id, records) {
        missing.push("the null simulator has not been shown to change its verdict beyond what other seeds change");
    }
    if !plausibly_changed(id, records) {
        missing.push("no configuration inside the plausible ranges has been shown to change it beyond what other seeds change");
    }
    (!missing.is_empty()).then(|| missing.join("; "))
}

/// The standing from the records of what was seen and chosen, before the rows' switches
/// are asked whether the physics decides them.
fn seen_or_chosen(id: &str, parameters: &[String], records: &Records) -> (Standing, String) {
    let withdrawn = |p: &&PipelineCheck| {
        records
            .withdrawn_pipeline_check
            .iter()
            .any(|w| w.finding == p.finding)
    };
    if let Some(p) = records
        .pipeline_check
        .iter()
        .filter(|p| !withdrawn(p))
        .find(|p| p.finding == id)
    {
        return (Standing::PipelineCheck, p.why.clone());
    }
    let mechanisms: Vec<&CalibratedMechanism> = records
        .calibrated_mechanism
        .iter()
        .filter(|m| m.findings.iter().any(|f| f == id))
        .collect();
    if !parameters.is_empty() || !mechanisms.is_empty() {
        let mut by: Vec<String> = parameters.to_vec();
        by.extend(
            mechanisms
                .iter()
                .map(|m| format!("{} ({})", m.mechanism, m.commits.join(", "))),
        );
        return (
            Standing::Calibrated,
            format!("chosen to move it: {}", by.join("; ")),
        );
    }
    if let Some((number, p)) = records.pre_registering_numbered(id).next() {
        // the change itself is stated once, where the page lists the predictions
        return (
            Standing::PreRegistered,
            format!(
                "expected `{}` under prediction {number} (docs/standings.toml)",
                p.expect[id]
            ),
        );
    }
    let seen: Vec<String> = records
        .in_view
        .iter()
        .filter(|v| v.findings.names(id))
        .map(|v| {
            if v.commits.is_empty() {
                v.chose.clone()
            } else {
                v.commits.join(", ")
            }
        })
        .collect();
    if !seen.is_empty() {
        return (
            Standing::InView,
            format!(
                "shown while the simulator was chosen in {}",
                seen.join("; ")
            ),
        );
    }
    (Standing::NeverSeen, String::new())
}

/// The prediction that pre-registers `id` (the latest), as the page states it once: its
/// number and the change it expected of the simulator.
pub fn pre_registered_by(id: &str, records: &Records) -> Option<PredictionRef> {
    records
        .pre_registering_numbered(id)
        .next()
        .map(|(number, p)| PredictionRef {
            number,
            change: p.change.clone(),
            mechanism: records.mechanism_of(number).map(str::to_string),
            bands: p.bands.clone(),
        })
}

/// A `[[prediction]]` of docs/standings.toml by number, with its change in words, the
/// mechanism it is of and its tolerances.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PredictionRef {
    pub number: usize,
    pub change: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mechanism: Option<String>,
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub bands: BTreeMap<String, [f64; 2]>,
}

/// The expected verdict a prediction committed for `id`, if any: the one that
/// pre-registers it (so the page judges a row against the prediction it is listed under),
/// else the latest (an expectation of a verdict the row already had).
pub fn predicted<'a>(id: &'a str, records: &'a Records) -> Option<&'a str> {
    if let Some((_, p)) = records.pre_registering_numbered(id).next() {
        return p.expect.get(id).map(String::as_str);
    }
    records
        .prediction
        .iter()
        .rev()
        .find_map(|p| p.expect.get(id).map(String::as_str))
}

#[cfg(test)]
mod tests {
    use super::*;

    const IDS: [&str; 4] = ["a", "b", "c", "d"];

    /// The records in `text` alone.
    fn bare(text: &str) -> Records {
        parse(text, "test", &IDS).unwrap()
    }

    /// The records in `text`, with switches that show every row its physics' (so the rows
    /// these tests expect as evidence are).
    fn records(text: &str) -> Records {
        parse(&format!("{text}{}", shown_switches(&IDS)), "test", &IDS).unwrap()
    }

    #[test]
    fn a_row_not_shown_to_be_its_physics_is_unshown_not_evidence() {
        let bare = parse("", "test", &IDS).unwrap();
        let (standing, why) = of("d", &[], &bare);
        assert_eq!(standing, Standing::Unshown);
        assert!(!standing.is_evidence());
        assert!(
            why.starts_with("never seen (") && why.contains("null simulator"),
            "{why}"
        );
        // shown by its null simulator alone: still unshown, for want of a plausible rig
        let null_only = parse(
            "[[switch]]\nswitch = \"n\"\nkind = \"null\"\nrun = \"r\"\nverdicts = { d = [\"yes\", \"no\"] }\nwhy = \"w\"\n",
            "test",
            &IDS,
        )
        .unwrap();
        let (standing, why) = of("d", &[], &null_only);
        assert_eq!(standing, Standing::Unshown);
        assert!(
            !why.contains("null simulator") && why.contains("plausible"),
            "{why}"
        );
        assert_eq!(of("d", &[], &records("")).0, Standing::NeverSeen);
        // other seeds of the same run changing it: the switches show nothing of it
        let seeds = format!(
            "{}\n[[switch]]\nswitch = \"s\"\nkind = \"other_seeds\"\nrun = \"test\"\nverdicts = {{ d = [\"yes\", \"not resolved\"] }}\nwhy = \"w\"\n",
            shown_switches(&IDS)
        );
        let seeds = parse(&seeds, "test", &IDS).unwrap();
        assert_eq!(of("d", &[], &seeds).0, Standing::Unshown);
        assert_eq!(of("c", &[], &seeds).0, Standing::NeverSeen);
    }

    #[test]
    fn each_finding_has_the_first_standing_that_applies_and_only_two_are_evidence() {
        let r = records(
            r#"
[[pipeline_check]]
finding = "a"
why = "it times the CPU"

[[calibrated_mechanism]]
mechanism = "m"
commits = ["x"]
findings = ["a", "b"]
why = "w"

[[in_view]]
commits = ["y"]
chose = "z"
findings = ["a", "b", "c"]

[[prediction]]
change = "ch"
values = "v"
reasoning = "r"
expect = { "c" = "yes" }
"#,
        );
        let standing = |id: &str, params: &[String]| of(id, params, &r).0;
        // a pipeline check stays one, whatever else names it: never evidence
        assert_eq!(standing("a", &[]), Standing::PipelineCheck);
        assert_eq!(standing("a", &["p".into()]), Standing::PipelineCheck);
        assert!(!Standing::PipelineCheck.is_evidence());
        // a mechanism or a parameter calibrated against it: calibrated, not evidence
        assert_eq!(standing("b", &[]), Standing::Calibrated);
        assert_eq!(
            standing("d", &["arm.latency_s".into()]),
            Standing::Calibrated
        );
        // a prediction committed before its run makes an in-view row evidence again
        assert_eq!(standing("c", &[]), Standing::PreRegistered);
        assert_eq!(predicted("c", &r), Some("yes"));
        // named by nothing: never seen
        assert_eq!(standing("d", &[]), Standing::NeverSeen);
        let evidence: Vec<&str> = IDS
            .iter()
            .copied()
            .filter(|id| standing(id, &[]).is_evidence())
            .collect();
        assert_eq!(evidence, ["c", "d"]);
        // an in-view record of every finding takes every unnamed one out of evidence
        let all =
            records("[[in_view]]\ncommits = []\nchose = \"everything\"\nfindings = \"all\"\n");
        assert_eq!(of("d", &[], &all).0, Standing::InView);
    }

    #[test]
    fn an_expectation_of_the_verdict_a_row_already_had_leaves_its_standing() {
        let r = records(
            r#"
[[in_view]]
commits = ["y"]
chose = "z"
findings = ["b", "c"]

[[prediction]]
change = "first"
values = "v"
reasoning = "r"
expect = { "b" = "yes" }

[[prediction]]
change = "second"
values = "v"
reasoning = "r"
expect = { "b" = "no", "c" = "no" }

[[unchanged_expectation]]
prediction = 2
findings = ["b", "c"]
why = "both verdicts as in the run before"
"#,
        );
        // c: only an unchanged expectation names it, so it stays in view
        assert_eq!(of("c", &[], &r).0, Standing::InView);
        // b: the first prediction still pre-registers it, and the page judges it by that
        // prediction's expectation
        let (standing, said) = of("b", &[], &r);
        assert_eq!(standing, Standing::PreRegistered);
        assert!(said.contains("under prediction 1"), "{said}");
        assert_eq!(
            pre_registered_by("b", &r),
            Some(PredictionRef {
                number: 1,
                change: "first".into(),
                mechanism: None,
                bands: BTreeMap::new(),
            })
        );
        // the row is judged against the prediction it is listed under, not the later
        // expectation of the verdict it already had
        assert_eq!(predicted("b", &r), Some("yes"));
        let wrong = |u: &str| {
            parse(
                &format!("[[prediction]]\nchange = \"c\"\nvalues = \"v\"\nreasoning = \"r\"\nexpect = {{ a = \"yes\" }}\n\n[[unchanged_expectation]]\n{u}why = \"w\"\n"),
                "f",
                &IDS,
            )
            .unwrap_err()
            .to_string()
        };
        assert!(wrong("prediction = 2\nfindings = [\"a\"]\n").contains("expected 1 to 1"));
        assert!(wrong("prediction = 1\nfindings = [\"b\"]\n").contains("does not expect"));
    }

    #[test]
    fn a_switch_shows_a_row_can_fail_where_it_is_not_yes_under_the_switch_or_in_its_baseline() {
        let r = bare(
            r#"
[[switch]]
switch = "p=2"
run = "test"
verdicts = { a = ["yes", "no"], b = ["yes", "yes"], c = ["no", "no"], d = ["yes", "not measured"] }
why = "w"
"#,
        );
        assert!(can_fail("a", &r), "yes -> no");
        assert!(!can_fail("b", &r), "yes under the switch too");
        assert!(can_fail("c", &r), "no as it stands");
        assert!(can_fail("d", &r), "not measured is not yes");
        assert!(!can_fail("a", &bare("")), "no record");
        let e = parse(
            "[[switch]]\nswitch = \"s\"\nrun = \"r\"\nverdicts = { a = [\"yes\", \"perhaps\"] }\nwhy = \"w\"\n",
            "f",
            &IDS,
        )
        .unwrap_err();
        assert!(e.to_string().contains("records `perhaps` of `a`"), "{e}");
        let e = parse(
            "[[switch]]\nswitch = \"s\"\nrun = \"r\"\nverdicts = { zz = [\"yes\", \"no\"] }\nwhy = \"w\"\n",
            "f",
            &IDS,
        )
        .unwrap_err();
        assert!(e.to_string().contains("a switch record names `zz`"), "{e}");
    }

    #[test]
    fn the_null_simulator_and_the_in_range_switches_argue_a_rows_standing() {
        let r = bare(
            r#"
[[switch]]
switch = "null"
kind = "null"
run = "test"
verdicts = { a = ["yes", "no"], b = ["no", "no"] }
why = "w"

[[switch]]
switch = "p=0.1"
kind = "in_range"
run = "test"
verdicts = { a = ["yes", "not resolved"], b = ["no", "not resolved"], c = ["not resolved", "no"] }
why = "w"

[[switch]]
switch = "p=9"
run = "test"
verdicts = { b = ["no", "yes"] }
why = "w"
"#,
        );
        assert!(
            null_differs("a", &r),
            "yes in the simulator, no in the null"
        );
        assert!(!null_differs("b", &r), "the null gives its verdict alike");
        assert!(!null_differs("c", &r), "no null run");
        assert!(plausibly_changed("a", &r), "a yes row fails in range");
        assert!(
            !plausibly_changed("b", &r),
            "a no row must pass in range; passing out of range does not count"
        );
        assert!(plausibly_changed("c", &r), "a not-resolved row resolves");
        let outcomes = switch_outcomes("b", &r);
        assert_eq!(
            outcomes.iter().map(|o| o.kind).collect::<Vec<_>>(),
            [
                SwitchKind::Null,
                SwitchKind::InRange,
                SwitchKind::OutOfRange
            ]
        );
        let e = parse(
            "[[switch]]\nswitch = \"s\"\nkind = \"plausible\"\nrun = \"r\"\nverdicts = {}\nwhy = \"w\"\n",
            "f",
            &IDS,
        )
        .unwrap_err();
        assert!(e.to_string().contains("plausible"), "{e}");
    }

    #[test]
    fn a_withdrawn_pipeline_check_leaves_the_row_to_its_next_standing() {
        let text = r#"
[[pipeline_check]]
finding = "a"
why = "cannot fail"

[[in_view]]
commits = ["x"]
chose = "c"
findings = "all"
"#;
        assert_eq!(of("a", &[], &records(text)).0, Standing::PipelineCheck);
        let withdrawn = format!(
            "{text}\n[[withdrawn_pipeline_check]]\nfinding = \"a\"\ncommits = [\"m\"]\nwhy = \"it can fail now\"\n"
        );
        assert_eq!(of("a", &[], &records(&withdrawn)).0, Standing::InView);
        let e = parse(
            "[[withdrawn_pipeline_check]]\nfinding = \"b\"\ncommits = []\nwhy = \"w\"\n",
            "f",
            &IDS,
        )
        .unwrap_err();
        assert!(
            e.to_string().contains("which no pipeline check names"),
            "{e}"
        );
    }

    #[test]
    fn records_naming_unknown_findings_or_verdicts_are_refused() {
        let e = parse(
            "[[pipeline_check]]\nfinding = \"zz\"\nwhy = \"w\"\n",
            "f",
            &IDS,
        )
        .unwrap_err();
        assert!(e.to_string().contains("`zz`"), "{e}");
        let e = parse(
            "[[in_view]]\ncommits = []\nchose = \"c\"\nfindings = \"every\"\n",
            "f",
            &IDS,
        )
        .unwrap_err();
        assert!(e.to_string().contains("\"all\""), "{e}");
        let e = parse(
            "[[prediction]]\nchange = \"c\"\nvalues = \"v\"\nreasoning = \"r\"\nexpect = { a = \"maybe\" }\n",
            "f",
            &IDS,
        )
        .unwrap_err();
        assert!(e.to_string().contains("maybe"), "{e}");
    }

    #[test]
    fn a_prediction_carries_its_bands_and_the_mechanism_it_is_of() {
        let text = |bands: &str, mechanisms: &str| {
            format!("[[prediction]]\nchange = \"c\"\nvalues = \"v\"\nreasoning = \"r\"\nexpect = {{ a = \"yes\" }}\n{bands}\n\n[[prediction]]\nchange = \"d\"\nvalues = \"v\"\nreasoning = \"r\"\nexpect = {{ b = \"no\" }}\n\n{mechanisms}")
        };
        let r = parse(
            &text(
                "bands = { \"x.fp\" = [0.0, 0.1] }",
                "[[mechanism]]\nname = \"the curl\"\npredictions = [1, 2]\n",
            ),
            "f",
            &IDS,
        )
        .unwrap();
        let by = pre_registered_by("a", &r).unwrap();
        assert_eq!(by.mechanism.as_deref(), Some("the curl"));
        assert_eq!(by.bands["x.fp"], [0.0, 0.1]);
        assert_eq!(r.mechanism_of(2), Some("the curl"));
        let wrong = |bands: &str, mechanisms: &str| {
            parse(&text(bands, mechanisms), "f", &IDS)
                .unwrap_err()
                .to_string()
        };
        assert!(wrong("bands = { \"x.fp\" = [0.2, 0.1] }", "")
            .contains("prediction 1's band of `x.fp` is [0.2, 0.1]: expected finite bounds"));
        assert!(
            wrong("", "[[mechanism]]\nname = \"m\"\npredictions = [3]\n")
                .contains("the mechanism `m` names prediction 3: expected 1 to 2")
        );
        assert!(wrong(
            "",
            "[[mechanism]]\nname = \"m\"\npredictions = [1]\n\n[[mechanism]]\nname = \"n\"\npredictions = [1]\n"
        )
        .contains("prediction 1 is named by two mechanisms, `m` and `n`"));
    }
}
