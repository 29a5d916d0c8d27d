//! Binary classifiers as the slip detector of `tmo` uses them, with nothing of slip or
//! touch in them: rows in (row-major `f32`, `dim` values a row), labels in (anything that
//! is [`Label`]), models out.
//!
//! - [`svm`]: C-SVC with an RBF or a linear kernel, as libsvm (and so scikit-learn's `SVC`)
//!   defines it, solved by SMO (RBF) or an interior-point method (linear), with warm starts.
//! - [`logreg`]: L2-regularised logistic regression by Newton's method, as scikit-learn's
//!   `LogisticRegression(solver="newton-cholesky")`.
//! - [`scaler`]: per-column standardisation, as `StandardScaler`.
//! - [`bayes`]: Bayesian optimisation of a black-box score over a box in log space.
//! - [`cholesky`]: the dense factorisation the last two solve with.
//! - [`threshold`]: a threshold on one score per row, as a baseline classifier.
//! - [`metrics`]: precision, recall, F1 and macro F1 of a binary classifier.
//! - [`cross_validation`]: folds by group, so one group's rows never sit on both sides.
//! - [`warm`]: a fit's solution carried row by row to a neighbouring fit's start.
//!
//! Hyperparameters are checked before a fit (`SvmParams::check`, `LogRegParams::check`),
//! as linfa does: a fit only takes checked ones.

pub mod bayes;
pub mod cholesky;
pub mod cross_validation;
pub mod logreg;
pub mod metrics;
pub mod scaler;
pub mod svm;
pub mod threshold;
pub mod warm;

/// A binary label: the classifiers learn to tell rows of the positive class from the rest,
/// and predict `true` for the positive class.
pub trait Label: Copy {
    fn is_positive(self) -> bool;
    fn from_positive(positive: bool) -> Self;
}

impl Label for bool {
    fn is_positive(self) -> bool {
        self
    }

    fn from_positive(positive: bool) -> Self {
        positive
    }
}
