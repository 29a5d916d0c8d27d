//! What a hyperparameter search explores: log-uniform ranges of C and gamma, given on the
//! command line as `LOW:HIGH`, and whether a search's best lies at an end of its range.

use super::bayes::LogRange;
use super::classifier::ClassifierKind;

/// Default search ranges, as scikit-optimize searches would commonly set them for the
/// paper's models.
pub const C_RANGE: LogRange = LogRange {
    name: "C",
    low: 1e-2,
    high: 1e3,
};
pub const GAMMA_RANGE: LogRange = LogRange {
    name: "gamma",
    low: 1e-4,
    high: 10.0,
};

/// The ranges a search explores (log-uniform), `[low, high]` each.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SearchRanges {
    pub c: [f64; 2],
    pub gamma: [f64; 2],
}

impl Default for SearchRanges {
    fn default() -> Self {
        Self {
            c: [C_RANGE.low, C_RANGE.high],
            gamma: [GAMMA_RANGE.low, GAMMA_RANGE.high],
        }
    }
}

impl SearchRanges {
    /// The ranges searched for `kind`, in the order of the search's parameters.
    pub(super) fn for_kind(&self, kind: ClassifierKind) -> Vec<LogRange> {
        let c = LogRange {
            low: self.c[0],
            high: self.c[1],
            ..C_RANGE
        };
        let gamma = LogRange {
            low: self.gamma[0],
            high: self.gamma[1],
            ..GAMMA_RANGE
        };
        match kind {
            ClassifierKind::SvmRbf => vec![c, gamma],
            ClassifierKind::SvmLinear | ClassifierKind::Logreg => vec![c],
            ClassifierKind::Threshold => vec![],
        }
    }

    /// The searched parameters of a sweep cell's classifier that lie at an end of their
    /// ranges, as `(name, value, end)`.
    pub fn ends_reached(
        &self,
        kind: ClassifierKind,
        c: f64,
        gamma: f64,
    ) -> Vec<(&'static str, f64, &'static str)> {
        let mut out = Vec::new();
        if kind == ClassifierKind::Threshold {
            return out;
        }
        if let Some(end) = at_range_end(c, self.c) {
            out.push(("C", c, end));
        }
        if kind == ClassifierKind::SvmRbf {
            if let Some(end) = at_range_end(gamma, self.gamma) {
                out.push(("gamma", gamma, end));
            }
        }
        out
    }
}

/// Whether a searched `value` lies at an end of its log-uniform range `[low, high]` (within
/// 2 % of the range's log width): `Some("lower" | "upper")`. The optimum may lie beyond.
pub fn at_range_end(value: f64, [low, high]: [f64; 2]) -> Option<&'static str> {
    let width = (high / low).ln();
    let near = |end: f64| (value / end).ln().abs() <= 0.02 * width;
    if near(low) {
        Some("lower")
    } else if near(high) {
        Some("upper")
    } else {
        None
    }
}

/// Parses `--search-rows`: a fit of fewer than 50 rows says nothing about C or gamma.
pub fn parse_search_rows(text: &str) -> Result<usize, String> {
    match text.trim().parse::<usize>() {
        Ok(n) if n >= 50 => Ok(n),
        _ => Err(format!(
            "expected a number of rows, at least 50, got {text:?}"
        )),
    }
}

/// Parses a search range `LOW:HIGH` (both positive, finite, `LOW < HIGH`).
pub fn parse_range(text: &str) -> Result<[f64; 2], String> {
    let expected = || {
        format!(
            "expected LOW:HIGH with {} <= LOW < HIGH <= {} (e.g. 0.01:1000), got {text:?}",
            SEARCHABLE[0], SEARCHABLE[1]
        )
    };
    let (low, high) = text.split_once(':').ok_or_else(expected)?;
    let parse = |v: &str| v.trim().parse::<f64>().map_err(|_| expected());
    let (low, high) = (parse(low)?, parse(high)?);
    if !(searchable(low) && searchable(high) && high > low) {
        return Err(expected());
    }
    Ok([low, high])
}

/// The values a search may try for C or gamma. Beyond them an SVM fit does not end in
/// useful time (a grid point of C 1e308 ran past two minutes) or its kernel underflows; no
/// scale of features puts a useful value there.
pub const SEARCHABLE: [f64; 2] = [1e-6, 1e6];

/// Whether `v` is a value a search may try (finite, within [`SEARCHABLE`]).
pub fn searchable(v: f64) -> bool {
    v.is_finite() && (SEARCHABLE[0]..=SEARCHABLE[1]).contains(&v)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_parse_and_bad_ones_say_what_was_expected() {
        assert_eq!(parse_range("0.01:1000"), Ok([0.01, 1000.0]));
        assert_eq!(parse_range(" 1e-3 : 2 "), Ok([1e-3, 2.0]));
        for bad in [
            "1:1", "2:1", "0:1", "-1:1", "1", "a:b", "1:inf", "nan:1", "1:1e308", "1e-9:1",
        ] {
            let e = parse_range(bad).unwrap_err();
            assert!(e.contains("LOW:HIGH") && e.contains(bad), "{bad}: {e}");
        }
    }

    #[test]
    fn a_sweep_cell_whose_best_lies_on_a_range_end_is_found() {
        let r = SearchRanges::default();
        assert_eq!(at_range_end(0.0105, r.c), Some("lower"));
        assert_eq!(at_range_end(990.0, r.c), Some("upper"));
        assert_eq!(at_range_end(3.0, r.c), None);
        assert_eq!(
            r.ends_reached(ClassifierKind::SvmRbf, 3.0, 9.9),
            vec![("gamma", 9.9, "upper")]
        );
        // logreg has no gamma to search; the threshold nothing
        assert!(r.ends_reached(ClassifierKind::Logreg, 3.0, 9.9).is_empty());
        assert!(r
            .ends_reached(ClassifierKind::Threshold, 0.01, 0.0)
            .is_empty());
    }
}
