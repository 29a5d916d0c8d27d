//! Splitting a sweep's grid or a batch's trials into parts run by separate processes.

/// A deterministic part of a grid, for running one sweep or batch over several processes
/// or cluster jobs: shard `index` of `count` (1-based) takes the items at positions
/// `index - 1`, `index - 1 + count`, ... A sweep's chains of cells come costliest first and
/// a batch's trials cycle through its grid, so every shard gets a like share of the work.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    pub index: usize,
    pub count: usize,
}

impl std::str::FromStr for Shard {
    type Err = ShardError;

    fn from_str(text: &str) -> Result<Self, ShardError> {
        let err = || ShardError(text.to_string());
        let (k, n) = text.split_once('/').ok_or_else(err)?;
        let (index, count) = (
            k.trim().parse::<usize>().map_err(|_| err())?,
            n.trim().parse::<usize>().map_err(|_| err())?,
        );
        if index == 0 || index > count {
            return Err(err());
        }
        Ok(Shard { index, count })
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

impl Shard {
    /// This shard's part of `items`.
    pub fn select<T>(&self, items: Vec<T>) -> Vec<T> {
        items
            .into_iter()
            .enumerate()
            .filter(|(i, _)| i % self.count == self.index - 1)
            .map(|(_, c)| c)
            .collect()
    }
}

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("`{0}`: expected K/N with 1 <= K <= N, e.g. 2/8")]
pub struct ShardError(pub String);
