//! Criterion benchmarks of the simulator: building the `paper` sea (1200 components, closed-form
//! RAOs), one streamed 8 Hz sample of all seven channels, one direct `sample_at`, and the exact
//! autocorrelation of one DOF over 1600 lags.
//!
//! Run: `cargo bench --bench sim`.

use criterion::{criterion_group, criterion_main, Criterion};
use shipcast_sim::{ShipMotion, SimConfig};
use shipcast_wire::Dof;
use std::hint::black_box;

fn bench_sim(c: &mut Criterion) {
    let cfg = SimConfig::default();
    c.bench_function("sim/build_paper_sea", |b| {
        b.iter(|| ShipMotion::new(black_box(&cfg)).expect("paper scenario builds"))
    });
    let motion = ShipMotion::new(&cfg).expect("paper scenario builds");
    let mut stream = motion.stream(8.0, 0.0).expect("valid rate");
    c.bench_function("sim/stream_next_sample", |b| {
        b.iter(|| black_box(stream.next()))
    });
    let mut t = 0.0;
    c.bench_function("sim/sample_at", |b| {
        b.iter(|| {
            t += 0.125;
            black_box(motion.sample_at(black_box(t)))
        })
    });
    c.bench_function("sim/autocorrelation_1600_lags", |b| {
        b.iter(|| black_box(motion.autocorrelation(Dof::Heave, 0.125, 1600)))
    });
}

criterion_group!(benches, bench_sim);
criterion_main!(benches);
