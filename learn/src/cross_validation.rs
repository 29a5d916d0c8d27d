//! Folds by group (scikit-learn's `GroupKFold`, shuffled): rows of one group, e.g. the
//! frames of one recorded trial, never sit on both sides of a fold.

use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FoldError {
    #[error(
        "--folds {0}: expected at least 2 (each fold is scored by a model trained on the others)"
    )]
    Folds(usize),
    #[error("cross-validation needs at least {folds} groups, got {groups}")]
    TooFewGroups { folds: usize, groups: usize },
}

/// The fold of each group id (indexed by the id) for `folds` folds: the distinct ids of
/// `groups` are shuffled by `seed` and dealt out in turn, so fold sizes differ by at most
/// one group.
pub fn group_folds(groups: &[u32], folds: usize, seed: u64) -> Result<Vec<usize>, FoldError> {
    if folds < 2 {
        return Err(FoldError::Folds(folds));
    }
    let mut ids: Vec<u32> = groups.to_vec();
    ids.sort_unstable();
    ids.dedup();
    if ids.len() < folds {
        return Err(FoldError::TooFewGroups {
            folds,
            groups: ids.len(),
        });
    }
    ids.shuffle(&mut ChaCha8Rng::seed_from_u64(seed));
    let mut fold_of = vec![0; groups.iter().max().map_or(0, |g| *g as usize + 1)];
    for (position, id) in ids.iter().enumerate() {
        fold_of[*id as usize] = position % folds;
    }
    Ok(fold_of)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_group_lands_in_one_fold_and_the_folds_are_even() {
        let groups: Vec<u32> = (0..7).flat_map(|g| [g; 3]).collect();
        let fold_of = group_folds(&groups, 3, 1).unwrap();
        let mut sizes = [0; 3];
        for g in 0..7 {
            sizes[fold_of[g]] += 1;
        }
        assert!(sizes.iter().all(|s| (2..=3).contains(s)), "{sizes:?}");
        // seeded: the same seed deals the same way
        assert_eq!(fold_of, group_folds(&groups, 3, 1).unwrap());
    }

    #[test]
    fn too_few_groups_or_folds_are_errors() {
        assert_eq!(
            group_folds(&[0, 1], 3, 0),
            Err(FoldError::TooFewGroups {
                folds: 3,
                groups: 2
            })
        );
        assert_eq!(group_folds(&[0, 1, 2], 1, 0), Err(FoldError::Folds(1)));
    }
}
