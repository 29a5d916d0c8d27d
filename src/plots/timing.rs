//! The online loop's lateness, trial by trial (docs/online.md): each trial's median, p99
//! and worst frame against its due time, from the batches' `timing.csv`.

use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::prelude::*;

use super::{clear, DrawResult, PlotError, FONT, SIZE};
use crate::report::inputs::Inputs;
use crate::runner::loop_timing::TimingRow;

/// One trial's point: its index in the report, p50, p99 and max lateness (ms), and whether
/// it faulted on its deadline.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrialLateness {
    pub index: usize,
    pub p50_ms: f64,
    pub p99_ms: f64,
    pub max_ms: f64,
    pub faulted: bool,
}

pub fn points(rows: &[&TimingRow]) -> Vec<TrialLateness> {
    rows.iter()
        .enumerate()
        .map(|(index, r)| TrialLateness {
            index,
            p50_ms: r.lateness_p50_ms,
            p99_ms: r.lateness_p99_ms,
            max_ms: r.lateness_max_ms,
            faulted: r.deadline_fault,
        })
        .collect()
}

fn lateness_plot<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    points: &[TrialLateness],
) -> DrawResult<DB> {
    clear(root)?;
    let lo = points.iter().map(|p| p.p50_ms).fold(-20.0, f64::min);
    let hi = points.iter().map(|p| p.max_ms).fold(20.0, f64::max);
    let n = points.len().max(1) as f64;
    let mut chart = ChartBuilder::on(root)
        .caption(
            "Online loop: each trial's lateness against its deadline",
            (FONT, 20),
        )
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(60)
        .build_cartesian_2d(-0.5..n - 0.5, lo * 1.1..hi * 1.1)?;
    chart
        .configure_mesh()
        .light_line_style(TRANSPARENT)
        .x_desc("trial (in report order)")
        .x_label_formatter(&|v| format!("{v:.0}"))
        .y_desc("decision time minus due time (ms; above 0: late)")
        .label_style((FONT, 14))
        .axis_desc_style((FONT, 15))
        .draw()?;
    chart.draw_series(std::iter::once(PathElement::new(
        vec![(-0.5, 0.0), (n - 0.5, 0.0)],
        BLACK.stroke_width(1),
    )))?;
    type Value = fn(&TrialLateness) -> f64;
    let series: [(&str, RGBColor, Value); 3] = [
        ("median frame", RGBColor(150, 150, 150), |p| p.p50_ms),
        ("p99 frame", RGBColor(59, 81, 139), |p| p.p99_ms),
        ("worst frame", super::FN_COLOUR, |p| p.max_ms),
    ];
    for (label, colour, value) in series {
        chart
            .draw_series(
                points
                    .iter()
                    .map(|p| Circle::new((p.index as f64, value(p)), 3, colour.filled())),
            )?
            .label(label)
            .legend(move |(x, y)| Circle::new((x + 8, y), 3, colour.filled()));
    }
    // a trial that faulted on its deadline: ringed, and never scored
    chart
        .draw_series(
            points
                .iter()
                .filter(|p| p.faulted)
                .map(|p| Circle::new((p.index as f64, p.max_ms), 7, BLACK.stroke_width(1))),
        )?
        .label("deadline fault (not scored)")
        .legend(|(x, y)| Circle::new((x + 8, y), 6, BLACK.stroke_width(1)));
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .background_style(WHITE.mix(0.9))
        .border_style(BLACK)
        .label_font((FONT, 13))
        .draw()?;
    Ok(())
}

/// `loop_lateness` over every online trial the inputs timed (none: no figure).
pub fn timing_figures(inputs: &Inputs, dir: &Path) -> Result<Vec<PathBuf>, PlotError> {
    let rows: Vec<&TimingRow> = inputs.batches.iter().flat_map(|b| &b.timing).collect();
    if rows.is_empty() {
        return Ok(Vec::new());
    }
    let points = points(&rows);
    Ok(crate::figure_files!(
        dir.join("loop_lateness"),
        SIZE,
        |root| lateness_plot(&root, &points)
    ))
}
