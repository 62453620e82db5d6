//! Sigma's fast widening, per DOF and step: an exponentially weighted mean of the squared
//! standardised error (e / sigma)^2 of each step over about ten seconds, against the calibrated
//! sigma in force when the step is verified. The calibration and the change detector average
//! over minutes and over every step, so a turn that throws the forecasts of a few leads off
//! (sway 3-6 s ahead missed by 5-6 sigmas for ten seconds of a turn towards following seas,
//! while the longer leads, at no skill anyway, stayed within theirs) was met minutes late.
//! Above [`BAR`] the step's sigma grows by sqrt(mean / BAR). Nothing allocates after
//! construction.

use shipcast_wire::payload::{MAX_STEPS, NUM_DOF};

/// Memory of the mean [values] (10 s at 2 Hz).
const MEMORY: f64 = 20.0;
/// Mean above which sigma widens.
const BAR: f64 = 2.0;
/// Largest squared standardised error one value brings in: one wild error alone must not
/// widen sigma tenfold.
const MAX_Z2: f64 = 100.0;

#[derive(Debug, Clone)]
pub struct Burst {
    mean: Vec<[f64; MAX_STEPS]>,
}

impl Default for Burst {
    fn default() -> Self {
        Self {
            mean: vec![[1.0; MAX_STEPS]; NUM_DOF],
        }
    }
}

impl Burst {
    /// Step index `k` of DOF `d` was verified with squared standardised error `z2`.
    #[inline]
    pub fn observe(&mut self, d: usize, k: usize, z2: f64) {
        if z2.is_finite() {
            let m = &mut self.mean[d][k];
            *m += (z2.min(MAX_Z2) - *m) / MEMORY;
        }
    }

    /// Factor (>= 1) for the sigma of DOF `d`, step index `k`.
    #[inline]
    pub fn factor(&self, d: usize, k: usize) -> f64 {
        (self.mean[d][k] / BAR).max(1.0).sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, StandardNormal};

    #[test]
    fn errors_within_sigma_leave_it_alone_and_a_burst_widens_it_to_the_errors_within_seconds() {
        let mut rng = ChaCha8Rng::seed_from_u64(21);
        let mut b = Burst::default();
        let (mut widened, mut sum) = (0usize, 0.0);
        let n = 20_000;
        for _ in 0..n {
            let e: f64 = StandardNormal.sample(&mut rng);
            b.observe(1, 5, e * e);
            let f = b.factor(1, 5);
            sum += f;
            widened += usize::from(f > 1.0);
        }
        // Independent standard errors: the mean of 20 exceeds the bar 2 rarely (chi-squared
        // with about 39 degrees of freedom over 39, beyond 2: well under 1 %), and by little.
        assert!((widened as f64) < 0.01 * n as f64, "{widened}");
        assert!(sum / (n as f64) < 1.01, "{}", sum / n as f64);
        // Errors of 5 sigma: within 3 memories (30 s at 2 Hz) sigma has grown at least
        // three-fold, to within 10 % of the errors' sqrt(25 / 2); another step, another DOF,
        // are left alone.
        for _ in 0..60 {
            let e: f64 = StandardNormal.sample(&mut rng);
            b.observe(1, 5, 25.0 * e * e);
        }
        let f = b.factor(1, 5);
        assert!(f > 3.0 && f < 1.1 * 12.5f64.sqrt() * 1.2, "{f}");
        assert_eq!(b.factor(1, 6), 1.0);
        assert_eq!(b.factor(0, 5), 1.0);
    }

    #[test]
    fn one_wild_error_widens_sigma_boundedly_and_non_finite_ones_change_nothing() {
        let mut b = Burst::default();
        b.observe(2, 0, f64::NAN);
        b.observe(2, 0, f64::INFINITY);
        assert_eq!(b.factor(2, 0), 1.0);
        b.observe(2, 0, 1e12);
        // (1 + (100 - 1) / 20) / 2 = 2.975.
        assert!((b.factor(2, 0) - 2.975f64.sqrt()).abs() < 1e-12);
    }
}
