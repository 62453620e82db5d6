//! The engine end to end on records with known statistics (through `replay`, which drives it
//! exactly as the service does, with retraining inline), by theme; the shared records and
//! helpers are here.

use super::replay::{replay, DofReplay};
use super::retrain::Retrainer;
use super::Engine;
use crate::config::PredictorServiceConfig;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use shipcast_series::motion_csv::{Column, MotionData};
use shipcast_wire::payload::MotionSample;

/// A resonant AR(2) process at 2 Hz (period 8 s, pole radius 0.95), innovations N(0, scale^2).
fn ar2(n: usize, seed: u64, scale: impl Fn(usize) -> f64) -> Vec<f64> {
    let theta = std::f64::consts::TAU / 16.0;
    let (a1, a2) = (2.0 * 0.95 * theta.cos(), -0.95 * 0.95);
    let noise = Normal::new(0.0, 1.0).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut x = vec![0.0; n];
    for t in 2..n {
        x[t] = a1 * x[t - 1] + a2 * x[t - 2] + scale(t) * noise.sample(&mut rng);
    }
    x
}

/// The root mean square of `values` (the std of a zero-mean process).
fn rms(values: &[f64]) -> f64 {
    (values.iter().map(|x| x * x).sum::<f64>() / values.len() as f64).sqrt()
}

fn record(heave: Vec<f64>, rate: f64) -> MotionData {
    MotionData {
        ignored: Vec::new(),
        time: (0..heave.len()).map(|i| i as f64 / rate).collect(),
        columns: vec![Column {
            name: "heave_m".into(),
            values: heave,
        }],
    }
}

/// An engine at 2 Hz whose start-up models were fitted on 6000 values of `ar2(seed)` in every
/// DOF, retraining inline as `config` says.
fn engine_fitted_on_ar2(config: &PredictorServiceConfig, seed: u64) -> Engine {
    let clean = ar2(6000, seed, |_| 1.0);
    let models = super::models::fit(&vec![clean; 6], config, 1).unwrap();
    Engine::new(
        config.clone(),
        2.0,
        Some(models),
        Retrainer::inline(config.clone()),
    )
    .unwrap()
}

/// Sample `i` of a 2 Hz record with the six DOF values `dof`.
fn at_2hz(i: usize, dof: [f64; 6]) -> MotionSample {
    MotionSample {
        seq: i as u64,
        stamp_ns: 0,
        time_s: i as f64 / 2.0,
        dof,
    }
}

/// Sample `i` of a 2 Hz record that moves in heave alone, by `h`.
fn heave_only(i: usize, h: f64) -> MotionSample {
    at_2hz(i, [0.0, 0.0, h, 0.0, 0.0, 0.0])
}

fn run(data: &MotionData, skip_s: f64) -> DofReplay {
    let config = PredictorServiceConfig::default();
    let (report, _) = replay(data, &config, None, skip_s, false, &|_| {}).unwrap();
    assert_eq!(report.dofs.len(), 1);
    report.dofs.into_iter().next().unwrap()
}

mod level;
mod records;
mod retrains;
mod sea_change;
mod sigma;
