//! The threshold classifier (paper, "Threshold Classifier"): slip when the norm of the mean
//! pin velocity `v` reaches `T`. `T` is the best (by macro F1 on the training data) of ten
//! values evenly spaced between the mean `v` of the static frames and that of the slip frames.

use super::features::mean_velocity_norm;
use super::Class;

#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ThresholdModel {
    /// px per frame
    pub threshold: f32,
}

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ThresholdError {
    #[error(
        "training data needs frames of both classes (static {static_frames}, slip {slip_frames})"
    )]
    OneClass {
        static_frames: usize,
        slip_frames: usize,
    },
}

impl ThresholdModel {
    /// Fits on feature rows (each `2N` values) and their labels: the threshold on the norm
    /// of each row's mean pin velocity (`tmo_learn::threshold`).
    pub fn fit(rows: &[&[f32]], labels: &[Class]) -> Result<Self, ThresholdError> {
        let v: Vec<f32> = rows.iter().map(|r| mean_velocity_norm(r)).collect();
        tmo_learn::threshold::fit_threshold(&v, labels)
            .map(|threshold| Self { threshold })
            .map_err(|e| match e {
                tmo_learn::threshold::ThresholdError::OneClass { negative, positive } => {
                    ThresholdError::OneClass {
                        static_frames: negative,
                        slip_frames: positive,
                    }
                }
            })
    }

    pub fn predict(&self, features: &[f32]) -> Class {
        if mean_velocity_norm(features) >= self.threshold {
            Class::Slip
        } else {
            Class::Static
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One-pin feature rows with speed `r` (angle 0 after centring).
    fn row(r: f32) -> Vec<f32> {
        vec![r, 0.0]
    }

    #[test]
    fn picks_a_threshold_between_the_class_means_that_separates_them() {
        let speeds = [0.1, 0.2, 0.1, 0.15, 1.0, 1.2];
        let labels = [
            Class::Static,
            Class::Static,
            Class::Static,
            Class::Static,
            Class::Slip,
            Class::Slip,
        ];
        let rows: Vec<Vec<f32>> = speeds.iter().map(|&s| row(s)).collect();
        let refs: Vec<&[f32]> = rows.iter().map(|r| r.as_slice()).collect();
        let m = ThresholdModel::fit(&refs, &labels).unwrap();
        assert!(m.threshold > 0.2 && m.threshold <= 1.0, "{}", m.threshold);
        assert_eq!(m.predict(&row(0.9)), Class::Slip);
        assert_eq!(m.predict(&row(0.18)), Class::Static);
    }

    #[test]
    fn one_class_is_an_error() {
        let rows = [row(0.1)];
        let refs: Vec<&[f32]> = rows.iter().map(|r| r.as_slice()).collect();
        assert!(ThresholdModel::fit(&refs, &[Class::Static]).is_err());
    }
}
