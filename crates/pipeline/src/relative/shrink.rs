//! Shrinkage of the relative mean towards no relative motion, from verified relative forecasts.
//!
//! Each ship's DOF forecast is already shrunk towards zero by its own engine
//! (`engine::calibrate`), so that it is never worse than predicting zero. Their difference at
//! two points is not: where the two points move nearly together (B just ahead, its spot at
//! the tip's lever arm), the relative motion is a small difference of two large ones, and the
//! difference of the two forecasts over-predicts it. On Gullfaks, waves from 120 deg, the 5 s
//! relative z forecast missed by 0.407 m RMS against a relative motion of 0.335 m, and over all
//! geometries the true relative z was 0.77 times the forecast at 5 s.
//!
//! So the relative mean is shrunk per axis and step by the least-squares factor beta in [0, 1]
//! of the true relative displacement on the raw difference, from exponentially weighted sums
//! over verified forecasts (the sigma calibration's half-life). On the evidence it is fitted
//! to, beta times the raw difference is never worse than the raw difference nor than no
//! relative motion (the least-squares property, clamped). Until a step has `min_weight`
//! verified forecasts behind it, beta is 1: the raw difference stands, as the independent
//! sigma does. The sigma calibration then scores the shrunk mean, so sigma describes the error
//! of what is issued.
//!
//! Not [`PairSums::beta`], the engine's rule for a model's raw output, which sets beta to 0
//! below a skill bar and ramps it in above: the two ships' forecasts it is applied to are
//! already shrunk that way, and applied again to their difference the bar cost the paper sea
//! up to 6 % of error at 20-25 s (z 0.657 m against the raw difference's 0.622 m, seed 1,
//! default geometry), where the plain least-squares factor costs nothing.

use super::RelativeTrack;
use crate::engine::calibrate::PairSums;
use crate::sigma_scale::decay_per_forecast;
use shipcast_wire::payload::MAX_STEPS;

/// Exponentially weighted (raw mean, true relative displacement) sums per axis and step.
#[derive(Debug, Clone)]
pub struct MeanShrinkage {
    enabled: bool,
    decay: f64,
    min_weight: f64,
    sums: [[PairSums; MAX_STEPS]; 3],
}

impl MeanShrinkage {
    /// Sums that forget with a half-life of `halflife` verified forecasts, used once
    /// `min_weight` of them stand behind a step; `enabled` false keeps beta at 1 (the raw
    /// difference), for comparison.
    pub fn new(enabled: bool, halflife: f64, min_weight: f64) -> Self {
        Self {
            enabled,
            decay: decay_per_forecast(halflife),
            min_weight: min_weight.max(1.0),
            sums: [[PairSums::default(); MAX_STEPS]; 3],
        }
    }

    /// Adds a verified forecast: `track` as issued (its `raw_mean`), `actual[k]` the true
    /// relative displacement at its step k. Non-finite values are skipped.
    pub fn observe(&mut self, track: &RelativeTrack, actual: &[[f64; 3]]) {
        let steps = track.steps().min(actual.len()).min(MAX_STEPS);
        for (k, value) in actual.iter().enumerate().take(steps) {
            for (axis, &x) in value.iter().enumerate() {
                let m = track.raw_mean[axis][k];
                if !(m.is_finite() && x.is_finite()) {
                    continue;
                }
                let s = &mut self.sums[axis][k];
                *s = s.scaled(self.decay);
                s.add(m, x);
            }
        }
    }

    /// The factor on the raw relative mean of `axis` at step `k`.
    pub fn beta(&self, axis: usize, k: usize) -> f64 {
        match self.sums.get(axis).and_then(|a| a.get(k)) {
            Some(s) if self.enabled && s.count() >= self.min_weight => s.least_squares_beta(),
            _ => 1.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn track(raw: f64) -> RelativeTrack {
        let mut t = RelativeTrack::default();
        t.alignment.steps = 1;
        t.raw_mean[2][0] = raw;
        t
    }

    #[test]
    fn an_over_predicting_difference_is_shrunk_to_the_least_squares_factor() {
        // Truth x = 0.6 m + small noise: beta is 0.6 and the shrunk forecast's error is the
        // noise, where the raw one's had 0.4 m more in it.
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let mut s = MeanShrinkage::new(true, f64::INFINITY, 100.0);
        for _ in 0..5000 {
            let m: f64 = rng.random_range(-1.0..1.0);
            let noise: f64 = rng.random_range(-0.05..0.05);
            s.observe(&track(m), &[[0.0, 0.0, 0.6 * m + noise]]);
        }
        assert!((s.beta(2, 0) - 0.6).abs() < 0.01, "{}", s.beta(2, 0));
        // Steps without evidence keep the raw difference.
        assert_eq!(s.beta(2, 1), 1.0);
        assert_eq!(s.beta(2, MAX_STEPS), 1.0);
    }

    #[test]
    fn a_difference_without_skill_is_shrunk_to_no_relative_motion() {
        // Truth independent of the forecast: the raw difference only adds its own square to
        // the error, and beta goes to about 0 (the zero forecast).
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        let mut s = MeanShrinkage::new(true, 1200.0, 100.0);
        for _ in 0..5000 {
            let m: f64 = rng.random_range(-1.0..1.0);
            let x: f64 = rng.random_range(-1.0..1.0);
            s.observe(&track(m), &[[0.0, 0.0, x]]);
        }
        assert!(s.beta(2, 0) < 0.05, "{}", s.beta(2, 0));
        // Switched off, the raw difference stands whatever was verified.
        let mut off = MeanShrinkage::new(false, 1200.0, 100.0);
        for _ in 0..500 {
            off.observe(&track(1.0), &[[0.0, 0.0, 0.0]]);
        }
        assert_eq!(off.beta(2, 0), 1.0);
    }

    #[test]
    fn on_its_evidence_the_shrunk_mean_beats_both_the_raw_difference_and_no_motion() {
        // Whatever the relation of truth to forecast (here over- and under-predicting,
        // anti-correlated, unrelated), beta m has at most the squared error of m and of 0
        // over the forecasts beta was fitted to (no forgetting).
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        for gain in [2.0, 0.7, 0.1, 0.0, -0.5] {
            let mut s = MeanShrinkage::new(true, f64::INFINITY, 10.0);
            let pairs: Vec<(f64, f64)> = (0..2000)
                .map(|_| {
                    let m: f64 = rng.random_range(-1.0..1.0);
                    (m, gain * m + rng.random_range(-0.3..0.3))
                })
                .collect();
            for &(m, x) in &pairs {
                s.observe(&track(m), &[[0.0, 0.0, x]]);
            }
            let b = s.beta(2, 0);
            let sse = |f: &dyn Fn(f64) -> f64| {
                pairs.iter().map(|&(m, x)| (x - f(m)).powi(2)).sum::<f64>()
            };
            let shrunk = sse(&|m| b * m);
            assert!(shrunk <= sse(&|m| m) + 1e-9, "gain {gain}");
            assert!(shrunk <= sse(&|_| 0.0) + 1e-9, "gain {gain}");
        }
    }

    #[test]
    fn nothing_is_shrunk_before_enough_is_verified_and_bad_values_are_skipped() {
        let mut s = MeanShrinkage::new(true, f64::INFINITY, 50.0);
        for _ in 0..49 {
            s.observe(&track(1.0), &[[0.0, 0.0, 0.5]]);
            s.observe(&track(f64::NAN), &[[0.0, 0.0, 0.5]]);
            s.observe(&track(1.0), &[[0.0, 0.0, f64::INFINITY]]);
        }
        assert_eq!(s.beta(2, 0), 1.0);
        s.observe(&track(1.0), &[[0.0, 0.0, 0.5]]);
        assert!((s.beta(2, 0) - 0.5).abs() < 1e-12);
    }

    #[test]
    fn old_evidence_fades_with_the_half_life() {
        // 2000 forecasts at x = m, then 2000 at x = 0.5 m with a half-life of 100: the old
        // ones weigh 2^-20 and beta follows the new sea.
        let mut s = MeanShrinkage::new(true, 100.0, 10.0);
        for i in 0..2000 {
            let m = if i % 2 == 0 { 1.0 } else { -1.0 };
            s.observe(&track(m), &[[0.0, 0.0, m]]);
        }
        assert!((s.beta(2, 0) - 1.0).abs() < 1e-9);
        for i in 0..2000 {
            let m = if i % 2 == 0 { 1.0 } else { -1.0 };
            s.observe(&track(m), &[[0.0, 0.0, 0.5 * m]]);
        }
        assert!((s.beta(2, 0) - 0.5).abs() < 1e-5, "{}", s.beta(2, 0));
    }
}
