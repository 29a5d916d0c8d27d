//! First-time lift figures: object and hand height over one lift with its stages shaded
//! (paper Fig. 12), and slips and overgrasp against mass (Fig. 13).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::{clear, DrawResult, PlotError, FONT, SIZE};
use crate::report::inputs::{BatchRows, Inputs};
use crate::report::stats::mean_sd;
use crate::runner::score::LiftRow;
use crate::trial::Trial;

/// One lift's heights relative to the start, and its stage boundaries, s.
#[derive(Debug, Clone, PartialEq)]
pub struct LiftTrace {
    pub title: String,
    /// (t, object rise, hand rise), mm.
    pub samples: Vec<(f64, f64, f64)>,
    /// Stage boundaries: contact made, lift starts, object lifted (if it was), hold ends,
    /// and the end of the log.
    pub contact_s: f64,
    pub lift_s: f64,
    pub lifted_s: Option<f64>,
    pub hold_end_s: f64,
    pub end_s: f64,
    pub responses_s: Vec<f64>,
}

impl LiftTrace {
    pub fn from_trial(t: &Trial, lifted_above_mm: f64) -> Option<Self> {
        let phase = |name: &str| {
            t.events
                .iter()
                .find(|e| e.topic == "/phase" && e.data["phase"] == name)
                .map(|e| e.time_s)
        };
        let (contact_s, lift_s, hold_end_s) =
            (phase("contact")?, phase("lifting")?, phase("hold_end")?);
        let first = t.markers.first()?;
        let samples: Vec<(f64, f64, f64)> = t
            .markers
            .iter()
            .map(|m| {
                (
                    m.time_s,
                    m.object_mm - first.object_mm,
                    m.hand_mm - first.hand_mm,
                )
            })
            .collect();
        let lifted_s = samples
            .windows(2)
            .find(|w| w[0].0 >= lift_s && w.iter().all(|s| s.1 > lifted_above_mm))
            .map(|w| w[0].0);
        Some(Self {
            title: format!(
                "{} ({}, +{} g)",
                t.meta.trial_id,
                t.meta.object,
                t.meta
                    .parameters
                    .get("extra_mass_g")
                    .map_or("0", |s| s.as_str())
            ),
            end_s: samples.last()?.0,
            samples,
            contact_s,
            lift_s,
            lifted_s,
            hold_end_s,
            responses_s: t
                .events
                .iter()
                .filter(|e| crate::trial::is_reaction(e))
                .map(|e| e.time_s)
                .collect(),
        })
    }
}

fn trace<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, l: &LiftTrace) -> DrawResult<DB> {
    clear(root)?;
    let (lo, hi) = l
        .samples
        .iter()
        .flat_map(|s| [s.1, s.2])
        .fold((0.0f64, 1.0f64), |(a, b), v| (a.min(v), b.max(v)));
    let t0 = l.samples.first().map_or(0.0, |s| s.0);
    let mut chart = ChartBuilder::on(root)
        .caption(format!("First-time lift: {}", l.title), (FONT, 20))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(60)
        .build_cartesian_2d(t0..l.end_s, (lo - 3.0)..(hi + 6.0))?;
    let stages = [
        (t0, l.contact_s, "", RGBColor(245, 245, 245)),
        (l.contact_s, l.lift_s, "1", RGBColor(220, 230, 245)),
        (
            l.lift_s,
            l.lifted_s.unwrap_or(l.hold_end_s),
            "2",
            RGBColor(250, 225, 200),
        ),
        (
            l.lifted_s.unwrap_or(l.hold_end_s),
            l.hold_end_s,
            "3",
            RGBColor(215, 240, 215),
        ),
        (l.hold_end_s, l.end_s, "4", RGBColor(235, 225, 245)),
    ];
    for (a, b, name, colour) in stages {
        if b <= a {
            continue;
        }
        chart.draw_series(std::iter::once(Rectangle::new(
            [(a, lo - 3.0), (b, hi + 6.0)],
            colour.filled(),
        )))?;
        chart.draw_series(std::iter::once(Text::new(
            name.to_string(),
            ((a + b) / 2.0, hi + 3.0),
            (FONT, 13)
                .into_font()
                .color(&BLACK)
                .pos(Pos::new(HPos::Center, VPos::Center)),
        )))?;
    }
    chart
        .configure_mesh()
        .light_line_style(TRANSPARENT)
        .x_desc("time (s); stages: 1 contact, 2 slip and tighten, 3 held, 4 lowered")
        .y_desc("height above start (mm)")
        .label_style((FONT, 14))
        .axis_desc_style((FONT, 15))
        .draw()?;
    let hand = RGBColor(59, 81, 139);
    let object = RGBColor(200, 40, 40);
    chart
        .draw_series(LineSeries::new(
            l.samples.iter().map(|s| (s.0, s.2)),
            hand.stroke_width(2),
        ))?
        .label("hand (marker)")
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], hand.stroke_width(2)));
    chart
        .draw_series(LineSeries::new(
            l.samples.iter().map(|s| (s.0, s.1)),
            object.stroke_width(2),
        ))?
        .label("object (marker)")
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], object.stroke_width(2)));
    chart
        .draw_series(
            l.responses_s
                .iter()
                .map(|&t| PathElement::new(vec![(t, lo - 3.0), (t, lo)], BLACK.stroke_width(2))),
        )?
        .label(format!("slip responses ({})", l.responses_s.len()))
        .legend(|(x, y)| {
            PathElement::new(vec![(x + 6, y - 6), (x + 6, y + 6)], BLACK.stroke_width(2))
        });
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .background_style(WHITE.mix(0.9))
        .border_style(BLACK)
        .label_font((FONT, 13))
        .draw()?;
    Ok(())
}

/// Per object and added mass: (mass, slips mean and sd, overgrasp mean and sd in %).
pub type MassPoint = (f64, (f64, f64), Option<(f64, f64)>);

pub fn by_mass(rows: &[&LiftRow]) -> BTreeMap<String, Vec<MassPoint>> {
    let mut cells: BTreeMap<String, BTreeMap<u64, Vec<&LiftRow>>> = BTreeMap::new();
    for r in rows.iter().filter(|r| r.fault.is_none()) {
        cells
            .entry(r.object.clone())
            .or_default()
            .entry(r.mass_g.to_bits())
            .or_default()
            .push(r);
    }
    cells
        .into_iter()
        .map(|(object, by)| {
            let points = by
                .into_iter()
                .map(|(m, rs)| {
                    let slips: Vec<f64> = rs.iter().map(|r| r.slips as f64).collect();
                    let over: Vec<f64> = rs
                        .iter()
                        .filter_map(|r| r.overgrasp)
                        .map(|o| 100.0 * o)
                        .collect();
                    (
                        f64::from_bits(m),
                        mean_sd(&slips).unwrap_or((0.0, 0.0)),
                        mean_sd(&over),
                    )
                })
                .collect();
            (object, points)
        })
        .collect()
}

fn mass_plot<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    object: &str,
    points: &[MassPoint],
) -> DrawResult<DB> {
    clear(root)?;
    let m_max = points.iter().map(|p| p.0).fold(1.0, f64::max);
    let s_max = points.iter().map(|p| p.1 .0 + p.1 .1).fold(1.0, f64::max);
    let o_max = points
        .iter()
        .filter_map(|p| p.2.map(|o| o.0 + o.1))
        .fold(10.0, f64::max);
    let mut chart = ChartBuilder::on(root)
        .caption(
            format!("First-time lift: slips and overgrasp ({object})"),
            (FONT, 20),
        )
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(60)
        .right_y_label_area_size(60)
        .build_cartesian_2d(-0.05 * m_max..m_max * 1.05, 0.0..s_max * 1.15)?
        .set_secondary_coord(-0.05 * m_max..m_max * 1.05, 0.0..o_max * 1.15);
    chart
        .configure_mesh()
        .light_line_style(TRANSPARENT)
        .x_desc("added mass (g)")
        .x_label_formatter(&|v| format!("{v:.0}"))
        .y_desc("slip responses per lift (mean ± sd)")
        .label_style((FONT, 14))
        .axis_desc_style((FONT, 15))
        .draw()?;
    chart
        .configure_secondary_axes()
        .y_desc("overgrasp (%)")
        .y_label_formatter(&|v| format!("{v:.0}"))
        .label_style((FONT, 14))
        .axis_desc_style((FONT, 15))
        .draw()?;
    let red = RGBColor(200, 40, 40);
    let blue = RGBColor(59, 81, 139);
    chart
        .draw_series(LineSeries::new(
            points.iter().map(|p| (p.0, p.1 .0)),
            red.stroke_width(2),
        ))?
        .label("slips")
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], red.stroke_width(2)));
    chart.draw_series(
        points
            .iter()
            .map(|p| Circle::new((p.0, p.1 .0), 4, red.filled())),
    )?;
    chart.draw_series(points.iter().map(|p| {
        PathElement::new(
            vec![(p.0, (p.1 .0 - p.1 .1).max(0.0)), (p.0, p.1 .0 + p.1 .1)],
            red.stroke_width(1),
        )
    }))?;
    let over: Vec<(f64, f64)> = points
        .iter()
        .filter_map(|p| p.2.map(|o| (p.0, o.0)))
        .collect();
    chart
        .draw_secondary_series(LineSeries::new(over.iter().copied(), blue.stroke_width(2)))?
        .label("overgrasp (right axis)")
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], blue.stroke_width(2)));
    chart.draw_secondary_series(
        over.iter()
            .map(|&p| TriangleMarker::new(p, 5, blue.filled())),
    )?;
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .background_style(WHITE.mix(0.9))
        .border_style(BLACK)
        .label_font((FONT, 13))
        .draw()?;
    Ok(())
}

/// Fig. 12 (the successful lift with the most slip responses) and Fig. 13 per object.
pub fn lift_figures(inputs: &Inputs, dir: &Path) -> Result<Vec<PathBuf>, PlotError> {
    let mut out = Vec::new();
    let rows = inputs.lift_rows();
    if rows.is_empty() {
        return Ok(out);
    }
    for (object, points) in by_mass(&rows) {
        let stem = dir.join(format!("fig13_lift_by_mass_{}", super::slug(&object)));
        out.extend(crate::figure_files!(stem, SIZE, |root| mass_plot(
            &root, &object, &points
        )));
    }
    // The log of the most telling lift: successful, with the most responses.
    let pick = inputs.batches.iter().find_map(|b| match &b.rows {
        BatchRows::Lift(rs) => rs
            .iter()
            .filter(|r| r.success && r.fault.is_none())
            .max_by_key(|r| r.slips)
            .map(|r| b.dir.join(format!("{}.mcap", r.trial_id))),
        _ => None,
    });
    if let Some(path) = pick {
        let trial = crate::trial::read_trial(&path)?;
        if let Some(l) = LiftTrace::from_trial(&trial, 1.0) {
            out.extend(crate::figure_files!(
                dir.join("fig12_lift_heights"),
                SIZE,
                |root| { trace(&root, &l) }
            ));
        }
    }
    Ok(out)
}
