//! The paper's figures with plotters, each as SVG, PDF and PNG (6 x 4 in; the PNG at
//! [`files::DPI`]). Text is drawn with a bundled DejaVu Sans (through plotters' `ab_glyph`
//! feature) so a machine without system font libraries draws the same PNGs; the SVGs name
//! it first and the PDFs embed it.
//!
//! Each figure is a function generic over the drawing backend; the `figure_files!` macro runs it on
//! both and derives the PDF from the SVG. Data preparation is plain functions with unit tests; drawing is checked by eye (the
//! issue note lists what was looked at) and by tests that the files are written.

pub mod files;
mod font;
pub mod lift;
pub mod offline;
pub mod online;
pub mod timing;

use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::report::inputs::Inputs;

#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    #[error("cannot draw {path}: {message}")]
    Draw { path: PathBuf, message: String },
    #[error("cannot create {path}: {source}")]
    Dir {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: {message}")]
    Input { path: PathBuf, message: String },
    /// A trial log that cannot be read (the error names the log).
    #[error(transparent)]
    Trial(#[from] crate::trial::TrialError),
}

/// What a figure function returns for backend `DB`.
pub type DrawResult<DB> = Result<(), DrawingAreaErrorKind<<DB as DrawingBackend>::ErrorType>>;

pub use font::{register_font, FONT};

/// Figure size, px (also the SVG's user units).
pub const SIZE: (u32, u32) = (900, 600);

/// Draws `figure` to `stem.svg` and `stem.png`, converts the SVG to `stem.pdf`; returns the
/// three paths.
#[macro_export]
macro_rules! figure_files {
    ($stem:expr, $size:expr, |$root:ident| $figure:expr) => {{
        $crate::plots::register_font();
        let svg = $stem.with_extension("svg");
        let png = $stem.with_extension("png");
        let pdf = $stem.with_extension("pdf");
        let err = |path: &std::path::Path, e: String| $crate::plots::PlotError::Draw {
            path: path.to_path_buf(),
            message: e,
        };
        // Each file is written whole or not at all (a full disk leaves no half figure).
        let mut svg_text = String::new();
        {
            let $root = plotters::prelude::SVGBackend::with_string(&mut svg_text, $size)
                .into_drawing_area();
            $figure.map_err(|e| err(&svg, e.to_string()))?;
            $root.present().map_err(|e| err(&svg, e.to_string()))?;
        }
        $crate::output::atomic::write_atomic(&svg, svg_text.as_bytes())
            .map_err(|e| err(&svg, e.to_string()))?;
        // plotters picks the image format by extension: drawn as `.<stem>.partial.png`
        let drawn = $crate::plots::files::drawing_path(&png);
        {
            let $root = plotters::prelude::BitMapBackend::new(&drawn, $size).into_drawing_area();
            $figure.map_err(|e| err(&png, e.to_string()))?;
            $root.present().map_err(|e| err(&png, e.to_string()))?;
        }
        $crate::plots::files::state_png_dpi(&drawn, &png).map_err(|e| err(&png, e))?;
        $crate::plots::files::svg_to_pdf(&svg, &pdf).map_err(|e| err(&pdf, e))?;
        vec![svg, pdf, png]
    }};
}

/// A colour for value `t` in 0..1 on the viridis scale (perceptually even, readable in grey
/// and by colour-blind readers), interpolated between its published anchor colours.
pub fn viridis(t: f64) -> RGBColor {
    const ANCHORS: [(u8, u8, u8); 9] = [
        (68, 1, 84),
        (71, 44, 122),
        (59, 81, 139),
        (44, 113, 142),
        (33, 144, 141),
        (39, 173, 129),
        (92, 200, 99),
        (170, 220, 50),
        (253, 231, 37),
    ];
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let x = t * (ANCHORS.len() - 1) as f64;
    let i = (x.floor() as usize).min(ANCHORS.len() - 2);
    let f = x - i as f64;
    let mix = |a: u8, b: u8| (a as f64 + (b as f64 - a as f64) * f).round() as u8;
    let (a, b) = (ANCHORS[i], ANCHORS[i + 1]);
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

/// The three outcome colours (TP green, FP orange, FN red), as in the paper's bar charts.
pub const TP_COLOUR: RGBColor = RGBColor(46, 139, 87);
pub const FP_COLOUR: RGBColor = RGBColor(230, 145, 56);
pub const FN_COLOUR: RGBColor = RGBColor(200, 40, 40);

/// What a figure shows, as a caption: the paper's figure it stands for and the findings
/// (docs/paper_findings.toml ids) it bears on; `None` for a file name this module does not
/// make.
pub fn caption(file_stem: &str) -> Option<String> {
    let fig5 = |classifier: &str| {
        format!("Fig. 5: test macro F1 of the {classifier} over the down-sampling d (static frames kept) and n_slip (slip frames labelled per slip); the paper's best cells lie at n_slip 11-15. Findings sf-offline-order, sf-best-n-slip, sf-best-d, sf-few-frames-trail-off, sf-svm-wins-cells.")
    };
    Some(match file_stem {
        "fig4a_pin_speed" => "Fig. 4a: how the magnitude of the mean pin velocity is spread over the static and the slip frames of the rail's training trials, with the threshold classifier's T. In the paper the static class has a long tail reaching into the slip class, so no threshold separates them. Findings sf-pin-speed-tail, sf-threshold-misses-slip.".to_string(),
        "fig4b_pin_velocities" => "Fig. 4b: pin velocity fields of two frames of one rail training trial and sensor, on one arrow scale: a typical static frame (the median speed of its static frames) and its fastest slip frame. The paper shows four, static and slip frames each above and below the threshold T; these two are the ends of that range. Finding sf-threshold-misses-slip.".to_string(),
        "fig5_f1_svm_rbf" => fig5("SVM with an RBF kernel"),
        "fig5_f1_logreg" => fig5("logistic regression"),
        "fig5_f1_threshold" => fig5("threshold on the mean pin speed"),
        "fig7_hand_outcomes" => "Fig. 7: TP, FP and FN over the strategies, one panel per model (global, local) and grasp (the hand at 0 and at 180 deg); grey, trials that did not slip or were held with no measurable slip. One object's release and regrasp, as the paper's (the crisps can's where given): an objects batch beside it is not pooled in. The paper: the local classifier loses TPs at 180 deg, the global hardly. Findings wh-global-beats-local, wh-global-generalises, wh-fn-local-rotated, wh-fp-sensitive-strategy.".to_string(),
        "fig8_hand_slip_distance" => "Fig. 8: slip distance D before the regrasp caught the object, by strategy (and by model where the batch ran several), pooled over both grasps of the same object's release as Fig. 7 (not an objects batch) (boxes: quartiles and median; n: caught trials). The paper: 16-45 mm, smallest for 1Fr2Sen. Findings wh-distance, wh-distance-sensitive-smallest, wh-distance-local-rotated.".to_string(),
        "fig12_lift_heights" => "Fig. 12: object and hand heights through a first-time lift (a lift succeeds when the object rises with the hand, after the hand has risen alone while it tightened). Findings lift-all-lifted, lift-cat.".to_string(),
        stem if stem.starts_with("fig13_lift_by_mass") => "Fig. 13: first-time lift by mass: slips per lift and overgrasp (how far past the least lifting grasp the hand closed; the paper: 39 % at 100-300 g, 105 % above). Findings lift-slips-rise-with-mass, lift-overgrasp-light, lift-overgrasp-heavy.".to_string(),
        "loop_lateness" => "The online loop's timing (docs/online.md), one column per timed trial: the lateness of its median, p99 and worst frame, decision time minus due time (above 0: late; the limit is one more frame period, 16.7 ms at 60 fps). Ringed: a trial that broke the deadline, kept as a faulted log and never scored. On the lock-step simulator simulated time waits for the computer, so its trials sit below 0 on any machine; timing.csv's late_with_work says what this machine's work would have added.".to_string(),
        _ => return None,
    })
}

/// A safe file name part.
pub fn slug(s: &str) -> String {
    s.chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect()
}

/// Every figure the inputs support, into `dir`.
pub fn draw_all(inputs: &Inputs, dir: &Path) -> Result<Vec<PathBuf>, PlotError> {
    std::fs::create_dir_all(dir).map_err(|source| PlotError::Dir {
        path: dir.to_path_buf(),
        source,
    })?;
    let mut out = Vec::new();
    for (k, s) in inputs.sweeps.iter().enumerate() {
        // Several sweeps in one report each get their own figures.
        let prefix = if inputs.sweeps.len() > 1 {
            format!("sweep{}_", k + 1)
        } else {
            String::new()
        };
        out.extend(offline::sweep_heatmaps(&s.rows, dir, &prefix)?);
    }
    if !inputs.trial_dirs.is_empty() {
        let threshold = inputs.models.iter().find_map(|(_, m)| m.threshold());
        out.extend(offline::trial_figures(&inputs.trial_dirs, threshold, dir)?);
    }
    out.extend(online::hand_figures(inputs, dir)?);
    out.extend(lift::lift_figures(inputs, dir)?);
    out.extend(timing::timing_figures(inputs, dir)?);
    Ok(out)
}

/// Helper for figures: a blank white canvas.
pub fn clear<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
    root.fill(&WHITE)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn viridis_runs_from_purple_to_yellow() {
        assert_eq!(viridis(0.0), RGBColor(68, 1, 84));
        assert_eq!(viridis(1.0), RGBColor(253, 231, 37));
        assert_eq!(viridis(f64::NAN), viridis(0.0));
        assert_eq!(viridis(0.5), RGBColor(33, 144, 141));
    }
}
