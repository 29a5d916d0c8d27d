//! The paper's findings as data (`docs/paper_findings.toml`, built into the binary) and the
//! rules that decide, from our measurements, whether each one reproduced.

use std::collections::BTreeMap;

/// The findings file, as shipped.
pub const PAPER_FINDINGS: &str = include_str!("../../docs/paper_findings.toml");

pub use super::evidence::Measure;

/// Measurements by metric name.
pub use super::evidence::Measures;

#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Rule {
    /// Each metric above the next.
    Decreasing { metrics: Vec<String> },
    /// `metric >= than + by` and `metric > than`; "partly" when it is above `than` but by
    /// less than `by`.
    Exceeds {
        metric: String,
        than: String,
        #[serde(default)]
        by: f64,
    },
    /// `lo <= metric <= hi`; "not resolved" when its 95 % interval crosses an edge.
    Within { metric: String, lo: f64, hi: f64 },
    /// `metric` above every one of `among`.
    Largest { metric: String, among: Vec<String> },
    /// `metric` below every one of `among`.
    Smallest { metric: String, among: Vec<String> },
}

#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Finding {
    pub id: String,
    pub section: String,
    pub measured: String,
    pub paper: String,
    pub source: String,
    pub rule: Rule,
    /// One of the paper's central claims (listed first on the findings page).
    #[serde(default)]
    pub central: bool,
    /// The paper's own trial counts behind a metric of the rule, where it prints them:
    /// `[coef, k, n]` terms of a sum of rates (`[[1, 10, 50]]` for 10 of 50).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub paper_counts: BTreeMap<String, Vec<(f64, u64, u64)>>,
    /// The value lens: the paper's number for a metric of the rule, and how far from it
    /// ours may lie (`[paper, tolerance]`), written before any run that used it.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub value: BTreeMap<String, (f64, f64)>,
    /// Why each tolerance is what it is.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub value_why: Option<String>,
}

#[derive(Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct FindingsFile {
    finding: Vec<Finding>,
}

#[derive(Debug, thiserror::Error)]
pub enum FindingsError {
    #[error("{origin}: {message}")]
    Parse { origin: String, message: String },
    #[error("{origin}: finding `{id}` appears twice")]
    Duplicate { origin: String, id: String },
    #[error("{origin}: finding `{id}`: {message}")]
    Invalid {
        origin: String,
        id: String,
        message: String,
    },
}

/// Parses a findings file (`origin` names it in errors).
pub fn parse(text: &str, origin: &str) -> Result<Vec<Finding>, FindingsError> {
    let file: FindingsFile = toml::from_str(text).map_err(|e| FindingsError::Parse {
        origin: origin.into(),
        message: e.to_string(),
    })?;
    let mut seen = std::collections::BTreeSet::new();
    for f in &file.finding {
        if !seen.insert(f.id.as_str()) {
            return Err(FindingsError::Duplicate {
                origin: origin.into(),
                id: f.id.clone(),
            });
        }
        let invalid = |message: String| FindingsError::Invalid {
            origin: origin.into(),
            id: f.id.clone(),
            message,
        };
        for (metric, terms) in &f.paper_counts {
            if !f.rule.metrics().contains(&metric.as_str()) {
                return Err(invalid(format!(
                    "paper_counts names `{metric}`, which its rule does not read"
                )));
            }
            if terms.is_empty() || terms.iter().any(|&(c, k, n)| n == 0 || k > n || c == 0.0) {
                return Err(invalid(format!(
                    "paper_counts `{metric}`: expected [coef, k, n] terms with coef != 0 and 0 <= k <= n, n > 0"
                )));
            }
        }
        for (metric, &(paper, tolerance)) in &f.value {
            if !f.rule.metrics().contains(&metric.as_str()) {
                return Err(invalid(format!(
                    "value names `{metric}`, which its rule does not read"
                )));
            }
            if !(paper.is_finite() && tolerance.is_finite() && tolerance >= 0.0) {
                return Err(invalid(format!(
                    "value `{metric}`: expected [paper, tolerance] with a finite number and a tolerance >= 0"
                )));
            }
        }
        if f.value.is_empty() != f.value_why.is_none() {
            return Err(invalid(
                "value and value_why go together: the tolerance needs its reason".into(),
            ));
        }
    }
    Ok(file.finding)
}

/// The shipped findings.
pub fn paper() -> Vec<Finding> {
    parse(PAPER_FINDINGS, "docs/paper_findings.toml").expect("the shipped findings parse")
}

/// A verdict.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Reproduced {
    /// The claim holds with its 95 % interval clear of the rule's margin.
    Yes,
    /// Only for a claim with parts: `exceeds` with a margin, whose direction clearly holds
    /// and whose size clearly does not (above, and clearly by less than the margin);
    /// `decreasing`, at least half of whose steps clearly hold and one clearly fails.
    Partly,
    /// The opposite holds with its interval clear.
    No,
    /// The interval straddles the rule's margin (or a range's edge): the data cannot tell.
    NotResolved,
    /// A metric the rule needs was not measured (a step did not run or gave nothing).
    NotMeasured,
}

impl Reproduced {
    pub fn label(self) -> &'static str {
        match self {
            Reproduced::Yes => "yes",
            Reproduced::Partly => "partly",
            Reproduced::No => "no",
            Reproduced::NotResolved => "not resolved",
            Reproduced::NotMeasured => "not measured",
        }
    }
}

/// `a - b` as a rule reads it.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Comparison {
    pub metric: String,
    pub than: String,
    pub difference: f64,
    pub interval: Option<(f64, f64)>,
}

/// Whether `d` (with its interval, if any) shows "above by at least `margin`". With no
/// interval the point decides.
fn exceeds(d: f64, interval: Option<(f64, f64)>, margin: f64) -> Reproduced {
    let (lo, hi) = interval.unwrap_or((d, d));
    if lo >= margin && lo > 0.0 {
        Reproduced::Yes
    } else if lo > 0.0 && (interval.is_none() || hi < margin) {
        Reproduced::Partly
    } else if hi < margin || hi <= 0.0 || interval.is_none() {
        Reproduced::No
    } else {
        Reproduced::NotResolved
    }
}

/// Steps that must each hold: all clearly hold, yes; any clearly fails, no; else not
/// resolved.
fn all_of(steps: &[Reproduced]) -> Reproduced {
    if steps.iter().all(|s| *s == Reproduced::Yes) {
        Reproduced::Yes
    } else if steps.contains(&Reproduced::No) {
        Reproduced::No
    } else {
        Reproduced::NotResolved
    }
}

impl Rule {
    /// The metrics the rule reads.
    pub fn metrics(&self) -> Vec<&str> {
        match self {
            Rule::Decreasing { metrics } => metrics.iter().map(String::as_str).collect(),
            Rule::Exceeds { metric, than, .. } => vec![metric, than],
            Rule::Within { metric, .. } => vec![metric],
            Rule::Largest { metric, among } | Rule::Smallest { metric, among } => {
                std::iter::once(metric.as_str())
                    .chain(among.iter().map(String::as_str))
                    .collect()
            }
        }
    }

    /// The differences the rule compares, `(a, b)` for "a above b".
    fn pairs(&self) -> Vec<(&str, &str)> {
        match self {
            Rule::Decreasing { metrics } => metrics
                .windows(2)
                .map(|w| (w[0].as_str(), w[1].as_str()))
                .collect(),
            Rule::Exceeds { metric, than, .. } => vec![(metric, than)],
            Rule::Within { .. } => Vec::new(),
            Rule::Largest { metric, among } => among
                .iter()
                .map(|o| (metric.as_str(), o.as_str()))
                .collect(),
            Rule::Smallest { metric, among } => among
                .iter()
                .map(|o| (o.as_str(), metric.as_str()))
                .collect(),
        }
    }

    /// The differences the rule reads, with their intervals (a bootstrap drawing from
    /// `seed`: the finding's own, [`super::evidence::seed_of`] its id).
    pub fn comparisons(&self, m: &Measures, seed: u64) -> Vec<Comparison> {
        self.pairs()
            .into_iter()
            .filter_map(|(a, b)| {
                let (x, y) = (m.get(a)?, m.get(b)?);
                let (difference, interval) = super::evidence::difference(x, y, seed);
                Some(Comparison {
                    metric: a.into(),
                    than: b.into(),
                    difference,
                    interval,
                })
            })
            .collect()
    }

    /// Applies the rule to `m`, with the measures' intervals (docs/reproduce.md).
    pub fn judge(&self, m: &Measures) -> Reproduced {
        self.judge_seeded(m, 0)
    }

    /// [`Rule::judge`], with the bootstraps of its differences drawn from `seed`.
    pub fn judge_seeded(&self, m: &Measures, seed: u64) -> Reproduced {
        for name in self.metrics() {
            if !m.get(name).is_some_and(|v| v.value.is_finite()) {
                return Reproduced::NotMeasured;
            }
        }
        let comparisons = self.comparisons(m, seed);
        let steps: Vec<Reproduced> = comparisons
            .iter()
            .map(|c| exceeds(c.difference, c.interval, 0.0))
            .collect();
        match self {
            Rule::Decreasing { .. } => {
                let held = steps.iter().filter(|s| **s == Reproduced::Yes).count();
                match all_of(&steps) {
                    Reproduced::No if held > 0 && 2 * held >= steps.len() => Reproduced::Partly,
                    verdict => verdict,
                }
            }
            Rule::Exceeds { by, .. } => {
                let c = &comparisons[0];
                exceeds(c.difference, c.interval, *by)
            }
            Rule::Within { metric, lo, hi } => {
                let v = &m[metric.as_str()];
                match v.interval {
                    Some((a, b)) if a >= *lo && b <= *hi => Reproduced::Yes,
                    Some((a, b)) if b < *lo || a > *hi => Reproduced::No,
                    // a range is one claim: an interval across its edge cannot tell
                    Some(_) => Reproduced::NotResolved,
                    None if (*lo..=*hi).contains(&v.value) => Reproduced::Yes,
                    None => Reproduced::No,
                }
            }
            Rule::Largest { .. } | Rule::Smallest { .. } => all_of(&steps),
        }
    }

    /// Whether the claim holds at the measured values alone, intervals aside (how each
    /// replicate is counted).
    pub fn holds_at_point(&self, m: &Measures) -> bool {
        let points: Measures = m.iter().map(|(k, v)| (k.clone(), v.point())).collect();
        self.judge(&points) == Reproduced::Yes
    }

    /// The rule in words.
    pub fn describe(&self) -> String {
        match self {
            Rule::Decreasing { metrics } => metrics.join(" > "),
            Rule::Exceeds { metric, than, by } if *by == 0.0 => format!("{metric} > {than}"),
            Rule::Exceeds { metric, than, by } => format!("{metric} >= {than} + {by}"),
            Rule::Within { metric, lo, hi } => format!("{lo} <= {metric} <= {hi}"),
            Rule::Largest { metric, among } => format!("{metric} > each of {}", among.join(", ")),
            Rule::Smallest { metric, among } => format!("{metric} < each of {}", among.join(", ")),
        }
    }
}

/// One metric through the value lens: the paper's number `paper` inside our interval, or
/// our whole interval within `tolerance` of it, is "yes"; our interval wholly outside that
/// band is "no"; anything else "not resolved". With no interval, the point decides.
pub fn value_lens(m: &Measure, paper: f64, tolerance: f64) -> Reproduced {
    let (lo, hi) = m.interval.unwrap_or((m.value, m.value));
    let (band_lo, band_hi) = (paper - tolerance, paper + tolerance);
    if (lo <= paper && paper <= hi) || (band_lo <= lo && hi <= band_hi) {
        Reproduced::Yes
    } else if hi < band_lo || lo > band_hi {
        Reproduced::No
    } else {
        Reproduced::NotResolved
    }
}

impl Finding {
    /// The value lens over every metric the paper gives a number for: "yes" if each
    /// metric's is, "no" if any is, otherwise "not resolved"; `None` where the paper gives
    /// no number (an order, a sign) and "not measured" where a metric is missing.
    pub fn value_verdict(&self, m: &Measures) -> Option<Reproduced> {
        if self.value.is_empty() {
            return None;
        }
        let mut verdicts = Vec::new();
        for (metric, &(paper, tolerance)) in &self.value {
            match m.get(metric).filter(|v| v.value.is_finite()) {
                None => return Some(Reproduced::NotMeasured),
                Some(v) => verdicts.push(value_lens(v, paper, tolerance)),
            }
        }
        Some(all_of(&verdicts))
    }

    /// The rule applied to the paper's own counts, where it prints the counts of every
    /// metric the rule reads: whether its effect was clear at its own n.
    pub fn paper_verdict(&self) -> Option<Reproduced> {
        let metrics = self.rule.metrics();
        if metrics.iter().any(|m| !self.paper_counts.contains_key(*m)) {
            return None;
        }
        let m: Measures = self
            .paper_counts
            .iter()
            .map(|(name, terms)| {
                let terms = terms
                    .iter()
                    .map(|&(coef, k, n)| super::evidence::Count { coef, k, n })
                    .collect();
                (name.clone(), Measure::counts(terms))
            })
            .collect();
        Some(self.rule.judge(&m))
    }
}

/// One finding with our values and its verdict.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Judged {
    #[serde(flatten)]
    pub finding: Finding,
    pub rule_text: String,
    /// The values the rule read, by metric (pooled over the replicates).
    pub ours: BTreeMap<String, Option<Measure>>,
    /// The differences the rule compared, with their intervals.
    pub comparisons: Vec<Comparison>,
    pub reproduced: Reproduced,
    /// The value lens: the paper's numbers against ours (`None`: the paper gives none).
    #[serde(default)]
    pub value_verdict: Option<Reproduced>,
    /// What was seen of this finding while the simulator was chosen (docs/standings.toml).
    #[serde(default)]
    pub standing: super::standing::Standing,
    /// The record that gave the standing, in words.
    #[serde(default)]
    pub standing_why: String,
    /// The verdict a prediction committed before the run expected, if one did.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub predicted: Option<String>,
    /// The prediction that pre-registered it (a pre-registered row).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub prediction: Option<super::standing::PredictionRef>,
    /// Replicates in which the claim held at the point, and replicates that measured it.
    pub held_in: (u32, u32),
    /// The rule on the paper's own counts, where it gives them.
    pub paper_verdict: Option<Reproduced>,
    /// Simulator parameters whose values were chosen with this finding in view: a
    /// calibrated finding, counted apart from the held-out ones.
    pub calibrated_by: Vec<String>,
    /// The sensitivity variants (`parameter@low`) that change its verdict; `None` where no
    /// sensitivity study was run, empty where none does.
    pub sensitive_to: Option<Vec<String>>,
    /// Whether the study's noise reference (other seeds, same parameters) changes its
    /// verdict; `None` where none was run.
    pub changes_with_seeds: Option<bool>,
    /// Its verdict under each recorded switch (docs/standings.toml `[[switch]]`): the
    /// null simulator, the configurations in and out of the plausible ranges.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub switches: Vec<super::standing::SwitchOutcome>,
}

/// Judges every finding against the pooled measures `m`, counting in how many of the
/// replicates' own measures each claim held.
pub fn judge_all(findings: &[Finding], m: &Measures, replicates: &[Measures]) -> Vec<Judged> {
    findings
        .iter()
        .map(|f| {
            let seed = super::evidence::seed_of(&f.id);
            let measured = |r: &Measures| f.rule.metrics().iter().all(|k| r.contains_key(*k));
            let counted: Vec<&Measures> = replicates.iter().filter(|r| measured(r)).collect();
            Judged {
                rule_text: f.rule.describe(),
                ours: f
                    .rule
                    .metrics()
                    .into_iter()
                    .map(|k| (k.to_string(), m.get(k).cloned()))
                    .collect(),
                comparisons: f.rule.comparisons(m, seed),
                reproduced: f.rule.judge_seeded(m, seed),
                value_verdict: f.value_verdict(m),
                standing: super::standing::Standing::NeverSeen,
                standing_why: String::new(),
                predicted: None,
                prediction: None,
                switches: Vec::new(),
                held_in: (
                    counted.iter().filter(|r| f.rule.holds_at_point(r)).count() as u32,
                    counted.len() as u32,
                ),
                paper_verdict: f.paper_verdict(),
                calibrated_by: Vec::new(),
                sensitive_to: None,
                changes_with_seeds: None,
                finding: f.clone(),
            }
        })
        .collect()
}

/// How many of some findings' verdicts are of each kind.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub struct Tally {
    pub yes: usize,
    pub partly: usize,
    pub no: usize,
    pub not_resolved: usize,
    pub not_measured: usize,
    pub total: usize,
}

impl Tally {
    fn add(&mut self, v: Reproduced) {
        self.total += 1;
        match v {
            Reproduced::Yes => self.yes += 1,
            Reproduced::Partly => self.partly += 1,
            Reproduced::No => self.no += 1,
            Reproduced::NotResolved => self.not_resolved += 1,
            Reproduced::NotMeasured => self.not_measured += 1,
        }
    }

    /// The shape lens (the rule) over `judged`.
    pub fn of<'a>(judged: impl IntoIterator<Item = &'a Judged>) -> Self {
        let mut t = Tally::default();
        for j in judged {
            t.add(j.reproduced);
        }
        t
    }

    /// The value lens over those of `judged` that have one.
    pub fn of_values<'a>(judged: impl IntoIterator<Item = &'a Judged>) -> Self {
        let mut t = Tally::default();
        for v in judged.into_iter().filter_map(|j| j.value_verdict) {
            t.add(v);
        }
        t
    }
}

/// The findings of one standing, through both lenses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct StandingTally {
    pub standing: super::standing::Standing,
    pub shape: Tally,
    pub value: Tally,
}

/// The findings tallied by standing, evidence first (standings with no finding left out).
pub fn by_standing(judged: &[Judged]) -> Vec<StandingTally> {
    super::standing::Standing::ALL
        .iter()
        .map(|&standing| {
            let rows: Vec<&Judged> = judged.iter().filter(|j| j.standing == standing).collect();
            StandingTally {
                standing,
                shape: Tally::of(rows.iter().copied()),
                value: Tally::of_values(rows.iter().copied()),
            }
        })
        .filter(|t| t.shape.total > 0)
        .collect()
}

/// The evidence: pre-registered and never-seen findings, through both lenses.
pub fn evidence(judged: &[Judged]) -> (Tally, Tally) {
    let rows = || judged.iter().filter(|j| j.standing.is_evidence());
    (Tally::of(rows()), Tally::of_values(rows()))
}

/// Gives each finding its standing from `records` and the parameters calibrated against
/// it ([`mark_calibrated`] first), and the verdict a prediction expected of it.
/// The shipped standing records (`docs/standings.toml`), checked against the shipped
/// findings.
pub fn shipped_standings() -> super::standing::Records {
    let findings = paper();
    let ids: Vec<&str> = findings.iter().map(|f| f.id.as_str()).collect();
    super::standing::shipped(&ids)
}

pub fn mark_standings(judged: &mut [Judged], records: &super::standing::Records) {
    for j in judged.iter_mut() {
        let (standing, why) = super::standing::of(&j.finding.id, &j.calibrated_by, records);
        j.standing = standing;
        j.standing_why = why;
        j.predicted = super::standing::predicted(&j.finding.id, records).map(str::to_string);
        j.prediction = (standing == super::standing::Standing::PreRegistered)
            .then(|| super::standing::pre_registered_by(&j.finding.id, records))
            .flatten();
        j.switches = super::standing::switch_outcomes(&j.finding.id, records);
    }
}

/// Marks each finding with the parameters calibrated against it.
pub fn mark_calibrated<'a>(
    judged: &mut [Judged],
    calibrations: impl IntoIterator<Item = (&'a str, &'a [String])>,
) {
    for (parameter, findings) in calibrations {
        for j in judged.iter_mut() {
            if findings.contains(&j.finding.id) && !j.calibrated_by.iter().any(|p| p == parameter) {
                j.calibrated_by.push(parameter.to_string());
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn measures(pairs: &[(&str, f64)]) -> Measures {
        pairs
            .iter()
            .map(|(k, v)| (k.to_string(), Measure::exact(*v)))
            .collect()
    }

    fn names(v: &[&str]) -> Vec<String> {
        v.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn the_shipped_findings_parse_and_every_rule_names_its_metrics() {
        let f = paper();
        assert!(f.len() >= 25, "{}", f.len());
        for finding in &f {
            assert!(!finding.rule.metrics().is_empty(), "{}", finding.id);
            // with nothing measured, nothing reproduces
            assert_eq!(
                finding.rule.judge(&Measures::new()),
                Reproduced::NotMeasured,
                "{}",
                finding.id
            );
        }
    }

    #[test]
    fn the_value_lens_asks_for_the_papers_number_in_our_interval_or_ours_within_its_tolerance() {
        let at = |v: f64, lo: f64, hi: f64| Measure::with_interval(v, (lo, hi));
        // (ours, the paper's number, its tolerance, the verdict)
        let cases = [
            // the paper's 0.972 inside our interval
            (at(0.96, 0.95, 0.975), 0.972, 0.03, Reproduced::Yes),
            // not inside, but our whole interval within 0.03 of it
            (at(0.95, 0.945, 0.955), 0.972, 0.03, Reproduced::Yes),
            // wholly outside the band: no (0.837 [0.813, 0.861] against 0.972 +- 0.03)
            (at(0.837, 0.813, 0.861), 0.972, 0.03, Reproduced::No),
            // across the band's edge: not resolved
            (at(0.94, 0.93, 0.95), 0.972, 0.03, Reproduced::NotResolved),
            // at the edge exactly: inside
            (at(0.942, 0.942, 0.942), 0.972, 0.03, Reproduced::Yes),
            // a point decides alone
            (Measure::exact(13.0), 13.0, 0.0, Reproduced::Yes),
            (Measure::exact(15.1), 13.0, 2.0, Reproduced::No),
        ];
        for (ours, paper, tolerance, verdict) in &cases {
            assert_eq!(
                value_lens(ours, *paper, *tolerance),
                *verdict,
                "{ours:?} against {paper} +- {tolerance}"
            );
        }
        // a row: every metric, and none missing
        let f = Finding {
            value: [("a".to_string(), (0.5, 0.1)), ("b".to_string(), (0.2, 0.1))].into(),
            value_why: Some("test".into()),
            ..paper().remove(0)
        };
        let m = |a: f64, b: f64| measures(&[("a", a), ("b", b)]);
        assert_eq!(f.value_verdict(&m(0.55, 0.25)), Some(Reproduced::Yes));
        assert_eq!(f.value_verdict(&m(0.55, 0.35)), Some(Reproduced::No));
        assert_eq!(
            f.value_verdict(&measures(&[("a", 0.5)])),
            Some(Reproduced::NotMeasured)
        );
        let none = Finding {
            value: BTreeMap::new(),
            value_why: None,
            ..f.clone()
        };
        assert_eq!(none.value_verdict(&m(0.5, 0.2)), None);
    }

    #[test]
    fn every_range_with_the_papers_counts_is_won_by_those_counts() {
        // a rule the paper's own data cannot win is no fair test of it
        for f in paper() {
            if let (Rule::Within { .. }, Some(v)) = (&f.rule, f.paper_verdict()) {
                assert_eq!(
                    v,
                    Reproduced::Yes,
                    "{}: the paper's own counts give {v:?}",
                    f.id
                );
            }
        }
    }

    #[test]
    fn decreasing_holds_partly_or_not() {
        let rule = Rule::Decreasing {
            metrics: names(&["a", "b", "c"]),
        };
        assert_eq!(
            rule.judge(&measures(&[("a", 0.97), ("b", 0.95), ("c", 0.75)])),
            Reproduced::Yes
        );
        assert_eq!(
            rule.judge(&measures(&[("a", 0.90), ("b", 0.95), ("c", 0.75)])),
            Reproduced::Partly
        );
        assert_eq!(
            rule.judge(&measures(&[("a", 0.7), ("b", 0.8), ("c", 0.9)])),
            Reproduced::No
        );
        assert_eq!(
            rule.judge(&measures(&[("a", 0.9), ("b", 0.8)])),
            Reproduced::NotMeasured
        );
    }

    #[test]
    fn exceeds_by_a_margin() {
        let rule = Rule::Exceeds {
            metric: "svm".into(),
            than: "threshold".into(),
            by: 0.1,
        };
        let judge = |a, b| rule.judge(&measures(&[("svm", a), ("threshold", b)]));
        assert_eq!(judge(0.97, 0.75), Reproduced::Yes);
        assert_eq!(judge(0.91, 0.90), Reproduced::Partly);
        assert_eq!(judge(0.90, 0.915), Reproduced::No);
        // with no margin, a tie is not "above"
        let strict = Rule::Exceeds {
            metric: "a".into(),
            than: "b".into(),
            by: 0.0,
        };
        assert_eq!(
            strict.judge(&measures(&[("a", 0.0), ("b", 0.0)])),
            Reproduced::No
        );
    }

    #[test]
    fn within_a_range_or_its_interval() {
        let rule = Rule::Within {
            metric: "d".into(),
            lo: 10.0,
            hi: 50.0,
        };
        let mut m = measures(&[("d", 30.0)]);
        assert_eq!(rule.judge(&m), Reproduced::Yes);
        // a range is one claim, with no parts: an interval across an edge cannot tell
        m.insert("d".into(), Measure::with_interval(8.0, (6.0, 11.0)));
        assert_eq!(rule.judge(&m), Reproduced::NotResolved);
        m.insert("d".into(), Measure::with_interval(45.0, (40.0, 55.0)));
        assert_eq!(rule.judge(&m), Reproduced::NotResolved);
        // at the edges themselves: inside
        m.insert("d".into(), Measure::with_interval(10.0, (10.0, 50.0)));
        assert_eq!(rule.judge(&m), Reproduced::Yes);
        m.insert("d".into(), Measure::with_interval(9.0, (8.0, 9.999)));
        assert_eq!(rule.judge(&m), Reproduced::No);
        m.insert("d".into(), Measure::with_interval(45.0, (40.0, 50.0)));
        assert_eq!(rule.judge(&m), Reproduced::Yes);
        m.insert("d".into(), Measure::exact(4.0));
        assert_eq!(rule.judge(&m), Reproduced::No);
        m.insert("d".into(), Measure::exact(f64::NAN));
        assert_eq!(rule.judge(&m), Reproduced::NotMeasured);
    }

    #[test]
    fn largest_and_smallest() {
        let largest = Rule::Largest {
            metric: "s0".into(),
            among: names(&["s1", "s2"]),
        };
        let smallest = Rule::Smallest {
            metric: "s0".into(),
            among: names(&["s1", "s2"]),
        };
        let m = measures(&[("s0", 0.87), ("s1", 0.82), ("s2", 0.80)]);
        assert_eq!(largest.judge(&m), Reproduced::Yes);
        assert_eq!(smallest.judge(&m), Reproduced::No);
        let m = measures(&[("s0", 0.70), ("s1", 0.82), ("s2", 0.80)]);
        assert_eq!(largest.judge(&m), Reproduced::No);
        assert_eq!(smallest.judge(&m), Reproduced::Yes);
    }

    #[test]
    fn a_bad_findings_file_is_named() {
        let e = parse("[[finding]]\nid = \"x\"\n", "f.toml").unwrap_err();
        assert!(e.to_string().starts_with("f.toml: "), "{e}");
        let row = "[[finding]]\nid = \"x\"\nsection = \"s\"\nmeasured = \"m\"\npaper = \"p\"\nsource = \"s\"\nrule = { kind = \"within\", metric = \"a\", lo = 0, hi = 1 }\n";
        let e = parse(&format!("{row}{row}"), "f.toml").unwrap_err();
        assert!(e.to_string().contains("`x` appears twice"), "{e}");
        let bad_rule = row.replace("within", "around");
        assert!(parse(&bad_rule, "f.toml").is_err());
    }

    #[test]
    fn a_difference_inside_its_interval_is_not_resolved_and_one_clear_of_it_is_decided() {
        let rule = Rule::Exceeds {
            metric: "a".into(),
            than: "b".into(),
            by: 0.0,
        };
        let judge = |ka, kb, n| {
            let mut m = Measures::new();
            m.insert("a".into(), Measure::proportion(ka, n));
            m.insert("b".into(), Measure::proportion(kb, n));
            rule.judge(&m)
        };
        // the paper's 180-degree effect: 37/40 against 31/40 is not clear at n = 40
        assert_eq!(judge(37, 31, 40), Reproduced::NotResolved);
        // the same rates over 400 trials are
        assert_eq!(judge(370, 310, 400), Reproduced::Yes);
        // and the reverse is a clear "no"
        assert_eq!(judge(310, 370, 400), Reproduced::No);
        // a tie with intervals is not resolved, not "no"
        assert_eq!(judge(20, 20, 40), Reproduced::NotResolved);
        // at the point alone all three are decided as before
        let at_point = |ka: u64, kb: u64| {
            let mut m = Measures::new();
            m.insert("a".into(), Measure::proportion(ka, 40));
            m.insert("b".into(), Measure::proportion(kb, 40));
            rule.holds_at_point(&m)
        };
        assert!(at_point(37, 31));
        assert!(!at_point(31, 37));
    }

    #[test]
    fn a_margin_needs_the_whole_interval_above_it() {
        let rule = Rule::Exceeds {
            metric: "a".into(),
            than: "b".into(),
            by: 0.1,
        };
        let judge = |ka, kb| {
            let mut m = Measures::new();
            m.insert("a".into(), Measure::proportion(ka, 250));
            m.insert("b".into(), Measure::proportion(kb, 250));
            rule.judge(&m)
        };
        // 0.30 - 0.05: the interval of 0.25 clears 0.1
        assert_eq!(judge(75, 12), Reproduced::Yes);
        // 0.10 - 0.05: clearly above, clearly by less than 0.1
        assert_eq!(judge(25, 12), Reproduced::Partly);
        // 0.16 - 0.05: the interval straddles the margin
        assert_eq!(judge(40, 12), Reproduced::NotResolved);
        // 0.06 - 0.05: not clearly above, and clearly short of the margin
        assert_eq!(judge(15, 12), Reproduced::No);
    }

    #[test]
    fn within_decides_by_where_the_interval_lies() {
        let rule = Rule::Within {
            metric: "r".into(),
            lo: 0.6,
            hi: 0.9,
        };
        let judge = |k, n| {
            let mut m = Measures::new();
            m.insert("r".into(), Measure::proportion(k, n));
            rule.judge(&m)
        };
        assert_eq!(judge(375, 500), Reproduced::Yes); // 0.75 [0.71, 0.79]
        assert_eq!(judge(15, 20), Reproduced::NotResolved); // 0.75 [0.53, 0.89]: not clear
        assert_eq!(judge(10, 200), Reproduced::No); // 0.05, far below
        assert_eq!(judge(11, 20), Reproduced::NotResolved); // below, interval reaches in
    }

    #[test]
    fn decreasing_and_largest_with_intervals() {
        let rule = Rule::Decreasing {
            metrics: names(&["a", "b", "c"]),
        };
        let rep = |a: f64, b: f64, c: f64| -> Measures {
            [("a", a), ("b", b), ("c", c)]
                .iter()
                .map(|(k, v)| (k.to_string(), Measure::exact(*v)))
                .collect()
        };
        let pooled = |reps: &[Measures]| super::super::evidence::pool(reps, &Measures::new());
        // three replicates, each step clear
        let clear = [
            rep(0.88, 0.84, 0.65),
            rep(0.89, 0.85, 0.66),
            rep(0.87, 0.83, 0.64),
        ];
        assert_eq!(rule.judge(&pooled(&clear)), Reproduced::Yes);
        // the first step swings both ways between replicates: not resolved
        let swinging = [
            rep(0.88, 0.84, 0.65),
            rep(0.84, 0.88, 0.66),
            rep(0.87, 0.86, 0.64),
        ];
        assert_eq!(rule.judge(&pooled(&swinging)), Reproduced::NotResolved);
        // the first step clearly fails, the second clearly holds: partly
        let reversed = [
            rep(0.80, 0.84, 0.65),
            rep(0.81, 0.85, 0.66),
            rep(0.79, 0.83, 0.64),
        ];
        assert_eq!(rule.judge(&pooled(&reversed)), Reproduced::Partly);
        let largest = Rule::Largest {
            metric: "a".into(),
            among: names(&["b", "c"]),
        };
        assert_eq!(largest.judge(&pooled(&clear)), Reproduced::Yes);
        assert_eq!(largest.judge(&pooled(&swinging)), Reproduced::NotResolved);
        assert_eq!(largest.judge(&pooled(&reversed)), Reproduced::No);
    }

    #[test]
    fn the_papers_own_counts_are_judged_by_the_same_rule() {
        let f = paper();
        let verdict = |id: &str| {
            f.iter()
                .find(|x| x.id == id)
                .unwrap_or_else(|| panic!("{id}"))
                .paper_verdict()
        };
        // 20 % -> 0 % FP over 50 trials each is clear of the 0.1 margin? 10/50 vs 0/50:
        // the difference's interval starts near 0.09, so not clear of it
        assert_eq!(verdict("sf-rail-fp-drop"), Some(Reproduced::NotResolved));
        // the paper's 180-degree generalisation is not clear at its n
        assert_eq!(
            verdict("wh-global-generalises"),
            Some(Reproduced::NotResolved)
        );
        // all FPs from 1Fr2Sen (14/40 against 0/120) is
        assert_eq!(verdict("wh-fp-sensitive-strategy"), Some(Reproduced::Yes));
        // findings with no counts have no paper verdict
        assert_eq!(verdict("sf-offline-order"), None);
    }

    #[test]
    fn paper_counts_must_belong_to_the_rule() {
        let row = "[[finding]]\nid = \"x\"\nsection = \"s\"\nmeasured = \"m\"\npaper = \"p\"\nsource = \"s\"\nrule = { kind = \"within\", metric = \"a\", lo = 0, hi = 1 }\n";
        let other = format!("{row}paper_counts = {{ \"b\" = [[1, 1, 2]] }}\n");
        let e = parse(&other, "f.toml").unwrap_err();
        assert!(e.to_string().contains("`b`"), "{e}");
        let bad = format!("{row}paper_counts = {{ \"a\" = [[1, 3, 2]] }}\n");
        assert!(parse(&bad, "f.toml").is_err());
        let good = format!("{row}paper_counts = {{ \"a\" = [[1, 1, 2]] }}\n");
        assert_eq!(
            parse(&good, "f.toml").unwrap()[0].paper_counts["a"],
            vec![(1.0, 1, 2)]
        );
    }

    #[test]
    fn the_shipped_standing_records_name_only_findings_that_exist() {
        let r = shipped_standings();
        assert!(r.pipeline_check.len() >= 5);
        assert!(!r.in_view.is_empty());
        assert!(!r.prediction.is_empty());
        // every band names a measure a finding reads, so the page can show what was found
        let read: Vec<String> = paper()
            .iter()
            .flat_map(|f| f.rule.metrics().into_iter().map(str::to_string))
            .collect();
        for (n, p) in r.prediction.iter().enumerate() {
            for metric in p.bands.keys() {
                assert!(
                    read.contains(metric),
                    "prediction {}'s band names `{metric}`, which no finding reads",
                    n + 1
                );
            }
        }
        // and every prediction is of a mechanism
        for n in 1..=r.prediction.len() {
            assert!(
                r.mechanism_of(n).is_some(),
                "prediction {n} names no mechanism"
            );
        }
    }

    /// Issue 53: a row counted as evidence must have been shown able to fail in this
    /// simulator (a switch record), or it would be a pipeline check.
    #[test]
    fn every_shipped_evidence_row_has_a_switch_under_which_it_fails() {
        let (evidence, records) = shipped_evidence();
        // (none at present: see the_shipped_switches_show_none_of_the_curls_rows_...)
        let unshown: Vec<&String> = evidence
            .iter()
            .filter(|id| !super::super::standing::can_fail(id, &records))
            .collect();
        assert!(unshown.is_empty(), "evidence without a switch: {unshown:?}");
    }

    /// The shipped evidence rows, as the shipped records class them.
    fn shipped_evidence() -> (Vec<String>, super::super::standing::Records) {
        let mut judged = judge_all(&paper(), &Measures::new(), &[]);
        let parameters = tmo_sim::parameters::built_in();
        mark_calibrated(
            &mut judged,
            parameters
                .iter()
                .map(|r| (r.name.as_str(), r.calibrated_against.as_slice())),
        );
        let records = shipped_standings();
        mark_standings(&mut judged, &records);
        let evidence = judged
            .iter()
            .filter(|j| j.standing.is_evidence())
            .map(|j| j.finding.id.clone())
            .collect();
        (evidence, records)
    }

    /// Issue 70, items 1 and 2, as the shipped switches found them (docs/standings.toml,
    /// 2026-12-08): none of the curl's three rows is shown to be its physics, so none is
    /// evidence, each for its own reason.
    #[test]
    fn the_shipped_switches_show_none_of_the_curls_rows_to_be_its_physics() {
        use super::super::standing::{null_differs, plausibly_changed, Standing};
        let (evidence, records) = shipped_evidence();
        let mut judged = judge_all(&paper(), &Measures::new(), &[]);
        mark_standings(&mut judged, &records);
        let standing = |id: &str| judged.iter().find(|j| j.finding.id == id).unwrap();
        // the curl decides the thumb's lead (the null simulator turns it, other seeds do
        // not), but no rig inside the plausible ranges changes it
        assert!(null_differs("wh-thumb-best", &records));
        assert!(!plausibly_changed("wh-thumb-best", &records));
        // the harder-than-one-finger row is "no" everywhere, the null simulator too
        assert!(!null_differs("wh-harder-than-one-finger", &records));
        assert!(!plausibly_changed("wh-harder-than-one-finger", &records));
        // the sensitive strategy's row: other seeds alone change it at one replicate
        assert!(!null_differs("wh-fp-sensitive-strategy", &records));
        assert!(!plausibly_changed("wh-fp-sensitive-strategy", &records));
        for id in [
            "wh-thumb-best",
            "wh-harder-than-one-finger",
            "wh-fp-sensitive-strategy",
        ] {
            let j = standing(id);
            assert_eq!(j.standing, Standing::Unshown, "{id}");
            assert!(
                j.standing_why.starts_with("pre-registered ("),
                "{}",
                j.standing_why
            );
            assert!(!j.switches.is_empty(), "{id}");
        }
        // and every row that is evidence is shown by both
        for id in &evidence {
            assert!(
                null_differs(id, &records) && plausibly_changed(id, &records),
                "{id}"
            );
        }
    }
}
