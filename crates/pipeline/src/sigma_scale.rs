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
//! The sigmas an operator reads use [`SigmaScale::adaptive`]: a memory that grows with the
//! evidence and a guard against a ratio that no longer holds (the type's doc says why).

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

/// How much shorter the guard's memory is than the scale's own: a half-life of 1200 verified
/// forecasts (10 min at 2 Hz) gives the guard 150 (75 s).
pub const GUARD_MEMORY_FRACTION: f64 = 1.0 / 8.0;

/// By how much (in mean square) the guard's recent errors must exceed what the scale claims
/// before the guard's scale is used instead: errors 1.22 times the scaled sigma. Tried on the
/// two-ship study: 1.3 fired on wave groups and widened the measured sea's +-1 sigma to 0.73;
/// 2.0 never fired while the sigmas drifted (docs/two_ships.md, "Sigma").
pub const GUARD_RATIO: f64 = 1.5;

/// An adaptive scale's memory grows with its evidence: its half-life is a quarter of the
/// forecasts verified so far (at least half of `min_weight`) until it reaches the configured
/// one, after 4 half-lives (40 minutes at the default 1200). An infinite half-life does not
/// grow: it never forgets from the start.
pub const MEMORY_GROWTH: f64 = 4.0;

/// Running, exponentially weighted standardised squares per axis (x, y, z) and step.
///
/// [`SigmaScale::adaptive`], for the sigmas an operator reads (the relative motion's, the crane
/// tip's), adds two things to [`SigmaScale::new`]'s plain sums, both about one hazard: the
/// scale assumes that the ratio of the errors to the sigma it scales is steady, and a long
/// memory carries the ratio of the past into a present where it no longer holds. In a
/// pipeline's first quarter hour the ships' own sigmas start at the motion's std (no skill) and
/// then fall over minutes as their engines calibrate, while an error that does not follow them
/// (B = A plus white noise, `relative::tests`) stays as large: the standardised squares of the
/// past are too small for now. With plain sums the relative sigma there covered 57-60 % of the
/// errors within +-1 sigma and 86-88 % within +-2 sigma from 300 s to 900 s.
/// - **A memory that grows with the evidence** ([`MEMORY_GROWTH`]): the first minutes weigh
///   less as more come in. 65-68 % and 93-95 % there.
/// - **A one-sided guard**: a second set of sums with an eighth of the configured half-life
///   (or the grown one, while that is shorter: in the first minutes, when the memory is short
///   anyway, the guard adds nothing), whose mean the scale follows where it exceeds the long
///   one's by [`GUARD_RATIO`]: an abrupt change of regime later on is followed within a
///   guard's memory. It never narrows the scale: a sigma too wide is left to the long memory,
///   the safe side.
#[derive(Debug, Clone)]
pub struct SigmaScale {
    min_weight: f64,
    /// The configured half-life, in verified forecasts.
    halflife: f64,
    /// Verified forecasts observed.
    observed: f64,
    long: ScaleSums,
    /// The guard's sums, an eighth of the memory: an adaptive scale's only.
    guard: Option<ScaleSums>,
}

/// Exponentially weighted sums with one memory.
#[derive(Debug, Clone)]
struct ScaleSums {
    decay: f64,
    /// Verified forecasts (weighted) that reached each step, and unweighted.
    weight: [f64; MAX_STEPS],
    seen: [f64; MAX_STEPS],
    squares: [[f64; MAX_STEPS]; 3],
    /// Forecasts counted in `squares` (those with a positive, finite variance).
    counted: [[f64; MAX_STEPS]; 3],
}

impl ScaleSums {
    fn new(halflife: f64) -> Self {
        Self {
            decay: decay_per_forecast(halflife),
            weight: [0.0; MAX_STEPS],
            seen: [0.0; MAX_STEPS],
            squares: [[0.0; MAX_STEPS]; 3],
            counted: [[0.0; MAX_STEPS]; 3],
        }
    }

    /// Forgets by one forecast at step `k` and adds its standardised squares (None: no
    /// standardised error on that axis).
    fn add(&mut self, k: usize, z2: [Option<f64>; 3]) {
        let d = self.decay;
        self.weight[k] = d * self.weight[k] + 1.0;
        self.seen[k] += 1.0;
        for (axis, z2) in z2.iter().enumerate() {
            self.squares[axis][k] = d * self.squares[axis][k] + z2.unwrap_or(0.0);
            self.counted[axis][k] = d * self.counted[axis][k] + f64::from(u8::from(z2.is_some()));
        }
    }

    /// The weight the sums tend to with their present memory: 1 / (1 - decay).
    fn full_weight(&self) -> f64 {
        if self.decay < 1.0 {
            1.0 / (1.0 - self.decay)
        } else {
            f64::INFINITY
        }
    }

    /// The weighted mean standardised square of `axis` at step `k`.
    fn mean(&self, axis: usize, k: usize) -> Option<f64> {
        (self.counted[axis][k] > 0.0).then(|| self.squares[axis][k] / self.counted[axis][k])
    }
}

impl SigmaScale {
    /// Plain sums that forget with a half-life of `halflife` verified forecasts and are used
    /// once `min_weight` verified forecasts (weighted) stand behind a step.
    pub fn new(halflife: f64, min_weight: f64) -> Self {
        Self {
            min_weight: min_weight.max(1.0),
            halflife,
            observed: 0.0,
            long: ScaleSums::new(halflife),
            guard: None,
        }
    }

    /// Sums whose memory grows with the evidence up to `halflife`, with the guard (see the
    /// type's doc), used once `min_weight` verified forecasts have reached a step. An infinite
    /// half-life never forgets, and then the guard is the scale itself.
    pub fn adaptive(halflife: f64, min_weight: f64) -> Self {
        Self {
            guard: Some(ScaleSums::new(halflife * GUARD_MEMORY_FRACTION)),
            ..Self::new(halflife, min_weight)
        }
    }

    /// Adds one verified forecast of `steps` steps: `error(axis, k)` gives its error and the
    /// variance it was issued with at step k. A step without a positive, finite variance (or
    /// with a non-finite error) has no standardised error to count.
    pub fn observe(&mut self, steps: usize, mut error: impl FnMut(usize, usize) -> (f64, f64)) {
        self.observed += 1.0;
        if let Some(guard) = self.guard.as_mut().filter(|_| self.halflife.is_finite()) {
            let grown = (self.observed / MEMORY_GROWTH).max(0.5 * self.min_weight);
            let long = self.halflife.min(grown);
            self.long.decay = decay_per_forecast(long);
            guard.decay = decay_per_forecast(long.min(self.halflife * GUARD_MEMORY_FRACTION));
        }
        for k in 0..steps.min(MAX_STEPS) {
            let z2 = std::array::from_fn(|axis| {
                let (e, v) = error(axis, k);
                (v > 0.0 && v.is_finite() && e.is_finite()).then(|| (e * e / v).min(MAX_Z2))
            });
            self.long.add(k, z2);
            if let Some(guard) = &mut self.guard {
                guard.add(k, z2);
            }
        }
    }

    /// The factor by which the (long) sums forget at each verified forecast now.
    pub fn decay(&self) -> f64 {
        self.long.decay
    }

    /// Whether step `k` has `min_weight` verified forecasts behind it (weighted for plain
    /// sums; counted for adaptive ones, whose early memory is short by design).
    pub fn ready(&self, k: usize) -> bool {
        let behind = if self.guard.is_some() {
            self.long.seen.get(k)
        } else {
            self.long.weight.get(k)
        };
        behind.is_some_and(|&w| w >= self.min_weight)
    }

    /// Factor on the sigma of `axis` at step `k`, once enough is verified: the long memory's,
    /// or, for an adaptive scale, the guard's where that is [`GUARD_RATIO`] larger in mean
    /// square.
    pub fn scale(&self, axis: usize, k: usize) -> Option<f64> {
        if !self.ready(k) || axis >= 3 {
            return None;
        }
        let long = self.long.mean(axis, k)?;
        let guard = self
            .guard
            .as_ref()
            .filter(|g| g.weight[k] >= self.min_weight.min(0.5 * g.full_weight()))
            .and_then(|g| g.mean(axis, k))
            .unwrap_or(0.0);
        Some(
            if guard > GUARD_RATIO * long {
                guard
            } else {
                long
            }
            .sqrt(),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, StandardNormal};

    /// Feeds `n` one-step forecasts with variance 1 whose z-axis error is `error()`.
    fn feed(scale: &mut SigmaScale, n: usize, mut error: impl FnMut() -> f64) {
        for _ in 0..n {
            let e = error();
            scale.observe(1, |axis, _| (if axis == 2 { e } else { 0.0 }, 1.0));
        }
    }

    /// Errors a tenth of sigma for 6000 forecasts (the memory grown to its full 1200), then as
    /// large as sigma. The long memory alone is still at 0.41 after 300 forecasts of the new
    /// regime; the guard's (two of its half-lives) has the scale at about 0.87.
    #[test]
    fn a_scale_learnt_in_another_regime_does_not_stay_too_narrow() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let mut scale = SigmaScale::adaptive(1200.0, 100.0);
        feed(&mut scale, 6000, || 0.1);
        assert!((scale.scale(2, 0).unwrap() - 0.1).abs() < 1e-9);
        feed(&mut scale, 300, || StandardNormal.sample(&mut rng));
        let s = scale.scale(2, 0).unwrap();
        assert!((0.8..1.2).contains(&s), "{s}");
        let long = (scale.long.squares[2][0] / scale.long.counted[2][0]).sqrt();
        assert!(long < 0.5, "{long}");
    }

    /// The memory grows with the evidence: its half-life is a quarter of the forecasts seen,
    /// never below half of `min_weight` nor above the configured one; plain sums and an
    /// infinite half-life do not grow.
    #[test]
    fn an_adaptive_memory_grows_with_the_forecasts_verified() {
        let halflife_after = |scale: &mut SigmaScale, n: usize| {
            feed(scale, n, || 1.0);
            0.5f64.ln() / scale.decay().ln()
        };
        let mut scale = SigmaScale::adaptive(1200.0, 100.0);
        assert!((halflife_after(&mut scale, 10) - 50.0).abs() < 1e-6);
        assert!((halflife_after(&mut scale, 790) - 200.0).abs() < 1e-6);
        assert!((halflife_after(&mut scale, 4000) - 1200.0).abs() < 1e-6);
        let mut plain = SigmaScale::new(1200.0, 100.0);
        assert!((halflife_after(&mut plain, 800) - 1200.0).abs() < 1e-6);
        let mut never = SigmaScale::adaptive(f64::INFINITY, 100.0);
        feed(&mut never, 800, || 1.0);
        assert_eq!(never.decay(), 1.0);
        // Counted, not weighted: ready at the 100th forecast although its memory is 50.
        let mut early = SigmaScale::adaptive(1200.0, 100.0);
        feed(&mut early, 99, || 1.0);
        assert_eq!(early.scale(2, 0), None);
        feed(&mut early, 1, || 1.0);
        assert_eq!(early.scale(2, 0), Some(1.0));
    }

    /// The other way, errors shrinking, the guard leaves the wide long-memory scale alone.
    #[test]
    fn the_guard_never_narrows_the_scale() {
        let mut scale = SigmaScale::adaptive(1200.0, 100.0);
        feed(&mut scale, 6000, || 1.0);
        feed(&mut scale, 300, || 0.1);
        let s = scale.scale(2, 0).unwrap();
        let long = (scale.long.squares[2][0] / scale.long.counted[2][0]).sqrt();
        assert_eq!(s, long);
        assert!(s > 0.85, "{s}");
    }

    /// Monte Carlo, steady sea: errors correlated from one forecast to the next (AR(1), 0.95,
    /// like neighbouring origins') of unit variance. The guarded scale's +-1 and +-2 sigma
    /// cover them about as a Gaussian's do; the guard widens sigma only a little.
    #[test]
    fn in_a_steady_sea_the_guarded_sigma_covers_as_a_gaussian_does() {
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let mut scale = SigmaScale::adaptive(1200.0, 100.0);
        let rho: f64 = 0.95;
        let mut e = 0.0;
        let mut next = |rng: &mut ChaCha8Rng| {
            let w: f64 = StandardNormal.sample(rng);
            e = rho * e + (1.0 - rho * rho).sqrt() * w;
            e
        };
        for _ in 0..3000 {
            let x = next(&mut rng);
            scale.observe(1, |axis, _| (if axis == 2 { x } else { 0.0 }, 1.0));
        }
        let (mut n, mut in1, mut in2, mut sum) = (0.0, 0.0, 0.0, 0.0);
        for _ in 0..200_000 {
            let s = scale.scale(2, 0).unwrap();
            let x = next(&mut rng);
            n += 1.0;
            sum += s;
            in1 += f64::from(u8::from(x.abs() <= s));
            in2 += f64::from(u8::from(x.abs() <= 2.0 * s));
            scale.observe(1, |axis, _| (if axis == 2 { x } else { 0.0 }, 1.0));
        }
        let (c1, c2, mean) = (in1 / n, in2 / n, sum / n);
        assert!((0.66..0.72).contains(&c1), "{c1}");
        assert!((0.94..0.97).contains(&c2), "{c2}");
        assert!((0.98..1.08).contains(&mean), "{mean}");
    }
}
