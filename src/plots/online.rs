//! Whole-hand online figures: TP / FP / FN per strategy and grasp (stacked bars, one panel
//! per classifier scope) and slip distance D per strategy (box plots).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::prelude::*;

use super::{clear, DrawResult, PlotError, FN_COLOUR, FONT, FP_COLOUR, SIZE, TP_COLOUR};
use crate::outcome::Verdict;
use crate::protocol::Kind;
use crate::report::inputs::Inputs;
use crate::runner::score::OutcomeRow;

/// The label of the category at integer position `v` of a category axis, blank between.
fn category(labels: &[String], v: f64) -> String {
    let i = v.round();
    if (v - i).abs() < 1e-6 && i >= 0.0 {
        labels.get(i as usize).cloned().unwrap_or_default()
    } else {
        String::new()
    }
}

/// Trials that neither slipped measurably nor were judged TP, FP or FN.
const OTHER_COLOUR: RGBColor = RGBColor(170, 170, 170);

/// Outcome counts of one bar.
#[derive(Debug, Clone, PartialEq)]
pub struct Bar {
    pub label: String,
    pub tp: usize,
    pub fp: usize,
    pub fn_: usize,
    /// Trials with neither a TP, an FP nor an FN: no slip at all, or held with no
    /// measurable slip. Drawn too, so that a bar's height is its trial count and a cell
    /// whose trials all ended so is not an empty slot.
    pub other: usize,
}

/// Bars per scope, one per strategy and grasp, from completed trials.
pub fn outcome_bars(rows: &[&OutcomeRow]) -> BTreeMap<String, Vec<Bar>> {
    let mut cells: BTreeMap<String, BTreeMap<(String, u64), Vec<&OutcomeRow>>> = BTreeMap::new();
    for r in rows.iter().filter(|r| r.fault.is_none()) {
        cells
            .entry(r.scope.clone())
            .or_default()
            .entry((r.strategy.clone(), r.grasp_deg.to_bits()))
            .or_default()
            .push(r);
    }
    cells
        .into_iter()
        .map(|(scope, by)| {
            let bars = by
                .into_iter()
                .map(|((strategy, grasp), rs)| {
                    let n = |v: Verdict| rs.iter().filter(|r| r.verdict == v).count();
                    Bar {
                        label: format!("{strategy} {}°", f64::from_bits(grasp)),
                        tp: n(Verdict::TruePositive),
                        fp: n(Verdict::FalsePositive),
                        fn_: n(Verdict::FalseNegative),
                        other: n(Verdict::NoSlip) + n(Verdict::HeldNoSlip),
                    }
                })
                .collect();
            (scope, bars)
        })
        .collect()
}

fn bars<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    panels: &BTreeMap<String, Vec<Bar>>,
) -> DrawResult<DB> {
    clear(root)?;
    let root = root.titled(
        "Online release: outcomes per strategy and grasp",
        (FONT, 20),
    )?;
    let areas = root.split_evenly((panels.len().max(1), 1));
    for (area, (scope, bars)) in areas.iter().zip(panels) {
        let top = bars
            .iter()
            .map(|b| b.tp + b.fp + b.fn_ + b.other)
            .max()
            .unwrap_or(1) as f64;
        let labels: Vec<String> = bars.iter().map(|b| b.label.clone()).collect();
        let mut chart = ChartBuilder::on(area)
            .caption(format!("{scope} model"), (FONT, 15))
            .margin(8)
            .x_label_area_size(30)
            .y_label_area_size(50)
            // headroom above the bars for the legend's four entries
            .build_cartesian_2d(-0.5..(bars.len() as f64 - 0.5), 0.0..top * 1.7)?;
        chart
            .configure_mesh()
            .light_line_style(TRANSPARENT)
            .disable_x_mesh()
            .x_labels(bars.len())
            .x_label_formatter(&|v| category(&labels, *v))
            .y_desc("trials")
            .y_label_formatter(&|v| format!("{v:.0}"))
            .label_style((FONT, 12))
            .axis_desc_style((FONT, 13))
            .draw()?;
        for (k, (colour, name)) in [
            (TP_COLOUR, "TP"),
            (FP_COLOUR, "FP"),
            (FN_COLOUR, "FN"),
            (OTHER_COLOUR, "no slip, or held with none"),
        ]
        .into_iter()
        .enumerate()
        {
            chart
                .draw_series(bars.iter().enumerate().map(|(i, b)| {
                    let counts = [b.tp, b.fp, b.fn_, b.other];
                    let base: usize = counts[..k].iter().sum();
                    let x = i as f64;
                    Rectangle::new(
                        [
                            (x - 0.35, base as f64),
                            (x + 0.35, (base + counts[k]) as f64),
                        ],
                        colour.filled(),
                    )
                }))?
                .label(name)
                .legend(move |(x, y)| {
                    Rectangle::new([(x, y - 5), (x + 12, y + 5)], colour.filled())
                });
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.9))
            .border_style(BLACK)
            .label_font((FONT, 12))
            .draw()?;
    }
    Ok(())
}

/// Slip distances (caught trials) per strategy, in strategy order.
pub fn distances_by_strategy(rows: &[&OutcomeRow]) -> Vec<(String, Vec<f64>)> {
    let mut by: BTreeMap<String, Vec<f64>> = BTreeMap::new();
    for r in rows.iter().filter(|r| r.fault.is_none()) {
        if let Some(d) = r.slip_distance_mm {
            by.entry(r.strategy.clone()).or_default().push(d);
        }
    }
    by.into_iter().collect()
}

fn boxes<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    groups: &[(String, Vec<f64>)],
) -> DrawResult<DB> {
    clear(root)?;
    // The whiskers set the scale; points past them are drawn but may run off the top.
    let top = groups
        .iter()
        .filter(|(_, v)| !v.is_empty())
        .map(|(_, v)| f64::from(Quartiles::new(v).values()[4]))
        .fold(1.0, f64::max);
    let labels: Vec<String> = groups
        .iter()
        .map(|(s, v)| format!("{s} (n={})", v.len()))
        .collect();
    let mut chart = ChartBuilder::on(root)
        .caption("Slip distance D before the regrasp held", (FONT, 20))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(55)
        .build_cartesian_2d(-0.5..(groups.len() as f64 - 0.5), 0.0..top * 1.1)?;
    chart
        .configure_mesh()
        .light_line_style(TRANSPARENT)
        .disable_x_mesh()
        .x_labels(groups.len())
        .x_label_formatter(&|v| category(&labels, *v))
        .y_desc("D (mm), caught trials")
        .label_style((FONT, 13))
        .axis_desc_style((FONT, 14))
        .draw()?;
    let colour = RGBColor(59, 81, 139);
    for (i, (_, v)) in groups.iter().enumerate() {
        if v.is_empty() {
            continue;
        }
        let q = Quartiles::new(v);
        let [lo, q1, med, q3, hi] = q.values().map(f64::from);
        let x = i as f64;
        let style = colour.stroke_width(2);
        chart.draw_series(std::iter::once(Rectangle::new(
            [(x - 0.25, q1), (x + 0.25, q3)],
            colour.mix(0.25).filled(),
        )))?;
        chart.draw_series(std::iter::once(Rectangle::new(
            [(x - 0.25, q1), (x + 0.25, q3)],
            style,
        )))?;
        for (a, b) in [
            ((x - 0.25, med), (x + 0.25, med)),
            ((x, q3), (x, hi)),
            ((x, q1), (x, lo)),
        ] {
            chart.draw_series(std::iter::once(PathElement::new(vec![a, b], style)))?;
        }
        for y in [lo, hi] {
            chart.draw_series(std::iter::once(PathElement::new(
                vec![(x - 0.12, y), (x + 0.12, y)],
                style,
            )))?;
        }
        chart.draw_series(
            v.iter()
                .filter(|&&d| d < lo || d > hi)
                .map(|&d| Circle::new((x, d.min(top * 1.08)), 3, colour.stroke_width(1))),
        )?;
    }
    Ok(())
}

/// The whole-hand figures, when the inputs hold online hand-release batches.
pub fn hand_figures(inputs: &Inputs, dir: &Path) -> Result<Vec<PathBuf>, PlotError> {
    let rows = inputs.catch_rows(Kind::HandRelease);
    if rows.is_empty() {
        return Ok(Vec::new());
    }
    let panels = outcome_bars(&rows);
    let height = (330 * panels.len() as u32 + 40).max(520);
    let mut out = crate::figure_files!(dir.join("hand_outcomes"), (1200, height), |root| {
        bars(&root, &panels)
    });
    let groups = distances_by_strategy(&rows);
    out.extend(crate::figure_files!(
        dir.join("hand_slip_distance"),
        SIZE,
        |root| { boxes(&root, &groups) }
    ));
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(scope: &str, strategy: &str, grasp: f64, v: Verdict, d: Option<f64>) -> OutcomeRow {
        OutcomeRow {
            trial_id: "t".into(),
            object: "crisps_can".into(),
            grasp_deg: grasp,
            scope: scope.into(),
            strategy: strategy.into(),
            verdict: v,
            onset_s: None,
            reaction_s: None,
            latency_s: None,
            dropped: false,
            slip_distance_mm: d,
            fault: None,
            responses: 1,
            truth_verdict: None,
            extra_mass_g: 0.0,
        }
    }

    #[test]
    fn bars_count_each_verdict_per_scope_strategy_and_grasp() {
        let rows = [
            row("global", "2Fr2Sen", 0.0, Verdict::TruePositive, Some(3.0)),
            row("global", "2Fr2Sen", 0.0, Verdict::FalsePositive, None),
            row("global", "2Fr2Sen", 180.0, Verdict::FalseNegative, None),
            row("local", "1Fr1Sen", 0.0, Verdict::TruePositive, Some(1.0)),
            row("local", "2Fr2Sen", 0.0, Verdict::NoSlip, None),
            row("local", "2Fr2Sen", 0.0, Verdict::HeldNoSlip, None),
        ];
        let refs: Vec<&OutcomeRow> = rows.iter().collect();
        let b = outcome_bars(&refs);
        assert_eq!(b.len(), 2);
        assert_eq!(
            b["global"][0],
            Bar {
                label: "2Fr2Sen 0°".into(),
                tp: 1,
                fp: 1,
                fn_: 0,
                other: 0
            }
        );
        assert_eq!(b["global"][1].fn_, 1);
        // every trial is in its bar: those without a slip too
        assert_eq!((b["local"][1].tp, b["local"][1].other), (0, 2));
        let d = distances_by_strategy(&refs);
        assert_eq!(
            d,
            vec![("1Fr1Sen".into(), vec![1.0]), ("2Fr2Sen".into(), vec![3.0])]
        );
    }
}
