//! The paper's offline grid (Fig. 5): for every classifier, number of slip frames `n_slip`
//! and static down-sampling `d`, train on the training trials (hyperparameters fixed or
//! searched per cell on the training trials only) and score on every row of the test trials.
//!
//! Trials are labelled once with the largest `n_slip` and narrowed per cell
//! ([`Dataset::with_n_slip`]); cells run in chains ([`SweepSpec::chains`]), the chains in
//! parallel, the costliest first.

use std::collections::HashMap;
use std::sync::atomic::Ordering;

use rayon::prelude::*;
use std::time::Instant;

use super::dataset::{Dataset, Scope};
use super::model::{
    score_models_on, train_models_from, ClassifierKind, Hyperparameters, SensorModel, TrainError,
};
use super::tuning::{self, TuneError, TuneSpec};
use super::warm::WarmStart;

/// How a cell gets its hyperparameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum HyperChoice {
    Fixed(Hyperparameters),
    /// Bayesian optimisation of cross-validated macro F1 in every cell.
    Search {
        iterations: usize,
        folds: usize,
        ranges: tuning::SearchRanges,
        max_fit_rows: Option<usize>,
        held_out: tuning::HeldOutRows,
    },
}

/// The expected cost of the cells a sweep runs ([`SweepSpec::costs`]).
#[derive(Debug, Clone, Default)]
pub struct CellCosts {
    by_key: std::collections::HashMap<(String, usize, String), f64>,
    pub total: f64,
}

impl CellCosts {
    /// The cost of the cell a result row came from (0 for a cell not planned).
    pub fn of(&self, row: &SweepRow) -> f64 {
        self.by_key.get(&row.key()).copied().unwrap_or(0.0)
    }

    /// Seconds left, from the time the finished cells took for their share of the cost:
    /// `elapsed x (total - done) / done`. The whole run's average, not a recent rate: the
    /// cells finish in lumps of very different cost, and a rate over the last few swings
    /// with each lump. `None` before any cost is done.
    pub fn eta_s(&self, elapsed_s: f64, done: f64) -> Option<f64> {
        (done > 0.0 && self.total > 0.0).then(|| elapsed_s * (self.total - done).max(0.0) / done)
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct SweepSpec {
    pub classifiers: Vec<ClassifierKind>,
    pub downsample: Vec<f64>,
    pub n_slip: Vec<usize>,
    pub scope: Scope,
    pub hyper: HyperChoice,
    pub seed: u64,
}

/// One cell of the grid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cell {
    pub classifier: ClassifierKind,
    pub n_slip: usize,
    pub downsample: f64,
}

/// A cell as a results file names it: classifier, n_slip, d as written.
pub type CellKey = (String, usize, String);

impl Cell {
    /// Identifies the cell in a results file (d rounded as written there).
    pub fn key(&self) -> CellKey {
        (
            self.classifier.name().to_string(),
            self.n_slip,
            format!("{:.3}", self.downsample),
        )
    }
}

/// One line of the sweep's CSV.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SweepRow {
    pub classifier: String,
    pub scope: Scope,
    pub n_slip: usize,
    pub downsample: String,
    /// C of the cell's classifier; empty for the threshold, which has none.
    pub c: Option<f64>,
    /// The RBF kernel's gamma; empty for the classifiers without one.
    pub gamma: Option<f64>,
    /// Best cross-validated macro F1 of the search, when there was one.
    pub cv_macro_f1: Option<f64>,
    pub train_rows: usize,
    pub train_slip_rows: usize,
    pub test_rows: usize,
    pub macro_f1: f64,
    pub slip_precision: f64,
    pub slip_recall: f64,
    pub slip_f1: f64,
    pub static_precision: f64,
    pub static_recall: f64,
    pub static_f1: f64,
    pub true_slip: u64,
    pub false_slip: u64,
    pub true_static: u64,
    pub false_static: u64,
    pub seconds: f64,
}

impl SweepRow {
    pub fn key(&self) -> (String, usize, String) {
        (
            self.classifier.clone(),
            self.n_slip,
            self.downsample.clone(),
        )
    }
}

#[derive(Debug, thiserror::Error)]
pub enum SweepError {
    #[error("the grid is empty: {0}")]
    EmptyGrid(&'static str),
    #[error("down-sampling proportion {0} is outside (0, 1]")]
    Downsample(f64),
    #[error("n_slip must be at least 1")]
    NSlip,
    #[error("the datasets were not labelled from trials (no slip frame counts)")]
    NotFromTrials,
    #[error("{cell:?}: {source}")]
    Train {
        cell: Cell,
        #[source]
        source: TrainError,
    },
    #[error("{cell:?}: {source}")]
    Tune {
        cell: Cell,
        #[source]
        source: TuneError,
    },
    #[error(
        "{cell:?}: the test trials have sensor {sensor}, which no local model was trained for"
    )]
    Sensor { cell: Cell, sensor: u8 },
    #[error("stopped before every cell had run")]
    Stopped,
}

impl SweepSpec {
    pub fn check(&self) -> Result<(), SweepError> {
        if self.classifiers.is_empty() {
            return Err(SweepError::EmptyGrid("no classifiers"));
        }
        if self.downsample.is_empty() {
            return Err(SweepError::EmptyGrid("no down-sampling proportions"));
        }
        if self.n_slip.is_empty() {
            return Err(SweepError::EmptyGrid("no n_slip values"));
        }
        if let Some(d) = self.downsample.iter().find(|d| !(**d > 0.0 && **d <= 1.0)) {
            return Err(SweepError::Downsample(*d));
        }
        if self.n_slip.contains(&0) {
            return Err(SweepError::NSlip);
        }
        Ok(())
    }

    /// Every cell, costliest first (RBF SVM, then the largest training sets), so the
    /// parallel run does not end waiting on one big fit.
    pub fn cells(&self) -> Vec<Cell> {
        let mut cells: Vec<Cell> = self
            .classifiers
            .iter()
            .flat_map(|&classifier| {
                self.n_slip.iter().flat_map(move |&n_slip| {
                    self.downsample.iter().map(move |&downsample| Cell {
                        classifier,
                        n_slip,
                        downsample,
                    })
                })
            })
            .collect();
        // Any training set will do for the order: the cost grows with d within a classifier.
        let cost = |c: &Cell| self.cell_cost(c, 1000, 100_000);
        cells.sort_by(|a, b| cost(b).total_cmp(&cost(a)));
        cells
    }

    /// The grid as chains of cells that run in order, each cell's fits started from the
    /// previous cell's solutions (see [`super::warm`]): the cells of one classifier at one
    /// `d`, `n_slip` rising, whose training rows are nested. The logistic regression's
    /// optimum is unique, and a start from the previous cell took 0.52 of a cold start's
    /// time (`cargo bench --bench warm_start`). The RBF SVM's start reaches the optimum
    /// within the solver's tolerance: 0.61 of the time at d 1, n_slip 12-15 in that bench,
    /// with no test prediction changed; over the step-by-step pipeline's grid its cells took 1,034 s
    /// against 1,424 s cold (the whole grid 620 s against 793 s), and 10 of its 150 cells'
    /// test macro F1 moved, by at most 0.0009. (Before the start's kernel rows were computed
    /// 64 at a time and its gradient summed in parallel, the start cost about what it saved
    /// there.) With a search, each cell's search is its own, the same as unchained; only its
    /// final fit starts from the previous cell's final fit, made at whatever point that
    /// cell's search chose. On the step-by-step pipeline's data, RBF cells at d 0.2, 0.6 and 1.0 searched
    /// with `--iters 12 --search-rows 4000` took 893 s of CPU against 1,270 s unchained
    /// (463 s wall against 656 s), with every search's choice the same and 15 of 45 cells'
    /// test macro F1 moved, by at most 0.0008.
    /// Costliest chain first. A chain runs whole in one shard and is resumed from its
    /// start, so that shards and resumed sweeps give the cells a single run gives.
    pub fn chains(&self) -> Vec<Vec<Cell>> {
        let cells = self.cells();
        let chained = |c: &Cell| {
            matches!(
                c.classifier,
                ClassifierKind::Logreg | ClassifierKind::SvmRbf
            )
        };
        let mut chains: Vec<Vec<Cell>> = Vec::new();
        for cell in cells {
            let same = |c: &Cell| {
                chained(c)
                    && c.classifier == cell.classifier
                    && c.downsample.to_bits() == cell.downsample.to_bits()
            };
            match chains.iter_mut().find(|chain| same(&chain[0])) {
                Some(chain) => chain.push(cell),
                None => chains.push(vec![cell]),
            }
        }
        for chain in &mut chains {
            chain.sort_by_key(|c| c.n_slip);
        }
        chains.sort_by(|a, b| self.chain_cost(b).total_cmp(&self.chain_cost(a)));
        chains
    }

    /// A chain's cost relative to the others' ([`Self::cell_cost`] on a fixed, typical
    /// training set: it depends on the grid alone, so every process that deals chains out
    /// deals them alike).
    pub fn chain_cost(&self, chain: &[Cell]) -> f64 {
        chain.iter().map(|c| self.cell_cost(c, 1000, 100_000)).sum()
    }

    /// Each of `cells`' cost ([`Self::cell_cost`]) on the training set `train`, by the key a
    /// result row carries, for progress that advances by cost.
    pub fn costs(&self, cells: &[Cell], train: &Dataset) -> CellCosts {
        let (slip, stat) = (
            train.count(super::Class::Slip),
            train.count(super::Class::Static),
        );
        // The slip rows depend on n_slip; the training set was labelled with the largest.
        let max_n = self.n_slip.iter().copied().max().unwrap_or(1).max(1);
        let by_key: std::collections::HashMap<_, _> = cells
            .iter()
            .map(|c| {
                let slip_rows = slip * c.n_slip / max_n;
                (c.key(), self.cell_cost(c, slip_rows, stat))
            })
            .collect();
        let total = by_key.values().sum();
        CellCosts { by_key, total }
    }

    /// What a cell costs to run, in rough seconds of this project's 2-core reference machine,
    /// for `slip_rows` and `static_rows` training rows (before down-sampling): only its ratio
    /// to other cells' costs matters (the sweep runs the costliest first, and its progress
    /// advances by cost so that its ETA does not swing as cheap cells follow dear ones).
    /// Measured on the step-by-step pipeline's 40 hand trials, n_slip 13, fixed hyperparameters: an RBF
    /// cell took 3.7 s at 16k training rows, 11 s at 61k and 36 s at 151k (fit and scoring
    /// both grow about linearly there); a LogReg cell 0.28 s and 3.1 s; a threshold cell
    /// 0.10 s and 0.31 s (the linear SVM is put between the two learned ones). A search
    /// adds its fits: iterations x folds, each on about two thirds of the rows (capped by
    /// `--search-rows`).
    pub fn cell_cost(&self, cell: &Cell, slip_rows: usize, static_rows: usize) -> f64 {
        let rows = slip_rows as f64 + cell.downsample.clamp(0.0, 1.0) * static_rows as f64;
        let (per_row, fixed) = match cell.classifier {
            ClassifierKind::SvmRbf => (2.3e-4, 0.0),
            ClassifierKind::SvmLinear => (1e-4, 0.0),
            ClassifierKind::Logreg => (2.1e-5, 0.0),
            ClassifierKind::Threshold => (1.5e-6, 0.08),
        };
        let fit = |n: f64| fixed + per_row * n;
        match &self.hyper {
            HyperChoice::Search {
                iterations,
                folds,
                max_fit_rows,
                ..
            } if cell.classifier != ClassifierKind::Threshold => {
                let fold_rows = rows * (*folds as f64 - 1.0) / (*folds as f64).max(1.0);
                let fold_rows = max_fit_rows.map_or(fold_rows, |cap| fold_rows.min(cap as f64));
                fit(rows) + (*iterations * *folds) as f64 * fit(fold_rows)
            }
            _ => fit(rows),
        }
    }
}

pub use crate::output::shard::Shard;

/// Sorts rows into the order a sweep's CSV has: classifiers as `classifiers` lists them,
/// then n_slip, then d.
pub fn sort_rows(rows: &mut [SweepRow], classifiers: &[String]) {
    let rank = |r: &SweepRow| {
        classifiers
            .iter()
            .position(|k| *k == r.classifier)
            .unwrap_or(usize::MAX)
    };
    rows.sort_by(|a, b| {
        (rank(a), a.n_slip, &a.downsample).cmp(&(rank(b), b.n_slip, &b.downsample))
    });
}

impl SweepRow {
    /// The hyperparameters the row's cell was fitted with (the defaults where its classifier
    /// has none). A CSV keeps them to the bit: they are written in Rust's shortest form that
    /// reads back as the same number.
    pub fn hyperparameters(&self) -> Hyperparameters {
        let default = Hyperparameters::default();
        Hyperparameters {
            c: self.c.unwrap_or(default.c),
            gamma: self.gamma.unwrap_or(default.gamma),
            max_iterations: None,
        }
    }
}

/// A cell's models, fitted on its training rows.
struct FittedCell {
    models: Vec<SensorModel>,
    hyper: Hyperparameters,
    cv_macro_f1: Option<f64>,
    train_rows: usize,
    train_slip_rows: usize,
}

/// Fits one cell's models, each started from `starts` (the previous cell's solutions in its
/// chain; empty for a cold start); returns them with their own solutions. `searched`: the
/// hyperparameters an earlier run's search chose for the cell, which are not searched again.
fn fit_cell(
    train: &Dataset,
    spec: &SweepSpec,
    cell: Cell,
    starts: &[Option<WarmStart>],
    searched: Option<Hyperparameters>,
) -> Result<(FittedCell, Vec<Option<WarmStart>>), SweepError> {
    let train = train
        .with_n_slip(cell.n_slip)
        .ok_or(SweepError::NotFromTrials)?;
    let (hyper, cv_macro_f1) = match (spec.hyper, cell.classifier) {
        (HyperChoice::Fixed(h), _) => (h, None),
        (HyperChoice::Search { .. }, _) if searched.is_some() => (searched.expect("matched"), None),
        // T is picked from the training rows; there is nothing to search
        (HyperChoice::Search { .. }, ClassifierKind::Threshold) => {
            (Hyperparameters::default(), None)
        }
        (
            HyperChoice::Search {
                iterations,
                folds,
                ranges,
                max_fit_rows,
                held_out,
            },
            kind,
        ) => {
            let tune = TuneSpec {
                kind,
                scope: spec.scope,
                downsample: cell.downsample,
                seed: spec.seed,
                iterations,
                folds,
                ranges,
                max_fit_rows,
                held_out,
                // a sweep's replicates vary the split by seed
                assignment: Default::default(),
            };
            let (h, record) = tuning::search(&train, &tune)
                .map_err(|source| SweepError::Tune { cell, source })?;
            let best = record
                .evaluations
                .iter()
                .map(|e| e.score)
                .fold(f64::NEG_INFINITY, f64::max);
            (h, Some(best))
        }
    };
    let (models, next) = train_models_from(
        &train,
        cell.classifier,
        hyper,
        spec.scope,
        cell.downsample,
        spec.seed,
        starts,
    )
    .map_err(|source| SweepError::Train { cell, source })?;
    let fitted = FittedCell {
        train_rows: models.iter().map(|m| m.training_rows).sum(),
        train_slip_rows: train.count(super::Class::Slip),
        models,
        hyper,
        cv_macro_f1,
    };
    Ok((fitted, next))
}

/// Scores a fitted cell on every test row; `started` is when the cell's work began.
fn score_cell(
    fitted: &FittedCell,
    test: &Dataset,
    spec: &SweepSpec,
    cell: Cell,
    started: Instant,
) -> Result<SweepRow, SweepError> {
    let test_rows = test
        .rows_with_n_slip(cell.n_slip)
        .ok_or(SweepError::NotFromTrials)?;
    let (s, _) = score_models_on(&fitted.models, spec.scope, test, &test_rows)
        .map_err(|sensor| SweepError::Sensor { cell, sensor })?;
    let hyper = fitted.hyper;
    let (key_classifier, _, key_d) = cell.key();
    Ok(SweepRow {
        classifier: key_classifier,
        scope: spec.scope,
        n_slip: cell.n_slip,
        downsample: key_d,
        c: cell.classifier.uses_c().then_some(hyper.c),
        gamma: cell.classifier.uses_gamma().then_some(hyper.gamma),
        cv_macro_f1: fitted.cv_macro_f1,
        train_rows: fitted.train_rows,
        train_slip_rows: fitted.train_slip_rows,
        test_rows: test_rows.len(),
        macro_f1: s.macro_f1,
        slip_precision: s.slip.precision,
        slip_recall: s.slip.recall,
        slip_f1: s.slip.f1,
        static_precision: s.static_.precision,
        static_recall: s.static_.recall,
        static_f1: s.static_.f1,
        true_slip: s.confusion.true_slip,
        false_slip: s.confusion.false_slip,
        true_static: s.confusion.true_static,
        false_static: s.confusion.false_static,
        seconds: started.elapsed().as_secs_f64(),
    })
}

/// Runs the whole grid of `spec` ([`SweepSpec::chains`]) in parallel; `on_done` sees every
/// finished row at once (to save or count it).
pub fn run_sweep(
    train: &Dataset,
    test: &Dataset,
    spec: &SweepSpec,
    on_done: impl Fn(&SweepRow) + Sync,
) -> Result<Vec<SweepRow>, SweepError> {
    run_chains_until(
        train,
        test,
        spec,
        &spec.chains(),
        &HashMap::new(),
        None,
        on_done,
    )
}

/// Runs `chains` in parallel, each chain's cells in order, and returns the rows of the cells
/// not in `finished` (each finished cell with the hyperparameters it was fitted with). A
/// finished cell before an unfinished one in its chain is fitted again at those (not searched
/// again, nor scored), so the cells after it start where a run without the interruption
/// started them. Starts no more cells once `stop` is set (cells in flight finish and reach
/// `on_done`); then it returns [`SweepError::Stopped`]. The first failing cell stops the
/// sweep; rows already passed to `on_done` stay valid.
pub fn run_chains_until(
    train: &Dataset,
    test: &Dataset,
    spec: &SweepSpec,
    chains: &[Vec<Cell>],
    finished: &HashMap<CellKey, Hyperparameters>,
    stop: Option<&std::sync::atomic::AtomicBool>,
    on_done: impl Fn(&SweepRow) + Sync,
) -> Result<Vec<SweepRow>, SweepError> {
    spec.check()?;
    let run_chain = |chain: &[Cell]| -> Result<Vec<SweepRow>, SweepError> {
        let mut rows = Vec::new();
        let Some(last) = chain.iter().rposition(|c| !finished.contains_key(&c.key())) else {
            return Ok(rows);
        };
        let mut starts = Vec::new();
        for &cell in &chain[..=last] {
            if stop.is_some_and(|s| s.load(Ordering::Relaxed)) {
                return Err(SweepError::Stopped);
            }
            let started = Instant::now();
            let searched = finished.get(&cell.key()).copied();
            let (fitted, next) = fit_cell(train, spec, cell, &starts, searched)?;
            starts = next;
            if searched.is_none() {
                let row = score_cell(&fitted, test, spec, cell, started)?;
                on_done(&row);
                rows.push(row);
            }
        }
        Ok(rows)
    };
    let rows: Vec<Vec<SweepRow>> = chains
        .par_iter()
        .with_max_len(1)
        .map(|chain| run_chain(chain))
        .collect::<Result<_, SweepError>>()?;
    Ok(rows.into_iter().flatten().collect())
}

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("`{text}`: expected {expected}")]
pub struct RangeError {
    pub text: String,
    pub expected: String,
}

/// Grid values from `start:end:step` (inclusive), `start:end` (step 1), or `a,b,c`.
pub fn parse_f64_grid(text: &str) -> Result<Vec<f64>, RangeError> {
    let said = |expected: &str| RangeError {
        text: text.to_string(),
        expected: expected.to_string(),
    };
    let err = || said("start:end:step (e.g. 0.1:1.0:0.1) or a list (0.2,0.4)");
    let num = |s: &str| s.trim().parse::<f64>().ok().filter(|v| v.is_finite());
    if text.contains(':') {
        let parts: Vec<&str> = text.split(':').collect();
        let (start, end, step) = match parts.as_slice() {
            [a, b] => (num(a), num(b), Some(1.0)),
            [a, b, c] => (num(a), num(b), num(c)),
            _ => return Err(err()),
        };
        let (Some(start), Some(end), Some(step)) = (start, end, step) else {
            return Err(err());
        };
        // each way a range can be wrong, said as it is (T4-12)
        if end < start {
            return Err(said(&format!(
                "an end at or above the start (a grid counts up: write {end}:{start})"
            )));
        }
        if step <= 0.0 {
            return Err(said("a positive step"));
        }
        // Count steps rather than accumulate, so 0.1:1.0:0.1 ends at exactly 1.0.
        let n = ((end - start) / step + 1e-9).floor() as usize;
        if n > 10_000 {
            return Err(said("at most 10,001 values (a coarser step)"));
        }
        Ok((0..=n).map(|i| start + step * i as f64).collect())
    } else {
        text.split(',').map(|s| num(s).ok_or_else(err)).collect()
    }
}

/// Whole-number grid values, in the forms of [`parse_f64_grid`].
pub fn parse_usize_grid(text: &str) -> Result<Vec<usize>, RangeError> {
    let values = parse_f64_grid(text)?;
    values
        .iter()
        .map(|v| {
            (v.fract() == 0.0 && *v >= 0.0)
                .then_some(*v as usize)
                .ok_or_else(|| RangeError {
                    text: text.to_string(),
                    expected: "whole numbers, e.g. 1:15 or 5,10,13".into(),
                })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_range_that_counts_down_or_never_moves_says_so() {
        let e = parse_usize_grid("5:1").unwrap_err().to_string();
        assert!(e.contains("write 1:5"), "{e}");
        let e = parse_f64_grid("0.1:1:0").unwrap_err().to_string();
        assert!(e.contains("a positive step"), "{e}");
        let e = parse_f64_grid("0:1:0.00001").unwrap_err().to_string();
        assert!(e.contains("at most"), "{e}");
    }

    #[test]
    fn grids_parse_as_the_paper_writes_them() {
        let d = parse_f64_grid("0.1:1.0:0.1").unwrap();
        assert_eq!(d.len(), 10);
        assert!((d[9] - 1.0).abs() < 1e-12 && (d[0] - 0.1).abs() < 1e-12);
        assert_eq!(
            parse_usize_grid("1:15").unwrap(),
            (1..=15).collect::<Vec<_>>()
        );
        assert_eq!(parse_usize_grid("5,13").unwrap(), vec![5, 13]);
        assert_eq!(parse_f64_grid("0.4").unwrap(), vec![0.4]);
        for bad in ["", "1:0", "0:1:0", "a:b", "1:2:3:4", "0.1,x"] {
            assert!(parse_f64_grid(bad).is_err(), "{bad}");
        }
        assert!(parse_usize_grid("1.5:3").is_err());
    }

    #[test]
    fn shards_split_the_grid_into_disjoint_parts_of_like_cost() {
        let spec = SweepSpec {
            classifiers: vec![ClassifierKind::SvmRbf, ClassifierKind::Threshold],
            downsample: vec![0.2, 0.5, 1.0],
            n_slip: vec![1, 2, 3, 4],
            scope: Scope::Global,
            hyper: HyperChoice::Fixed(Hyperparameters::default()),
            seed: 0,
        };
        let all = spec.cells();
        let mut joined = Vec::new();
        for index in 1..=3 {
            let shard: Shard = format!("{index}/3").parse().unwrap();
            // whole chains: one classifier at one d, n_slip rising
            let chains = shard.select(spec.chains());
            for chain in &chains {
                assert!(chain.windows(2).all(|w| w[0].classifier == w[1].classifier
                    && w[0].downsample == w[1].downsample
                    && w[0].n_slip < w[1].n_slip));
            }
            let part: Vec<Cell> = chains.into_iter().flatten().collect();
            assert_eq!(part.len(), 8);
            // each shard gets its share of the costly RBF cells
            let rbf = part
                .iter()
                .filter(|c| c.classifier == ClassifierKind::SvmRbf)
                .count();
            assert_eq!(rbf, 4);
            joined.extend(part.iter().map(Cell::key));
        }
        joined.sort();
        let mut keys: Vec<_> = all.iter().map(Cell::key).collect();
        keys.sort();
        assert_eq!(joined, keys, "every cell once");
        for bad in ["0/3", "4/3", "3", "a/b", "1/0"] {
            assert!(bad.parse::<Shard>().is_err(), "{bad}");
        }
        assert_eq!("2/8".parse::<Shard>().unwrap().to_string(), "2/8");
    }

    #[test]
    fn the_cells_of_a_classifier_and_d_chain_by_n_slip_with_or_without_a_search() {
        let mut spec = SweepSpec {
            classifiers: vec![ClassifierKind::Logreg, ClassifierKind::SvmRbf],
            downsample: vec![0.5, 1.0],
            n_slip: vec![3, 1, 2],
            scope: Scope::Global,
            hyper: HyperChoice::Fixed(Hyperparameters::default()),
            seed: 0,
        };
        let chains = spec.chains();
        // a chain per classifier and d
        assert_eq!(chains.len(), 4);
        // costliest first: the RBF SVM at d 1
        assert_eq!(chains[0][0].classifier, ClassifierKind::SvmRbf);
        assert_eq!(chains[0][0].downsample, 1.0);
        for chain in &chains {
            assert_eq!(
                chain.iter().map(|c| c.n_slip).collect::<Vec<_>>(),
                vec![1, 2, 3]
            );
            assert!(chain.iter().all(|c| c.classifier == chain[0].classifier
                && c.downsample.to_bits() == chain[0].downsample.to_bits()));
        }
        spec.hyper = HyperChoice::Search {
            iterations: 2,
            folds: 2,
            ranges: tuning::SearchRanges::default(),
            max_fit_rows: None,
            held_out: tuning::HeldOutRows::Every,
        };
        assert_eq!(spec.chains(), chains);
        spec.classifiers.push(ClassifierKind::Threshold);
        // a threshold has no solution to start from: its cells run alone
        let chains = spec.chains();
        assert_eq!(chains.len(), 4 + 6);
        assert_eq!(chains.iter().filter(|c| c.len() == 1).count(), 6);
    }

    #[test]
    fn a_cells_cost_grows_with_its_rows_and_its_search() {
        let mut spec = SweepSpec {
            classifiers: vec![ClassifierKind::SvmRbf, ClassifierKind::Threshold],
            downsample: vec![0.1, 1.0],
            n_slip: vec![13],
            scope: Scope::Global,
            hyper: HyperChoice::Fixed(Hyperparameters {
                c: 1.0,
                gamma: 0.1,
                max_iterations: None,
            }),
            seed: 1,
        };
        let cell = |classifier, downsample| Cell {
            classifier,
            n_slip: 13,
            downsample,
        };
        let rbf =
            |spec: &SweepSpec, d| spec.cell_cost(&cell(ClassifierKind::SvmRbf, d), 1400, 150_000);
        // the measured cells of the step-by-step pipeline's grid: 3.7 s at d 0.1 and 36 s at d 1.0
        assert!((rbf(&spec, 0.1) - 3.7).abs() < 0.5, "{}", rbf(&spec, 0.1));
        assert!((rbf(&spec, 1.0) - 36.0).abs() < 3.0, "{}", rbf(&spec, 1.0));
        let threshold = spec.cell_cost(&cell(ClassifierKind::Threshold, 1.0), 1400, 150_000);
        assert!(threshold < rbf(&spec, 0.1) / 5.0);
        spec.hyper = HyperChoice::Search {
            iterations: 12,
            folds: 3,
            ranges: tuning::SearchRanges::default(),
            max_fit_rows: Some(4000),
            held_out: tuning::HeldOutRows::Every,
        };
        // 36 fits of 4000 rows on top of the final fit; the threshold has nothing to search
        let searched = rbf(&spec, 1.0);
        assert!(
            (searched - 36.0 - 36.0 * 4000.0 * 2.3e-4).abs() < 3.0,
            "{searched}"
        );
        assert_eq!(
            spec.cell_cost(&cell(ClassifierKind::Threshold, 1.0), 1400, 150_000),
            threshold
        );
        // the time left follows the cost left, at the rate of the whole run so far
        let costs = CellCosts {
            total: 100.0,
            ..Default::default()
        };
        assert_eq!(costs.eta_s(10.0, 0.0), None);
        assert_eq!(costs.eta_s(30.0, 25.0), Some(90.0));
        assert_eq!(costs.eta_s(60.0, 100.0), Some(0.0));
    }

    #[test]
    fn cells_cover_the_grid_costliest_first() {
        let spec = SweepSpec {
            classifiers: vec![ClassifierKind::Threshold, ClassifierKind::SvmRbf],
            downsample: vec![0.2, 1.0],
            n_slip: vec![1, 13],
            scope: Scope::Global,
            hyper: HyperChoice::Fixed(Hyperparameters::default()),
            seed: 0,
        };
        spec.check().unwrap();
        let cells = spec.cells();
        assert_eq!(cells.len(), 8);
        assert_eq!(cells[0].classifier, ClassifierKind::SvmRbf);
        assert_eq!(cells[0].downsample, 1.0);
        assert_eq!(cells[7].classifier, ClassifierKind::Threshold);
        let bad = SweepSpec {
            downsample: vec![0.0],
            ..spec.clone()
        };
        assert!(matches!(bad.check(), Err(SweepError::Downsample(_))));
        let bad = SweepSpec {
            n_slip: vec![],
            ..spec
        };
        assert!(matches!(bad.check(), Err(SweepError::EmptyGrid(_))));
    }

    /// Rows far apart for slip, with slip-frame counts as trials would give them.
    fn toy(trials: u32) -> Dataset {
        let mut ds = Dataset {
            dim: 2,
            trial_ids: (0..trials).map(|t| format!("t{t}")).collect(),
            ..Default::default()
        };
        for t in 0..trials {
            for i in 0..80u32 {
                let slip_frame = i.saturating_sub(59); // frames 60.. are slip frames 1..20
                let v = if slip_frame > 0 { 3.0 } else { 0.0 } + (i % 7) as f32 * 0.1;
                ds.x.extend_from_slice(&[v, -v]);
                ds.y.push(if slip_frame > 0 {
                    super::super::Class::Slip
                } else {
                    super::super::Class::Static
                });
                ds.slip_frame.push(slip_frame);
                ds.trial.push(t);
                ds.sensor.push(0);
                ds.seq.push(i as u64);
                ds.time_s.push(i as f64 / 60.0);
            }
        }
        ds
    }

    #[test]
    fn a_resumed_search_sweep_refits_finished_cells_at_their_recorded_point_unsearched() {
        let (train, test) = (toy(4), toy(2));
        let spec = SweepSpec {
            classifiers: vec![ClassifierKind::SvmRbf],
            downsample: vec![0.5],
            n_slip: vec![2, 4, 6],
            scope: Scope::Global,
            hyper: HyperChoice::Search {
                iterations: 3,
                folds: 2,
                ranges: tuning::SearchRanges::default(),
                max_fit_rows: None,
                held_out: tuning::HeldOutRows::Every,
            },
            seed: 5,
        };
        let strip = |mut rows: Vec<SweepRow>| {
            rows.iter_mut().for_each(|r| r.seconds = 0.0);
            sort_rows(&mut rows, &["svm-rbf".into()]);
            rows
        };
        let whole = strip(run_sweep(&train, &test, &spec, |_| {}).unwrap());
        assert_eq!(whole.len(), 3);
        // the first two cells finished before an interruption
        let finished: HashMap<_, _> = whole[..2]
            .iter()
            .map(|r| (r.key(), r.hyperparameters()))
            .collect();
        let rest = run_chains_until(
            &train,
            &test,
            &spec,
            &spec.chains(),
            &finished,
            None,
            |_| {},
        );
        assert_eq!(strip(rest.unwrap()), whole[2..]);
        // a finished cell is fitted at its recorded point, with no search
        let odd = Hyperparameters {
            c: 0.37,
            gamma: 0.29,
            max_iterations: None,
        };
        let cell = spec.chains()[0][0];
        let (fitted, _) = fit_cell(&train, &spec, cell, &[], Some(odd)).unwrap();
        assert_eq!((fitted.hyper, fitted.cv_macro_f1), (odd, None));
        let (searched, _) = fit_cell(&train, &spec, cell, &[], None).unwrap();
        assert_eq!(Some(searched.hyper.c), whole[0].c);
        assert!(searched.cv_macro_f1.is_some());
    }

    #[test]
    fn a_sweep_scores_every_cell_on_the_whole_test_set() {
        let (train, test) = (toy(4), toy(2));
        let spec = SweepSpec {
            classifiers: vec![ClassifierKind::Logreg, ClassifierKind::Threshold],
            downsample: vec![0.5, 1.0],
            n_slip: vec![2, 10],
            scope: Scope::Global,
            hyper: HyperChoice::Fixed(Hyperparameters {
                c: 1.0,
                gamma: 0.0,
                max_iterations: None,
            }),
            seed: 1,
        };
        let seen = std::sync::atomic::AtomicUsize::new(0);
        let rows = run_sweep(&train, &test, &spec, |_| {
            seen.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        })
        .unwrap();
        assert_eq!(rows.len(), 8);
        assert_eq!(seen.into_inner(), 8);
        for r in &rows {
            // test rows: 2 trials x (60 static rows + n_slip slip rows), never down-sampled
            assert_eq!(r.test_rows, 2 * (60 + r.n_slip), "{r:?}");
            assert_eq!(r.train_slip_rows, 4 * r.n_slip);
            assert!(r.macro_f1 > 0.9, "{r:?}");
            // a row names only the hyperparameters its classifier has
            assert_eq!(r.gamma, None);
            match r.classifier.as_str() {
                "logreg" => assert_eq!(r.c, Some(1.0)),
                _ => assert_eq!(r.c, None),
            }
        }
    }
}
