//! The paper's findings as data (`docs/paper_findings.toml`, built into the binary) and the
//! rules that decide, from our measurements, whether each one reproduced.

use std::collections::BTreeMap;

/// The findings file, as shipped.
pub const PAPER_FINDINGS: &str = include_str!("../../docs/paper_findings.toml");

/// One of our measurements: a value, with its 95 % interval when it is a rate or a mean.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Measure {
    pub value: f64,
    pub interval: Option<(f64, f64)>,
    /// Trials (or rows) behind it.
    pub n: Option<u64>,
}

impl Measure {
    pub fn exact(value: f64) -> Self {
        Self {
            value,
            interval: None,
            n: None,
        }
    }
}

/// Measurements by metric name.
pub type Measures = BTreeMap<String, Measure>;

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
    /// `lo <= metric <= hi`; "partly" when only its 95 % interval reaches the range.
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
    }
    Ok(file.finding)
}

/// The shipped findings.
pub fn paper() -> Vec<Finding> {
    parse(PAPER_FINDINGS, "docs/paper_findings.toml").expect("the shipped findings parse")
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Reproduced {
    Yes,
    Partly,
    No,
    /// A metric the rule needs was not measured (a step did not run or gave nothing).
    NotMeasured,
}

impl Reproduced {
    pub fn label(self) -> &'static str {
        match self {
            Reproduced::Yes => "yes",
            Reproduced::Partly => "partly",
            Reproduced::No => "no",
            Reproduced::NotMeasured => "not measured",
        }
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

    /// Applies the rule to `m`.
    pub fn judge(&self, m: &Measures) -> Reproduced {
        let mut values = Vec::new();
        for name in self.metrics() {
            match m.get(name) {
                Some(v) if v.value.is_finite() => values.push(*v),
                _ => return Reproduced::NotMeasured,
            }
        }
        match self {
            Rule::Decreasing { .. } => {
                let pairs = values.windows(2).count();
                let held = values
                    .windows(2)
                    .filter(|w| w[0].value > w[1].value)
                    .count();
                if held == pairs {
                    Reproduced::Yes
                } else if 2 * held >= pairs && held > 0 {
                    Reproduced::Partly
                } else {
                    Reproduced::No
                }
            }
            Rule::Exceeds { by, .. } => {
                let (a, b) = (values[0].value, values[1].value);
                if a >= b + by && a > b {
                    Reproduced::Yes
                } else if a > b {
                    Reproduced::Partly
                } else {
                    Reproduced::No
                }
            }
            Rule::Within { lo, hi, .. } => {
                let v = values[0];
                if (*lo..=*hi).contains(&v.value) {
                    Reproduced::Yes
                } else if v.interval.is_some_and(|(a, b)| a <= *hi && b >= *lo) {
                    Reproduced::Partly
                } else {
                    Reproduced::No
                }
            }
            Rule::Largest { .. } => {
                let first = values[0].value;
                if values[1..].iter().all(|v| first > v.value) {
                    Reproduced::Yes
                } else {
                    Reproduced::No
                }
            }
            Rule::Smallest { .. } => {
                let first = values[0].value;
                if values[1..].iter().all(|v| first < v.value) {
                    Reproduced::Yes
                } else {
                    Reproduced::No
                }
            }
        }
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

/// One finding with our values and its verdict.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Judged {
    #[serde(flatten)]
    pub finding: Finding,
    pub rule_text: String,
    /// The values the rule read, by metric.
    pub ours: BTreeMap<String, Option<Measure>>,
    pub reproduced: Reproduced,
}

/// Judges every finding against `m`.
pub fn judge_all(findings: &[Finding], m: &Measures) -> Vec<Judged> {
    findings
        .iter()
        .map(|f| Judged {
            rule_text: f.rule.describe(),
            ours: f
                .rule
                .metrics()
                .into_iter()
                .map(|k| (k.to_string(), m.get(k).copied()))
                .collect(),
            reproduced: f.rule.judge(m),
            finding: f.clone(),
        })
        .collect()
}

/// How many findings reproduced fully, and of how many.
pub fn summary(judged: &[Judged]) -> (usize, usize) {
    (
        judged
            .iter()
            .filter(|j| j.reproduced == Reproduced::Yes)
            .count(),
        judged.len(),
    )
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
        m.insert(
            "d".into(),
            Measure {
                value: 8.0,
                interval: Some((6.0, 11.0)),
                n: Some(10),
            },
        );
        assert_eq!(rule.judge(&m), Reproduced::Partly);
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
    fn the_summary_counts_full_reproductions() {
        let f = paper();
        let judged = judge_all(&f[..3], &Measures::new());
        assert_eq!(summary(&judged), (0, 3));
        assert!(judged
            .iter()
            .all(|j| j.reproduced == Reproduced::NotMeasured));
    }
}
