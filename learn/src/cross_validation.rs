//! Folds by group: rows of one group, e.g. the frames of one recorded trial, never sit on
//! both sides of a fold. Two ways to assign groups: dealt out shuffled by a seed
//! ([`group_folds`], scikit-learn's `GroupKFold(shuffle=True)` in spirit), or as scikit-learn's
//! unshuffled `GroupKFold` assigns them ([`group_k_fold`]), for a search that must pick what
//! `GridSearchCV(cv=GroupKFold(k))` picks on the same rows.

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

/// The fold of each group id (indexed by the id) as scikit-learn's `GroupKFold(folds)`
/// assigns them (shuffle off): the groups in decreasing order of their row count, each to
/// the fold holding the fewest rows so far (the first such fold on a tie). Groups of equal
/// size go in reverse order of their labels, as `GroupKFold`'s stable sort of `np.unique`'s
/// sorted labels, reversed, puts them: `label_order` lists every distinct id of `groups`
/// once, in its label's sorted order. No seed: the split is a function of the sizes alone.
pub fn group_k_fold(
    groups: &[u32],
    folds: usize,
    label_order: &[u32],
) -> Result<Vec<usize>, FoldError> {
    if folds < 2 {
        return Err(FoldError::Folds(folds));
    }
    if label_order.len() < folds {
        return Err(FoldError::TooFewGroups {
            folds,
            groups: label_order.len(),
        });
    }
    let slots = groups.iter().max().map_or(0, |g| *g as usize + 1);
    let mut rows = vec![0usize; slots];
    for g in groups {
        rows[*g as usize] += 1;
    }
    // np.argsort(sizes, kind="stable")[::-1]: by size descending, ties latest label first
    let mut by_size: Vec<(usize, u32)> = label_order
        .iter()
        .enumerate()
        .map(|(rank, id)| (rank, *id))
        .collect();
    by_size.sort_by(|a, b| {
        rows[b.1 as usize]
            .cmp(&rows[a.1 as usize])
            .then(b.0.cmp(&a.0))
    });
    let mut fold_rows = vec![0usize; folds];
    let mut fold_of = vec![0; slots];
    for (_, id) in by_size {
        // np.argmin: the first of the lightest
        let lightest = (0..folds)
            .min_by_key(|f| (fold_rows[*f], *f))
            .expect("at least two folds");
        fold_rows[lightest] += rows[id as usize];
        fold_of[id as usize] = lightest;
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
        assert_eq!(
            group_k_fold(&[0, 1, 2], 1, &[0, 1, 2]),
            Err(FoldError::Folds(1))
        );
        assert_eq!(
            group_k_fold(&[0, 1], 3, &[0, 1]),
            Err(FoldError::TooFewGroups {
                folds: 3,
                groups: 2
            })
        );
    }

    /// The assignment scikit-learn 1.9's `GroupKFold(3)` makes: groups labelled a..g with
    /// 5, 9, 3, 9, 4, 1, 4 rows (ids 0..6 in label order) go to folds
    /// [2, 1, 1, 0, 0, 2, 2] (`GroupKFold(3).split(X, groups=labels)`, read back per group).
    /// The two 9s and the two 4s are the ties: the later label goes first.
    #[test]
    fn groups_are_assigned_as_scikit_learns_group_k_fold() {
        let sizes = [5, 9, 3, 9, 4, 1, 4];
        let groups: Vec<u32> = sizes
            .iter()
            .enumerate()
            .flat_map(|(g, n)| std::iter::repeat_n(g as u32, *n))
            .collect();
        let order: Vec<u32> = (0..7).collect();
        assert_eq!(
            group_k_fold(&groups, 3, &order).unwrap(),
            [2, 1, 1, 0, 0, 2, 2]
        );
        // the ids' own numbering does not matter, only their labels' order
        let renumbered: Vec<u32> = groups.iter().map(|g| 6 - g).collect();
        let reversed: Vec<u32> = (0..7).rev().collect();
        let by_label = group_k_fold(&renumbered, 3, &reversed).unwrap();
        assert_eq!(
            (0..7).map(|g| by_label[6 - g]).collect::<Vec<_>>(),
            [2, 1, 1, 0, 0, 2, 2]
        );
    }
}
