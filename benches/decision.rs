//! Criterion benchmark of one deck decision from a full error ensemble (600 verified paths of
//! 50 steps, each with its standardised means): `Decider::decide`, which loads the forecast's
//! tracks, counts every member's broken steps (after regressing the errors on the mean) and
//! finds the window probability now and the next window. The deck service makes one per
//! forecast (2 Hz).
//!
//! Run: `cargo bench --bench decision`.

use criterion::{criterion_group, criterion_main, Criterion};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use shipcast_pipeline::config::DeckConfig;
use shipcast_pipeline::decision::{ensemble, Decider, NUM_QUANTITIES};
use shipcast_wire::payload::{Forecast, MAX_STEPS};
use std::hint::black_box;

const STEPS: usize = 50;

/// A 25 s forecast of a gentle roll and pitch with sigma growing with lead.
fn forecast(phase: f64) -> Forecast {
    let mut f = Forecast {
        time_s: 100.0,
        dt_s: 0.5,
        steps: STEPS as u32,
        ..Forecast::default()
    };
    for k in 0..STEPS {
        let t = (k + 1) as f64 * 0.5;
        let s = 0.2 + 0.03 * k as f64;
        // heave, roll, pitch (m, rad, rad)
        f.mean[2][k] = (0.3 * (0.6 * t + phase).sin()) as f32;
        f.mean[3][k] = (1.0f64.to_radians() * (0.55 * t + phase).sin()) as f32;
        f.mean[4][k] = (0.5f64.to_radians() * (0.6 * t + phase).cos()) as f32;
        f.sigma[2][k] = (0.1 * s) as f32;
        f.sigma[3][k] = (0.4f64.to_radians() * s) as f32;
        f.sigma[4][k] = (0.2f64.to_radians() * s) as f32;
    }
    f
}

fn full_decider() -> Decider {
    let mut decider = Decider::new(&DeckConfig::default());
    let normal = Normal::new(0.0, 1.0).expect("unit normal");
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let mut u = [[0.0; MAX_STEPS]; NUM_QUANTITIES];
    let mut z = [[0.0; MAX_STEPS]; NUM_QUANTITIES];
    for _ in 0..ensemble::DEFAULT_CAPACITY * ensemble::DEFAULT_STRIDE {
        for q in 0..NUM_QUANTITIES {
            for k in 0..STEPS {
                z[q][k] = normal.sample(&mut rng);
                u[q][k] = 0.1 * z[q][k] + normal.sample(&mut rng);
            }
        }
        decider.add_verified(&u, &z, STEPS);
    }
    decider
}

fn decide(c: &mut Criterion) {
    let mut decider = full_decider();
    let forecasts: Vec<Forecast> = (0..16).map(|i| forecast(i as f64 * 0.4)).collect();
    let mut i = 0;
    c.bench_function("deck decision, full ensemble (600 paths, 50 steps)", |b| {
        b.iter(|| {
            i = (i + 1) % forecasts.len();
            black_box(decider.decide(black_box(&forecasts[i])))
        })
    });
}

criterion_group!(benches, decide);
criterion_main!(benches);
