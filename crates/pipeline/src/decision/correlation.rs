//! The correlation of standardised forecast errors across steps, estimated from verified
//! forecasts (u = (actual - mean) / sigma): per quantity, the full matrix
//! corr(i, j) = sum u_i u_j / sqrt(sum u_i^2 sum u_j^2) over every verified forecast, and its
//! lag-one summary rho (the AR(1)-in-lead model used before enough evidence exists and for
//! the deck velocity's sigma).

use super::NUM_QUANTITIES;

use shipcast_wire::payload::MAX_STEPS;

/// Pairs of steps needed before the estimate replaces the configured correlation.
pub const MIN_PAIRS: f64 = 500.0;

/// Verified forecasts needed before the full matrix is used (a 50 x 50 correlation estimated
/// from fewer strongly dependent forecasts is noise).
pub const MIN_FORECASTS: f64 = 600.0;

#[derive(Debug, Clone)]
pub struct ErrorCorrelation {
    /// Per quantity: sum u_k u_(k+1), sum u_k^2, sum u_(k+1)^2, pairs.
    sums: [[f64; 4]; NUM_QUANTITIES],
    /// Per quantity: sum u_i u_j (MAX_STEPS x MAX_STEPS, row-major) and forecasts added.
    products: Vec<Vec<f64>>,
    forecasts: [f64; NUM_QUANTITIES],
    steps: [usize; NUM_QUANTITIES],
    fallback: [f64; NUM_QUANTITIES],
}

impl ErrorCorrelation {
    /// `fallback`: what [`Self::rho`] tells before `MIN_PAIRS` pairs were seen.
    pub fn new(fallback: [f64; NUM_QUANTITIES]) -> Self {
        Self {
            sums: [[0.0; 4]; NUM_QUANTITIES],
            products: vec![vec![0.0; MAX_STEPS * MAX_STEPS]; NUM_QUANTITIES],
            forecasts: [0.0; NUM_QUANTITIES],
            steps: [0; NUM_QUANTITIES],
            fallback,
        }
    }

    /// The full correlation matrix of quantity `q` over `steps` steps into `out` (row-major,
    /// `steps` columns), if enough forecasts of that many finite steps were verified.
    pub fn matrix(&self, q: usize, steps: usize, out: &mut [f64]) -> bool {
        if self.forecasts[q] < MIN_FORECASTS || self.steps[q] != steps || out.len() < steps * steps
        {
            return false;
        }
        let p = &self.products[q];
        for i in 0..steps {
            for j in 0..steps {
                let d = (p[i * MAX_STEPS + i] * p[j * MAX_STEPS + j]).sqrt();
                out[i * steps + j] = if d > 0.0 {
                    p[i * MAX_STEPS + j] / d
                } else {
                    0.0
                };
            }
        }
        true
    }

    /// Add one verified forecast's standardised errors of quantity `q` (consecutive steps;
    /// non-finite entries, from missing values, and errors beyond [`MAX_CORRELATED_U`] sigma
    /// break the run). Review: a miss at sigma 0 (1e30 sigma) entered the products as 1e60
    /// and made the matrix that one forecast's for good; errors of 1e12 sigma, from a sigma
    /// that collapsed while a sensor was frozen, did the same.
    pub fn add(&mut self, q: usize, u: &[f64]) {
        let steps = u.len().min(MAX_STEPS);
        if steps > 0 && u[..steps].iter().all(|&v| scaled(v)) {
            if self.steps[q] != steps {
                // A new horizon: the products were about other steps.
                self.products[q].iter_mut().for_each(|v| *v = 0.0);
                self.forecasts[q] = 0.0;
                self.steps[q] = steps;
            }
            let p = &mut self.products[q];
            for i in 0..steps {
                for j in 0..steps {
                    p[i * MAX_STEPS + j] += u[i] * u[j];
                }
            }
            self.forecasts[q] += 1.0;
        }
        let s = &mut self.sums[q];
        for pair in u.windows(2) {
            let (a, b) = (pair[0], pair[1]);
            if scaled(a) && scaled(b) {
                s[0] += a * b;
                s[1] += a * a;
                s[2] += b * b;
                s[3] += 1.0;
            }
        }
    }

    pub fn pairs(&self, q: usize) -> f64 {
        self.sums[q][3]
    }

    /// The estimate, clamped to [0, 1) (the AR(1) model has no negative lag-one
    /// correlation in use: a negative estimate is taken as independence).
    pub fn rho(&self) -> [f64; NUM_QUANTITIES] {
        std::array::from_fn(|q| {
            let s = self.sums[q];
            let denom = (s[1] * s[2]).sqrt();
            if s[3] < MIN_PAIRS || denom.is_nan() || denom <= 0.0 {
                self.fallback[q]
            } else {
                (s[0] / denom).clamp(0.0, super::window::MAX_RHO)
            }
        })
    }
}

/// Standardised errors beyond this many sigma say the sigma was wrong, not how errors at
/// neighbouring steps go together: one forecast at u adds u^2 to every product, where an
/// ordinary one adds about 1 and the matrix is used after 600 (review: at the first bound,
/// 1000, one forecast at 500 sigma made the matrix all ones). An honest Gaussian error
/// passes 8 sigma about never; 20 leaves room for heavy tails.
pub const MAX_CORRELATED_U: f64 = 20.0;

/// Whether a standardised error tells about the correlation: finite and within
/// [`MAX_CORRELATED_U`].
fn scaled(u: f64) -> bool {
    u.is_finite() && u.abs() <= MAX_CORRELATED_U
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};

    #[test]
    fn recovers_the_correlation_of_ar1_errors() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let rhos = [0.0, 0.5, 0.9, 0.97];
        let mut est = ErrorCorrelation::new([0.3; NUM_QUANTITIES]);
        assert_eq!(est.rho(), [0.3; NUM_QUANTITIES], "fallback before evidence");
        let mut u = vec![0.0; 40];
        for _ in 0..2000 {
            for (q, &rho) in rhos.iter().enumerate() {
                let c = (1.0f64 - rho * rho).sqrt();
                u[0] = StandardNormal.sample(&mut rng);
                for k in 1..u.len() {
                    let w: f64 = StandardNormal.sample(&mut rng);
                    u[k] = rho * u[k - 1] + c * w;
                }
                est.add(q, &u);
            }
        }
        let got = est.rho();
        let mut m = vec![0.0; 40 * 40];
        for (q, &rho) in rhos.iter().enumerate() {
            assert!((got[q] - rho).abs() < 0.02, "q {q}: {} vs {rho}", got[q]);
            // The full matrix: rho^lag at lags 1, 3 and 10.
            assert!(est.matrix(q, 40, &mut m));
            for lag in [1usize, 3, 10] {
                let c = m[5 * 40 + 5 + lag];
                assert!(
                    (c - rho.powi(lag as i32)).abs() < 0.06,
                    "q {q} lag {lag}: {c}"
                );
            }
            assert!((m[7 * 40 + 7] - 1.0).abs() < 1e-12);
        }
        assert!(!est.matrix(0, 30, &mut m), "other steps than verified");
        // A break (no sigma) does not pair across it.
        let mut e = ErrorCorrelation::new([0.0; NUM_QUANTITIES]);
        e.add(0, &[1.0, f64::NAN, 1.0]);
        assert_eq!(e.pairs(0), 0.0);
        // Nor across a miss at sigma 0 or a sigma far too small, and a forecast with one is
        // not in the matrix.
        e.add(0, &[1.0, -super::super::UNBOUNDED_ERROR, 1.0]);
        e.add(0, &[1.0, 2e12, 1.0]);
        assert_eq!(e.pairs(0), 0.0);
        for _ in 0..MIN_FORECASTS as usize {
            e.add(1, &[1.0, 0.5, -1.0]);
        }
        let mut before = vec![0.0; 9];
        assert!(e.matrix(1, 3, &mut before));
        e.add(1, &[1.0, 1.5 * MAX_CORRELATED_U, -1.0]);
        let mut after = vec![0.0; 9];
        assert!(e.matrix(1, 3, &mut after));
        assert_eq!(before, after);
        assert_eq!(e.pairs(1), 2.0 * MIN_FORECASTS);
    }
}
