//! The seeded sea-like record the predictor benchmarks train and forecast on.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A dense, seeded sea-like record at 2 Hz: 300 wave components with random frequencies in the
/// band of ship motion (periods 5-20 s), a spectrum peaked near 10 s, random phases.
pub fn sea(len: usize, seed: u64) -> Vec<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let components: Vec<(f64, f64, f64)> = (0..300)
        .map(|_| {
            let omega: f64 = rng.random_range(0.31..1.26);
            let peak = 2.0 * std::f64::consts::PI / 10.0;
            let amplitude = 0.1 * (-((omega - peak) / 0.15).powi(2)).exp();
            (
                omega,
                amplitude,
                rng.random_range(0.0..std::f64::consts::TAU),
            )
        })
        .collect();
    (0..len)
        .map(|i| {
            let t = i as f64 * 0.5;
            components
                .iter()
                .map(|&(w, a, p)| a * (w * t + p).sin())
                .sum()
        })
        .collect()
}
