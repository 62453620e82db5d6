//! Sigma for a forecast whose input holds bridged values. A gap of up to `MAX_FILL` samples is
//! bridged by a straight line (or, for non-finite samples, by holding the last value), and the
//! values the decimation filter makes from it are not the motion. A linear predictor passes
//! that error on: with the sharp maps a narrow sea allows, a 0.75 s dropout at 8 Hz put the
//! forecasts 15-17 sigmas off for as long as it stayed in the models' input (review: and set
//! off twelve changes of sea on a stationary record). So while it does, each forecast is made
//! a second time with the bridged values moved by the bridge's likely error, and the
//! difference widens sigma; its errors teach neither the calibration nor the change detector.
//! Nothing allocates after construction (the scratch input grows once if a model's order
//! exceeds the configured one).

use super::ingest::BridgeSpan;
use shipcast_predict::{AnyPredictor, Predictor};
use shipcast_wire::payload::MAX_STEPS;

/// Values of history the error of a bridge is sized from (2 minutes at 2 Hz).
const SIZING_VALUES: usize = 240;
/// Safety on the sized error: the second difference of values 0.5 s apart under-states the
/// curvature of the shorter waves a little.
const SAFETY: f64 = 1.25;

/// The likely error of the bridged values of a DOF whose newest history is `history` (values
/// `dt` apart): a straight line over `span_s` misses a motion of curvature x'' by up to
/// x'' span^2 / 8, a held value a motion of slope x' by up to x' span.
pub fn fill_error(history: &[f64], dt: f64, bridge: &BridgeSpan) -> f64 {
    let n = history.len().min(SIZING_VALUES);
    let h = &history[history.len() - n..];
    if n < 3 || dt <= 0.0 {
        return 0.0;
    }
    let rms = |it: &mut dyn Iterator<Item = f64>| {
        let (mut sum, mut count) = (0.0, 0.0);
        for v in it {
            sum += v * v;
            count += 1.0;
        }
        (sum / count).sqrt()
    };
    let span = bridge.span_s / dt;
    let error = if bridge.held {
        rms(&mut h.windows(2).map(|w| w[1] - w[0])) * span
    } else {
        rms(&mut h.windows(3).map(|w| w[2] - 2.0 * w[1] + w[0])) * span * span / 8.0
    };
    if error.is_finite() {
        SAFETY * error
    } else {
        0.0
    }
}

/// Scratch for the second forecast, per engine.
#[derive(Debug, Clone)]
pub struct BridgeSpread {
    input: Vec<f64>,
    moved: [f64; MAX_STEPS],
    /// The larger change per step of moving one value either way.
    each: [f64; MAX_STEPS],
}

impl BridgeSpread {
    pub fn new(order: usize) -> Self {
        Self {
            input: Vec::with_capacity(order),
            moved: [0.0; MAX_STEPS],
            each: [0.0; MAX_STEPS],
        }
    }

    /// Forecast `out` again from `past` with each of the values `nearest..=farthest` back
    /// from the newest moved by `error` in turn, and write per step the sum of the changes'
    /// sizes into `spread` (`out.len()` steps): the most the bridge's errors can move the
    /// forecast, whatever their signs. (One shift of them all together under-stated it up to
    /// a thousandfold where the model's weights alternate in sign and cancel.) A forecast
    /// that fails the second time adds nothing: the first one stands.
    pub fn measure(
        &mut self,
        p: &mut AnyPredictor,
        past: &[f64],
        out: &[f64],
        (nearest, farthest): (usize, usize),
        error: f64,
        spread: &mut [f64],
    ) {
        spread.fill(0.0);
        if error <= 0.0 || past.is_empty() {
            return;
        }
        self.input.clear();
        self.input.extend_from_slice(past);
        let newest = self.input.len() - 1;
        for back in nearest..=farthest.min(newest) {
            let i = newest - back;
            let kept = self.input[i];
            // Both ways: a guarded map is not linear (its guard clamps the forecast), and
            // one way may be clamped where the other is not.
            for sign in [1.0, -1.0] {
                self.input[i] = kept + sign * error;
                let moved = &mut self.moved[..out.len()];
                if p.forecast(&self.input, moved).is_ok() {
                    for ((s, m), o) in self.each.iter_mut().zip(moved.iter()).zip(out) {
                        let d = (m - o).abs();
                        if d.is_finite() {
                            *s = s.max(d);
                        }
                    }
                }
            }
            self.input[i] = kept;
            for (s, e) in spread.iter_mut().zip(self.each.iter_mut()) {
                *s += *e;
                *e = 0.0;
            }
        }
        // An error in the input does not fade with the lead the way the weights of one step
        // against the next suggest: each step gets the largest spread of the steps up to it.
        let mut most = 0.0f64;
        for s in spread.iter_mut() {
            most = most.max(*s);
            *s = most;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bridge(span_s: f64, held: bool) -> BridgeSpan {
        BridgeSpan::new_for_test(span_s, held)
    }

    #[test]
    fn a_straight_line_over_a_sine_misses_it_by_what_its_curvature_says() {
        // A sine of amplitude 1, period 8 s, at 2 Hz: x'' = -w^2 x; a straight line over
        // 1 s misses it by up to w^2 / 8 where the curvature is largest. Sized from the
        // curvature's RMS, w^2 / sqrt(2), the error lies between that miss and the largest.
        let dt = 0.5;
        let w = std::f64::consts::TAU / 8.0;
        let x: Vec<f64> = (0..400).map(|i| (w * i as f64 * dt).sin()).collect();
        let e = fill_error(&x, dt, &bridge(1.0, false));
        // The second difference is a little less than w^2 dt^2.
        let expected = SAFETY * w * w / std::f64::consts::SQRT_2 / 8.0;
        assert!((e / expected - 1.0).abs() < 0.05, "{e} {expected}");
        assert!(
            e > w * w / std::f64::consts::SQRT_2 / 8.0 && e < w * w / 8.0,
            "{e}"
        );
        // Held instead: the slope's RMS w / sqrt(2) times the span, far more.
        let held = fill_error(&x, dt, &bridge(1.0, true));
        let expected = SAFETY * w / std::f64::consts::SQRT_2;
        assert!((held / expected - 1.0).abs() < 0.05, "{held} {expected}");
        // Nothing to size from: no error claimed, and no NaN.
        assert_eq!(fill_error(&x[..2], dt, &bridge(1.0, false)), 0.0);
    }

    #[test]
    fn the_spread_is_the_forecasts_response_to_the_moved_values() {
        // Persistence forecasts the newest value at every step: moving the newest value by
        // 0.3 moves every step by 0.3; moving only older values moves nothing.
        let config = shipcast_predict::PredictorConfig {
            order: 1,
            horizon: 4,
            ..Default::default()
        };
        let mut p = AnyPredictor::new(shipcast_predict::Method::Persistence, &config).unwrap();
        p.fit(&[0.0; 16]).unwrap();
        let past = [1.0, 2.0, 3.0];
        let mut out = [0.0; 4];
        p.forecast(&past[2..], &mut out).unwrap();
        let mut b = BridgeSpread::new(1);
        let mut spread = [9.0; 4];
        b.measure(&mut p, &past[2..], &out, (0, 0), 0.3, &mut spread);
        assert!(spread.iter().all(|s| (s - 0.3).abs() < 1e-12), "{spread:?}");
        b.measure(&mut p, &past[2..], &out, (0, 0), 0.0, &mut spread);
        assert_eq!(spread, [0.0; 4]);
    }
}
