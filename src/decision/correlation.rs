//! The step-to-step correlation of standardised forecast errors, estimated from verified
//! forecasts: per quantity, rho = sum u_k u_(k+1) / sqrt(sum u_k^2 sum u_(k+1)^2) over every
//! pair of neighbouring steps of every verified forecast, u = (actual - mean) / sigma. That is
//! the lag-one correlation that defines the AR(1)-in-lead error model of [`super::window`].

use super::NUM_QUANTITIES;

/// Pairs of steps needed before the estimate replaces the configured correlation.
pub const MIN_PAIRS: f64 = 500.0;

#[derive(Debug, Clone)]
pub struct ErrorCorrelation {
    /// Per quantity: sum u_k u_(k+1), sum u_k^2, sum u_(k+1)^2, pairs.
    sums: [[f64; 4]; NUM_QUANTITIES],
    fallback: [f64; NUM_QUANTITIES],
}

impl ErrorCorrelation {
    /// `fallback`: what [`Self::rho`] tells before `MIN_PAIRS` pairs were seen.
    pub fn new(fallback: [f64; NUM_QUANTITIES]) -> Self {
        Self {
            sums: [[0.0; 4]; NUM_QUANTITIES],
            fallback,
        }
    }

    /// Add one verified forecast's standardised errors of quantity `q` (consecutive steps;
    /// non-finite entries, from steps without sigma, break the run).
    pub fn add(&mut self, q: usize, u: &[f64]) {
        let s = &mut self.sums[q];
        for pair in u.windows(2) {
            let (a, b) = (pair[0], pair[1]);
            if a.is_finite() && b.is_finite() {
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
        for (q, &rho) in rhos.iter().enumerate() {
            assert!((got[q] - rho).abs() < 0.02, "q {q}: {} vs {rho}", got[q]);
        }
        // A break (no sigma) does not pair across it.
        let mut e = ErrorCorrelation::new([0.0; NUM_QUANTITIES]);
        e.add(0, &[1.0, f64::NAN, 1.0]);
        assert_eq!(e.pairs(0), 0.0);
    }
}
