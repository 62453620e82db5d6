//! Criterion benchmarks of the pieces on the sample -> forecast hot path: the decimation step
//! (six DOF, 8 -> 2 Hz), the six-DOF MCA-800 forecast, writing the Forecast payload (and sending
//! it over iceoryx2), encoding a forecast as zenoh JSON, and the predictor's optional receive
//! stamp; and, first, the whole forecast path of the service's engine ([`forecast_path`]):
//! p50/p99 and allocations of each step, and the JSON encoders on the engine's own forecasts.
//!
//! Run: `cargo bench --bench hot_path` (`-- json_encoding` for the encoders only; the
//! forecast-path table is printed by every run).

use criterion::{criterion_group, criterion_main, Criterion};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use shipcast_bench::pipeline::{backfill_s, backfilled_engine, motion_record};
use shipcast_bench::stamps::{ReceiveStamp, StampPublisher, StampReader, StampTally};
use shipcast_bench::LatencyRecorder;
use shipcast_pipeline::config::PipelineConfig;
use shipcast_pipeline::transport::iox::remove_leftovers;
use shipcast_pipeline::transport::iox::{self, IoxPublisher, IoxSubscriber, Sizing, WaitMode};
use shipcast_pipeline::transport::monotonic_ns;
use shipcast_pipeline::transport::zenoh::{
    free_loopback_endpoint, open, JsonPublisher, ZenohSettings,
};
use shipcast_pipeline::transport::Names;
use shipcast_predict::alloc_count::{counted, CountingAllocator};
use shipcast_predict::{McaPredictor, Predictor, PredictorConfig};
use shipcast_series::decimator::Decimator;
use shipcast_wire::payload::{Forecast, MotionSample, MAX_STEPS, NUM_DOF};
use shipcast_wire::payload_json::ForecastJsonEncoder;
use std::hint::black_box;

#[global_allocator]
static ALLOCATOR: CountingAllocator = CountingAllocator;

/// Duration [ns] and allocations of `f` on this thread.
fn measured<T>(f: impl FnOnce() -> T) -> (T, u64, u64) {
    let t = monotonic_ns();
    let (out, allocations) = counted(f);
    (out, monotonic_ns() - t, allocations)
}

/// One step of the forecast path: its durations and allocations per forecast.
#[derive(Default)]
struct StepTally {
    latency: LatencyRecorder,
    allocations: u64,
}

impl StepTally {
    fn add(&mut self, ns: u64, allocations: u64) {
        self.latency.record_ns(ns);
        self.allocations += allocations;
    }

    fn line(&self, name: &str) -> String {
        let n = self.latency.count().max(1);
        format!(
            "{name:<44} {:>7} {:>9.2} {:>9.2} {:>12.2}",
            self.latency.count(),
            self.latency.quantile_us(0.5),
            self.latency.quantile_us(0.99),
            self.allocations as f64 / n as f64
        )
    }
}

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
    // The paper's setting (order 800, horizon 50) and the MCA settings of the predictor
    // service's configuration (order 200 with eigenvalue weighting, horizon 50; the service
    // runs them with `method = "mca"`, its default being Wiener). `_f64` repeats one origin,
    // so it times the service's arrival path (the known values' product prepared ahead, the
    // newest value's column added); `_f32` computes the full product every time.
    let service = PipelineConfig::default().predictor.predictor_config();
    for (name, config) in [
        ("mca800_h50", PredictorConfig::default()),
        ("service_mca_settings_h50", service),
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

/// A forecast publisher and a busy-polling subscriber of the same service.
fn forecast_ports(
    node: &iceoryx2::prelude::Node<iox::Ipc>,
    names: &Names,
) -> (IoxPublisher<Forecast>, IoxSubscriber<Forecast>) {
    let publisher = IoxPublisher::<Forecast>::new(node, &names.forecast(), Sizing::FORECAST)
        .expect("forecast publisher");
    let subscriber = IoxSubscriber::<Forecast>::new(
        node,
        &names.forecast(),
        Sizing::FORECAST,
        WaitMode::BusyPoll,
    )
    .expect("forecast subscriber");
    (publisher, subscriber)
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
    let (publisher, subscriber) = forecast_ports(&node, &names);
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
            if sent.is_multiple_of(32) {
                reader.drain(&mut tally).expect("drain");
            }
        });
    });
    group.finish();
    drop((publisher, subscriber, mpub, msub, stamps, reader, node));
    remove_leftovers(&names.iox_prefix());
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

/// Forecasts of the service's own engine (default configuration, retraining off, as the
/// latency bench's services rows), each step of publishing them timed and its allocations
/// counted on this thread: the engine step that completes a forecast, the iceoryx2 send of the
/// payload, the JSON encoding, and the zenoh put to a peer on 127.0.0.1 (the JSON's buffer
/// shared with zenoh, and, for comparison, copied into zenoh's as before); then the encoding
/// of the same forecasts under criterion.
fn forecast_path(c: &mut Criterion) {
    const FORECASTS: u64 = 4000;
    let mut config = PipelineConfig::default();
    config.predictor.retrain_every_s = 0.0;
    let rate = config.producer.rate_hz;
    let backfill = (backfill_s(&config.predictor) * rate).round() as u64;
    let record = motion_record(&config, backfill + 4 * FORECASTS + 8).expect("simulated sea");
    let mut engine = backfilled_engine(&config, &record, backfill).expect("engine");

    let instance = format!("bench-path-{}", std::process::id());
    let names = Names::new(Some(&instance), "bench").expect("valid bench names");
    let node = iox::node(&names, "forecast-path").expect("iceoryx2 node");
    let (publisher, subscriber) = forecast_ports(&node, &names);
    let endpoint = free_loopback_endpoint().expect("free port");
    let listener = open(&ZenohSettings::listen_on(&endpoint)).expect("zenoh listener");
    let connector = open(&ZenohSettings::connect_to(&endpoint)).expect("zenoh connector");
    let key = names.forecast();
    let sub = shipcast_pipeline::transport::zenoh::LatestSubscriber::new(&connector, &key)
        .expect("zenoh subscriber");
    let remote = JsonPublisher::new(&listener, &key).expect("zenoh publisher");
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(10);
    while !remote.has_subscribers() && std::time::Instant::now() < deadline {
        std::thread::sleep(std::time::Duration::from_millis(10));
    }

    let mut json = ForecastJsonEncoder::new();
    let mut steps: [StepTally; 6] = Default::default();
    let mut reused = Vec::with_capacity(16 * 1024);
    let mut forecasts = Vec::with_capacity(FORECASTS as usize);
    for (seq, dof) in (backfill..).zip(&record[backfill as usize..]) {
        let sample = MotionSample {
            seq,
            stamp_ns: monotonic_ns(),
            time_s: seq as f64 / rate,
            dof: *dof,
        };
        let (pushed, ns, n) = measured(|| engine.push(&sample).expect("push").is_some());
        if !pushed {
            engine.prepare_next().expect("prepare");
            engine.poll_models();
            continue;
        }
        steps[0].add(ns, n);
        let f = *engine.forecast();
        let (_, ns, n) = measured(|| publisher.send(&f).expect("send"));
        steps[1].add(ns, n);
        let (bytes, ns, n) = measured(|| json.encode_shared(&f).expect("encode"));
        steps[2].add(ns, n);
        let (_, ns, n) = measured(|| f.write_json(&mut reused).expect("encode"));
        steps[5].add(ns, n);
        let (_, ns, n) = measured(|| remote.put_shared(bytes).expect("put"));
        steps[3].add(ns, n);
        // As before: the JSON copied into a buffer of zenoh's, the same bytes once more.
        let (_, ns, n) = measured(|| remote.put(json.encode(&f).expect("encode")).expect("put"));
        steps[4].add(ns, n);
        engine.poll_models();
        while subscriber.receive().expect("receive").is_some() {}
        while sub.latest().expect("receive").is_some() {}
        forecasts.push(f);
        if forecasts.len() as u64 == FORECASTS {
            break;
        }
    }
    println!(
        "\nforecast path of the engine, {} forecasts (one every 4 samples; µs):\n{:<44} {:>7} {:>9} {:>9} {:>12}",
        forecasts.len(),
        "step",
        "count",
        "p50",
        "p99",
        "allocs/fcst"
    );
    for (tally, name) in steps.iter().zip([
        "engine step completing a forecast",
        "iceoryx2 send (loan, write, notify)",
        "JSON encoding (serde_json, shared buffer)",
        "zenoh put, buffer shared (put_shared)",
        "zenoh put, JSON copied (put)",
        "JSON encoding (serde_json, reused Vec)",
    ]) {
        println!("{}", tally.line(name));
    }
    drop((publisher, subscriber, sub, remote, node));
    drop((listener, connector));
    remove_leftovers(&names.iox_prefix());

    // The encoder on the engine's own forecasts, in order (the text copied nowhere).
    let mut i = 0usize;
    c.bench_function("json_encoding/engine_forecasts_shared_buffer", |b| {
        b.iter(|| {
            i += 1;
            black_box(json.encode_shared(black_box(&forecasts[i % forecasts.len()])))
        })
    });
}

criterion_group!(
    benches,
    forecast_path,
    decimation_step,
    six_dof_forecast,
    payload_write,
    json_encoding
);
criterion_main!(benches);
