//! Recalibration of the raw model output from verified forecasts, per DOF and step.
//!
//! For each step the calibrator keeps, over the rolling window, the sums of the raw model mean
//! m and the value x that then happened: n, sum x^2, sum m^2, sum m x. The delivered mean is
//! `beta * m` with `beta = clamp(sum m x / sum m^2, 0, 1)`, the least-squares shrinkage towards
//! zero, and the delivered sigma is the RMS error that this shrunk forecast had:
//! `(sum x^2 - 2 beta sum m x + beta^2 sum m^2) / n`. Because that error is a convex function of
//! beta that equals the error of predicting zero at beta = 0 and falls until the unclamped
//! optimum, a shrunk forecast is never worse than zero on the evidence it was fitted to.
//!
//! The evidence starts from a prior: the new model's scores on held-out data of this sea when it
//! was fitted on live data, or "no skill" (beta 0, sigma = the motion's std) for a model that
//! has never been scored on this sea (a start-up model from the simulator or a file). A model
//! change replaces the window's evidence, because it was about the previous model.

use super::rolling::RollingSums;
use shipcast_wire::payload::{MAX_STEPS, NUM_DOF};

/// Index of each sum in [`RollingSums`] entries.
const N: usize = 0;
const XX: usize = 1;
const MM: usize = 2;
const MX: usize = 3;

/// Fraction of the zero forecast's squared error below which a model counts as no skill.
pub const MIN_EXPLAINED: f64 = 0.08;

/// Bar widths above the bar over which beta is ramped in from 0 to its least-squares value.
/// Measured with `scripts/replay_study.py` (docs/forecasting.md): without the ramp the
/// delivered NRMSE reached 1.006-1.010 at leads of 17-23 s; 1 width left 1.002-1.003, 2 widths
/// 1.0007 at most, 3 widths 1.0004 at 1-2 % more error at 5 s.
pub const RAMP_WIDTHS: f64 = 2.0;

/// Sums of (m, x) pairs of one step: the form both the prior and the window take.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct PairSums(pub [f64; 4]);

impl PairSums {
    /// A prior that knows only the motion's variance: n pseudo-values, no skill.
    pub fn no_skill(n: f64, variance: f64) -> Self {
        Self([n, n * variance, 0.0, 0.0])
    }

    pub fn add(&mut self, m: f64, x: f64) {
        let s = &mut self.0;
        s[N] += 1.0;
        s[XX] += x * x;
        s[MM] += m * m;
        s[MX] += m * x;
    }

    /// The same evidence counted as at most `n` values.
    pub fn capped(self, n: f64) -> Self {
        if self.0[N] <= n || self.0[N] == 0.0 {
            return self;
        }
        self.scaled(n / self.0[N])
    }

    /// The same evidence weighted by `f` (an exponential forgetting step).
    pub fn scaled(self, f: f64) -> Self {
        Self(self.0.map(|v| v * f))
    }

    fn plus(self, o: [f64; 4]) -> Self {
        Self(std::array::from_fn(|i| self.0[i] + o[i]))
    }

    /// Least-squares shrinkage in [0, 1]; 0 where the model removes at most `MIN_EXPLAINED`
    /// of the zero forecast's squared error. That fraction is itself estimated from strongly
    /// correlated errors, so below the threshold skill is indistinguishable from none, and a
    /// small beta fitted to noise would let the delivered error creep above zero's.
    ///
    /// Just above the bar the estimate is still uncertain by about the bar itself, and
    /// switching from 0 straight to the full least-squares beta (often 0.8-0.9 where the raw
    /// forecast has decayed) turns each noisy crossing into an episode worse than zero. So
    /// beta is ramped in linearly over `RAMP_WIDTHS` more bar widths; beyond that it is the
    /// plain least-squares value, and a well-fitted model is left exactly as it is.
    pub fn beta(&self) -> f64 {
        let s = &self.0;
        let beta = self.least_squares_beta();
        if beta == 0.0 {
            return 0.0;
        }
        // Fraction of sum x^2 that beta * m removes: (2 beta MX - beta^2 MM) / XX.
        let explained = (2.0 * beta * s[MX] - beta * beta * s[MM]) / s[XX];
        // Fewer pairs (a new model, a changed sea) mean a noisier estimate of the fraction:
        // the bar rises as 2 / sqrt(n), which is about two standard errors of the estimate
        // when neighbouring pairs are strongly correlated.
        let bar = MIN_EXPLAINED.max(2.0 / s[N].max(1.0).sqrt());
        let ramp = ((explained - bar) / (RAMP_WIDTHS * bar)).clamp(0.0, 1.0);
        beta * ramp
    }

    /// The least-squares factor of x on m, clamped to [0, 1], without [`Self::beta`]'s bar:
    /// 0 for no evidence (or NaN sums, never expected).
    pub fn least_squares_beta(&self) -> f64 {
        let s = &self.0;
        if s[MM].is_nan() || s[MM] <= 0.0 || !s[MX].is_finite() || s[XX].is_nan() || s[XX] <= 0.0 {
            return 0.0;
        }
        (s[MX] / s[MM]).clamp(0.0, 1.0)
    }

    /// Mean squared error of `beta * m` (and of zero, at beta 0).
    pub fn mse(&self, beta: f64) -> f64 {
        let s = &self.0;
        if s[N].is_nan() || s[N] <= 0.0 {
            return f64::NAN;
        }
        ((s[XX] - 2.0 * beta * s[MX] + beta * beta * s[MM]) / s[N]).max(0.0)
    }

    pub fn count(&self) -> f64 {
        self.0[N]
    }
}

/// What the calibrator tells for one step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Calibration {
    pub beta: f64,
    pub sigma: f64,
}

/// Per-DOF, per-step shrinkage and sigma from a prior and the rolling window of verified pairs.
#[derive(Debug, Clone)]
pub struct Calibrator {
    window: RollingSums<4>,
    /// None: "no skill", worth `no_skill_weight` values at the motion's live variance (known
    /// only when asked: at start-up there is none yet).
    prior: Vec<[Option<PairSums>; MAX_STEPS]>,
    no_skill_weight: [f64; NUM_DOF],
    /// Largest weight (in values) a prior may carry.
    prior_cap: f64,
    /// Per DOF and step, the squared error delivered by the model that a swap during a change
    /// of sea replaced, as (weight, weight x mean square): a floor under the new model's sigma
    /// until the new model's own verified pairs outweigh it ([`Self::reset_carrying`]).
    carried: Vec<[[f64; 2]; MAX_STEPS]>,
    /// Per DOF and step, the new model's own verified pairs since the carry: counted apart
    /// from the window, which a change discounts and its length caps (review: the carry then
    /// never faded, or came back at the next change).
    carried_own: Vec<[f64; MAX_STEPS]>,
}

/// After how many times its weight in the new model's own verified pairs a carried error is
/// gone ([`Calibrator::reset_carrying`]).
const CARRY_FADE: f64 = 4.0;

impl Calibrator {
    /// A window of `window_values` record values; priors count as at most `prior_cap` values.
    pub fn new(window_values: usize, prior_cap: f64) -> Self {
        Self {
            window: RollingSums::new(window_values, 20),
            prior: vec![[None; MAX_STEPS]; NUM_DOF],
            no_skill_weight: [prior_cap; NUM_DOF],
            prior_cap,
            carried: vec![[[0.0; 2]; MAX_STEPS]; NUM_DOF],
            carried_own: vec![[0.0; MAX_STEPS]; NUM_DOF],
        }
    }

    /// A new model for DOF `d`: forget the old model's evidence and start from `prior` (one
    /// entry per step; steps beyond it, and an empty prior, start from "no skill").
    pub fn reset(&mut self, d: usize, prior: &[PairSums]) {
        self.window.clear(d);
        self.drop_carry(d);
        self.no_skill_weight[d] = self.prior_cap;
        for (k, p) in self.prior[d].iter_mut().enumerate() {
            // Held-out values without variance (a DOF that stood still while the model was
            // fitted) prove no skill: counted as evidence, their error of 0 kept sigma at 0
            // once the DOF moved, and the deck called go with certainty (review). They start
            // from "no skill" instead, which follows the live variance.
            *p = prior
                .get(k)
                .filter(|s| s.0[XX] > 0.0)
                .map(|s| s.capped(self.prior_cap));
        }
    }

    /// A new model for DOF `d` put in service while its errors were found larger than
    /// claimed: as [`Self::reset`], but the new model's held-out evidence counts as `keep`
    /// values at most (it was fitted mostly on the sea before, and so was that evidence), and
    /// the error the old model delivered on the changing sea (its sigma now, `variance` being
    /// the motion's live mean square) stays beside it as `keep` values, fading as the new
    /// model's own verified pairs come in. Review: a model swapped in 23 s after a turn towards following seas was held
    /// to its held-out sigma (sway 0.045 m against 0.13-0.24 m before the swap), and its
    /// forecasts missed by 11-17 sigma. The old model's error, not "no skill", is carried: an
    /// exact model on an exact sea keeps a sigma near its error (a doubt of "no skill" held it
    /// 40 times too wide in the relative study's tests).
    pub fn reset_carrying(&mut self, d: usize, prior: &[PairSums], variance: f64, keep: f64) {
        let before: [f64; MAX_STEPS] = std::array::from_fn(|k| {
            let sigma = self.get(d, k, variance).sigma;
            sigma * sigma
        });
        self.reset(d, prior);
        self.cap_prior(d, keep);
        for (carried, mse) in self.carried[d].iter_mut().zip(before) {
            if mse.is_finite() {
                *carried = [keep, keep * mse];
            }
        }
    }

    /// The prior of DOF `d`, held-out evidence or "no skill", counts as `keep` values at most.
    fn cap_prior(&mut self, d: usize, keep: f64) {
        for p in self.prior[d].iter_mut().flatten() {
            *p = p.capped(keep);
        }
        self.no_skill_weight[d] = self.no_skill_weight[d].min(keep);
    }

    /// Forget what [`Self::reset_carrying`] carried for DOF `d` (a plain swap, or errors
    /// found much smaller than claimed).
    pub fn drop_carry(&mut self, d: usize) {
        self.carried[d] = [[0.0; 2]; MAX_STEPS];
        self.carried_own[d] = [0.0; MAX_STEPS];
    }

    /// The raw forecast `m` of step index `k` turned out to be `x`.
    #[inline]
    pub fn observe(&mut self, d: usize, k: usize, m: f64, x: f64) {
        self.window.add(d, k, [1.0, x * x, m * m, m * x]);
        let weight = self.carried[d][k][0];
        if weight > 0.0 {
            self.carried_own[d][k] += 1.0;
            if self.carried_own[d][k] >= CARRY_FADE * weight {
                self.carried[d][k] = [0.0; 2];
            }
        }
    }

    /// One new record value was scored.
    pub fn tick(&mut self) {
        self.window.tick();
    }

    /// The sea changed for DOF `d`: what is known counts as `keep` values at most.
    pub fn discount(&mut self, d: usize, keep: f64) {
        self.cap_prior(d, keep);
        for c in self.carried[d].iter_mut() {
            if c[0] > keep {
                *c = c.map(|v| v * keep / c[0]);
            }
        }
        let n = (0..MAX_STEPS)
            .map(|k| self.window.get(d, k)[N])
            .fold(0.0, f64::max);
        if n > keep {
            self.window.discount(d, keep / n);
        }
    }

    /// Evidence of DOF `d`, step index `k`: prior plus window; `variance` is the motion's
    /// live mean square, which a "no skill" prior stands for.
    pub fn sums(&self, d: usize, k: usize, variance: f64) -> PairSums {
        let prior = self.prior[d][k]
            .unwrap_or_else(|| PairSums::no_skill(self.no_skill_weight[d], variance));
        prior.plus(self.window.get(d, k))
    }

    /// The calibration of DOF `d`, step index `k`: the shrinkage from the evidence, and the
    /// sigma of the shrunk forecast, never narrower than with a carried error beside it
    /// ([`Self::reset_carrying`]).
    #[inline]
    pub fn get(&self, d: usize, k: usize, variance: f64) -> Calibration {
        let s = self.sums(d, k, variance);
        let beta = s.beta();
        let mut mse = s.mse(beta);
        let [weight, sum] = self.carried[d][k];
        if weight > 0.0 {
            let own = self.carried_own[d][k];
            let left = (1.0 - own / (CARRY_FADE * weight)).max(0.0);
            if left > 0.0 {
                let n = s.count();
                mse = mse.max((n * mse + left * sum) / (n + left * weight));
            }
        }
        Calibration {
            beta,
            sigma: mse.sqrt(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Held-out evidence of perfect forecasts (error 0) of a sine.
    fn perfect(n: usize) -> PairSums {
        let mut s = PairSums::default();
        for i in 0..n {
            let x = (i as f64 * 0.3).sin();
            s.add(x, x);
        }
        s
    }

    /// `n` verified pairs of DOF 0, step 0, each a perfect forecast of the same sine.
    fn observe_perfect(c: &mut Calibrator, n: usize) {
        for i in 0..n {
            let x = (i as f64 * 0.3).sin();
            c.observe(0, 0, x, x);
            c.tick();
        }
    }

    #[test]
    fn a_model_swapped_in_during_a_change_keeps_the_old_error_beside_its_own_until_it_fades() {
        // The old model has no skill: sigma^2 = variance 0.5, beta 0. The new one brings
        // perfect held-out evidence, capped at 60 values, with the old error beside it as 60
        // values: sigma^2 = (60 x 0 + 60 x 0.5) / 120, the shrinkage the evidence's alone.
        let mut c = Calibrator::new(2400, 240.0);
        c.reset(0, &[]);
        assert!((c.get(0, 0, 0.5).sigma - 0.5f64.sqrt()).abs() < 1e-12);
        c.reset_carrying(0, &[perfect(480)], 0.5, 60.0);
        let carried = c.get(0, 0, 0.5);
        assert_eq!(carried.beta, 1.0);
        assert!((carried.sigma - 0.5).abs() < 1e-12, "{carried:?}");
        // The new model's own pairs come in, perfect: the carried error fades with them,
        // half gone after twice its weight, gone after four times.
        observe_perfect(&mut c, 120);
        let fading = c.get(0, 0, 0.5).sigma;
        // (30 x 0.5) / (60 + 120 + 30).
        assert!((fading - (15.0f64 / 210.0).sqrt()).abs() < 1e-9, "{fading}");
        observe_perfect(&mut c, 120);
        assert!(c.get(0, 0, 0.5).sigma < 1e-6);
        // A plain reset (a swap on a settled sea) carries nothing.
        c.reset_carrying(0, &[perfect(480)], 0.5, 60.0);
        c.reset(0, &[perfect(480)]);
        assert!(c.get(0, 0, 0.5).sigma < 1e-6);
    }

    #[test]
    fn a_carried_error_once_faded_stays_gone_whatever_the_window_does() {
        // Regressions (review): the fading counted the window's pairs, which a later change
        // discounts (the carry came back) and a short window caps (it never went).
        for window in [2400, 120] {
            let mut c = Calibrator::new(window, 240.0);
            c.reset(0, &[]);
            c.reset_carrying(0, &[perfect(480)], 0.5, 60.0);
            observe_perfect(&mut c, 300);
            assert!(c.get(0, 0, 0.5).sigma < 1e-6, "window {window}");
            c.discount(0, 60.0);
            assert!(c.get(0, 0, 0.5).sigma < 1e-6, "window {window}");
        }
        // Errors found much smaller than claimed drop it at once.
        let mut c = Calibrator::new(2400, 240.0);
        c.reset(0, &[]);
        c.reset_carrying(0, &[perfect(480)], 0.5, 60.0);
        assert!(c.get(0, 0, 0.5).sigma > 0.4);
        c.drop_carry(0);
        assert!(c.get(0, 0, 0.5).sigma < 1e-6);
    }

    #[test]
    fn an_exact_old_model_carries_no_doubt_onto_an_exact_new_one() {
        // What "no skill" beside the new model could not do (the relative study's exact seas):
        // an old model whose errors were 0 leaves the new one's sigma at 0, and a carried
        // error never narrows a sigma that the new evidence alone makes wider.
        let mut c = Calibrator::new(2400, 240.0);
        c.reset(0, &[perfect(480)]);
        c.reset_carrying(0, &[perfect(480)], 0.5, 60.0);
        assert!(c.get(0, 0, 0.5).sigma < 1e-6);
        c.reset(0, &[perfect(480)]);
        c.reset_carrying(0, &[], 0.5, 60.0);
        assert!((c.get(0, 0, 0.5).sigma - 0.5f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn shrinkage_never_raises_the_error_of_a_well_fitted_model() {
        // Analytic case: x = m exactly. beta must be 1 and the error 0, so shrinking changes
        // nothing; and for x = m + independent noise, beta -> 1 as well.
        let mut s = PairSums::default();
        for i in 0..500 {
            let m = (i as f64 * 0.3).sin();
            s.add(m, m);
        }
        assert_eq!(s.beta(), 1.0);
        assert!(s.mse(s.beta()) < 1e-24);
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let mut s = PairSums::default();
        for i in 0..20000 {
            let m = (i as f64 * 0.37).sin();
            s.add(m, m + 0.2 * (rng.random::<f64>() - 0.5));
        }
        assert!((s.beta() - 1.0).abs() < 0.01, "{}", s.beta());
        assert!(s.mse(s.beta()) <= s.mse(1.0) + 1e-12);
    }

    #[test]
    fn a_useless_model_is_shrunk_to_zero_and_never_worse_than_zero() {
        // m unrelated to x, and m with the wrong sign: both beta 0, error = predicting zero.
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        for sign in [1.0, -1.0] {
            let mut s = PairSums::default();
            for _ in 0..5000 {
                let x: f64 = rng.random::<f64>() - 0.5;
                let m = if sign > 0.0 {
                    100.0 * (rng.random::<f64>() - 0.5)
                } else {
                    -3.0 * x
                };
                s.add(m, x);
            }
            let beta = s.beta();
            assert!(s.mse(beta) <= s.mse(0.0) + 1e-15, "sign {sign}");
            if sign < 0.0 {
                assert_eq!(beta, 0.0);
            } else {
                assert!(beta < 0.01);
            }
        }
    }

    #[test]
    fn beta_ramps_in_continuously_above_the_bar() {
        // x = m + independent noise of variance v, m of unit variance: explained = 1 / (1 + v)
        // and the least-squares beta is 1 (n large, so the bar is MIN_EXPLAINED). The
        // delivered beta is 0 at or below the bar, rises linearly over RAMP_WIDTHS bar widths,
        // and is the least-squares value beyond.
        let sums = |explained: f64| {
            let n = 1.0e6;
            let v = 1.0 / explained - 1.0;
            PairSums([n, n * (1.0 + v), n, n])
        };
        let bar = MIN_EXPLAINED;
        assert_eq!(sums(bar * 0.99).beta(), 0.0);
        let mid = sums(bar * (1.0 + RAMP_WIDTHS / 2.0)).beta();
        assert!((mid - 0.5).abs() < 1e-9, "{mid}");
        assert_eq!(sums(bar * (1.0 + RAMP_WIDTHS) + 1e-9).beta(), 1.0);
        assert_eq!(sums(0.9).beta(), 1.0);
        // Continuous: no jump anywhere on a fine grid.
        let mut last = 0.0;
        for i in 1..=1000 {
            let b = sums(i as f64 / 1000.0 * 0.5).beta();
            assert!(b >= last && b - last < 0.02, "jump at {i}: {last} -> {b}");
            last = b;
        }
    }

    #[test]
    fn overconfident_model_gets_the_error_it_really_has() {
        // m = 2 x: beta 0.5 recovers x exactly; a half-skilled model m = x + e gets beta
        // var(x) / (var(x) + var(e)) and sigma of the optimal shrunk forecast.
        let mut s = PairSums::default();
        for i in 0..1000 {
            let x = (i as f64 * 0.1).sin();
            s.add(2.0 * x, x);
        }
        assert!((s.beta() - 0.5).abs() < 1e-12);
        assert!(s.mse(s.beta()) < 1e-20);
    }

    #[test]
    fn no_skill_prior_gives_zero_and_the_motion_std_until_evidence_comes() {
        let mut c = Calibrator::new(2400, 120.0);
        c.reset(2, &[]);
        let cal = c.get(2, 10, 4.0);
        assert_eq!(cal.beta, 0.0);
        assert!((cal.sigma - 2.0).abs() < 1e-12);
        // Perfect evidence outweighs the prior as it accumulates.
        for i in 0..5000 {
            let x = 2.0 * (i as f64 * 0.2).sin();
            c.observe(2, 10, x, x);
            c.tick();
        }
        let cal = c.get(2, 10, 4.0);
        assert!(cal.beta > 0.9, "{cal:?}");
        assert!(cal.sigma < 0.7, "{cal:?}");
    }

    /// Regression (review): a model fitted while a DOF stood still brought held-out sums
    /// without variance, counted as 240 values of error 0; sigma stayed 0 once the DOF moved,
    /// and the deck called go with certainty. Such a prior is no evidence: sigma is the live
    /// motion's, and a prior with variance is still kept.
    #[test]
    fn a_prior_from_a_motion_without_variance_is_no_skill_not_certainty() {
        let mut still = PairSums::default();
        for _ in 0..240 {
            still.add(0.0, 0.0);
        }
        let mut c = Calibrator::new(2400, 120.0);
        c.reset(0, &[still; 3]);
        for k in 0..3 {
            let cal = c.get(0, k, 0.25);
            assert_eq!(cal.beta, 0.0);
            assert!((cal.sigma - 0.5).abs() < 1e-12, "{cal:?}");
        }
        c.reset(0, &[perfect(240)]);
        assert!(c.get(0, 0, 0.25).sigma < 1e-6);
    }
}
