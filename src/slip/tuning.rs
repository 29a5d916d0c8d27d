//! Hyperparameter search on training data only: Bayesian optimisation of the macro F1 of
//! a cross-validation that splits by trial, so frames of one trial never sit on both sides.

use super::bayes::{best, BayesSearch, Evaluation};
use super::cross_validation::Folds;
pub use super::cross_validation::{FoldAssignment, HeldOutRows, TuneError, TuneSpec};
use super::dataset::Dataset;
use super::metrics::Scores;
use super::model::{ClassifierKind, Hyperparameters, SearchRecord};
pub use super::search_range::{
    at_range_end, parse_range, parse_search_rows, SearchRanges, C_RANGE, GAMMA_RANGE,
};

/// Mean macro F1 over `folds` folds of whole trials: train (static rows down-sampled) on the
/// rest, score the fold (see [`cross_validate`]).
pub fn cross_validated_f1(
    data: &Dataset,
    spec: &TuneSpec,
    hyper: Hyperparameters,
) -> Result<f64, TuneError> {
    Ok(mean_f1(&cross_validate(data, spec, hyper)?))
}

fn mean_f1(folds: &[Scores]) -> f64 {
    folds.iter().map(|s| s.macro_f1).sum::<f64>() / folds.len() as f64
}

/// Each of `folds` folds of whole trials scored (every row, or as `spec.held_out` says) by a
/// model trained (static rows down-sampled) on the rest. A fold whose sensor the training
/// folds never saw (a local model set lacking it) scores as all wrong.
pub fn cross_validate(
    data: &Dataset,
    spec: &TuneSpec,
    hyper: Hyperparameters,
) -> Result<Vec<Scores>, TuneError> {
    Folds::new(data, spec)?.score(spec, hyper)
}

/// Searches C (and gamma for the RBF SVM) by Bayesian optimisation; a fit that fails scores 0.
pub fn search(
    data: &Dataset,
    spec: &TuneSpec,
) -> Result<(Hyperparameters, SearchRecord), TuneError> {
    search_reporting(data, spec, |_, _, _| {})
}

/// [`search`], telling `on_evaluation` of each evaluation as it finishes: how many are done,
/// the point and its cross-validated macro F1.
pub fn search_reporting(
    data: &Dataset,
    spec: &TuneSpec,
    mut on_evaluation: impl FnMut(usize, &Hyperparameters, f64),
) -> Result<(Hyperparameters, SearchRecord), TuneError> {
    if spec.kind == ClassifierKind::Threshold {
        return Err(TuneError::NothingToSearch("threshold"));
    }
    let ranges = spec.ranges.for_kind(spec.kind);
    // Split once, before the search (whose failed evaluations would only score 0): the
    // evaluations share the folds' rows.
    let folds = Folds::new(data, spec)?;
    let to_hyper = |p: &[f64]| Hyperparameters {
        c: p[0],
        gamma: p.get(1).copied().unwrap_or(0.0),
        max_iterations: None,
    };
    let search = BayesSearch {
        ranges: ranges.clone(),
        iterations: spec.iterations,
        initial_points: (spec.iterations / 3).clamp(1, 10),
        seed: spec.seed,
    };
    let mut scorer = Scorer::new(&folds, spec);
    let mut done = 0;
    let history: Vec<Evaluation> = search.maximise(|p| {
        let hyper = to_hyper(p);
        let f1 = scorer.score(hyper);
        done += 1;
        on_evaluation(done, &hyper, f1);
        f1
    })?;
    scorer.refuse_if_every_fit_failed(&history)?;
    let b = best(&history).expect("at least one evaluation");
    let record = search_record(
        "bayes (GP Matern 5/2, expected improvement)".into(),
        spec,
        ranges.iter().map(|r| r.name.to_string()).collect(),
        ranges.iter().map(|r| [r.low, r.high]).collect(),
        &history,
    );
    Ok((to_hyper(&b.params), record))
}

/// Scores points by the folds' mean macro F1; a fit that fails scores 0, and the first
/// failure is kept so that a search whose every fit failed can say why.
struct Scorer<'a> {
    folds: &'a Folds,
    spec: &'a TuneSpec,
    first_error: Option<TuneError>,
}

impl<'a> Scorer<'a> {
    fn new(folds: &'a Folds, spec: &'a TuneSpec) -> Self {
        Self {
            folds,
            spec,
            first_error: None,
        }
    }

    fn score(&mut self, hyper: Hyperparameters) -> f64 {
        match self.folds.score(self.spec, hyper) {
            Ok(scores) => mean_f1(&scores),
            Err(e) => {
                self.first_error.get_or_insert(e);
                0.0
            }
        }
    }

    /// A search where every point scored 0 because its fits failed is an error, not a result.
    fn refuse_if_every_fit_failed(&mut self, history: &[Evaluation]) -> Result<(), TuneError> {
        if history.iter().all(|e| e.score == 0.0) {
            if let Some(e) = self.first_error.take() {
                return Err(e);
            }
        }
        Ok(())
    }
}

/// The record of a finished search, `method` naming how its points were chosen.
fn search_record(
    method: String,
    spec: &TuneSpec,
    parameters: Vec<String>,
    ranges: Vec<[f64; 2]>,
    history: &[Evaluation],
) -> SearchRecord {
    SearchRecord {
        method: format!(
            "{method}{}, {}{}",
            spec.max_fit_rows
                .map_or(String::new(), |cap| format!(", fits on at most {cap} rows")),
            spec.held_out.describe(),
            // named only when not the default, so that existing records read as before
            match spec.assignment {
                FoldAssignment::Shuffled => String::new(),
                other => format!(", {}", other.describe()),
            }
        ),
        folds: spec.folds,
        parameters,
        ranges,
        evaluations: history.to_vec(),
    }
}

/// Every point of a grid of C (and gamma for the RBF SVM) scored by the same
/// cross-validation as [`search`] (folds of whole trials, split once); the best is the
/// first point with the highest mean macro F1, in the grid's order (C outer, gamma inner),
/// as scikit-learn's `GridSearchCV` picks it. A fit that fails scores 0.
pub fn grid_search_reporting(
    data: &Dataset,
    spec: &TuneSpec,
    cs: &[f64],
    gammas: &[f64],
    mut on_evaluation: impl FnMut(usize, &Hyperparameters, f64),
) -> Result<(Hyperparameters, SearchRecord), TuneError> {
    if spec.kind == ClassifierKind::Threshold {
        return Err(TuneError::NothingToSearch("threshold"));
    }
    let uses_gamma = spec.kind.uses_gamma();
    let gammas: &[f64] = if uses_gamma { gammas } else { &[0.0] };
    if cs.is_empty() || gammas.is_empty() {
        return Err(TuneError::EmptyGrid);
    }
    let folds = Folds::new(data, spec)?;
    let mut scorer = Scorer::new(&folds, spec);
    let mut history = Vec::new();
    for &c in cs {
        for &gamma in gammas {
            let hyper = Hyperparameters {
                c,
                gamma,
                max_iterations: None,
            };
            let f1 = scorer.score(hyper);
            on_evaluation(history.len() + 1, &hyper, f1);
            let params = if uses_gamma { vec![c, gamma] } else { vec![c] };
            history.push(Evaluation { params, score: f1 });
        }
    }
    scorer.refuse_if_every_fit_failed(&history)?;
    // the first of the highest, as GridSearchCV ranks ties
    let top = history
        .iter()
        .map(|e| e.score)
        .fold(f64::NEG_INFINITY, f64::max);
    let b = history
        .iter()
        .find(|e| e.score == top)
        .expect("a grid point");
    let span = |v: &[f64]| {
        [
            v.iter().copied().fold(f64::INFINITY, f64::min),
            v.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        ]
    };
    let mut parameters = vec!["C".to_string()];
    let mut ranges = vec![span(cs)];
    if uses_gamma {
        parameters.push("gamma".to_string());
        ranges.push(span(gammas));
    }
    let record = search_record(
        format!("grid ({} points)", history.len()),
        spec,
        parameters,
        ranges,
        &history,
    );
    let hyper = Hyperparameters {
        c: b.params[0],
        gamma: b.params.get(1).copied().unwrap_or(0.0),
        max_iterations: None,
    };
    Ok((hyper, record))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::slip::dataset::Scope;
    use crate::slip::Class;

    /// Six trials of two-feature rows; slip rows sit around (2, 2), static around (0, 0),
    /// with enough spread that the classes overlap a little.
    fn blobs() -> Dataset {
        let mut ds = Dataset {
            dim: 2,
            trial_ids: (0..6).map(|t| format!("t{t}")).collect(),
            ..Default::default()
        };
        let mut state = 7u64;
        let mut noise = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 33) as f32 / (1u64 << 31) as f32) * 2.0 - 1.0
        };
        for trial in 0..6u32 {
            for i in 0..60 {
                let slip = i % 4 == 0;
                let centre = if slip { 2.0 } else { 0.0 };
                ds.x.push(centre + 1.2 * noise());
                ds.x.push(centre + 1.2 * noise());
                ds.y.push(if slip { Class::Slip } else { Class::Static });
                ds.trial.push(trial);
                ds.sensor.push(0);
                ds.seq.push(i);
                ds.time_s.push(i as f64 / 60.0);
            }
        }
        ds
    }

    #[test]
    fn a_grid_scores_every_point_and_keeps_the_first_best() {
        let data = blobs();
        let s = spec(ClassifierKind::SvmRbf, 0, 3);
        let mut seen = Vec::new();
        let (hyper, record) =
            grid_search_reporting(&data, &s, &[0.01, 1.0, 10.0], &[0.1, 1.0], |k, h, f1| {
                seen.push((k, h.c, h.gamma, f1))
            })
            .unwrap();
        assert_eq!(seen.len(), 6);
        assert_eq!(
            seen.iter().map(|p| (p.1, p.2)).collect::<Vec<_>>(),
            [
                (0.01, 0.1),
                (0.01, 1.0),
                (1.0, 0.1),
                (1.0, 1.0),
                (10.0, 0.1),
                (10.0, 1.0)
            ]
        );
        // each point scored as the search's own cross-validation scores it
        for &(_, c, gamma, f1) in &seen {
            let h = Hyperparameters {
                c,
                gamma,
                max_iterations: None,
            };
            assert_eq!(f1, cross_validated_f1(&data, &s, h).unwrap());
        }
        let top = seen.iter().map(|p| p.3).fold(f64::NEG_INFINITY, f64::max);
        let first = seen.iter().find(|p| p.3 == top).unwrap();
        assert_eq!((hyper.c, hyper.gamma), (first.1, first.2));
        assert_eq!(record.ranges, vec![[0.01, 10.0], [0.1, 1.0]]);
        assert!(
            record.method.starts_with("grid (6 points)"),
            "{}",
            record.method
        );
        // a linear model has no gamma: the grid is C alone
        let (_, linear) = grid_search_reporting(
            &data,
            &spec(ClassifierKind::Logreg, 0, 3),
            &[0.1, 1.0],
            &[0.1, 1.0],
            |_, _, _| {},
        )
        .unwrap();
        assert_eq!(linear.evaluations.len(), 2);
        assert!(matches!(
            grid_search_reporting(&data, &s, &[], &[1.0], |_, _, _| {}),
            Err(TuneError::EmptyGrid)
        ));
    }

    #[test]
    fn fewer_than_two_folds_are_refused_not_divided_by() {
        let data = Dataset {
            dim: 1,
            ..Default::default()
        };
        for folds in [0, 1] {
            let e = search(&data, &spec(ClassifierKind::Logreg, 3, folds)).unwrap_err();
            assert!(matches!(e, TuneError::Folds(f) if f == folds), "{e}");
            assert!(e.to_string().contains("at least 2"), "{e}");
        }
    }

    fn spec(kind: ClassifierKind, iterations: usize, folds: usize) -> TuneSpec {
        TuneSpec {
            kind,
            scope: Scope::Global,
            downsample: 1.0,
            seed: 3,
            iterations,
            folds,
            ranges: SearchRanges::default(),
            max_fit_rows: None,
            held_out: HeldOutRows::Every,
            assignment: FoldAssignment::Shuffled,
        }
    }

    /// GroupKFold's folds are the trials' sizes' alone: another seed, the same split (the
    /// shuffled folds move with it), and the search record says which was used.
    #[test]
    fn group_k_fold_folds_do_not_move_with_the_seed() {
        let data = blobs();
        let hyper = Hyperparameters {
            c: 1.0,
            gamma: 0.0,
            max_iterations: None,
        };
        let held_out_f1 = |assignment, seed| -> Vec<f64> {
            let s = TuneSpec {
                assignment,
                seed,
                ..spec(ClassifierKind::Logreg, 1, 3)
            };
            cross_validate(&data, &s, hyper)
                .unwrap()
                .iter()
                .map(|s| s.macro_f1)
                .collect()
        };
        for seed in [4, 5, 6] {
            assert_eq!(
                held_out_f1(FoldAssignment::GroupKFold, 3),
                held_out_f1(FoldAssignment::GroupKFold, seed)
            );
        }
        assert!(
            [4, 5, 6]
                .iter()
                .any(|seed| held_out_f1(FoldAssignment::Shuffled, 3)
                    != held_out_f1(FoldAssignment::Shuffled, *seed)),
            "the shuffled folds move with the seed"
        );
        let (_, record) = grid_search_reporting(
            &data,
            &TuneSpec {
                assignment: FoldAssignment::GroupKFold,
                ..spec(ClassifierKind::Logreg, 0, 3)
            },
            &[1.0],
            &[],
            |_, _, _| {},
        )
        .unwrap();
        assert!(
            record.method.ends_with("as GroupKFold"),
            "{}",
            record.method
        );
    }

    #[test]
    fn a_search_keeps_to_given_ranges_and_says_when_its_best_lies_on_an_end() {
        let data = blobs();
        let s = TuneSpec {
            ranges: SearchRanges {
                c: [2.0, 2.0001],
                gamma: [0.5, 0.5001],
            },
            ..spec(ClassifierKind::SvmRbf, 4, 3)
        };
        let (hyper, record) = search(&data, &s).unwrap();
        assert!((2.0..=2.0001).contains(&hyper.c), "{hyper:?}");
        assert!(record
            .evaluations
            .iter()
            .all(|e| (2.0..=2.0001).contains(&e.params[0])));
        assert!((0.5..=0.5001).contains(&hyper.gamma), "{hyper:?}");
        assert_eq!(record.ranges, vec![[2.0, 2.0001], [0.5, 0.5001]]);
        // the best point decides whether the record warns: inside, at the lower end (within
        // 2 % of the range's log width), at the upper end
        let (_, wide) = search(&data, &spec(ClassifierKind::Logreg, 4, 3)).unwrap();
        let at_bottom = SearchRecord {
            evaluations: vec![Evaluation {
                params: vec![0.0105],
                score: 1.0,
            }],
            ..wide.clone()
        };
        assert_eq!(
            at_bottom.best_on_range_ends(),
            vec![("C".to_string(), 0.0105, "lower")]
        );
        let inside = SearchRecord {
            evaluations: vec![Evaluation {
                params: vec![1.0],
                score: 1.0,
            }],
            ..wide
        };
        assert!(inside.best_on_range_ends().is_empty());
        let at_top = SearchRecord {
            evaluations: vec![Evaluation {
                params: vec![999.0],
                score: 1.0,
            }],
            ..inside
        };
        assert_eq!(at_top.best_on_range_ends()[0].2, "upper");
    }

    #[test]
    fn a_search_may_fit_on_fewer_rows_each_class_alike() {
        let data = blobs();
        let sub = data.subsample_each_class(0.25, 1);
        assert_eq!(sub.count(Class::Slip), 23); // 90 * 0.25, rounded
        assert_eq!(sub.count(Class::Static), 68); // 270 * 0.25, rounded
        assert_eq!(data.subsample_each_class(1.0, 1), data);
        let hyper = Hyperparameters {
            c: 1.0,
            gamma: 0.0,
            max_iterations: None,
        };
        let full = cross_validated_f1(&data, &spec(ClassifierKind::Logreg, 1, 3), hyper).unwrap();
        let capped = TuneSpec {
            max_fit_rows: Some(60),
            held_out: HeldOutRows::Every,
            ..spec(ClassifierKind::Logreg, 1, 3)
        };
        let few = cross_validated_f1(&data, &capped, hyper).unwrap();
        // the blobs separate from a few rows as from all; the fits really were smaller
        assert!(few > 0.8 && (few - full).abs() < 0.1, "{few} vs {full}");
        let (_, record) = search(
            &data,
            &TuneSpec {
                iterations: 2,
                ..capped
            },
        )
        .unwrap();
        assert!(
            record.method.contains("at most 60 rows"),
            "{}",
            record.method
        );
        assert_eq!(parse_search_rows("4000"), Ok(4000));
        assert!(parse_search_rows("10").unwrap_err().contains("at least 50"));
    }

    #[test]
    fn held_out_folds_are_scored_on_every_row_or_down_sampled_by_d() {
        let data = blobs();
        let hyper = Hyperparameters {
            c: 1.0,
            gamma: 0.0,
            max_iterations: None,
        };
        let rows_scored = |held_out| -> (u64, u64) {
            let spec = TuneSpec {
                downsample: 0.25,
                held_out,
                ..spec(ClassifierKind::Logreg, 1, 3)
            };
            cross_validate(&data, &spec, hyper)
                .unwrap()
                .iter()
                .map(|s| {
                    let c = s.confusion;
                    (c.true_slip + c.false_static, c.true_static + c.false_slip)
                })
                .fold((0, 0), |(a, b), (s, t)| (a + s, b + t))
        };
        // 90 slip and 270 static rows in all; each row is in one held-out fold.
        assert_eq!(rows_scored(HeldOutRows::Every), (90, 270));
        let (slip, stat) = rows_scored(HeldOutRows::Downsampled);
        assert_eq!(slip, 90, "every slip row");
        assert!(
            (66..=69).contains(&stat),
            "a quarter of each fold's static rows: {stat}"
        );
        let (_, record) = search(
            &data,
            &TuneSpec {
                iterations: 2,
                held_out: HeldOutRows::Downsampled,
                ..spec(ClassifierKind::Logreg, 2, 3)
            },
        )
        .unwrap();
        assert!(
            record.method.contains("down-sampled by d"),
            "{}",
            record.method
        );
    }

    #[test]
    fn cross_validation_scores_a_separable_task_highly() {
        let f1 = cross_validated_f1(
            &blobs(),
            &spec(ClassifierKind::Logreg, 1, 3),
            Hyperparameters {
                c: 1.0,
                gamma: 0.0,
                max_iterations: None,
            },
        )
        .unwrap();
        assert!(f1 > 0.8 && f1 <= 1.0, "f1 {f1}");
    }

    #[test]
    fn search_stays_in_range_and_is_seeded() {
        let data = blobs();
        let s = spec(ClassifierKind::SvmRbf, 6, 3);
        let (hyper, record) = search(&data, &s).unwrap();
        assert_eq!(record.evaluations.len(), 6);
        assert!((C_RANGE.low..=C_RANGE.high).contains(&hyper.c));
        assert!((GAMMA_RANGE.low..=GAMMA_RANGE.high).contains(&hyper.gamma));
        let best_score = record
            .evaluations
            .iter()
            .map(|e| e.score)
            .fold(f64::MIN, f64::max);
        assert!(best_score > 0.8, "best CV F1 {best_score}");
        assert_eq!(
            search(&data, &s).unwrap().0,
            hyper,
            "same seed, same answer"
        );
        // each evaluation is reported as it finishes, as the record keeps it
        let mut seen = Vec::new();
        let (reported, _) = search_reporting(&data, &s, |done, h, f1| {
            seen.push((done, h.c, h.gamma, f1));
        })
        .unwrap();
        assert_eq!(reported, hyper);
        assert_eq!(seen.len(), 6);
        for (k, ((done, c, gamma, f1), e)) in seen.iter().zip(&record.evaluations).enumerate() {
            assert_eq!(*done, k + 1);
            assert_eq!((*c, *gamma, *f1), (e.params[0], e.params[1], e.score));
        }
    }

    #[test]
    fn too_few_trials_and_threshold_searches_are_refused() {
        let data = blobs();
        assert!(matches!(
            cross_validated_f1(
                &data,
                &spec(ClassifierKind::Logreg, 1, 7),
                Hyperparameters {
                    c: 1.0,
                    gamma: 0.0,
                    max_iterations: None
                }
            ),
            Err(TuneError::TooFewTrials {
                folds: 7,
                trials: 6
            })
        ));
        assert!(matches!(
            search(&data, &spec(ClassifierKind::Threshold, 4, 3)),
            Err(TuneError::NothingToSearch(_))
        ));
    }
}
