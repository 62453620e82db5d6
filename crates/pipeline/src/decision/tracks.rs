//! The limited quantities of one forecast, step by step: roll, pitch and the deck point's
//! vertical displacement and velocity, with their sigmas; and the standardised errors and means
//! that verified forecasts give the error ensemble.

use super::{HEAVE, NUM_QUANTITIES, PITCH, ROLL};
use crate::deck::ShipPoint;
use shipcast_wire::payload::{Forecast, MAX_STEPS};

/// Means and sigmas of the limited quantities at every step of one forecast.
#[derive(Debug, Clone)]
pub struct Tracks {
    pub steps: usize,
    pub dt_s: f64,
    pub mean: [[f64; MAX_STEPS]; NUM_QUANTITIES],
    pub sigma: [[f64; MAX_STEPS]; NUM_QUANTITIES],
}

impl Default for Tracks {
    fn default() -> Self {
        Self {
            steps: 0,
            dt_s: 0.0,
            mean: [[0.0; MAX_STEPS]; NUM_QUANTITIES],
            sigma: [[0.0; MAX_STEPS]; NUM_QUANTITIES],
        }
    }
}

impl Tracks {
    /// Fill from a forecast. The deck point's vertical sigma takes heave, roll and pitch errors
    /// as independent; its velocity is the central difference over neighbouring steps, whose
    /// sigma uses the displacement's error correlation `rho_z` between the two steps.
    pub fn fill(&mut self, point: &ShipPoint, forecast: &Forecast, rho_z: f64) {
        let steps = forecast.valid_steps();
        self.steps = steps;
        self.dt_s = forecast.dt_s;
        for k in 0..steps {
            let dof: [f64; 6] = std::array::from_fn(|d| f64::from(forecast.mean[d][k]));
            let sig = |d: usize| f64::from(forecast.sigma[d][k]);
            self.mean[0][k] = dof[ROLL];
            self.sigma[0][k] = sig(ROLL);
            self.mean[1][k] = dof[PITCH];
            self.sigma[1][k] = sig(PITCH);
            self.mean[2][k] = -point.displacement(dof).z;
            self.sigma[2][k] = point.vertical_sigma(sig(HEAVE), sig(ROLL), sig(PITCH));
        }
        for k in 0..steps {
            let (a, b) = match (k.checked_sub(1), k + 1 < steps) {
                (Some(a), true) => (a, k + 1),
                (None, true) => (k, k + 1),
                (Some(a), false) => (a, k),
                (None, false) => (k, k),
            };
            if a == b {
                self.mean[3][k] = 0.0;
                self.sigma[3][k] = 0.0;
                continue;
            }
            let span = (b - a) as f64 * self.dt_s;
            let (za, zb) = (self.mean[2][a], self.mean[2][b]);
            let (sa, sb) = (self.sigma[2][a], self.sigma[2][b]);
            let r = rho_z.clamp(0.0, 1.0).powi((b - a) as i32);
            let var = sa * sa + sb * sb - 2.0 * r * sa * sb;
            self.mean[3][k] = (zb - za) / span;
            self.sigma[3][k] = var.max(0.0).sqrt() / span;
        }
    }

    /// Central differences for the deck velocity at the first and last step (filled by
    /// [`Self::fill`]), from the recorded DOF values one step before the first (`before`, at
    /// the forecast's `time_s`, known when it is issued) and one after the last (`after`),
    /// where given. A one-sided difference at an end is the velocity half a step away from
    /// that step's time, so a limit there would be checked at another instant than the step's.
    /// A forecast's tracks take `before` (a recorded value: no error of its own, so the first
    /// step's velocity sigma is the second step's displacement sigma over 2 dt), and the
    /// recorded tracks its errors are taken against take the same; whether a limit held is
    /// judged with `after` too.
    pub fn central_ends(
        &mut self,
        point: &ShipPoint,
        before: Option<&[f64; 6]>,
        after: Option<&[f64; 6]>,
    ) {
        let steps = self.steps;
        if steps < 2 || self.dt_s.is_nan() || self.dt_s <= 0.0 {
            return;
        }
        let z = |dof: &[f64; 6]| -point.displacement(*dof).z;
        if let Some(b) = before {
            self.mean[3][0] = (self.mean[2][1] - z(b)) / (2.0 * self.dt_s);
            self.sigma[3][0] = self.sigma[2][1] / (2.0 * self.dt_s);
        }
        if let Some(a) = after {
            self.mean[3][steps - 1] = (z(a) - self.mean[2][steps - 2]) / (2.0 * self.dt_s);
        }
    }
}

/// The standardised errors u = (actual - mean) / sigma of a forecast's tracks against what
/// happened (`actual` filled from the record's values at the same steps; its sigma unused),
/// over the steps both cover ([`standardised_error`]). Returns the steps filled.
pub fn standardised_errors(
    predicted: &Tracks,
    actual: &Tracks,
    u: &mut [[f64; MAX_STEPS]; NUM_QUANTITIES],
) -> usize {
    let steps = predicted.steps.min(actual.steps);
    for (q, row) in u.iter_mut().enumerate() {
        for (k, x) in row.iter_mut().enumerate().take(steps) {
            *x = standardised_error(
                actual.mean[q][k],
                predicted.mean[q][k],
                predicted.sigma[q][k],
            );
        }
    }
    steps
}

/// The standardised error (actual - mean) / sigma of one value, as the error ensembles take
/// it. Where sigma is zero: 0 if the forecast was exact (to the rounding of its values), else
/// [`UNBOUNDED_ERROR`] with the error's sign (a miss the forecast said could not happen);
/// NaN where a value or sigma is missing.
pub fn standardised_error(actual: f64, mean: f64, sigma: f64) -> f64 {
    let error = actual - mean;
    if sigma > 0.0 {
        error / sigma
    } else if error.is_nan() || sigma.is_nan() {
        f64::NAN
    } else if error.is_finite()
        && error.abs() <= ROUNDING * actual.abs().max(mean.abs()) + ROUNDING_FLOOR
    {
        // Review: the deck point's displacement of a zero motion is 0 or +-9e-16 m by yaw,
        // and that rounding counted as a miss beyond every limit.
        0.0
    } else {
        UNBOUNDED_ERROR.copysign(error)
    }
}

/// Relative rounding within which a value forecast with sigma 0 counts as hit: a few units
/// of f32's precision, the wire's.
const ROUNDING: f64 = 4.0 * f32::EPSILON as f64;
/// Absolute floor of it (m, rad, m/s): far below any sensor's resolution, and above the
/// rounding a derived quantity carries from its inputs (the deck velocity is a difference of
/// two displacements of up to metres, each rounded to f32, over 1 s: about 1e-6).
const ROUNDING_FLOOR: f64 = 1e-5;

/// The standardised error of a miss where the forecast stated sigma 0: large enough that
/// any forecast with a positive sigma breaks every limit under it, finite so that the
/// ensemble keeps it (it counts a non-finite error as none). Review: such a miss was taken
/// as no error, so a sigma-0 forecast source filled the ensemble with perfect forecasts.
pub const UNBOUNDED_ERROR: f64 = 1e30;

/// Whether a standardised error is such a miss (kept as f32 by the ensembles: compared with
/// room to spare).
pub fn is_unbounded(u: f64) -> bool {
    u.abs() >= 0.5 * UNBOUNDED_ERROR
}

/// The standardised means z = mean / sigma of a forecast's tracks (NaN where sigma is zero),
/// over its steps: what the ensemble regresses the errors on ([`super::ensemble`]).
pub fn standardised_means(predicted: &Tracks, z: &mut [[f64; MAX_STEPS]; NUM_QUANTITIES]) {
    for (q, row) in z.iter_mut().enumerate() {
        for (k, x) in row.iter_mut().enumerate().take(predicted.steps) {
            let s = predicted.sigma[q][k];
            *x = if s > 0.0 {
                predicted.mean[q][k] / s
            } else {
                f64::NAN
            };
        }
    }
}
