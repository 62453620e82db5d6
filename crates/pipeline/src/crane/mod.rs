//! Crane-tip motion forecast: where the tip of a crane (a point fixed on the ship) will be over
//! the forecast horizon, for the operator transferring cargo between ships.

pub mod verify;

use crate::relative::PointTrack;
use serde::{Deserialize, Serialize};
use shipcast_wire::payload::Forecast;
use verify::TipVerifier;

/// Predicted tip displacement at one step (ship axes: x forward, y starboard, z down).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TipStep {
    /// Seconds after the forecast's `time_s`.
    pub ahead_s: f64,
    /// Displacement from the tip's rest position [m].
    pub displacement_m: [f64; 3],
    /// Standard deviation of the displacement per axis [m]: linearised from the DOF sigmas,
    /// scaled by the verified tip forecasts once enough exist ([`verify`]).
    pub sigma_m: [f64; 3],
    /// Whether every axis's sigma (with a variance to scale) is scaled by verified forecasts
    /// (else, on some axis, the DOF errors are taken as independent).
    pub sigma_calibrated: bool,
}

/// The tip displacement at every step of `point` (the tip's track of a forecast with step
/// `dt_s`), written into `out` (cleared first, so a reused vector does not allocate once it has
/// grown to the horizon), its sigma scaled by `verified` where enough tip forecasts have been
/// verified.
pub fn tip_track(point: &PointTrack, dt_s: f64, verified: &TipVerifier, out: &mut Vec<TipStep>) {
    out.clear();
    for k in 0..point.steps {
        let mut sigma_calibrated = true;
        let sigma_m = std::array::from_fn(|axis| {
            let var = point.var[axis][k];
            let (s, calibrated) = verified.sigma(axis, k, var);
            // An axis the DOF sigmas give no variance has nothing to scale.
            sigma_calibrated &= calibrated || var <= 0.0;
            s
        });
        out.push(TipStep {
            ahead_s: (k + 1) as f64 * dt_s,
            displacement_m: std::array::from_fn(|axis| point.mean[axis][k]),
            sigma_m,
            sigma_calibrated,
        });
    }
}

/// One console line: the tip's vertical motion (positive up) at a few look-ahead times and the
/// largest excursion over the horizon.
pub fn summary(forecast: &Forecast, track: &[TipStep]) -> String {
    let mut line = format!(
        "crane t={:.1}s v{} seq {}:",
        forecast.time_s, forecast.model_version, forecast.seq
    );
    for target in [5.0, 10.0, 20.0] {
        if let Some(s) = track.iter().find(|s| s.ahead_s >= target - 1e-9) {
            line.push_str(&format!(
                " +{:.0}s up {:+.2}±{:.2} m",
                s.ahead_s, -s.displacement_m[2], s.sigma_m[2]
            ));
        }
    }
    let max_h = track
        .iter()
        .map(|s| s.displacement_m[0].hypot(s.displacement_m[1]))
        .fold(0.0, f64::max);
    let max_v = track
        .iter()
        .map(|s| s.displacement_m[2].abs())
        .fold(0.0, f64::max);
    let basis = if track.iter().all(|s| s.sigma_calibrated) {
        "calibrated"
    } else if track.iter().any(|s| s.sigma_calibrated) {
        "partly calibrated"
    } else {
        "independent DOF errors"
    };
    line.push_str(&format!(
        " | max horizontal {max_h:.2} m, vertical {max_v:.2} m | sigma {basis}"
    ));
    line
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::deck::ShipPoint;
    use crate::sigma_scale::SigmaScale;

    #[test]
    fn tip_track_follows_roll_and_is_summarised() {
        let tip = ShipPoint::new([0.0, 15.0, -20.0]);
        let mut f = Forecast {
            time_s: 10.0,
            dt_s: 0.5,
            steps: 40,
            ..Forecast::default()
        };
        for k in 0..40 {
            f.mean[3][k] = 0.01 * k as f32; // roll, starboard down
            f.sigma[2][k] = 0.1;
        }
        let mut track = Vec::new();
        let mut point = PointTrack::default();
        point.fill(&tip, 0.0, &f, 0, f.valid_steps());
        let fresh = TipVerifier::new(tip, SigmaScale::adaptive(600.0, 50.0), verify::MAX_PENDING);
        tip_track(&point, f.dt_s, &fresh, &mut track);
        assert_eq!(track.len(), 40);
        assert_eq!(track[9].ahead_s, 5.0);
        // Roll phi moves a point (y, z) to (y cos - z sin, y sin + z cos).
        let phi = 0.01f32 * 9.0;
        let phi = phi as f64;
        let expect_z = 15.0 * phi.sin() - 20.0 * phi.cos() + 20.0;
        assert!((track[9].displacement_m[2] - expect_z).abs() < 1e-6);
        assert!((track[0].sigma_m[2] - 0.1).abs() < 1e-6);
        assert!(!track[0].sigma_calibrated);
        let line = summary(&f, &track);
        assert!(
            line.contains("+5s up") && line.contains("+20s up"),
            "{line}"
        );
        assert!(line.ends_with("sigma independent DOF errors"), "{line}");
        // Verified forecasts whose vertical errors were twice the claimed sigma double it.
        let mut verified = TipVerifier::new(tip, SigmaScale::adaptive(600.0, 50.0), 4);
        let mut history = crate::observed::MotionHistory::new(2.0, 60.0);
        for i in 0..60u64 {
            let t = i as f64 * 0.5;
            let mut still = Forecast {
                time_s: t,
                dt_s: 0.5,
                steps: 1,
                ..Forecast::default()
            };
            still.sigma[2][0] = 0.1;
            verified.push(&still);
            let mut dof = [0.0; 6];
            dof[2] = if i % 2 == 0 { 0.2 } else { -0.2 };
            history.push(&shipcast_wire::payload::MotionSample {
                seq: i + 1,
                stamp_ns: 0,
                time_s: t + 0.5,
                dof,
            });
            verified.verify_until(t + 0.5, &history);
        }
        tip_track(&point, f.dt_s, &verified, &mut track);
        assert!((track[0].sigma_m[2] - 0.2).abs() < 1e-6);
        assert!(track[0].sigma_calibrated && !track[1].sigma_calibrated);
        assert!(summary(&f, &track).ends_with("sigma partly calibrated"));
    }
}
