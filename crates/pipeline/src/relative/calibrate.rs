//! Calibration of the relative sigma from verified relative errors.
//!
//! The two ships' forecast errors are correlated: the same unpredicted waves reach both, a
//! little later or earlier and through other RAOs. The variance of the relative error is
//! var_A + var_B - 2 cov(A, B), and neither the covariance nor how well each ship's sigma
//! holds at the other ship's point is known in advance. So for each axis and step the relative
//! sigma is the independent one, sqrt(var_A + var_B), times the root of the mean of the
//! verified forecasts' e_rel^2 / (var_A + var_B), exponentially weighted over them (half-life in
//! forecasts): the scale that makes the standardised relative error's mean square 1.
//!
//! The scale is [`crate::sigma_scale::SigmaScale`]'s, whose doc says why it is the mean of the
//! ratios and not the ratio of the sums (what this was until 2026-12-05). Here that mattered
//! with B 15 m ahead: the ratio of sums left +-1 sigma covering 51-52 % of the relative errors
//! across at 5 s (83-84 % within +-2 sigma) on seeds 1 and 2; the mean of the ratios 63-70 %
//! (93-97 %) at every lead and axis of the four geometries of `scripts/two_ship_study.py`. Only
//! forecasts whose every step has been observed are verified (the caller feeds them in time
//! order: causal). Until a step has `min_weight` of verified forecasts behind it, `scale` is
//! None and the independent sigma stands. The correlation of the two ships' errors is
//! estimated alongside, for the report.

use super::shrink::MeanShrinkage;
use super::RelativeTrack;
use crate::sigma_scale::SigmaScale;
use shipcast_wire::payload::MAX_STEPS;

/// Running, exponentially weighted sums of verified relative forecasts.
#[derive(Debug, Clone)]
pub struct SigmaCalibration {
    /// Standardised squared relative errors, e_rel^2 / (var_A + var_B), of the issued mean
    /// and of the raw difference.
    issued: SigmaScale,
    raw: SigmaScale,
    /// Products of the two ships' own point errors (A's tip, B's spot in A's axes).
    aa: [[f64; MAX_STEPS]; 3],
    bb: [[f64; MAX_STEPS]; 3],
    ab: [[f64; MAX_STEPS]; 3],
    verified: u64,
}

impl SigmaCalibration {
    /// Sums that forget with a half-life of `halflife` verified forecasts and are used once
    /// `min_weight` verified forecasts stand behind a step: the issued sigma's adaptive (its
    /// memory grows with the evidence, with a guard: `SigmaScale::adaptive`), the raw
    /// difference's (the lift's) plain, which kept every lift figure as it was.
    pub fn new(halflife: f64, min_weight: f64) -> Self {
        Self {
            issued: SigmaScale::adaptive(halflife, min_weight),
            raw: SigmaScale::new(halflife, min_weight),
            aa: [[0.0; MAX_STEPS]; 3],
            bb: [[0.0; MAX_STEPS]; 3],
            ab: [[0.0; MAX_STEPS]; 3],
            verified: 0,
        }
    }

    /// Adds a verified forecast: `track` as it was issued, `actual_tip[k]` and `actual_spot[k]`
    /// the observed displacements of the two points (A's axes) at its step k. The relative
    /// error is that of the raw difference shrunk by `shrinkage` as it stands now (before this
    /// forecast teaches it), not by the factor the forecast was issued with: when the
    /// shrinkage first applies, after `min_weight` verified forecasts, a sigma scored on the
    /// unshrunk means issued until then would stay too wide for about a half-life. The ships'
    /// own point errors are those of their point forecasts.
    pub fn observe(
        &mut self,
        track: &RelativeTrack,
        actual_tip: &[[f64; 3]],
        actual_spot: &[[f64; 3]],
        shrinkage: &MeanShrinkage,
    ) {
        let steps = track.steps().min(actual_tip.len()).min(actual_spot.len());
        self.verified += 1;
        let own = |axis: usize, k: usize| {
            (
                actual_tip[k][axis] - track.tip.mean[axis][k],
                actual_spot[k][axis] - track.spot.mean[axis][k],
            )
        };
        let var = |axis: usize, k: usize| track.tip.var[axis][k] + track.spot.var[axis][k];
        self.issued.observe(steps, |axis, k| {
            let truth = actual_tip[k][axis] - actual_spot[k][axis];
            let mean = shrinkage.beta(axis, k) * track.raw_mean[axis][k];
            (truth - mean, var(axis, k))
        });
        self.raw.observe(steps, |axis, k| {
            let (ea, eb) = own(axis, k);
            (ea - eb, var(axis, k))
        });
        // The correlation's sums forget as the issued sigma's scale does.
        let d = self.issued.decay();
        for k in 0..steps.min(MAX_STEPS) {
            for axis in 0..3 {
                let (ea, eb) = own(axis, k);
                self.aa[axis][k] = d * self.aa[axis][k] + ea * ea;
                self.bb[axis][k] = d * self.bb[axis][k] + eb * eb;
                self.ab[axis][k] = d * self.ab[axis][k] + ea * eb;
            }
        }
    }

    /// Forecasts verified so far.
    pub fn verified(&self) -> u64 {
        self.verified
    }

    /// Factor on the independent sigma of `axis` at step `k`, once enough is verified.
    pub fn scale(&self, axis: usize, k: usize) -> Option<f64> {
        self.issued.scale(axis, k)
    }

    /// Factor on the independent sigma of the raw difference (before the mean's shrinkage)
    /// of `axis` at step `k`, once enough is verified.
    pub fn scale_raw(&self, axis: usize, k: usize) -> Option<f64> {
        self.raw.scale(axis, k)
    }

    /// Correlation of the two ships' point errors on `axis` at step `k` (weighted, about zero
    /// mean), once enough is verified.
    pub fn correlation(&self, axis: usize, k: usize) -> Option<f64> {
        let den = (self.aa[axis][k] * self.bb[axis][k]).sqrt();
        (self.issued.ready(k) && den > 0.0).then(|| self.ab[axis][k] / den)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// No shrinkage: the relative error is that of the raw difference.
    fn raw() -> MeanShrinkage {
        MeanShrinkage::new(false, f64::INFINITY, 1.0)
    }
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// A standard normal draw (Box-Muller).
    fn normal(rng: &mut ChaCha8Rng) -> f64 {
        let u: f64 = rng.random::<f64>().max(1e-300);
        let v: f64 = rng.random();
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }

    /// Feeds `n` forecasts whose two point errors (sigma `sa`, `sb`, correlation `rho`) hit
    /// zero-mean tracks, then returns the calibration and the fraction of the next `n`
    /// relative errors within the calibrated and within the independent +-1 sigma at step 0.
    fn run(rho: f64, sa: f64, sb: f64, n: usize) -> (SigmaCalibration, f64, f64) {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let mut cal = SigmaCalibration::new(f64::INFINITY, 50.0);
        let mut track = RelativeTrack::default();
        track.alignment.steps = 2;
        for k in 0..2 {
            track.tip.var[2][k] = sa * sa;
            track.spot.var[2][k] = sb * sb;
        }
        let draw = |rng: &mut ChaCha8Rng| {
            let (z1, z2) = (normal(rng), normal(rng));
            let ea = sa * z1;
            let eb = sb * (rho * z1 + (1.0 - rho * rho).sqrt() * z2);
            ([[0.0, 0.0, ea]; 2], [[0.0, 0.0, eb]; 2])
        };
        for _ in 0..n {
            let (tip, spot) = draw(&mut rng);
            cal.observe(&track, &tip, &spot, &raw());
        }
        let independent = (sa * sa + sb * sb).sqrt();
        let calibrated = cal.scale(2, 0).unwrap() * independent;
        let (mut in_cal, mut in_ind) = (0usize, 0usize);
        for _ in 0..n {
            let (tip, spot) = draw(&mut rng);
            let e = (tip[0][2] - spot[0][2]).abs();
            in_cal += usize::from(e <= calibrated);
            in_ind += usize::from(e <= independent);
        }
        (cal, in_cal as f64 / n as f64, in_ind as f64 / n as f64)
    }

    #[test]
    fn correlated_errors_shrink_the_relative_sigma_to_what_was_verified() {
        // Equal sigmas, correlation 0.8: var_rel = 2 s^2 (1 - 0.8), scale sqrt(0.2).
        let (cal, cover_cal, cover_ind) = run(0.8, 0.3, 0.3, 20_000);
        let scale = cal.scale(2, 0).unwrap();
        assert!((scale - 0.2f64.sqrt()).abs() < 0.02, "{scale}");
        assert!((cal.correlation(2, 0).unwrap() - 0.8).abs() < 0.02);
        // Calibrated +-1 sigma covers 68 %; taken as independent it covers far more (the
        // sigma is too wide by 1 / sqrt(0.2)).
        assert!((cover_cal - 0.6827).abs() < 0.02, "{cover_cal}");
        assert!(cover_ind > 0.97, "{cover_ind}");
        // Anti-correlated errors add up: the scale exceeds 1.
        let (cal, cover_cal, _) = run(-0.5, 0.2, 0.4, 20_000);
        let expect = ((0.04 + 0.16 + 2.0 * 0.5 * 0.08) / 0.2f64).sqrt();
        assert!((cal.scale(2, 0).unwrap() - expect).abs() < 0.03);
        assert!((cover_cal - 0.6827).abs() < 0.02, "{cover_cal}");
        // Axes and steps nobody verified have no scale.
        assert_eq!(cal.scale(0, 0), None);
        assert_eq!(cal.scale(2, 2), None);
    }

    #[test]
    fn a_widened_ship_sigma_does_not_narrow_the_relative_sigma_of_the_other_forecasts() {
        // Regression: half the forecasts come while one ship's sigma is widened three-fold
        // (its variance nine-fold), the relative error unchanged, N(0, 0.1^2) throughout.
        // Scaled by the ratio of the sums, sigma was sqrt(5) times too narrow in the other
        // half and the standardised error's mean square was 2.78; by the mean of the ratios it
        // is 1 overall.
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let mut cal = SigmaCalibration::new(f64::INFINITY, 50.0);
        let mut narrow = RelativeTrack::default();
        narrow.alignment.steps = 1;
        narrow.tip.var[2][0] = 0.02;
        narrow.spot.var[2][0] = 0.02;
        let mut wide = narrow.clone();
        wide.tip.var[2][0] = 0.34;
        let track = |i: usize| if i.is_multiple_of(2) { &narrow } else { &wide };
        let error = |rng: &mut ChaCha8Rng| [[0.0, 0.0, 0.1 * normal(rng)]];
        for i in 0..40_000 {
            cal.observe(track(i), &error(&mut rng), &[[0.0; 3]], &raw());
        }
        let scale = cal.scale(2, 0).unwrap();
        let mut mean_square = 0.0;
        let n = 40_000;
        for i in 0..n {
            let t = track(i);
            let sigma = scale * (t.tip.var[2][0] + t.spot.var[2][0]).sqrt();
            mean_square += (error(&mut rng)[0][2] / sigma).powi(2) / n as f64;
        }
        assert!((mean_square - 1.0).abs() < 0.05, "{mean_square}");
    }

    #[test]
    fn nothing_is_scaled_before_enough_is_verified_and_old_errors_fade() {
        let mut cal = SigmaCalibration::new(10.0, 20.0);
        let mut track = RelativeTrack::default();
        track.alignment.steps = 1;
        track.tip.var[2][0] = 1.0;
        for i in 0..19 {
            cal.observe(&track, &[[0.0, 0.0, 3.0]], &[[0.0; 3]], &raw());
            assert_eq!(cal.scale(2, 0), None, "after {i}");
        }
        // The issued sigma's scale counts the forecasts behind a step (its memory is short
        // at first by design): ready at the 20th.
        cal.observe(&track, &[[0.0, 0.0, 3.0]], &[[0.0; 3]], &raw());
        assert!((cal.scale(2, 0).unwrap() - 3.0).abs() < 1e-9);
        // The raw difference's plain sums weigh them: with a half-life of 10 the weight tends
        // to 1 / (1 - 0.5^0.1) = 14.9 < 20, never enough.
        for _ in 0..200 {
            cal.observe(&track, &[[0.0, 0.0, 3.0]], &[[0.0; 3]], &raw());
        }
        assert_eq!(cal.scale_raw(2, 0), None);
        let mut cal = SigmaCalibration::new(10.0, 5.0);
        for _ in 0..100 {
            cal.observe(&track, &[[0.0, 0.0, 3.0]], &[[0.0; 3]], &raw());
        }
        assert!((cal.scale(2, 0).unwrap() - 3.0).abs() < 1e-9);
        // Errors of 1 from now on: after 10 half-lives the old ones weigh 1/1024.
        for _ in 0..100 {
            cal.observe(&track, &[[0.0, 0.0, 1.0]], &[[0.0; 3]], &raw());
        }
        let s = cal.scale(2, 0).unwrap();
        assert!(s > 1.0 && s < 1.01, "{s}");
        assert_eq!(cal.verified(), 200);
        let s = cal.scale_raw(2, 0).unwrap();
        assert!(s > 1.0 && s < 1.01, "{s}");
    }
}
