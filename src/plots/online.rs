//! Whole-hand online figures: TP / FP / FN per strategy and grasp (stacked bars, one panel
//! per classifier scope) and slip distance D per strategy (box plots).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

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

/// One panel of Fig. 7: a model's scope and the hand's grasp (deg).
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
pub struct Panel {
    pub scope: String,
    /// The grasp in degrees, as f64 bits (non-negative angles sort as numbers).
    grasp_bits: u64,
}

impl Panel {
    pub fn new(scope: &str, grasp_deg: f64) -> Self {
        Self {
            scope: scope.to_string(),
            grasp_bits: grasp_deg.abs().to_bits(),
        }
    }

    pub fn grasp_deg(&self) -> f64 {
        f64::from_bits(self.grasp_bits)
    }

    /// The panel's title: "global model, hand at 180 deg" (no degree sign: some viewers'
    /// fonts space it oddly at the labels' size).
    pub fn title(&self) -> String {
        format!("{} model, hand at {} deg", self.scope, self.grasp_deg())
    }
}

/// Whether `rows` come from more than one slip model (a protocol's `models`): then each
/// model is drawn apart, never pooled with another.
fn several_models(rows: &[&OutcomeRow]) -> bool {
    rows.iter().any(|r| r.model != rows[0].model)
}

/// What a row's panel or box is named by: its `what` (scope, strategy), with its model's
/// name before it where the rows hold several models.
fn per_model_label(r: &OutcomeRow, what: &str, several: bool) -> String {
    if several {
        format!("{}: {what}", r.model)
    } else {
        what.to_string()
    }
}

/// Bars per panel (scope and grasp; a model's scope where there are several models), one
/// per strategy, from completed trials.
pub fn outcome_bars(rows: &[&OutcomeRow]) -> BTreeMap<Panel, Vec<Bar>> {
    let several = several_models(rows);
    let mut cells: BTreeMap<Panel, BTreeMap<String, Vec<&OutcomeRow>>> = BTreeMap::new();
    for r in rows.iter().filter(|r| r.fault.is_none()) {
        cells
            .entry(Panel::new(
                &per_model_label(r, &r.scope, several),
                r.grasp_deg,
            ))
            .or_default()
            .entry(r.strategy.clone())
            .or_default()
            .push(r);
    }
    cells
        .into_iter()
        .map(|(panel, by)| {
            let bars = by
                .into_iter()
                .map(|(strategy, rs)| {
                    let n = |v: Verdict| rs.iter().filter(|r| r.verdict == v).count();
                    Bar {
                        label: strategy,
                        tp: n(Verdict::TruePositive),
                        fp: n(Verdict::FalsePositive),
                        fn_: n(Verdict::FalseNegative),
                        other: n(Verdict::NoSlip) + n(Verdict::HeldNoSlip),
                    }
                })
                .collect();
            (panel, bars)
        })
        .collect()
}

/// The grid Fig. 7's panels sit in: a row per scope, a column per grasp.
fn panel_grid(panels: &BTreeMap<Panel, Vec<Bar>>) -> (Vec<String>, Vec<u64>) {
    let mut scopes: Vec<String> = panels.keys().map(|p| p.scope.clone()).collect();
    let mut grasps: Vec<u64> = panels.keys().map(|p| p.grasp_bits).collect();
    scopes.dedup();
    grasps.sort_unstable();
    grasps.dedup();
    (scopes, grasps)
}

fn bars<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    panels: &BTreeMap<Panel, Vec<Bar>>,
) -> DrawResult<DB> {
    clear(root)?;
    let root = root.titled(
        "Online release: outcomes per strategy, by model and grasp",
        (FONT, 20),
    )?;
    // the legend has its own strip on the right, so the axis can fit the bars
    let width = root.dim_in_pixel().0 as i32;
    let (plots, legend) = root.split_horizontally(width - 200);
    draw_legend(&legend)?;
    let (scopes, grasps) = panel_grid(panels);
    let areas = plots.split_evenly((scopes.len().max(1), grasps.len().max(1)));
    for (panel, bars) in panels {
        let row = scopes.iter().position(|s| *s == panel.scope).unwrap_or(0);
        let col = grasps
            .iter()
            .position(|g| *g == panel.grasp_bits)
            .unwrap_or(0);
        let area = &areas[row * grasps.len().max(1) + col];
        let tallest = bars
            .iter()
            .map(|b| b.tp + b.fp + b.fn_ + b.other)
            .max()
            .unwrap_or(1);
        let top = count_axis_top(tallest);
        let labels: Vec<String> = bars.iter().map(|b| b.label.clone()).collect();
        let mut chart = ChartBuilder::on(area)
            .caption(panel.title(), (FONT, 17))
            .margin(8)
            .x_label_area_size(34)
            .y_label_area_size(50)
            .build_cartesian_2d(-0.5..(bars.len() as f64 - 0.5), 0.0..top as f64)?;
        chart
            .configure_mesh()
            .light_line_style(TRANSPARENT)
            .disable_x_mesh()
            .x_labels(bars.len())
            .x_label_formatter(&|v| category(&labels, *v))
            // counts: whole-number ticks only
            .y_labels(count_ticks(top))
            .y_desc("trials")
            .y_label_formatter(&|v| format!("{v:.0}"))
            .label_style((FONT, 14))
            .axis_desc_style((FONT, 15))
            .draw()?;
        for (k, (colour, _)) in OUTCOMES.into_iter().enumerate() {
            chart.draw_series(bars.iter().enumerate().map(|(i, b)| {
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
            }))?;
        }
    }
    Ok(())
}

/// The stacked bars' parts, bottom up.
const OUTCOMES: [(RGBColor, &str); 4] = [
    (TP_COLOUR, "TP"),
    (FP_COLOUR, "FP"),
    (FN_COLOUR, "FN"),
    (OTHER_COLOUR, "no slip, or held"),
];

fn draw_legend<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
    for (k, (colour, name)) in OUTCOMES.into_iter().enumerate() {
        let y = 60 + 26 * k as i32;
        area.draw(&Rectangle::new([(10, y - 7), (26, y + 7)], colour.filled()))?;
        area.draw(&Text::new(
            name,
            (34, y - 8),
            (FONT, 15).into_font().color(&BLACK),
        ))?;
    }
    Ok(())
}

/// The top of a count axis: a little above the tallest bar, a whole number.
fn count_axis_top(tallest: usize) -> usize {
    (tallest as f64 * 1.08).ceil().max(1.0) as usize
}

/// How many ticks a count axis from 0 to `top` may have so that none falls between whole
/// numbers (plotters picks round steps no finer than the count allows).
fn count_ticks(top: usize) -> usize {
    (top + 1).min(11)
}

/// Slip distances (caught trials) per strategy (a model's strategy where there are several
/// models), in strategy order.
pub fn distances_by_strategy(rows: &[&OutcomeRow]) -> Vec<(String, Vec<f64>)> {
    let several = several_models(rows);
    let mut by: BTreeMap<String, Vec<f64>> = BTreeMap::new();
    for r in rows.iter().filter(|r| r.fault.is_none()) {
        if let Some(d) = r.slip_distance_mm {
            by.entry(per_model_label(r, &r.strategy, several))
                .or_default()
                .push(d);
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
    // Each box's label in lines under it (strategy, then n), and a model's name once under
    // its boxes: "global: 1Fr1Sen (n=2)" side by side, a box apart, ran into each other.
    let parts: Vec<(Option<&str>, &str)> = groups
        .iter()
        .map(|(s, _)| match s.split_once(": ") {
            Some((model, strategy)) => (Some(model), strategy),
            None => (None, s.as_str()),
        })
        .collect();
    let models = parts.iter().any(|(m, _)| m.is_some());
    let mut chart = ChartBuilder::on(root)
        .caption("Slip distance D before the regrasp held", (FONT, 20))
        .margin(12)
        .x_label_area_size(if models { 62 } else { 44 })
        .y_label_area_size(55)
        .build_cartesian_2d(-0.5..(groups.len() as f64 - 0.5), 0.0..top * 1.1)?;
    chart
        .configure_mesh()
        .light_line_style(TRANSPARENT)
        .disable_x_mesh()
        .x_labels(groups.len())
        .x_label_formatter(&|_| String::new())
        .y_desc("D (mm), caught trials")
        .label_style((FONT, 13))
        .axis_desc_style((FONT, 14))
        .draw()?;
    let line = |text: String, x: f64, dy: i32, size: f64| {
        EmptyElement::at((x, 0.0))
            + Text::new(
                text,
                (0, dy),
                TextStyle::from((FONT, size).into_font()).pos(Pos::new(HPos::Center, VPos::Top)),
            )
    };
    for (i, ((_, strategy), (_, v))) in parts.iter().zip(groups).enumerate() {
        let x = i as f64;
        chart.draw_series([
            line(strategy.to_string(), x, 6, 12.0),
            line(format!("n={}", v.len()), x, 20, 11.0),
        ])?;
    }
    // a model's name centred under its run of boxes
    let mut i = 0;
    while i < parts.len() {
        let model = parts[i].0;
        let run = parts[i..].iter().take_while(|(m, _)| *m == model).count();
        if let Some(model) = model {
            let centre = i as f64 + (run as f64 - 1.0) / 2.0;
            chart.draw_series([line(format!("{model} model"), centre, 36, 13.0)])?;
        }
        i += run;
    }
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

/// The rows Figs. 7 and 8 draw: the paper's are the crisps can's release and regrasp, so
/// where batches of several objects are given (an objects batch beside it), only one
/// object's rows: the crisps can's if present, else the first object's by name. Pooled,
/// eleven objects' trials would fill two of the bars and three the rest.
fn paper_object(rows: Vec<&OutcomeRow>) -> Vec<&OutcomeRow> {
    let label = crate::report::build::object_label;
    let mut objects: Vec<String> = rows.iter().map(|r| label(r)).collect();
    objects.sort();
    objects.dedup();
    let Some(first) = objects.first() else {
        return rows;
    };
    let chosen = if objects.iter().any(|o| o == "crisps_can") {
        "crisps_can".to_string()
    } else {
        first.clone()
    };
    rows.into_iter().filter(|r| label(r) == chosen).collect()
}

/// The hand-release rows Figs. 7 and 8 draw, of the inputs' batches ([`release_rows`]).
fn release_rows_of(inputs: &Inputs) -> Vec<&OutcomeRow> {
    use crate::report::inputs::BatchRows;
    release_rows(
        inputs
            .batches_of(Kind::HandRelease, crate::protocol::Mode::Online)
            .map(|b| match &b.rows {
                BatchRows::Catch(r) => r.iter().collect(),
                _ => Vec::new(),
            })
            .collect(),
    )
}

/// The rows Figs. 7 and 8 draw of hand-release batches' rows: the batches that release
/// one object (the paper's release and regrasp), leaving out a batch of several objects
/// (the objects experiment), whose trials of the same object would otherwise be pooled into
/// the panels of its one model and grasp; of those, one object's ([`paper_object`]). Only
/// objects batches given: one object's rows of them.
fn release_rows(batches: Vec<Vec<&OutcomeRow>>) -> Vec<&OutcomeRow> {
    let label = crate::report::build::object_label;
    let (one_object, several): (Vec<Vec<&OutcomeRow>>, Vec<Vec<&OutcomeRow>>) = batches
        .into_iter()
        .partition(|rows| rows.iter().all(|r| label(r) == label(rows[0])));
    let one_object: Vec<&OutcomeRow> = one_object.into_iter().flatten().collect();
    if one_object.is_empty() {
        paper_object(several.into_iter().flatten().collect())
    } else {
        paper_object(one_object)
    }
}

/// The whole-hand figures, when the inputs hold online hand-release batches.
pub fn hand_figures(inputs: &Inputs, dir: &Path) -> Result<Vec<PathBuf>, PlotError> {
    let rows = release_rows_of(inputs);
    if rows.is_empty() {
        return Ok(Vec::new());
    }
    let panels = outcome_bars(&rows);
    let height = (330 * panel_grid(&panels).0.len() as u32 + 40).max(520);
    let mut out = crate::figure_files!(dir.join("fig7_hand_outcomes"), (1200, height), |root| {
        bars(&root, &panels)
    });
    let groups = distances_by_strategy(&rows);
    out.extend(crate::figure_files!(
        dir.join("fig8_hand_slip_distance"),
        SIZE,
        |root| { boxes(&root, &groups) }
    ));
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn figures_seven_and_eight_draw_one_objects_rows_the_crisps_cans_first() {
        let mut banana = row("global", "2Fr2Sen", 0.0, Verdict::FalseNegative, None);
        banana.object = "banana".into();
        let can = row("global", "2Fr2Sen", 0.0, Verdict::TruePositive, Some(10.0));
        let rows = vec![&banana, &can, &banana];
        let kept = paper_object(rows);
        assert_eq!(kept.len(), 1);
        assert_eq!(kept[0].object, "crisps_can");
        // no crisps can: the first object by name, alone
        let mut softball = banana.clone();
        softball.object = "softball".into();
        let kept = paper_object(vec![&softball, &banana]);
        assert!(kept.iter().all(|r| r.object == "banana") && kept.len() == 1);
    }

    /// The objects batch's crisps can trials are not pooled into the release's panels:
    /// beside a batch of one object, a batch of several is left out.
    #[test]
    fn an_objects_batch_is_not_pooled_into_the_release() {
        let release = row("global", "2Fr2Sen", 180.0, Verdict::TruePositive, Some(4.0));
        let objects_can = row("global", "2Fr2Sen", 0.0, Verdict::FalsePositive, None);
        let mut banana = objects_can.clone();
        banana.object = "banana".into();
        let kept = release_rows(vec![vec![&release, &release], vec![&objects_can, &banana]]);
        assert_eq!(kept.len(), 2);
        assert!(kept.iter().all(|r| r.grasp_deg == 180.0));
        // the objects batch alone: its crisps can rows
        let kept = release_rows(vec![vec![&objects_can, &banana]]);
        assert_eq!(kept.len(), 1);
        assert_eq!(kept[0].object, "crisps_can");
    }

    fn row(scope: &str, strategy: &str, grasp: f64, v: Verdict, d: Option<f64>) -> OutcomeRow {
        OutcomeRow {
            trial_id: "t".into(),
            object: "crisps_can".into(),
            grasp_deg: grasp,
            model: "svm".into(),
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
        assert_eq!(b.len(), 3);
        let global_0 = &b[&Panel::new("global", 0.0)];
        assert_eq!(
            global_0[0],
            Bar {
                label: "2Fr2Sen".into(),
                tp: 1,
                fp: 1,
                fn_: 0,
                other: 0
            }
        );
        assert_eq!(b[&Panel::new("global", 180.0)][0].fn_, 1);
        // every trial is in its bar: those without a slip too
        let local_0 = &b[&Panel::new("local", 0.0)];
        assert_eq!((local_0[1].tp, local_0[1].other), (0, 2));
        assert_eq!(
            panel_grid(&b),
            (
                vec!["global".into(), "local".into()],
                vec![0f64.to_bits(), 180f64.to_bits()]
            )
        );
        assert_eq!(
            Panel::new("local", 180.0).title(),
            "local model, hand at 180 deg"
        );
        let d = distances_by_strategy(&refs);
        assert_eq!(
            d,
            vec![("1Fr1Sen".into(), vec![1.0]), ("2Fr2Sen".into(), vec![3.0])]
        );
    }

    #[test]
    fn each_model_has_panels_and_boxes_of_its_own() {
        let mut a = row("global", "2Fr2Sen", 0.0, Verdict::TruePositive, Some(3.0));
        let mut b = row("global", "2Fr2Sen", 0.0, Verdict::FalsePositive, None);
        let mut c = row("global", "2Fr2Sen", 0.0, Verdict::TruePositive, Some(5.0));
        a.model = "mlp".into();
        b.model = "forest".into();
        c.model = "forest".into();
        let refs = vec![&a, &b, &c];
        let bars = outcome_bars(&refs);
        assert_eq!(bars.len(), 2);
        let forest = &bars[&Panel::new("forest: global", 0.0)][0];
        assert_eq!((forest.tp, forest.fp), (1, 1));
        assert_eq!(bars[&Panel::new("mlp: global", 0.0)][0].tp, 1);
        assert_eq!(
            distances_by_strategy(&refs),
            vec![
                ("forest: 2Fr2Sen".into(), vec![5.0]),
                ("mlp: 2Fr2Sen".into(), vec![3.0])
            ]
        );
    }

    /// The texts of an SVG, in drawing order.
    fn texts(svg: &str) -> Vec<String> {
        svg.split("</text>")
            .filter_map(|t| t.rsplit('>').next())
            .map(|t| t.trim().to_string())
            .filter(|t| !t.is_empty())
            .collect()
    }

    /// Figs. 7 and 8 as drawn and as captioned: Fig. 7 has a panel per model and grasp
    /// (its caption says so), Fig. 8 one box per strategy, pooled over models and grasps.
    #[test]
    fn the_captions_of_figures_seven_and_eight_say_what_they_draw() {
        crate::plots::register_font();
        let mut rows = Vec::new();
        for scope in ["global", "local"] {
            for grasp in [0.0, 180.0] {
                for strategy in ["1Fr2Sen", "2Fr2Sen"] {
                    rows.push(row(
                        scope,
                        strategy,
                        grasp,
                        Verdict::TruePositive,
                        Some(5.0),
                    ));
                }
            }
        }
        let refs: Vec<&OutcomeRow> = rows.iter().collect();
        let panels = outcome_bars(&refs);
        let mut svg = String::new();
        {
            let root = SVGBackend::with_string(&mut svg, (1200, 700)).into_drawing_area();
            bars(&root, &panels).unwrap();
        }
        let drawn: Vec<String> = texts(&svg)
            .into_iter()
            .filter(|t| t.contains(" model, hand at "))
            .collect();
        assert_eq!(
            drawn,
            [
                "global model, hand at 0 deg",
                "global model, hand at 180 deg",
                "local model, hand at 0 deg",
                "local model, hand at 180 deg"
            ]
        );
        let fig7 = crate::plots::caption("fig7_hand_outcomes").unwrap();
        assert!(
            fig7.contains("one panel per model (global, local) and grasp"),
            "{fig7}"
        );
        // the x labels are the strategies alone
        assert!(texts(&svg).iter().any(|t| t == "1Fr2Sen"), "{svg}");

        let groups = distances_by_strategy(&refs);
        let mut svg = String::new();
        {
            let root = SVGBackend::with_string(&mut svg, (900, 600)).into_drawing_area();
            boxes(&root, &groups).unwrap();
        }
        // each box named in lines under it: its strategy whole, then its n
        let drawn = texts(&svg);
        let at = |t: &str| drawn.iter().position(|d| d == t);
        for strategy in ["1Fr2Sen", "2Fr2Sen"] {
            let named = at(strategy).unwrap_or_else(|| panic!("{drawn:?}"));
            assert_eq!(drawn[named + 1], "n=4", "{drawn:?}");
        }
        let fig8 = crate::plots::caption("fig8_hand_slip_distance").unwrap();
        assert!(
            fig8.contains(
                "by strategy (and by model where the batch ran several), pooled over both grasps"
            ),
            "{fig8}"
        );
    }

    /// The outcome figure's count axes: whole-number ticks only, and an axis that ends just
    /// above the tallest bar (it used to tick 0, 0, 1, 1, 2, 2 for three trials and run to
    /// 60 for bars of 39, to leave room for a legend drawn over the plot).
    #[test]
    fn count_axes_tick_whole_numbers_and_fit_the_bars() {
        crate::plots::register_font();
        for tallest in [1, 2, 3, 5, 7, 12, 39, 40, 99, 250] {
            let top = count_axis_top(tallest);
            assert!(top >= tallest && (top as f64) <= (tallest as f64 * 1.08).ceil() + 0.5);
            let mut panels = BTreeMap::new();
            panels.insert(
                Panel::new("global", 0.0),
                vec![Bar {
                    label: "2Fr2Sen".into(),
                    tp: tallest,
                    fp: 0,
                    fn_: 0,
                    other: 0,
                }],
            );
            let mut svg = String::new();
            {
                let root = SVGBackend::with_string(&mut svg, (1200, 520)).into_drawing_area();
                bars(&root, &panels).unwrap();
            }
            // the y tick labels: the texts that are whole numbers
            let ticks: Vec<i64> = svg
                .split("</text>")
                .filter_map(|t| t.rsplit('>').next()?.trim().parse::<i64>().ok())
                .collect();
            assert!(ticks.len() >= 2, "{tallest}: ticks {ticks:?}");
            assert!(
                ticks.windows(2).all(|w| w[0] < w[1]),
                "{tallest}: ticks {ticks:?}"
            );
            assert!(*ticks.last().unwrap() <= top as i64, "{tallest}: {ticks:?}");
        }
    }
}
