//! The averager's arithmetic on hand-computed cases, its limits, and the fitted weights.

use super::*;
use crate::Method;

#[test]
fn k_one_returns_each_forecast_bit_for_bit() {
    let mut averager = ForecastAverager::new(AveragingWeights::uniform(1, 4).unwrap());
    let mut out = [0.0; 4];
    for f in [
        [0.1, -0.0, 1e-300, -7.25],
        [3.0, f64::MIN_POSITIVE, 2.5e10, -1.0 / 3.0],
    ] {
        averager.push(&f, &mut out).unwrap();
        assert_eq!(out.map(f64::to_bits), f.map(f64::to_bits));
    }
}

/// K = 3, H = 4: step s of the newest forecast is covered by min(available, H - s) forecasts,
/// the one made j steps ago at its index s + j.
#[test]
fn uniform_mean_of_the_forecasts_covering_each_step() {
    let mut averager = ForecastAverager::new(AveragingWeights::uniform(3, 4).unwrap());
    let mut out = [0.0; 4];
    averager.push(&[1.0, 2.0, 3.0, 4.0], &mut out).unwrap();
    assert_eq!(out, [1.0, 2.0, 3.0, 4.0]);
    averager.push(&[10.0, 20.0, 30.0, 40.0], &mut out).unwrap();
    assert_eq!(out, [6.0, 11.5, 17.0, 40.0]);
    averager
        .push(&[100.0, 200.0, 300.0, 400.0], &mut out)
        .unwrap();
    let expected = [
        (100.0 + 20.0 + 3.0) / 3.0,
        (200.0 + 30.0 + 4.0) / 3.0,
        (300.0 + 40.0) / 2.0,
        400.0,
    ];
    for (o, e) in out.iter().zip(expected) {
        assert!((o - e).abs() < 1e-12, "{out:?} against {expected:?}");
    }
    // The oldest leaves the window: (1000 + 200 + 30) / 3 at step 0.
    averager
        .push(&[1000.0, 2000.0, 3000.0, 4000.0], &mut out)
        .unwrap();
    assert!((out[0] - 410.0).abs() < 1e-12, "{out:?}");
    // After a reset the next forecast stands alone again.
    averager.reset();
    averager.push(&[5.0, 6.0, 7.0, 8.0], &mut out).unwrap();
    assert_eq!(out, [5.0, 6.0, 7.0, 8.0]);
}

#[test]
fn k_outside_one_to_horizon_is_a_one_line_error() {
    for k in [0, 11] {
        let e = AveragingWeights::uniform(k, 10).unwrap_err().to_string();
        assert!(e.contains("between 1 and the horizon 10"), "{e}");
        assert!(!e.contains('\n'));
    }
    assert!(Averaging {
        k: 10,
        mode: AverageMode::Weighted
    }
    .validate(10)
    .is_ok());
    let mut averager = ForecastAverager::new(AveragingWeights::uniform(2, 4).unwrap());
    assert!(averager.push(&[1.0; 3], &mut [0.0; 4]).is_err());
    assert_eq!("Weighted".parse::<AverageMode>(), Ok(AverageMode::Weighted));
    assert!("mean"
        .parse::<AverageMode>()
        .unwrap_err()
        .contains("uniform or weighted"));
}

/// On the ramp x[i] = i, forecasts exact in shape but with a gain error growing with the lead:
/// step s reads (1 + g s) times the truth. Every forecast of an instant is then a known multiple
/// of the truth, so the least-squares weights must make the combination exact (up to the small
/// ridge), while the uniform mean keeps a gain error.
struct GainErrorRamp {
    order: usize,
    horizon: usize,
    gain: f64,
}

impl Predictor for GainErrorRamp {
    fn method(&self) -> Method {
        Method::Wiener
    }
    fn order(&self) -> usize {
        self.order
    }
    fn horizon(&self) -> usize {
        self.horizon
    }
    fn fit(&mut self, _train: &[f64]) -> Result<(), PredictError> {
        Ok(())
    }
    fn forecast(&mut self, past: &[f64], out: &mut [f64]) -> Result<(), PredictError> {
        let last = past[past.len() - 1];
        for (s, o) in out.iter_mut().enumerate().take(self.horizon) {
            *o = (last + 1.0 + s as f64) * (1.0 + self.gain * s as f64);
        }
        Ok(())
    }
}

#[test]
fn fitted_weights_undo_a_lead_dependent_gain_error() {
    let (order, horizon, k) = (5, 6, 3);
    let ramp: Vec<f64> = (0..400).map(|i| i as f64).collect();
    let mut p = GainErrorRamp {
        order,
        horizon,
        gain: 0.05,
    };
    let weights = fit_weights(&mut p, &ramp[..200], k).unwrap();
    // Step 0 is covered by leads 0, 1, 2 with gains 1, 1.05, 1.1: the weights, applied to the
    // gains, must give 1.
    for s in 0..horizon {
        let w = weights.at_step(s);
        assert_eq!(w.len(), k.min(horizon - s));
        let gain: f64 = w
            .iter()
            .enumerate()
            .map(|(j, w)| w * (1.0 + 0.05 * (s + j) as f64))
            .sum();
        assert!(
            (gain - 1.0).abs() < 1e-4,
            "step {s}: weights {w:?} give gain {gain}"
        );
    }
    // Out of the training segment, the weighted combination is exact, the uniform one is not.
    let mut weighted = ForecastAverager::new(weights);
    let mut uniform = ForecastAverager::new(AveragingWeights::uniform(k, horizon).unwrap());
    let (mut fw, mut fu, mut f) = ([0.0; 6], [0.0; 6], [0.0; 6]);
    for origin in 300..=394 {
        p.forecast(&ramp[origin - order..origin], &mut f).unwrap();
        weighted.push(&f, &mut fw).unwrap();
        uniform.push(&f, &mut fu).unwrap();
        if origin < 300 + k {
            continue;
        }
        for s in 0..horizon {
            let truth = ramp[origin + s];
            assert!(
                (fw[s] - truth).abs() < 1e-3 * truth,
                "origin {origin} step {s}"
            );
        }
        assert!((fu[0] - ramp[origin]).abs() > 0.04 * ramp[origin]);
    }
}

#[test]
fn fitting_needs_enough_training_values() {
    let mut p = GainErrorRamp {
        order: 5,
        horizon: 6,
        gain: 0.0,
    };
    let ramp: Vec<f64> = (0..15).map(|i| i as f64).collect();
    // 5 + 3 - 1 origins to have three forecasts, their 6 steps, and 3 to weigh them: 16.
    let e = fit_weights(&mut p, &ramp, 3).unwrap_err();
    assert!(
        matches!(
            e,
            PredictError::TooShortToWeigh {
                k: 3,
                needed: 16,
                got: 15,
                ..
            }
        ),
        "{e}"
    );
    assert!(fit_weights(&mut p, &(0..16).map(f64::from).collect::<Vec<_>>(), 3).is_ok());
}

#[test]
fn pushing_forecasts_does_not_allocate() {
    let ramp: Vec<f64> = (0..200).map(|i| i as f64).collect();
    let mut p = GainErrorRamp {
        order: 5,
        horizon: 6,
        gain: 0.01,
    };
    let mut averager = ForecastAverager::new(fit_weights(&mut p, &ramp, 4).unwrap());
    let (mut f, mut out) = ([0.0; 6], [0.0; 6]);
    let allocations = crate::conformance::allocations_during(|| {
        for origin in 5..100 {
            p.forecast(&ramp[origin - 5..origin], &mut f).unwrap();
            averager.push(&f, &mut out).unwrap();
            if origin == 50 {
                averager.reset();
            }
        }
    });
    assert_eq!(allocations, 0);
}
