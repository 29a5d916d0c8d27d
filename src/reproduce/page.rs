//! The findings report of a reproduction: `findings.md`, `findings.json` and a
//! self-contained `findings.html`. Each row gives the verdict first, then the paper's value
//! and ours (pooled over the replicates, with its 95 % interval), in how many replicates
//! the claim held, whether the paper's own effect was clear at its n, and whether a
//! simulator value was calibrated against the row. The evidence comes first (each
//! prediction stated once), then the central claims. Then the paper's tables and figures
//! as `tmo report` makes them from the first replicate.

use std::path::{Path, PathBuf};

use super::findings::{
    by_standing, evidence, judge_all, mark_calibrated, mark_standings, paper, Judged, Measure,
    Measures, Reproduced, StandingTally, Tally,
};
use super::measure::{measure, Observations};
use super::page_evidence::{self, verdict_class};
use super::show::ours;
use super::standing::Standing;
use super::steps::{read_sweep, Preset, Step, Timing};
use super::{io, replicate_dir, ReproduceError};
use crate::report::html;
use crate::runner::score::{LiftRow, OutcomeRow};
use crate::slip::evaluation::Evaluation;
use crate::slip::model::ModelFile;

/// What the report wrote and said.
#[derive(Debug, Clone)]
pub struct Written {
    pub md: PathBuf,
    pub json: PathBuf,
    pub html: PathBuf,
    pub figures: Vec<PathBuf>,
    pub preset: Preset,
    pub replicates: u32,
    pub all: Tally,
    /// The evidence (pre-registered and never-seen findings) through the shape lens (the
    /// rule) and the value lens.
    pub evidence: (Tally, Tally),
    /// Every standing's findings, evidence first.
    pub by_standing: Vec<StandingTally>,
    /// Simulated catch trials with a ground-truth verdict, and how many agree.
    pub truth_agreement: Option<(usize, usize)>,
    /// Verdicts the sensitivity study's noise reference (other seeds alone) changes, and
    /// the verdicts it judged; `None` where no reference was run.
    pub seed_noise: Option<(usize, usize)>,
    /// A user's model that stood in for the hand's global model (`--hand-model`).
    pub hand_model: Option<super::hand_model::HandModel>,
    /// The evidence by mechanism, in the headline's words
    /// ([`page_evidence::mechanism_summary`]).
    pub mechanisms: Option<String>,
}

/// `yes Y, no N, ...` of a tally, the kinds it has.
fn tally_text(t: &Tally) -> String {
    let mut parts = vec![format!("{} yes", t.yes), format!("{} no", t.no)];
    if t.partly > 0 {
        parts.push(format!("{} partly", t.partly));
    }
    parts.push(format!("{} not resolved", t.not_resolved));
    if t.not_measured > 0 {
        parts.push(format!("{} not measured", t.not_measured));
    }
    format!("{} of {}", parts.join(", "), t.total)
}

impl Written {
    /// The headline: the evidence through both lenses, then the other standings' counts.
    pub fn summary_line(&self) -> String {
        let (shape, value) = &self.evidence;
        let mut s = format!(
            "evidence (pre-registered or never-seen findings): {} rows",
            shape.total
        );
        if let Some(by) = &self.mechanisms {
            s += by;
        }
        if shape.total > 0 {
            s += &format!(", rule {}; value {}", tally_text(shape), tally_text(value));
        }
        let others: Vec<String> = self
            .by_standing
            .iter()
            .filter(|t| !t.standing.is_evidence())
            .map(|t| format!("{} {}", t.standing.label(), t.shape.total))
            .collect();
        if !others.is_empty() {
            s += &format!("; not evidence: {}", others.join(", "));
        }
        s + &format!(
            " ({} replicate{})",
            self.replicates,
            if self.replicates == 1 { "" } else { "s" }
        )
    }

    /// Each standing's findings through both lenses, a line each (the page's and the
    /// command's second lines).
    pub fn standing_lines(&self) -> Vec<String> {
        self.by_standing
            .iter()
            .map(|t| {
                let value = if t.value.total > 0 {
                    format!("; value lens: {}", tally_text(&t.value))
                } else {
                    String::new()
                };
                format!(
                    "{}: rule {}{value}",
                    t.standing.label(),
                    tally_text(&t.shape)
                )
            })
            .collect()
    }

    /// How many verdicts other seeds alone change, if a noise reference was run: the
    /// headline's own noise, to read beside it.
    pub fn noise_line(&self) -> Option<String> {
        self.seed_noise.map(|(changed, of)| {
            format!(
                "Other seeds alone (the noise reference: as many replicates again, every seed new) change {changed} of {of} verdicts; those rows are not decided at this many replicates."
            )
        })
    }

    /// The noise line, in every run: the reference's count where one ran beside it, or
    /// the last one measured for this preset and replicate count (docs/noise_reference.toml),
    /// or that none is on record.
    pub fn noise_text(&self) -> String {
        let preset = self.preset;
        if let Some(line) = self.noise_line() {
            return line;
        }
        match last_noise(preset.name(), self.replicates) {
            Some(m) => format!(
                "No noise reference ran beside this run. The last one measured for the {} preset at {} replicate{} (tmo at {}, {}): other seeds alone changed {} of {} verdicts (docs/noise_reference.toml).",
                m.preset,
                m.replicates,
                if m.replicates == 1 { "" } else { "s" },
                m.version,
                m.date,
                m.changed,
                m.of
            ),
            None => format!(
                "No noise reference ran beside this run, and none is on record for the {} preset at {} replicate{}: `--sensitivity --sensitivity-parameters reseeded` measures how many verdicts other seeds alone change.",
                preset.name(),
                self.replicates,
                if self.replicates == 1 { "" } else { "s" }
            ),
        }
    }

    /// How often the marker verdicts agree with ground truth, if any trial has one.
    /// The paragraphs under the headline: which model judged the hand (when a user's did),
    /// the seeds' noise, and the markers' agreement with the ground truth.
    pub fn lead_paragraphs(&self) -> Vec<String> {
        [
            self.hand_model.as_ref().map(|m| m.line()),
            Some(self.noise_text()),
            self.agreement_line(),
        ]
        .into_iter()
        .flatten()
        .collect()
    }

    pub fn agreement_line(&self) -> Option<String> {
        self.truth_agreement.map(|(n, agree)| {
            format!(
                "Marker-scored verdicts agree with the simulator's ground truth in {agree} of {n} simulated catch trials ({:.1} %).",
                100.0 * agree as f64 / n.max(1) as f64
            )
        })
    }
}

/// A noise reference's count on record (docs/noise_reference.toml).
#[derive(Debug, Clone, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct NoiseMeasured {
    preset: String,
    replicates: u32,
    changed: usize,
    of: usize,
    version: String,
    date: String,
}

#[derive(Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct NoiseRecords {
    measured: Vec<NoiseMeasured>,
}

const NOISE_RECORDS: &str = include_str!("../../docs/noise_reference.toml");

/// The newest noise reference on record for `preset` at `replicates`.
fn last_noise(preset: &str, replicates: u32) -> Option<NoiseMeasured> {
    let records: NoiseRecords =
        toml::from_str(NOISE_RECORDS).expect("docs/noise_reference.toml parses");
    records
        .measured
        .into_iter()
        .rev()
        .find(|m| m.preset == preset && m.replicates == replicates)
}

/// Verdicts the noise reference changed, of those it judged (`None`: no reference).
fn seed_noise(judged: &[Judged]) -> Option<(usize, usize)> {
    let judged: Vec<bool> = judged.iter().filter_map(|j| j.changes_with_seeds).collect();
    (!judged.is_empty()).then(|| (judged.iter().filter(|c| **c).count(), judged.len()))
}

fn read_json<T: serde::de::DeserializeOwned>(path: &Path) -> Option<T> {
    serde_json::from_str(&std::fs::read_to_string(path).ok()?).ok()
}

/// Everything the steps left, read from their directories (missing pieces stay `None`).
pub struct Loaded {
    sweep: Option<Vec<crate::slip::sweep::SweepRow>>,
    speeds: Option<(Vec<f64>, Vec<f64>, f64)>,
    timing: Option<Timing>,
    rail_online: Option<Vec<OutcomeRow>>,
    global: Option<Evaluation>,
    local: Option<Evaluation>,
    rail_on_hand: Option<Evaluation>,
    hand_online: Option<Vec<OutcomeRow>>,
    objects: Option<Vec<OutcomeRow>>,
    pour: Option<Vec<OutcomeRow>>,
    lift: Option<Vec<LiftRow>>,
    lift_cat: Option<Vec<LiftRow>>,
}

fn done(out: &Path, step: Step) -> Option<PathBuf> {
    let dir = out.join(step.dir());
    super::read_record(&dir).map(|_| dir)
}

fn rail_speeds(out: &Path) -> Option<(Vec<f64>, Vec<f64>, f64)> {
    let model_dir = done(out, Step::RailModel)?;
    let collect = done(out, Step::RailCollect)?;
    let model = ModelFile::load(&model_dir.join("threshold.json")).ok()?;
    let threshold = f64::from(model.threshold()?);
    let (ds, _, _) =
        crate::slip::dataset::load_labelled(&[collect.join("train")], &model.labels).ok()?;
    let s = crate::plots::offline::SpeedsByClass::from_dataset(&ds);
    Some((s.static_, s.slip, threshold))
}

fn load(out: &Path) -> Loaded {
    fn rows<T: serde::de::DeserializeOwned>(out: &Path, step: Step, file: &str) -> Option<T> {
        read_json(&done(out, step)?.join(file))
    }
    Loaded {
        sweep: done(out, Step::RailSweep).and_then(|d| read_sweep(&d.join("sweep.csv")).ok()),
        speeds: rail_speeds(out),
        timing: rows(out, Step::HandModels, "timing.json"),
        rail_online: rows(out, Step::RailOnline, "outcomes.json"),
        global: rows(out, Step::HandModels, "eval_global.json"),
        local: rows(out, Step::HandModels, "eval_local.json"),
        rail_on_hand: rows(out, Step::HandModels, "eval_rail_model.json"),
        hand_online: rows(out, Step::HandOnline, "outcomes.json"),
        objects: {
            let all: Option<Vec<OutcomeRow>> = rows(out, Step::Objects, "all/outcomes.json");
            let cat: Option<Vec<OutcomeRow>> = rows(out, Step::Objects, "cat_100g/outcomes.json");
            all.map(|mut a| {
                a.extend(cat.unwrap_or_default());
                a
            })
        },
        pour: rows(out, Step::RicePour, "outcomes.json"),
        lift: rows(out, Step::FirstTimeLift, "can/outcomes.json"),
        lift_cat: rows(out, Step::FirstTimeLift, "cat/outcomes.json"),
    }
}

/// The details line's head: the rule, its source and the standing.
fn details_head(j: &Judged) -> String {
    format!(
        "rule `{}` ({}); {}",
        j.rule_text,
        j.finding.source,
        j.standing.label()
    )
}

/// A pre-registered row's expected verdict and its prediction's number: the details line
/// links the prediction, which the Evidence section states once.
fn prediction_link(j: &Judged) -> Option<(&str, usize)> {
    Some((j.predicted.as_deref()?, j.prediction.as_ref()?.number))
}

/// The rule, its source and the standing's record, for the details line (Markdown).
fn details(j: &Judged) -> String {
    let mut s = details_head(j);
    if let Some((expected, n)) = prediction_link(j) {
        s += &format!(
            ": expected `{expected}` under [prediction {n}](#{})",
            page_evidence::anchor(n)
        );
    } else if !j.standing_why.is_empty() {
        s += &format!(": {}", j.standing_why);
    }
    if let Some(line) = unshown_switches(j) {
        s += &format!("; {line}");
    }
    s
}

/// An unshown row's verdicts under its switches: why the page does not count it.
fn unshown_switches(j: &Judged) -> Option<String> {
    (j.standing == super::standing::Standing::Unshown)
        .then(|| page_evidence::switch_line(j))
        .flatten()
}

/// [`details`] as HTML: the prediction's link a real anchor.
fn details_html(j: &Judged) -> String {
    let mut s = html::inline_markdown(&details_head(j));
    if let Some((expected, n)) = prediction_link(j) {
        s += &format!(
            ": expected <code>{}</code> under <a href=\"#{}\">prediction {n}</a>",
            html::escape(expected),
            page_evidence::anchor(n)
        );
    } else if !j.standing_why.is_empty() {
        s += &format!(": {}", html::inline_markdown(&j.standing_why));
    }
    if let Some(line) = unshown_switches(j) {
        s += &format!("; {}", html::inline_markdown(&line));
    }
    s
}

fn held_in(j: &Judged) -> String {
    let (held, of) = j.held_in;
    if of == 0 {
        "-".into()
    } else {
        format!("{held} of {of}")
    }
}

fn paper_effect(j: &Judged) -> String {
    match j.paper_verdict {
        Some(Reproduced::Yes) => "clear at its n".into(),
        Some(Reproduced::Partly) => "partly clear at its n".into(),
        Some(v) => format!("{} at its n", v.label()),
        None => "-".into(),
    }
}

fn standing(j: &Judged) -> String {
    match &j.predicted {
        Some(expected) if j.standing == Standing::PreRegistered => format!(
            "pre-registered: expected {expected}, {}",
            if expected == j.reproduced.label() {
                "came true"
            } else {
                "did not come true"
            }
        ),
        _ => j.standing.label().to_string(),
    }
}

fn value_cell(j: &Judged) -> String {
    j.value_verdict
        .map_or("no number".to_string(), |v| v.label().to_string())
}

/// Whether every value the verdict used was a point with no interval (one replicate of an
/// offline score): decided, but with nothing to say how firmly.
fn decided_at_point(j: &Judged) -> bool {
    let no_interval = |m: &Option<Measure>| m.as_ref().is_none_or(|m| m.interval.is_none());
    if j.comparisons.is_empty() {
        j.ours.values().all(no_interval)
    } else {
        j.comparisons.iter().all(|c| c.interval.is_none())
    }
}

/// The evidence first (pre-registered and never-seen rows, as the page's first section
/// lists them), then the central claims, then the rest; within each, standings in their
/// order, then the findings file's order. The Markdown's table and the HTML's sections
/// alike.
fn ordered(judged: &[Judged]) -> Vec<&Judged> {
    let mut rows: Vec<&Judged> = judged.iter().collect();
    rows.sort_by_key(|j| (!j.standing.is_evidence(), !j.finding.central, j.standing));
    rows
}

const COLUMNS: [&str; 10] = [
    "rule",
    "finding",
    "value",
    "paper",
    "ours (95 % interval)",
    "replicates holding",
    "paper's effect",
    "standing",
    "sensitivity",
    "id",
];

fn sensitivity(j: &Judged) -> String {
    use super::sensitivity::{standing, Standing};
    let varied = || j.sensitive_to.as_deref().unwrap_or_default().join(", ");
    match standing(j) {
        None => "-".into(),
        Some(Standing::Robust) => "robust".into(),
        Some(Standing::SeedStable) => "stable under other seeds (no parameter varied)".into(),
        Some(Standing::Fragile) => format!("fragile ({})", varied()),
        Some(Standing::Undecided) if varied().is_empty() => {
            "not decided: other seeds alone change it".into()
        }
        Some(Standing::Undecided) => {
            format!(
                "not decided: other seeds alone change it (and {})",
                varied()
            )
        }
    }
}

/// Whether the page has a sensitivity column (a study was run).
fn studied(judged: &[Judged]) -> bool {
    judged
        .iter()
        .any(|j| j.sensitive_to.is_some() || j.changes_with_seeds.is_some())
}

/// The columns and cells the page shows: all but the sensitivity column when no study ran.
fn shown<T: Clone>(row: &[T], judged: &[Judged]) -> Vec<T> {
    row.iter()
        .enumerate()
        .filter(|(i, _)| studied(judged) || *i != 8)
        .map(|(_, c)| c.clone())
        .collect()
}

fn cells(j: &Judged) -> [String; 10] {
    [
        j.reproduced.label().to_string(),
        j.finding.measured.clone(),
        value_cell(j),
        j.finding.paper.clone(),
        ours(j),
        held_in(j),
        paper_effect(j),
        standing(j),
        sensitivity(j),
        j.finding.id.clone(),
    ]
}

/// What the page says about how far its verdicts can be trusted.
fn caveats(preset: Preset, judged: &[Judged], w: &Written) -> Vec<String> {
    let mut out = vec![
        "**Rule** (the claim's shape: an order, a sign, a range): **yes** where the claim holds with its 95 % interval clear of the rule's margin, **no** where the opposite holds that way, **not resolved** where the interval straddles the margin or a range's edge; **partly** only for a claim with parts (an order whose steps mostly hold and one clearly fails; a lead in the right direction clearly smaller than the margin asked). \"Replicates holding\" counts the replicates in which the claim held at the measured values alone (docs/reproduce.md).".to_string(),
        "**Value** (the paper's number): **yes** where the paper's number lies inside our 95 % interval or our whole interval within the tolerance written for the row before any run (docs/paper_findings.toml), **no** where our interval lies wholly outside that tolerance, **not resolved** otherwise; **no number** where the paper gives an order or a sign but no number.".to_string(),
        format!(
            "**Standing** (what was seen of the row while the simulator was chosen; docs/standings.toml): {}. Only pre-registered and never-seen rows are evidence.",
            Standing::ALL
                .iter()
                .map(|s| format!("**{}**, {}", s.label(), s.meaning()))
                .collect::<Vec<_>>()
                .join("; ")
        ),
        "An **FP** in the findings is the paper's \"action triggered before slip\", judged from the simulator's ground truth. The tables below give the markers' verdicts: an early reaction that stopped the object before it ever moved shows there as \"held, no slip\", not as an FP, so a table's FP count can be smaller than the finding's (docs/reproduce.md, \"Scoring catch trials\").".to_string(),
    ];
    let unresolved: Vec<&str> = judged
        .iter()
        .filter(|j| j.reproduced == Reproduced::NotResolved)
        .map(|j| j.finding.id.as_str())
        .collect();
    if !unresolved.is_empty() {
        out.push(format!(
            "Not resolved at this size: {}.",
            unresolved.join(", ")
        ));
    }
    if w.replicates == 1 {
        let point: Vec<&str> = judged
            .iter()
            .filter(|j| j.reproduced != Reproduced::NotMeasured && decided_at_point(j))
            .map(|j| j.finding.id.as_str())
            .collect();
        if !point.is_empty() {
            out.push(format!(
                "With one replicate these rows rest on a single offline score, with no interval to say how firmly they are decided: {}. Run more replicates (`--replicates K`) to decide them.",
                point.join(", ")
            ));
        }
    }
    if preset == Preset::Smoke {
        out.push("The smoke preset runs the fewest trials that run every step: it checks a setup, and its verdicts mean nothing. `--preset quick` is a first look, `--preset paper` the paper's counts.".to_string());
    }
    if preset == Preset::Quick {
        out.push("The quick preset runs a few trials a cell: its online rows are mostly not resolved, and its verdicts are a first look, not evidence. `--preset paper` runs the paper's counts with five replicates.".to_string());
    }
    out
}

fn markdown(
    preset: Preset,
    judged: &[Judged],
    measures: &Measures,
    w: &Written,
    tables: &str,
) -> String {
    let mut out = format!(
        "# tmo reproduce: findings against the paper (preset `{}`)\n\n**{}.**\n\n",
        preset.name(),
        w.summary_line()
    );
    for line in w.standing_lines() {
        out += &format!("- {line}\n");
    }
    out += "\n";
    for line in w.lead_paragraphs() {
        out += &format!("{line}\n\n");
    }
    out += &page_evidence::markdown(judged, measures);
    out += &super::outside::markdown(&super::outside::shipped());
    out += "## How to read the verdicts\n\n";
    for c in caveats(preset, judged, w) {
        out += &format!("- {c}\n");
    }
    out += "\n";
    let columns = shown(&COLUMNS, judged);
    out += &format!(
        "## Every finding\n\n| {} | details |\n|{}\n",
        columns.join(" | "),
        " --- |".repeat(columns.len() + 1)
    );
    for j in ordered(judged) {
        let mut row: Vec<String> = shown(&cells(j), judged);
        if j.finding.central {
            row[1] = format!("**{}**", row[1]);
        }
        row.push(details(j));
        out += &format!(
            "| {} |\n",
            row.iter()
                .map(|c| c.replace('|', "\\|"))
                .collect::<Vec<_>>()
                .join(" | ")
        );
    }
    out += "\nThe evidence comes first (the section above states each prediction once), then the central claims (in bold), then the rest.\n\n## The paper's tables, from the first replicate\n\n";
    out += tables;
    out
}

fn html_page(
    preset: Preset,
    judged: &[Judged],
    measures: &Measures,
    w: &Written,
    tables: &[crate::report::Table],
) -> String {
    let mut body = format!(
        "<p><b>{}</b> (preset <code>{}</code>).</p>\n",
        html::escape(&w.summary_line()),
        preset.name()
    );
    body += "<ul>\n";
    for line in w.standing_lines() {
        body += &format!("<li>{}</li>\n", html::escape(&line));
    }
    body += "</ul>\n";
    for line in w.lead_paragraphs() {
        body += &format!("<p>{}</p>\n", html::inline_markdown(&line));
    }
    body += &page_evidence::html_section(judged, measures);
    body += &super::outside::html_section(&super::outside::shipped());
    body += "<h2>How to read the verdicts</h2>\n<ul>\n";
    for c in caveats(preset, judged, w) {
        body += &format!("<li>{}</li>\n", html::inline_markdown(&c));
    }
    body += "</ul>\n";
    let table = |title: &str, rows: &[&Judged]| {
        if rows.is_empty() {
            return String::new();
        }
        let mut t = format!("<h2>{title}</h2>\n<table>\n<tr>");
        for c in shown(&COLUMNS, judged) {
            t += &format!("<th>{}</th>", html::escape(c));
        }
        t += "</tr>\n";
        for j in rows {
            let c = shown(&cells(j), judged);
            t += &format!(
                "<tr><td class=\"{}\"><b>{}</b></td><td>{}<div class=\"details\">{}</div></td>",
                verdict_class(j.reproduced),
                html::escape(&c[0]),
                html::escape(&c[1]),
                details_html(j)
            );
            // the value lens's cell in its verdict's colour, as the rule's
            let value_class = j.value_verdict.map_or("", verdict_class);
            t += &format!(
                "<td class=\"{value_class}\">{}</td>",
                html::inline_markdown(&c[2])
            );
            for cell in &c[3..] {
                t += &format!("<td>{}</td>", html::inline_markdown(cell));
            }
            t += "</tr>\n";
        }
        t + "</table>\n"
    };
    // the Markdown's order, in three sections
    let rows = ordered(judged);
    let evidence: Vec<&Judged> = rows
        .iter()
        .copied()
        .filter(|j| j.standing.is_evidence())
        .collect();
    let (central, rest): (Vec<&Judged>, Vec<&Judged>) = rows
        .iter()
        .copied()
        .filter(|j| !j.standing.is_evidence())
        .partition(|j| j.finding.central);
    body += &table("The evidence rows in full", &evidence);
    body += &table("Central claims", &central);
    body += &table("Details", &rest);
    body += "<h2>The paper's tables, from the first replicate</h2>\n";
    body += &tables.iter().map(html::table).collect::<String>();
    if !w.figures.is_empty() {
        body += "<h2>Figures</h2>\n";
        body += &html::figures(&w.figures, &crate::plots::caption);
    }
    html::page("tmo reproduce: findings against the paper", &body)
}

fn observations(l: &Loaded) -> Observations<'_> {
    Observations {
        rail_sweep: l.sweep.as_deref(),
        rail_speeds: l
            .speeds
            .as_ref()
            .map(|(a, b, t)| (a.as_slice(), b.as_slice(), *t)),
        classify_ms: l.timing.as_ref().map(|t| t.median_ms),
        rail_online: l.rail_online.as_deref(),
        hand_global: l.global.as_ref(),
        hand_local: l.local.as_ref(),
        rail_model_on_hand: l.rail_on_hand.as_ref(),
        hand_online: l.hand_online.as_deref(),
        objects: l.objects.as_deref(),
        pour: l.pour.as_deref(),
        lift: l.lift.as_deref(),
        lift_cat: l.lift_cat.as_deref(),
    }
}

/// Every replicate's trial rows of one kind, together (`None` where no replicate has any).
fn pooled<T: Clone>(
    loaded: &[Loaded],
    rows: impl Fn(&Loaded) -> Option<&Vec<T>>,
) -> Option<Vec<T>> {
    let mut all: Option<Vec<T>> = None;
    for l in loaded {
        if let Some(r) = rows(l) {
            all.get_or_insert_with(Vec::new).extend(r.iter().cloned());
        }
    }
    all
}

/// The findings of the replicates' finished steps: pooled measures, verdicts, and the
/// calibration marks from the simulator's parameter records.
pub fn judge_replicates(out: &Path, replicates: u32) -> (Vec<Judged>, Measures, Vec<Loaded>) {
    let loaded: Vec<Loaded> = (1..=replicates.max(1))
        .map(|r| load(&replicate_dir(out, r)))
        .collect();
    let per_replicate: Vec<Measures> = loaded.iter().map(|l| measure(&observations(l))).collect();
    let rail_online = pooled(&loaded, |l| l.rail_online.as_ref());
    let hand_online = pooled(&loaded, |l| l.hand_online.as_ref());
    let objects = pooled(&loaded, |l| l.objects.as_ref());
    let pour = pooled(&loaded, |l| l.pour.as_ref());
    let lift = pooled(&loaded, |l| l.lift.as_ref());
    let lift_cat = pooled(&loaded, |l| l.lift_cat.as_ref());
    let from_trials = measure(&Observations {
        rail_online: rail_online.as_deref(),
        hand_online: hand_online.as_deref(),
        objects: objects.as_deref(),
        pour: pour.as_deref(),
        lift: lift.as_deref(),
        lift_cat: lift_cat.as_deref(),
        ..Default::default()
    });
    let measures = super::evidence::pool(&per_replicate, &from_trials);
    let mut judged = judge_all(&paper(), &measures, &per_replicate);
    let records = tmo_sim::parameters::built_in();
    mark_calibrated(
        &mut judged,
        records
            .iter()
            .map(|r| (r.name.as_str(), r.calibrated_against.as_slice())),
    );
    mark_standings(&mut judged, &super::findings::shipped_standings());
    (judged, measures, loaded)
}

/// Measures what the finished steps of the replicates in `out` hold and writes the
/// findings report there.
pub fn write_findings(
    out: &Path,
    preset: &Preset,
    replicates: u32,
    study: Option<&[super::sensitivity::Variant]>,
) -> Result<Written, ReproduceError> {
    let (mut judged, measures, loaded) = judge_replicates(out, replicates);
    let mut sensitivity_md = None;
    if let Some(variants) = study {
        let outcomes: Vec<super::sensitivity::Outcome> = variants
            .iter()
            .map(|v| {
                let dir = v.dir(out);
                if let Ok(why) = std::fs::read_to_string(dir.join(super::sensitivity::FAILED)) {
                    return super::sensitivity::failed(v.clone(), why);
                }
                let (here, _, _) = judge_replicates(&dir, replicates);
                super::sensitivity::compare(v.clone(), &judged, &here)
            })
            .collect();
        super::sensitivity::mark_fragile(&mut judged, &outcomes);
        let md = super::sensitivity::markdown(&judged, &outcomes);
        let path = out.join("sensitivity.md");
        crate::output::atomic::write_atomic(&path, md.as_bytes()).map_err(io(&path))?;
        let path = out.join("sensitivity.json");
        crate::output::atomic::write_atomic(
            &path,
            serde_json::to_string_pretty(&outcomes)
                .expect("outcomes serialise")
                .as_bytes(),
        )
        .map_err(io(&path))?;
        sensitivity_md = Some(md);
    }
    let evidence = evidence(&judged);
    let by_standing = by_standing(&judged);
    let truth_agreement = crate::outcome::truth_agreement(
        loaded
            .iter()
            .flat_map(|l| [&l.rail_online, &l.hand_online, &l.objects, &l.pour])
            .flatten()
            .flatten()
            .filter(|r| r.fault.is_none())
            .map(|r| (r.verdict, r.truth_verdict)),
    );

    // The paper's tables and figures from the first replicate, as `tmo report` makes them.
    let first = replicate_dir(out, 1);
    let mut inputs: Vec<PathBuf> = Vec::new();
    let mut add = |step: Step, sub: &str| {
        if let Some(d) = done(&first, step) {
            inputs.push(if sub.is_empty() { d } else { d.join(sub) });
        }
    };
    add(Step::RailCollect, "train");
    add(Step::RailSweep, "sweep.csv");
    add(Step::RailModel, "threshold.json");
    add(Step::RailOnline, "");
    add(Step::HandModels, "eval_global.json");
    add(Step::HandModels, "eval_local.json");
    add(Step::HandModels, "eval_rail_model.json");
    add(Step::HandOnline, "");
    add(Step::Objects, "all");
    add(Step::Objects, "cat_100g");
    add(Step::RicePour, "");
    add(Step::Calibrate, "can");
    add(Step::FirstTimeLift, "can");
    let (tables, figures) = if inputs.is_empty() {
        (Vec::new(), Vec::new())
    } else {
        let loaded = crate::report::inputs::load(&inputs)
            .map_err(|e| ReproduceError::step("findings", e))?;
        let tables = crate::report::build::tables(&loaded);
        let figures = crate::plots::draw_all(&loaded, &out.join("figures"))
            .map_err(|e| ReproduceError::step("findings", e))?;
        (tables, figures)
    };

    let mut written = Written {
        md: out.join("findings.md"),
        json: out.join("findings.json"),
        html: out.join("findings.html"),
        figures,
        preset: *preset,
        replicates: replicates.max(1),
        all: Tally::of(&judged),
        evidence,
        by_standing,
        truth_agreement,
        seed_noise: seed_noise(&judged),
        hand_model: super::hand_model::HandModel::recorded(&first.join(Step::HandModels.dir())),
        mechanisms: page_evidence::mechanism_summary(&judged),
    };
    let md_tables = crate::report::render(&tables, crate::report::Format::Md)
        .map_err(|e| ReproduceError::step("findings", e))?;
    let mut md = markdown(*preset, &judged, &measures, &written, &md_tables);
    if let Some(table) = &sensitivity_md {
        md += "\n";
        md += &table.replacen("# Sensitivity", "## Sensitivity", 1);
    }
    crate::output::atomic::write_atomic(&written.md, md.as_bytes()).map_err(io(&written.md))?;
    let json = serde_json::json!({
        "preset": preset.name(),
        "replicates": written.replicates,
        "headline": written.summary_line(),
        "mechanisms": page_evidence::by_mechanism(&judged),
        "all": written.all,
        "values": Tally::of_values(&judged),
        "evidence": {"rule": written.evidence.0, "value": written.evidence.1},
        "standings": written.by_standing,
        "truth_agreement": truth_agreement.map(|(n, agree)| serde_json::json!({"trials": n, "agree": agree})),
        "seed_noise": written.seed_noise.map(|(changed, of)| serde_json::json!({"changed": changed, "verdicts": of})),
        "hand_model": written.hand_model,
        "findings": judged,
        "measures": measures,
    });
    crate::output::atomic::write_atomic(
        &written.json,
        serde_json::to_string_pretty(&json)
            .expect("findings serialise")
            .as_bytes(),
    )
    .map_err(io(&written.json))?;
    let page = html_page(*preset, &judged, &measures, &written, &tables);
    crate::output::atomic::write_atomic(&written.html, page.as_bytes())
        .map_err(io(&written.html))?;
    written.figures.retain(|p| p.exists());
    Ok(written)
}
