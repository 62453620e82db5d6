//! Tests of the MCA predictor: analytic cases, an independent reference implementation, the
//! options and the error paths.

use super::*;
use crate::conformance::{noisy_oscillation, nrmse_over_test, sum_of_sinusoids};
use crate::AnyPredictor;
use faer::linalg::solvers::Solve;
use faer::{Mat, Side};

fn config(order: usize, horizon: usize) -> PredictorConfig {
    PredictorConfig {
        order,
        horizon,
        ..PredictorConfig::default()
    }
}

fn fitted(config: &PredictorConfig, train: &[f64]) -> McaPredictor {
    let mut p = McaPredictor::new(config).unwrap();
    p.fit(train).unwrap();
    p
}

fn assert_same_matrix(a: &McaPredictor, b: &McaPredictor) {
    assert_eq!(
        a.prediction_matrix().unwrap().coefficients(),
        b.prediction_matrix().unwrap().coefficients()
    );
}

fn frobenius(map: &LinearMap) -> f64 {
    map.coefficients().iter().map(|c| c * c).sum::<f64>().sqrt()
}

#[test]
fn mca_800_predicts_sinusoids_50_steps() {
    let x = sum_of_sinusoids(5000 + 1000);
    let mut p = fitted(&config(800, 50), &x[..5000]);
    let nrmse = nrmse_over_test(&mut p, &x, 5000, 25);
    assert!(nrmse < 1e-3, "MCA-800 nrmse {nrmse}");
}

#[test]
fn minor_components_of_three_sinusoids_are_the_null_space() {
    // Windows of three sinusoids span exactly six dimensions; the other 34 eigenvalues are
    // zero up to rounding, so a tiny energy threshold keeps exactly those.
    let x = sum_of_sinusoids(2000);
    let tiny = PredictorConfig {
        mca_energy: 1e-9,
        ..config(40, 10)
    };
    let d = fitted(&tiny, &x).diagnostics();
    assert_eq!(d.minor_components, Some(34));
    assert_eq!(d.energy, Some(1e-9));
    // The paper's threshold adds the weakest signal directions on top of the null space.
    let d = fitted(&config(40, 10), &x).diagnostics();
    assert!(d.minor_components.unwrap() >= 34, "{d:?}");
}

#[test]
fn at_least_horizon_minor_components_are_used() {
    // With energy 0 only exactly-zero eigenvalues would qualify; noise leaves none.
    let x = noisy_oscillation(1000, 11);
    let p = fitted(
        &PredictorConfig {
            mca_energy: 0.0,
            ..config(30, 8)
        },
        &x,
    );
    assert_eq!(p.diagnostics().minor_components, Some(8));
}

/// R = sum x x^T over the windows of length `n` starting every `shift` values, by explicit loops.
fn window_correlation(x: &[f64], n: usize, shift: usize) -> Mat<f64> {
    let mut r = Mat::<f64>::zeros(n, n);
    let mut start = 0;
    while start + n <= x.len() {
        let w = &x[start..start + n];
        for i in 0..n {
            for j in 0..n {
                r[(i, j)] += w[i] * w[j];
            }
        }
        start += shift;
    }
    r
}

/// Independent path: R by explicit loops, faer's eigen-decomposition,
/// the energy rule written out, B2^T B2 and B2^T B1 by loops, a dense LU solve.
fn reference_prediction(x: &[f64], n: usize, h: usize, shift: usize, energy: f64) -> Vec<Vec<f64>> {
    let r = window_correlation(x, n, shift);
    let evd = r.self_adjoint_eigen(Side::Lower).unwrap();
    let values: Vec<f64> = (0..n).map(|i| evd.S()[i]).collect();
    let trace: f64 = (0..n).map(|i| r[(i, i)]).sum();
    let mut k = 0;
    let mut sum = 0.0;
    while k < n && sum + values[k] <= energy * trace {
        sum += values[k];
        k += 1;
    }
    let k = k.max(h);
    let u = evd.U();
    let n1 = n - h;
    // b[c][i] = i-th entry of minor eigenvector c (B has these as rows).
    let b: Vec<Vec<f64>> = (0..k)
        .map(|c| (0..n).map(|i| u[(i, c)]).collect())
        .collect();
    let gram = Mat::from_fn(h, h, |i, j| {
        (0..k).map(|c| b[c][n1 + i] * b[c][n1 + j]).sum::<f64>()
    });
    let rhs = Mat::from_fn(h, n1, |i, j| {
        -(0..k).map(|c| b[c][n1 + i] * b[c][j]).sum::<f64>()
    });
    let p = gram.partial_piv_lu().solve(&rhs);
    (0..h)
        .map(|i| (0..n1).map(|j| p[(i, j)]).collect())
        .collect()
}

/// Largest |P - reference| relative to the reference's largest entry.
fn relative_distance(map: &LinearMap, reference: &[Vec<f64>]) -> f64 {
    let scale = reference
        .iter()
        .flatten()
        .fold(0.0f64, |m, v| m.max(v.abs()));
    let mut worst = 0.0f64;
    for (i, row) in reference.iter().enumerate() {
        for (got, want) in map.row(i).iter().zip(row) {
            worst = worst.max((got - want).abs());
        }
    }
    worst / scale
}

/// The paper's P for each energy equals `reference_prediction`'s.
fn assert_matches_reference(x: &[f64], n: usize, h: usize, shift: usize, energies: &[f64]) {
    for &energy in energies {
        let p = fitted(
            &PredictorConfig {
                mca_shift: shift,
                mca_energy: energy,
                ..config(n, h)
            },
            x,
        );
        let reference = reference_prediction(x, n, h, shift, energy);
        let distance = relative_distance(p.prediction_matrix().unwrap(), &reference);
        assert!(distance <= 1e-6, "energy {energy}: P off by {distance:e}");
    }
}

#[test]
fn agrees_with_reference_implementation() {
    assert_matches_reference(&noisy_oscillation(400, 12), 20, 5, 3, &[0.015, 0.1]);
}

#[test]
fn fewer_windows_than_the_order_agree_with_the_full_decomposition() {
    // 49 windows of 60 values: R has rank 49, the fit goes through the QR of the windows
    // instead of the 60 x 60 eigen-decomposition the reference takes.
    let (n, h, shift) = (60, 10, 5);
    let x = noisy_oscillation(300, 22);
    assert!((x.len() - n) / shift + 1 < n);
    assert_matches_reference(&x, n, h, shift, &[0.015, 0.1, 0.5]);
    for ridge in [1e-3, 0.1] {
        let p = fitted(&inverse(n, h, shift, ridge), &x);
        let want = conditional_mean(&x, n, h, shift, ridge);
        let reference: Vec<Vec<f64>> = (0..h)
            .map(|i| (0..n - h).map(|j| want[(i, j)]).collect())
            .collect();
        let distance = relative_distance(p.prediction_matrix().unwrap(), &reference);
        assert!(distance <= 1e-6, "ridge {ridge}: P off by {distance:e}");
        assert_eq!(p.diagnostics().minor_components, Some(n));
    }
}

#[test]
fn horizon_at_or_beyond_order_is_infeasible() {
    for (order, horizon) in [(10, 10), (10, 11), (1, 1)] {
        let err = McaPredictor::new(&config(order, horizon)).unwrap_err();
        assert!(matches!(err, PredictError::Infeasible(_)), "{err}");
        assert!(err.to_string().contains("horizon < order"), "{err}");
        let err = AnyPredictor::new(Method::Mca, &config(order, horizon)).unwrap_err();
        assert!(matches!(err, PredictError::Infeasible(_)), "{err}");
    }
}

#[test]
fn bad_options_are_infeasible() {
    let bad = [
        PredictorConfig {
            mca_shift: 0,
            ..config(20, 5)
        },
        PredictorConfig {
            mca_energy: 1.0,
            ..config(20, 5)
        },
        PredictorConfig {
            mca_energy: f64::NAN,
            ..config(20, 5)
        },
        PredictorConfig {
            mca_ridge: -0.1,
            ..config(20, 5)
        },
    ];
    for c in bad {
        assert!(
            matches!(McaPredictor::new(&c), Err(PredictError::Infeasible(_))),
            "{c:?} accepted"
        );
    }
}

#[test]
fn ridge_shrinks_the_prediction_matrix() {
    let x = noisy_oscillation(1000, 13);
    let plain = fitted(&config(30, 6), &x);
    let ridged = fitted(
        &PredictorConfig {
            mca_ridge: 0.1,
            ..config(30, 6)
        },
        &x,
    );
    // (G + l I)^-2 <= G^-2 for G positive definite, so ||P||_F can only shrink.
    let (a, b) = (
        frobenius(plain.prediction_matrix().unwrap()),
        frobenius(ridged.prediction_matrix().unwrap()),
    );
    assert!(b < a, "ridge {b} vs plain {a}");
    assert_eq!(
        ridged.diagnostics().minor_components,
        plain.diagnostics().minor_components
    );
}

#[test]
fn validated_energy_is_from_the_grid_and_refits_on_everything() {
    let x = noisy_oscillation(1500, 14);
    let validated = fitted(
        &PredictorConfig {
            mca_validate_energy: true,
            ..config(40, 10)
        },
        &x,
    );
    let energy = validated.diagnostics().energy.unwrap();
    assert!(ENERGY_GRID.contains(&energy), "chose {energy}");
    // The final model is the plain fit on the whole segment with the chosen threshold.
    let plain = fitted(
        &PredictorConfig {
            mca_energy: energy,
            ..config(40, 10)
        },
        &x,
    );
    assert_same_matrix(&validated, &plain);
}

#[test]
fn validation_needs_room_for_a_held_out_forecast() {
    let needed = validation_needed(40, 10);
    assert!(needed - needed / 5 >= 40 && needed / 5 >= 10);
    assert!((needed - 1) - (needed - 1) / 5 < 40 || (needed - 1) / 5 < 10);
    let mut p = McaPredictor::new(&PredictorConfig {
        mca_validate_energy: true,
        ..config(40, 10)
    })
    .unwrap();
    let x = noisy_oscillation(needed, 15);
    let err = p.fit(&x[..needed - 1]).unwrap_err();
    assert!(
        matches!(err, PredictError::TooShort { needed: n, .. } if n == needed),
        "{err}"
    );
    p.fit(&x).unwrap();
}

#[test]
fn f32_forecast_is_close_to_f64() {
    let x = noisy_oscillation(2000, 16);
    let mut p = fitted(&config(100, 20), &x[..1500]);
    let (mut a, mut b) = ([0.0; 20], [0.0; 20]);
    p.forecast(&x[..1700], &mut a).unwrap();
    p.forecast_f32(&x[..1700], &mut b).unwrap();
    let scale = a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for (u, v) in a.iter().zip(&b) {
        assert!((u - v).abs() <= 1e-4 * scale, "{u} vs {v}");
    }
    let mut unfitted = McaPredictor::new(&config(100, 20)).unwrap();
    assert_eq!(
        unfitted.forecast_f32(&x[..100], &mut b),
        Err(PredictError::NotFitted(Method::Mca))
    );
}

#[test]
fn forecast_uses_only_the_last_past_len_values() {
    // The first `horizon` of the `order` values handed in are outside the MCA past window.
    let x = noisy_oscillation(600, 17);
    let mut p = fitted(&config(20, 5), &x);
    let mut window = x[500..520].to_vec();
    let (mut a, mut b) = ([0.0; 5], [0.0; 5]);
    p.forecast(&window, &mut a).unwrap();
    window[..5].fill(1e6);
    p.forecast(&window, &mut b).unwrap();
    assert_eq!(a, b);
    assert_eq!(p.past_len(), 15);
}

fn inverse(order: usize, horizon: usize, shift: usize, ridge: f64) -> PredictorConfig {
    PredictorConfig {
        mca_weighting: McaWeighting::Inverse,
        mca_shift: shift,
        mca_ridge: ridge,
        ..config(order, horizon)
    }
}

/// Independent path for inverse weighting: R by explicit loops, then the conditional mean
/// P = R21 (R11 + eps I)^-1 by a dense LU solve of (R11 + eps I) P^T = R12, with
/// eps = ridge * trace / n (the mean eigenvalue).
fn conditional_mean(x: &[f64], n: usize, h: usize, shift: usize, ridge: f64) -> Mat<f64> {
    let r = window_correlation(x, n, shift);
    let n1 = n - h;
    let eps = ridge * (0..n).map(|i| r[(i, i)]).sum::<f64>() / n as f64;
    let r11 = Mat::from_fn(n1, n1, |i, j| r[(i, j)] + if i == j { eps } else { 0.0 });
    let r12 = Mat::from_fn(n1, h, |i, j| r[(i, n1 + j)]);
    r11.partial_piv_lu().solve(&r12).transpose().to_owned()
}

#[test]
fn inverse_weighting_is_the_conditional_mean_of_the_sample_covariance() {
    let (n, h, shift) = (20, 5, 2);
    let x = noisy_oscillation(800, 18);
    // A tiny ridge: the exact R21 R11^-1; a large one: exactly the ridge-regularised version.
    for ridge in [1e-12, 0.1] {
        let p = fitted(&inverse(n, h, shift, ridge), &x);
        let want = conditional_mean(&x, n, h, shift, ridge);
        let map = p.prediction_matrix().unwrap();
        let scale = (0..h)
            .flat_map(|i| (0..n - h).map(move |j| (i, j)))
            .fold(0.0f64, |m, (i, j)| m.max(want[(i, j)].abs()));
        for i in 0..h {
            for (j, got) in map.row(i).iter().enumerate() {
                let w = want[(i, j)];
                assert!(
                    (got - w).abs() <= 1e-6 * scale,
                    "ridge {ridge}: P[{i}][{j}] = {got}, conditional mean {w}"
                );
            }
        }
        let d = p.diagnostics();
        assert_eq!(d.mca_weighting, Some(McaWeighting::Inverse));
        assert_eq!(d.ridge, Some(ridge));
        assert_eq!(d.minor_components, Some(n), "every eigenvector is used");
        assert_eq!(d.energy, None, "no energy threshold");
    }
}

#[test]
fn inverse_weighting_extrapolates_sinusoids_despite_a_rank_deficient_r() {
    // Three sinusoids span six of the 200 dimensions: the default ridge keeps the null space
    // from deciding the forecast, and the prediction stays nearly exact.
    let x = sum_of_sinusoids(3000 + 1000);
    let mut p = fitted(&inverse(200, 50, 10, 0.0), &x[..3000]);
    assert_eq!(p.diagnostics().ridge, Some(INVERSE_DEFAULT_RIDGE));
    let nrmse = nrmse_over_test(&mut p, &x, 3000, 25);
    assert!(nrmse < 1e-3, "inverse MCA-200 nrmse {nrmse}");
}

#[test]
fn an_all_zero_series_predicts_zero() {
    // Shift 1: 81 windows of 20 (full decomposition); shift 10: 9 windows (through the QR).
    for shift in [1, 10] {
        for weighting in [McaWeighting::Inverse, McaWeighting::Paper] {
            let c = PredictorConfig {
                mca_weighting: weighting,
                ..inverse(20, 5, shift, 0.0)
            };
            let p = fitted(&c, &[0.0; 100]);
            assert!(
                p.prediction_matrix()
                    .unwrap()
                    .coefficients()
                    .iter()
                    .all(|&c| c == 0.0),
                "{weighting} shift {shift}"
            );
        }
    }
}

#[test]
fn paper_weighting_is_the_default_and_reported() {
    assert_eq!(
        PredictorConfig::default().mca_weighting,
        McaWeighting::Paper
    );
    let d = fitted(&config(20, 5), &noisy_oscillation(300, 19)).diagnostics();
    assert_eq!(d.mca_weighting, Some(McaWeighting::Paper));
    assert_eq!(d.ridge, Some(0.0));
    assert!(d.minor_components.unwrap() < 20, "{d:?}");
}

#[test]
fn weighting_names_parse_and_round_trip() {
    for w in [McaWeighting::Paper, McaWeighting::Inverse] {
        assert_eq!(w.to_string().parse::<McaWeighting>(), Ok(w));
        let json = serde_json::to_string(&w).unwrap();
        assert_eq!(json, format!("\"{}\"", w.name()));
    }
    assert_eq!(
        " Inverse ".parse::<McaWeighting>(),
        Ok(McaWeighting::Inverse)
    );
    let err = "inverted".parse::<McaWeighting>().unwrap_err();
    assert!(err.contains("expected paper or inverse"), "{err}");
    let c: PredictorConfig = serde_json::from_str(r#"{"mca_weighting":"inverse"}"#).unwrap();
    assert_eq!(c.mca_weighting, McaWeighting::Inverse);
    assert!(serde_json::from_str::<PredictorConfig>(r#"{"mca_weighting":"minor"}"#).is_err());
}

#[test]
fn model_files_without_weighting_load_as_the_paper_method() {
    let x = noisy_oscillation(300, 20);
    let p = fitted(&inverse(20, 5, 1, 0.0), &x);
    let mut json: serde_json::Value = serde_json::to_value(&p).unwrap();
    assert_eq!(json["weighting"], "inverse");
    json.as_object_mut().unwrap().remove("weighting");
    let old: McaPredictor = serde_json::from_value(json).unwrap();
    assert_eq!(old.weighting, McaWeighting::Paper);
    // The fitted matrix is kept as stored.
    assert_same_matrix(&old, &p);
}

#[test]
fn validation_with_inverse_weighting_chooses_the_ridge_and_refits_on_everything() {
    let x = noisy_oscillation(1500, 21);
    let validated = fitted(
        &PredictorConfig {
            mca_validate_energy: true,
            ..inverse(40, 10, 1, 0.0)
        },
        &x,
    );
    let ridge = validated.diagnostics().ridge.unwrap();
    assert!(RIDGE_GRID.contains(&ridge), "chose {ridge}");
    let plain = fitted(&inverse(40, 10, 1, ridge), &x);
    assert_same_matrix(&validated, &plain);
}

/// Regression (review): windows (a, a, b) have a minor direction (1, -1, 0) with no future
/// part. MCA solved P = -(M22 + ridge)^-1 M21 from an M22 of 1e-34, ridge included (it is
/// relative to M22), and forecast with gains of 1e16. It must refuse the fit instead.
#[test]
fn a_projector_without_a_future_part_is_refused_not_solved() {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(21);
    let mut x = Vec::new();
    for _ in 0..1000 {
        let a: f64 = rng.random::<f64>() - 0.5;
        x.extend([a, a, rng.random::<f64>() - 0.5]);
    }
    for ridge in [0.0, 0.1] {
        let mut p = McaPredictor::new(&PredictorConfig {
            mca_shift: 3,
            mca_energy: 1e-4,
            mca_ridge: ridge,
            ..config(3, 1)
        })
        .unwrap();
        let err = p.fit(&x).unwrap_err().to_string();
        assert!(err.contains("no future part"), "ridge {ridge}: {err}");
    }
}
