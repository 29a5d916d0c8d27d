//! Rows of Q (`Q_ij = y_i y_j K(x_i, x_j)`) whose use is known ahead: a warm start's and a
//! gradient reconstruction's. They are computed many at a time in one pass over the
//! training rows (see [`Rows::dots_many`]), not one at a time through the solver's cache,
//! and they are not cached: such work reads each row once.

use std::ops::Range;

use rayon::prelude::*;

use super::kernel::{Kernel, Rows, BLOCK};

/// Rows computed together in one pass over the training rows: more rows a pass read the
/// training rows fewer times.
pub(super) const ROWS_PER_PASS: usize = 64;

/// Below this many multiply-adds (a row of about 70k entries at 60 features, half a
/// millisecond) kernel values are computed on one thread: waking another thread for them
/// cost more than it saved. Measured with 2 threads (`cargo bench -p tmo-learn --bench svm_speed`): at
/// 64k multiply-adds, 20k rows fitted in 0.59 s and 61k in 4.74 s; at 4M, 0.53 s and 4.64 s.
pub(super) const PARALLEL_WORK: usize = 4 << 20;

/// Columns a parallel piece of work covers.
const PIECE: usize = 8 * BLOCK;

/// Where the pieces of `columns` start: a possibly partial first block, then [`PIECE`]
/// columns each from a block boundary.
fn piece_starts(columns: Range<usize>) -> Vec<usize> {
    let head = ((BLOCK - columns.start % BLOCK) % BLOCK).min(columns.len());
    let mut starts = if head > 0 {
        vec![columns.start]
    } else {
        Vec::new()
    };
    starts.extend((columns.start + head..columns.end).step_by(PIECE));
    starts
}

/// Splits `out` (one value per column of `columns`) at the pieces `starts`.
fn split_at_pieces<'a, T>(mut out: &'a mut [T], starts: &[usize], end: usize) -> Vec<&'a mut [T]> {
    let mut pieces = Vec::with_capacity(starts.len());
    for (p, &start) in starts.iter().enumerate() {
        let stop = starts.get(p + 1).copied().unwrap_or(end);
        let (piece, tail) = out.split_at_mut(stop - start);
        pieces.push(piece);
        out = tail;
    }
    pieces
}

/// Rows `targets` of Q, their entries in `columns` each.
pub(super) fn q_rows(
    rows: &Rows,
    y: &[i8],
    kernel: Kernel,
    targets: &[usize],
    columns: Range<usize>,
) -> Vec<Vec<f32>> {
    let len = columns.len();
    // Allocated zeroed, not cloned: a clone would write every buffer once more.
    let mut bufs: Vec<Vec<f32>> = targets.iter().map(|_| vec![0.0f32; len]).collect();
    let starts = piece_starts(columns.clone());
    // pieces[p]: every target's slice of piece p's columns.
    let mut pieces: Vec<Vec<&mut [f32]>> = starts.iter().map(|_| Vec::new()).collect();
    for buf in bufs.iter_mut() {
        for (p, piece) in split_at_pieces(buf, &starts, columns.end)
            .into_iter()
            .enumerate()
        {
            pieces[p].push(piece);
        }
    }
    let compute = |outs: &mut Vec<&mut [f32]>, &at: &usize| {
        kernel_rows_chunk(rows, y, kernel, targets, at, outs)
    };
    if targets.len() * len * rows.dim >= PARALLEL_WORK {
        pieces
            .par_iter_mut()
            .zip(&starts)
            .for_each(|(outs, at)| compute(outs, at));
    } else {
        pieces
            .iter_mut()
            .zip(&starts)
            .for_each(|(outs, at)| compute(outs, at));
    }
    bufs
}

/// One sum for [`add_q_products`]: `out[k] += sum over t of coefs[t] Q(targets[t], k)`.
pub(super) struct Sum<'a> {
    pub coefs: &'a [f64],
    pub out: &'a mut [f64],
}

/// Adds to each sum's `out` (one value per column of `columns`) its coefficients times the
/// rows `targets` of Q. Every entry adds the targets' terms in their order, skipping zero
/// coefficients, so it is what adding [`q_rows`]'s rows one after another gives, to the bit.
///
/// The values are computed [`ROWS_PER_PASS`] targets by [`PIECE`] columns at a time into a
/// small buffer and added at once, never stored whole: 64 rows of 151k columns would be
/// 37 MB written and read back, and a reconstruction of the gradient at that size (4,900
/// free rows) took 2.3 s that way. With AVX-512, RBF values go straight into the sums
/// ([`fused`]).
pub(super) fn add_q_products(
    rows: &Rows,
    y: &[i8],
    kernel: Kernel,
    targets: &[usize],
    columns: Range<usize>,
    sums: &mut [Sum],
) {
    add_q_products_with(rows, y, kernel, targets, columns, sums, true)
}

/// [`add_q_products`], through [`fused`] only where `may_fuse` (tests check both ways).
fn add_q_products_with(
    rows: &Rows,
    y: &[i8],
    kernel: Kernel,
    targets: &[usize],
    columns: Range<usize>,
    sums: &mut [Sum],
    may_fuse: bool,
) {
    let starts = piece_starts(columns.clone());
    let coefs: Vec<&[f64]> = sums.iter().map(|s| s.coefs).collect();
    // pieces[p]: every sum's slice of piece p's columns.
    let mut pieces: Vec<Vec<&mut [f64]>> = starts.iter().map(|_| Vec::new()).collect();
    for sum in sums.iter_mut() {
        assert_eq!(sum.coefs.len(), targets.len(), "one coefficient per target");
        assert_eq!(sum.out.len(), columns.len(), "one output per column");
        for (p, piece) in split_at_pieces(&mut *sum.out, &starts, columns.end)
            .into_iter()
            .enumerate()
        {
            pieces[p].push(piece);
        }
    }
    #[cfg(target_arch = "x86_64")]
    let fused = may_fuse
        && matches!(kernel, Kernel::Rbf { .. })
        && coefs.len() <= 2
        && std::arch::is_x86_feature_detected!("avx512f");
    let work = |values: &mut Vec<f32>, outs: &mut Vec<&mut [f64]>, &at: &usize| {
        let Some(len) = outs.first().map(|o| o.len()) else {
            return;
        };
        #[cfg(target_arch = "x86_64")]
        if fused {
            let Kernel::Rbf { gamma } = kernel else {
                unreachable!("checked")
            };
            // SAFETY: the CPU has the features the function is compiled for.
            return unsafe {
                fused::add_rbf_products(rows, y, gamma as f32, targets, &coefs, at, outs)
            };
        }
        for (b, batch) in targets.chunks(ROWS_PER_PASS).enumerate() {
            values.resize(ROWS_PER_PASS * len, 0.0);
            let mut qs: Vec<&mut [f32]> = values.chunks_mut(len).take(batch.len()).collect();
            kernel_rows_chunk(rows, y, kernel, batch, at, &mut qs);
            for (out, coefs) in outs.iter_mut().zip(&coefs) {
                for (&c, q) in coefs[b * ROWS_PER_PASS..].iter().zip(&qs) {
                    if c != 0.0 {
                        for (o, v) in out.iter_mut().zip(q.iter()) {
                            *o += c * f64::from(*v);
                        }
                    }
                }
            }
        }
    };
    if targets.len() * columns.len() * rows.dim >= PARALLEL_WORK {
        pieces
            .par_iter_mut()
            .zip(&starts)
            .for_each_init(Vec::new, |values, (outs, at)| work(values, outs, at));
    } else {
        let mut values = Vec::new();
        for (outs, at) in pieces.iter_mut().zip(&starts) {
            work(&mut values, outs, at);
        }
    }
}

/// `outs[t][k] = Q(targets[t], from + k)`: dot products by blocks of rows, then the kernel
/// and the label signs in one pass. Compiled for AVX2 and FMA where the CPU has them.
fn kernel_rows_chunk(
    rows: &Rows,
    y: &[i8],
    kernel: Kernel,
    targets: &[usize],
    from: usize,
    outs: &mut [&mut [f32]],
) {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
        {
            // SAFETY: the CPU has the features the function is compiled for.
            return unsafe { kernel_rows_chunk_avx2(rows, y, kernel, targets, from, outs) };
        }
    }
    kernel_rows_chunk_portable(rows, y, kernel, targets, from, outs)
}

#[inline(always)]
fn kernel_rows_chunk_portable(
    rows: &Rows,
    y: &[i8],
    kernel: Kernel,
    targets: &[usize],
    from: usize,
    outs: &mut [&mut [f32]],
) {
    let xs: Vec<&[f32]> = targets.iter().map(|&i| rows.row(i)).collect();
    rows.dots_many(&xs, from, outs);
    for (&i, out) in targets.iter().zip(outs.iter_mut()) {
        let (ni, yi) = (rows.norms[i], f32::from(y[i]));
        for (k, v) in out.iter_mut().enumerate() {
            let j = from + k;
            *v = yi * f32::from(y[j]) * kernel.from_dot(*v, ni, rows.norms[j]) as f32;
        }
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn kernel_rows_chunk_avx2(
    rows: &Rows,
    y: &[i8],
    kernel: Kernel,
    targets: &[usize],
    from: usize,
    outs: &mut [&mut [f32]],
) {
    kernel_rows_chunk_portable(rows, y, kernel, targets, from, outs)
}

/// [`add_q_products`] for the RBF kernel with AVX-512, from dot products to sums without
/// storing the kernel values: for 32 columns at a time, the sums' values stay in registers
/// while every target passes, eight targets' dot products at a time. Why: computed apart,
/// each value of Q was written and read back twice (the kernel pass, then the sums), and
/// those passes took half as long as the dot products (perf, the fixed grid's RBF cells at
/// d 0.3 and 0.7). Measured whole, RBF d 0.7 n_slip 1-8: 30.0 -> 29.1 s of CPU, as the
/// dot products, not the passes, set the pace. Each value is computed by the
/// same operations as [`kernel_rows_chunk_portable`]'s and added in target order, skipping
/// zero coefficients, so the sums are bit-identical.
#[cfg(target_arch = "x86_64")]
mod fused {
    use super::super::kernel::{exp_nonpositive, wide_dots, Rows, BLOCK, WIDE_COLUMNS, WIDE_ROWS};

    /// Targets whose dot products are computed together.
    const GROUP: usize = WIDE_ROWS;
    /// Columns whose sums stay in registers.
    const TILE: usize = WIDE_COLUMNS;

    /// `outs[s][k] += sum over t of coefs[s][t] Q(targets[t], from + k)`, at most two sums.
    #[target_feature(enable = "avx512f")]
    pub(super) fn add_rbf_products(
        rows: &Rows,
        y: &[i8],
        gamma: f32,
        targets: &[usize],
        coefs: &[&[f64]],
        from: usize,
        outs: &mut [&mut [f64]],
    ) {
        match outs.len() {
            1 => add_products::<1>(rows, y, gamma, targets, coefs, from, outs),
            2 => add_products::<2>(rows, y, gamma, targets, coefs, from, outs),
            _ => unreachable!("one or two sums"),
        }
    }

    #[target_feature(enable = "avx512f")]
    fn add_products<const S: usize>(
        rows: &Rows,
        y: &[i8],
        gamma: f32,
        targets: &[usize],
        coefs: &[&[f64]],
        from: usize,
        outs: &mut [&mut [f64]],
    ) {
        let n = rows.len();
        let len = outs[0].len();
        assert!(from + len <= n && coefs.len() == S && outs.iter().all(|o| o.len() == len));
        assert!(coefs.iter().all(|c| c.len() == targets.len()));
        let mut done = 0;
        while done < len {
            let row = from + done;
            let (b, first) = (row / BLOCK, row % BLOCK);
            let take = (BLOCK - first).min(len - done);
            let block = rows.block(b);
            for t0 in (0..BLOCK).step_by(TILE) {
                let (lo, hi) = (first.max(t0), (first + take).min(t0 + TILE));
                if lo >= hi {
                    continue;
                }
                // lane k is row b * BLOCK + t0 + k; lanes lo - t0..hi - t0 are columns
                let lanes = lo - t0..hi - t0;
                let out_at = done + lo - first;
                let mut norm = [0.0f32; TILE];
                let mut sign = [0.0f32; TILE];
                for k in lanes.clone() {
                    let j = b * BLOCK + t0 + k;
                    norm[k] = rows.norms[j];
                    sign[k] = f32::from(y[j]);
                }
                let mut sums = [[0.0f64; TILE]; S];
                for s in 0..S {
                    sums[s][lanes.clone()].copy_from_slice(&outs[s][out_at..out_at + lanes.len()]);
                }
                for (g, group) in targets.chunks(GROUP).enumerate() {
                    let dots = group_dots(rows, block, t0, group);
                    for (m, &i) in group.iter().enumerate() {
                        let (ni, yi) = (rows.norms[i], f32::from(y[i]));
                        let mut q = [0.0f32; TILE];
                        for k in 0..TILE {
                            let d2 = (ni + norm[k] - 2.0 * dots[m][k]).max(0.0);
                            q[k] = yi * sign[k] * exp_nonpositive(-gamma * d2);
                        }
                        for s in 0..S {
                            let c = coefs[s][g * GROUP + m];
                            if c != 0.0 {
                                for k in 0..TILE {
                                    sums[s][k] += c * f64::from(q[k]);
                                }
                            }
                        }
                    }
                }
                for s in 0..S {
                    outs[s][out_at..out_at + lanes.len()].copy_from_slice(&sums[s][lanes.clone()]);
                }
            }
            done += take;
        }
    }

    /// `dots[m][k] = row(group[m]) . row(b * BLOCK + t0 + k)` for the block's 32 rows from
    /// `t0`.
    #[target_feature(enable = "avx512f")]
    fn group_dots(rows: &Rows, block: &[f32], t0: usize, group: &[usize]) -> [[f32; TILE]; GROUP] {
        // a short group repeats its first target; those lanes are not read
        let xs = std::array::from_fn(|m| rows.row(group[m.min(group.len() - 1)]));
        wide_dots(block, t0, xs)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(n: usize, dim: usize) -> (Rows, Vec<i8>) {
        let x = (0..n * dim)
            .map(|i| ((i * 37) % 23) as f32 * 0.1 - 1.1)
            .collect();
        let y = (0..n).map(|i| if i % 3 == 0 { 1 } else { -1 }).collect();
        (Rows::new(dim, x), y)
    }

    #[test]
    fn pieces_start_at_the_columns_then_on_block_boundaries() {
        assert_eq!(piece_starts(0..0), Vec::<usize>::new());
        assert_eq!(piece_starts(0..10), vec![0]);
        assert_eq!(piece_starts(3..10), vec![3]);
        assert_eq!(piece_starts(3..BLOCK + 1), vec![3, BLOCK]);
        assert_eq!(
            piece_starts(BLOCK..BLOCK + 2 * PIECE),
            vec![BLOCK, BLOCK + PIECE]
        );
    }

    /// `base` plus the rows of Q added one after another, as a reconstruction did before
    /// [`add_q_products`].
    fn row_by_row(
        rows: &Rows,
        y: &[i8],
        targets: &[usize],
        coefs: &[f64],
        columns: Range<usize>,
        base: &[f64],
    ) -> Vec<f64> {
        let mut out = base.to_vec();
        for (batch, cs) in targets
            .chunks(ROWS_PER_PASS)
            .zip(coefs.chunks(ROWS_PER_PASS))
        {
            let qs = q_rows(rows, y, KERNEL, batch, columns.clone());
            for (&c, q) in cs.iter().zip(&qs) {
                if c != 0.0 {
                    for (o, v) in out.iter_mut().zip(q) {
                        *o += c * f64::from(*v);
                    }
                }
            }
        }
        out
    }

    const KERNEL: Kernel = Kernel::Rbf { gamma: 0.4 };

    #[test]
    fn products_added_together_are_the_rows_added_one_after_another() {
        let (n, dim) = (3_000, 8);
        let (rows, y) = sample(n, dim);
        // 200 targets (more than one pass takes) clear the threshold for threads; 10 do not.
        let targets: Vec<usize> = (0..200).map(|t| (t * 7) % n).collect();
        let alpha: Vec<f64> = (0..200).map(|t| 0.1 + t as f64 * 0.37).collect();
        let upper: Vec<f64> = (0..200)
            .map(|t| if t % 5 == 0 { 2.5 } else { 0.0 })
            .collect();
        for (count, may_fuse) in [(200, true), (10, true), (200, false), (10, false)] {
            for columns in [0..n, 3..n, 64..1700, 70..71, 130..130, 33..95] {
                let base: Vec<f64> = columns.clone().map(|k| k as f64 * 0.01 - 1.0).collect();
                let (targets, alpha, upper) = (&targets[..count], &alpha[..count], &upper[..count]);
                let (mut got_a, mut got_b) = (base.clone(), base.clone());
                let mut sums = [
                    Sum {
                        coefs: alpha,
                        out: &mut got_a,
                    },
                    Sum {
                        coefs: upper,
                        out: &mut got_b,
                    },
                ];
                add_q_products_with(
                    &rows,
                    &y,
                    KERNEL,
                    targets,
                    columns.clone(),
                    &mut sums,
                    may_fuse,
                );
                let case = format!("{count} targets, columns {columns:?}, fused {may_fuse}");
                let want_a = row_by_row(&rows, &y, targets, alpha, columns.clone(), &base);
                assert_eq!(got_a, want_a, "{case}");
                let want_b = row_by_row(&rows, &y, targets, upper, columns.clone(), &base);
                assert_eq!(got_b, want_b, "{case}");
                if !columns.is_empty() {
                    assert_ne!(got_a, base, "{case}: something was added");
                }
            }
        }
    }
}
