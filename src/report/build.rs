//! The paper's tables from loaded inputs. Trials a fault aborted are left out of the rates
//! (they say nothing about the detector) and counted in the table's title.

use std::collections::BTreeMap;

use super::inputs::Inputs;
use super::{Cell, Table};
use crate::online::strategy::Strategy;
use crate::outcome::Verdict;
use crate::protocol::Kind;
use crate::runner::score::OutcomeRow;
use crate::slip::dataset::Scope;

fn group<'r, R, K: Ord>(rows: &[&'r R], key: impl Fn(&R) -> K) -> BTreeMap<K, Vec<&'r R>> {
    let mut cells: BTreeMap<K, Vec<&R>> = BTreeMap::new();
    for r in rows {
        cells.entry(key(r)).or_default().push(*r);
    }
    cells
}

/// A table of `rows` built by `build`, one block of rows per model: where the rows come
/// from more than one model (a protocol's `models`, or batches of several), each block is
/// built from its model's rows alone and a leading `model` column names it, so no count
/// pools two models' trials.
fn per_model<R>(rows: &[&R], model: impl Fn(&R) -> &str, build: impl Fn(&[&R]) -> Table) -> Table {
    let models = group(rows, |r| model(r).to_string());
    if models.len() <= 1 {
        return build(rows);
    }
    let mut out: Option<Table> = None;
    for (name, rs) in models {
        let block = build(&rs);
        let t = out.get_or_insert_with(|| {
            let mut t = Table::new(&block.name, &block.title, &[]);
            t.columns = std::iter::once("model".to_string())
                .chain(block.columns.iter().cloned())
                .collect();
            t
        });
        for row in block.rows {
            t.push(
                std::iter::once(Cell::text(name.clone()))
                    .chain(row)
                    .collect(),
            );
        }
    }
    out.expect("two or more models")
}

fn rate(rows: &[&OutcomeRow], keep: impl Fn(&OutcomeRow) -> bool) -> Cell {
    Cell::Rate {
        count: rows.iter().filter(|r| keep(r)).count() as u64,
        trials: rows.len() as u64,
    }
}

fn verdict(v: Verdict) -> impl Fn(&OutcomeRow) -> bool {
    move |r| r.verdict == v
}

fn distances(rows: &[&OutcomeRow]) -> Vec<f64> {
    rows.iter().filter_map(|r| r.slip_distance_mm).collect()
}

/// Rows a fault did not abort; `None` when there are no rows at all. The title notes how
/// many were left out.
fn completed<'r, R>(
    rows: Vec<&'r R>,
    aborted: impl Fn(&R) -> bool,
    title: &str,
) -> Option<(Vec<&'r R>, String)> {
    if rows.is_empty() {
        return None;
    }
    let total = rows.len();
    let kept: Vec<_> = rows.into_iter().filter(|r| !aborted(r)).collect();
    let aborted = total - kept.len();
    let title = if aborted > 0 {
        format!("{title} ({aborted} aborted trial(s) left out)")
    } else {
        title.to_string()
    };
    Some((kept, title))
}

fn completed_catches<'r>(
    inputs: &'r Inputs,
    kind: Kind,
    title: &str,
) -> Option<(Vec<&'r OutcomeRow>, String)> {
    completed(inputs.catch_rows(kind), |r| r.fault.is_some(), title)
}

/// Every table the inputs support, in the paper's order.
pub fn tables(inputs: &Inputs) -> Vec<Table> {
    let mut out = Vec::new();
    out.extend(offline_sweep(inputs));
    out.extend(offline_evaluations(inputs));
    out.extend(rail(inputs));
    out.extend(hand_online(inputs));
    out.extend(per_object(inputs));
    out.extend(rice_pour(inputs));
    out.extend(calibration(inputs));
    out.extend(first_time_lift(inputs));
    out.extend(truth_agreement(inputs));
    out.extend(loop_timing(inputs));
    out
}

/// How the online loop kept its cameras' pace, per model and backend.
pub fn loop_timing(inputs: &Inputs) -> Option<Table> {
    let rows: Vec<_> = inputs
        .batches
        .iter()
        .flat_map(|b| b.timing.iter().cloned())
        .collect();
    timing_table(&rows)
}

/// The online loop's timing per model and backend, over the trials of `rows`.
pub fn timing_table(rows: &[crate::runner::loop_timing::TimingRow]) -> Option<Table> {
    if rows.is_empty() {
        return None;
    }
    let mut t = Table::new(
        "loop_timing",
        "Online loop: each frame's decision against its deadline (late: after one frame period; a deadline fault is never scored)",
        &[
            "model",
            "backend",
            "trials",
            "frames",
            "late frames",
            "lateness p50 (ms)",
            "lateness p99 (ms)",
            "lateness max (ms)",
            "deadline faults",
            "work p99 (ms)",
            "late with this machine's work",
        ],
    );
    let mut groups: std::collections::BTreeMap<
        (&str, &str),
        Vec<&crate::runner::loop_timing::TimingRow>,
    > = Default::default();
    for r in rows {
        groups
            .entry((r.model.as_str(), r.backend.as_str()))
            .or_default()
            .push(r);
    }
    for ((model, backend), rs) in groups {
        let frames: u64 = rs.iter().map(|r| r.frames).sum();
        let late: u64 = rs.iter().map(|r| r.late).sum();
        // the trials' own quantiles: the median trial's median, the worst trial's p99
        let mut p50: Vec<f64> = rs.iter().map(|r| r.lateness_p50_ms).collect();
        p50.sort_by(f64::total_cmp);
        let worst = |f: fn(&crate::runner::loop_timing::TimingRow) -> f64| {
            rs.iter().map(|r| f(r)).fold(f64::MIN, f64::max)
        };
        t.push(vec![
            Cell::text(model),
            Cell::text(backend),
            Cell::Count(rs.len() as u64),
            Cell::Count(frames),
            Cell::Count(late),
            Cell::number(Some(crate::online::deadline::nearest_rank(&p50, 0.5)), 2),
            Cell::number(Some(worst(|r| r.lateness_p99_ms)), 2),
            Cell::number(Some(worst(|r| r.lateness_max_ms)), 2),
            Cell::Count(rs.iter().filter(|r| r.deadline_fault).count() as u64),
            Cell::number(Some(worst(|r| r.work_p99_ms)), 3),
            Cell::Count(rs.iter().map(|r| r.late_with_work).sum()),
        ]);
    }
    Some(t)
}

/// Best cell per classifier of each sweep (paper Fig. 5 in numbers).
pub fn offline_sweep(inputs: &Inputs) -> Option<Table> {
    if inputs.sweeps.is_empty() {
        return None;
    }
    let mut t = Table::new(
        "offline_sweep",
        "Offline: test macro F1 over the down-sampling x n_slip grid",
        &[
            "sweep",
            "classifier",
            "cells",
            "best macro F1",
            "at d",
            "at n_slip",
            "mean macro F1",
        ],
    );
    for s in &inputs.sweeps {
        let by: BTreeMap<&str, Vec<_>> = s.rows.iter().fold(BTreeMap::new(), |mut m, r| {
            m.entry(r.classifier.as_str())
                .or_insert_with(Vec::new)
                .push(r);
            m
        });
        for (classifier, rows) in by {
            let best = rows
                .iter()
                .max_by(|a, b| a.macro_f1.total_cmp(&b.macro_f1))
                .expect("a group has rows");
            let mean = rows.iter().map(|r| r.macro_f1).sum::<f64>() / rows.len() as f64;
            t.push(vec![
                Cell::text(short_label(&s.path)),
                Cell::text(classifier_label(classifier)),
                Cell::Count(rows.len() as u64),
                Cell::number(Some(best.macro_f1), 3),
                Cell::text(best.downsample.clone()),
                Cell::Count(best.n_slip as u64),
                Cell::number(Some(mean), 3),
            ]);
        }
    }
    Some(t)
}

/// A classifier's name as people write it (`svm-rbf` is the file format's).
pub fn classifier_label(name: &str) -> String {
    match name {
        "svm-rbf" => "SVM (RBF)",
        "svm-linear" => "SVM (linear)",
        "logreg" => "LogReg",
        "onnx" => "ONNX",
        other => other,
    }
    .to_string()
}

/// A step's output of `tmo reproduce` by what it is: `.../replicate-01/02_rail_sweep/sweep.csv`
/// is "rail sweep (replicate 1)", `.../replicate-02/06_hand_models/global.json` "hand
/// models: global (replicate 2)"; `None` for a path outside that layout.
fn reproduce_label(path: &std::path::Path) -> Option<String> {
    let parts: Vec<String> = path
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    let at = parts.iter().rposition(|p| p.starts_with("replicate-"))?;
    let replicate: u32 = parts[at].strip_prefix("replicate-")?.parse().ok()?;
    let step = parts.get(at + 1)?;
    let (number, name) = step.split_once('_')?;
    if number.len() != 2 || !number.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    let step = name.replace('_', " ");
    let what = match parts.get(at + 2).map(std::path::Path::new) {
        Some(file) if parts.len() == at + 3 => {
            let stem = file.file_stem()?.to_string_lossy().into_owned();
            if step
                .split(' ')
                .any(|w| w == stem || format!("{stem}s") == w)
            {
                step
            } else {
                format!("{step}: {stem}")
            }
        }
        _ => step,
    };
    Some(format!("{what} (replicate {replicate})"))
}

/// A file's name for a table's row label: what a reproduction's step made it as (see
/// [`reproduce_label`]); else relative to the working directory when it lies under it,
/// else its last two parts (`06_hand_models/global.json`): an absolute path breaks, and
/// says too much, when a report is shared.
fn short_label(path: &std::path::Path) -> String {
    if let Some(label) = reproduce_label(path) {
        return label;
    }
    if path.is_relative() {
        return path.display().to_string();
    }
    if let Some(rel) = std::env::current_dir()
        .ok()
        .and_then(|cwd| path.strip_prefix(cwd).ok().map(|p| p.to_path_buf()))
    {
        return rel.display().to_string();
    }
    let parts: Vec<_> = path.components().rev().take(2).collect();
    parts
        .iter()
        .rev()
        .map(|c| c.as_os_str().to_string_lossy())
        .collect::<Vec<_>>()
        .join("/")
}

/// Macro F1 per classifier and scope; per sensor for local models.
pub fn offline_evaluations(inputs: &Inputs) -> Option<Table> {
    if inputs.evaluations.is_empty() {
        return None;
    }
    let mut t = Table::new(
        "offline_models",
        "Offline: models on test trials",
        &[
            "model",
            "classifier",
            "scope",
            "sensor",
            "macro F1",
            "slip precision",
            "slip recall",
            "frames",
        ],
    );
    for (_, e) in &inputs.evaluations {
        let scope = format!("{:?}", e.scope).to_lowercase();
        let row = |sensor: String, s: &crate::slip::metrics::Scores| {
            vec![
                Cell::text(short_label(std::path::Path::new(&e.model))),
                Cell::text(classifier_label(&e.classifier)),
                Cell::text(scope.clone()),
                Cell::text(sensor),
                Cell::number(Some(s.macro_f1), 3),
                Cell::number(Some(s.slip.precision), 3),
                Cell::number(Some(s.slip.recall), 3),
                Cell::Count(s.slip.support + s.static_.support),
            ]
        };
        t.push(row("all".into(), &e.overall));
        if e.scope == Scope::Local {
            for s in &e.per_sensor {
                t.push(row(s.sensor.to_string(), &s.scores));
            }
        }
    }
    Some(t)
}

/// N frames | trials | caught | FP | dropped | d (mm), as the paper's rail results.
pub fn rail(inputs: &Inputs) -> Option<Table> {
    let (rows, title) = completed_catches(
        inputs,
        Kind::RailCatch,
        "Slip rail: catching a sliding object",
    )?;
    Some(per_model(
        &rows,
        |r| &r.model,
        |rows| rail_table(rows, &title),
    ))
}

/// [`rail`]'s table of `rows`.
fn rail_table(rows: &[&OutcomeRow], title: &str) -> Table {
    let mut t = Table::new(
        "rail_catch",
        title,
        &[
            "N frames",
            "trials",
            "caught",
            "FP",
            "held no slip",
            "dropped",
            "d (mm)",
        ],
    );
    let frames = |r: &OutcomeRow| r.strategy.parse::<Strategy>().map_or(0, |s| s.frames);
    for (n, rs) in group(rows, frames) {
        t.push(vec![
            Cell::Count(u64::from(n)),
            Cell::Count(rs.len() as u64),
            rate(&rs, verdict(Verdict::TruePositive)),
            rate(&rs, verdict(Verdict::FalsePositive)),
            rate(&rs, verdict(Verdict::HeldNoSlip)),
            rate(&rs, |r| r.dropped),
            Cell::mean_sd(&distances(&rs), 1),
        ]);
    }
    t
}

fn catch_row(label: [String; 3], rs: &[&OutcomeRow]) -> Vec<Cell> {
    let [a, b, c] = label;
    vec![
        Cell::text(a),
        Cell::text(b),
        Cell::text(c),
        rate(rs, verdict(Verdict::TruePositive)),
        rate(rs, verdict(Verdict::FalsePositive)),
        rate(rs, verdict(Verdict::FalseNegative)),
        rate(rs, verdict(Verdict::HeldNoSlip)),
        Cell::mean_sd(&distances(rs), 1),
    ]
}

/// scope | strategy | grasp | TP | FP | FN | D (mm), with per-scope and overall rows.
pub fn hand_online(inputs: &Inputs) -> Option<Table> {
    let (rows, title) = completed_catches(
        inputs,
        Kind::HandRelease,
        "Whole hand: online release and regrasp",
    )?;
    Some(per_model(
        &rows,
        |r| &r.model,
        |rows| hand_online_table(rows, &title),
    ))
}

/// [`hand_online`]'s table of `rows`.
fn hand_online_table(rows: &[&OutcomeRow], title: &str) -> Table {
    let mut t = Table::new(
        "hand_online",
        title,
        &[
            "scope",
            "strategy",
            "grasp (deg)",
            "TP",
            "FP",
            "FN",
            "held no slip",
            "D (mm)",
        ],
    );
    // Batches of different objects are never pooled into one strategy x grasp table (an
    // objects batch beside the crisps can's would change its counts): one block of rows
    // per object, each with its own totals, the object named in the scope column.
    let objects = group(rows, object_label);
    let several = objects.len() > 1;
    for (object, rows) in &objects {
        let scope_of = |scope: &str| {
            if several {
                format!("{object}: {scope}")
            } else {
                scope.to_string()
            }
        };
        let cells = group(rows, |r| {
            (r.scope.clone(), r.strategy.clone(), r.grasp_deg.to_bits())
        });
        for ((scope, strategy, grasp), rs) in &cells {
            let grasp = f64::from_bits(*grasp).to_string();
            t.push(catch_row([scope_of(scope), strategy.clone(), grasp], rs));
        }
        for (scope, rs) in group(rows, |r| r.scope.clone()) {
            t.push(catch_row(
                [scope_of(&scope), "all".into(), "all".into()],
                &rs,
            ));
        }
        t.push(catch_row(
            [scope_of("all"), "all".into(), "all".into()],
            rows,
        ));
    }
    t
}

/// An object as the tables name it: with its added mass, if any.
pub fn object_label(r: &OutcomeRow) -> String {
    if r.extra_mass_g > 0.0 {
        format!("{} +{:.0} g", r.object, r.extra_mass_g)
    } else {
        r.object.clone()
    }
}

/// object | strategy | TP | FP | FN (whole-hand trials, all scopes and grasps).
pub fn per_object(inputs: &Inputs) -> Option<Table> {
    let (rows, title) = completed_catches(inputs, Kind::HandRelease, "Whole hand: per object")?;
    Some(per_model(
        &rows,
        |r| &r.model,
        |rows| per_object_table(rows, &title),
    ))
}

fn per_object_table(rows: &[&OutcomeRow], title: &str) -> Table {
    let mut t = Table::new(
        "hand_objects",
        title,
        &["object", "strategy", "TP", "FP", "FN", "held no slip"],
    );
    for ((object, strategy), rs) in group(rows, |r| (object_label(r), r.strategy.clone())) {
        t.push(vec![
            Cell::text(object),
            Cell::text(strategy),
            rate(&rs, verdict(Verdict::TruePositive)),
            rate(&rs, verdict(Verdict::FalsePositive)),
            rate(&rs, verdict(Verdict::FalseNegative)),
            rate(&rs, verdict(Verdict::HeldNoSlip)),
        ]);
    }
    t
}

/// kind | trials with ground truth | marker verdict agrees (simulated catch trials only).
pub fn truth_agreement(inputs: &Inputs) -> Option<Table> {
    let mut t = Table::new(
        "truth_agreement",
        "Simulator only: marker-scored verdicts against ground truth",
        &["kind", "trials", "agree"],
    );
    for kind in [Kind::RailCatch, Kind::HandRelease, Kind::RicePour] {
        let rows: Vec<&OutcomeRow> = inputs
            .catch_rows(kind)
            .into_iter()
            .filter(|r| r.fault.is_none() && r.truth_verdict.is_some())
            .collect();
        if rows.is_empty() {
            continue;
        }
        t.push(vec![
            Cell::text(kind.to_string()),
            Cell::Count(rows.len() as u64),
            rate(&rows, |r| r.truth_verdict == Some(r.verdict)),
        ]);
    }
    (!t.rows.is_empty()).then_some(t)
}

/// object | strategy | trials | responses | dropped.
pub fn rice_pour(inputs: &Inputs) -> Option<Table> {
    let (rows, title) =
        completed_catches(inputs, Kind::RicePour, "Grasp destabilisation: rice pour")?;
    Some(per_model(
        &rows,
        |r| &r.model,
        |rows| rice_pour_table(rows, &title),
    ))
}

fn rice_pour_table(rows: &[&OutcomeRow], title: &str) -> Table {
    let mut t = Table::new(
        "rice_pour",
        title,
        &["object", "strategy", "trials", "responses", "dropped"],
    );
    for ((object, strategy), rs) in group(rows, |r| (r.object.clone(), r.strategy.clone())) {
        let responses: Vec<f64> = rs.iter().map(|r| r.responses as f64).collect();
        t.push(vec![
            Cell::text(object),
            Cell::text(strategy),
            Cell::Count(rs.len() as u64),
            Cell::mean_sd(&responses, 1),
            rate(&rs, |r| r.dropped),
        ]);
    }
    t
}

/// object | added mass | trials | found | g_cont | g_min | g_min - g_cont.
pub fn calibration(inputs: &Inputs) -> Option<Table> {
    let (rows, title) = completed(
        inputs.calibration_rows(),
        |r| r.fault.is_some(),
        "First-time lift: calibration of g_min",
    )?;
    let mut t = Table::new(
        "calibrate_lift",
        &title,
        &[
            "object",
            "added mass (g)",
            "trials",
            "g_min found",
            "g_cont",
            "g_min",
            "g_min - g_cont",
        ],
    );
    for ((object, mass), rs) in group(&rows, |r| (r.object.clone(), r.mass_g.to_bits())) {
        let cont: Vec<f64> = rs.iter().filter_map(|r| r.g_cont).collect();
        let min: Vec<f64> = rs.iter().filter_map(|r| r.g_min).collect();
        let past: Vec<f64> = rs
            .iter()
            .filter_map(|r| Some(r.g_min? - r.g_cont?))
            .collect();
        t.push(vec![
            Cell::text(object),
            Cell::number(Some(f64::from_bits(mass)), 0),
            Cell::Count(rs.len() as u64),
            Cell::Rate {
                count: min.len() as u64,
                trials: rs.len() as u64,
            },
            Cell::mean_sd(&cont, 3),
            Cell::mean_sd(&min, 3),
            Cell::mean_sd(&past, 3),
        ]);
    }
    Some(t)
}

/// object | added mass | trials | success | slips | lag | overgrasp, as the paper's Fig. 13.
pub fn first_time_lift(inputs: &Inputs) -> Option<Table> {
    let (rows, title) = completed(inputs.lift_rows(), |r| r.fault.is_some(), "First-time lift")?;
    Some(per_model(
        &rows,
        |r| &r.model,
        |rows| first_time_lift_table(rows, &title),
    ))
}

fn first_time_lift_table(rows: &[&crate::runner::score::LiftRow], title: &str) -> Table {
    let mut t = Table::new(
        "first_time_lift",
        title,
        &[
            "object",
            "added mass (g)",
            "trials",
            "success",
            "slips",
            "lag (mm)",
            "overgrasp (%)",
        ],
    );
    for ((object, mass), rs) in group(rows, |r| (r.object.clone(), r.mass_g.to_bits())) {
        let slips: Vec<f64> = rs.iter().map(|r| r.slips as f64).collect();
        let lag: Vec<f64> = rs.iter().filter_map(|r| r.lag_mm).collect();
        let over: Vec<f64> = rs
            .iter()
            .filter_map(|r| r.overgrasp)
            .map(|o| 100.0 * o)
            .collect();
        t.push(vec![
            Cell::text(object),
            Cell::number(Some(f64::from_bits(mass)), 0),
            Cell::Count(rs.len() as u64),
            Cell::Rate {
                count: rs.iter().filter(|r| r.success).count() as u64,
                trials: rs.len() as u64,
            },
            Cell::mean_sd(&slips, 1),
            Cell::mean_sd(&lag, 1),
            Cell::mean_sd(&over, 0),
        ]);
    }
    t
}

#[cfg(test)]
mod tests {
    use super::{classifier_label, hand_online_table, short_label};
    use crate::outcome::Verdict;
    use crate::runner::score::OutcomeRow;
    use std::path::Path;

    /// T4-7: an objects batch beside the crisps can's is kept apart, never pooled into its
    /// strategy x grasp counts.
    #[test]
    fn batches_of_different_objects_are_kept_apart_in_the_hand_table() {
        let row = |object: &str, v: Verdict| OutcomeRow {
            trial_id: "t".into(),
            object: object.into(),
            grasp_deg: 0.0,
            model: "svm".into(),
            scope: "global".into(),
            strategy: "2Fr2Sen".into(),
            verdict: v,
            onset_s: None,
            reaction_s: None,
            latency_s: None,
            dropped: false,
            slip_distance_mm: Some(10.0),
            fault: None,
            responses: 1,
            truth_verdict: None,
            extra_mass_g: 0.0,
        };
        let can: Vec<OutcomeRow> = (0..3)
            .map(|_| row("crisps_can", Verdict::TruePositive))
            .collect();
        let others: Vec<OutcomeRow> = (0..30)
            .map(|i| {
                row(
                    if i % 2 == 0 { "banana" } else { "softball" },
                    Verdict::FalseNegative,
                )
            })
            .collect();
        let rows: Vec<&OutcomeRow> = can.iter().chain(&others).collect();
        let t = hand_online_table(&rows, "t");
        let text = crate::report::render(&[t], crate::report::Format::Csv).unwrap();
        let can_line = text
            .lines()
            .find(|l| l.starts_with("crisps_can: global,2Fr2Sen,0"))
            .unwrap_or_else(|| panic!("{text}"));
        assert!(
            can_line.contains(",3,") || can_line.contains("3/3"),
            "{can_line}"
        );
        assert!(!text.lines().any(|l| l.starts_with("global,")), "{text}");
        assert!(text.contains("banana: all"), "{text}");
    }

    #[test]
    fn row_labels_are_short_names_not_absolute_paths() {
        assert_eq!(
            short_label(Path::new("results/sweep.csv")),
            "results/sweep.csv"
        );
        assert_eq!(
            short_label(Path::new("/elsewhere/hand_models/global.json")),
            "hand_models/global.json"
        );
        // a reproduction's outputs by what they are
        let labels = [
            (
                "/elsewhere/r/replicate-01/06_hand_models/global.json",
                "hand models: global (replicate 1)",
            ),
            (
                "results/paper/replicate-03/02_rail_sweep/sweep.csv",
                "rail sweep (replicate 3)",
            ),
            (
                "r/replicate-02/03_rail_model/rail.json",
                "rail model (replicate 2)",
            ),
            ("r/replicate-01/07_hand_online", "hand online (replicate 1)"),
            (
                "r/replicate-01/notastep/x.csv",
                "r/replicate-01/notastep/x.csv",
            ),
        ];
        for (path, label) in labels {
            assert_eq!(short_label(Path::new(path)), label, "{path}");
        }
        assert_eq!(classifier_label("svm-rbf"), "SVM (RBF)");
        assert_eq!(classifier_label("logreg"), "LogReg");
        assert_eq!(classifier_label("threshold"), "threshold");
        let here = std::env::current_dir().unwrap().join("a/b.json");
        assert_eq!(short_label(&here), "a/b.json");
    }

    #[test]
    fn the_loop_timing_table_has_a_line_per_model_and_backend() {
        let row = |trial_id: &str, model: &str, late: u64, fault: bool| {
            crate::runner::loop_timing::TimingRow {
                trial_id: trial_id.into(),
                model: model.into(),
                strategy: "1Fr1Sen".into(),
                backend: "real".into(),
                frames: 3,
                late,
                lateness_p50_ms: -10.0,
                lateness_p99_ms: 1.0,
                lateness_max_ms: if fault { 40.0 } else { 4.0 },
                work_p99_ms: 0.5,
                classify_p99_ms: 0.2,
                late_with_work: late,
                deadline_fault: fault,
            }
        };
        use super::timing_table;
        assert_eq!(timing_table(&[]), None);
        let t = timing_table(&[
            row("t1", "a", 1, false),
            row("t2", "a", 2, true),
            row("t3", "b", 0, false),
        ])
        .unwrap();
        let text = t.markdown();
        assert!(
            text.contains("| a | real | 2 | 6 | 3 | -10.00 | 1.00 | 40.00 | 1 |"),
            "{text}"
        );
        assert!(text.contains("| b | real | 1 | 3 | 0 |"), "{text}");
    }
}
