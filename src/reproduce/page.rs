//! The findings report of a reproduction: `findings.md`, `findings.json` and a
//! self-contained `findings.html`, each row the paper's value, ours (with its interval)
//! and whether it reproduced by the row's rule; then the paper's tables and figures as
//! `tmo report` makes them from the same step outputs.

use std::path::{Path, PathBuf};

use super::findings::{judge_all, paper, summary, Judged, Measure, Measures, Reproduced};
use super::measure::{measure, Observations};
use super::steps::{read_sweep, Preset, Step, Timing};
use super::{io, ReproduceError};
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
    /// Findings reproduced fully, partly, and in all.
    pub reproduced: usize,
    pub partly: usize,
    pub total: usize,
    /// Simulated catch trials with a ground-truth verdict, and how many agree.
    pub truth_agreement: Option<(usize, usize)>,
}

impl Written {
    pub fn summary_line(&self) -> String {
        format!(
            "{} of {} findings reproduced ({} partly)",
            self.reproduced, self.total, self.partly
        )
    }

    /// How often the marker verdicts agree with ground truth, if any trial has one.
    pub fn agreement_line(&self) -> Option<String> {
        self.truth_agreement.map(|(n, agree)| {
            format!(
                "Marker-scored verdicts agree with the simulator's ground truth in {agree} of {n} simulated catch trials ({:.1} %).",
                100.0 * agree as f64 / n.max(1) as f64
            )
        })
    }
}

fn read_json<T: serde::de::DeserializeOwned>(path: &Path) -> Option<T> {
    serde_json::from_str(&std::fs::read_to_string(path).ok()?).ok()
}

/// Everything the steps left, read from their directories (missing pieces stay `None`).
struct Loaded {
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

/// The value of a measure as the report shows it, interval included.
pub fn show(m: &Measure) -> String {
    let v = |x: f64| {
        if x.abs() >= 10.0 {
            format!("{x:.1}")
        } else {
            format!("{x:.3}")
        }
    };
    let mut s = v(m.value);
    if let Some((lo, hi)) = m.interval {
        s += &format!(" [{}, {}]", v(lo), v(hi));
    }
    if let Some(n) = m.n {
        s += &format!(" (n={n})");
    }
    s
}

fn ours(j: &Judged) -> String {
    j.ours
        .iter()
        .map(|(k, v)| {
            format!(
                "{k} = {}",
                v.as_ref().map_or("not measured".to_string(), show)
            )
        })
        .collect::<Vec<_>>()
        .join("; ")
}

fn markdown(preset: Preset, judged: &[Judged], w: &Written, tables: &str) -> String {
    let mut out = format!(
        "# tmo reproduce: findings against the paper (preset `{}`)\n\n**{}.**\n\n",
        preset.name(),
        w.summary_line()
    );
    if let Some(line) = w.agreement_line() {
        out += &format!("{line}\n\n");
    }
    out += "| id | measured | paper | source | ours | rule | reproduced |\n| --- | --- | --- | --- | --- | --- | --- |\n";
    for j in judged {
        let f = &j.finding;
        let cells = [
            f.id.clone(),
            f.measured.clone(),
            f.paper.clone(),
            f.source.clone(),
            ours(j),
            format!("`{}`", j.rule_text),
            j.reproduced.label().to_string(),
        ];
        out += &format!(
            "| {} |\n",
            cells
                .iter()
                .map(|c| c.replace('|', "\\|"))
                .collect::<Vec<_>>()
                .join(" | ")
        );
    }
    out += "\n## The paper's tables, from this run\n\n";
    out += tables;
    out
}

fn html_page(
    preset: Preset,
    judged: &[Judged],
    w: &Written,
    tables: &[crate::report::Table],
) -> String {
    let mut body = format!(
        "<p><b>{}</b> (preset <code>{}</code>).</p>\n",
        html::escape(&w.summary_line()),
        preset.name()
    );
    if let Some(line) = w.agreement_line() {
        body += &format!("<p>{}</p>\n", html::escape(&line));
    }
    body += "<table>\n<tr><th>id</th><th>measured</th><th>paper</th><th>source</th><th>ours</th><th>rule</th><th>reproduced</th></tr>\n";
    for j in judged {
        let f = &j.finding;
        let class = match j.reproduced {
            Reproduced::Yes => "yes",
            Reproduced::Partly => "partly",
            Reproduced::No => "no",
            Reproduced::NotMeasured => "not_measured",
        };
        body += &format!(
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td><code>{}</code></td><td class=\"{class}\">{}</td></tr>\n",
            html::escape(&f.id),
            html::escape(&f.measured),
            html::escape(&f.paper),
            html::escape(&f.source),
            html::escape(&ours(j)),
            html::escape(&j.rule_text),
            j.reproduced.label()
        );
    }
    body += "</table>\n<h2>The paper's tables, from this run</h2>\n";
    body += &tables.iter().map(html::table).collect::<String>();
    if !w.figures.is_empty() {
        body += "<h2>Figures</h2>\n";
        body += &html::figures(&w.figures);
    }
    html::page("tmo reproduce: findings against the paper", &body)
}

/// Measures what the finished steps in `out` hold and writes the findings report there.
pub fn write_findings(out: &Path, preset: &Preset) -> Result<Written, ReproduceError> {
    let l = load(out);
    let speeds = l
        .speeds
        .as_ref()
        .map(|(a, b, t)| (a.as_slice(), b.as_slice(), *t));
    let observations = Observations {
        rail_sweep: l.sweep.as_deref(),
        rail_speeds: speeds,
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
    };
    let measures: Measures = measure(&observations);
    let judged = judge_all(&paper(), &measures);
    let (reproduced, total) = summary(&judged);
    let partly = judged
        .iter()
        .filter(|j| j.reproduced == Reproduced::Partly)
        .count();
    let truth_agreement = crate::outcome::truth_agreement(
        [&l.rail_online, &l.hand_online, &l.objects, &l.pour]
            .into_iter()
            .flatten()
            .flatten()
            .filter(|r| r.fault.is_none())
            .map(|r| (r.verdict, r.truth_verdict)),
    );

    // The paper's tables and figures from the same outputs, as `tmo report` makes them.
    let mut inputs: Vec<PathBuf> = Vec::new();
    let mut add = |step: Step, sub: &str| {
        if let Some(d) = done(out, step) {
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
        reproduced,
        partly,
        total,
        truth_agreement,
    };
    let md_tables = crate::report::render(&tables, crate::report::Format::Md)
        .map_err(|e| ReproduceError::step("findings", e))?;
    let md = markdown(*preset, &judged, &written, &md_tables);
    std::fs::write(&written.md, md).map_err(io(&written.md))?;
    let json = serde_json::json!({
        "preset": preset.name(),
        "reproduced": reproduced,
        "partly": partly,
        "total": total,
        "truth_agreement": truth_agreement.map(|(n, agree)| serde_json::json!({"trials": n, "agree": agree})),
        "findings": judged,
        "measures": measures,
    });
    std::fs::write(
        &written.json,
        serde_json::to_string_pretty(&json).expect("findings serialise"),
    )
    .map_err(io(&written.json))?;
    let page = html_page(*preset, &judged, &written, &tables);
    std::fs::write(&written.html, page).map_err(io(&written.html))?;
    written.figures.retain(|p| p.exists());
    Ok(written)
}
