//! Protocol tests with predictors whose behaviour is known exactly.

use super::*;
use shipcast_predict::{Averaging, Method, PredictError, Predictor, PredictorConfig};
use shipcast_series::motion_csv::{Column, MotionData};
use shipcast_wire::Dof;

/// Forecasts `last + 1 + k + offset` for step k+1; on the ramp x[i] = i that is off by
/// exactly `offset` at every step. As an online method it checks that updates arrive one value at
/// a time, in order, and that a forecast at origin o follows the update of x[o-1] and no later.
pub(super) struct RampSpy {
    order: usize,
    horizon: usize,
    offset: f64,
    online: bool,
    last_update: Option<f64>,
    pub(super) updates: usize,
}

impl RampSpy {
    pub(super) fn new(order: usize, horizon: usize, offset: f64, online: bool) -> Self {
        Self {
            order,
            horizon,
            offset,
            online,
            last_update: None,
            updates: 0,
        }
    }
}

impl Predictor for RampSpy {
    fn method(&self) -> Method {
        Method::Ar
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
        if past.len() != self.order {
            return Err(PredictError::Length(format!("past of {}", past.len())));
        }
        let last = past[past.len() - 1];
        if self.online && self.last_update != Some(last) {
            return Err(PredictError::Numerical(format!(
                "forecast after x={last} but last update was {:?}",
                self.last_update
            )));
        }
        for (k, o) in out.iter_mut().enumerate() {
            *o = last + 1.0 + k as f64 + self.offset;
        }
        Ok(())
    }
    fn is_online(&self) -> bool {
        self.online
    }
    fn update(&mut self, recent: &[f64]) -> Result<(), PredictError> {
        let newest = recent[recent.len() - 1];
        let in_order = self.last_update.is_none_or(|prev| newest == prev + 1.0);
        if recent.len() != self.order + self.horizon || !in_order {
            return Err(PredictError::Numerical(format!(
                "bad update ending at {newest}"
            )));
        }
        self.last_update = Some(newest);
        self.updates += 1;
        Ok(())
    }
}

pub(super) fn ramp(len: usize) -> Vec<f64> {
    (0..len).map(|i| i as f64).collect()
}

#[test]
fn origins_follow_the_protocol() {
    let got: Vec<usize> = origins(100, 50, 10, 5, 3).unwrap().collect();
    let expected: Vec<usize> = (60..=95).step_by(3).collect();
    assert_eq!(got, expected);
    assert_eq!(
        origins(65, 50, 10, 5, 1).unwrap().collect::<Vec<_>>(),
        vec![60]
    );
    let short = origins(64, 50, 10, 5, 1).unwrap_err().to_string();
    assert!(
        short.contains("64 samples is too short") && short.contains("= 65"),
        "{short}"
    );
    assert!(origins(100, 50, 0, 5, 1).is_err());
    assert!(origins(100, 50, usize::MAX, 5, 1).is_err());
    assert!(origins(100, 50, 10, 0, 1).is_err());
    assert!(origins(100, 50, 10, 5, 0).is_err());
}

#[test]
fn scores_are_exact_for_a_known_error() {
    let x = ramp(300);
    for (online, stride) in [(false, 1), (true, 1), (true, 7)] {
        let mut spy = RampSpy::new(20, 6, 0.5, online);
        let done = std::cell::Cell::new(0u64);
        let scores = score_forecasts(&mut spy, &x, 100, stride, None, &|n| {
            done.set(done.get() + n)
        })
        .unwrap_or_else(|e| panic!("online {online}, stride {stride}: {e}"));
        let expected_origins = (120..=294).step_by(stride).count();
        assert_eq!(scores.origins, expected_origins);
        assert_eq!(done.get(), expected_origins as u64);
        assert!(scores.rms.iter().all(|r| (r - 0.5).abs() < 1e-12));
        // Persistence on a ramp is off by h at step h.
        for (h, r) in scores.persistence_rms.iter().enumerate() {
            assert!((r - (h + 1) as f64).abs() < 1e-12);
        }
        if online {
            // Every test value x[100..last origin) was given, one by one.
            let last_origin = (120..=294).step_by(stride).last().unwrap();
            assert_eq!(spy.updates, last_origin - 100);
            assert_eq!(spy.last_update, Some((last_origin - 1) as f64));
        }
        let sigma =
            forecast_sigma(&mut RampSpy::new(20, 6, -0.25, false), &x, 100, stride).unwrap();
        assert!(sigma.iter().all(|s| (s - 0.25).abs() < 1e-12));
    }
}

#[test]
fn online_updates_skip_values_without_enough_history() {
    // Test segment starts at 10 but an update needs order + H = 26 values: the first update is
    // the one ending at x[25], then every value in order up to the origin.
    let x = ramp(120);
    let mut spy = RampSpy::new(20, 6, 0.0, true);
    let scores = score_forecasts(&mut spy, &x, 10, 1, None, &|_| {}).unwrap();
    assert_eq!(scores.origins, (30..=114).count());
    assert_eq!(spy.updates, 113 - 25 + 1);
}

pub(super) fn settings(train: usize, noise_pct: f64) -> EvalSettings {
    EvalSettings {
        train,
        stride: 1,
        sample_rate: 2.0,
        noise_pct,
        seed: 3,
        average: Averaging::NONE,
    }
}

pub(super) fn config(order: usize, horizon: usize) -> PredictorConfig {
    PredictorConfig {
        order,
        horizon,
        ..PredictorConfig::default()
    }
}

fn wave(len: usize) -> Vec<f64> {
    (0..len)
        .map(|i| (i as f64 * 0.31).sin() + 0.5 * (i as f64 * 0.113).cos())
        .collect()
}

#[test]
fn baselines_match_an_independent_computation_with_and_without_noise() {
    let clean = wave(400);
    let (order, horizon, train) = (30, 8, 150);
    for noise in [0.0, 20.0] {
        let prepared = prepare_series(&clean, Dof::Heave, &settings(train, noise)).unwrap();
        let x = &prepared.series;
        assert_eq!(prepared.clean.is_some(), noise > 0.0);
        let s = settings(train, noise);
        let zero = evaluate_method(
            &prepared,
            Dof::Heave,
            Method::Zero,
            &config(order, horizon),
            &s,
            &|_| {},
        )
        .unwrap();
        let persistence = evaluate_method(
            &prepared,
            Dof::Heave,
            Method::Persistence,
            &config(order, horizon),
            &s,
            &|_| {},
        )
        .unwrap();
        let origins: Vec<usize> = (train + order..=x.len() - horizon).collect();
        assert_eq!(zero.origins, origins.len());
        let test = &x[train..];
        let mean = test.iter().sum::<f64>() / test.len() as f64;
        let std = (test.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / test.len() as f64).sqrt();
        for h in 1..=horizon {
            let rms_of = |f: &dyn Fn(usize) -> f64| {
                (origins.iter().map(|&o| f(o).powi(2)).sum::<f64>() / origins.len() as f64).sqrt()
            };
            let zero_rms = rms_of(&|o| x[o + h - 1]);
            let pers_rms = rms_of(&|o| x[o - 1] - x[o + h - 1]);
            assert!((zero.rms[h - 1] - zero_rms).abs() < 1e-12);
            assert!((zero.nrmse[h - 1] - zero_rms / std).abs() < 1e-12);
            assert!((persistence.rms[h - 1] - pers_rms).abs() < 1e-12);
            assert_eq!(persistence.rms, persistence.persistence_rms);
            assert_eq!(zero.persistence_rms, persistence.persistence_rms);
            match &zero.rms_clean {
                Some(rms_clean) => {
                    let clean_rms = rms_of(&|o| clean[o + h - 1]);
                    assert!((rms_clean[h - 1] - clean_rms).abs() < 1e-12);
                    assert!((rms_clean[h - 1] - zero.rms[h - 1]).abs() > 1e-6);
                }
                None => assert_eq!(noise, 0.0),
            }
        }
    }
}

fn record(len: usize) -> MotionData {
    MotionData {
        ignored: Vec::new(),
        time: (0..len).map(|i| i as f64 * 0.5).collect(),
        columns: vec![
            Column {
                name: "heave_m".into(),
                values: wave(len),
            },
            Column {
                name: "pitch_rad".into(),
                values: wave(len).iter().map(|v| 0.01 * v).collect(),
            },
        ],
    }
}

#[test]
fn failing_methods_become_entries_and_bad_input_stops_everything() {
    let data = record(300);
    let methods = [Method::Persistence, Method::Mca, Method::Zero];
    // Horizon = order: infeasible for MCA, fine for the baselines.
    let cfg = config(10, 10);
    let mut seen = Vec::new();
    let entries = evaluate_record(
        &data,
        &[Dof::Heave, Dof::Pitch],
        &methods,
        &cfg,
        &settings(100, 0.0),
        &|_| {},
        &mut |e| seen.push((e.dof(), e.method())),
    )
    .unwrap();
    assert_eq!(entries.len(), 6);
    assert_eq!(seen.len(), 6);
    for entry in &entries {
        match (entry.method(), entry) {
            (Method::Mca, Entry::Failed(f)) => assert!(!f.error.is_empty()),
            (Method::Mca, Entry::Done(_)) => panic!("MCA with H = order must fail"),
            (_, Entry::Done(r)) => assert_eq!(r.origins, (110..=290).count()),
            (m, Entry::Failed(f)) => panic!("{m} failed: {}", f.error),
        }
    }
    let absent = evaluate_record(
        &data,
        &[Dof::Roll],
        &methods,
        &cfg,
        &settings(100, 0.0),
        &|_| {},
        &mut |_| {},
    );
    assert!(absent.unwrap_err().to_string().contains("roll_rad"));
    let short = evaluate_record(
        &data,
        &[Dof::Heave],
        &methods,
        &config(200, 10),
        &settings(100, 0.0),
        &|_| {},
        &mut |_| {},
    );
    assert!(matches!(
        short,
        Err(RecordError::Eval(EvalError::TooShort { .. }))
    ));
    let noise = evaluate_record(
        &data,
        &[Dof::Heave],
        &methods,
        &cfg,
        &settings(100, -5.0),
        &|_| {},
        &mut |_| {},
    );
    assert!(matches!(
        noise,
        Err(RecordError::Eval(EvalError::BadNoise(_)))
    ));
}

#[test]
fn json_record_has_the_contract_fields() {
    let data = record(200);
    let entries = evaluate_record(
        &data,
        &[Dof::Heave],
        &[Method::Zero],
        &config(20, 4),
        &settings(100, 10.0),
        &|_| {},
        &mut |_| {},
    )
    .unwrap();
    let json = serde_json::to_value(&entries[0]).unwrap();
    for field in [
        "dof",
        "method",
        "order",
        "horizon",
        "train",
        "sample_rate",
        "origins",
        "rms",
        "nrmse",
        "persistence_rms",
        "rms_clean",
        "train_seconds",
        "predict_seconds",
    ] {
        assert!(json.get(field).is_some(), "missing {field}: {json}");
    }
    assert_eq!(json["dof"], "heave");
    assert_eq!(json["method"], "zero");
    assert_eq!(json["rms"].as_array().unwrap().len(), 4);
    let back: Entry = serde_json::from_value(json).unwrap();
    assert_eq!(back, entries[0]);
}
