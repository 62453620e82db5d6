//! The conformance suite every method in `Method::ALL` passes, run through `AnyPredictor`, plus
//! the signals and scoring helpers the per-method tests share.
//!
//! Built for this crate's own tests and, behind the `conformance` feature, for any crate that
//! wants to run it (e.g. on a new method): [`check_all`] runs every check on one method and
//! panics with the method's name and what failed. The allocation check needs
//! [`CountingAllocator`] installed as the test binary's global allocator:
//!
//! ```text
//! #[global_allocator]
//! static ALLOCATOR: shipcast_predict::conformance::CountingAllocator =
//!     shipcast_predict::conformance::CountingAllocator;
//! ```
//!
//! Orders are small (40 past values, 10 steps) so the slower methods (MLP) keep the suite fast.

use super::{AnyPredictor, Method, PredictError, Predictor, PredictorConfig};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

pub use crate::alloc_count::{counted, CountingAllocator};

/// Whether [`CountingAllocator`] is this binary's global allocator (else nothing is counted).
pub fn counting_allocator_installed() -> bool {
    allocations_during(|| {
        std::hint::black_box(Box::new(0u64));
    }) > 0
}

/// Allocations made by this thread while running `f`; always 0 unless
/// [`CountingAllocator`] is installed.
pub fn allocations_during(f: impl FnOnce()) -> usize {
    counted(f).1 as usize
}

// ---------------------------------------------------------------------------------------------
// Signals and scoring.

/// Sample rate of the test signals [Hz], the evaluation rate of docs/contracts.md section 4.
pub const RATE_HZ: f64 = 2.0;

/// Amplitude, period [s] and phase [rad] of the lines of `sum_of_sinusoids`.
pub const LINES: [(f64, f64, f64); 3] = [(1.0, 7.0, 0.3), (0.6, 10.3, 1.1), (0.3, 14.1, 2.0)];

/// Three sinusoids with wave-like periods (7, 10.3 and 14.1 s) sampled at 2 Hz: a line
/// spectrum, which any linear predictor with enough past values extrapolates exactly.
pub fn sum_of_sinusoids(len: usize) -> Vec<f64> {
    (0..len)
        .map(|i| {
            let t = i as f64 / RATE_HZ;
            LINES
                .iter()
                .map(|&(amp, period, phase)| {
                    amp * (2.0 * std::f64::consts::PI * t / period + phase).sin()
                })
                .sum()
        })
        .collect()
}

/// A resonant AR(2) process (period about 10 s at 2 Hz) driven by seeded Gaussian noise, plus a
/// little measurement noise, scaled to unit standard deviation (ship-motion magnitudes, so the
/// paper's LMS gain is stable): a dense spectrum with distinct eigenvalues.
pub fn noisy_oscillation(len: usize, seed: u64) -> Vec<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let normal = Normal::new(0.0, 1.0).expect("unit normal is valid");
    let (radius, angle) = (0.97f64, 2.0 * std::f64::consts::PI / 20.0);
    let (a1, a2) = (2.0 * radius * angle.cos(), -radius * radius);
    let (mut x1, mut x2) = (0.0, 0.0);
    let mut out = Vec::with_capacity(len);
    for _ in 0..len + 200 {
        let x = a1 * x1 + a2 * x2 + normal.sample(&mut rng);
        x2 = x1;
        x1 = x;
        out.push(x + 0.1 * normal.sample(&mut rng));
    }
    // Drop the start-up transient.
    let mut out = out.split_off(200);
    let rms = (out.iter().map(|v| v * v).sum::<f64>() / len.max(1) as f64).sqrt();
    out.iter_mut().for_each(|v| *v /= rms);
    out
}

/// Run the evaluation protocol of docs/contracts.md section 4 on `x` with training length
/// `train_len` (the predictor is already fitted): forecasts at origins `train_len + order`, then
/// every `stride` values; online methods learn from every value as it is observed. Returns the
/// RMS error over all steps and origins.
pub fn rms_over_test(p: &mut impl Predictor, x: &[f64], train_len: usize, stride: usize) -> f64 {
    let (order, horizon) = (p.order(), p.horizon());
    let mut forecast = vec![0.0; horizon];
    let (mut sum, mut count) = (0.0, 0usize);
    let first = train_len + order;
    for origin in train_len + 1..=x.len() {
        if p.is_online() {
            p.update(&x[..origin]).expect("update");
        }
        if origin < first || !(origin - first).is_multiple_of(stride) || origin + horizon > x.len()
        {
            continue;
        }
        p.forecast(&x[origin - order..origin], &mut forecast)
            .expect("forecast");
        for (f, v) in forecast.iter().zip(&x[origin..origin + horizon]) {
            sum += (f - v) * (f - v);
        }
        count += horizon;
    }
    assert!(count > 0, "test segment too short for one forecast");
    (sum / count as f64).sqrt()
}

/// `rms_over_test` divided by the standard deviation of the test segment.
pub fn nrmse_over_test(p: &mut impl Predictor, x: &[f64], train_len: usize, stride: usize) -> f64 {
    let test = &x[train_len..];
    let mean = test.iter().sum::<f64>() / test.len() as f64;
    let var = test.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / test.len() as f64;
    rms_over_test(p, x, train_len, stride) / var.sqrt()
}

// ---------------------------------------------------------------------------------------------
// The suite.

const ORDER: usize = 40;
const HORIZON: usize = 10;
const TRAIN: usize = 1500;

fn config() -> PredictorConfig {
    PredictorConfig {
        order: ORDER,
        horizon: HORIZON,
        mlp_epochs: 100,
        // Plain LMS at the paper's gain 0.005 diverges on `noisy_oscillation` (power about 90,
        // stability needs gain < 2/(order*power) = 5e-4) and says so; NLMS is stable for any
        // signal power.
        lms_normalized: true,
        lms_gain: 0.1,
        ..PredictorConfig::default()
    }
}

/// Methods that learn from the training data (every one but the baselines).
fn learns(method: Method) -> bool {
    !matches!(method, Method::Persistence | Method::Zero)
}

fn fitted(method: Method, config: &PredictorConfig, train: &[f64]) -> AnyPredictor {
    let mut p =
        AnyPredictor::new(method, config).unwrap_or_else(|e| panic!("{method}: cannot build: {e}"));
    p.fit(train)
        .unwrap_or_else(|e| panic!("{method}: fit failed: {e}"));
    p
}

pub fn reports_its_shape_and_writes_exactly_horizon_steps(
    method: Method,
    config: &PredictorConfig,
) {
    let x = noisy_oscillation(TRAIN + 100, 1);
    let mut p = fitted(method, config, &x[..TRAIN]);
    assert_eq!(p.method(), method);
    assert_eq!(p.order(), ORDER, "{method}");
    assert_eq!(p.horizon(), HORIZON, "{method}");
    // A longer past and a longer output are fine: only the last `order` values are used
    // and only the first `horizon` slots are written.
    let mut out = vec![f64::NAN; HORIZON + 3];
    p.forecast(&x[..TRAIN + 50], &mut out).unwrap();
    assert!(
        out[..HORIZON].iter().all(|v| v.is_finite()),
        "{method}: {out:?}"
    );
    assert!(
        out[HORIZON..].iter().all(|v| v.is_nan()),
        "{method} wrote past horizon"
    );
    let mut exact = vec![0.0; HORIZON];
    p.forecast(&x[TRAIN + 50 - ORDER..TRAIN + 50], &mut exact)
        .unwrap();
    assert_eq!(
        &exact[..],
        &out[..HORIZON],
        "{method} used more than `order` values"
    );
}

pub fn forecast_and_update_never_allocate(method: Method, config: &PredictorConfig) {
    let x = noisy_oscillation(TRAIN + 100, 2);
    let mut p = fitted(method, config, &x[..TRAIN]);
    let mut out = vec![0.0; HORIZON];
    let allocations = allocations_during(|| {
        for end in TRAIN..TRAIN + 20 {
            p.update(&x[..end]).unwrap();
            p.forecast(&x[end - ORDER..end], &mut out).unwrap();
            p.prepare(&x[..end]).unwrap();
        }
    });
    assert_eq!(
        allocations, 0,
        "{method} allocated in forecast/update/prepare"
    );
}

pub fn prepared_forecasts_are_bit_identical_to_unprepared_ones(
    method: Method,
    config: &PredictorConfig,
) {
    let x = noisy_oscillation(TRAIN + 100, 7);
    let mut plain = fitted(method, config, &x[..TRAIN]);
    let mut prepared = fitted(method, config, &x[..TRAIN]);
    let (mut a, mut b) = (vec![0.0; HORIZON], vec![0.0; HORIZON]);
    for end in TRAIN + 1..TRAIN + 60 {
        plain.update(&x[..end]).unwrap();
        prepared.update(&x[..end]).unwrap();
        plain.forecast(&x[..end], &mut a).unwrap();
        prepared.forecast(&x[..end], &mut b).unwrap();
        let bits = |v: &[f64]| v.iter().map(|f| f.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&a), bits(&b), "{method} at {end}");
        // Ready for the next value (every third time for a history that will not come).
        let known = if end % 3 == 0 {
            &x[..end - 1]
        } else {
            &x[..end]
        };
        prepared.prepare(known).unwrap();
    }
}

pub fn same_config_and_seed_give_identical_forecasts(method: Method, config: &PredictorConfig) {
    let x = noisy_oscillation(TRAIN + 100, 3);
    let mut a = fitted(method, config, &x[..TRAIN]);
    let mut b = fitted(method, config, &x[..TRAIN]);
    let (mut fa, mut fb) = (vec![0.0; HORIZON], vec![0.0; HORIZON]);
    for end in [TRAIN, TRAIN + 37, TRAIN + 100] {
        a.forecast(&x[..end], &mut fa).unwrap();
        b.forecast(&x[..end], &mut fb).unwrap();
        assert_eq!(fa, fb, "{method} is not deterministic");
    }
}

pub fn too_short_or_non_finite_training_is_a_clear_error(method: Method, config: &PredictorConfig) {
    let x = noisy_oscillation(TRAIN, 4);
    let mut p = AnyPredictor::new(method, config).unwrap();
    let err = p.fit(&[]).unwrap_err();
    assert!(
        matches!(err, PredictError::TooShort { got: 0, .. }),
        "{method}: {err}"
    );
    if !learns(method) {
        return;
    }
    let err = p.fit(&x[..ORDER - 1]).unwrap_err();
    match &err {
        PredictError::TooShort {
            method: m,
            order,
            needed,
            got,
        } => {
            assert_eq!((*m, *order, *got), (method, ORDER, ORDER - 1));
            assert!(*needed >= ORDER, "{method}: {err}");
        }
        other => panic!("{method}: expected TooShort, got {other}"),
    }
    assert!(
        err.to_string().contains("too short"),
        "{method}: message '{err}'"
    );
    let mut bad = x.clone();
    bad[TRAIN / 2] = f64::NAN;
    assert!(
        matches!(p.fit(&bad), Err(PredictError::NonFinite(_))),
        "{method} accepted NaN in training"
    );
}

pub fn too_short_buffers_and_unfitted_use_are_errors(method: Method, config: &PredictorConfig) {
    let x = noisy_oscillation(TRAIN, 5);
    let mut out = vec![0.0; HORIZON];
    if learns(method) {
        let mut unfitted = AnyPredictor::new(method, config).unwrap();
        assert_eq!(
            unfitted.forecast(&x[..ORDER], &mut out),
            Err(PredictError::NotFitted(method)),
            "{method}"
        );
    }
    let mut p = fitted(method, config, &x);
    let err = p.forecast(&x[..ORDER - 1], &mut out).unwrap_err();
    assert!(matches!(err, PredictError::Length(_)), "{method}: {err}");
    let err = p
        .forecast(&x[..ORDER], &mut out[..HORIZON - 1])
        .unwrap_err();
    assert!(matches!(err, PredictError::Length(_)), "{method}: {err}");
}

pub fn saved_and_loaded_models_forecast_identically(method: Method, config: &PredictorConfig) {
    let x = noisy_oscillation(TRAIN + 100, 6);
    let mut p = fitted(method, config, &x[..TRAIN]);
    let json = serde_json::to_string(&p).unwrap();
    let mut loaded: AnyPredictor = serde_json::from_str(&json)
        .unwrap_or_else(|e| panic!("{method}: cannot load its own model: {e}"));
    assert_eq!(loaded.method(), method);
    assert_eq!(loaded.diagnostics(), p.diagnostics(), "{method}");
    let (mut a, mut b) = (vec![0.0; HORIZON], vec![0.0; HORIZON]);
    for end in [TRAIN, TRAIN + 61] {
        p.forecast(&x[..end], &mut a).unwrap();
        loaded.forecast(&x[..end], &mut b).unwrap();
        assert_eq!(
            a, b,
            "{method} forecasts differently after a JSON round trip"
        );
    }
}

pub fn learning_methods_beat_the_zero_predictor_on_sinusoids(
    method: Method,
    config: &PredictorConfig,
) {
    if !learns(method) {
        return;
    }
    let x = sum_of_sinusoids(TRAIN + 400);
    let mut zero = fitted(Method::Zero, config, &x[..TRAIN]);
    let zero_rms = rms_over_test(&mut zero, &x, TRAIN, 5);
    let mut p = fitted(method, config, &x[..TRAIN]);
    let rms = rms_over_test(&mut p, &x, TRAIN, 5);
    assert!(
        rms < zero_rms,
        "{method}: rms {rms} vs zero predictor {zero_rms}"
    );
}

/// Every check of the suite on `method` with the suite's configuration; panics with the method
/// and the check that failed.
pub fn check_all(method: Method) {
    check_all_with(method, &config());
}

/// Every check of the suite on `method` with `config` (the suite's with a method's own option
/// changed, e.g. how a Wiener fit estimates its weights).
pub fn check_all_with(method: Method, config: &PredictorConfig) {
    assert!(
        counting_allocator_installed(),
        "conformance: install shipcast_predict::conformance::CountingAllocator as the \
         #[global_allocator] of the test binary (the allocation check needs it)"
    );
    reports_its_shape_and_writes_exactly_horizon_steps(method, config);
    forecast_and_update_never_allocate(method, config);
    prepared_forecasts_are_bit_identical_to_unprepared_ones(method, config);
    same_config_and_seed_give_identical_forecasts(method, config);
    too_short_or_non_finite_training_is_a_clear_error(method, config);
    too_short_buffers_and_unfitted_use_are_errors(method, config);
    saved_and_loaded_models_forecast_identically(method, config);
    learning_methods_beat_the_zero_predictor_on_sinusoids(method, config);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_allocation_counter_sees_allocations_on_this_thread_only() {
        let n = allocations_during(|| {
            std::hint::black_box(vec![1u8; 16]);
        });
        assert_eq!(n, 1, "one allocation (frees are not counted)");
        // Another thread allocating while this one waits must not count here.
        let barrier = std::sync::Barrier::new(2);
        std::thread::scope(|s| {
            s.spawn(|| {
                barrier.wait();
                for len in 1..100 {
                    std::hint::black_box(vec![0u64; len]);
                }
                barrier.wait();
            });
            let n = allocations_during(|| {
                barrier.wait();
                barrier.wait();
            });
            assert_eq!(n, 0, "allocations of another thread were counted");
        });
    }

    /// One test per method, so the methods run in parallel; the match fails to compile when a
    /// method is added without its test. A compile-time check, not a test: a test calling it
    /// could not fail (test-quality review).
    const _: fn(Method) -> fn() = conformance_test_exists;
    fn conformance_test_exists(method: Method) -> fn() {
        match method {
            Method::Mca => mca_conforms,
            Method::Wiener => wiener_conforms,
            Method::Ar => ar_conforms,
            Method::Mlp => mlp_conforms,
            Method::Persistence => persistence_conforms,
            Method::Zero => zero_conforms,
        }
    }

    #[test]
    fn mca_conforms() {
        check_all(Method::Mca);
    }
    #[test]
    fn wiener_conforms() {
        check_all(Method::Wiener);
    }
    /// The Wiener predictor fitted the way `fit` says.
    fn wiener_fitted_by(fit: crate::WienerFit) {
        let config = PredictorConfig {
            wiener_fit: fit,
            ..config()
        };
        check_all_with(Method::Wiener, &config);
    }
    #[test]
    fn wiener_least_squares_conforms() {
        wiener_fitted_by(crate::WienerFit::LeastSquares);
    }
    #[test]
    fn wiener_guarded_conforms() {
        wiener_fitted_by(crate::WienerFit::Guarded);
    }
    /// MCA as the predictor service runs it by default (`[predictor.mca]`: eigenvalue-weighted,
    /// window shift 2, ridge validated on held-out training data), not only the paper's rule.
    #[test]
    fn mca_as_the_service_runs_it_conforms() {
        let config = PredictorConfig {
            mca_weighting: crate::McaWeighting::Inverse,
            mca_shift: 2,
            mca_validate_energy: true,
            ..config()
        };
        check_all_with(Method::Mca, &config);
    }
    #[test]
    fn ar_conforms() {
        check_all(Method::Ar);
    }
    #[test]
    fn mlp_conforms() {
        check_all(Method::Mlp);
    }
    #[test]
    fn persistence_conforms() {
        check_all(Method::Persistence);
    }
    #[test]
    fn zero_conforms() {
        check_all(Method::Zero);
    }
}
