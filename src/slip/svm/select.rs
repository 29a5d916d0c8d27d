//! libsvm's second-order working-set selection (WSS 3 of Fan, Chen and Lin, 2005) as two
//! passes that each keep four independent running extremes, so that the compiler can keep
//! them in vector registers instead of following one branchy scalar chain.
//!
//! Why: on a search's fits (4,000 rows, large C, hundreds of thousands of SMO steps) the
//! selection was a quarter of a Bayesian sweep's time. Ties go to the last index, as in
//! the one-at-a-time loop: each lane keeps its last extreme, and lanes combine by value,
//! then by the larger index; the selected pair is the same.

use super::smo::Bound;

/// Lanes of running extremes: four `f64`, one AVX register.
const LANES: usize = 4;

/// `i`: the variable that may move up (`I_up`) with the largest `-y_t G_t`, and that value
/// (`m(alpha)`); `None` when no variable may move up.
pub(super) fn max_violating_up(
    y: &[i8],
    status: &[Bound],
    gradient: &[f64],
) -> Option<(usize, f64)> {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has the feature the function is compiled for.
            return unsafe { max_violating_up_avx2(y, status, gradient) };
        }
    }
    max_violating_up_lanes(y, status, gradient)
}

/// The partner `j` of `i` (from `I_low`) that most decreases the objective, by the
/// second-order rule, with `M(alpha)`'s negation `gmax2` (the largest `y_t G_t` over
/// `I_low`). `q_i` is row `i` of Q, `diagonal` Q's diagonal, `gmax` the value
/// [`max_violating_up`] returned, `y_i` and `qd_i` those of `i`; `tau` replaces a
/// non-positive curvature.
pub(super) struct Partner {
    pub j: Option<usize>,
    pub gmax2: f64,
}

#[allow(clippy::too_many_arguments)]
pub(super) fn best_partner(
    y: &[i8],
    status: &[Bound],
    gradient: &[f64],
    diagonal: &[f64],
    q_i: &[f32],
    gmax: f64,
    y_i: f64,
    qd_i: f64,
    tau: f64,
) -> Partner {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has the feature the function is compiled for.
            return unsafe {
                best_partner_avx2(y, status, gradient, diagonal, q_i, gmax, y_i, qd_i, tau)
            };
        }
    }
    best_partner_lanes(y, status, gradient, diagonal, q_i, gmax, y_i, qd_i, tau)
}

#[inline(always)]
fn max_violating_up_lanes(y: &[i8], status: &[Bound], gradient: &[f64]) -> Option<(usize, f64)> {
    let n = gradient.len();
    let (y, status) = (&y[..n], &status[..n]);
    let mut best = [f64::NEG_INFINITY; LANES];
    let mut at = [usize::MAX; LANES];
    // One variable's candidacy: its value, or nothing when it may not move up.
    let value = |t: usize| {
        let (up, v) = if y[t] == 1 {
            (status[t] != Bound::Upper, -gradient[t])
        } else {
            (status[t] != Bound::Lower, gradient[t])
        };
        (up, v)
    };
    let whole = n / LANES * LANES;
    for base in (0..whole).step_by(LANES) {
        for l in 0..LANES {
            let t = base + l;
            let (up, v) = value(t);
            let take = up & (v >= best[l]);
            best[l] = if take { v } else { best[l] };
            at[l] = if take { t } else { at[l] };
        }
    }
    let mut found: Option<(usize, f64)> = None;
    for l in 0..LANES {
        if at[l] == usize::MAX {
            continue;
        }
        found = match found {
            Some((t, v)) if v > best[l] || (v == best[l] && t > at[l]) => Some((t, v)),
            _ => Some((at[l], best[l])),
        };
    }
    for t in whole..n {
        let (up, v) = value(t);
        if up && found.is_none_or(|(_, best)| v >= best) {
            found = Some((t, v));
        }
    }
    found
}

#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn best_partner_lanes(
    y: &[i8],
    status: &[Bound],
    gradient: &[f64],
    diagonal: &[f64],
    q_i: &[f32],
    gmax: f64,
    y_i: f64,
    qd_i: f64,
    tau: f64,
) -> Partner {
    let n = gradient.len();
    let (y, status, diagonal, q_i) = (&y[..n], &status[..n], &diagonal[..n], &q_i[..n]);
    let mut gmax2 = [f64::NEG_INFINITY; LANES];
    let mut best = [f64::INFINITY; LANES];
    let mut at = [None; LANES];
    let whole = n / LANES * LANES;
    for base in (0..whole).step_by(LANES) {
        for l in 0..LANES {
            let t = base + l;
            let (low, yg, improves, obj) = partner_candidate(
                y[t],
                status[t],
                gradient[t],
                diagonal[t],
                q_i[t],
                gmax,
                y_i,
                qd_i,
                tau,
            );
            if low && yg > gmax2[l] {
                gmax2[l] = yg;
            }
            if low && improves && obj <= best[l] {
                best[l] = obj;
                at[l] = Some(t);
            }
        }
    }
    let lanes = Lanes { best, at, gmax2 };
    finish_partner(
        lanes, y, status, gradient, diagonal, q_i, gmax, y_i, qd_i, tau, whole,
    )
}

/// One variable's part in [`best_partner`]: whether it may move down, its `y_t G_t`,
/// whether the gradient difference is positive, and the objective's decrease were it the
/// partner.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn partner_candidate(
    y: i8,
    status: Bound,
    gradient: f64,
    diagonal: f64,
    q: f32,
    gmax: f64,
    y_i: f64,
    qd_i: f64,
    tau: f64,
) -> (bool, f64, bool, f64) {
    let curvature = 2.0 * y_i * f64::from(q);
    let (low, yg, quad) = if y == 1 {
        (
            status != Bound::Lower,
            gradient,
            qd_i + diagonal - curvature,
        )
    } else {
        (
            status != Bound::Upper,
            -gradient,
            qd_i + diagonal + curvature,
        )
    };
    let grad_diff = gmax + yg;
    let obj = -(grad_diff * grad_diff) / if quad > 0.0 { quad } else { tau };
    (low, yg, grad_diff > 0.0, obj)
}

/// Each lane's running extremes over the variables before `whole` (every fourth from the
/// lane's own): the partner's objective and index, and the largest `y_t G_t` of `I_low`.
struct Lanes {
    best: [f64; LANES],
    at: [Option<usize>; LANES],
    gmax2: [f64; LANES],
}

/// [`best_partner`] from its lanes and the variables from `whole` on, one at a time: lanes
/// combine by objective, then by the larger index, as the one-at-a-time loop's last tie.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn finish_partner(
    lanes: Lanes,
    y: &[i8],
    status: &[Bound],
    gradient: &[f64],
    diagonal: &[f64],
    q_i: &[f32],
    gmax: f64,
    y_i: f64,
    qd_i: f64,
    tau: f64,
    whole: usize,
) -> Partner {
    let mut j: Option<(usize, f64)> = None;
    let mut m2 = f64::NEG_INFINITY;
    for l in 0..LANES {
        m2 = m2.max(lanes.gmax2[l]);
        let Some(at) = lanes.at[l] else { continue };
        j = match j {
            Some((t, v)) if v < lanes.best[l] || (v == lanes.best[l] && t > at) => Some((t, v)),
            _ => Some((at, lanes.best[l])),
        };
    }
    for t in whole..gradient.len() {
        let (low, yg, improves, obj) = partner_candidate(
            y[t],
            status[t],
            gradient[t],
            diagonal[t],
            q_i[t],
            gmax,
            y_i,
            qd_i,
            tau,
        );
        if low {
            m2 = m2.max(yg);
            if improves && j.is_none_or(|(_, best)| obj <= best) {
                j = Some((t, obj));
            }
        }
    }
    Partner {
        j: j.map(|(t, _)| t),
        gmax2: m2,
    }
}

/// [`max_violating_up_lanes`] in AVX2 intrinsics, four variables a step (as
/// [`best_partner_avx2`]).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn max_violating_up_avx2(
    y: &[i8],
    status: &[Bound],
    gradient: &[f64],
) -> Option<(usize, f64)> {
    use std::arch::x86_64::*;
    let n = gradient.len();
    assert!(y.len() >= n && status.len() >= n);
    let (one, half) = (_mm256_set1_pd(1.0), _mm256_set1_pd(0.5));
    let mut best = _mm256_set1_pd(f64::NEG_INFINITY);
    let mut at = _mm256_set1_pd(-1.0);
    let mut index = _mm256_setr_pd(0.0, 1.0, 2.0, 3.0);
    let step = _mm256_set1_pd(LANES as f64);
    let whole = n / LANES * LANES;
    for base in (0..whole).step_by(LANES) {
        let yf = widen(y.as_ptr().add(base) as *const u8);
        let st = widen(status.as_ptr().add(base) as *const u8);
        // A slip variable may move up unless at its upper bound (1), a static one unless at
        // its lower bound (0): the excluded bound is (1 + y) / 2.
        let excluded = _mm256_mul_pd(_mm256_add_pd(one, yf), half);
        let up = _mm256_cmp_pd::<_CMP_NEQ_OQ>(st, excluded);
        // -y G, exactly: multiplying by -1 or 1 only sets the sign.
        let value = _mm256_mul_pd(
            _mm256_xor_pd(yf, _mm256_set1_pd(-0.0)),
            _mm256_loadu_pd(gradient.as_ptr().add(base)),
        );
        let take = _mm256_and_pd(up, _mm256_cmp_pd::<_CMP_GE_OQ>(value, best));
        best = _mm256_blendv_pd(best, value, take);
        at = _mm256_blendv_pd(at, index, take);
        index = _mm256_add_pd(index, step);
    }
    let (mut best_l, mut at_l) = ([0.0; LANES], [0.0; LANES]);
    _mm256_storeu_pd(best_l.as_mut_ptr(), best);
    _mm256_storeu_pd(at_l.as_mut_ptr(), at);
    let mut found: Option<(usize, f64)> = None;
    for l in 0..LANES {
        if at_l[l] < 0.0 {
            continue;
        }
        let (t_l, v_l) = (at_l[l] as usize, best_l[l]);
        found = match found {
            Some((t, v)) if v > v_l || (v == v_l && t > t_l) => Some((t, v)),
            _ => Some((t_l, v_l)),
        };
    }
    for t in whole..n {
        let (up, v) = if y[t] == 1 {
            (status[t] != Bound::Upper, -gradient[t])
        } else {
            (status[t] != Bound::Lower, gradient[t])
        };
        if up && found.is_none_or(|(_, best)| v >= best) {
            found = Some((t, v));
        }
    }
    found
}

/// Four bytes from `p` as four f64.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn widen(p: *const u8) -> std::arch::x86_64::__m256d {
    use std::arch::x86_64::*;
    let word = (p as *const i32).read_unaligned();
    _mm256_cvtepi32_pd(_mm_cvtepi8_epi32(_mm_cvtsi32_si128(word)))
}

/// [`best_partner_lanes`] in AVX2 intrinsics, four variables a step: the same operations
/// on the same values, so the same pair (the compiler did not vectorise the lanes' selects
/// itself: 39 % of a search sweep's time, against 26 % for the one-at-a-time loop).
#[allow(clippy::too_many_arguments)]
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn best_partner_avx2(
    y: &[i8],
    status: &[Bound],
    gradient: &[f64],
    diagonal: &[f64],
    q_i: &[f32],
    gmax: f64,
    y_i: f64,
    qd_i: f64,
    tau: f64,
) -> Partner {
    use std::arch::x86_64::*;
    let n = gradient.len();
    assert!(y.len() >= n && status.len() >= n && diagonal.len() >= n && q_i.len() >= n);
    let sign = _mm256_set1_pd(-0.0);
    let (one, half) = (_mm256_set1_pd(1.0), _mm256_set1_pd(0.5));
    let (gmax_v, qd_i_v, tau_v, zero) = (
        _mm256_set1_pd(gmax),
        _mm256_set1_pd(qd_i),
        _mm256_set1_pd(tau),
        _mm256_setzero_pd(),
    );
    let two_y_i = _mm256_set1_pd(2.0 * y_i);
    let mut gmax2 = _mm256_set1_pd(f64::NEG_INFINITY);
    let mut best = _mm256_set1_pd(f64::INFINITY);
    // Indices as f64 (exact far beyond any row count); -1 for none.
    let mut at = _mm256_set1_pd(-1.0);
    let mut index = _mm256_setr_pd(0.0, 1.0, 2.0, 3.0);
    let step = _mm256_set1_pd(LANES as f64);
    let whole = n / LANES * LANES;
    for base in (0..whole).step_by(LANES) {
        let yf = widen(y.as_ptr().add(base) as *const u8);
        let st = widen(status.as_ptr().add(base) as *const u8);
        // A slip variable may move down unless at its lower bound (0), a static one unless
        // at its upper bound (1): the excluded bound is (1 - y) / 2.
        let excluded = _mm256_mul_pd(_mm256_sub_pd(one, yf), half);
        let low = _mm256_cmp_pd::<_CMP_NEQ_OQ>(st, excluded);
        let g = _mm256_loadu_pd(gradient.as_ptr().add(base));
        let yg = _mm256_mul_pd(yf, g);
        let q = _mm256_cvtps_pd(_mm_loadu_ps(q_i.as_ptr().add(base)));
        let curvature = _mm256_mul_pd(two_y_i, q);
        let quad = _mm256_sub_pd(
            _mm256_add_pd(qd_i_v, _mm256_loadu_pd(diagonal.as_ptr().add(base))),
            _mm256_mul_pd(yf, curvature),
        );
        let grad_diff = _mm256_add_pd(gmax_v, yg);
        let positive = _mm256_cmp_pd::<_CMP_GT_OQ>(quad, zero);
        let denominator = _mm256_blendv_pd(tau_v, quad, positive);
        let obj = _mm256_div_pd(
            _mm256_xor_pd(_mm256_mul_pd(grad_diff, grad_diff), sign),
            denominator,
        );
        let larger = _mm256_and_pd(low, _mm256_cmp_pd::<_CMP_GT_OQ>(yg, gmax2));
        gmax2 = _mm256_blendv_pd(gmax2, yg, larger);
        let improves = _mm256_cmp_pd::<_CMP_GT_OQ>(grad_diff, zero);
        let take = _mm256_and_pd(
            _mm256_and_pd(low, improves),
            _mm256_cmp_pd::<_CMP_LE_OQ>(obj, best),
        );
        best = _mm256_blendv_pd(best, obj, take);
        at = _mm256_blendv_pd(at, index, take);
        index = _mm256_add_pd(index, step);
    }
    let (mut best_l, mut at_l, mut gmax2_l) = ([0.0; LANES], [0.0; LANES], [0.0; LANES]);
    _mm256_storeu_pd(best_l.as_mut_ptr(), best);
    _mm256_storeu_pd(at_l.as_mut_ptr(), at);
    _mm256_storeu_pd(gmax2_l.as_mut_ptr(), gmax2);
    let lanes = Lanes {
        best: best_l,
        at: std::array::from_fn(|l| (at_l[l] >= 0.0).then_some(at_l[l] as usize)),
        gmax2: gmax2_l,
    };
    finish_partner(
        lanes, y, status, gradient, diagonal, q_i, gmax, y_i, qd_i, tau, whole,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The selection one variable at a time, as libsvm writes it.
    fn one_at_a_time(
        y: &[i8],
        status: &[Bound],
        gradient: &[f64],
        diagonal: &[f64],
        q_i_of: impl Fn(usize) -> Vec<f32>,
        tau: f64,
    ) -> Option<(usize, Option<usize>, f64, f64)> {
        let mut gmax = f64::NEG_INFINITY;
        let mut gmax_idx = None;
        for t in 0..gradient.len() {
            if y[t] == 1 {
                if status[t] != Bound::Upper && -gradient[t] >= gmax {
                    gmax = -gradient[t];
                    gmax_idx = Some(t);
                }
            } else if status[t] != Bound::Lower && gradient[t] >= gmax {
                gmax = gradient[t];
                gmax_idx = Some(t);
            }
        }
        let i = gmax_idx?;
        let (qi, yi, qd_i) = (q_i_of(i), f64::from(y[i]), diagonal[i]);
        let (mut gmax2, mut gmin_idx, mut obj_min) = (f64::NEG_INFINITY, None, f64::INFINITY);
        for j in 0..gradient.len() {
            let (grad_diff, quad) = if y[j] == 1 {
                if status[j] == Bound::Lower {
                    continue;
                }
                gmax2 = gmax2.max(gradient[j]);
                (
                    gmax + gradient[j],
                    qd_i + diagonal[j] - 2.0 * yi * f64::from(qi[j]),
                )
            } else {
                if status[j] == Bound::Upper {
                    continue;
                }
                gmax2 = gmax2.max(-gradient[j]);
                (
                    gmax - gradient[j],
                    qd_i + diagonal[j] + 2.0 * yi * f64::from(qi[j]),
                )
            };
            if grad_diff > 0.0 {
                let obj = -(grad_diff * grad_diff) / if quad > 0.0 { quad } else { tau };
                if obj <= obj_min {
                    gmin_idx = Some(j);
                    obj_min = obj;
                }
            }
        }
        Some((i, gmin_idx, gmax, gmax2))
    }

    #[test]
    fn lanes_select_the_pair_one_at_a_time_selects_ties_and_all() {
        let mut state = 17u64;
        let mut next = |k: u64| {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 33) % k
        };
        for case in 0..400 {
            let n = 1 + next(70) as usize;
            // Few distinct values, so that ties are common; some cases with none free.
            let y: Vec<i8> = (0..n).map(|_| if next(3) == 0 { 1 } else { -1 }).collect();
            let status: Vec<Bound> = (0..n)
                .map(|_| match next(if case % 5 == 0 { 2 } else { 3 }) {
                    0 => Bound::Lower,
                    1 => Bound::Upper,
                    _ => Bound::Free,
                })
                .collect();
            let gradient: Vec<f64> = (0..n).map(|_| next(7) as f64 * 0.25 - 0.75).collect();
            let diagonal: Vec<f64> = (0..n).map(|_| 1.0).collect();
            let q: Vec<f32> = (0..n * n).map(|_| next(5) as f32 * 0.25 - 0.5).collect();
            let q_i_of = |i: usize| q[i * n..(i + 1) * n].to_vec();
            let expected = one_at_a_time(&y, &status, &gradient, &diagonal, q_i_of, 1e-12);
            let got = max_violating_up(&y, &status, &gradient).map(|(i, gmax)| {
                let p = best_partner(
                    &y,
                    &status,
                    &gradient,
                    &diagonal,
                    &q_i_of(i),
                    gmax,
                    f64::from(y[i]),
                    diagonal[i],
                    1e-12,
                );
                let portable = best_partner_lanes(
                    &y,
                    &status,
                    &gradient,
                    &diagonal,
                    &q_i_of(i),
                    gmax,
                    f64::from(y[i]),
                    diagonal[i],
                    1e-12,
                );
                assert_eq!((portable.j, portable.gmax2), (p.j, p.gmax2), "case {case}");
                (i, p.j, gmax, p.gmax2)
            });
            let portable = max_violating_up_lanes(&y, &status, &gradient);
            assert_eq!(portable, got.map(|g| (g.0, g.2)));
            assert_eq!(got, expected, "case {case}, {n} variables");
        }
    }
}
