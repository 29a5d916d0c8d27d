//! Bayesian optimisation of a black-box score over a box in log space: a Gaussian-process
//! surrogate and the expected-improvement acquisition, seeded and deterministic.
//!
//! Written in the project rather than taken from egobox-ego (the maintained crate): egobox
//! brings some 30 direct dependencies (linfa, ndarray-linalg, clap, ctrlc, env_logger, ...)
//! for what is here a few dozen points in one or two dimensions, where an exact GP with a
//! Cholesky factorisation costs microseconds.
//!
//! - Inputs are mapped to the unit cube (log10 of each parameter between its bounds).
//! - Kernel: Matern 5/2 with one length scale, observations standardised; the length scale
//!   and noise are picked each step by maximum marginal likelihood over a small grid.
//! - Acquisition: expected improvement (xi = 0.01), maximised over 2,000 random points plus
//!   local perturbations of the best ones.
//! - The first `initial_points` evaluations are random (seeded), as scikit-optimize does.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::cholesky;

/// One searched parameter: a positive value between `low` and `high`, searched in log space.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LogRange {
    pub name: &'static str,
    pub low: f64,
    pub high: f64,
}

#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Evaluation {
    pub params: Vec<f64>,
    pub score: f64,
}

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SearchError {
    #[error("search range of {name}: expected 0 < low < high, got {low}..{high}")]
    BadRange {
        name: &'static str,
        low: f64,
        high: f64,
    },
    #[error("at least one evaluation is needed")]
    NoIterations,
}

/// A maximiser of `objective` over `ranges`.
pub struct BayesSearch {
    pub ranges: Vec<LogRange>,
    pub iterations: usize,
    pub initial_points: usize,
    pub seed: u64,
}

fn to_unit(r: &LogRange, v: f64) -> f64 {
    (v.log10() - r.low.log10()) / (r.high.log10() - r.low.log10())
}

fn from_unit(r: &LogRange, u: f64) -> f64 {
    10f64.powf(r.low.log10() + u.clamp(0.0, 1.0) * (r.high.log10() - r.low.log10()))
}

fn matern52(d: f64, length: f64) -> f64 {
    let s = 5f64.sqrt() * d / length;
    (1.0 + s + s * s / 3.0) * (-s).exp()
}

fn dist(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f64>()
        .sqrt()
}

/// A fitted Gaussian process on standardised observations.
struct Gp {
    x: Vec<Vec<f64>>,
    chol: Vec<f64>,
    alpha: Vec<f64>,
    length: f64,
    mean: f64,
    std: f64,
}

impl Gp {
    fn fit(x: &[Vec<f64>], y: &[f64]) -> Gp {
        let n = x.len();
        let mean = y.iter().sum::<f64>() / n as f64;
        let std = (y.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / n as f64)
            .sqrt()
            .max(1e-9);
        let ys: Vec<f64> = y.iter().map(|v| (v - mean) / std).collect();
        let mut best: Option<(f64, Gp)> = None;
        for &length in &[0.05, 0.1, 0.2, 0.35, 0.6, 1.0] {
            for &noise in &[1e-6, 1e-4, 1e-2, 1e-1] {
                let mut k = vec![0.0; n * n];
                for i in 0..n {
                    for j in 0..n {
                        k[i * n + j] =
                            matern52(dist(&x[i], &x[j]), length) + if i == j { noise } else { 0.0 };
                    }
                }
                if !cholesky::factor(&mut k, n) {
                    continue;
                }
                let mut alpha = ys.clone();
                cholesky::solve_lower(&k, n, &mut alpha);
                let fit_term: f64 = alpha.iter().map(|a| a * a).sum();
                let log_det: f64 = (0..n).map(|i| k[i * n + i].ln()).sum::<f64>() * 2.0;
                let log_likelihood = -0.5 * fit_term - 0.5 * log_det;
                cholesky::solve_upper_t(&k, n, &mut alpha);
                if best.as_ref().is_none_or(|(b, _)| log_likelihood > *b) {
                    best = Some((
                        log_likelihood,
                        Gp {
                            x: x.to_vec(),
                            chol: k,
                            alpha,
                            length,
                            mean,
                            std,
                        },
                    ));
                }
            }
        }
        best.expect("a noise of 0.1 keeps the matrix positive definite")
            .1
    }

    /// Posterior mean and standard deviation, in the observations' units.
    fn predict(&self, p: &[f64]) -> (f64, f64) {
        let n = self.x.len();
        let kv: Vec<f64> = self
            .x
            .iter()
            .map(|xi| matern52(dist(xi, p), self.length))
            .collect();
        let mu: f64 = kv.iter().zip(&self.alpha).map(|(a, b)| a * b).sum();
        let mut v = kv;
        cholesky::solve_lower(&self.chol, n, &mut v);
        let var = (1.0 - v.iter().map(|a| a * a).sum::<f64>()).max(1e-12);
        (self.mean + self.std * mu, self.std * var.sqrt())
    }
}

fn normal_pdf(z: f64) -> f64 {
    (-0.5 * z * z).exp() / (2.0 * std::f64::consts::PI).sqrt()
}

/// Standard normal CDF (Abramowitz & Stegun 7.1.26 for erf, error < 1.5e-7).
fn normal_cdf(z: f64) -> f64 {
    let x = z / 2f64.sqrt();
    let t = 1.0 / (1.0 + 0.327_591_1 * x.abs());
    let poly = t
        * (0.254_829_592
            + t * (-0.284_496_736
                + t * (1.421_413_741 + t * (-1.453_152_027 + t * 1.061_405_429))));
    let erf = 1.0 - poly * (-x * x).exp();
    0.5 * (1.0 + if x >= 0.0 { erf } else { -erf })
}

/// Expected improvement over `best` of a maximised score.
fn expected_improvement(mu: f64, sigma: f64, best: f64, xi: f64) -> f64 {
    if sigma <= 0.0 {
        return 0.0;
    }
    let z = (mu - best - xi) / sigma;
    (mu - best - xi) * normal_cdf(z) + sigma * normal_pdf(z)
}

impl BayesSearch {
    /// Evaluates `objective` `iterations` times and returns every evaluation, in order.
    pub fn maximise(
        &self,
        mut objective: impl FnMut(&[f64]) -> f64,
    ) -> Result<Vec<Evaluation>, SearchError> {
        for r in &self.ranges {
            if !(r.low > 0.0 && r.high > r.low) {
                return Err(SearchError::BadRange {
                    name: r.name,
                    low: r.low,
                    high: r.high,
                });
            }
        }
        if self.iterations == 0 {
            return Err(SearchError::NoIterations);
        }
        let dims = self.ranges.len();
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed);
        let mut unit: Vec<Vec<f64>> = Vec::new();
        let mut history = Vec::new();
        for it in 0..self.iterations {
            let next: Vec<f64> = if it < self.initial_points.max(1) || unit.len() < 2 {
                (0..dims).map(|_| rng.gen::<f64>()).collect()
            } else {
                let scores: Vec<f64> = history.iter().map(|e: &Evaluation| e.score).collect();
                let gp = Gp::fit(&unit, &scores);
                let best = scores.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
                let ei = |p: &[f64]| {
                    let (mu, sigma) = gp.predict(p);
                    expected_improvement(mu, sigma, best, 0.01)
                };
                let mut candidates: Vec<(f64, Vec<f64>)> = (0..2000)
                    .map(|_| {
                        let p: Vec<f64> = (0..dims).map(|_| rng.gen::<f64>()).collect();
                        (ei(&p), p)
                    })
                    .collect();
                candidates.sort_by(|a, b| b.0.total_cmp(&a.0));
                let mut best_point = candidates[0].clone();
                for (_, start) in candidates.iter().take(5) {
                    for step in [0.05, 0.02, 0.005] {
                        for _ in 0..20 {
                            let p: Vec<f64> = start
                                .iter()
                                .map(|v| {
                                    (v + step * (rng.gen::<f64>() * 2.0 - 1.0)).clamp(0.0, 1.0)
                                })
                                .collect();
                            let v = ei(&p);
                            if v > best_point.0 {
                                best_point = (v, p);
                            }
                        }
                    }
                }
                best_point.1
            };
            let params: Vec<f64> = self
                .ranges
                .iter()
                .zip(&next)
                .map(|(r, u)| from_unit(r, *u))
                .collect();
            let score = objective(&params);
            unit.push(
                self.ranges
                    .iter()
                    .zip(&params)
                    .map(|(r, v)| to_unit(r, *v))
                    .collect(),
            );
            history.push(Evaluation { params, score });
        }
        Ok(history)
    }
}

/// The best evaluation (the first of equals).
pub fn best(history: &[Evaluation]) -> Option<&Evaluation> {
    history
        .iter()
        .fold(None, |acc: Option<&Evaluation>, e| match acc {
            Some(b) if b.score >= e.score => Some(b),
            _ => Some(e),
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_the_peak_of_a_smooth_function_in_few_evaluations() {
        // peak at C = 10, gamma = 0.1 in log space
        let f = |p: &[f64]| -((p[0].log10() - 1.0).powi(2) + (p[1].log10() + 1.0).powi(2));
        let search = BayesSearch {
            ranges: vec![
                LogRange {
                    name: "C",
                    low: 1e-2,
                    high: 1e3,
                },
                LogRange {
                    name: "gamma",
                    low: 1e-4,
                    high: 10.0,
                },
            ],
            iterations: 25,
            initial_points: 5,
            seed: 1,
        };
        let history = search.maximise(f).unwrap();
        let b = best(&history).unwrap();
        assert!(b.score > -0.05, "best {b:?}");
        // and it beats random search with the same budget
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let random_best = (0..25)
            .map(|_| {
                f(&[
                    from_unit(&search.ranges[0], rng.gen()),
                    from_unit(&search.ranges[1], rng.gen()),
                ])
            })
            .fold(f64::NEG_INFINITY, f64::max);
        assert!(b.score > random_best, "{} vs random {random_best}", b.score);
    }

    #[test]
    fn same_seed_same_search() {
        let f = |p: &[f64]| -(p[0].log10() - 0.5).powi(2);
        let s = BayesSearch {
            ranges: vec![LogRange {
                name: "C",
                low: 0.01,
                high: 100.0,
            }],
            iterations: 12,
            initial_points: 4,
            seed: 9,
        };
        assert_eq!(s.maximise(f).unwrap(), s.maximise(f).unwrap());
    }

    #[test]
    fn gp_interpolates_its_observations() {
        let x = vec![vec![0.1], vec![0.5], vec![0.9]];
        let y = vec![1.0, 3.0, 2.0];
        let gp = Gp::fit(&x, &y);
        for (xi, yi) in x.iter().zip(&y) {
            let (mu, sigma) = gp.predict(xi);
            assert!((mu - yi).abs() < 0.1 && sigma < 0.5, "{mu} {sigma}");
        }
    }

    #[test]
    fn normal_cdf_is_accurate() {
        assert!((normal_cdf(0.0) - 0.5).abs() < 1e-7);
        assert!((normal_cdf(1.96) - 0.975).abs() < 1e-4);
        assert!(expected_improvement(1.0, 0.0, 0.5, 0.0) == 0.0);
    }

    #[test]
    fn bad_range_is_rejected() {
        let s = BayesSearch {
            ranges: vec![LogRange {
                name: "C",
                low: 0.0,
                high: 1.0,
            }],
            iterations: 3,
            initial_points: 1,
            seed: 0,
        };
        assert!(s.maximise(|_| 0.0).is_err());
    }
}
