//! libsvm's second-order working-set selection (WSS 3 of Fan, Chen and Lin, 2005), four
//! variables a step with AVX2 where the CPU has it, one at a time elsewhere.
//!
//! Why: on a search's fits (4,000 rows, large C, hundreds of thousands of SMO steps) the
//! one-at-a-time loops were a third of a Bayesian sweep's time. The vector passes keep four
//! lanes of running extremes and their indices; ties go to the last index, as in the
//! one-at-a-time loop, since each lane keeps its last extreme and lanes combine by value,
//! then by the larger index. So the selected pair is the same, to the bit.

use super::status::Bound;

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
    scan_up(y, status, gradient, 0, None)
}

/// What [`best_partner`] found: the partner `j`, if any, and `M(alpha)`'s negation `gmax2`
/// (the largest `y_t G_t` over `I_low`).
pub(super) struct Partner {
    pub j: Option<usize>,
    pub gmax2: f64,
}

/// The row `i` of the working pair and what choosing its partner needs: row `i` of Q, the
/// value `gmax` [`max_violating_up`] returned, `y_i`, `Q_ii`, and `tau`, which replaces a
/// non-positive curvature.
pub(super) struct First<'a> {
    pub q_i: &'a [f32],
    pub gmax: f64,
    pub y_i: f64,
    pub qd_i: f64,
    pub tau: f64,
}

/// The partner `j` of `i` (from `I_low`) that most decreases the objective, by the
/// second-order rule.
pub(super) fn best_partner(
    y: &[i8],
    status: &[Bound],
    gradient: &[f64],
    diagonal: &[f64],
    first: &First,
) -> Partner {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has the feature the function is compiled for.
            return unsafe { best_partner_avx2(y, status, gradient, diagonal, first) };
        }
    }
    scan_partner(
        y,
        status,
        gradient,
        diagonal,
        first,
        0,
        None,
        f64::NEG_INFINITY,
    )
}

/// Variable `t`'s value `-y_t G_t` if it may move up.
#[inline(always)]
fn up_value(y: i8, status: Bound, gradient: f64) -> Option<f64> {
    if y == 1 {
        (status != Bound::Upper).then_some(-gradient)
    } else {
        (status != Bound::Lower).then_some(gradient)
    }
}

/// [`max_violating_up`] over the variables from `from` on, one at a time, continuing from
/// `found` (the best of those before).
fn scan_up(
    y: &[i8],
    status: &[Bound],
    gradient: &[f64],
    from: usize,
    mut found: Option<(usize, f64)>,
) -> Option<(usize, f64)> {
    for t in from..gradient.len() {
        if let Some(v) = up_value(y[t], status[t], gradient[t]) {
            if found.is_none_or(|(_, best)| v >= best) {
                found = Some((t, v));
            }
        }
    }
    found
}

/// Variable `t`'s part in [`best_partner`] if it may move down: its `y_t G_t`, and the
/// objective's decrease were it the partner, when the gradient difference is positive.
#[inline(always)]
fn partner_value(
    y: i8,
    status: Bound,
    gradient: f64,
    diagonal: f64,
    q: f32,
    first: &First,
) -> Option<(f64, Option<f64>)> {
    let curvature = 2.0 * first.y_i * f64::from(q);
    let (low, yg, quad) = if y == 1 {
        (
            status != Bound::Lower,
            gradient,
            first.qd_i + diagonal - curvature,
        )
    } else {
        (
            status != Bound::Upper,
            -gradient,
            first.qd_i + diagonal + curvature,
        )
    };
    let grad_diff = first.gmax + yg;
    let quad = if quad > 0.0 { quad } else { first.tau };
    low.then(|| {
        (
            yg,
            (grad_diff > 0.0).then(|| -(grad_diff * grad_diff) / quad),
        )
    })
}

/// [`best_partner`] over the variables from `from` on, one at a time, continuing from
/// `found` and `gmax2` (those of the variables before).
#[allow(clippy::too_many_arguments)]
fn scan_partner(
    y: &[i8],
    status: &[Bound],
    gradient: &[f64],
    diagonal: &[f64],
    first: &First,
    from: usize,
    mut found: Option<(usize, f64)>,
    mut gmax2: f64,
) -> Partner {
    for t in from..gradient.len() {
        let part = partner_value(
            y[t],
            status[t],
            gradient[t],
            diagonal[t],
            first.q_i[t],
            first,
        );
        if let Some((yg, objective)) = part {
            gmax2 = gmax2.max(yg);
            if let Some(obj) = objective {
                if found.is_none_or(|(_, best)| obj <= best) {
                    found = Some((t, obj));
                }
            }
        }
    }
    Partner {
        j: found.map(|(t, _)| t),
        gmax2,
    }
}

/// The best of the lanes' extremes: by `better` value, then by the larger index.
fn combine(
    lanes: [Option<(usize, f64)>; LANES],
    better: impl Fn(f64, f64) -> bool,
) -> Option<(usize, f64)> {
    lanes.into_iter().flatten().reduce(|(t, v), (t_l, v_l)| {
        if better(v, v_l) || (v == v_l && t > t_l) {
            (t, v)
        } else {
            (t_l, v_l)
        }
    })
}

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use std::arch::x86_64::*;

    use super::{Bound, LANES};

    /// Four lanes of running extremes with the index each was taken at, in AVX registers.
    /// Indices are kept as f64 (exact far beyond any row count); -1 for none yet.
    pub(super) struct Extremes {
        best: __m256d,
        at: __m256d,
        index: __m256d,
    }

    impl Extremes {
        #[target_feature(enable = "avx2")]
        #[inline]
        pub(super) fn new(start: f64) -> Self {
            Self {
                best: _mm256_set1_pd(start),
                at: _mm256_set1_pd(-1.0),
                index: _mm256_setr_pd(0.0, 1.0, 2.0, 3.0),
            }
        }

        pub(super) fn best(&self) -> __m256d {
            self.best
        }

        /// Takes `value` in the lanes `take` sets, then moves on to the next four.
        #[target_feature(enable = "avx2")]
        #[inline]
        pub(super) fn offer(&mut self, value: __m256d, take: __m256d) {
            self.best = _mm256_blendv_pd(self.best, value, take);
            self.at = _mm256_blendv_pd(self.at, self.index, take);
            self.index = _mm256_add_pd(self.index, _mm256_set1_pd(LANES as f64));
        }

        /// Each lane's extreme and its index, if it took any.
        #[target_feature(enable = "avx2")]
        #[inline]
        pub(super) fn lanes(&self) -> [Option<(usize, f64)>; LANES] {
            let (mut best, mut at) = ([0.0; LANES], [0.0; LANES]);
            // SAFETY: each array holds the four values stored.
            unsafe {
                _mm256_storeu_pd(best.as_mut_ptr(), self.best);
                _mm256_storeu_pd(at.as_mut_ptr(), self.at);
            }
            std::array::from_fn(|l| (at[l] >= 0.0).then(|| (at[l] as usize, best[l])))
        }
    }

    /// Four bytes from `p` as four f64.
    ///
    /// # Safety
    /// `p` must point to four readable bytes.
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn widen(p: *const u8) -> __m256d {
        let word = (p as *const i32).read_unaligned();
        _mm256_cvtepi32_pd(_mm_cvtepi8_epi32(_mm_cvtsi32_si128(word)))
    }

    /// The labels (as f64) of the four variables from `base`, and a mask of those that may
    /// move up (`up`) or down: a positive variable may move up unless at its upper bound (1)
    /// and down unless at its lower bound (0), a negative one the other way round; so the
    /// excluded bound is `(1 + y) / 2` moving up, `(1 - y) / 2` moving down.
    ///
    /// # Safety
    /// `y` and `status` must hold four values from `base`.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(super) unsafe fn labels_and_freedom(
        y: &[i8],
        status: &[Bound],
        base: usize,
        up: bool,
    ) -> (__m256d, __m256d) {
        debug_assert!(base + LANES <= y.len().min(status.len()));
        let yf = widen(y.as_ptr().add(base) as *const u8);
        let st = widen(status.as_ptr().add(base) as *const u8);
        let one = _mm256_set1_pd(1.0);
        let towards = if up {
            _mm256_add_pd(one, yf)
        } else {
            _mm256_sub_pd(one, yf)
        };
        let excluded = _mm256_mul_pd(towards, _mm256_set1_pd(0.5));
        (yf, _mm256_cmp_pd::<_CMP_NEQ_OQ>(st, excluded))
    }
}

/// [`max_violating_up`] four variables a step.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn max_violating_up_avx2(
    y: &[i8],
    status: &[Bound],
    gradient: &[f64],
) -> Option<(usize, f64)> {
    use avx2::{labels_and_freedom, Extremes};
    use std::arch::x86_64::*;
    let n = gradient.len();
    assert!(y.len() >= n && status.len() >= n);
    let sign = _mm256_set1_pd(-0.0);
    let mut extremes = Extremes::new(f64::NEG_INFINITY);
    let whole = n / LANES * LANES;
    for base in (0..whole).step_by(LANES) {
        let (yf, up) = labels_and_freedom(y, status, base, true);
        // -y G, exactly: multiplying by -1 or 1 only sets the sign.
        let value = _mm256_mul_pd(
            _mm256_xor_pd(yf, sign),
            _mm256_loadu_pd(gradient.as_ptr().add(base)),
        );
        let take = _mm256_and_pd(up, _mm256_cmp_pd::<_CMP_GE_OQ>(value, extremes.best()));
        extremes.offer(value, take);
    }
    let found = combine(extremes.lanes(), |a, b| a > b);
    scan_up(y, status, gradient, whole, found)
}

/// [`best_partner`] four variables a step: the same operations on the same values as
/// [`partner_value`].
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn best_partner_avx2(
    y: &[i8],
    status: &[Bound],
    gradient: &[f64],
    diagonal: &[f64],
    first: &First,
) -> Partner {
    use avx2::{labels_and_freedom, Extremes};
    use std::arch::x86_64::*;
    let n = gradient.len();
    assert!(y.len() >= n && status.len() >= n && diagonal.len() >= n && first.q_i.len() >= n);
    let (sign, zero) = (_mm256_set1_pd(-0.0), _mm256_setzero_pd());
    let (gmax, qd_i, tau) = (
        _mm256_set1_pd(first.gmax),
        _mm256_set1_pd(first.qd_i),
        _mm256_set1_pd(first.tau),
    );
    let two_y_i = _mm256_set1_pd(2.0 * first.y_i);
    let mut gmax2 = _mm256_set1_pd(f64::NEG_INFINITY);
    let mut extremes = Extremes::new(f64::INFINITY);
    let whole = n / LANES * LANES;
    for base in (0..whole).step_by(LANES) {
        let (yf, low) = labels_and_freedom(y, status, base, false);
        let yg = _mm256_mul_pd(yf, _mm256_loadu_pd(gradient.as_ptr().add(base)));
        let q = _mm256_cvtps_pd(_mm_loadu_ps(first.q_i.as_ptr().add(base)));
        let curvature = _mm256_mul_pd(two_y_i, q);
        let quad = _mm256_sub_pd(
            _mm256_add_pd(qd_i, _mm256_loadu_pd(diagonal.as_ptr().add(base))),
            _mm256_mul_pd(yf, curvature),
        );
        let grad_diff = _mm256_add_pd(gmax, yg);
        let positive = _mm256_cmp_pd::<_CMP_GT_OQ>(quad, zero);
        let obj = _mm256_div_pd(
            _mm256_xor_pd(_mm256_mul_pd(grad_diff, grad_diff), sign),
            _mm256_blendv_pd(tau, quad, positive),
        );
        let larger = _mm256_and_pd(low, _mm256_cmp_pd::<_CMP_GT_OQ>(yg, gmax2));
        gmax2 = _mm256_blendv_pd(gmax2, yg, larger);
        let improves = _mm256_cmp_pd::<_CMP_GT_OQ>(grad_diff, zero);
        let take = _mm256_and_pd(
            _mm256_and_pd(low, improves),
            _mm256_cmp_pd::<_CMP_LE_OQ>(obj, extremes.best()),
        );
        extremes.offer(obj, take);
    }
    let mut lanes_gmax2 = [0.0; LANES];
    _mm256_storeu_pd(lanes_gmax2.as_mut_ptr(), gmax2);
    let gmax2 = lanes_gmax2.into_iter().fold(f64::NEG_INFINITY, f64::max);
    let found = combine(extremes.lanes(), |a, b| a < b);
    scan_partner(y, status, gradient, diagonal, first, whole, found, gmax2)
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
                let q_i = q_i_of(i);
                let first = First {
                    q_i: &q_i,
                    gmax,
                    y_i: f64::from(y[i]),
                    qd_i: diagonal[i],
                    tau: 1e-12,
                };
                let p = best_partner(&y, &status, &gradient, &diagonal, &first);
                // Also the code for CPUs without AVX2, which this one may not run otherwise.
                let one_by_one = scan_partner(
                    &y,
                    &status,
                    &gradient,
                    &diagonal,
                    &first,
                    0,
                    None,
                    f64::NEG_INFINITY,
                );
                assert_eq!(
                    (one_by_one.j, one_by_one.gmax2),
                    (p.j, p.gmax2),
                    "case {case}"
                );
                (i, p.j, gmax, p.gmax2)
            });
            let one_by_one = scan_up(&y, &status, &gradient, 0, None);
            assert_eq!(one_by_one, got.map(|g| (g.0, g.2)));
            assert_eq!(got, expected, "case {case}, {n} variables");
        }
    }
}
