//! Standardisation fitted on training data only and stored in the model: each feature
//! minus its mean, divided by its standard deviation (population, as scikit-learn's
//! StandardScaler; a constant feature is divided by 1).

#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Scaler {
    pub mean: Vec<f64>,
    pub scale: Vec<f64>,
}

impl Scaler {
    /// Fits on row-major `x`, `dim` wide.
    pub fn fit(dim: usize, x: &[f32]) -> Self {
        let n = (x.len() / dim.max(1)).max(1) as f64;
        let mut mean = vec![0.0f64; dim];
        for row in x.chunks_exact(dim) {
            for (m, v) in mean.iter_mut().zip(row) {
                *m += f64::from(*v);
            }
        }
        mean.iter_mut().for_each(|m| *m /= n);
        let mut var = vec![0.0f64; dim];
        for row in x.chunks_exact(dim) {
            for ((s, v), m) in var.iter_mut().zip(row).zip(&mean) {
                let d = f64::from(*v) - m;
                *s += d * d;
            }
        }
        let scale = var
            .iter()
            .map(|v| (v / n).sqrt())
            .map(|s| if s < 1e-12 { 1.0 } else { s })
            .collect();
        Self { mean, scale }
    }

    pub fn transform_into(&self, row: &[f32], out: &mut [f32]) {
        for (((o, v), m), s) in out.iter_mut().zip(row).zip(&self.mean).zip(&self.scale) {
            *o = ((f64::from(*v) - m) / s) as f32;
        }
    }

    /// Scales every row of row-major `x`.
    pub fn transform(&self, x: &[f32]) -> Vec<f32> {
        let dim = self.mean.len();
        let mut out = vec![0.0; x.len()];
        for (row, o) in x.chunks_exact(dim).zip(out.chunks_exact_mut(dim)) {
            self.transform_into(row, o);
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn standardises_columns_and_leaves_constants_centred() {
        let x = [1.0, 5.0, 3.0, 5.0];
        let s = Scaler::fit(2, &x);
        assert_eq!(s.mean, vec![2.0, 5.0]);
        assert_eq!(s.scale, vec![1.0, 1.0]);
        let x = [0.0, 1.0, 4.0, 1.0];
        let s = Scaler::fit(2, &x);
        assert_eq!(s.transform(&x), vec![-1.0, 0.0, 1.0, 0.0]);
    }
}
