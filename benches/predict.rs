//! Criterion benchmarks of the predictors: MCA-800 training on 5000 points, and one 50-step
//! forecast per method and order (40, 100, 800), with the MCA forecast in three variants
//! (`forecast` as the services run it: the same origin each iteration, so the product of the
//! known values is the one prepared ahead and only the newest value's column and a
//! comparison are timed; f64 plain loop and f32 matrix: the full product), and the
//! six-DOF MCA-800 forecast in full (`six_dof_forecast_in_full`: six predictors, a new origin
//! every iteration). MCA-800 training against numpy: `cargo bench --bench mca_vs_numpy`.
//!
//! Run: `cargo bench --bench predict` (a few minutes). The paper's MATLAB figures for MCA-800
//! on a 1.6 GHz Pentium: training 40 s, 500 predictions 0.09 s (180 us each).

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use shipcast_predict::{
    AnyPredictor, McaPredictor, Method, PredictError, Predictor, PredictorConfig,
};
use std::hint::black_box;
use std::time::Duration;

#[path = "support/sea.rs"]
mod support_sea;
use support_sea::sea;

const TRAIN: usize = 5000;
const HORIZON: usize = 50;
const ORDERS: [usize; 3] = [40, 100, 800];

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

type ForecastFn = fn(&mut McaPredictor, &[f64], &mut [f64]) -> Result<(), PredictError>;

/// The six-DOF MCA-800 forecast in full: six fitted predictors, each computing its whole 50-step
/// forecast from 750 past values. Every iteration moves the forecast origin one value on, as a
/// new sample does, so no part of the product can be reused from the iteration before (the
/// services' `prepare` would do that; this measures the cost without it).
fn six_dof_forecasts(c: &mut Criterion) {
    const DOF: usize = 6;
    const ORDER: usize = 800;
    let records: Vec<Vec<f64>> = (0..DOF).map(|d| sea(TRAIN + 2000, 10 + d as u64)).collect();
    let fit = |record: &[f64]| {
        let mut p = McaPredictor::new(&config(ORDER)).expect("MCA-800 config is feasible");
        p.fit(&record[..TRAIN]).expect("fit");
        p
    };
    let mut models: Vec<McaPredictor> = records.iter().map(|r| fit(r)).collect();
    let mut outs = vec![[0.0; HORIZON]; DOF];
    let mut group = c.benchmark_group("six_dof_forecast_in_full");
    group.sample_size(50);
    group.warm_up_time(Duration::from_millis(500));
    group.measurement_time(Duration::from_secs(3));
    let variants: [(&str, ForecastFn); 2] = [
        // What the services run: f64 arithmetic, reading the f32 copy of the coefficients
        // where that provably moves the forecast by at most 1e-5 of the largest input
        // (`linear_map::MIXED_MAX_ROUNDING`; these well-conditioned maps pass).
        ("mca_800_forecast", |m, past, out| m.forecast(past, out)),
        ("mca_800_f32", McaPredictor::forecast_f32),
    ];
    let origins = TRAIN..TRAIN + 1000;
    let mut origin = origins.start;
    for (name, forecast) in variants {
        group.bench_function(name, |b| {
            b.iter(|| {
                origin = if origin + 1 < origins.end {
                    origin + 1
                } else {
                    origins.start
                };
                for ((m, r), out) in models.iter_mut().zip(&records).zip(&mut outs) {
                    forecast(m, black_box(&r[origin - ORDER..origin]), out).expect("forecast");
                }
                black_box(&outs);
            })
        });
    }
    group.finish();
}

criterion_group!(benches, mca_training, forecasts, six_dof_forecasts);
criterion_main!(benches);
