//! The protocol with averaged forecasts: K = 1 is the plain protocol bit for bit, exact
//! forecasts stay exact, every scored origin combines the forecasts of the origins before it,
//! and the fitted weights see the training segment only.

use super::tests::{config, ramp, settings, RampSpy};
use super::*;
use shipcast_predict::averaging::{averager_for, AveragingWeights, ForecastAverager};
use shipcast_predict::{
    AnyPredictor, AverageMode, Averaging, Method, PredictError, Predictor, PredictorConfig,
};
use shipcast_wire::Dof;

/// The exact predictor of a sum of sinusoids with known frequencies: such a series obeys the
/// linear recurrence whose characteristic polynomial is prod (z^2 - 2 cos(w) z + 1), so
/// iterating it extrapolates without error (up to rounding).
struct SinusoidRecurrence {
    /// x[t] = sum_i c[i] x[t - 1 - i].
    c: Vec<f64>,
    horizon: usize,
    work: Vec<f64>,
}

impl SinusoidRecurrence {
    fn new(frequencies: &[f64], horizon: usize) -> Self {
        // Polynomial coefficients, highest power first.
        let mut poly = vec![1.0];
        for &w in frequencies {
            let factor = [1.0, -2.0 * w.cos(), 1.0];
            let mut next = vec![0.0; poly.len() + 2];
            for (i, p) in poly.iter().enumerate() {
                for (j, f) in factor.iter().enumerate() {
                    next[i + j] += p * f;
                }
            }
            poly = next;
        }
        let c: Vec<f64> = poly[1..].iter().map(|a| -a).collect();
        let work = vec![0.0; c.len() + horizon];
        Self { c, horizon, work }
    }
}

impl Predictor for SinusoidRecurrence {
    fn method(&self) -> Method {
        Method::Wiener
    }
    fn order(&self) -> usize {
        self.c.len()
    }
    fn horizon(&self) -> usize {
        self.horizon
    }
    fn fit(&mut self, _train: &[f64]) -> Result<(), PredictError> {
        Ok(())
    }
    fn forecast(&mut self, past: &[f64], out: &mut [f64]) -> Result<(), PredictError> {
        let p = self.c.len();
        self.work[..p].copy_from_slice(&past[past.len() - p..]);
        for t in p..p + self.horizon {
            let v: f64 = (0..p).map(|i| self.c[i] * self.work[t - 1 - i]).sum();
            self.work[t] = v;
            out[t - p] = v;
        }
        Ok(())
    }
}

const FREQUENCIES: [f64; 3] = [0.31, 0.52, 0.113];

fn sinusoids(len: usize) -> Vec<f64> {
    (0..len)
        .map(|i| {
            let t = i as f64;
            (FREQUENCIES[0] * t).sin()
                + 0.5 * (FREQUENCIES[1] * t + 1.0).cos()
                + 0.8 * (FREQUENCIES[2] * t + 0.3).sin()
        })
        .collect()
}

#[test]
fn averaging_exact_forecasts_leaves_them_exact() {
    let x = sinusoids(700);
    let (train, horizon, k) = (300, 20, 5);
    let mut p = SinusoidRecurrence::new(&FREQUENCIES, horizon);
    let plain = score_forecasts(&mut p, &x, train, 3, None, &|_| {}).unwrap();
    assert!(plain.rms.iter().all(|r| *r < 1e-9), "{:?}", plain.rms);
    for mode in [AverageMode::Uniform, AverageMode::Weighted] {
        let mut averager = averager_for(Averaging { k, mode }, &mut p, &x[..train]).unwrap();
        let scores =
            score_averaged_forecasts(&mut p, &x, train, 3, None, &mut averager, &|_| {}).unwrap();
        assert_eq!(scores.origins, plain.origins);
        // Weighted: the small ridge shrinks the weights' sum below 1 by about 1e-6.
        let tolerance = if mode == AverageMode::Uniform {
            1e-9
        } else {
            1e-4
        };
        assert!(
            scores.rms.iter().all(|r| *r < tolerance),
            "{mode}: {:?}",
            scores.rms
        );
    }
}

/// On the ramp every origin forecasts instant t as t + offset, so any mean of forecasts of t is
/// off by exactly the offset; an online spy also checks that each forecast follows the update
/// of the value just before its origin, with averaging as without.
#[test]
fn averaged_scores_use_every_origin_and_keep_the_update_order() {
    let x = ramp(300);
    for (online, stride) in [(false, 1), (true, 4)] {
        let mut spy = RampSpy::new(20, 6, 0.5, online);
        let mut averager = ForecastAverager::new(AveragingWeights::uniform(4, 6).unwrap());
        let done = std::cell::Cell::new(0u64);
        let scores =
            score_averaged_forecasts(&mut spy, &x, 100, stride, None, &mut averager, &|n| {
                done.set(done.get() + n)
            })
            .unwrap_or_else(|e| panic!("online {online}, stride {stride}: {e}"));
        let scored = (120..=294).step_by(stride).count();
        assert_eq!(scores.origins, scored);
        assert_eq!(done.get(), scored as u64);
        assert!(
            scores.rms.iter().all(|r| (r - 0.5).abs() < 1e-12),
            "{:?}",
            scores.rms
        );
        if online {
            // Forecasts are made at every origin from 117 to 294, so every value x[100..294)
            // was given.
            assert_eq!(spy.updates, 294 - 100);
        }
    }
}

/// K = 1 through the averaged loop gives the plain protocol's numbers bit for bit, also for an
/// online method scored every few origins; and `evaluate_method` with K = 1 in either mode is
/// the evaluation without averaging.
#[test]
fn k_one_equals_the_protocol_bit_for_bit() {
    let x = sinusoids(900)
        .iter()
        .enumerate()
        .map(|(i, v)| v + 0.05 * ((i * 7919 % 101) as f64 / 101.0 - 0.5))
        .collect::<Vec<_>>();
    let cfg = PredictorConfig {
        lms_normalized: true,
        ..config(40, 10)
    };
    let fitted = || {
        let mut p = AnyPredictor::new(Method::Ar, &cfg).unwrap();
        p.fit(&x[..400]).unwrap();
        p
    };
    let bits = |v: &[f64]| v.iter().map(|r| r.to_bits()).collect::<Vec<_>>();
    let plain = score_forecasts(&mut fitted(), &x, 400, 3, None, &|_| {}).unwrap();
    for mode in [AverageMode::Uniform, AverageMode::Weighted] {
        let mut p = fitted();
        let mut averager = averager_for(Averaging { k: 1, mode }, &mut p, &x[..400]).unwrap();
        let one =
            score_averaged_forecasts(&mut p, &x, 400, 3, None, &mut averager, &|_| {}).unwrap();
        assert_eq!(one.origins, plain.origins);
        assert_eq!(bits(&one.rms), bits(&plain.rms), "{mode}");
        assert_eq!(bits(&one.persistence_rms), bits(&plain.persistence_rms));
    }

    let prepared = prepare_series(&x, Dof::Heave, &settings(400, 0.0)).unwrap();
    let none = evaluate_method(
        &prepared,
        Dof::Heave,
        Method::Wiener,
        &cfg,
        &settings(400, 0.0),
        &|_| {},
    )
    .unwrap();
    let weighted_one = EvalSettings {
        stride: 1,
        average: Averaging {
            k: 1,
            mode: AverageMode::Weighted,
        },
        ..settings(400, 0.0)
    };
    let one = evaluate_method(
        &prepared,
        Dof::Heave,
        Method::Wiener,
        &cfg,
        &weighted_one,
        &|_| {},
    )
    .unwrap();
    assert_eq!(bits(&one.rms), bits(&none.rms));
    assert_eq!(one.average_weights, None);
}

/// The weights come from the training segment alone: a different test segment leaves them
/// unchanged (and changes the scores), a different training segment changes them.
#[test]
fn fitted_weights_depend_on_the_training_segment_only() {
    let train = 400;
    let noise =
        |seed: usize, i: usize| 0.2 * (((i * 7919 + seed * 104_729) % 1009) as f64 / 1009.0 - 0.5);
    let series = |train_seed: usize, test_seed: usize| -> PreparedSeries {
        let x = sinusoids(900)
            .iter()
            .enumerate()
            .map(|(i, v)| v + noise(if i < train { train_seed } else { test_seed }, i))
            .collect::<Vec<_>>();
        prepare_series(&x, Dof::Heave, &settings(train, 0.0)).unwrap()
    };
    let s = EvalSettings {
        average: Averaging {
            k: 4,
            mode: AverageMode::Weighted,
        },
        ..settings(train, 0.0)
    };
    let run = |prepared: &PreparedSeries| {
        evaluate_method(
            prepared,
            Dof::Heave,
            Method::Wiener,
            &config(30, 8),
            &s,
            &|_| {},
        )
        .unwrap()
    };
    let a = run(&series(1, 2));
    let other_test = run(&series(1, 3));
    let other_train = run(&series(4, 2));
    let weights = a
        .average_weights
        .clone()
        .expect("weighted averaging reports its weights");
    assert_eq!(weights.len(), 8);
    assert_eq!(weights[0].len(), 4);
    assert_eq!(weights[7].len(), 1);
    assert_eq!(other_test.average_weights.as_ref(), Some(&weights));
    assert_ne!(other_test.rms, a.rms);
    assert_ne!(other_train.average_weights.as_ref(), Some(&weights));
    assert_eq!(
        a.average,
        Averaging {
            k: 4,
            mode: AverageMode::Weighted
        }
    );
}

#[test]
fn k_beyond_the_horizon_stops_the_evaluation_with_one_line() {
    let prepared = prepare_series(&sinusoids(900), Dof::Heave, &settings(400, 0.0)).unwrap();
    let s = EvalSettings {
        average: Averaging {
            k: 9,
            mode: AverageMode::Uniform,
        },
        ..settings(400, 0.0)
    };
    let e = evaluate_method(
        &prepared,
        Dof::Heave,
        Method::Zero,
        &config(30, 8),
        &s,
        &|_| {},
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("between 1 and the horizon 8"), "{e}");
    assert!(origin_count(900, &config(30, 8), &s).is_err());
}
