//! The least-squares (covariance-method) estimate of the Wiener predictor: for each step h the
//! weights minimise the squared h-step error over the training segment's own forecast origins,
//! instead of solving the normal equations under the biased autocorrelation (the paper's
//! Yule-Walker estimate, `wiener.rs`). Not in the paper; `wiener_fit = least-squares`.
//!
//! The biased autocorrelation tapers lag k by (1 - k/T) and treats the segment as zero outside
//! it. That bias smooths the spectrum the predictor is fitted to, which costs accuracy on a
//! steady sea (ship motion is smooth and very predictable a few seconds ahead) and buys
//! robustness: the fit never leans on frequencies the segment did not hold. The least-squares
//! fit does lean on them, so it is sharper while the sea stays as it was and wild for a while
//! after it changes. `Guard` holds it near the autocorrelation fit's forecast, which keeps the
//! sharpness on the sea both fits know and the robustness off it; that is the service's default
//! (`WienerFit::Guarded`). All three measured in docs/forecasting.md ("How the weights are
//! estimated").
//!
//! The normal equations `A w_h = b_h` share one `order x order` matrix for all steps (every
//! step is fitted on the same origins), so the cost is one Gram matrix of the lagged values,
//! computed from its first row by a recursion along its diagonals (`lagged_gram`), and one
//! Cholesky factorisation.

use super::linear_map::LinearMap;
use super::PredictError;
use faer::linalg::solvers::Solve;
use faer::{Mat, Side};
use serde::{Deserialize, Serialize};

/// How a Wiener predictor's weights are estimated from a training segment.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum WienerFit {
    /// The paper's: the Toeplitz normal equations under the biased autocorrelation.
    #[default]
    Autocorrelation,
    /// Least squares over the training segment's forecast origins (not in the paper).
    LeastSquares,
    /// Least squares held step by step within a band around the autocorrelation fit's
    /// forecast (`Guard`; not in the paper).
    Guarded,
}

impl WienerFit {
    /// Every fit, in the order help texts list them.
    pub const ALL: [WienerFit; 3] = [
        WienerFit::Autocorrelation,
        WienerFit::LeastSquares,
        WienerFit::Guarded,
    ];

    /// CLI / config name.
    pub const fn name(self) -> &'static str {
        match self {
            WienerFit::Autocorrelation => "autocorrelation",
            WienerFit::LeastSquares => "least-squares",
            WienerFit::Guarded => "guarded",
        }
    }

    /// Training values a fit of `order` and `horizon` needs: the autocorrelation's lags, or
    /// the least-squares fit's origins (`values_needed`).
    pub const fn training_values(self, order: usize, horizon: usize) -> usize {
        match self {
            WienerFit::Autocorrelation => order + horizon,
            WienerFit::LeastSquares | WienerFit::Guarded => values_needed(order, horizon),
        }
    }
}

impl std::fmt::Display for WienerFit {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for WienerFit {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let lower = s.trim().to_ascii_lowercase();
        WienerFit::ALL
            .into_iter()
            .find(|f| f.name() == lower)
            .ok_or_else(|| {
                format!(
                    "unknown Wiener fit '{s}' (expected autocorrelation, least-squares or guarded)"
                )
            })
    }
}

/// Ridges tried in turn, relative to the mean diagonal of the Gram matrix. The first is only
/// numerical insurance: a noise-free, band-limited record makes the Gram matrix nearly
/// singular, and anything larger measurably blurs the fit there. The second is taken only if
/// rounding makes the first fail the Cholesky factorisation.
const RIDGES: [f64; 2] = [1e-9, 1e-6];

/// Forecast origins per weight at least: with fewer, the least-squares fit follows the
/// training segment's noise (`values_needed`).
pub const ORIGINS_PER_ORDER: usize = 2;

/// Training values a least-squares fit of `order` and `horizon` needs: `ORIGINS_PER_ORDER`
/// origins per weight, each with `order` values before it and `horizon` after.
pub const fn values_needed(order: usize, horizon: usize) -> usize {
    ORIGINS_PER_ORDER * order + order + horizon - 1
}

/// Gram matrix of the lagged vectors `z_t(k) = x[t + lead - k]`, `k = 0 .. size`, summed over
/// the origins `t = first ..= last`: `gram[k * size + l] = sum_t z_t(k) z_t(l)`.
///
/// Row 0 is summed directly; every further entry follows from the one before it on its
/// diagonal, `G[k+1][l+1] = G[k][l] + z_{first-1}(k) z_{first-1}(l) - z_last(k) z_last(l)`,
/// because shifting both lags by one shifts the origins by one. `O(size * origins + size^2)`
/// instead of `O(size^2 * origins)`.
///
/// The caller guarantees `first + lead >= size - 1` and `last + lead < x.len()`, so every index
/// is inside `x` (the origin before the first, `first - 1`, may be -1: only its values at lags
/// `k <= size - 2` are read, at `first + lead - 1 - k >= 0`).
fn lagged_gram(x: &[f64], first: usize, last: usize, lead: usize, size: usize) -> Vec<f64> {
    let mut gram = vec![0.0; size * size];
    for l in 0..size {
        gram[l] = (first..=last).map(|t| x[t + lead] * x[t + lead - l]).sum();
    }
    // The values of z at the origin before the first and at the last origin, at lag k.
    let before = |k: usize| x[first + lead - 1 - k];
    let at_last = |k: usize| x[last + lead - k];
    for k in 0..size - 1 {
        for l in k..size - 1 {
            let entering = before(k) * before(l);
            let leaving = at_last(k) * at_last(l);
            gram[(k + 1) * size + l + 1] = gram[k * size + l] + entering - leaving;
        }
    }
    for k in 0..size {
        for l in 0..k {
            gram[k * size + l] = gram[l * size + k];
        }
    }
    gram
}

/// The Gram matrix of a fit of `order` and `horizon` on `x`, over its forecast origins
/// `t = order - 1 ..= len - 1 - horizon`, with `z_t(k) = x[t + horizon - k]`: `k < horizon` are
/// the targets `x[t + horizon] .. x[t + 1]`, `k = horizon + l` the past value `x[t - l]`.
/// Both the least-squares weights and their `Guard` are read off it.
pub struct FitGram {
    order: usize,
    horizon: usize,
    /// Row-major, `order + horizon` square.
    gram: Vec<f64>,
    origins: usize,
}

impl FitGram {
    /// The Gram matrix of a fit of `order` and `horizon` on `x`.
    pub fn new(x: &[f64], order: usize, horizon: usize) -> Result<Self, PredictError> {
        let needed = values_needed(order, horizon);
        if x.len() < needed {
            return Err(PredictError::Length(format!(
                "a least-squares Wiener fit of order {order} and horizon {horizon} needs {needed} \
                 training values ({ORIGINS_PER_ORDER} forecast origins per weight), got {}",
                x.len()
            )));
        }
        let (first, last) = (order - 1, x.len() - 1 - horizon);
        Ok(Self {
            order,
            horizon,
            gram: lagged_gram(x, first, last, horizon, order + horizon),
            origins: last - first + 1,
        })
    }
}

/// The least-squares weights of every step `1..=horizon` read off a fit's Gram matrix, as a
/// matrix over the past window in chronological order.
pub fn least_squares_from(fit: &FitGram) -> Result<LinearMap, PredictError> {
    let (order, horizon, gram) = (fit.order, fit.horizon, &fit.gram);
    let size = order + horizon;
    let past = |l: usize| horizon + l;
    let a = Mat::from_fn(order, order, |i, j| gram[past(i) * size + past(j)]);
    // b[l][h-1] = sum_t x[t - l] x[t + h] = G[horizon + l][horizon - h].
    let b = Mat::from_fn(order, horizon, |l, h| {
        gram[past(l) * size + horizon - 1 - h]
    });
    let mean_diagonal = (0..order).map(|i| a[(i, i)]).sum::<f64>() / order as f64;
    if !(mean_diagonal.is_finite() && mean_diagonal > 0.0) {
        return Err(PredictError::Numerical(
            "least-squares Wiener fit: the training segment has no power".into(),
        ));
    }
    for ridge in RIDGES {
        let mut regularised = a.clone();
        for i in 0..order {
            regularised[(i, i)] += ridge * mean_diagonal;
        }
        let Ok(llt) = regularised.llt(Side::Lower) else {
            continue;
        };
        let w = llt.solve(&b);
        // w[(l, h-1)] multiplies x(t - l), the value l steps before the newest: column
        // order - 1 - l of row h - 1.
        let coef: Vec<f64> = (0..horizon)
            .flat_map(|h| (0..order).map(move |j| (h, j)))
            .map(|(h, j)| w[(order - 1 - j, h)])
            .collect();
        if coef.iter().any(|c| !c.is_finite()) {
            continue;
        }
        return LinearMap::from_row_major(horizon, order, coef).map_err(PredictError::Numerical);
    }
    Err(PredictError::Numerical(
        "least-squares Wiener fit: the lagged Gram matrix is not positive definite even with a \
         ridge of 1e-6"
            .into(),
    ))
}

/// How far, in RMS differences over the training origins, a guarded forecast may stray from
/// its reference (`Guard`).
pub const GUARD_SPREADS: f64 = 3.0;

/// A band around a reference forecast (the autocorrelation fit's) that a sharper forecast (the
/// least-squares fit's) is held in, step by step.
///
/// On the sea they were fitted on, the two forecasts differ by a typical amount per step,
/// measured on the training origins; a sharper forecast that leaves the reference by several
/// times that is extrapolating from a sea it has not seen (after a turn, the least-squares
/// forecasts left it within seconds and missed by up to 9 std). `GUARD_SPREADS` of those RMS
/// differences bound it, so the guarded forecast is the sharper one on the sea both know and
/// stays near the robust one off it.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(from = "GuardFile", into = "GuardFile")]
pub struct Guard {
    /// The reference fit on the same segment, `horizon x order`.
    reference: LinearMap,
    /// Per step, the largest distance of the delivered forecast from the reference's.
    band: Vec<f64>,
    /// The reference's forecast, one value per step: sized with the band, so holding a
    /// forecast never allocates.
    scratch: Vec<f64>,
}

/// A guard as a model file holds it.
#[derive(Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct GuardFile {
    reference: LinearMap,
    band: Vec<f64>,
}

impl From<GuardFile> for Guard {
    fn from(f: GuardFile) -> Self {
        Guard::new(f.reference, f.band)
    }
}

impl From<Guard> for GuardFile {
    fn from(g: Guard) -> Self {
        GuardFile {
            reference: g.reference,
            band: g.band,
        }
    }
}

impl Guard {
    /// A guard of `reference` with `band` per step.
    pub fn new(reference: LinearMap, band: Vec<f64>) -> Self {
        let scratch = vec![0.0; band.len()];
        Self {
            reference,
            band,
            scratch,
        }
    }

    /// Per step, the largest distance of the delivered forecast from the reference's.
    pub fn band(&self) -> &[f64] {
        &self.band
    }

    /// The guard of `delivered` against `reference`, both fitted on the window of `fit`: per
    /// step, `GUARD_SPREADS` times the RMS over its origins of the difference of their
    /// forecasts (from the past block of its Gram matrix).
    pub fn fit(
        fit: &FitGram,
        delivered: &LinearMap,
        reference: LinearMap,
    ) -> Result<Self, PredictError> {
        let (order, horizon, gram, origins) = (fit.order, fit.horizon, &fit.gram, fit.origins);
        if (delivered.rows(), delivered.cols()) != (horizon, order)
            || (reference.rows(), reference.cols()) != (horizon, order)
        {
            return Err(PredictError::Length(format!(
                "a Wiener guard of order {order} and horizon {horizon} needs two {horizon} x {order} maps"
            )));
        }
        let size = order + horizon;
        let mut difference = vec![0.0; order];
        let band = (0..horizon)
            .map(|h| {
                // In lag order: lag l is column order - 1 - l.
                for (l, dw) in difference.iter_mut().enumerate() {
                    *dw = delivered.row(h)[order - 1 - l] - reference.row(h)[order - 1 - l];
                }
                let mut quadratic = 0.0;
                for (i, di) in difference.iter().enumerate() {
                    let row = &gram[(horizon + i) * size + horizon..(horizon + i) * size + size];
                    quadratic += di
                        * row
                            .iter()
                            .zip(&difference)
                            .map(|(g, dj)| g * dj)
                            .sum::<f64>();
                }
                GUARD_SPREADS * (quadratic.max(0.0) / origins as f64).sqrt()
            })
            .collect::<Vec<f64>>();
        if band.iter().any(|b| !b.is_finite()) {
            return Err(PredictError::Numerical(
                "guarded Wiener fit: the band is not finite".into(),
            ));
        }
        Ok(Self::new(reference, band))
    }

    /// Hold each step of `out` (forecast from `window`, the last `order` values) within the
    /// band around the reference's forecast from the same values. Never allocates.
    pub fn hold(&mut self, window: &[f64], out: &mut [f64]) {
        self.reference.apply_prepared(window, &mut self.scratch);
        for ((o, reference), band) in out.iter_mut().zip(&self.scratch).zip(&self.band) {
            *o = o.clamp(reference - band, reference + band);
        }
    }

    /// The reference's share of `Predictor::prepare`.
    pub fn prepare(&mut self, known: &[f64]) {
        self.reference.prepare(known);
    }

    /// What a model file's guard must satisfy for a predictor of `order` and `horizon`.
    pub fn validate(&self, order: usize, horizon: usize) -> Result<(), String> {
        if (self.reference.rows(), self.reference.cols()) != (horizon, order) {
            return Err(format!(
                "Wiener guard reference is {} x {}; horizon {horizon} and order {order} need {horizon} x {order}",
                self.reference.rows(),
                self.reference.cols()
            ));
        }
        if self.band.len() != horizon || self.band.iter().any(|b| !(b.is_finite() && *b >= 0.0)) {
            return Err(format!(
                "Wiener guard band must hold {horizon} finite values >= 0"
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::linalg::solvers::SolveLstsq;
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};

    /// The least-squares weights of a fit of `order` and `horizon` on `x`.
    fn least_squares_coefficients(
        x: &[f64],
        order: usize,
        horizon: usize,
    ) -> Result<LinearMap, PredictError> {
        least_squares_from(&FitGram::new(x, order, horizon)?)
    }

    fn white(n: usize, seed: u64) -> Vec<f64> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        (0..n).map(|_| StandardNormal.sample(&mut rng)).collect()
    }

    #[test]
    fn the_gram_recursion_equals_the_direct_sums() {
        let x = white(300, 1);
        // The second case is one past value: the origin before the first is -1.
        for (first, last, lead, size) in [(9, 260, 30, 40), (0, 269, 30, 31)] {
            let g = lagged_gram(&x, first, last, lead, size);
            for k in 0..size {
                for l in 0..size {
                    let direct: f64 = (first..=last)
                        .map(|t| x[t + lead - k] * x[t + lead - l])
                        .sum();
                    assert!(
                        (g[k * size + l] - direct).abs() < 1e-9 * direct.abs().max(1.0),
                        "first {first}, ({k}, {l}): {} vs {direct}",
                        g[k * size + l]
                    );
                }
            }
        }
    }

    #[test]
    fn an_ar1_is_fitted_as_phi_to_the_power_h_on_the_newest_value() {
        // x_t = 0.9 x_{t-1} + e_t: the best h-step predictor is 0.9^h x_t, nothing older.
        let e = white(40_000, 2);
        let mut x = vec![0.0; e.len()];
        for t in 1..x.len() {
            x[t] = 0.9 * x[t - 1] + e[t];
        }
        let (order, horizon) = (5, 4);
        let map = least_squares_coefficients(&x, order, horizon).unwrap();
        for h in 1..=horizon {
            let row = map.row(h - 1);
            let newest = row[order - 1];
            assert!(
                (newest - 0.9f64.powi(h as i32)).abs() < 0.02,
                "step {h}: {newest}"
            );
            for (j, c) in row[..order - 1].iter().enumerate() {
                assert!(c.abs() < 0.02, "step {h}, column {j}: {c}");
            }
        }
    }

    #[test]
    fn it_is_the_dense_least_squares_solution() {
        // Independent path: the regression matrix written out and solved through faer's QR.
        let x = white(400, 3);
        let (order, horizon) = (6, 3);
        let map = least_squares_coefficients(&x, order, horizon).unwrap();
        let origins: Vec<usize> = (order - 1..x.len() - horizon).collect();
        let design = Mat::from_fn(origins.len(), order, |i, j| x[origins[i] + j + 1 - order]);
        let targets = Mat::from_fn(origins.len(), horizon, |i, h| x[origins[i] + h + 1]);
        let w = design.qr().solve_lstsq(&targets);
        for h in 0..horizon {
            for j in 0..order {
                let got = map.row(h)[j];
                assert!(
                    (got - w[(j, h)]).abs() < 1e-6,
                    "step {} column {j}: {got} vs {}",
                    h + 1,
                    w[(j, h)]
                );
            }
        }
    }

    #[test]
    fn order_one_is_exact() {
        let x = white(200, 4);
        let map = least_squares_coefficients(&x, 1, 2).unwrap();
        for h in 1..=2 {
            let (num, den) = (0..x.len() - 2).fold((0.0, 0.0), |(n, d), t| {
                (n + x[t] * x[t + h], d + x[t] * x[t])
            });
            let got = map.row(h - 1)[0];
            assert!((got - num / den).abs() < 1e-6, "step {h}: {got}");
        }
    }

    #[test]
    fn too_short_a_segment_and_a_silent_one_are_errors() {
        let err = least_squares_coefficients(&[1.0; 20], 10, 5).unwrap_err();
        assert!(err.to_string().contains("needs 34"), "{err}");
        let err = least_squares_coefficients(&[0.0; 200], 10, 5).unwrap_err();
        assert!(err.to_string().contains("no power"), "{err}");
    }

    #[test]
    fn a_sum_of_sinusoids_is_predicted_from_a_segment_the_autocorrelation_fit_cannot_use() {
        // Three lines are exactly predictable by a linear map of 6 or more past values. The
        // autocorrelation estimate's taper (1 - k/T) keeps Wiener-40 at about 1e-2 on 1000
        // values (`wiener.rs` needs 80000 for 1e-3); least squares has no taper.
        use crate::conformance::{nrmse_over_test, sum_of_sinusoids};
        use crate::{Predictor, PredictorConfig, WienerPredictor};
        let x = sum_of_sinusoids(1400);
        let nrmse = |fit: WienerFit| {
            let config = PredictorConfig {
                order: 40,
                horizon: 20,
                wiener_fit: fit,
                ..PredictorConfig::default()
            };
            let mut p = WienerPredictor::new(&config).unwrap();
            p.fit(&x[..1000]).unwrap();
            nrmse_over_test(&mut p, &x, 1000, 3)
        };
        let (ls, yw) = (
            nrmse(WienerFit::LeastSquares),
            nrmse(WienerFit::Autocorrelation),
        );
        assert!(ls < 1e-3, "least squares: {ls}");
        assert!(yw > 10.0 * ls, "autocorrelation {yw} vs least squares {ls}");
    }

    #[test]
    fn a_model_file_without_the_fit_is_the_papers() {
        // Model files written before `fit` existed load as what fitted them.
        let json = r#"{"order": 1, "horizon": 1, "coefficients": null}"#;
        let p: crate::WienerPredictor = serde_json::from_str(json).unwrap();
        let back = serde_json::to_value(&p).unwrap();
        assert_eq!(back["fit"], "autocorrelation");
    }

    /// A map of `rows x cols` with entries from `seed`.
    fn random_map(rows: usize, cols: usize, seed: u64) -> LinearMap {
        LinearMap::from_row_major(rows, cols, white(rows * cols, seed)).unwrap()
    }

    #[test]
    fn the_band_is_the_rms_difference_of_the_two_forecasts_over_the_training_origins() {
        let x = white(500, 5);
        let (order, horizon) = (8, 4);
        let (a, b) = (random_map(horizon, order, 6), random_map(horizon, order, 7));
        let guard = Guard::fit(&FitGram::new(&x, order, horizon).unwrap(), &a, b.clone()).unwrap();
        // Directly: every origin t = order - 1 ..= len - 1 - horizon, window x[t-order+1 ..= t].
        for h in 0..horizon {
            let origins = order - 1..x.len() - horizon;
            let n = origins.len() as f64;
            let mean_square = origins
                .map(|t| {
                    let w = &x[t + 1 - order..=t];
                    let d: f64 = (0..order).map(|j| (a.row(h)[j] - b.row(h)[j]) * w[j]).sum();
                    d * d
                })
                .sum::<f64>()
                / n;
            let expect = GUARD_SPREADS * mean_square.sqrt();
            assert!(
                (guard.band()[h] - expect).abs() < 1e-9 * expect,
                "step {}: {} vs {expect}",
                h + 1,
                guard.band()[h]
            );
        }
    }

    #[test]
    fn a_forecast_is_held_within_the_band_and_left_alone_inside_it() {
        // Reference: step 1 repeats the newest value, step 2 forecasts 0; bands 1 and 0.5.
        let reference = LinearMap::from_row_major(2, 2, vec![0.0, 1.0, 0.0, 0.0]).unwrap();
        let mut guard = Guard::new(reference, vec![1.0, 0.5]);
        // The forecast's window: the last two values, the newest 10.
        let window = [3.0, 10.0];
        let mut out = [10.4, -0.2, 99.0];
        guard.hold(&window, &mut out);
        assert_eq!(
            out,
            [10.4, -0.2, 99.0],
            "inside the band, and past the horizon"
        );
        let mut out = [20.0, -3.0];
        guard.hold(&window, &mut out);
        assert_eq!(out, [11.0, -0.5]);
        // A guard of a fit against itself has no band: the forecast is the reference's.
        let x = white(300, 8);
        let same = random_map(3, 5, 9);
        let guard = Guard::fit(&FitGram::new(&x, 5, 3).unwrap(), &same, same.clone()).unwrap();
        assert!(guard.band().iter().all(|b| *b == 0.0), "{:?}", guard.band());
    }

    #[test]
    fn a_model_file_guard_of_the_wrong_shape_is_refused() {
        let guard = Guard::new(random_map(3, 5, 10), vec![1.0; 3]);
        assert!(guard.validate(5, 3).is_ok());
        assert!(guard.validate(4, 3).unwrap_err().contains("3 x 5"));
        let short = Guard::new(random_map(3, 5, 10), vec![1.0; 2]);
        assert!(short
            .validate(5, 3)
            .unwrap_err()
            .contains("3 finite values"));
        let negative = Guard::new(random_map(3, 5, 10), vec![1.0, -1.0, 1.0]);
        assert!(negative.validate(5, 3).is_err());
        // Through a model file: a hand-edited band of the wrong length is refused on load.
        let config = crate::PredictorConfig {
            order: 5,
            horizon: 3,
            wiener_fit: WienerFit::Guarded,
            ..crate::PredictorConfig::default()
        };
        let mut p = crate::WienerPredictor::new(&config).unwrap();
        crate::Predictor::fit(&mut p, &white(200, 11)).unwrap();
        let mut json = serde_json::to_value(&p).unwrap();
        json["guard"]["band"] = serde_json::json!([1.0, 1.0]);
        let err = serde_json::from_value::<crate::WienerPredictor>(json).unwrap_err();
        assert!(err.to_string().contains("3 finite values"), "{err}");
    }

    #[test]
    fn names_round_trip() {
        for fit in [
            WienerFit::Autocorrelation,
            WienerFit::LeastSquares,
            WienerFit::Guarded,
        ] {
            assert_eq!(fit.name().parse::<WienerFit>().unwrap(), fit);
        }
        assert!("yule".parse::<WienerFit>().is_err());
    }
}
