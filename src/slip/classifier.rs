//! Which classifier, and its hyperparameters: what a model file, a search and a sweep cell
//! name a fit by.

use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum ClassifierKind {
    SvmRbf,
    SvmLinear,
    Logreg,
    Threshold,
}

impl ClassifierKind {
    /// Whether the classifier has a regularisation constant C (the threshold has none).
    pub fn uses_c(&self) -> bool {
        *self != ClassifierKind::Threshold
    }

    /// Whether the classifier has a kernel width gamma (only the RBF SVM).
    pub fn uses_gamma(&self) -> bool {
        *self == ClassifierKind::SvmRbf
    }

    pub fn name(&self) -> &'static str {
        match self {
            ClassifierKind::SvmRbf => "svm-rbf",
            ClassifierKind::SvmLinear => "svm-linear",
            ClassifierKind::Logreg => "logreg",
            ClassifierKind::Threshold => "threshold",
        }
    }
}

/// Hyperparameters of one fit; which ones apply depends on the classifier.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Hyperparameters {
    /// Absent from model files of the threshold, which has none (the default is then kept).
    #[serde(default = "paper_c")]
    pub c: f64,
    /// Absent from model files of every classifier but the RBF SVM (the default is then kept).
    #[serde(default = "paper_gamma")]
    pub gamma: f64,
    /// Cap on the SVM solver's iterations (`None`: for the RBF kernel's SMO, libsvm's
    /// `max(100 n, 10^7)` pair steps; for the linear kernel's interior-point method, 200
    /// Newton steps). A fit that reaches it is approximate and says so (`unconverged_gap`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_iterations: Option<usize>,
}

/// The RBF kernel's gamma when none is given: one over the number of features, which is
/// scikit-learn's `gamma = "scale"` for standardised features (each of variance 1). The
/// paper's 1.104 was chosen for its own feature scaling; on tmo's standardised 60 features it
/// makes every training row a support vector and the model never detects slip.
pub fn scale_gamma(features: usize) -> f64 {
    1.0 / features.max(1) as f64
}

/// The paper's best single-finger SVM's C.
fn paper_c() -> f64 {
    3.989
}

/// The paper's best single-finger SVM's gamma.
fn paper_gamma() -> f64 {
    1.104
}

impl Default for Hyperparameters {
    /// The paper's best single-finger SVM.
    fn default() -> Self {
        Self {
            c: paper_c(),
            gamma: paper_gamma(),
            max_iterations: None,
        }
    }
}
