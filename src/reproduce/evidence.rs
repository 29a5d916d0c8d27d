//! How sure we are of a measured value, and of the difference between two: the statistics
//! a verdict rests on. Each [`Measure`] keeps what it was computed from (its [`Basis`]), so
//! that a difference gets the interval its data call for:
//!
//! - **counts of trials** (rates, and sums or differences of rates): each rate has its
//!   Wilson score interval, and a linear combination of independent rates combines them by
//!   MOVER (Zou & Donner 2008). For a difference of two rates that is Newcombe's hybrid
//!   score interval (Newcombe 1998, method 10), which stays inside [-1, 1] and behaves at
//!   0 and 100 %, where the normal approximation does not;
//! - **per-trial values** (slip distances, responses): the mean, with a percentile
//!   bootstrap over trials; a difference of two means resamples each side's trials
//!   independently (the two sides are always different trials);
//! - **one value per replicate** (offline scores, which a replicate computes once): the
//!   mean, with Student's t interval on the replicates' spread; a difference is taken within
//!   each replicate first (paired), since both sides come from the same replicate's data;
//! - anything else that has an interval (a rank correlation's Fisher interval): MOVER on
//!   the two intervals, the other side counted as exact where it has none.
//!
//! Every interval is two-sided 95 %, and is cut to the values the metric can take (a rate
//! cannot leave [0, 1]; the best n_slip cannot leave the grid): the cut set still holds the
//! true value whenever the uncut one does.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::report::stats::{wilson, Z95};

/// Bootstrap resamples for means and differences of means: at 10,000 the Monte Carlo
/// error of a 2.5 % percentile is about a tenth of the interval's own spread.
pub const BOOTSTRAP_RESAMPLES: usize = 10_000;

/// A bootstrap seed from a name (a metric's, or a finding's id): each interval gets
/// resamples of its own, so that two samples of one size never share one resample
/// matrix, and the same name gives the same interval in every run. (FNV-1a: stable across
/// builds, unlike std's hasher.)
pub fn seed_of(name: &str) -> u64 {
    name.bytes().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}

/// One rate in a linear combination of rates: `coef * k / n`.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Count {
    pub coef: f64,
    pub k: u64,
    pub n: u64,
}

impl Count {
    pub fn new(coef: f64, k: u64, n: u64) -> Self {
        Self { coef, k, n }
    }
}

/// What a measure was computed from.
#[derive(Debug, Clone, PartialEq, Default)]
pub enum Basis {
    /// A single number with no sampling model of its own (its interval, if any, is given).
    #[default]
    Fixed,
    /// `sum coef_i k_i / n_i` over independent counts of trials.
    Counts(Vec<Count>),
    /// The mean of these per-trial values.
    Samples(Vec<f64>),
    /// The mean of one value per replicate, in replicate order.
    Replicates(Vec<f64>),
}

impl Basis {
    /// The per-trial values of a mean over trials (none for any other basis).
    fn samples(&self) -> &[f64] {
        match self {
            Basis::Samples(v) => v,
            _ => &[],
        }
    }
}

/// One of our measurements: a value, with its 95 % interval when there is one.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Measure {
    pub value: f64,
    pub interval: Option<(f64, f64)>,
    /// Trials (or rows) behind it.
    pub n: Option<u64>,
    /// For a rate: which trials it counts (a name for the set) and, trial by trial, whether
    /// each was counted. Two rates of the same trials are not independent: their
    /// difference takes the paired interval.
    #[serde(skip)]
    pub trials: Option<(String, Vec<bool>)>,
    /// Replicates it pools or averages (1 for a single run).
    #[serde(default = "one")]
    pub replicates: u32,
    #[serde(skip)]
    pub basis: Basis,
    /// The values the metric can take, when bounded.
    #[serde(skip)]
    pub domain: Option<(f64, f64)>,
}

/// Every measured metric of a reproduction, by its key.
pub type Measures = std::collections::BTreeMap<String, Measure>;

fn one() -> u32 {
    1
}

impl Measure {
    /// A value with no interval.
    pub fn exact(value: f64) -> Self {
        Self {
            value,
            interval: None,
            n: None,
            trials: None,
            replicates: 1,
            basis: Basis::Fixed,
            domain: None,
        }
    }

    /// A value with a given interval and no sampling model of its own.
    pub fn with_interval(value: f64, interval: (f64, f64)) -> Self {
        Self {
            interval: Some(interval),
            ..Self::exact(value)
        }
    }

    /// `k` of `n` trials, with its Wilson interval.
    pub fn proportion(k: u64, n: u64) -> Self {
        let mut m = Self::counts(vec![Count { coef: 1.0, k, n }]);
        m.n = Some(n);
        m
    }

    /// A linear combination of independent rates, with its MOVER interval.
    pub fn counts(terms: Vec<Count>) -> Self {
        let (value, interval) = counts_interval(&terms);
        let lo: f64 = terms.iter().map(|t| t.coef.min(0.0)).sum();
        let hi: f64 = terms.iter().map(|t| t.coef.max(0.0)).sum();
        Self {
            value,
            interval: Some(interval),
            n: None,
            trials: None,
            replicates: 1,
            basis: Basis::Counts(terms),
            domain: Some((lo, hi)),
        }
    }

    /// The rate of trials for which `hits` holds, among the trials named `trials`: a
    /// proportion that knows its trials (see [`Measure::trials`]).
    pub fn share_of(trials: &str, hits: Vec<bool>) -> Self {
        let k = hits.iter().filter(|h| **h).count() as u64;
        let mut m = Self::proportion(k, hits.len() as u64);
        m.trials = Some((trials.to_string(), hits));
        m
    }

    /// The mean of per-trial values, with a bootstrap interval seeded by `name`; `None`
    /// for no values.
    pub fn mean_of(name: &str, values: Vec<f64>) -> Option<Self> {
        let mut m = Self::mean_without_interval(values)?;
        m.interval = Some(bootstrap_mean(m.basis.samples(), seed_of(name)));
        Some(m)
    }

    /// The mean of per-trial values with no interval yet (it is drawn where the metric's
    /// name is known, so the resamples are drawn once); `None` for no values.
    pub fn mean_without_interval(values: Vec<f64>) -> Option<Self> {
        if values.is_empty() {
            return None;
        }
        let value = mean(&values);
        Some(Self {
            value,
            interval: None,
            n: Some(values.len() as u64),
            trials: None,
            replicates: 1,
            basis: Basis::Samples(values),
            domain: None,
        })
    }

    /// The mean of one value per replicate, with Student's t interval (none for one value).
    pub fn of_replicates(values: Vec<f64>, domain: Option<(f64, f64)>) -> Self {
        let value = mean(&values);
        let interval = t_interval(&values).map(|iv| clamp(iv, domain));
        Self {
            value,
            interval,
            n: None,
            trials: None,
            replicates: values.len() as u32,
            basis: Basis::Replicates(values),
            domain,
        }
    }

    /// The same value with no interval and no basis: what the rule sees "at the point".
    pub fn point(&self) -> Self {
        Self {
            replicates: self.replicates,
            ..Self::exact(self.value)
        }
    }

    pub fn in_domain(mut self, domain: (f64, f64)) -> Self {
        self.domain = Some(domain);
        self.interval = self.interval.map(|iv| clamp(iv, Some(domain)));
        self
    }
}

fn clamp((lo, hi): (f64, f64), domain: Option<(f64, f64)>) -> (f64, f64) {
    match domain {
        Some((a, b)) => (lo.max(a).min(b), hi.min(b).max(a)),
        None => (lo, hi),
    }
}

fn mean(values: &[f64]) -> f64 {
    values.iter().sum::<f64>() / values.len() as f64
}

/// The value of `sum coef_i k_i / n_i` and its MOVER interval from each rate's Wilson
/// interval (Zou & Donner 2008): each term pushes the lower bound down by its distance to
/// the bound on the side that lowers the sum, and likewise for the upper bound.
pub fn counts_interval(terms: &[Count]) -> (f64, (f64, f64)) {
    let (mut value, mut down, mut up) = (0.0, 0.0, 0.0);
    for t in terms {
        let p = if t.n == 0 {
            0.0
        } else {
            t.k as f64 / t.n as f64
        };
        let (l, u) = wilson(t.k, t.n, Z95);
        let (a, b) = (t.coef * l, t.coef * u);
        let (low, high) = (a.min(b), a.max(b));
        let v = t.coef * p;
        value += v;
        down += (v - low).powi(2);
        up += (high - v).powi(2);
    }
    (value, (value - down.sqrt(), value + up.sqrt()))
}

/// Student's t quantile for a two-sided 95 % interval with `df` degrees of freedom.
pub fn t95(df: usize) -> f64 {
    const TABLE: [f64; 30] = [
        12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160,
        2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056,
        2.052, 2.048, 2.045, 2.042,
    ];
    match df {
        0 => f64::INFINITY,
        1..=30 => TABLE[df - 1],
        // Cornish-Fisher's first correction to the normal quantile: within 0.001 beyond 30
        _ => Z95 + (Z95.powi(3) + Z95) / (4.0 * df as f64),
    }
}

/// Mean +- t * sd / sqrt(k) of `values`; `None` for fewer than two.
pub fn t_interval(values: &[f64]) -> Option<(f64, f64)> {
    let (m, sd) = crate::report::stats::mean_sd(values)?;
    if values.len() < 2 {
        return None;
    }
    let half = t95(values.len() - 1) * sd / (values.len() as f64).sqrt();
    Some((m - half, m + half))
}

fn percentile_interval(mut resampled: Vec<f64>) -> (f64, f64) {
    resampled.sort_by(f64::total_cmp);
    let n = resampled.len();
    let at = |q: f64| resampled[((q * n as f64) as usize).min(n - 1)];
    (at(0.025), at(0.975))
}

fn resampled_mean(values: &[f64], rng: &mut ChaCha8Rng) -> f64 {
    (0..values.len())
        .map(|_| values[rng.gen_range(0..values.len())])
        .sum::<f64>()
        / values.len() as f64
}

/// Percentile bootstrap interval of the mean (seeded, so a report is reproducible).
pub fn bootstrap_mean(values: &[f64], seed: u64) -> (f64, f64) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    percentile_interval(
        (0..BOOTSTRAP_RESAMPLES)
            .map(|_| resampled_mean(values, &mut rng))
            .collect(),
    )
}

/// Percentile bootstrap interval of `mean(a) - mean(b)`, each side resampled on its own.
pub fn bootstrap_difference(a: &[f64], b: &[f64], seed: u64) -> (f64, f64) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    percentile_interval(
        (0..BOOTSTRAP_RESAMPLES)
            .map(|_| resampled_mean(a, &mut rng) - resampled_mean(b, &mut rng))
            .collect(),
    )
}

/// The difference of two rates counted on the same trials, `p1 - p2`, with Newcombe's
/// interval for paired proportions (Newcombe 1998b, method 10: each rate's Wilson interval
/// combined by MOVER with the correlation `phi` of the two indicators over the trials).
/// Two outcomes of one trial (a miss and a false alarm) are not independent: where they
/// exclude each other `phi` is negative and the interval wider than for independent rates
/// (the multinomial variance `(p1 + p2 - (p1 - p2)^2) / n`).
pub fn paired_rates_interval(x: &[bool], y: &[bool]) -> (f64, (f64, f64)) {
    let n = x.len() as u64;
    let count = |f: &dyn Fn(bool, bool) -> bool| {
        x.iter().zip(y).filter(|(a, b)| f(**a, **b)).count() as f64
    };
    let (both, only_x, only_y, neither) = (
        count(&|a, b| a && b),
        count(&|a, b| a && !b),
        count(&|a, b| !a && b),
        count(&|a, b| !a && !b),
    );
    let (k1, k2) = (both + only_x, both + only_y);
    let nf = n as f64;
    let (p1, p2) = (k1 / nf, k2 / nf);
    let (l1, u1) = wilson(k1 as u64, n, Z95);
    let (l2, u2) = wilson(k2 as u64, n, Z95);
    let denominator = (k1 * (nf - k1) * k2 * (nf - k2)).sqrt();
    let phi = if denominator > 0.0 {
        (both * neither - only_x * only_y) / denominator
    } else {
        0.0
    };
    let d = p1 - p2;
    let down = (p1 - l1).powi(2) - 2.0 * phi * (p1 - l1) * (u2 - p2) + (u2 - p2).powi(2);
    let up = (u1 - p1).powi(2) - 2.0 * phi * (u1 - p1) * (p2 - l2) + (p2 - l2).powi(2);
    (
        d,
        (
            (d - down.max(0.0).sqrt()).max(-1.0),
            (d + up.max(0.0).sqrt()).min(1.0),
        ),
    )
}

/// `a - b` and its 95 % interval, if the two measures have enough to give one; a
/// bootstrap draws its resamples from `seed`.
pub fn difference(a: &Measure, b: &Measure, seed: u64) -> (f64, Option<(f64, f64)>) {
    let d = a.value - b.value;
    if let (Some((ta, x)), Some((tb, y))) = (&a.trials, &b.trials) {
        if ta == tb && x.len() == y.len() && !x.is_empty() {
            return (d, Some(paired_rates_interval(x, y).1));
        }
    }
    let interval = match (&a.basis, &b.basis) {
        (Basis::Counts(x), Basis::Counts(y)) => {
            let terms: Vec<Count> = x
                .iter()
                .copied()
                .chain(y.iter().map(|t| Count {
                    coef: -t.coef,
                    ..*t
                }))
                .collect();
            Some(counts_interval(&terms).1)
        }
        (Basis::Samples(x), Basis::Samples(y)) => Some(bootstrap_difference(x, y, seed)),
        (Basis::Replicates(x), Basis::Replicates(y)) if x.len() == y.len() => {
            let paired: Vec<f64> = x.iter().zip(y).map(|(p, q)| p - q).collect();
            t_interval(&paired)
        }
        _ => match (a.interval, b.interval) {
            (None, None) => None,
            (ia, ib) => {
                let (la, ua) = ia.unwrap_or((a.value, a.value));
                let (lb, ub) = ib.unwrap_or((b.value, b.value));
                Some((
                    d - ((a.value - la).powi(2) + (ub - b.value).powi(2)).sqrt(),
                    d + ((ua - a.value).powi(2) + (b.value - lb).powi(2)).sqrt(),
                ))
            }
        },
    };
    (d, interval)
}

/// Pools per-replicate measures into one per metric. Metrics measured on trials
/// (`from_trials`, measured once on every replicate's trials together) are taken from
/// there, their counts and samples already pooled; every other metric is the mean over the
/// replicates that have it, with the replicates' spread in its interval.
pub fn pool(per_replicate: &[Measures], from_trials: &Measures) -> Measures {
    let mut names: std::collections::BTreeSet<&String> = from_trials.keys().collect();
    for m in per_replicate {
        names.extend(m.keys());
    }
    let mut out = Measures::new();
    for name in names {
        let have: Vec<&Measure> = per_replicate
            .iter()
            .filter_map(|m| m.get(name))
            .filter(|m| m.value.is_finite())
            .collect();
        let pooled = if let Some(m) = from_trials.get(name) {
            Measure {
                replicates: (have.len() as u32).max(1),
                ..m.clone()
            }
        } else {
            match have.as_slice() {
                [] => continue,
                [only] => (*only).clone(),
                many => {
                    Measure::of_replicates(many.iter().map(|m| m.value).collect(), many[0].domain)
                }
            }
        };
        out.insert(name.clone(), pooled);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() < tol
    }

    #[test]
    fn a_difference_of_two_rates_is_newcombes_hybrid_score_interval() {
        // Newcombe (1998), Table II, example (a): 56/70 - 48/80 = 0.2000, method 10:
        // 0.0524 to 0.3339
        let a = Measure::proportion(56, 70);
        let b = Measure::proportion(48, 80);
        let (d, iv) = difference(&a, &b, 0);
        let (lo, hi) = iv.unwrap();
        assert!(close(d, 0.2, 1e-12));
        assert!(
            close(lo, 0.0524, 1e-4) && close(hi, 0.3339, 1e-4),
            "{lo} {hi}"
        );
        // example (h): 0/10 - 0/20: -0.1611 to 0.2775
        let (_, iv) = difference(&Measure::proportion(0, 10), &Measure::proportion(0, 20), 0);
        let (lo, hi) = iv.unwrap();
        assert!(
            close(lo, -0.1611, 1e-4) && close(hi, 0.2775, 1e-4),
            "{lo} {hi}"
        );
    }

    #[test]
    fn two_rates_of_the_same_trials_take_the_paired_interval() {
        // 120 trials: 29 missed (FN), 3 false alarms, none both (exclusive verdicts)
        let fnr: Vec<bool> = (0..120).map(|i| i < 29).collect();
        let fpr: Vec<bool> = (0..120).map(|i| (29..32).contains(&i)).collect();
        let paired = (
            Measure::share_of("objects.2Fr2Sen", fnr.clone()),
            Measure::share_of("objects.2Fr2Sen", fpr.clone()),
        );
        let (d, iv) = difference(&paired.0, &paired.1, 0);
        let (lo, hi) = iv.unwrap();
        let (_, independent) = difference(
            &Measure::proportion(29, 120),
            &Measure::proportion(3, 120),
            0,
        );
        let (ilo, ihi) = independent.unwrap();
        assert!(close(d, 26.0 / 120.0, 1e-12));
        // exclusive outcomes are negatively correlated: wider than the independent interval
        assert!(lo < ilo && hi > ihi, "{lo} {hi} / {ilo} {ihi}");
        // and close to the Wald interval on the multinomial variance (n large enough here)
        let (p1, p2): (f64, f64) = (29.0 / 120.0, 3.0 / 120.0);
        let sd = ((p1 + p2 - (p1 - p2) * (p1 - p2)) / 120.0).sqrt();
        assert!(
            close(hi - lo, 2.0 * Z95 * sd, 0.02),
            "{} {}",
            hi - lo,
            2.0 * Z95 * sd
        );
        // uncorrelated indicators: the independent (Newcombe) interval at the same n
        let x: Vec<bool> = (0..100).map(|i| i % 2 == 0).collect();
        let y: Vec<bool> = (0..100).map(|i| i % 4 < 2).collect();
        let (_, (plo, phi)) = paired_rates_interval(&x, &y);
        let (_, iv) = difference(
            &Measure::proportion(50, 100),
            &Measure::proportion(50, 100),
            0,
        );
        let (nlo, nhi) = iv.unwrap();
        assert!(close(plo, nlo, 1e-12) && close(phi, nhi, 1e-12));
        // rates of other trials are independent, whatever their sizes
        let other = Measure::share_of("objects.1Fr2Sen", fpr);
        assert_eq!(difference(&paired.0, &other, 0).1, independent);
    }

    #[test]
    fn bootstraps_of_equal_size_draw_resamples_of_their_own() {
        let a: Vec<f64> = (0..30).map(|i| (i % 7) as f64).collect();
        let b: Vec<f64> = (0..30).map(|i| (i % 7) as f64 * 2.0).collect();
        // the same seed: b's interval is exactly twice a's (one resample matrix)
        let (alo, ahi) = bootstrap_mean(&a, 0);
        let (blo, bhi) = bootstrap_mean(&b, 0);
        assert!(close(blo, 2.0 * alo, 1e-12) && close(bhi, 2.0 * ahi, 1e-12));
        // seeded by name, they differ; the same name gives the same interval
        let a: Vec<f64> = (0..30).map(|i| (i as f64 * 0.37).sin()).collect();
        let ia = Measure::mean_of("lift.overgrasp.100_300g", a.clone())
            .unwrap()
            .interval;
        let ib = Measure::mean_of("lift.overgrasp.over_300g", a.clone())
            .unwrap()
            .interval;
        assert_ne!(ia, ib);
        assert_eq!(
            ia,
            Measure::mean_of("lift.overgrasp.100_300g", a)
                .unwrap()
                .interval
        );
        assert_ne!(seed_of("a"), seed_of("b"));
    }

    #[test]
    fn one_rate_through_mover_is_its_wilson_interval() {
        let m = Measure::proportion(8, 10);
        let (lo, hi) = m.interval.unwrap();
        assert!(
            close(lo, 0.4902, 1e-4) && close(hi, 0.9433, 1e-4),
            "{lo} {hi}"
        );
        assert_eq!(m.domain, Some((0.0, 1.0)));
    }

    #[test]
    fn a_difference_of_differences_widens_with_every_term() {
        let one = Measure::counts(vec![Count::new(1.0, 36, 40), Count::new(-1.0, 31, 40)]);
        let other = Measure::counts(vec![Count::new(1.0, 38, 40), Count::new(-1.0, 37, 40)]);
        let (d, iv) = difference(&one, &other, 0);
        let (lo, hi) = iv.unwrap();
        let (olo, ohi) = one.interval.unwrap();
        assert!(close(d, 0.1, 1e-12));
        // wider than the one difference alone, and (as in the paper at n = 40) around zero
        assert!(hi - lo > ohi - olo, "{lo} {hi} / {olo} {ohi}");
        assert!(lo < 0.0 && hi > 0.1, "{lo} {hi}");
    }

    #[test]
    fn t_quantiles_and_replicate_intervals() {
        assert_eq!(t95(4), 2.776);
        assert!(close(t95(1000), 1.962, 1e-3));
        assert!(t95(31) < t95(30) && t95(31) > Z95);
        // 1, 2, 3: mean 2, sd 1, t(2) 4.303: 2 +- 2.484
        let (lo, hi) = t_interval(&[1.0, 2.0, 3.0]).unwrap();
        assert!(close(lo, 2.0 - 4.303 / 3f64.sqrt(), 1e-9) && close(hi, 2.0 + 2.4843, 1e-3));
        assert_eq!(t_interval(&[5.0]), None);
        // cut to the metric's domain
        let m = Measure::of_replicates(vec![13.0, 15.0, 14.0, 12.0, 15.0], Some((1.0, 15.0)));
        assert_eq!(m.interval.unwrap().1, 15.0);
        assert!(m.interval.unwrap().0 > 12.0);
    }

    #[test]
    fn replicate_differences_are_paired() {
        // a is always 0.01 above b while both swing by 0.1 between replicates: the paired
        // interval is narrow, an unpaired one would straddle zero
        let a = Measure::of_replicates(vec![0.91, 0.81, 0.95, 0.85], None);
        let b = Measure::of_replicates(vec![0.90, 0.80, 0.94, 0.84], None);
        let (d, iv) = difference(&a, &b, 0);
        let (lo, hi) = iv.unwrap();
        assert!(close(d, 0.01, 1e-9));
        assert!(lo > 0.0099 && hi < 0.0101, "{lo} {hi}");
    }

    #[test]
    fn a_difference_of_means_is_bootstrapped_over_each_sides_trials() {
        let a: Vec<f64> = (0..40).map(|i| 20.0 + (i % 7) as f64).collect();
        let b: Vec<f64> = (0..40).map(|i| 10.0 + (i % 5) as f64).collect();
        let (d, iv) = difference(
            &Measure::mean_of("a", a.clone()).unwrap(),
            &Measure::mean_of("b", b).unwrap(),
            0,
        );
        let (lo, hi) = iv.unwrap();
        assert!(lo < d && d < hi && lo > 8.0 && hi < 13.0, "{d} {lo} {hi}");
        // the same values on both sides: an interval about zero
        let same = Measure::mean_of("a", a).unwrap();
        let (_, iv) = difference(&same, &same, 0);
        let (lo, hi) = iv.unwrap();
        assert!(lo < 0.0 && hi > 0.0);
    }

    #[test]
    fn mixed_bases_combine_their_intervals() {
        let a = Measure::with_interval(0.7, (0.6, 0.8));
        let b = Measure::exact(0.5);
        let (d, iv) = difference(&a, &b, 0);
        let (lo, hi) = iv.unwrap();
        assert!(close(d, 0.2, 1e-12) && close(lo, 0.1, 1e-12) && close(hi, 0.3, 1e-12));
        assert_eq!(difference(&b, &Measure::exact(0.1), 0).1, None);
    }

    #[test]
    fn pooling_takes_trial_metrics_whole_and_averages_the_rest() {
        let rep = |f1: f64| {
            let mut m = super::Measures::new();
            m.insert("f1".into(), Measure::exact(f1).in_domain((0.0, 1.0)));
            m.insert("rate".into(), Measure::proportion(1, 10));
            m
        };
        let mut trials = super::Measures::new();
        trials.insert("rate".into(), Measure::proportion(5, 30));
        let pooled = pool(&[rep(0.8), rep(0.9), rep(0.85)], &trials);
        assert_eq!(pooled["rate"].n, Some(30));
        assert_eq!(pooled["rate"].replicates, 3);
        let f1 = &pooled["f1"];
        assert!(close(f1.value, 0.85, 1e-12));
        assert_eq!(f1.replicates, 3);
        assert!(matches!(f1.basis, Basis::Replicates(ref v) if v.len() == 3));
        let (lo, hi) = f1.interval.unwrap();
        assert!(lo < 0.85 && hi > 0.85 && hi <= 1.0);
        // one replicate: its own measure, unchanged
        let single = pool(&[rep(0.8)], &super::Measures::new());
        assert_eq!(single["f1"].interval, None);
    }
}
