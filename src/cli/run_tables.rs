//! The summary table `tmo run` prints at the end of a batch, one layout per protocol kind
//! (the paper's tables; `tmo report` makes the full set from the outcome files).

use std::collections::BTreeMap;

use tmo::outcome::Verdict;
use tmo::runner::score::{CalibrationRow, LiftRow, OutcomeRow};

fn mean(v: impl Iterator<Item = f64>) -> Option<f64> {
    let (mut sum, mut n) = (0.0, 0usize);
    for x in v {
        sum += x;
        n += 1;
    }
    (n > 0).then(|| sum / n as f64)
}

fn show(v: Option<f64>, decimals: usize) -> String {
    v.map_or("-".into(), |x| format!("{x:.decimals$}"))
}

fn count(rows: &[&OutcomeRow], v: Verdict) -> usize {
    rows.iter().filter(|r| r.verdict == v).count()
}

fn group<R, K: Ord>(rows: &[R], key: impl Fn(&R) -> K) -> BTreeMap<K, Vec<&R>> {
    let mut cells: BTreeMap<K, Vec<&R>> = BTreeMap::new();
    for r in rows {
        cells.entry(key(r)).or_default().push(r);
    }
    cells
}

/// scope | strategy | grasp | TP | FP | FN | D (mm), as the paper's Table II.
pub fn hand(rows: &[OutcomeRow]) {
    println!(
        "{:<8} {:<9} {:>6} {:>4} {:>4} {:>4} {:>7}",
        "scope", "strategy", "grasp", "TP", "FP", "FN", "D (mm)"
    );
    let cells = group(rows, |r| {
        (
            r.scope.clone(),
            r.strategy.clone(),
            format!("{}", r.grasp_deg),
        )
    });
    for ((scope, strategy, grasp), rs) in cells {
        let d = mean(rs.iter().filter_map(|r| r.slip_distance_mm));
        println!(
            "{scope:<8} {strategy:<9} {grasp:>6} {:>4} {:>4} {:>4} {:>7}",
            count(&rs, Verdict::TruePositive),
            count(&rs, Verdict::FalsePositive),
            count(&rs, Verdict::FalseNegative),
            show(d, 1)
        );
    }
}

/// strategy | trials | caught | FP | dropped | d (mm), as the paper's rail results.
pub fn rail(rows: &[OutcomeRow]) {
    println!(
        "{:<9} {:>6} {:>8} {:>4} {:>8} {:>7}",
        "strategy", "trials", "caught", "FP", "dropped", "d (mm)"
    );
    for (strategy, rs) in group(rows, |r| r.strategy.clone()) {
        let d = mean(rs.iter().filter_map(|r| r.slip_distance_mm));
        println!(
            "{strategy:<9} {:>6} {:>8} {:>4} {:>8} {:>7}",
            rs.len(),
            count(&rs, Verdict::TruePositive),
            count(&rs, Verdict::FalsePositive),
            rs.iter().filter(|r| r.dropped).count(),
            show(d, 1)
        );
    }
}

/// object | strategy | trials | responses | dropped, as the paper's rice-pour results.
pub fn pour(rows: &[OutcomeRow]) {
    println!(
        "{:<16} {:<9} {:>6} {:>10} {:>8}",
        "object", "strategy", "trials", "responses", "dropped"
    );
    for ((object, strategy), rs) in group(rows, |r| (r.object.clone(), r.strategy.clone())) {
        println!(
            "{object:<16} {strategy:<9} {:>6} {:>10} {:>8}",
            rs.len(),
            rs.iter().map(|r| r.responses).sum::<usize>(),
            rs.iter().filter(|r| r.dropped).count()
        );
    }
}

/// object | mass | trials | success | slips | lag | overgrasp, as the paper's Fig. 10.
pub fn lift(rows: &[LiftRow], calibrated: bool) {
    println!(
        "{:<16} {:>7} {:>6} {:>8} {:>6} {:>9} {:>10}",
        "object", "added g", "trials", "success", "slips", "lag (mm)", "overgrasp"
    );
    for ((object, mass), rs) in group(rows, |r| (r.object.clone(), r.mass_g.to_bits())) {
        let mass = f64::from_bits(mass);
        let o = mean(rs.iter().filter_map(|r| r.overgrasp));
        println!(
            "{object:<16} {mass:>7} {:>6} {:>8} {:>6} {:>9} {:>10}",
            rs.len(),
            rs.iter().filter(|r| r.success).count(),
            show(mean(rs.iter().map(|r| r.slips as f64)), 1),
            show(mean(rs.iter().filter_map(|r| r.lag_mm)), 1),
            o.map_or("-".into(), |o| format!("{:.0} %", 100.0 * o)),
        );
    }
    if !calibrated {
        println!("(no overgrasp: set first_time_lift.calibration to a calibrate_lift batch's g_min.json)");
    }
}

/// object | mass | trials | found | g_cont | g_min | g_min - g_cont.
pub fn calibration(rows: &[CalibrationRow]) {
    println!(
        "{:<16} {:>7} {:>6} {:>6} {:>7} {:>7} {:>9}",
        "object", "added g", "trials", "found", "g_cont", "g_min", "past cont"
    );
    for ((object, mass), rs) in group(rows, |r| (r.object.clone(), r.mass_g.to_bits())) {
        let mass = f64::from_bits(mass);
        let found: Vec<_> = rs.iter().filter(|r| r.g_min.is_some()).collect();
        println!(
            "{object:<16} {mass:>7} {:>6} {:>6} {:>7} {:>7} {:>9}",
            rs.len(),
            found.len(),
            show(mean(rs.iter().filter_map(|r| r.g_cont)), 3),
            show(mean(found.iter().filter_map(|r| r.g_min)), 3),
            show(
                mean(found.iter().filter_map(|r| Some(r.g_min? - r.g_cont?))),
                3
            ),
        );
    }
}
