//! The findings page's first section: the evidence (pre-registered and never-seen rows).
//! Each prediction is stated once, with what came of every row it decided; a row's details
//! then name its prediction by number instead of repeating the change. The page opens with
//! this, before the central claims, because only these rows count as the simulator
//! predicting the paper.

use super::findings::{Judged, Reproduced};
use super::standing::{PredictionRef, Standing};
use crate::report::html;

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
pub fn markdown(judged: &[Judged]) -> String {
    let groups = groups(judged);
    if groups.is_empty() {
        return String::new();
    }
    let mut out = "## Evidence: each prediction and what came of it\n\n".to_string();
    out += &format!("{WHY_A_MISS_COUNTS}\n\n");
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
        }
        out += "\n";
    }
    out
}

/// The section as HTML (empty when there is no evidence row): each prediction under its
/// own anchor, which the rows' details link to.
pub fn html_section(judged: &[Judged]) -> String {
    let groups = groups(judged);
    if groups.is_empty() {
        return String::new();
    }
    let mut out = "<h2>Evidence: each prediction and what came of it</h2>\n".to_string();
    out += &format!("<p>{}</p>\n", html::escape(WHY_A_MISS_COUNTS));
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
            out += &format!(
                "<li><code>{}</code> {}: <span class=\"{class}\"><b>{}</b></span></li>\n",
                html::escape(&j.finding.id),
                html::escape(&j.finding.measured),
                html::escape(&outcome(j))
            );
        }
        out += "</ul>\n";
    }
    out
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

    fn shipped_judged() -> Vec<Judged> {
        let mut judged = judge_all(&paper(), &Default::default(), &[]);
        mark_standings(&mut judged, &shipped_standings());
        judged
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
        let md = markdown(&judged);
        let change = &groups[0].prediction.unwrap().change;
        assert_eq!(md.matches(change.as_str()).count(), 1, "{md}");
        assert!(md.starts_with("## Evidence"), "{md}");
        assert!(md.contains(WHY_A_MISS_COUNTS));
        let html = html_section(&judged);
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
}
