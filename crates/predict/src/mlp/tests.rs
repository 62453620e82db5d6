//! Behaviour only. Speed is measured elsewhere: one forecast per method and order by
//! `cargo bench --bench predict`; training and forecast times by `shipcast eval --json`
//! (`train_seconds`, `predict_seconds`) and `shipcast paper` (Table 2).

use super::*;

fn config(order: usize, horizon: usize, hidden: usize, epochs: usize) -> PredictorConfig {
    PredictorConfig {
        order,
        horizon,
        mlp_hidden: hidden,
        mlp_epochs: epochs,
        ..PredictorConfig::default()
    }
}

/// Two wave-like lines at 2 Hz, in metres.
fn sines(len: usize) -> Vec<f64> {
    (0..len)
        .map(|t| {
            let t = t as f64 / 2.0;
            1.5 * (std::f64::consts::TAU * t / 9.0).sin()
                + 0.7 * (std::f64::consts::TAU * t / 13.7 + 1.0).sin()
        })
        .collect()
}

/// RMS error over all steps of forecasts from every 3rd origin after `train_len`.
fn test_rms(p: &mut MlpPredictor, x: &[f64], train_len: usize) -> f64 {
    let (order, horizon) = (p.order(), p.horizon());
    let mut out = vec![0.0; horizon];
    let (mut sum, mut count) = (0.0, 0);
    for origin in (train_len + order..=x.len() - horizon).step_by(3) {
        p.forecast(&x[..origin], &mut out).unwrap();
        for (f, v) in out.iter().zip(&x[origin..origin + horizon]) {
            sum += (f - v).powi(2);
            count += 1;
        }
    }
    (sum / count as f64).sqrt()
}

#[test]
fn fits_a_sum_of_sinusoids_much_better_than_zero() {
    let x = sines(1800);
    let train_len = 1200;
    let mut p = MlpPredictor::new(&config(30, 10, 100, 300)).unwrap();
    p.fit(&x[..train_len]).unwrap();
    let rms = test_rms(&mut p, &x, train_len);
    let zero_rms =
        (x[train_len..].iter().map(|v| v * v).sum::<f64>() / (x.len() - train_len) as f64).sqrt();
    assert!(rms < 0.05 * zero_rms, "MLP rms {rms} vs zero {zero_rms}");
}

#[test]
fn training_lowers_the_loss() {
    let x = sines(600);
    let fitted_loss = |epochs| {
        let mut p = MlpPredictor::new(&config(20, 5, 16, epochs)).unwrap();
        p.fit(&x).unwrap();
        p.final_loss().unwrap()
    };
    let (first, trained) = (fitted_loss(1), fitted_loss(200));
    assert!(
        trained < 0.01 * first,
        "loss {first} after 1 epoch, {trained} after 200"
    );
}

#[test]
fn same_seed_same_network_other_seed_other_network() {
    let x = sines(500);
    let fit = |seed| {
        let mut p = MlpPredictor::new(&PredictorConfig {
            seed,
            ..config(20, 5, 8, 30)
        })
        .unwrap();
        p.fit(&x).unwrap();
        p
    };
    let (a, b, c) = (fit(7), fit(7), fit(8));
    assert_eq!(a.params, b.params);
    assert_ne!(a.params, c.params);
}

#[test]
fn forecast_scales_back_to_the_units_of_the_data() {
    // The same signal in millimetres instead of metres gives the same forecast times 1000:
    // the network works in units of the training standard deviation.
    let metres = sines(500);
    let millimetres: Vec<f64> = metres.iter().map(|v| v * 1000.0).collect();
    let forecast = |x: &[f64]| {
        let mut p = MlpPredictor::new(&config(20, 5, 8, 40)).unwrap();
        p.fit(&x[..400]).unwrap();
        let mut out = vec![0.0; 5];
        p.forecast(&x[..450], &mut out).unwrap();
        out
    };
    for (m, mm) in forecast(&metres).iter().zip(forecast(&millimetres)) {
        assert!(
            (m * 1000.0 - mm).abs() < 1e-6 * mm.abs().max(1.0),
            "{m} m vs {mm} mm"
        );
    }
}

#[test]
fn long_training_series_thin_their_windows() {
    let p = MlpPredictor::new(&config(800, 50, 4, 1)).unwrap();
    assert_eq!(p.effective_stride(5000), MLP_WINDOW_STRIDE);
    let stride = p.effective_stride(200_000);
    let windows = (200_000 - 850) / stride + 1;
    assert!(windows * 800 <= MAX_TRAINING_VALUES, "stride {stride}");
    assert!(stride > 1);
}

#[test]
fn bad_configurations_and_inputs_are_errors() {
    assert!(matches!(
        MlpPredictor::new(&config(10, 2, 0, 10)),
        Err(PredictError::Infeasible(_))
    ));
    assert!(matches!(
        MlpPredictor::new(&config(10, 2, 5, 0)),
        Err(PredictError::Infeasible(_))
    ));
    assert!(matches!(
        MlpPredictor::new(&config(usize::MAX / 2, 2, 5, 1)),
        Err(PredictError::Infeasible(_))
    ));
    let mut p = MlpPredictor::new(&config(10, 2, 4, 5)).unwrap();
    let mut out = [0.0; 2];
    assert_eq!(
        p.forecast(&[0.0; 10], &mut out),
        Err(PredictError::NotFitted(Method::Mlp))
    );
    assert!(matches!(
        p.fit(&[0.5; 11]),
        Err(PredictError::TooShort {
            needed: 12,
            got: 11,
            ..
        })
    ));
    // A constant series trains (there is no spread to scale by) and forecasts finite values.
    p.fit(&[0.5; 40]).unwrap();
    p.forecast(&[0.5; 10], &mut out).unwrap();
    assert!(out.iter().all(|v| v.is_finite()));
    let mut window = [0.5; 10];
    window[3] = f64::INFINITY;
    assert!(matches!(
        p.forecast(&window, &mut out),
        Err(PredictError::NonFinite(_))
    ));
}

#[test]
fn a_model_file_with_wrong_parameters_is_refused() {
    let mut p = MlpPredictor::new(&config(6, 2, 3, 5)).unwrap();
    p.fit(&sines(40)).unwrap();
    let model = serde_json::to_value(&p).unwrap();
    let mut short = model.clone();
    short["params"].as_array_mut().unwrap().pop();
    let mut zero_scale = model;
    zero_scale["scale"] = serde_json::json!(0.0);
    for (broken, field) in [(short, "MLP params hold"), (zero_scale, "MLP scale")] {
        let err = serde_json::from_value::<MlpPredictor>(broken).unwrap_err();
        assert!(err.to_string().contains(field), "{err}");
    }
}

/// Regression (review): an order and hidden units each within their own limits made a network
/// of 10^8 weights, and training aborted the process on a failed allocation. Refused at
/// construction, with the budget; the largest network within it is built.
#[test]
fn a_network_beyond_the_weight_budget_is_refused_before_anything_is_allocated() {
    let config = |order, hidden| PredictorConfig {
        order,
        horizon: 50,
        mlp_hidden: hidden,
        ..PredictorConfig::default()
    };
    let e = MlpPredictor::new(&config(10_000, 10_000)).err().unwrap();
    assert!(e.to_string().contains("at most 10000000 weights"), "{e}");
    // 1000 x (9949 + 50 + 1) + 50 = 10^7 + 50: just beyond; one input fewer per unit is within.
    assert!(MlpPredictor::new(&config(9_949, 1_000)).is_err());
    assert!(MlpPredictor::new(&config(9_948, 1_000)).is_ok());
}
