//! A scale on a sigma, per axis and step, from the verified forecasts' standardised squared
//! errors: the root of their exponentially weighted mean, so that the standardised error of
//! the scaled sigma has a mean square of 1.
//!
//! Used wherever a sigma is derived under an assumption the sea may break: a point's sigma
//! linearised from its ship's DOF sigmas taken as independent (the crane tip, `crane::verify`),
//! the relative sigma of two ships taken as independent (`relative::calibrate`). Why the mean
//! of the ratios e^2 / v and not the ratio of the sums: the sigmas move with their own live
//! errors (a change detector widening one of them), and the ratio of sums is then set by the
//! forecasts whose sigma is widest, leaving the others too narrow (docs/two_ships.md, "Sigma").
//! Only whole verified forecasts are fed in, in time order (causal). Until a step has
//! `min_weight` verified forecasts behind it, `scale` is None and the unscaled sigma stands.

use shipcast_wire::payload::MAX_STEPS;

/// Largest standardised squared error one forecast adds (|e| at 10 sigma). A mean of ratios is
/// at the mercy of its largest terms: on the two-sine records of `relative::tests`, whose first
/// forecasts (the start-up model's, before the first fit) are far off, the uncapped mean held
/// the relative sigma at 0.37 against a relative RMS error of 0.006 (0.029 with the cap). A
/// Gaussian error passes 10 sigma once in 10^23 forecasts, so on the study's records the cap
/// changes nothing, and 100 is still a hundred honest forecasts' worth of warning.
pub const MAX_Z2: f64 = 100.0;

/// The factor by which sums with a half-life of `halflife` verified forecasts forget at each
/// new one (1, no forgetting, for an infinite or unusable half-life).
pub fn decay_per_forecast(halflife: f64) -> f64 {
    if halflife.is_finite() && halflife > 0.0 {
        0.5f64.powf(1.0 / halflife)
    } else {
        1.0
    }
}

/// Running, exponentially weighted standardised squares per axis (x, y, z) and step.
#[derive(Debug, Clone)]
pub struct SigmaScale {
    decay: f64,
    min_weight: f64,
    /// Verified forecasts (weighted) that reached each step.
    weight: [f64; MAX_STEPS],
    squares: [[f64; MAX_STEPS]; 3],
    /// Forecasts counted in `squares` (those with a positive, finite variance).
    counted: [[f64; MAX_STEPS]; 3],
}

impl SigmaScale {
    /// Sums that forget with a half-life of `halflife` verified forecasts and are used once
    /// `min_weight` verified forecasts stand behind a step.
    pub fn new(halflife: f64, min_weight: f64) -> Self {
        Self {
            decay: decay_per_forecast(halflife),
            min_weight: min_weight.max(1.0),
            weight: [0.0; MAX_STEPS],
            squares: [[0.0; MAX_STEPS]; 3],
            counted: [[0.0; MAX_STEPS]; 3],
        }
    }

    /// Adds one verified forecast of `steps` steps: `error(axis, k)` gives its error and the
    /// variance it was issued with at step k. A step without a positive, finite variance (or
    /// with a non-finite error) has no standardised error to count.
    pub fn observe(&mut self, steps: usize, mut error: impl FnMut(usize, usize) -> (f64, f64)) {
        let d = self.decay;
        for k in 0..steps.min(MAX_STEPS) {
            self.weight[k] = d * self.weight[k] + 1.0;
            for axis in 0..3 {
                let (e, v) = error(axis, k);
                let counts = v > 0.0 && v.is_finite() && e.is_finite();
                let z2 = if counts { (e * e / v).min(MAX_Z2) } else { 0.0 };
                self.squares[axis][k] = d * self.squares[axis][k] + z2;
                self.counted[axis][k] = d * self.counted[axis][k] + f64::from(u8::from(counts));
            }
        }
    }

    /// The factor by which the sums forget at each verified forecast.
    pub fn decay(&self) -> f64 {
        self.decay
    }

    /// Whether step `k` has `min_weight` verified forecasts behind it.
    pub fn ready(&self, k: usize) -> bool {
        k < MAX_STEPS && self.weight[k] >= self.min_weight
    }

    /// Factor on the sigma of `axis` at step `k`, once enough is verified.
    pub fn scale(&self, axis: usize, k: usize) -> Option<f64> {
        (self.ready(k) && axis < 3 && self.counted[axis][k] > 0.0)
            .then(|| (self.squares[axis][k] / self.counted[axis][k]).sqrt())
    }
}
