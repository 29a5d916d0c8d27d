//! Starting a fit from a neighbouring fit's solution (the bookkeeping is
//! [`tmo_learn::warm`]'s; here is which tactile rows are the same row).
//!
//! A sweep's cells of one classifier and one down-sampling `d` differ only in `n_slip`, and
//! their training rows are nested: the static rows are the same seeded draw, and cell `k`'s
//! slip rows are cell `k + 1`'s without the `(k + 1)`-th frame of each onset. So cell `k`'s
//! solution is a good start for cell `k + 1`.

use super::dataset::Dataset;

/// A training row's identity across datasets cut from the same trials: trial, sensor,
/// frame sequence number.
pub type RowKey = (u32, u8, u64);

/// A fit's solution keyed by [`RowKey`].
pub type WarmStart = tmo_learn::warm::WarmStart<RowKey>;
pub use tmo_learn::warm::SvmRow;

/// Each of `data`'s rows' identity, in row order.
pub fn row_keys(data: &Dataset) -> impl Iterator<Item = RowKey> + '_ {
    (0..data.len()).map(|i| (data.trial[i], data.sensor[i], data.seq[i]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::slip::Class;
    use tmo_learn::svm::DualStart;

    fn rows(keys: &[(u32, u8, u64)]) -> Dataset {
        let mut d = Dataset {
            dim: 1,
            trial_ids: vec!["a".into(), "b".into()],
            ..Default::default()
        };
        for &(t, s, q) in keys {
            d.x.push(0.0);
            d.y.push(Class::Static);
            d.trial.push(t);
            d.sensor.push(s);
            d.seq.push(q);
            d.time_s.push(0.0);
        }
        d
    }

    #[test]
    fn a_row_is_the_same_row_by_trial_sensor_and_frame() {
        let before = rows(&[(0, 0, 1), (0, 1, 1), (1, 0, 7)]);
        let solved = DualStart::from_alpha(vec![0.5, 0.0, 2.0]);
        let start = WarmStart::svm(row_keys(&before), &solved);
        // Same trial and frame, another sensor: another row.
        let after = rows(&[(1, 0, 7), (1, 1, 7), (0, 0, 1)]);
        let got = start.svm_start_for(row_keys(&after)).unwrap();
        assert_eq!(got.alpha, vec![2.0, 0.0, 0.5]);
    }
}
