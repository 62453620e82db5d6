//! Probability that a forecast quantity stays within +-limit at every step of a window, when
//! its errors form a Gaussian AR(1) chain in lead: the standardised error z_k = e_k / sigma_k
//! follows z_k = rho z_(k-1) + sqrt(1 - rho^2) w_k with independent standard normal w_k, so
//! corr(z_i, z_j) = rho^|i-j|.
//!
//! The rectangle probability of that chain is computed by Genz's separation of variables
//! (Genz 1992, "Numerical computation of multivariate normal probabilities"): step by step, the
//! conditional probability that z_k lands inside its interval given z_(k-1) multiplies a
//! weight, and z_k is then drawn inside the interval by inverting the conditional CDF at a
//! lattice point. The average weight over the lattice is an unbiased estimate of the exact
//! probability whose error is far below a plain Monte Carlo's with as many points, and the
//! fixed lattice makes every decision reproducible.

use super::super::deck::normal_cdf;

/// Largest correlation used: at 1 the chain has no innovation and the conditional step
/// divides by zero; 0.999 is a chain that forgets over a thousand steps.
pub const MAX_RHO: f64 = 0.999;

/// A fixed rank-1 lattice of `points` points in `dims` dimensions (Richtmyer: the fractional
/// parts of (i + 1/2) sqrt(p_d) for the d-th prime p_d). Deterministic, so every decision is
/// reproducible; at a few dozen points it is far closer to the exact probability than as many
/// pseudo-random points (measured in the tests below).
#[derive(Debug, Clone)]
pub struct Lattice {
    points: usize,
    dims: usize,
    u: Vec<f64>,
}

impl Lattice {
    pub fn new(points: usize, dims: usize) -> Self {
        let points = points.max(1);
        let primes = first_primes(dims);
        let mut u = Vec::with_capacity(points * dims);
        for i in 0..points {
            for p in &primes {
                let alpha = (*p as f64).sqrt().fract();
                u.push(((i as f64 + 0.5) * alpha).fract());
            }
        }
        Self { points, dims, u }
    }

    pub fn points(&self) -> usize {
        self.points
    }

    pub fn dims(&self) -> usize {
        self.dims
    }

    fn point(&self, i: usize) -> &[f64] {
        &self.u[i * self.dims..(i + 1) * self.dims]
    }
}

fn first_primes(n: usize) -> Vec<u64> {
    let mut primes = Vec::with_capacity(n);
    let mut c = 2u64;
    while primes.len() < n {
        if primes
            .iter()
            .take_while(|&&p| p * p <= c)
            .all(|&p| !c.is_multiple_of(p))
        {
            primes.push(c);
        }
        c += 1;
    }
    primes
}

/// One step of Genz's separation of variables: with the standardised error of this step
/// `centre + scale * w` (w standard normal given the steps before), the CDF value of w at the
/// band's lower edge and the probability that |mean + sigma z| <= limit.
fn conditional_band(mean: f64, sigma: f64, limit: f64, centre: f64, scale: f64) -> (f64, f64) {
    let a = (-limit - mean) / sigma;
    let b = (limit - mean) / sigma;
    let lo = normal_cdf((a - centre) / scale);
    let hi = normal_cdf((b - centre) / scale);
    (lo, (hi - lo).max(0.0))
}

/// P(|mean_k + sigma_k z_k| <= limit for every k) for the AR(1) chain z with correlation
/// `rho` between neighbouring steps. A step with zero sigma counts as certain (it holds or fails
/// on its mean alone) and does not break the chain. A step whose sigma is unknown (NaN) cannot be
/// shown to hold, so the window's probability is 0: an unknown error is no licence for a go.
/// Steps beyond the lattice's dimension are not computed: callers size the lattice to the
/// longest window.
pub fn chain_within(mean: &[f64], sigma: &[f64], limit: f64, rho: f64, lattice: &Lattice) -> f64 {
    let n = mean.len().min(sigma.len());
    if n == 0 {
        return 1.0;
    }
    if sigma[..n].iter().any(|s| s.is_nan()) {
        return 0.0;
    }
    // Certain steps decide alone; the chain only sees the uncertain ones.
    if (0..n).any(|k| certain(sigma[k]) && (mean[k].is_nan() || mean[k].abs() > limit)) {
        return 0.0;
    }
    if (0..n).all(|k| certain(sigma[k])) {
        return 1.0;
    }
    let rho = rho.clamp(0.0, MAX_RHO);
    let innovation = (1.0 - rho * rho).sqrt();
    let mut total = 0.0;
    for i in 0..lattice.points() {
        let u = lattice.point(i);
        let mut weight = 1.0;
        let mut z_prev: Option<f64> = None;
        for k in 0..n.min(lattice.dims()) {
            let s = sigma[k];
            if certain(s) {
                continue;
            }
            let (centre, scale) = match z_prev {
                Some(z) => (rho * z, innovation),
                None => (0.0, 1.0),
            };
            let (lo, p) = conditional_band(mean[k], s, limit, centre, scale);
            weight *= p;
            if weight == 0.0 {
                break;
            }
            let w = inverse_normal_cdf(lo + u[k] * p);
            z_prev = Some(centre + scale * w);
        }
        total += weight;
    }
    (total / lattice.points() as f64).clamp(0.0, 1.0)
}

/// P(|mean_k + sigma_k z_k| <= limit for every k) for standard normal z with correlation
/// matrix C = L L^T, `chol` the lower Cholesky factor L (n x n, row-major). Genz's separation
/// of variables with the full factor; None when a step has no sigma (the chain form handles
/// those).
pub fn correlated_within(
    mean: &[f64],
    sigma: &[f64],
    limit: f64,
    chol: &[f64],
    lattice: &Lattice,
    y: &mut [f64],
) -> Option<f64> {
    let n = mean.len().min(sigma.len());
    if n == 0 {
        return Some(1.0);
    }
    if chol.len() < n * n
        || y.len() < n
        || lattice.dims() < n
        || sigma[..n].iter().any(|&s| s.is_nan() || certain(s))
    {
        return None;
    }
    let mut total = 0.0;
    for i in 0..lattice.points() {
        let u = lattice.point(i);
        let mut weight = 1.0;
        for k in 0..n {
            let row = &chol[k * n..k * n + k + 1];
            let centre: f64 = row[..k].iter().zip(&y[..k]).map(|(l, w)| l * w).sum();
            let scale = row[k];
            let (lo, p) = conditional_band(mean[k], sigma[k], limit, centre, scale);
            weight *= p;
            if weight == 0.0 {
                break;
            }
            y[k] = inverse_normal_cdf(lo + u[k] * p);
        }
        total += weight;
    }
    Some((total / lattice.points() as f64).clamp(0.0, 1.0))
}

/// Lower Cholesky factor of the n x n block of `corr` (row-major, `stride` columns) starting
/// at (start, start), into `out`; false when the block is not positive definite.
pub fn cholesky_block(
    corr: &[f64],
    stride: usize,
    start: usize,
    n: usize,
    out: &mut [f64],
) -> bool {
    if out.len() < n * n || (start + n) * stride > corr.len() {
        return false;
    }
    for i in 0..n {
        for j in 0..=i {
            let c = corr[(start + i) * stride + start + j];
            let s: f64 = (0..j).map(|k| out[i * n + k] * out[j * n + k]).sum();
            if i == j {
                let d = c - s;
                if d.is_nan() || d <= 1e-10 {
                    return false;
                }
                out[i * n + i] = d.sqrt();
            } else {
                out[i * n + j] = (c - s) / out[j * n + j];
            }
        }
        for j in i + 1..n {
            out[i * n + j] = 0.0;
        }
    }
    true
}

/// Zero sigma: the step holds or fails on its mean alone. (NaN is not certainty; callers refuse
/// it first.)
fn certain(sigma: f64) -> bool {
    sigma <= 0.0
}

/// Standard normal quantile (Acklam's rational approximation, relative error below 1.2e-9),
/// clamped to +-8.3 at the ends so that a probability of exactly 0 or 1 stays finite.
pub fn inverse_normal_cdf(p: f64) -> f64 {
    const A: [f64; 6] = [
        -3.969683028665376e1,
        2.209460984245205e2,
        -2.759285104469687e2,
        1.383_577_518_672_69e2,
        -3.066479806614716e1,
        2.506628277459239,
    ];
    const B: [f64; 5] = [
        -5.447609879822406e1,
        1.615858368580409e2,
        -1.556989798598866e2,
        6.680131188771972e1,
        -1.328068155288572e1,
    ];
    const C: [f64; 6] = [
        -7.784894002430293e-3,
        -3.223964580411365e-1,
        -2.400758277161838,
        -2.549732539343734,
        4.374664141464968,
        2.938163982698783,
    ];
    const D: [f64; 4] = [
        7.784695709041462e-3,
        3.224671290700398e-1,
        2.445134137142996,
        3.754408661907416,
    ];
    let p = p.clamp(1e-16, 1.0 - 1e-16);
    let low = 0.02425;
    if p < low {
        let q = (-2.0 * p.ln()).sqrt();
        (((((C[0] * q + C[1]) * q + C[2]) * q + C[3]) * q + C[4]) * q + C[5])
            / ((((D[0] * q + D[1]) * q + D[2]) * q + D[3]) * q + 1.0)
    } else if p <= 1.0 - low {
        let q = p - 0.5;
        let r = q * q;
        (((((A[0] * r + A[1]) * r + A[2]) * r + A[3]) * r + A[4]) * r + A[5]) * q
            / (((((B[0] * r + B[1]) * r + B[2]) * r + B[3]) * r + B[4]) * r + 1.0)
    } else {
        -inverse_normal_cdf(1.0 - p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::deck::prob_within;
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};

    #[test]
    fn quantile_inverts_the_cdf() {
        for &p in &[1e-6, 0.01, 0.1, 0.3, 0.5, 0.8, 0.975, 0.999] {
            let x = inverse_normal_cdf(p);
            assert!((normal_cdf(x) - p).abs() < 3e-7, "{p} {x}");
        }
        assert!((inverse_normal_cdf(0.975) - 1.959964).abs() < 1e-5);
        assert!(inverse_normal_cdf(0.0).is_finite() && inverse_normal_cdf(1.0).is_finite());
    }

    #[test]
    fn independent_steps_multiply_and_identical_steps_take_the_least() {
        let lattice = Lattice::new(64, 8);
        let mean = [0.2, -0.5, 0.9, 0.0];
        let sigma = [0.5, 0.7, 0.4, 1.0];
        // rho = 0: independent steps, the product of the marginals (exact in one dimension
        // per step, so the lattice estimate is exact up to the CDF's accuracy).
        let product: f64 = (0..4)
            .map(|k| prob_within(mean[k], sigma[k], 1.2))
            .product();
        let p = chain_within(&mean, &sigma, 1.2, 0.0, &lattice);
        assert!((p - product).abs() < 1e-6, "{p} {product}");
        // rho -> 1 with the same mean and sigma at every step: the window holds nearly as
        // often as a single step does (never more often).
        let one = prob_within(0.3, 0.5, 1.0);
        let p = chain_within(&[0.3; 8], &[0.5; 8], 1.0, MAX_RHO, &Lattice::new(4096, 8));
        assert!(p <= one && p > one - 0.03, "{p} {one}");
        // A certain step outside the limit closes the window; certain steps inside do nothing.
        assert_eq!(
            chain_within(&[0.0, 2.0], &[0.0, 0.0], 1.0, 0.5, &lattice),
            0.0
        );
        assert_eq!(
            chain_within(&[0.0, 0.5], &[0.0, 0.0], 1.0, 0.5, &lattice),
            1.0
        );
        // An unknown sigma is no certainty: the window cannot be shown to hold, even with a
        // mean well inside the limit.
        assert_eq!(
            chain_within(&[0.0, 0.5], &[0.1, f64::NAN], 1.0, 0.5, &lattice),
            0.0
        );
    }

    #[test]
    fn full_correlation_matches_the_chain_and_a_monte_carlo_of_oscillating_errors() {
        let n = 16;
        let mean: Vec<f64> = (0..n).map(|k| 0.5 * (k as f64 * 0.4).cos()).collect();
        let sigma = vec![0.4; n];
        let lattice = Lattice::new(8192, n);
        let mut chol = vec![0.0; n * n];
        let mut y = vec![0.0; n];
        // AR(1) correlation: the full form agrees with the chain form.
        let rho: f64 = 0.8;
        let ar1: Vec<f64> = (0..n * n)
            .map(|i| rho.powi((i / n).abs_diff(i % n) as i32))
            .collect();
        assert!(cholesky_block(&ar1, n, 0, n, &mut chol));
        let full = correlated_within(&mean, &sigma, 1.0, &chol, &lattice, &mut y).unwrap();
        let chain = chain_within(&mean, &sigma, 1.0, rho, &lattice);
        assert!((full - chain).abs() < 0.005, "{full} {chain}");
        // A damped oscillating correlation (errors of a resonant sea), against paths drawn
        // from its Cholesky factor by a different generator.
        let corr: Vec<f64> = (0..n * n)
            .map(|i| {
                let lag = (i / n).abs_diff(i % n) as f64;
                (-0.05 * lag).exp() * (std::f64::consts::TAU * lag / 16.0).cos()
            })
            .collect();
        assert!(cholesky_block(&corr, n, 0, n, &mut chol));
        let p = correlated_within(&mean, &sigma, 1.0, &chol, &lattice, &mut y).unwrap();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let paths = 100_000;
        let mut inside = 0u64;
        let mut w = vec![0.0; n];
        for _ in 0..paths {
            for v in w.iter_mut() {
                *v = StandardNormal.sample(&mut rng);
            }
            let ok = (0..n).all(|k| {
                let z: f64 = (0..=k).map(|j| chol[k * n + j] * w[j]).sum();
                (mean[k] + sigma[k] * z).abs() <= 1.0
            });
            inside += u64::from(ok);
        }
        let mc = inside as f64 / paths as f64;
        let se = (mc * (1.0 - mc) / paths as f64).sqrt();
        assert!((p - mc).abs() < 4.0 * se + 0.005, "{p} {mc}");
        // A block that is not positive definite is refused.
        assert!(!cholesky_block(&[1.0, 2.0, 2.0, 1.0], 2, 0, 2, &mut chol));
    }

    /// The joint window probability against a plain Monte Carlo of the correlated Gaussian
    /// errors (a different generator and method: explicit AR(1) paths, counting the paths that
    /// stay inside).
    #[test]
    fn window_probability_matches_a_monte_carlo_of_correlated_errors() {
        let n = 20;
        let mean: Vec<f64> = (0..n).map(|k| 0.6 * (k as f64 * 0.5).sin()).collect();
        let sigma: Vec<f64> = (0..n).map(|k| 0.2 + 0.02 * k as f64).collect();
        let limit = 1.0;
        let fine = Lattice::new(32768, n);
        let production = Lattice::new(
            super::super::LATTICE_POINTS,
            shipcast_wire::payload::MAX_STEPS,
        );
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        for &rho in &[0.0, 0.5, 0.9, 0.98] {
            let paths = 200_000;
            let c = (1.0f64 - rho * rho).sqrt();
            let mut inside = 0u64;
            for _ in 0..paths {
                let mut z: f64 = StandardNormal.sample(&mut rng);
                let mut ok = (mean[0] + sigma[0] * z).abs() <= limit;
                for k in 1..n {
                    let w: f64 = StandardNormal.sample(&mut rng);
                    z = rho * z + c * w;
                    ok &= (mean[k] + sigma[k] * z).abs() <= limit;
                }
                inside += u64::from(ok);
            }
            let mc = inside as f64 / paths as f64;
            let p = chain_within(&mean, &sigma, limit, rho, &fine);
            // 4 standard errors of the Monte Carlo plus the fine lattice's own error.
            let se = (mc * (1.0 - mc) / paths as f64).sqrt();
            assert!(
                (p - mc).abs() < 4.0 * se + 0.003,
                "rho {rho}: lattice {p}, MC {mc}"
            );
            // The lattice the decisions use is within two points.
            let q = chain_within(&mean, &sigma, limit, rho, &production);
            assert!(
                (q - mc).abs() < 4.0 * se + 0.02,
                "rho {rho}: production {q}, MC {mc}"
            );
            // The correlation matters: the joint probability is not the least likely step's.
            if rho < 0.95 {
                let least = (0..n)
                    .map(|k| prob_within(mean[k], sigma[k], limit))
                    .fold(1.0, f64::min);
                assert!(p < least - 0.02, "rho {rho}: {p} vs least step {least}");
            }
        }
    }
}
