//! Criterion benchmarks of the pieces on the sample -> forecast hot path: the decimation step
//! (six DOF, 8 -> 2 Hz), the six-DOF MCA-800 forecast, writing the Forecast payload (and sending
//! it over iceoryx2), encoding a forecast as zenoh JSON, and the predictor's optional receive
//! stamp.
//!
//! Run: `cargo bench --bench hot_path`.

use criterion::{criterion_group, criterion_main, Criterion};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use shipcast_bench::machine::remove_iox_leftovers;
use shipcast_bench::stamps::{ReceiveStamp, StampPublisher, StampReader, StampTally};
use shipcast_pipeline::config::PipelineConfig;
use shipcast_pipeline::transport::iox::{self, IoxPublisher, IoxSubscriber, Sizing, WaitMode};
use shipcast_pipeline::transport::Names;
use shipcast_predict::{McaPredictor, Predictor, PredictorConfig};
use shipcast_series::decimator::Decimator;
use shipcast_wire::payload::{Forecast, MotionSample, MAX_STEPS, NUM_DOF};
use shipcast_wire::payload_json::ForecastJsonEncoder;
use std::hint::black_box;

/// A ship-motion-like test series: a few incommensurate swell components plus noise, so the MCA
/// training matrix is well conditioned.
fn series(len: usize, seed: u64) -> Vec<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let comps: Vec<(f64, f64, f64)> = (0..12)
        .map(|_| {
            (
                rng.random_range(0.3..1.2),
                rng.random_range(0.1..1.0),
                rng.random_range(0.0..std::f64::consts::TAU),
            )
        })
        .collect();
    (0..len)
        .map(|i| {
            let t = i as f64 * 0.5;
            let swell: f64 = comps.iter().map(|(w, a, p)| a * (w * t + p).sin()).sum();
            swell + 0.01 * rng.random_range(-1.0..1.0)
        })
        .collect()
}

fn decimation_step(c: &mut Criterion) {
    let mut decimators: Vec<Decimator> = (0..NUM_DOF)
        .map(|_| Decimator::new(4).expect("factor 4 is valid"))
        .collect();
    let input = series(4096, 1);
    let mut i = 0usize;
    c.bench_function("decimation_step/six_dof_one_sample_8_to_2_hz", |b| {
        b.iter(|| {
            let x = input[i % input.len()];
            i += 1;
            for d in decimators.iter_mut() {
                black_box(d.push(black_box(x)));
            }
        })
    });
}

fn six_dof_forecast(c: &mut Criterion) {
    let mut group = c.benchmark_group("six_dof_forecast");
    // The paper's setting (order 800, horizon 50) and the predictor service's default (order
    // 400 with eigenvalue weighting, horizon 50).
    let service = PipelineConfig::default().predictor.predictor_config();
    for (name, config) in [
        ("mca800_h50", PredictorConfig::default()),
        ("service_default_mca400_h50", service),
    ] {
        let train = series(3000, 2);
        let mut models: Vec<McaPredictor> = (0..NUM_DOF)
            .map(|d| {
                let mut m = McaPredictor::new(&config).expect("MCA config is feasible");
                m.fit(&series(3000, 10 + d as u64))
                    .expect("MCA fits the test series");
                m
            })
            .collect();
        let past = &train[train.len() - config.order..];
        let mut out = vec![0.0; config.horizon];
        group.bench_function(format!("{name}_f64"), |b| {
            b.iter(|| {
                for m in models.iter_mut() {
                    m.forecast(black_box(past), &mut out)
                        .expect("buffers sized");
                }
                black_box(&out);
            })
        });
        group.bench_function(format!("{name}_f32"), |b| {
            b.iter(|| {
                for m in models.iter_mut() {
                    m.forecast_f32(black_box(past), &mut out)
                        .expect("buffers sized");
                }
                black_box(&out);
            })
        });
    }
    group.finish();
}

fn filled_forecast(steps: usize) -> Forecast {
    let mut f = Forecast {
        steps: steps as u32,
        dt_s: 0.5,
        ..Forecast::default()
    };
    for d in 0..NUM_DOF {
        for k in 0..steps {
            f.mean[d][k] = (0.1 * (d * MAX_STEPS + k) as f32).sin();
            f.sigma[d][k] = 0.05 + 0.001 * k as f32;
        }
    }
    f
}

fn payload_write(c: &mut Criterion) {
    let steps = PredictorConfig::default().horizon;
    let predictions: Vec<Vec<f64>> = (0..NUM_DOF).map(|d| series(steps, 20 + d as u64)).collect();
    let mut forecast = Forecast::default();
    let mut group = c.benchmark_group("payload_write");
    group.bench_function("fill_forecast_six_dof", |b| {
        b.iter(|| {
            forecast.seq += 1;
            forecast.steps = steps as u32;
            for (row, pred) in forecast.mean.iter_mut().zip(&predictions) {
                for (dst, src) in row.iter_mut().zip(black_box(pred)) {
                    *dst = *src as f32;
                }
            }
            black_box(&forecast);
        })
    });
    let instance = shipcast_pipeline::transport::unique_instance("bench-hot");
    let names = Names::new(Some(&instance), "bench").expect("valid bench names");
    let node = iox::node(&names, "hot-path").expect("iceoryx2 node");
    let publisher = IoxPublisher::<Forecast>::new(&node, &names.forecast(), Sizing::FORECAST)
        .expect("forecast publisher");
    let subscriber = IoxSubscriber::<Forecast>::new(
        &node,
        &names.forecast(),
        Sizing::FORECAST,
        WaitMode::BusyPoll,
    )
    .expect("forecast subscriber");
    let f = filled_forecast(steps);
    group.bench_function("iox_send_and_receive_forecast", |b| {
        b.iter(|| {
            publisher.send(black_box(&f)).expect("send");
            black_box(subscriber.receive().expect("receive"));
        })
    });
    let mpub = IoxPublisher::<MotionSample>::new(&node, &names.motion(), Sizing::MOTION)
        .expect("motion publisher");
    let msub = IoxSubscriber::<MotionSample>::new(
        &node,
        &names.motion(),
        Sizing::MOTION,
        WaitMode::BusyPoll,
    )
    .expect("motion subscriber");
    let m = MotionSample::default();
    group.bench_function("iox_send_and_receive_motion", |b| {
        b.iter(|| {
            mpub.send(black_box(&m)).expect("send");
            black_box(msub.receive().expect("receive"));
        })
    });
    // What `shipcast predictor --bench-stamps` adds per received sample (no notification).
    let stamp_name = names.bench_receive();
    let stamps = StampPublisher::new(&node, &stamp_name).expect("stamp publisher");
    let reader = StampReader::new(&node, &stamp_name).expect("stamp reader");
    let mut tally = StampTally::new(0);
    let mut sent = 0u32;
    group.bench_function("receive_stamp_send", |b| {
        b.iter(|| {
            stamps
                .send(black_box(ReceiveStamp::default()))
                .expect("send");
            // The benchmark's reader drains every 20 ms: about 20 stamps at 1 kHz.
            sent += 1;
            if sent % 32 == 0 {
                reader.drain(&mut tally).expect("drain");
            }
        });
    });
    group.finish();
    drop((publisher, subscriber, mpub, msub, stamps, reader, node));
    remove_iox_leftovers(&names.iox_prefix());
}

fn json_encoding(c: &mut Criterion) {
    let f = filled_forecast(PredictorConfig::default().horizon);
    let mut buf = Vec::with_capacity(16 * 1024);
    c.bench_function("json_encoding/forecast_50_steps", |b| {
        b.iter(|| {
            black_box(&f).write_json(&mut buf).expect("encode");
            black_box(buf.len());
        })
    });
}

/// The same forecast through the hand-written encoder: reused, so its sigma cache is warm
/// (`_encoder`), and with the sigma changing at every call, so it always formats both arrays
/// (`_encoder_cold`).
fn json_encoder(c: &mut Criterion) {
    let f = filled_forecast(PredictorConfig::default().horizon);
    let mut encoder = ForecastJsonEncoder::new();
    c.bench_function("json_encoding/forecast_50_steps_encoder", |b| {
        b.iter(|| black_box(encoder.encode(black_box(&f)).len()))
    });
    let mut g = f;
    for row in g.sigma.iter_mut() {
        for s in row.iter_mut() {
            *s *= 1.5;
        }
    }
    let alternating = [f, g];
    let mut i = 0usize;
    c.bench_function("json_encoding/forecast_50_steps_encoder_cold", |b| {
        b.iter(|| {
            i += 1;
            black_box(encoder.encode(black_box(&alternating[i % 2])).len())
        })
    });
}

criterion_group!(
    benches,
    decimation_step,
    six_dof_forecast,
    payload_write,
    json_encoding,
    json_encoder
);
criterion_main!(benches);
