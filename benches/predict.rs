//! Criterion benchmarks of the predictors: MCA-800 training on 5000 points, and one 50-step
//! forecast per method and order (40, 100, 800), with the MCA forecast in three variants
//! (f64 faer matrix-vector product as used by `forecast`, f64 plain loop, f32 matrix).
//!
//! Run: `cargo bench --bench predict` (a few minutes). The paper's MATLAB figures for MCA-800
//! on a 1.6 GHz Pentium: training 40 s, 500 predictions 0.09 s (180 us each).

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use shipcast_predict::{AnyPredictor, McaPredictor, Method, Predictor, PredictorConfig};
use std::hint::black_box;
use std::time::Duration;

const TRAIN: usize = 5000;
const HORIZON: usize = 50;
const ORDERS: [usize; 3] = [40, 100, 800];

/// A dense, seeded sea-like record at 2 Hz: 300 wave components with random frequencies in the
/// band of ship motion (periods 5-20 s), a spectrum peaked near 10 s, random phases.
fn sea(len: usize, seed: u64) -> Vec<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let components: Vec<(f64, f64, f64)> = (0..300)
        .map(|_| {
            let omega: f64 = rng.random_range(0.31..1.26);
            let peak = 2.0 * std::f64::consts::PI / 10.0;
            let amplitude = 0.1 * (-((omega - peak) / 0.15).powi(2)).exp();
            (
                omega,
                amplitude,
                rng.random_range(0.0..std::f64::consts::TAU),
            )
        })
        .collect();
    (0..len)
        .map(|i| {
            let t = i as f64 * 0.5;
            components
                .iter()
                .map(|&(w, a, p)| a * (w * t + p).sin())
                .sum()
        })
        .collect()
}

fn config(order: usize) -> PredictorConfig {
    PredictorConfig {
        order,
        horizon: HORIZON,
        // Forecast cost does not depend on how well the network is trained: one epoch keeps
        // the set-up of MLP-800 short.
        mlp_epochs: 1,
        ..PredictorConfig::default()
    }
}

fn mca_training(c: &mut Criterion) {
    let x = sea(TRAIN, 1);
    let mut group = c.benchmark_group("train");
    group.sample_size(10);
    group.measurement_time(Duration::from_secs(5));
    let mut p = McaPredictor::new(&config(800)).expect("MCA-800 config is feasible");
    group.bench_function("mca_800_on_5000", |b| {
        b.iter(|| p.fit(black_box(&x)).expect("fit"))
    });
    // The predictor service retrains in the background; on one core it must not starve the
    // forecasting thread, so the single-threaded figure matters too.
    let parallelism = faer::get_global_parallelism();
    faer::set_global_parallelism(faer::Par::Seq);
    group.bench_function("mca_800_on_5000_one_thread", |b| {
        b.iter(|| p.fit(black_box(&x)).expect("fit"))
    });
    faer::set_global_parallelism(parallelism);
    group.finish();
}

fn forecasts(c: &mut Criterion) {
    let x = sea(TRAIN + 1000, 2);
    let mut group = c.benchmark_group("forecast_50_steps");
    group.sample_size(30);
    group.warm_up_time(Duration::from_millis(500));
    group.measurement_time(Duration::from_secs(2));
    let mut out = vec![0.0; HORIZON];
    for order in ORDERS {
        let past = &x[TRAIN + 200 - order..TRAIN + 200];
        for method in [
            Method::Mca,
            Method::Wiener,
            Method::Ar,
            Method::Mlp,
            Method::Persistence,
        ] {
            let mut p = match AnyPredictor::new(method, &config(order)) {
                Ok(p) => p,
                // MCA-40 cannot forecast 50 steps (horizon >= order).
                Err(e) => {
                    eprintln!("skip {method}-{order}: {e}");
                    continue;
                }
            };
            p.fit(&x[..TRAIN]).expect("fit");
            group.bench_with_input(BenchmarkId::new(method.name(), order), past, |b, past| {
                b.iter(|| p.forecast(black_box(past), &mut out).expect("forecast"))
            });
        }
        if let Ok(mut mca) = McaPredictor::new(&config(order)) {
            mca.fit(&x[..TRAIN]).expect("fit");
            group.bench_with_input(BenchmarkId::new("mca_f32", order), past, |b, past| {
                b.iter(|| {
                    mca.forecast_f32(black_box(past), &mut out)
                        .expect("forecast")
                })
            });
            let map = mca.prediction_matrix().expect("fitted").clone();
            let x1 = &past[order - map.cols()..];
            group.bench_with_input(BenchmarkId::new("mca_plain_loop", order), x1, |b, x1| {
                b.iter(|| map.apply_loop(black_box(x1), &mut out))
            });
        }
    }
    group.finish();
}

criterion_group!(benches, mca_training, forecasts);
criterion_main!(benches);
