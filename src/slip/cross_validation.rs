//! Cross-validation by whole trials, split once and scored at any number of hyperparameter
//! points: a search's evaluations share each fold's rows (held out, and for training
//! sampled, split by sensor and down-sampled), which do not depend on the point. Copying
//! them again at every evaluation was about 15 % of a LogReg search's time (perf: row
//! copies and the page faults of their fresh buffers).

use rayon::prelude::*;

use super::bayes::SearchError;
use super::classifier::ClassifierKind;
use super::dataset::Dataset;
use super::dataset::Scope;
use super::metrics::Scores;
use super::model::TrainError;
use super::model::{fit_parts, score_models, training_parts, Hyperparameters, SensorModel};
use super::search_range::SearchRanges;
use super::Class;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TuneSpec {
    pub kind: ClassifierKind,
    pub scope: Scope,
    pub downsample: f64,
    pub seed: u64,
    pub iterations: usize,
    pub folds: usize,
    pub ranges: SearchRanges,
    /// At most this many rows (after down-sampling) in each of the search's fits: a fold's
    /// training rows are sampled, each class alike, down to it. The held-out fold is scored
    /// as `held_out` says, and the cell's final model is fitted on all its rows. `None`:
    /// every row.
    pub max_fit_rows: Option<usize>,
    pub held_out: HeldOutRows,
    pub assignment: FoldAssignment,
}

/// How whole trials are assigned to a cross-validation's folds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum FoldAssignment {
    /// Trials shuffled by the seed and dealt out in turn (fold sizes differ by at most one
    /// trial): a replicate with another seed splits the trials another way.
    #[default]
    Shuffled,
    /// As scikit-learn's `GroupKFold` (unshuffled) assigns groups: the trial with the most
    /// rows first, each to the fold with the fewest rows so far, ties by trial id; no seed.
    /// A grid search then picks what `GridSearchCV(cv=GroupKFold(k))` picks on the same rows.
    GroupKFold,
}

impl FoldAssignment {
    /// How a search record names it.
    pub fn describe(self) -> &'static str {
        match self {
            FoldAssignment::Shuffled => "trials shuffled into folds by the seed",
            FoldAssignment::GroupKFold => "trials assigned to folds as GroupKFold",
        }
    }

    /// The fold of each trial index of `data` (indexed by the index).
    fn assign(
        self,
        data: &Dataset,
        folds: usize,
        seed: u64,
    ) -> Result<Vec<usize>, tmo_learn::cross_validation::FoldError> {
        use tmo_learn::cross_validation::{group_folds, group_k_fold};
        match self {
            FoldAssignment::Shuffled => group_folds(&data.trial, folds, seed ^ 0x5eed),
            FoldAssignment::GroupKFold => {
                // GroupKFold's tie order is that of the trial ids' sorted labels
                let mut present: Vec<u32> = data.trial.clone();
                present.sort_unstable();
                present.dedup();
                present
                    .sort_by(|a, b| data.trial_ids[*a as usize].cmp(&data.trial_ids[*b as usize]));
                group_k_fold(&data.trial, folds, &present)
            }
        }
    }
}

/// The rows of a held-out fold that a search scores its models on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum HeldOutRows {
    /// Every row, as the test trials are scored.
    #[default]
    Every,
    /// The static rows down-sampled by the cell's `d` (every slip row kept), as
    /// scikit-learn's `BayesSearchCV` scores folds of a training set that was down-sampled
    /// before the search; faster at small `d`.
    Downsampled,
}

impl HeldOutRows {
    /// How a search record and a sweep's provenance name it.
    pub fn describe(self) -> &'static str {
        match self {
            HeldOutRows::Every => "held-out folds scored on every row",
            HeldOutRows::Downsampled => "held-out folds' static rows down-sampled by d",
        }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum TuneError {
    #[error(transparent)]
    Search(#[from] SearchError),
    #[error(transparent)]
    Train(#[from] TrainError),
    #[error("cross-validation needs at least {folds} trials, got {trials}")]
    TooFewTrials { folds: usize, trials: usize },
    #[error(
        "--folds {0}: expected at least 2 (each fold is scored by a model trained on the others)"
    )]
    Folds(usize),
    #[error("the {0} classifier has no hyperparameters to search")]
    NothingToSearch(&'static str),
    #[error("a grid search needs at least one C and, for the RBF SVM, one gamma")]
    EmptyGrid,
}

/// A cross-validation's folds, ready to be scored at any point.
#[derive(Debug)]
pub struct Folds {
    folds: Vec<Fold>,
}

#[derive(Debug)]
struct Fold {
    /// Each model's training rows, as [`super::model::train_models`] splits them.
    parts: Vec<(Option<u8>, Dataset)>,
    held_out: Dataset,
}

impl Folds {
    /// `spec.folds` folds of whole trials (as `spec.assignment` says): each fold's held-out rows
    /// (every row, or as `spec.held_out` says) and the rest's rows for training (sampled
    /// to `spec.max_fit_rows`, then split and down-sampled as the models train).
    pub fn new(data: &Dataset, spec: &TuneSpec) -> Result<Self, TuneError> {
        // whole trials in each fold, assigned by `tmo_learn`'s group folds
        let fold_by_trial = spec
            .assignment
            .assign(data, spec.folds, spec.seed)
            .map_err(|e| match e {
                tmo_learn::cross_validation::FoldError::Folds(f) => TuneError::Folds(f),
                tmo_learn::cross_validation::FoldError::TooFewGroups { folds, groups } => {
                    TuneError::TooFewTrials {
                        folds,
                        trials: groups,
                    }
                }
            })?;
        let fold_of = |t: u32| fold_by_trial[t as usize];
        let folds = (0..spec.folds)
            .into_par_iter()
            .map(|fold| {
                let train = data.filter(|i| fold_of(data.trial[i]) != fold);
                let train = match spec.max_fit_rows {
                    Some(cap) => {
                        let (slip, stat) = (train.count(Class::Slip), train.count(Class::Static));
                        let fitted = slip as f64 + spec.downsample.clamp(0.0, 1.0) * stat as f64;
                        if fitted > cap as f64 {
                            train.subsample_each_class(cap as f64 / fitted, spec.seed ^ 0xf17)
                        } else {
                            train
                        }
                    }
                    None => train,
                };
                let held_out = data.filter(|i| fold_of(data.trial[i]) == fold);
                let held_out = match spec.held_out {
                    HeldOutRows::Every => held_out,
                    HeldOutRows::Downsampled => {
                        held_out.downsample_static(spec.downsample, spec.seed ^ 0x7e57)
                    }
                };
                let parts = training_parts(&train, spec.scope, spec.downsample, spec.seed);
                Fold { parts, held_out }
            })
            .collect();
        Ok(Self { folds })
    }

    /// Each fold scored by models of `spec.kind` at `hyper`, trained on the other folds. A
    /// fold whose sensor the training folds never saw (a local model set lacking it) scores
    /// as all wrong.
    pub fn score(&self, spec: &TuneSpec, hyper: Hyperparameters) -> Result<Vec<Scores>, TuneError> {
        // Folds fit in parallel: the solver's own parallel kernel rows leave a core idle
        // during its sequential working-set steps.
        let scores: Vec<Result<Scores, TuneError>> = self
            .folds
            .par_iter()
            .map(|fold| {
                let models = fit_parts(&fold.parts, spec.kind, hyper, SensorModel::fit)?;
                // A local model set lacks a sensor only if the training folds never saw it.
                Ok(score_models(&models, spec.scope, &fold.held_out)
                    .map_or_else(|_| Scores::default(), |(s, _)| s))
            })
            .collect();
        scores.into_iter().collect()
    }
}
