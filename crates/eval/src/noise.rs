//! Measurement noise for the noise study (`--noise-pct`, table 3 of the paper).

use super::EvalError;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::Normal;

/// `series` plus zero-mean Gaussian noise whose standard deviation is `pct` % of the peak |x|.
///
/// The noise comes from ChaCha8 seeded with `seed` on stream `stream` (the DOF index), so each
/// DOF gets its own noise, the same for every method and every run with the same seed.
pub fn add_noise(series: &[f64], pct: f64, seed: u64, stream: u64) -> Result<Vec<f64>, EvalError> {
    if !(pct >= 0.0 && pct.is_finite()) {
        return Err(EvalError::BadNoise(pct));
    }
    let peak = series.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let sigma = pct / 100.0 * peak;
    if sigma == 0.0 {
        return Ok(series.to_vec());
    }
    let normal = Normal::new(0.0, sigma).map_err(|_| EvalError::BadNoise(pct))?;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(stream);
    Ok(series.iter().map(|x| x + rng.sample(normal)).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn noise_has_the_requested_size_and_is_seeded() {
        let x: Vec<f64> = (0..20_000).map(|i| 2.0 * (i as f64 * 0.05).sin()).collect();
        let peak = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let noisy = add_noise(&x, 10.0, 7, 2).unwrap();
        let n = x.len() as f64;
        let diffs: Vec<f64> = noisy.iter().zip(&x).map(|(a, b)| a - b).collect();
        let mean = diffs.iter().sum::<f64>() / n;
        let std = (diffs.iter().map(|d| (d - mean).powi(2)).sum::<f64>() / n).sqrt();
        assert!((std / (0.1 * peak) - 1.0).abs() < 0.03, "std {std}");
        assert!(mean.abs() < 0.01 * peak);
        assert_eq!(noisy, add_noise(&x, 10.0, 7, 2).unwrap());
        assert_ne!(noisy, add_noise(&x, 10.0, 7, 3).unwrap());
        assert_ne!(noisy, add_noise(&x, 10.0, 8, 2).unwrap());
        assert_eq!(add_noise(&x, 0.0, 7, 2).unwrap(), x);
        assert!(add_noise(&x, -1.0, 7, 2).is_err());
        assert!(add_noise(&x, f64::NAN, 7, 2).is_err());
    }
}
