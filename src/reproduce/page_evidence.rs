//! The findings page's first section: the evidence (pre-registered and never-seen rows).
//! Each prediction is stated once, with what came of every row it decided; a row's details
//! then name its prediction by number instead of repeating the change. The page opens with
//! this, before the central claims, because only these rows count as the simulator
//! predicting the paper.

use super::findings::{Judged, Measures, Reproduced};
use super::standing::{PredictionRef, Standing};
use crate::report::html;

/// One mechanism's evidence: the rows its predictions decided and how many of their
/// expectations came true. One mechanism's rows are one piece of evidence (issue 70): they
/// hang on the same physics, so they do not count as independent.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct MechanismCount {
    pub name: String,
    pub rows: Vec<String>,
    pub came_true: usize,
}

/// The evidence rows that predictions decided, by the mechanism each prediction is of (a
/// prediction no mechanism names stands for its own), in the predictions' order.
pub fn by_mechanism(judged: &[Judged]) -> Vec<MechanismCount> {
    let mut out: Vec<MechanismCount> = Vec::new();
    for g in groups(judged) {
        let Some(p) = g.prediction else { continue };
        let name = p
            .mechanism
            .clone()
            .unwrap_or_else(|| format!("prediction {}", p.number));
        let at = match out.iter().position(|m| m.name == name) {
            Some(at) => at,
            None => {
                out.push(MechanismCount {
                    name,
                    rows: Vec::new(),
                    came_true: 0,
                });
                out.len() - 1
            }
        };
        let m = &mut out[at];
        m.rows.extend(g.rows.iter().map(|j| j.finding.id.clone()));
        m.came_true += g.rows.iter().filter(|j| came_true(j) == Some(true)).count();
    }
    out
}

/// The headline's words for the evidence by mechanism, to follow "N rows": how many
/// mechanisms were predicted and how many of their expectations came true, and the
/// never-seen rows apart (`None` when no prediction decided a row).
pub fn mechanism_summary(judged: &[Judged]) -> Option<String> {
    let mechanisms = by_mechanism(judged);
    if mechanisms.is_empty() {
        return None;
    }
    let never_seen = judged
        .iter()
        .filter(|j| j.standing == Standing::NeverSeen)
        .count();
    let rows: usize = mechanisms.iter().map(|m| m.rows.len()).sum();
    let held: usize = mechanisms.iter().map(|m| m.came_true).sum();
    let from = format!(
        "from {} mechanism{} ({held} of {rows} expectations came true)",
        mechanisms.len(),
        if mechanisms.len() == 1 { "" } else { "s" }
    );
    Some(if never_seen > 0 {
        format!(": {rows} {from}, {never_seen} never seen")
    } else {
        format!(" {from}")
    })
}

/// What was found of one band of a prediction: the measure's pooled value, and whether it
/// fell inside (`None`: not measured in this run).
fn band_outcome(metric: &str, [lo, hi]: [f64; 2], measures: &Measures) -> (String, Option<bool>) {
    match measures.get(metric).map(|m| m.value) {
        Some(v) => {
            let inside = (lo..=hi).contains(&v);
            (
                format!(
                    "`{metric}` expected {lo}-{hi}, found {}: {}",
                    super::show::number(v),
                    if inside { "inside" } else { "outside" }
                ),
                Some(inside),
            )
        }
        None => (format!("`{metric}` expected {lo}-{hi}, not measured"), None),
    }
}

/// Each band of a prediction, what was found and whether inside; and how many were.
fn bands(p: &PredictionRef, measures: &Measures) -> (Vec<(String, Option<bool>)>, String) {
    let lines: Vec<(String, Option<bool>)> = p
        .bands
        .iter()
        .map(|(metric, band)| band_outcome(metric, *band, measures))
        .collect();
    let inside = lines.iter().filter(|(_, i)| *i == Some(true)).count();
    let measured = lines.iter().filter(|(_, i)| i.is_some()).count();
    (
        lines,
        format!("{inside} of {measured} measured values inside their bands"),
    )
}

/// Why a prediction that did not come true is kept among the evidence, in the page's words.
pub const WHY_A_MISS_COUNTS: &str = "A prediction that did not come true counts as evidence all the same: it was committed before its run, and a configuration was run under which its row fails, so the row was free to go either way. The miss measures where the simulator's physics, or our reasoning about it, departs from the paper's rig; keeping only the predictions that came true would count only what flatters the simulator.";

/// The evidence rows under one heading: a prediction's, or those never seen while the
/// simulator was chosen (no prediction).
#[derive(Debug)]
pub struct EvidenceGroup<'a> {
    pub prediction: Option<&'a PredictionRef>,
    pub rows: Vec<&'a Judged>,
}

/// The evidence rows grouped by the prediction that pre-registered them (in the
/// predictions' order), then the never-seen rows; each group's rows in the findings' order.
pub fn groups(judged: &[Judged]) -> Vec<EvidenceGroup<'_>> {
    let mut numbers: Vec<usize> = judged
        .iter()
        .filter(|j| j.standing.is_evidence())
        .filter_map(|j| j.prediction.as_ref().map(|p| p.number))
        .collect();
    numbers.sort_unstable();
    numbers.dedup();
    let mut out: Vec<EvidenceGroup> = numbers
        .iter()
        .map(|n| {
            let rows: Vec<&Judged> = judged
                .iter()
                .filter(|j| j.standing.is_evidence())
                .filter(|j| j.prediction.as_ref().is_some_and(|p| p.number == *n))
                .collect();
            EvidenceGroup {
                prediction: rows[0].prediction.as_ref(),
                rows,
            }
        })
        .collect();
    let unpredicted: Vec<&Judged> = judged
        .iter()
        .filter(|j| j.standing.is_evidence() && j.prediction.is_none())
        .collect();
    if !unpredicted.is_empty() {
        out.push(EvidenceGroup {
            prediction: None,
            rows: unpredicted,
        });
    }
    out
}

/// Whether a pre-registered row's expectation came true (`None`: no prediction).
fn came_true(j: &Judged) -> Option<bool> {
    match (&j.predicted, j.standing) {
        (Some(expected), Standing::PreRegistered) => Some(expected == j.reproduced.label()),
        _ => None,
    }
}

/// What came of one evidence row: the verdict expected and found, and whether the
/// expectation came true.
pub fn outcome(j: &Judged) -> String {
    let found = j.reproduced.label();
    match (came_true(j), &j.predicted) {
        (Some(true), Some(expected)) => format!("expected {expected}, found {found}: came true"),
        (Some(false), Some(expected)) => {
            format!("expected {expected}, found {found}: did not come true")
        }
        _ => format!("no prediction; found {found}"),
    }
}

/// The anchor a prediction's heading has on the page (Markdown and HTML alike).
pub fn anchor(number: usize) -> String {
    format!("prediction-{number}")
}

fn heading(g: &EvidenceGroup) -> String {
    match g.prediction {
        Some(p) => format!("Prediction {}", p.number),
        None => "Never seen while the simulator was chosen".to_string(),
    }
}

fn tally(rows: &[&Judged]) -> String {
    let held = rows.iter().filter(|j| came_true(j) == Some(true)).count();
    format!("{held} of {} expectations came true", rows.len())
}

/// The section as Markdown (empty when there is no evidence row).
pub fn markdown(judged: &[Judged], measures: &Measures) -> String {
    let groups = groups(judged);
    if groups.is_empty() {
        return none_shown_markdown(judged);
    }
    let mut out = "## Evidence: each prediction and what came of it\n\n".to_string();
    out += &format!("{WHY_A_MISS_COUNTS}\n\n");
    for m in by_mechanism(judged) {
        out += &format!("- {}\n", mechanism_line(&m));
    }
    out += &format!("\n{ONE_MECHANISM}\n\n{SWITCHES_EXPLAINED}\n\n");
    for g in &groups {
        out += &format!("### {}\n\n", heading(g));
        if let Some(p) = g.prediction {
            out += &format!("{} ({}).\n\n", p.change, tally(&g.rows));
        }
        for j in &g.rows {
            out += &format!(
                "- `{}` {}: **{}**\n",
                j.finding.id,
                j.finding.measured,
                outcome(j)
            );
            if let Some(line) = switch_line(j) {
                out += &format!("  - {line}\n");
            }
        }
        if let Some(p) = g.prediction.filter(|p| !p.bands.is_empty()) {
            let (lines, count) = bands(p, measures);
            out += &format!("\nIts tolerances ({count}):\n\n");
            for (line, _) in lines {
                out += &format!("- {line}\n");
            }
        }
        out += "\n";
    }
    out
}

/// The section as HTML (empty when there is no evidence row): each prediction under its
/// own anchor, which the rows' details link to.
pub fn html_section(judged: &[Judged], measures: &Measures) -> String {
    let groups = groups(judged);
    if groups.is_empty() {
        return none_shown_html(judged);
    }
    let mut out = "<h2>Evidence: each prediction and what came of it</h2>\n".to_string();
    out += &format!("<p>{}</p>\n<ul>\n", html::escape(WHY_A_MISS_COUNTS));
    for m in by_mechanism(judged) {
        out += &format!("<li>{}</li>\n", html::inline_markdown(&mechanism_line(&m)));
    }
    out += &format!(
        "</ul>\n<p>{}</p>\n<p>{}</p>\n",
        html::escape(ONE_MECHANISM),
        html::inline_markdown(SWITCHES_EXPLAINED)
    );
    for g in &groups {
        let id = g
            .prediction
            .map(|p| format!(" id=\"{}\"", anchor(p.number)))
            .unwrap_or_default();
        out += &format!("<h3{id}>{}</h3>\n", html::escape(&heading(g)));
        if let Some(p) = g.prediction {
            out += &format!(
                "<p class=\"details\">{} ({}).</p>\n",
                html::inline_markdown(&p.change),
                html::escape(&tally(&g.rows))
            );
        }
        out += "<ul>\n";
        for j in &g.rows {
            let class = match came_true(j) {
                Some(true) => "yes",
                Some(false) => "no",
                None => verdict_class(j.reproduced),
            };
            let switches = switch_line(j)
                .map(|l| {
                    format!(
                        "<br><span class=\"details\">{}</span>",
                        html::inline_markdown(&l)
                    )
                })
                .unwrap_or_default();
            out += &format!(
                "<li><code>{}</code> {}: <span class=\"{class}\"><b>{}</b></span>{switches}</li>\n",
                html::escape(&j.finding.id),
                html::escape(&j.finding.measured),
                html::escape(&outcome(j))
            );
        }
        out += "</ul>\n";
        if let Some(p) = g.prediction.filter(|p| !p.bands.is_empty()) {
            let (lines, count) = bands(p, measures);
            out += &format!("<p>Its tolerances ({}):</p>\n<ul>\n", html::escape(&count));
            for (line, inside) in lines {
                let class = match inside {
                    Some(true) => "yes",
                    Some(false) => "no",
                    None => "not_measured",
                };
                out += &format!(
                    "<li><span class=\"{class}\">{}</span></li>\n",
                    html::inline_markdown(&line)
                );
            }
            out += "</ul>\n";
        }
    }
    out
}

/// A row's verdicts under the recorded switches, each beside its own baseline (same seeds,
/// same size): the null simulator first, then the configurations a rig could have, then
/// those outside the plausible ranges (`None`: no switch recorded the row).
pub fn switch_line(j: &Judged) -> Option<String> {
    use super::standing::SwitchKind;
    if j.switches.is_empty() {
        return None;
    }
    let mut parts = Vec::new();
    for kind in [
        SwitchKind::Null,
        SwitchKind::InRange,
        SwitchKind::OtherSeeds,
        SwitchKind::OutOfRange,
    ] {
        for o in j.switches.iter().filter(|o| o.kind == kind) {
            parts.push(format!(
                "{} `{}`: {} -> {}",
                kind.label(),
                o.switch,
                o.verdicts[0],
                o.verdicts[1]
            ));
        }
    }
    Some(format!(
        "under other configurations (baseline -> there): {}",
        parts.join("; ")
    ))
}

/// The rows a prediction or no sight of them would have made evidence but that are not
/// shown to be their physics.
fn unshown(judged: &[Judged]) -> Vec<&Judged> {
    judged
        .iter()
        .filter(|j| j.standing == Standing::Unshown)
        .collect()
}

/// Why the section lists unshown rows when no row is evidence, in the page's words.
pub const NONE_SHOWN: &str = "No row is evidence: each row a prediction or no sight of it would have made evidence is not shown to be decided by its physics (docs/reproduce.md, \"Standings\"). Those rows, with what was found:";

const NONE_SHOWN_HEADING: &str = "Evidence: none shown yet";

/// The section when no row is evidence: the unshown rows and why (empty without them).
fn none_shown_markdown(judged: &[Judged]) -> String {
    let rows = unshown(judged);
    if rows.is_empty() {
        return String::new();
    }
    let mut out = format!("## {NONE_SHOWN_HEADING}\n\n{SWITCHES_EXPLAINED}\n\n{NONE_SHOWN}\n\n");
    for j in rows {
        out += &format!(
            "- `{}` {}: **{}**; {}\n",
            j.finding.id,
            j.finding.measured,
            j.reproduced.label(),
            j.standing_why
        );
        if let Some(line) = switch_line(j) {
            out += &format!("  - {line}\n");
        }
    }
    out + "\n"
}

/// [`none_shown_markdown`] as HTML.
fn none_shown_html(judged: &[Judged]) -> String {
    let rows = unshown(judged);
    if rows.is_empty() {
        return String::new();
    }
    let mut out = format!(
        "<h2>{NONE_SHOWN_HEADING}</h2>\n<p>{}</p>\n<p>{}</p>\n<ul>\n",
        html::inline_markdown(SWITCHES_EXPLAINED),
        html::escape(NONE_SHOWN)
    );
    for j in rows {
        let switches = switch_line(j)
            .map(|l| {
                format!(
                    "<br><span class=\"details\">{}</span>",
                    html::inline_markdown(&l)
                )
            })
            .unwrap_or_default();
        out += &format!(
            "<li><code>{}</code> {}: <span class=\"{}\"><b>{}</b></span>; {}{switches}</li>\n",
            html::escape(&j.finding.id),
            html::escape(&j.finding.measured),
            verdict_class(j.reproduced),
            html::escape(j.reproduced.label()),
            html::inline_markdown(&j.standing_why)
        );
    }
    out + "</ul>\n"
}

/// What the switch line under each row says, in the page's words.
pub const SWITCHES_EXPLAINED: &str = "Under each row, its verdict under the configurations recorded in docs/standings.toml, each beside a baseline with the same seeds and size: the **null simulator** (the row's mechanism off, the pin noise raised to match the pin motion it made) must not give the row's verdict, or the verdict would be the definitions' or the noise's, not the mechanism's; a configuration **in range** (every value inside its plausible range) shows the physics a rig could have decides it either way; one **out of range** shows only that it can fail at all.";

/// Why the page counts mechanisms, in its words.
pub const ONE_MECHANISM: &str = "Rows one mechanism decides hang on the same physics (and often the same estimate): they are one piece of evidence, not independent ones.";

fn mechanism_line(m: &MechanismCount) -> String {
    format!(
        "**{}**: {} of {} expectations came true ({})",
        m.name,
        m.came_true,
        m.rows.len(),
        m.rows
            .iter()
            .map(|r| format!("`{r}`"))
            .collect::<Vec<_>>()
            .join(", ")
    )
}

/// The CSS class of a verdict's colour.
pub fn verdict_class(v: Reproduced) -> &'static str {
    match v {
        Reproduced::Yes => "yes",
        Reproduced::Partly => "partly",
        Reproduced::No => "no",
        Reproduced::NotResolved => "not_resolved",
        Reproduced::NotMeasured => "not_measured",
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::reproduce::findings::{judge_all, mark_standings, paper, shipped_standings};

    /// The shipped findings and records, with switches that show every row its physics'
    /// (the shipped ones show none of the curl's rows: issue 70), so the section has rows.
    fn shipped_judged() -> Vec<Judged> {
        let findings = paper();
        let mut judged = judge_all(&findings, &Default::default(), &[]);
        let ids: Vec<&str> = findings.iter().map(|f| f.id.as_str()).collect();
        let mut records = shipped_standings();
        let shown = crate::reproduce::standing::parse(
            &crate::reproduce::standing::shown_switches(&ids),
            "test",
            &ids,
        )
        .unwrap();
        records.switch.extend(shown.switch);
        mark_standings(&mut judged, &records);
        judged
    }

    /// Each evidence row's switch line lists the null simulator first, then the in-range
    /// configurations, then the rest, each beside its own baseline; the page shows it.
    #[test]
    fn an_evidence_rows_switch_line_puts_the_null_simulator_first() {
        use crate::reproduce::standing::{SwitchKind, SwitchOutcome};
        let mut judged = shipped_judged();
        let j = judged
            .iter_mut()
            .find(|j| j.standing.is_evidence())
            .expect("an evidence row");
        let outcome = |switch: &str, kind, v: [&str; 2]| SwitchOutcome {
            switch: switch.into(),
            kind,
            verdicts: v.map(str::to_string),
        };
        j.switches = vec![
            outcome("noise=9", SwitchKind::OutOfRange, ["yes", "no"]),
            outcome("ratio=0.1", SwitchKind::InRange, ["yes", "not resolved"]),
            outcome("ratio=0", SwitchKind::Null, ["yes", "no"]),
            outcome("reseeded", SwitchKind::OtherSeeds, ["yes", "yes"]),
        ];
        let id = j.finding.id.clone();
        let line = switch_line(j).unwrap();
        let at = |s: &str| line.find(s).unwrap_or_else(|| panic!("{s} in {line}"));
        assert!(at("null simulator `ratio=0`: yes -> no") < at("in range `ratio=0.1`"));
        assert!(at("in range `ratio=0.1`: yes -> not resolved") < at("other seeds `reseeded`"));
        assert!(at("other seeds `reseeded`: yes -> yes") < at("out of range `noise=9`"));
        let page = markdown(&judged, &Default::default());
        let row = page.find(&format!("`{id}`")).unwrap();
        assert!(page[row..].contains("null simulator `ratio=0`"), "{page}");
        let mut bare = shipped_judged();
        bare.iter_mut().for_each(|j| j.switches.clear());
        assert!(bare.iter().all(|j| switch_line(j).is_none()));
    }

    /// With no evidence row (the shipped records, 2026-12-08) the section still leads the
    /// page: it lists the unshown rows, each with why and its switches.
    #[test]
    fn with_no_evidence_the_section_lists_the_unshown_rows() {
        let mut judged = judge_all(&paper(), &Default::default(), &[]);
        mark_standings(&mut judged, &shipped_standings());
        assert!(groups(&judged).is_empty());
        let md = markdown(&judged, &Default::default());
        assert!(md.starts_with("## Evidence: none shown yet"), "{md}");
        for id in [
            "wh-thumb-best",
            "wh-harder-than-one-finger",
            "wh-fp-sensitive-strategy",
        ] {
            assert!(md.contains(&format!("- `{id}`")), "{id}: {md}");
        }
        assert!(
            md.contains("null simulator `physics.finger_roll_ratio=0"),
            "{md}"
        );
        let html = html_section(&judged, &Default::default());
        assert!(
            html.starts_with("<h2>Evidence: none shown yet</h2>"),
            "{html}"
        );
        assert!(html.contains("<code>wh-thumb-best</code>"), "{html}");
    }

    /// Every evidence row sits under one heading, its prediction's (stated once) or the
    /// never-seen one; no other row does.
    #[test]
    fn each_evidence_row_is_listed_once_under_its_prediction() {
        let judged = shipped_judged();
        let groups = groups(&judged);
        let listed: Vec<&str> = groups
            .iter()
            .flat_map(|g| g.rows.iter().map(|j| j.finding.id.as_str()))
            .collect();
        let evidence: Vec<&str> = judged
            .iter()
            .filter(|j| j.standing.is_evidence())
            .map(|j| j.finding.id.as_str())
            .collect();
        assert!(!evidence.is_empty());
        let mut sorted = listed.clone();
        sorted.sort_unstable();
        sorted.dedup();
        assert_eq!(sorted.len(), listed.len(), "a row listed twice: {listed:?}");
        assert_eq!(sorted.len(), evidence.len());
        for g in &groups {
            for j in &g.rows {
                assert_eq!(
                    j.prediction.as_ref().map(|p| p.number),
                    g.prediction.map(|p| p.number)
                );
            }
        }
        // the change is stated once in the section, not in each row's details
        let md = markdown(&judged, &Measures::new());
        let change = &groups[0].prediction.unwrap().change;
        assert_eq!(md.matches(change.as_str()).count(), 1, "{md}");
        assert!(md.starts_with("## Evidence"), "{md}");
        assert!(md.contains(WHY_A_MISS_COUNTS));
        let html = html_section(&judged, &Measures::new());
        assert!(html.contains(&format!(
            "id=\"{}\"",
            anchor(groups[0].prediction.unwrap().number)
        )));
    }

    #[test]
    fn an_outcome_says_what_was_expected_and_whether_it_came_true() {
        let judged = shipped_judged();
        let mut j = judged
            .iter()
            .find(|j| j.standing == Standing::PreRegistered)
            .expect("a pre-registered row")
            .clone();
        j.predicted = Some("yes".into());
        j.reproduced = Reproduced::Yes;
        assert_eq!(outcome(&j), "expected yes, found yes: came true");
        j.reproduced = Reproduced::No;
        assert_eq!(outcome(&j), "expected yes, found no: did not come true");
        j.standing = Standing::NeverSeen;
        assert_eq!(outcome(&j), "no prediction; found no");
    }

    /// One mechanism's rows are counted once, under its name, with how many of their
    /// expectations came true; the headline says how many mechanisms.
    #[test]
    fn the_evidence_is_counted_by_mechanism() {
        let mut judged = shipped_judged();
        let predicted: Vec<String> = judged
            .iter()
            .filter(|j| j.standing.is_evidence() && j.prediction.is_some())
            .map(|j| j.finding.id.clone())
            .collect();
        let mechanisms = by_mechanism(&judged);
        let mut counted: Vec<String> = mechanisms.iter().flat_map(|m| m.rows.clone()).collect();
        counted.sort();
        let mut expected = predicted.clone();
        expected.sort();
        assert_eq!(counted, expected);
        // two rows of one mechanism, one expectation true: one mechanism, 1 of 2
        let rows: Vec<usize> = judged
            .iter()
            .enumerate()
            .filter(|(_, j)| j.standing == Standing::PreRegistered)
            .map(|(i, _)| i)
            .take(2)
            .collect();
        assert_eq!(rows.len(), 2, "two pre-registered rows shipped");
        for (k, &i) in rows.iter().enumerate() {
            let j = &mut judged[i];
            j.prediction.as_mut().unwrap().mechanism = Some("m".into());
            j.predicted = Some("yes".into());
            j.reproduced = if k == 0 {
                Reproduced::Yes
            } else {
                Reproduced::No
            };
        }
        judged.retain(|j| {
            j.standing != Standing::PreRegistered
                || j.prediction.as_ref().unwrap().mechanism.as_deref() == Some("m")
        });
        let m = by_mechanism(&judged);
        assert_eq!(m.len(), 1, "{m:?}");
        assert_eq!(
            (m[0].name.as_str(), m[0].rows.len(), m[0].came_true),
            ("m", 2, 1)
        );
        let summary = mechanism_summary(&judged).unwrap();
        assert_eq!(summary, " from 1 mechanism (1 of 2 expectations came true)");
        let md = markdown(&judged, &Measures::new());
        assert!(
            md.contains("- **m**: 1 of 2 expectations came true"),
            "{md}"
        );
        assert!(md.contains(ONE_MECHANISM));
    }

    #[test]
    fn a_band_says_what_was_found_and_whether_it_fell_inside() {
        let mut measures = Measures::new();
        measures.insert("a".into(), crate::reproduce::findings::Measure::exact(0.05));
        measures.insert(
            "b".into(),
            crate::reproduce::findings::Measure::exact(12.345),
        );
        let p = PredictionRef {
            number: 5,
            change: "c".into(),
            mechanism: None,
            bands: [("a", [0.0, 0.1]), ("b", [0.0, 10.0]), ("c", [1.0, 2.0])]
                .map(|(k, v)| (k.to_string(), v))
                .into(),
        };
        let (lines, count) = bands(&p, &measures);
        assert_eq!(count, "1 of 2 measured values inside their bands");
        assert_eq!(
            lines[0],
            (
                "`a` expected 0-0.1, found 0.050: inside".to_string(),
                Some(true)
            )
        );
        assert_eq!(
            lines[1],
            (
                "`b` expected 0-10, found 12.3: outside".to_string(),
                Some(false)
            )
        );
        assert_eq!(
            lines[2],
            ("`c` expected 1-2, not measured".to_string(), None)
        );
    }
}
