//! The eigen-decomposition of the MCA window correlation matrix R = X X^T (X: n x w, one window
//! per column) and the prediction matrix built from it.
//!
//! With fewer windows than the order (w < n: the paper's shift 10 on a few thousand values gives
//! 421 windows of 800), R has rank at most w. The decomposition then goes through a QR
//! factorisation X = Q_x R_x: R = Q_x (R_x R_x^T) Q_x^T, so the w x w matrix S = R_x R_x^T has
//! the non-zero eigenvalues of R, its eigenvectors mapped by Q_x are theirs, and the other
//! n - w eigenvalues are exactly zero with the orthogonal complement of range(Q_x) as
//! eigenvectors. That null space is never formed: the completion of a window needs the
//! projector onto the minor components B B^T, which is I - V V^T for the major ones V, all in
//! the range. Householder QR is backward stable like the n x n eigen-decomposition, and it is
//! much smaller: w^3 instead of n^3 work (MCA-800 on 5000 values: 22-28 ms against 54 ms for
//! the 800 x 800 eigen-decomposition, `cargo bench --bench mca_vs_numpy`).

use super::LinearMap;
use super::McaWeighting;
use crate::PredictError;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::householder;
use faer::linalg::matmul::matmul;
use faer::linalg::solvers::{Qr, Solve};
use faer::{get_global_parallelism, Accum, Conj, Mat, MatRef, Side};

/// Eigen-decomposition of the window correlation matrix R = sum X X^T.
pub(super) struct Spectrum {
    /// All n eigenvalues, ascending.
    eigenvalues: Vec<f64>,
    vectors: Eigenvectors,
}

enum Eigenvectors {
    /// Every eigenvector of R: column i belongs to eigenvalue i.
    Full(Mat<f64>),
    /// Fewer windows than n: X = Q_x R_x and the eigenvectors U of R_x R_x^T. Eigenvalue
    /// n - w + j belongs to eigenvector Q_x U[.., j]; the first n - w eigenvalues are the
    /// (exactly zero) null space of R.
    Range { qr: Qr<f64>, u: Mat<f64> },
}

/// How a factor F gives the projector the prediction uses.
#[derive(Clone, Copy)]
enum Projector {
    /// M = F F^T.
    Factor,
    /// M = I - F F^T.
    Complement,
}

/// What `Spectrum::model` learns: P and the number of eigen-directions it used.
pub(super) struct SpectrumModel {
    pub prediction: LinearMap,
    pub minor_components: usize,
}

impl Spectrum {
    /// Windows of length `n` starting at 0, shift, 2 shift, ... of `series`
    /// (at least one window: callers check `series.len() >= n`).
    pub fn of_windows(series: &[f64], n: usize, shift: usize) -> Result<Self, PredictError> {
        let windows = (series.len() - n) / shift + 1;
        let x = Mat::from_fn(n, windows, |i, j| series[j * shift + i]);
        let par = get_global_parallelism();
        let numerical = |e| PredictError::Numerical(format!("MCA eigen-decomposition: {e:?}"));
        if windows >= n {
            let mut r = Mat::<f64>::zeros(n, n);
            matmul(
                r.as_mut(),
                Accum::Replace,
                x.as_ref(),
                x.transpose(),
                1.0,
                par,
            );
            let evd = r.self_adjoint_eigen(Side::Lower).map_err(numerical)?;
            return Ok(Self {
                eigenvalues: evd.S().column_vector().iter().copied().collect(),
                vectors: Eigenvectors::Full(evd.U().to_owned()),
            });
        }
        let qr = x.qr();
        let r_x = qr.thin_R();
        let mut s = Mat::<f64>::zeros(windows, windows);
        matmul(s.as_mut(), Accum::Replace, r_x, r_x.transpose(), 1.0, par);
        let evd = s.self_adjoint_eigen(Side::Lower).map_err(numerical)?;
        let mut eigenvalues = vec![0.0; n - windows];
        eigenvalues.extend(evd.S().column_vector().iter().copied());
        Ok(Self {
            eigenvalues,
            vectors: Eigenvectors::Range {
                qr,
                u: evd.U().to_owned(),
            },
        })
    }

    /// Number of minor components for `energy`: the smallest eigenvalues whose sum is at most
    /// `energy` of the trace, and at least `horizon` of them.
    pub fn minor_count(&self, energy: f64, horizon: usize) -> usize {
        let trace: f64 = self.eigenvalues.iter().sum();
        let budget = energy * trace;
        let mut cumulative = 0.0;
        let mut count = 0;
        for &lambda in &self.eigenvalues {
            if cumulative + lambda > budget {
                break;
            }
            cumulative += lambda;
            count += 1;
        }
        count.max(horizon).min(self.eigenvalues.len())
    }

    /// P for `weighting`: the paper's minor components for `energy` (at least `horizon`), with
    /// `ridge` on their Gram matrix, or every direction weighted by 1/(lambda + eps).
    pub fn model(
        &self,
        weighting: McaWeighting,
        energy: f64,
        horizon: usize,
        ridge: f64,
    ) -> Result<SpectrumModel, PredictError> {
        let n = self.eigenvalues.len();
        let (prediction, minor_components) = match (weighting, &self.vectors) {
            (McaWeighting::Paper, Eigenvectors::Full(v)) => {
                let k = self.minor_count(energy, horizon);
                let minor = v.as_ref().subcols(0, k);
                (
                    prediction_matrix(minor, Projector::Factor, horizon, ridge)?,
                    k,
                )
            }
            (McaWeighting::Paper, Eigenvectors::Range { qr, u }) => {
                // The null space has eigenvalue 0 and is always within the energy budget.
                let null = n - u.ncols();
                let k = self.minor_count(energy, horizon).max(null);
                let major = range_vectors(qr, u.as_ref().subcols(k - null, n - k));
                let map = prediction_matrix(major.as_ref(), Projector::Complement, horizon, ridge)?;
                (map, k)
            }
            (McaWeighting::Inverse, Eigenvectors::Full(v)) => {
                let scale = self.inverse_weights(ridge, |w| w.sqrt());
                let weighted = Mat::from_fn(n, n, |i, j| v[(i, j)] * scale[j]);
                let map = prediction_matrix(weighted.as_ref(), Projector::Factor, horizon, 0.0)?;
                (map, n)
            }
            (McaWeighting::Inverse, Eigenvectors::Range { qr, u }) => {
                // M = sum w_i v_i v_i^T = I - sum (1 - w_i) v_i v_i^T, and 1 - w_i = 0 on the
                // null space.
                let null = n - u.ncols();
                let scale = self.inverse_weights(ridge, |w| (1.0 - w).max(0.0).sqrt());
                let weighted =
                    Mat::from_fn(u.nrows(), u.ncols(), |i, j| u[(i, j)] * scale[null + j]);
                let complement = range_vectors(qr, weighted.as_ref());
                let map =
                    prediction_matrix(complement.as_ref(), Projector::Complement, horizon, 0.0)?;
                (map, n)
            }
        };
        Ok(SpectrumModel {
            prediction,
            minor_components,
        })
    }

    /// `f(w_i)` for every eigenvalue, w_i = eps / (lambda_i + eps): the weights that make
    /// the Gram matrices `prediction_matrix` forms blocks of M = V diag(w) V^T. The common
    /// factor eps leaves P unchanged and keeps w in (0, 1] (null space ~1, strong directions
    /// ~eps/lambda), which keeps the Cholesky factorisation well scaled.
    ///
    /// eps = ridge * mean eigenvalue, floored at n * machine epsilon * largest eigenvalue: below
    /// that the eigenvalues of a rank-deficient R (fewer windows than n) are rounding noise,
    /// possibly negative (clamped to 0), and 1/lambda would be meaningless.
    fn inverse_weights(&self, ridge: f64, f: impl Fn(f64) -> f64) -> Vec<f64> {
        let n = self.eigenvalues.len();
        let largest = self.eigenvalues.last().copied().unwrap_or(0.0).max(0.0);
        let mean = self.eigenvalues.iter().map(|l| l.max(0.0)).sum::<f64>() / n.max(1) as f64;
        let eps = (ridge * mean).max(n as f64 * f64::EPSILON * largest);
        // An all-zero training series has R = 0: any eps gives equal weights and P = 0.
        let eps = if eps > 0.0 { eps } else { 1.0 };
        self.eigenvalues
            .iter()
            .map(|&l| f(eps / (l.max(0.0) + eps)))
            .collect()
    }
}

/// Q_x [coefficients; 0]: eigenvectors of R from those of R_x R_x^T (n x columns).
fn range_vectors(qr: &Qr<f64>, coefficients: MatRef<'_, f64>) -> Mat<f64> {
    let (n, cols) = (qr.Q_basis().nrows(), coefficients.ncols());
    let mut v = Mat::<f64>::zeros(n, cols);
    v.as_mut()
        .subrows_mut(0, coefficients.nrows())
        .copy_from(coefficients);
    let blocksize = qr.Q_coeff().nrows();
    let mut scratch = MemBuffer::new(
        householder::apply_block_householder_sequence_on_the_left_in_place_scratch::<f64>(
            n, blocksize, cols,
        ),
    );
    householder::apply_block_householder_sequence_on_the_left_in_place_with_conj(
        qr.Q_basis(),
        qr.Q_coeff(),
        Conj::No,
        v.as_mut(),
        get_global_parallelism(),
        MemStack::new(&mut scratch),
    );
    v
}

/// Smallest mean diagonal of M22 (the future's share of the projector) a map is solved from.
const MIN_FUTURE_SHARE: f64 = 1e-12;

/// P = -(M22 + ridge)^-1 M21 from the projector M that `factor` (n x k) gives: M = B B^T for the
/// minor eigenvectors B (`Projector::Factor`), or M = I - V V^T for the major ones V
/// (`Projector::Complement`). The window's first n - horizon values are the past, the last
/// `horizon` the future.
fn prediction_matrix(
    factor: MatRef<'_, f64>,
    projector: Projector,
    horizon: usize,
    ridge: f64,
) -> Result<LinearMap, PredictError> {
    let n = factor.nrows();
    let n1 = n - horizon;
    let past = factor.subrows(0, n1);
    let future = factor.subrows(n1, horizon);
    let par = get_global_parallelism();
    let sign = match projector {
        Projector::Factor => 1.0,
        Projector::Complement => -1.0,
    };
    let mut gram = Mat::<f64>::zeros(horizon, horizon);
    matmul(
        gram.as_mut(),
        Accum::Replace,
        future,
        future.transpose(),
        sign,
        par,
    );
    if let Projector::Complement = projector {
        for i in 0..horizon {
            gram[(i, i)] += 1.0;
        }
    }
    // M22's diagonal: the future's share of the projector, at most 1 (B is orthonormal).
    // Next to none (windows whose minor directions lie in the past alone, such as (a, a, b))
    // leaves the future undetermined: the ridge, relative to it, cannot help, and the map came
    // out with gains of 1e16 (review).
    let mean_diag = (0..horizon).map(|i| gram[(i, i)]).sum::<f64>() / horizon as f64;
    if mean_diag.is_nan() || mean_diag <= MIN_FUTURE_SHARE {
        return Err(PredictError::Numerical(format!(
            "MCA: the projector holds next to no future part (mean diagonal of M22 {mean_diag:.1e}): the training windows do not tie the future to the past; more minor components (a larger --energy) or another method"
        )));
    }
    if ridge > 0.0 {
        for i in 0..horizon {
            gram[(i, i)] += ridge * mean_diag;
        }
    }
    // -M21; the identity has no off-diagonal block.
    let mut rhs = Mat::<f64>::zeros(horizon, n1);
    matmul(
        rhs.as_mut(),
        Accum::Replace,
        future,
        past.transpose(),
        -sign,
        par,
    );
    let llt = gram.llt(Side::Lower).map_err(|e| {
        PredictError::Numerical(format!(
            "MCA: B2^T B2 is not positive definite ({e}); more minor components or mca_ridge > 0 may help"
        ))
    })?;
    llt.solve_in_place(rhs.as_mut());
    let mut coef = Vec::with_capacity(horizon * n1);
    for h in 0..horizon {
        coef.extend((0..n1).map(|j| rhs[(h, j)]));
    }
    LinearMap::from_row_major(horizon, n1, coef)
        .map_err(|e| PredictError::Numerical(format!("MCA prediction matrix: {e}")))
}
