//! Cholesky factorisation and solves for the small dense systems of the Gaussian process
//! (`bayes`), logistic regression's Newton steps (`logreg`) and the linear SVM's
//! interior-point steps (`svm::linear_ipm`): at most a few hundred unknowns, so a
//! linear-algebra crate would be a heavy dependency for a dozen lines.

/// In-place Cholesky factorisation of an `n x n` row-major symmetric matrix, read from its
/// lower triangle: afterwards the lower triangle holds `L` (`A = L L^T`) and the upper is
/// zero. False if the matrix is not positive definite (or not finite).
pub fn factor(a: &mut [f64], n: usize) -> bool {
    for j in 0..n {
        let mut d = a[j * n + j];
        for k in 0..j {
            d -= a[j * n + k] * a[j * n + k];
        }
        if d <= 0.0 || !d.is_finite() {
            return false;
        }
        let d = d.sqrt();
        a[j * n + j] = d;
        for i in j + 1..n {
            let mut s = a[i * n + j];
            for k in 0..j {
                s -= a[i * n + k] * a[j * n + k];
            }
            a[i * n + j] = s / d;
        }
        for i in 0..j {
            a[i * n + j] = 0.0;
        }
    }
    true
}

/// Solves `L x = b` in place.
pub fn solve_lower(l: &[f64], n: usize, b: &mut [f64]) {
    for i in 0..n {
        let mut s = b[i];
        for k in 0..i {
            s -= l[i * n + k] * b[k];
        }
        b[i] = s / l[i * n + i];
    }
}

/// Solves `L^T x = b` in place.
pub fn solve_upper_t(l: &[f64], n: usize, b: &mut [f64]) {
    for i in (0..n).rev() {
        let mut s = b[i];
        for k in i + 1..n {
            s -= l[k * n + i] * b[k];
        }
        b[i] = s / l[i * n + i];
    }
}

/// Solves `A x = b` in place, given the factor `L` of `A` from [`factor`].
pub fn solve(l: &[f64], n: usize, b: &mut [f64]) {
    solve_lower(l, n, b);
    solve_upper_t(l, n, b);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solves_a_small_system_and_refuses_an_indefinite_one() {
        // [[4, 2], [2, 3]] x = [2, 1] -> x = [0.5, 0]
        let mut a = [4.0, 2.0, 2.0, 3.0];
        assert!(factor(&mut a, 2));
        let mut b = [2.0, 1.0];
        solve(&a, 2, &mut b);
        assert!((b[0] - 0.5).abs() < 1e-12 && b[1].abs() < 1e-12, "{b:?}");
        assert!(!factor(&mut [1.0, 2.0, 2.0, 1.0], 2), "indefinite");
        assert!(!factor(&mut [f64::NAN], 1), "not finite");
    }
}
