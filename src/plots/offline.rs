//! Offline figures: macro F1 heatmaps over down-sampling x n_slip (paper Fig. 5), the
//! histogram of mean pin speed for static and slip frames with the threshold (Fig. 4a), and
//! example pin-velocity fields (Fig. 4b).

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::{clear, slug, viridis, DrawResult, PlotError, FONT, SIZE};
use crate::slip::dataset::{Dataset, LabelSpec};
use crate::slip::features::{mean_velocity_norm, FeatureSpec, Units};
use crate::slip::sweep::SweepRow;
use crate::slip::threshold::ThresholdModel;
use crate::slip::Class;
use crate::trial::Trial;

/// Macro F1 of one classifier over the grid.
#[derive(Debug, Clone, PartialEq)]
pub struct HeatGrid {
    pub classifier: String,
    pub n_slips: Vec<usize>,
    pub downsamples: Vec<f64>,
    /// `f1[d][n]`, `None` where the sweep has no cell.
    pub f1: Vec<Vec<Option<f64>>>,
}

impl HeatGrid {
    pub fn from_rows(rows: &[SweepRow], classifier: &str) -> Option<Self> {
        let mine: Vec<&SweepRow> = rows.iter().filter(|r| r.classifier == classifier).collect();
        if mine.is_empty() {
            return None;
        }
        let d = |r: &SweepRow| r.downsample.parse::<f64>().unwrap_or(f64::NAN);
        let n_slips: Vec<usize> = mine
            .iter()
            .map(|r| r.n_slip)
            .collect::<BTreeSet<_>>()
            .into_iter()
            .collect();
        let mut downsamples: Vec<f64> = mine
            .iter()
            .map(|r| d(r))
            .filter(|v| v.is_finite())
            .collect();
        downsamples.sort_by(f64::total_cmp);
        downsamples.dedup();
        let mut f1 = vec![vec![None; n_slips.len()]; downsamples.len()];
        for r in mine {
            let (Some(i), Some(j)) = (
                downsamples.iter().position(|&v| v == d(r)),
                n_slips.iter().position(|&n| n == r.n_slip),
            ) else {
                continue;
            };
            f1[i][j] = Some(r.macro_f1);
        }
        Some(Self {
            classifier: classifier.to_string(),
            n_slips,
            downsamples,
            f1,
        })
    }

    fn values(&self) -> impl Iterator<Item = f64> + '_ {
        self.f1.iter().flatten().flatten().copied()
    }

    /// Best cell: (macro F1, d, n_slip).
    pub fn best(&self) -> Option<(f64, f64, usize)> {
        let mut best: Option<(f64, f64, usize)> = None;
        for (i, row) in self.f1.iter().enumerate() {
            for (j, v) in row.iter().enumerate() {
                if let Some(v) = v {
                    if best.is_none_or(|b| *v > b.0) {
                        best = Some((*v, self.downsamples[i], self.n_slips[j]));
                    }
                }
            }
        }
        best
    }
}

/// `g`'s cells coloured on the macro F1 scale `(lo, hi)` (shared by a sweep's maps).
fn heatmap<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    g: &HeatGrid,
    (lo, hi): (f64, f64),
) -> DrawResult<DB> {
    clear(root)?;
    let span = (hi - lo).max(1e-9);
    let (chart_area, bar_area) = root.split_horizontally(SIZE.0 - 110);
    let title = match g.best() {
        Some((f1, d, n)) => format!(
            "{}: test macro F1 (best {f1:.3} at d = {d:.1}, n_slip = {n})",
            crate::report::build::classifier_label(&g.classifier)
        ),
        None => crate::report::build::classifier_label(&g.classifier),
    };
    // Cells sit on the grid's indices, not its values, so lists with gaps (odd n_slip
    // only, uneven d steps) draw as a solid block; the axis labels give the values.
    let (cols, rows) = (g.n_slips.len(), g.downsamples.len());
    let mut chart = ChartBuilder::on(&chart_area)
        .caption(title, (FONT, 22))
        .margin(12)
        .x_label_area_size(50)
        .y_label_area_size(66)
        .build_cartesian_2d((-0.5)..(cols as f64 - 0.5), (-0.5)..(rows as f64 - 0.5))?;
    let n_label = |v: &f64| {
        let k = v.round();
        if (v - k).abs() > 0.01 || k < 0.0 {
            return String::new();
        }
        g.n_slips
            .get(k as usize)
            .map_or(String::new(), |n| n.to_string())
    };
    let d_label = |v: &f64| {
        let k = v.round();
        if (v - k).abs() > 0.01 || k < 0.0 {
            return String::new();
        }
        g.downsamples
            .get(k as usize)
            .map_or(String::new(), |d| format!("{d:.1}"))
    };
    chart
        .configure_mesh()
        .light_line_style(TRANSPARENT)
        .disable_mesh()
        .x_desc("n_slip (frames labelled slip after onset)")
        .y_desc("down-sampling d (static frames kept)")
        .x_labels(cols.clamp(2, 20) + 1)
        .y_labels(rows.clamp(2, 12) + 1)
        .x_label_formatter(&n_label)
        .y_label_formatter(&d_label)
        .label_style((FONT, 17))
        .axis_desc_style((FONT, 17))
        .draw()?;
    // Each cell's value as large as the cell allows (the paper's grid is 15 x 10 cells;
    // the quick preset's 8 x 4), so it reads at the page's size too.
    let (plot_w, plot_h) = chart.plotting_area().dim_in_pixel();
    let value_px = (f64::from(plot_w) / cols.max(1) as f64 / 2.6)
        .min(f64::from(plot_h) / rows.max(1) as f64 / 2.2)
        .clamp(10.0, 22.0);
    for (i, row) in g.f1.iter().enumerate() {
        for (j, v) in row.iter().enumerate() {
            let Some(v) = v else { continue };
            let (x, y) = (j as f64, i as f64);
            let t = (v - lo) / span;
            chart.draw_series(std::iter::once(Rectangle::new(
                [(x - 0.5, y - 0.5), (x + 0.5, y + 0.5)],
                viridis(t).filled(),
            )))?;
            let ink = if t > 0.6 { BLACK } else { WHITE };
            chart.draw_series(std::iter::once(Text::new(
                format!("{:.2}", v),
                (x, y),
                (FONT, value_px)
                    .into_font()
                    .color(&ink)
                    .pos(Pos::new(HPos::Center, VPos::Center)),
            )))?;
        }
    }
    // Colour bar.
    let mut bar = ChartBuilder::on(&bar_area)
        .margin_top(45)
        .margin_bottom(57)
        .margin_right(10)
        .y_label_area_size(55)
        .build_cartesian_2d(0.0..1.0, lo..(lo + span))?;
    bar.configure_mesh()
        .light_line_style(TRANSPARENT)
        .disable_mesh()
        .disable_x_axis()
        .y_labels(6)
        .y_label_formatter(&|v| format!("{v:.2}"))
        .y_desc("macro F1")
        .label_style((FONT, 16))
        .axis_desc_style((FONT, 17))
        .draw()?;
    let steps = 100;
    bar.draw_series((0..steps).map(|k| {
        let a = lo + span * k as f64 / steps as f64;
        // Each step reaches into the next, which is drawn over it: steps that only met
        // edge to edge left hairline gaps where a browser rounds the SVG's coordinates,
        // and the bar read as stripes.
        let b = lo + span * ((k + 2).min(steps)) as f64 / steps as f64;
        Rectangle::new(
            [(0.0, a), (1.0, b)],
            viridis(k as f64 / steps as f64).filled(),
        )
    }))?;
    Ok(())
}

/// One heatmap per classifier in the sweep: `<prefix>fig5_f1_<classifier>.{svg,png}`.
pub fn sweep_heatmaps(
    rows: &[SweepRow],
    dir: &Path,
    prefix: &str,
) -> Result<Vec<PathBuf>, PlotError> {
    let classifiers: BTreeSet<&str> = rows.iter().map(|r| r.classifier.as_str()).collect();
    let grids: Vec<HeatGrid> = classifiers
        .into_iter()
        .filter_map(|c| HeatGrid::from_rows(rows, c))
        .collect();
    // One colour scale for every classifier's map, so that colours compare across them (the
    // paper's Fig. 5 panels are read side by side).
    let scale = grids
        .iter()
        .flat_map(|g| g.values())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    let mut out = Vec::new();
    for g in &grids {
        let stem = dir.join(format!("{prefix}fig5_f1_{}", slug(&g.classifier)));
        out.extend(crate::figure_files!(stem, SIZE, |root| heatmap(
            &root, g, scale
        )));
    }
    Ok(out)
}

/// Mean pin speed of every labelled frame, by class.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SpeedsByClass {
    pub static_: Vec<f64>,
    pub slip: Vec<f64>,
}

impl SpeedsByClass {
    pub fn from_dataset(ds: &Dataset) -> Self {
        let mut s = Self::default();
        for i in 0..ds.len() {
            let v = f64::from(mean_velocity_norm(ds.row(i)));
            match ds.y[i] {
                Class::Static => s.static_.push(v),
                Class::Slip => s.slip.push(v),
            }
        }
        s
    }
}

/// `bins` edges spaced evenly in log between `lo` and `hi` (both positive).
pub fn log_edges(lo: f64, hi: f64, bins: usize) -> Vec<f64> {
    let (a, b) = (lo.ln(), hi.ln());
    (0..=bins)
        .map(|k| (a + (b - a) * k as f64 / bins as f64).exp())
        .collect()
}

/// Fraction of `values` in each bin between consecutive `edges`; values outside go to the
/// end bins.
pub fn histogram(values: &[f64], edges: &[f64]) -> Vec<f64> {
    let bins = edges.len().saturating_sub(1);
    let mut h = vec![0.0; bins];
    if values.is_empty() || bins == 0 {
        return h;
    }
    for v in values {
        let k = edges[1..].partition_point(|e| e <= v).min(bins - 1);
        h[k] += 1.0;
    }
    h.iter_mut().for_each(|c| *c /= values.len() as f64);
    h
}

fn speed_histogram<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    s: &SpeedsByClass,
    threshold: (f64, &str),
    units: Units,
) -> DrawResult<DB> {
    let units = units.name();
    clear(root)?;
    // Speeds span three decades (still skin vs a sliding object): log bins show both.
    let mut all: Vec<f64> = s
        .static_
        .iter()
        .chain(&s.slip)
        .copied()
        .filter(|v| *v > 0.0)
        .collect();
    all.sort_by(f64::total_cmp);
    let lo = all
        .get(all.len() / 1000)
        .copied()
        .unwrap_or(1e-3)
        .min(threshold.0 / 2.0)
        .max(1e-4);
    let hi = all.last().copied().unwrap_or(1.0).max(threshold.0 * 2.0);
    let bins = 50;
    let edges = log_edges(lo, hi, bins);
    let hs = histogram(&s.static_, &edges);
    let hp = histogram(&s.slip, &edges);
    let y_max = hs.iter().chain(&hp).copied().fold(0.0, f64::max) * 1.25;
    let mut chart = ChartBuilder::on(root)
        .caption("Mean pin speed of static and slip frames", (FONT, 20))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(65)
        .build_cartesian_2d((lo..hi).log_scale(), 0.0..y_max.max(1e-3))?;
    chart
        .configure_mesh()
        .light_line_style(TRANSPARENT)
        .x_desc(format!("mean pin speed |v| ({units} per frame, log scale)"))
        .x_label_formatter(&|v| format!("{v}"))
        .y_desc("fraction of the class's frames")
        .label_style((FONT, 14))
        .axis_desc_style((FONT, 15))
        .draw()?;
    let static_colour = RGBColor(59, 81, 139);
    let slip_colour = RGBColor(200, 40, 40);
    for (h, colour, label, n) in [
        (&hs, static_colour, "static", s.static_.len()),
        (&hp, slip_colour, "slip", s.slip.len()),
    ] {
        chart
            .draw_series(h.iter().enumerate().map(|(k, f)| {
                Rectangle::new(
                    [(edges[k], 0.0), (edges[k + 1], *f)],
                    colour.mix(0.45).filled(),
                )
            }))?
            .label(format!("{label} ({n} frames)"))
            .legend(move |(x, y)| {
                Rectangle::new([(x, y - 5), (x + 14, y + 5)], colour.mix(0.6).filled())
            });
    }
    let (t, source) = threshold;
    chart
        .draw_series(DashedLineSeries::new(
            vec![(t, 0.0), (t, y_max)],
            8,
            5,
            BLACK.stroke_width(2),
        ))?
        .label(format!("threshold {t:.3} {units}/frame ({source})"))
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 14, y)], BLACK.stroke_width(2)));
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.9))
        .border_style(BLACK)
        .label_font((FONT, 14))
        .draw()?;
    Ok(())
}

/// Pins of one frame and their displacement from the sensor's previous frame.
#[derive(Debug, Clone, PartialEq)]
pub struct PinField {
    pub title: String,
    /// Which trial and sensor the frame is of.
    pub trial_id: String,
    pub sensor: u8,
    pub pins: Vec<(f64, f64)>,
    pub moves: Vec<(f64, f64)>,
}

fn field_of(trial: &Trial, sensor: u8, seq: u64, title: String) -> Option<PinField> {
    let frames: Vec<_> = trial.frames.iter().filter(|f| f.sensor == sensor).collect();
    let k = frames.iter().position(|f| f.seq == seq)?;
    let (now, before) = (frames[k], frames[k.checked_sub(1)?]);
    if now.pins.len() != before.pins.len() {
        return None;
    }
    Some(PinField {
        title,
        trial_id: trial.meta.trial_id.clone(),
        sensor,
        pins: now
            .pins
            .iter()
            .map(|p| (p[0] as f64, p[1] as f64))
            .collect(),
        moves: now
            .pins
            .iter()
            .zip(&before.pins)
            .map(|(a, b)| ((a[0] - b[0]) as f64, (a[1] - b[1]) as f64))
            .collect(),
    })
}

/// A typical static frame (median speed) and the fastest slip frame of the first trial
/// and sensor that has slip frames.
pub fn example_fields(trials: &[Trial], ds: &Dataset, units: Units) -> Option<[PinField; 2]> {
    let first_slip = (0..ds.len()).find(|&i| ds.y[i] == Class::Slip)?;
    let (trial, sensor) = (ds.trial[first_slip], ds.sensor[first_slip]);
    let rows: Vec<usize> = (0..ds.len())
        .filter(|&i| ds.trial[i] == trial && ds.sensor[i] == sensor)
        .collect();
    let speed = |i: usize| mean_velocity_norm(ds.row(i));
    let mut statics: Vec<usize> = rows
        .iter()
        .copied()
        .filter(|&i| ds.y[i] == Class::Static)
        .collect();
    statics.sort_by(|&a, &b| speed(a).total_cmp(&speed(b)));
    let still = *statics.get(statics.len() / 2)?;
    let slip = rows
        .iter()
        .copied()
        .filter(|&i| ds.y[i] == Class::Slip)
        .max_by(|&a, &b| speed(a).total_cmp(&speed(b)))?;
    let t = &trials[trial as usize];
    let name = |what: &str, i: usize| {
        format!(
            // short enough for half the figure at a size that reads: the trial and sensor
            // are the figure's own title
            "{what}: t = {:.2} s, |v| = {:.2} {}/frame",
            ds.time_s[i],
            speed(i),
            units.name()
        )
    };
    Some([
        field_of(t, sensor, ds.seq[still], name("static", still))?,
        field_of(t, sensor, ds.seq[slip], name("slip", slip))?,
    ])
}

fn quiver<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    fields: &[PinField; 2],
    units: Units,
) -> DrawResult<DB> {
    clear(root)?;
    let longest = fields
        .iter()
        .flat_map(|f| f.moves.iter())
        .map(|(dx, dy)| dx.hypot(*dy))
        .fold(0.0, f64::max)
        .max(1e-6);
    // One scale for both panels, so a static frame's arrows look as small as they are.
    let scale = 40.0 / longest;
    let (xs, ys): (Vec<f64>, Vec<f64>) = fields.iter().flat_map(|f| f.pins.iter().copied()).unzip();
    // a margin of a tenth of the field's span (50 px on a TacTip image)
    let span = |v: &[f64]| {
        v.iter().copied().fold(f64::NEG_INFINITY, f64::max)
            - v.iter().copied().fold(f64::INFINITY, f64::min)
    };
    let pad = (0.1 * span(&xs).max(span(&ys))).max(1e-3);
    let x_range = (xs.iter().copied().fold(f64::INFINITY, f64::min) - pad)
        ..(xs.iter().copied().fold(f64::NEG_INFINITY, f64::max) + pad);
    let y_lo = ys.iter().copied().fold(f64::INFINITY, f64::min) - pad;
    let y_hi = ys.iter().copied().fold(f64::NEG_INFINITY, f64::max) + pad;
    let root = root.titled(
        &format!(
            "Pin velocities of {} sensor {} (arrows x{}, {})",
            fields[0].trial_id,
            fields[0].sensor,
            significant(scale),
            units.name()
        ),
        (FONT, 20),
    )?;
    let panels = root.split_evenly((1, 2));
    for (area, f) in panels.iter().zip(fields) {
        let mut chart = ChartBuilder::on(area)
            .caption(&f.title, (FONT, 17))
            .margin(10)
            .x_label_area_size(42)
            .y_label_area_size(72)
            // image rows grow downwards
            .build_cartesian_2d(x_range.clone(), y_hi..y_lo)?;
        chart
            .configure_mesh()
            .light_line_style(TRANSPARENT)
            .x_desc(format!("x ({})", units.name()))
            .y_desc(format!("y ({})", units.name()))
            .label_style((FONT, 15))
            .axis_desc_style((FONT, 16))
            .draw()?;
        chart.draw_series(
            f.pins
                .iter()
                .map(|&p| Circle::new(p, 3, RGBColor(59, 81, 139).filled())),
        )?;
        let colour = RGBColor(200, 40, 40);
        for (&(x, y), &(dx, dy)) in f.pins.iter().zip(&f.moves) {
            let (ex, ey) = (x + dx * scale, y + dy * scale);
            let len = (dx * scale).hypot(dy * scale);
            chart.draw_series(std::iter::once(PathElement::new(
                vec![(x, y), (ex, ey)],
                colour.stroke_width(2),
            )))?;
            if len > 3.0 {
                let (ux, uy) = (dx * scale / len, dy * scale / len);
                let head = 6.0f64.min(len / 2.0);
                for side in [-1.0, 1.0] {
                    let (hx, hy) = (
                        ex - head * (ux - side * 0.5 * uy),
                        ey - head * (uy + side * 0.5 * ux),
                    );
                    chart.draw_series(std::iter::once(PathElement::new(
                        vec![(ex, ey), (hx, hy)],
                        colour.stroke_width(2),
                    )))?;
                }
            }
        }
    }
    Ok(())
}

/// `v` to two significant digits, without a trailing `.0` ("40", "0.0031").
fn significant(v: f64) -> String {
    if v >= 10.0 {
        format!("{v:.0}")
    } else {
        let decimals = (1.0 - v.log10().floor()).clamp(0.0, 12.0) as usize;
        format!("{v:.decimals$}")
    }
}

/// Fig. 4a and 4b from directories of collected trials.
pub fn trial_figures(
    dirs: &[PathBuf],
    threshold: Option<f32>,
    dir: &Path,
) -> Result<Vec<PathBuf>, PlotError> {
    let paths = crate::trial::expand_trial_paths(dirs)?;
    let trials = paths
        .iter()
        .map(|p| crate::trial::read_trial(p))
        .collect::<Result<Vec<_>, _>>()?;
    let Some(first) = trials.first() else {
        return Ok(Vec::new());
    };
    // an imported sensor's own units and step limit (bad ones fall back to the TacTip's:
    // a figure, not a model, is made here)
    let features =
        crate::slip::dataset::trial_features(first).unwrap_or(FeatureSpec::new(first.meta.pins));
    let trials: Vec<Trial> = trials
        .into_iter()
        .filter(|t| t.meta.pins == features.pins)
        .collect();
    // the paper's n_slip, so the histogram shows the frames its classifiers were trained on
    let labels = LabelSpec {
        n_slip: 13,
        onset: Default::default(),
    };
    let ds = Dataset::from_trials(&trials, &features, &labels);
    let speeds = SpeedsByClass::from_dataset(&ds);
    let (t, source) = match threshold {
        Some(t) => (f64::from(t), "the model's"),
        None => {
            let rows: Vec<&[f32]> = (0..ds.len()).map(|i| ds.row(i)).collect();
            match ThresholdModel::fit(&rows, &ds.y) {
                Ok(m) => (f64::from(m.threshold), "fitted to these frames"),
                Err(_) => return Ok(Vec::new()),
            }
        }
    };
    let mut out = crate::figure_files!(dir.join("fig4a_pin_speed"), SIZE, |root| {
        speed_histogram(&root, &speeds, (t, source), features.units)
    });
    if let Some(fields) = example_fields(&trials, &ds, features.units) {
        out.extend(crate::figure_files!(
            dir.join("fig4b_pin_velocities"),
            (1100, 560),
            |root| { quiver(&root, &fields, features.units) }
        ));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Fig. 4b draws two frames, a static one and a slip one, and its caption says so.
    #[test]
    fn the_caption_of_figure_4b_says_what_it_draws() {
        crate::plots::register_font();
        let field = |what: &str, step: f64| PinField {
            title: format!("{what}: t = 1.00 s, |v| = {step:.2} px/frame"),
            trial_id: "trial-00000".into(),
            sensor: 0,
            pins: vec![(0.0, 0.0), (10.0, 0.0), (0.0, 10.0)],
            moves: vec![(step, 0.0); 3],
        };
        let mut svg = String::new();
        {
            let root = SVGBackend::with_string(&mut svg, (1100, 560)).into_drawing_area();
            quiver(
                &root,
                &[field("static", 0.1), field("slip", 2.0)],
                Units::Px,
            )
            .unwrap();
        }
        let panels: Vec<&str> = svg
            .split("</text>")
            .filter_map(|t| t.rsplit('>').next())
            .filter_map(|t| t.trim().split(':').next())
            .filter(|t| ["static", "slip"].contains(t))
            .collect();
        assert_eq!(panels, ["static", "slip"]);
        let caption = crate::plots::caption("fig4b_pin_velocities").unwrap();
        assert!(
            caption.contains("two frames")
                && caption.contains("a typical static frame")
                && caption.contains("its fastest slip frame"),
            "{caption}"
        );
    }

    fn row(classifier: &str, n: usize, d: &str, f1: f64) -> SweepRow {
        SweepRow {
            classifier: classifier.into(),
            scope: crate::slip::dataset::Scope::Global,
            n_slip: n,
            downsample: d.into(),
            c: Some(1.0),
            gamma: Some(0.1),
            cv_macro_f1: None,
            train_rows: 0,
            train_slip_rows: 0,
            test_rows: 0,
            macro_f1: f1,
            slip_precision: 0.0,
            slip_recall: 0.0,
            slip_f1: 0.0,
            static_precision: 0.0,
            static_recall: 0.0,
            static_f1: 0.0,
            true_slip: 0,
            false_slip: 0,
            true_static: 0,
            false_static: 0,
            seconds: 0.0,
        }
    }

    #[test]
    fn a_sweep_becomes_a_grid_with_gaps_and_a_best_cell() {
        let rows = vec![
            row("svm-rbf", 3, "0.100", 0.8),
            row("svm-rbf", 1, "0.100", 0.7),
            row("svm-rbf", 3, "0.200", 0.9),
            row("logreg", 3, "0.200", 0.95),
        ];
        let g = HeatGrid::from_rows(&rows, "svm-rbf").unwrap();
        assert_eq!(g.n_slips, vec![1, 3]);
        assert_eq!(g.downsamples, vec![0.1, 0.2]);
        assert_eq!(
            g.f1,
            vec![vec![Some(0.7), Some(0.8)], vec![None, Some(0.9)]]
        );
        assert_eq!(g.best(), Some((0.9, 0.2, 3)));
        assert_eq!(HeatGrid::from_rows(&rows, "threshold"), None);
    }

    #[test]
    fn a_sweeps_heatmaps_share_one_colour_scale() {
        let dir = tempfile::tempdir().unwrap();
        let rows = vec![
            row("svm-rbf", 1, "0.100", 0.90),
            row("svm-rbf", 3, "0.100", 0.95),
            row("threshold", 1, "0.100", 0.55),
            row("threshold", 3, "0.100", 0.60),
        ];
        let files = sweep_heatmaps(&rows, dir.path(), "").unwrap();
        let svg = |name: &str| {
            let path = files
                .iter()
                .find(|f| f.to_string_lossy().ends_with(name))
                .unwrap();
            std::fs::read_to_string(path).unwrap()
        };
        // both colour bars run from the threshold's worst cell (0.55) to the SVM's best
        // (0.95), so both carry the ticks between (alone, each would span 0.05)
        for name in ["fig5_f1_svm_rbf.svg", "fig5_f1_threshold.svg"] {
            let text = svg(name);
            for tick in ["0.60", "0.70", "0.80", "0.90"] {
                assert!(text.contains(&format!("\n{tick}\n")), "{name} lacks {tick}");
            }
        }
    }

    #[test]
    fn histograms_are_fractions_of_the_class() {
        let h = histogram(&[0.01, 0.1, 0.2, 0.9, 5.0], &[0.1, 0.5, 1.0]);
        assert_eq!(h, vec![0.6, 0.4], "values outside go to the end bins");
        assert_eq!(histogram(&[], &[0.1, 1.0]), vec![0.0]);
        let e = log_edges(0.01, 1.0, 2);
        assert!((e[1] - 0.1).abs() < 1e-12 && e.len() == 3, "{e:?}");
    }
}
