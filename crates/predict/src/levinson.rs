//! Levinson recursion for a symmetric positive-definite Toeplitz system `T x = b`, with
//! `T[i][j] = r[|i - j|]` and an arbitrary right-hand side, in O(n^2) operations.
//!
//! The routine follows Golub & Van Loan, "Matrix Computations", algorithm 4.7.2: Durbin's
//! recursion for the Yule-Walker vector runs alongside the solution. Like faer's low-level
//! routines it takes its workspace from the caller, so it never allocates and can run in a
//! loop over many right-hand sides.

/// Why a Toeplitz system could not be solved.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum LevinsonError {
    /// A slice does not have the length the system size requires.
    #[error("Levinson: {what} has length {got}, expected {expected}")]
    Length {
        what: &'static str,
        expected: usize,
        got: usize,
    },
    /// The matrix is not positive definite (or is too close to singular): the leading
    /// principal minor of size `size` is not positive.
    #[error(
        "Levinson: Toeplitz matrix is not positive definite (leading minor of size {size} is not positive)"
    )]
    NotPositiveDefinite { size: usize },
}

/// Workspace length `solve_toeplitz` needs for a system of size `n`.
pub const fn workspace_len(n: usize) -> usize {
    n
}

/// Solve `T x = b` where `T` is the symmetric Toeplitz matrix with first row `r[..n]`,
/// `n = b.len()`. `r` must hold at least `n` values (more are ignored), `x` exactly `n`, and
/// `work` at least `workspace_len(n)`. Non-finite input is reported as not positive definite.
pub fn solve_toeplitz(
    r: &[f64],
    b: &[f64],
    x: &mut [f64],
    work: &mut [f64],
) -> Result<(), LevinsonError> {
    let n = b.len();
    check_len("r", n, r.len(), r.len() >= n)?;
    check_len("x", n, x.len(), x.len() == n)?;
    check_len("work", n, work.len(), work.len() >= workspace_len(n))?;
    if n == 0 {
        return Ok(());
    }
    let r0 = r[0];
    if !positive_and_finite(r0) {
        return Err(LevinsonError::NotPositiveDefinite { size: 1 });
    }
    // Work with the unit-diagonal matrix T / r0; the solution is unchanged when b is also
    // divided by r0.
    let rho = |k: usize| r[k] / r0;
    let y = &mut work[..n];
    x[0] = b[0] / r0;
    if n == 1 {
        return Ok(());
    }
    y[0] = -rho(1);
    let mut alpha = y[0];
    let mut beta = 1.0;
    for k in 1..n {
        // beta_k = (1 - alpha^2) beta_{k-1} is the ratio of consecutive leading minors.
        beta *= 1.0 - alpha * alpha;
        if !positive_and_finite(beta) {
            return Err(LevinsonError::NotPositiveDefinite { size: k + 1 });
        }
        let mut dot_rx = 0.0;
        for i in 0..k {
            dot_rx += rho(i + 1) * x[k - 1 - i];
        }
        let mu = (b[k] / r0 - dot_rx) / beta;
        for i in 0..k {
            x[i] += mu * y[k - 1 - i];
        }
        x[k] = mu;
        if k < n - 1 {
            let mut dot_ry = 0.0;
            for i in 0..k {
                dot_ry += rho(i + 1) * y[k - 1 - i];
            }
            alpha = -(rho(k + 1) + dot_ry) / beta;
            update_yule_walker(&mut y[..k], alpha);
            y[k] = alpha;
        }
    }
    if x.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(LevinsonError::NotPositiveDefinite { size: n })
    }
}

/// False for NaN as well as for zero, negative and infinite values.
fn positive_and_finite(v: f64) -> bool {
    v > 0.0 && v.is_finite()
}

/// `y <- y + alpha * reverse(y)` in place, a pair of mirrored entries at a time.
fn update_yule_walker(y: &mut [f64], alpha: f64) {
    let k = y.len();
    for i in 0..k / 2 {
        let (a, b) = (y[i], y[k - 1 - i]);
        y[i] = a + alpha * b;
        y[k - 1 - i] = b + alpha * a;
    }
    if k % 2 == 1 {
        y[k / 2] *= 1.0 + alpha;
    }
}

fn check_len(
    what: &'static str,
    expected: usize,
    got: usize,
    ok: bool,
) -> Result<(), LevinsonError> {
    if ok {
        Ok(())
    } else {
        Err(LevinsonError::Length {
            what,
            expected,
            got,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::linalg::solvers::Solve;
    use faer::Mat;

    /// Dense reference: build T explicitly and solve with faer's LU.
    fn dense_solve(r: &[f64], b: &[f64]) -> Vec<f64> {
        let n = b.len();
        let t = Mat::from_fn(n, n, |i, j| r[i.abs_diff(j)]);
        let rhs = Mat::from_fn(n, 1, |i, _| b[i]);
        let x = t.partial_piv_lu().solve(&rhs);
        (0..n).map(|i| x[(i, 0)]).collect()
    }

    fn max_rel_diff(a: &[f64], b: &[f64]) -> f64 {
        let scale = b.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        a.iter()
            .zip(b)
            .fold(0.0f64, |m, (x, y)| m.max((x - y).abs() / scale))
    }

    #[test]
    fn levinson_equals_dense_solve() {
        // Autocorrelation of a damped oscillation plus white noise: positive definite and
        // reasonably well conditioned.
        for n in [1usize, 2, 3, 7, 64, 200] {
            let r: Vec<f64> = (0..n)
                .map(|k| {
                    let k = k as f64;
                    (-0.05 * k).exp() * (0.4 * k).cos() + if k == 0.0 { 0.3 } else { 0.0 }
                })
                .collect();
            let b: Vec<f64> = (0..n).map(|i| ((i * 7 % 11) as f64) - 5.0).collect();
            let mut x = vec![0.0; n];
            let mut work = vec![0.0; workspace_len(n)];
            solve_toeplitz(&r, &b, &mut x, &mut work).unwrap();
            let reference = dense_solve(&r, &b);
            let diff = max_rel_diff(&x, &reference);
            assert!(diff < 1e-10, "n = {n}: relative difference {diff}");
        }
    }

    #[test]
    fn scaled_identity_is_solved_exactly() {
        let r = [4.0, 0.0, 0.0, 0.0];
        let b = [4.0, -8.0, 2.0, 0.0];
        let mut x = [0.0; 4];
        solve_toeplitz(&r, &b, &mut x, &mut [0.0; 4]).unwrap();
        assert_eq!(x, [1.0, -2.0, 0.5, 0.0]);
    }

    #[test]
    fn not_positive_definite_is_an_error() {
        let mut x = [0.0; 3];
        let mut work = [0.0; 3];
        // r = (1, 1, 1): the all-ones matrix is singular at size 2.
        let err =
            solve_toeplitz(&[1.0, 1.0, 1.0], &[1.0, 2.0, 3.0], &mut x, &mut work).unwrap_err();
        assert_eq!(err, LevinsonError::NotPositiveDefinite { size: 2 });
        // r = (1, 2): indefinite.
        let err = solve_toeplitz(&[1.0, 2.0], &[1.0, 1.0], &mut x[..2], &mut work).unwrap_err();
        assert_eq!(err, LevinsonError::NotPositiveDefinite { size: 2 });
        let err = solve_toeplitz(&[0.0, 0.0], &[1.0, 1.0], &mut x[..2], &mut work).unwrap_err();
        assert_eq!(err, LevinsonError::NotPositiveDefinite { size: 1 });
        let err =
            solve_toeplitz(&[f64::NAN, 0.0], &[1.0, 1.0], &mut x[..2], &mut work).unwrap_err();
        assert_eq!(err, LevinsonError::NotPositiveDefinite { size: 1 });
        assert!(err.to_string().contains("not positive definite"));
    }

    #[test]
    fn wrong_lengths_are_errors() {
        let mut work = [0.0; 3];
        let err =
            solve_toeplitz(&[1.0, 0.0], &[1.0, 1.0, 1.0], &mut [0.0; 3], &mut work).unwrap_err();
        assert!(matches!(err, LevinsonError::Length { what: "r", .. }));
        let err =
            solve_toeplitz(&[1.0, 0.0, 0.0], &[1.0; 3], &mut [0.0; 2], &mut work).unwrap_err();
        assert!(matches!(err, LevinsonError::Length { what: "x", .. }));
        let err =
            solve_toeplitz(&[1.0, 0.0, 0.0], &[1.0; 3], &mut [0.0; 3], &mut work[..2]).unwrap_err();
        assert!(matches!(err, LevinsonError::Length { what: "work", .. }));
    }
}
