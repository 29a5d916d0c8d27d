//! The RBF decision function's sums, `sum_i coef_i exp(-gamma |sv_i - x|^2)`, for one row
//! (the online detector's frame) or many (scoring a test set, a search's held-out fold).
//!
//! Support vectors are stored in blocks of [`BLOCK`], each feature-major, so the inner loop
//! runs across support vectors with no horizontal sums. Every row's sum is computed by the
//! same operations in the same order however many rows go together, so a batch gives each
//! row the very value [`rbf_sum`] gives it alone.

use super::kernel::{self, dot, BLOCK};
use super::SvmModel;

/// Rows that share each pass over a tile of support vectors in [`rbf_sums`].
const ROWS_PER_TILE: usize = 4;
/// Support vectors in a tile: with [`ROWS_PER_TILE`] rows, 8 AVX registers of sums.
const TILE: usize = 16;

/// `sum_i coef_i exp(-gamma |sv_i - x|^2)` for one row `x` (with the branch-free
/// exponential and AVX2: 80 us -> 18 us median for 6,277 support vectors; row-major dot
/// products spent most of their time reducing each short sum).
pub(super) fn rbf_sum(m: &SvmModel, gamma: f32, x: &[f32]) -> f64 {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
        {
            // SAFETY: the CPU has the features the function is compiled for.
            return unsafe { rbf_sum_avx2(m, gamma, x) };
        }
    }
    rbf_sum_portable(m, gamma, x)
}

/// [`rbf_sum`] of each row of `xs` (row-major, `m.dim` wide) into `out`.
pub(super) fn rbf_sums(m: &SvmModel, gamma: f32, xs: &[f32], out: &mut [f64]) {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx512f") {
            // SAFETY: the CPU has the features the function is compiled for.
            return unsafe { rbf_sums_avx512(m, gamma, xs, out) };
        }
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
        {
            // SAFETY: the CPU has the features the function is compiled for.
            return unsafe { rbf_sums_avx2(m, gamma, xs, out) };
        }
    }
    rbf_sums_portable(m, gamma, xs, out)
}

/// The support vectors a [`BLOCK`] at a time: the block (feature-major), its coefficients
/// and its squared norms.
#[inline(always)]
fn sv_blocks(m: &SvmModel) -> impl Iterator<Item = (&[f32], &[f32], &[f32])> {
    m.blocks
        .chunks_exact(BLOCK * m.dim)
        .zip(m.coef32.chunks_exact(BLOCK))
        .zip(m.norms.chunks_exact(BLOCK))
        .map(|((block, coefs), norms)| (block, coefs, norms))
}

#[inline(always)]
fn rbf_sum_portable(m: &SvmModel, gamma: f32, x: &[f32]) -> f64 {
    let nx = dot(x, x);
    // Per-lane running sums: a single scalar sum would keep the loop from vectorising.
    let mut total = [0.0f32; BLOCK];
    for (block, coefs, norms) in sv_blocks(m) {
        let mut acc = [0.0f32; BLOCK];
        for (j, xj) in x.iter().enumerate() {
            let col = &block[j * BLOCK..(j + 1) * BLOCK];
            for k in 0..BLOCK {
                acc[k] += col[k] * xj;
            }
        }
        for k in 0..BLOCK {
            let d2 = (norms[k] + nx - 2.0 * acc[k]).max(0.0);
            total[k] += coefs[k] * kernel::exp_nonpositive(-gamma * d2);
        }
    }
    lanes_sum(&total)
}

/// The per-lane sums added up, in lane order.
#[inline(always)]
fn lanes_sum(total: &[f32; BLOCK]) -> f64 {
    total.iter().map(|v| f64::from(*v)).sum()
}

/// [`rbf_sum`] of [`ROWS_PER_TILE`] rows at once: each tile of support vectors is read once
/// for all of them and each broadcast feature serves two vectors of sums. Why: one row at
/// a time streams every support vector from the L2 cache per row (1.4 MB at 6k support
/// vectors). svm_speed, 61k rows against 1,758 support vectors, one thread: 0.320 s one
/// row at a time, 0.262 s so, idle machine (0.567 against 0.373 s with the other core
/// busy); [`kernel::tile_product`]'s hand-written register tile for the dot products
/// took 0.279 s, so the compiler's own is kept. Each lane's sum takes the same terms in the
/// same order as in [`rbf_sum_portable`] (multiply then add, not fused), so the values are
/// bit-identical.
#[inline(always)]
fn rbf_sums_tiled(m: &SvmModel, gamma: f32, xs: [&[f32]; ROWS_PER_TILE]) -> [f64; ROWS_PER_TILE] {
    let nx: [f32; ROWS_PER_TILE] = std::array::from_fn(|r| dot(xs[r], xs[r]));
    let mut total = [[0.0f32; BLOCK]; ROWS_PER_TILE];
    for (block, coefs, norms) in sv_blocks(m) {
        for t0 in (0..BLOCK).step_by(TILE) {
            let mut acc = [[0.0f32; TILE]; ROWS_PER_TILE];
            for j in 0..m.dim {
                let col: &[f32; TILE] = block[j * BLOCK + t0..j * BLOCK + t0 + TILE]
                    .try_into()
                    .expect("a tile lies within its block");
                for r in 0..ROWS_PER_TILE {
                    let xj = xs[r][j];
                    for k in 0..TILE {
                        acc[r][k] += col[k] * xj;
                    }
                }
            }
            for r in 0..ROWS_PER_TILE {
                for k in 0..TILE {
                    let d2 = (norms[t0 + k] + nx[r] - 2.0 * acc[r][k]).max(0.0);
                    total[r][t0 + k] += coefs[t0 + k] * kernel::exp_nonpositive(-gamma * d2);
                }
            }
        }
    }
    std::array::from_fn(|r| lanes_sum(&total[r]))
}

#[inline(always)]
fn rbf_sums_portable(m: &SvmModel, gamma: f32, xs: &[f32], out: &mut [f64]) {
    let dim = m.dim;
    assert_eq!(xs.len(), dim * out.len(), "one output per {dim}-wide row");
    let whole = out.len() / ROWS_PER_TILE * ROWS_PER_TILE;
    for (rows, sums) in xs[..whole * dim]
        .chunks_exact(ROWS_PER_TILE * dim)
        .zip(out[..whole].chunks_exact_mut(ROWS_PER_TILE))
    {
        let group = std::array::from_fn(|r| &rows[r * dim..(r + 1) * dim]);
        sums.copy_from_slice(&rbf_sums_tiled(m, gamma, group));
    }
    for (x, sum) in xs[whole * dim..].chunks_exact(dim).zip(&mut out[whole..]) {
        *sum = rbf_sum_portable(m, gamma, x);
    }
}

/// [`rbf_sum_portable`] compiled for AVX2 and FMA, chosen at run time when the CPU has them.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn rbf_sum_avx2(m: &SvmModel, gamma: f32, x: &[f32]) -> f64 {
    rbf_sum_portable(m, gamma, x)
}

/// [`rbf_sums_portable`] compiled for AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn rbf_sums_avx2(m: &SvmModel, gamma: f32, xs: &[f32], out: &mut [f64]) {
    rbf_sums_portable(m, gamma, xs, out)
}

/// [`rbf_sums_portable`] with AVX-512: [`kernel::wide_dots`]' tiles of 8 rows x 32
/// support vectors. Why: the compiler's code for the AVX2 tile spent more instructions on
/// bounds checks, reloads and spills than on arithmetic (svm_speed, 61k rows against 1,758
/// support vectors, one thread: 0.300 s -> 0.221 s; a tile of 6, 8 or 12 rows made no
/// difference, so the tile runs at the core's rate of multiplies and adds, which on this
/// Zen 4 is the same for 256- and 512-bit vectors). Every lane takes the same terms in the
/// same order, multiply then add, so the values are bit-identical to the other paths'.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn rbf_sums_avx512(m: &SvmModel, gamma: f32, xs: &[f32], out: &mut [f64]) {
    const R: usize = kernel::WIDE_ROWS;
    let dim = m.dim;
    assert_eq!(xs.len(), dim * out.len(), "one output per {dim}-wide row");
    let whole = out.len() / R * R;
    for (rows, sums) in xs[..whole * dim]
        .chunks_exact(R * dim)
        .zip(out[..whole].chunks_exact_mut(R))
    {
        let group: [&[f32]; R] = std::array::from_fn(|r| &rows[r * dim..(r + 1) * dim]);
        sums.copy_from_slice(&rbf_sums_wide_tile(m, gamma, group));
    }
    for (x, sum) in xs[whole * dim..].chunks_exact(dim).zip(&mut out[whole..]) {
        *sum = rbf_sum_portable(m, gamma, x);
    }
}

/// [`rbf_sums_avx512`]'s sums for one group of rows.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn rbf_sums_wide_tile(
    m: &SvmModel,
    gamma: f32,
    xs: [&[f32]; kernel::WIDE_ROWS],
) -> [f64; kernel::WIDE_ROWS] {
    const R: usize = kernel::WIDE_ROWS;
    const TILE: usize = kernel::WIDE_COLUMNS;
    let nx: [f32; R] = std::array::from_fn(|r| dot(xs[r], xs[r]));
    let mut total = [[0.0f32; BLOCK]; R];
    for (block, coefs, norms) in sv_blocks(m) {
        for t0 in (0..BLOCK).step_by(TILE) {
            let acc = kernel::wide_dots(block, t0, xs);
            for r in 0..R {
                for k in 0..TILE {
                    let d2 = (norms[t0 + k] + nx[r] - 2.0 * acc[r][k]).max(0.0);
                    total[r][t0 + k] += coefs[t0 + k] * kernel::exp_nonpositive(-gamma * d2);
                }
            }
        }
    }
    std::array::from_fn(|r| lanes_sum(&total[r]))
}

#[cfg(test)]
mod tests {
    use crate::svm::SvmParams;

    #[test]
    fn rows_summed_together_get_the_values_each_gets_alone() {
        // 7 features (not a multiple of anything), 300 rows of two overlapping classes:
        // some hundred support vectors, so the last block is part-filled.
        let (n, dim) = (300, 7);
        let (x, y) = crate::svm::noisy_classes(n, dim, 5, 3, 1.0, 0.5);
        let model = SvmParams::rbf(1.0, 0.3)
            .check()
            .unwrap()
            .fit(dim, &x, &y)
            .unwrap();
        let sv = model.support_vector_count();
        assert!(sv > 64 && !sv.is_multiple_of(64), "{sv} support vectors");
        // Every count of rows up to two tiles and a remainder, from every start.
        for count in 1..=19 {
            for start in [0, 1, 13] {
                let xs = &x[start * dim..(start + count) * dim];
                let mut together = vec![0.0; count];
                model.decisions(xs, &mut together);
                // Also the code for CPUs without AVX2, which this one may not run otherwise.
                let mut portable = vec![0.0; count];
                super::rbf_sums_portable(&model, 0.3, xs, &mut portable);
                // and each vector path the CPU has, whichever `decisions` chose
                #[cfg(target_arch = "x86_64")]
                for (feature, has) in [
                    (
                        "avx2",
                        std::arch::is_x86_feature_detected!("avx2")
                            && std::arch::is_x86_feature_detected!("fma"),
                    ),
                    ("avx512f", std::arch::is_x86_feature_detected!("avx512f")),
                ] {
                    if !has {
                        continue;
                    }
                    let mut wide = vec![0.0; count];
                    // SAFETY: the CPU has the features the function is compiled for.
                    unsafe {
                        match feature {
                            "avx2" => super::rbf_sums_avx2(&model, 0.3, xs, &mut wide),
                            _ => super::rbf_sums_avx512(&model, 0.3, xs, &mut wide),
                        }
                    }
                    assert_eq!(wide, portable, "{feature}: {count} rows from {start}");
                }
                for (r, value) in together.iter().enumerate() {
                    let x = &xs[r * dim..(r + 1) * dim];
                    let alone = model.decision(x);
                    assert_eq!(value.to_bits(), alone.to_bits(), "{count} rows, row {r}");
                    assert_eq!(portable[r] - model.rho, *value, "{count} rows, row {r}");
                    assert_eq!(super::rbf_sum_portable(&model, 0.3, x) - model.rho, alone);
                }
            }
        }
    }
}
