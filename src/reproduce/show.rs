//! How the findings page shows a value: rates in percent with their counts, differences
//! of rates in percentage points, every other value with its interval in its own unit, and
//! each value of a row labelled with what it is.

use super::evidence::Basis;
use super::findings::{Judged, Measure};

/// Means of fractions the paper prints in percent (overgrasp: "39 %").
fn in_percent(metric: &str) -> bool {
    metric.starts_with("lift.overgrasp.")
}

/// What a metric is, in a few words, for a row that shows several: the part of its name
/// that tells it from the others of its row, in the paper's words.
pub fn label(metric: &str) -> String {
    let last = metric.rsplit('.').next().unwrap_or(metric);
    let known = match metric {
        "rail.offline.mean_f1.svm_rbf" => Some("SVM grid mean"),
        "hand.offline.f1.rail_model" => Some("rail model"),
        "hand.offline.f1.sensor0" => Some("thumb"),
        "hand.offline.f1.sensor1" => Some("finger 1"),
        "hand.offline.f1.sensor2" => Some("finger 2"),
        "hand.online.tp.nsen23" => Some("two or three sensors"),
        "hand.online.tp.nsen1" => Some("one sensor"),
        "hand.online.fp.others" => Some("other strategies"),
        "hand.online.fn.local.180" => Some("local at 180 deg"),
        "hand.online.d.local.180" => Some("local at 180 deg"),
        "hand.online.d.local.0" => Some("local at 0 deg"),
        "objects.tp.cat_100g" => Some("cat with 100 g"),
        "objects.tp.training" => Some("training objects"),
        "objects.tp.novel" => Some("novel objects"),
        "lift.overgrasp.100_300g" => Some("100-300 g"),
        "lift.overgrasp.over_300g" => Some("over 300 g"),
        _ => None,
    };
    if let Some(k) = known {
        return k.to_string();
    }
    match last {
        "svm_rbf" => "SVM".into(),
        "logreg" => "LogReg".into(),
        "1fr" => format!("{} 1 frame", prefix(metric)),
        "2fr" => format!("{} 2 frames", prefix(metric)),
        "global" | "local" if metric.contains(".tp_drop_180.") => format!("{last} drop at 180 deg"),
        "global" | "local" | "threshold" | "rigid" | "deformable" | "cat" => last.into(),
        strategy if strategy.contains("Fr") => {
            let what = prefix(metric);
            if metric.starts_with("objects.") || metric.starts_with("hand.online.fp.") {
                format!("{what} {strategy}")
            } else {
                strategy.into()
            }
        }
        _ => last.replace('_', " "),
    }
}

/// The kind of a rate or distance in a metric's name (`fp`, `dropped`, `d`), as the
/// paper's tables head it.
fn prefix(metric: &str) -> String {
    let parts: Vec<&str> = metric.split('.').collect();
    match parts.get(parts.len().saturating_sub(2)).copied() {
        Some("fp") => "FP".into(),
        Some("fn") => "FN".into(),
        Some("tp") => "TP".into(),
        Some("d") => "D".into(),
        Some(other) => other.replace('_', " "),
        None => String::new(),
    }
}

/// A value as the page shows it (three decimals, one from 10 up).
pub(super) fn number(x: f64) -> String {
    if x.abs() >= 10.0 {
        format!("{x:.1}")
    } else {
        format!("{x:.3}")
    }
}

/// `k` and `n` of a measure that is one rate.
fn single_rate(m: &Measure) -> Option<(u64, u64)> {
    match &m.basis {
        Basis::Counts(terms) if terms.len() == 1 && terms[0].coef == 1.0 => {
            Some((terms[0].k, terms[0].n))
        }
        _ => None,
    }
}

/// The value of a measure as the report shows it: a rate as a percentage with its counts,
/// anything else as a number; its interval; what it rests on.
pub fn show(m: &Measure) -> String {
    show_as(m, false)
}

/// [`show`], a mean of fractions (`percent`) in percent like the paper's overgrasp.
fn show_as(m: &Measure, percent: bool) -> String {
    if matches!(m.basis, Basis::Counts(_)) && single_rate(m).is_none() {
        // a difference of rates, in percentage points
        return points(m.value, m.interval);
    }
    if let Some((k, n)) = single_rate(m) {
        let pct = |x: f64| format!("{:.0}", 100.0 * x);
        let mut s = format!("{} %", pct(m.value));
        if let Some((lo, hi)) = m.interval {
            s += &format!(" [{}, {}]", pct(lo), pct(hi));
        }
        return s + &format!(" ({k}/{n})");
    }
    let mut s = if percent {
        let pct = |x: f64| format!("{:.0}", 100.0 * x);
        let mut s = format!("{} %", pct(m.value));
        if let Some((lo, hi)) = m.interval {
            s += &format!(" [{}, {}]", pct(lo), pct(hi));
        }
        s
    } else {
        let mut s = number(m.value);
        if let Some((lo, hi)) = m.interval {
            s += &format!(" [{}, {}]", like(m.value, lo), like(m.value, hi));
        }
        s
    };
    // a mean over trials says over how many; a mean over replicates has its own column
    if let (Basis::Samples(_), Some(n)) = (&m.basis, m.n) {
        s += &format!(" (n={n})");
    }
    s
}

/// `x` with as many decimals as `number` gives `value`.
fn like(value: f64, x: f64) -> String {
    if value.abs() >= 10.0 {
        format!("{x:.1}")
    } else {
        format!("{x:.3}")
    }
}

/// A difference of rates in percentage points, with its interval.
fn points(value: f64, interval: Option<(f64, f64)>) -> String {
    let pp = |x: f64| format!("{:+.0}", 100.0 * x);
    let mut s = format!("{} pp", pp(value));
    if let Some((lo, hi)) = interval {
        s += &format!(" [{}, {}]", pp(lo), pp(hi));
    }
    s
}

/// Our side of a row, in the rule's terms: the values it compares and, for a comparison,
/// the difference with its interval.
pub fn ours(j: &Judged) -> String {
    let value = |k: &str| {
        j.ours
            .get(k)
            .and_then(|m| m.as_ref())
            .map_or("not measured".to_string(), |m| show_as(m, in_percent(k)))
    };
    let metrics = j.finding.rule.metrics();
    let labelled = metrics.len() > 1;
    let mut s = metrics
        .iter()
        .map(|k| {
            if labelled {
                format!("{} {}", label(k), value(k))
            } else {
                value(k)
            }
        })
        .collect::<Vec<_>>()
        .join(", ");
    if let [c] = j.comparisons.as_slice() {
        let rates = [&c.metric, &c.than].iter().all(|k| {
            j.ours
                .get(k.as_str())
                .and_then(|m| m.as_ref())
                .is_some_and(|m| matches!(m.basis, Basis::Counts(_)))
        });
        if rates {
            s += &format!("; difference {}", points(c.difference, c.interval));
        } else if in_percent(&c.metric) {
            let pp = |x: f64| format!("{:+.0}", 100.0 * x);
            s += &format!("; difference {} pp", pp(c.difference));
            if let Some((lo, hi)) = c.interval {
                s += &format!(" [{}, {}]", pp(lo), pp(hi));
            }
        } else {
            s += &format!("; difference {}", number(c.difference));
            if let Some((lo, hi)) = c.interval {
                s += &format!(" [{}, {}]", like(c.difference, lo), like(c.difference, hi));
            }
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::reproduce::evidence::Count;

    #[test]
    fn values_read_in_the_papers_units() {
        assert_eq!(show(&Measure::proportion(37, 50)), "74 % [60, 84] (37/50)");
        let drop = Measure::counts(vec![Count::new(1.0, 36, 40), Count::new(-1.0, 31, 40)]);
        assert!(show(&drop).starts_with("+12 pp ["), "{}", show(&drop));
        let f1 = Measure::of_replicates(vec![0.88, 0.87, 0.89], Some((0.0, 1.0)));
        assert!(show(&f1).starts_with("0.880 [0.8"), "{}", show(&f1));
        assert_eq!(show(&Measure::exact(15.0)), "15.0");
        // an interval reads with its value's decimals
        let d = Measure::mean_of("d", vec![9.5, 11.0, 12.5, 10.0, 13.0]).unwrap();
        assert!(
            show(&d).starts_with("11.2 [") && show(&d).ends_with("(n=5)"),
            "{}",
            show(&d)
        );
        assert!(!show(&d).contains(".000"), "{}", show(&d));
        // overgrasp in percent, as the paper prints it
        let o = Measure::mean_of("o", vec![0.5, 0.6, 0.7]).unwrap();
        assert!(
            show_as(&o, true).starts_with("60 % ["),
            "{}",
            show_as(&o, true)
        );
    }

    #[test]
    fn every_value_of_a_row_of_several_is_labelled() {
        let labels = |metrics: &[&str]| metrics.iter().map(|m| label(m)).collect::<Vec<_>>();
        assert_eq!(
            labels(&[
                "rail.offline.best_f1.svm_rbf",
                "rail.offline.best_f1.logreg",
                "rail.offline.best_f1.threshold"
            ]),
            ["SVM", "LogReg", "threshold"]
        );
        assert_eq!(
            labels(&["rail.online.fp.1fr", "rail.online.fp.2fr"]),
            ["FP 1 frame", "FP 2 frames"]
        );
        assert_eq!(
            labels(&["objects.fn.2Fr2Sen", "objects.fp.2Fr2Sen"]),
            ["FN 2Fr2Sen", "FP 2Fr2Sen"]
        );
        assert_eq!(
            labels(&["hand.online.d.1Fr2Sen", "hand.online.d.2Fr3Sen"]),
            ["1Fr2Sen", "2Fr3Sen"]
        );
        // every metric of every multi-metric row has a label of its own within its row
        for f in super::super::findings::paper() {
            let metrics = f.rule.metrics();
            if metrics.len() > 1 {
                let mut l = labels(&metrics);
                l.sort();
                l.dedup();
                assert_eq!(l.len(), metrics.len(), "{}: {l:?}", f.id);
            }
        }
    }
}
