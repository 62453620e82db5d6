//! Helideck landing advisory: the motion of a point on the ship from the six DOF (glam), and
//! the predicted windows in which roll, pitch and the deck point's vertical displacement and
//! velocity stay within limits, with the probability that they really do (from the forecast's
//! `sigma`).
//!
//! Axes and signs are the simulator's (x forward, y starboard, z down; roll positive starboard
//! down, pitch positive bow up); the advisory reports vertical motion positive UP, as a landing
//! officer reads it.

use crate::config::DeckConfig;
use crate::decision::{Decider, Decision};
use glam::{DQuat, DVec3, EulerRot};
use serde::{Deserialize, Serialize};
use shipcast_wire::payload::{Forecast, MAX_STEPS};
use shipcast_wire::Dof;

const HEAVE: usize = Dof::Heave.index();
const ROLL: usize = Dof::Roll.index();
const PITCH: usize = Dof::Pitch.index();

/// A point fixed on the ship, given from the centre of gravity in ship axes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShipPoint {
    pub lever_arm: DVec3,
}

impl ShipPoint {
    pub fn new(lever_arm_m: [f64; 3]) -> Self {
        Self {
            lever_arm: DVec3::from_array(lever_arm_m),
        }
    }

    /// Displacement of the point from its rest position for a ship attitude: translation
    /// (surge, sway, heave) plus the rotated lever arm (z-y-x Euler angles yaw, pitch, roll)
    /// minus the lever arm at rest.
    pub fn displacement(&self, dof: [f64; 6]) -> DVec3 {
        let rotation = DQuat::from_euler(EulerRot::ZYX, dof[5], dof[4], dof[3]);
        DVec3::new(dof[0], dof[1], dof[2]) + rotation * self.lever_arm - self.lever_arm
    }

    /// Standard deviation of the point's vertical position from independent heave, roll and
    /// pitch errors, linearised about level trim: dz = heave - x pitch + y roll.
    pub fn vertical_sigma(&self, heave: f64, roll: f64, pitch: f64) -> f64 {
        let r = self.lever_arm;
        (heave * heave + (r.x * pitch).powi(2) + (r.y * roll).powi(2)).sqrt()
    }
}

/// Vertical motion (positive up) of a ship point at every step of a forecast, with sigma.
/// Writes `steps` values into each buffer; returns `steps`.
pub fn vertical_track(
    point: &ShipPoint,
    forecast: &Forecast,
    z_up: &mut [f64; MAX_STEPS],
    z_sigma: &mut [f64; MAX_STEPS],
) -> usize {
    let steps = forecast.valid_steps();
    for k in 0..steps {
        let dof: [f64; 6] = std::array::from_fn(|d| forecast.mean[d][k] as f64);
        z_up[k] = -point.displacement(dof).z;
        z_sigma[k] = point.vertical_sigma(
            forecast.sigma[HEAVE][k] as f64,
            forecast.sigma[ROLL][k] as f64,
            forecast.sigma[PITCH][k] as f64,
        );
    }
    steps
}

/// A predicted landing window, in seconds after the forecast's `time_s`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Window {
    pub start_s: f64,
    pub end_s: f64,
    /// Probability that every limit holds at the window's least likely step, assuming Gaussian
    /// forecast errors with the forecast's sigma: an upper bound of the probability that the
    /// whole window holds, which the advisory's `decision` states.
    pub confidence: f64,
}

/// The advisory issued for one forecast (JSON on `.../advisory/deck`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Advisory {
    pub forecast_seq: u64,
    pub model_version: u32,
    /// Record time the windows are counted from.
    pub time_s: f64,
    /// Predicted maxima over the horizon: |roll| [deg], |pitch| [deg], |vertical velocity| [m/s].
    pub max_roll_deg: f64,
    pub max_pitch_deg: f64,
    pub max_vertical_velocity_mps: f64,
    pub windows: Vec<Window>,
    /// Go/no-go over the minimum operation time, with the joint window probability.
    pub decision: Decision,
}

impl Advisory {
    /// One line for the console.
    pub fn summary(&self) -> String {
        // A window's confidence is its least likely step's probability: an upper bound of the
        // probability that the whole window holds (the decision's figure), so it is shown as
        // one, never beside the decision as if it were the same thing.
        let windows = if self.windows.is_empty() {
            "none".to_string()
        } else {
            self.windows
                .iter()
                .map(|w| {
                    format!(
                        "{:.1}-{:.1}s (at most {:.0}%)",
                        w.start_s,
                        w.end_s,
                        100.0 * w.confidence
                    )
                })
                .collect::<Vec<_>>()
                .join(", ")
        };
        format!(
            "deck t={:.1}s v{}: {}; max roll {:.1} deg pitch {:.1} deg vz {:.2} m/s; mean within limits: {windows}",
            self.time_s,
            self.model_version,
            self.decision.summary(),
            self.max_roll_deg,
            self.max_pitch_deg,
            self.max_vertical_velocity_mps
        )
    }
}

/// Turns forecasts into advisories; holds its work buffers so that `advise` allocates only the
/// (short) window list.
pub struct DeckAdvisor {
    point: ShipPoint,
    roll_limit: f64,
    pitch_limit: f64,
    velocity_limit: f64,
    displacement_limit: f64,
    min_window_s: f64,
    decider: Decider,
    z_up: [f64; MAX_STEPS],
    z_sigma: [f64; MAX_STEPS],
}

impl DeckAdvisor {
    pub fn new(config: &DeckConfig) -> Self {
        Self {
            point: ShipPoint::new(config.point_m),
            roll_limit: config.roll_limit_deg.to_radians(),
            pitch_limit: config.pitch_limit_deg.to_radians(),
            velocity_limit: config.vertical_velocity_limit_mps,
            displacement_limit: config.vertical_displacement_limit_m,
            min_window_s: config.min_window_s,
            decider: Decider::new(config),
            z_up: [0.0; MAX_STEPS],
            z_sigma: [0.0; MAX_STEPS],
        }
    }

    /// Vertical velocity (up) and its sigma at step k by differences over the forecast steps.
    /// The sigma assumes independent errors at the two steps: conservative, since forecast
    /// errors of neighbouring steps are correlated.
    /// The deck point's vertical velocity and its sigma at step `k`: a central difference,
    /// at the first step from `origin_z` (the recorded value at `time_s`, exact) if given.
    fn velocity(&self, k: usize, steps: usize, dt: f64, origin_z: Option<f64>) -> (f64, f64) {
        if let (0, Some(z0), true) = (k, origin_z, steps > 1) {
            let span = 2.0 * dt;
            return ((self.z_up[1] - z0) / span, self.z_sigma[1] / span);
        }
        let (a, b) = match (k.checked_sub(1), k + 1 < steps) {
            (Some(a), true) => (a, k + 1),
            (None, true) => (k, k + 1),
            (Some(a), false) => (a, k),
            (None, false) => return (0.0, 0.0),
        };
        let span = (b - a) as f64 * dt;
        let v = (self.z_up[b] - self.z_up[a]) / span;
        let s = self.z_sigma[b].hypot(self.z_sigma[a]) / span;
        (v, s)
    }

    /// The advisor of the live deck service: heave, roll and pitch are taken as present in
    /// the motion it verifies against, so one that never moves is a frozen sensor. A producer
    /// sends 0 for a column its record lacks, and a deck deciding on a roll of 0 that was never
    /// measured would call go on a calm deck that never was (replay does not score a deck
    /// without those columns, for the same reason).
    pub fn live(config: &DeckConfig) -> Self {
        let mut advisor = Self::new(config);
        advisor
            .decider
            .set_present_dofs(&crate::decision::still::WATCHED);
        advisor
    }

    /// The decider behind the advisory's `decision` (to verify its forecasts).
    pub fn decider(&self) -> &Decider {
        &self.decider
    }

    pub fn decider_mut(&mut self) -> &mut Decider {
        &mut self.decider
    }

    pub fn advise(&mut self, forecast: &Forecast) -> Advisory {
        self.advise_from(forecast, None)
    }

    /// [`Self::advise`], deciding with the recorded values at the forecast's `time_s`
    /// (`origin`, when the deck has them: [`Decider::decide_from`]).
    pub fn advise_from(&mut self, forecast: &Forecast, origin: Option<&[f64; 6]>) -> Advisory {
        let steps = vertical_track(&self.point, forecast, &mut self.z_up, &mut self.z_sigma);
        let dt = forecast.dt_s;
        let mut advisory = Advisory {
            forecast_seq: forecast.seq,
            model_version: forecast.model_version,
            time_s: forecast.time_s,
            max_roll_deg: 0.0,
            max_pitch_deg: 0.0,
            max_vertical_velocity_mps: 0.0,
            windows: Vec::new(),
            decision: self.decider.decide_from(forecast, origin),
        };
        // The same first step as the decision's (`Tracks::central_ends`).
        let origin_z = origin.map(|dof| -self.point.displacement(*dof).z);
        let mut open: Option<(usize, f64)> = None;
        for k in 0..=steps {
            let step_ok = if k < steps {
                let roll = forecast.mean[ROLL][k] as f64;
                let pitch = forecast.mean[PITCH][k] as f64;
                let (v, v_sigma) = self.velocity(k, steps, dt, origin_z);
                advisory.max_roll_deg = advisory.max_roll_deg.max(roll.abs().to_degrees());
                advisory.max_pitch_deg = advisory.max_pitch_deg.max(pitch.abs().to_degrees());
                advisory.max_vertical_velocity_mps =
                    advisory.max_vertical_velocity_mps.max(v.abs());
                // Every limit the decision judges (regression, review: the displacement's was
                // left out, and a deck 3 m up showed its whole horizon within limits).
                let z = self.z_up[k];
                let within = roll.abs() <= self.roll_limit
                    && pitch.abs() <= self.pitch_limit
                    && z.abs() <= self.displacement_limit
                    && v.abs() <= self.velocity_limit;
                within.then(|| {
                    prob_within(roll, forecast.sigma[ROLL][k] as f64, self.roll_limit)
                        * prob_within(pitch, forecast.sigma[PITCH][k] as f64, self.pitch_limit)
                        * prob_within(z, self.z_sigma[k], self.displacement_limit)
                        * prob_within(v, v_sigma, self.velocity_limit)
                })
            } else {
                None
            };
            match (step_ok, open) {
                (Some(p), None) => open = Some((k, p)),
                (Some(p), Some((start, q))) => open = Some((start, q.min(p))),
                (None, Some((start, confidence))) => {
                    // Step k (0-based) is at time (k + 1) * dt; the window spans its steps.
                    let window = Window {
                        start_s: (start + 1) as f64 * dt,
                        end_s: k as f64 * dt,
                        confidence,
                    };
                    if window.end_s - window.start_s >= self.min_window_s {
                        advisory.windows.push(window);
                    }
                    open = None;
                }
                (None, None) => {}
            }
        }
        advisory
    }
}

/// P(|X| <= limit) for X ~ N(mean, sigma^2); a zero sigma means certainty. An unknown (NaN)
/// sigma or mean gives 0: nothing known is no licence for a go.
pub fn prob_within(mean: f64, sigma: f64, limit: f64) -> f64 {
    if sigma.is_nan() || mean.is_nan() {
        return 0.0;
    }
    if sigma <= 0.0 {
        return if mean.abs() <= limit { 1.0 } else { 0.0 };
    }
    (normal_cdf((limit - mean) / sigma) - normal_cdf((-limit - mean) / sigma)).clamp(0.0, 1.0)
}

/// Standard normal CDF via erfc (Abramowitz & Stegun 7.1.26, |error| < 1.5e-7).
pub fn normal_cdf(x: f64) -> f64 {
    let z = x.abs() / std::f64::consts::SQRT_2;
    let t = 1.0 / (1.0 + 0.3275911 * z);
    let poly = t
        * (0.254829592
            + t * (-0.284496736 + t * (1.421413741 + t * (-1.453152027 + t * 1.061405429))));
    let erfc = poly * (-z * z).exp();
    if x >= 0.0 {
        1.0 - 0.5 * erfc
    } else {
        0.5 * erfc
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    #[test]
    fn point_displacement_matches_small_angle_geometry() {
        let p = ShipPoint::new([-60.0, 5.0, -4.0]);
        // Pure heave moves every point the same.
        let d = p.displacement([0.0, 0.0, 1.5, 0.0, 0.0, 0.0]);
        assert!((d - DVec3::new(0.0, 0.0, 1.5)).length() < 1e-12);
        // Bow up (pitch > 0) lowers the stern: z (down) grows by -x * pitch.
        let pitch = 0.01;
        let d = p.displacement([0.0, 0.0, 0.0, 0.0, pitch, 0.0]);
        assert!((d.z - 60.0 * pitch).abs() < 1e-3, "{d}");
        // Starboard down (roll > 0) lowers a starboard point: z grows by y * roll.
        let roll = 0.02;
        let d = p.displacement([0.0, 0.0, 0.0, roll, 0.0, 0.0]);
        assert!((d.z - 5.0 * roll).abs() < 1e-3, "{d}");
        // Rotation keeps the lever arm's length (exact, not small-angle).
        let d = p.displacement([0.0, 0.0, 0.0, 0.3, -0.2, 0.5]);
        assert!(((p.lever_arm + d).length() - p.lever_arm.length()).abs() < 1e-9);
    }

    #[test]
    fn normal_cdf_and_probabilities() {
        assert!((normal_cdf(0.0) - 0.5).abs() < 1e-7);
        assert!((normal_cdf(1.959964) - 0.975).abs() < 1e-6);
        assert!((normal_cdf(-1.0) - 0.158655).abs() < 1e-6);
        assert!((prob_within(0.0, 1.0, 1.0) - 0.682689).abs() < 1e-6);
        assert_eq!(prob_within(0.5, 0.0, 1.0), 1.0);
        assert_eq!(prob_within(1.5, 0.0, 1.0), 0.0);
        // Unknown is not certain: a NaN sigma or mean never reads as "within".
        assert_eq!(prob_within(0.0, f64::NAN, 1.0), 0.0);
        assert_eq!(prob_within(f64::NAN, 0.1, 1.0), 0.0);
    }

    /// A forecast at 2 Hz with roll following `roll_deg(k)`, everything else still, and the
    /// same sigma on every DOF (also the decision tests' fixture).
    pub(crate) fn forecast_with_roll(
        steps: usize,
        roll_deg: impl Fn(usize) -> f64,
        sigma: f32,
    ) -> Forecast {
        let mut f = Forecast {
            seq: 3,
            time_s: 100.0,
            dt_s: 0.5,
            steps: steps as u32,
            model_version: 2,
            ..Forecast::default()
        };
        for k in 0..steps {
            f.mean[ROLL][k] = roll_deg(k).to_radians() as f32;
            for d in 0..6 {
                f.sigma[d][k] = sigma;
            }
        }
        f
    }

    #[test]
    fn the_live_deck_takes_a_roll_that_never_moves_for_a_frozen_sensor() {
        let config = DeckConfig {
            go_needs_verified_errors: false,
            ..DeckConfig::default()
        };
        let quiet = |time_s: f64| Forecast {
            time_s,
            ..forecast_with_roll(40, |_| 0.5, 1e-3)
        };
        // Heave moves; roll and pitch are 0 throughout (a producer without those columns).
        let origin = |t: f64| [0.0, 0.0, 0.001 * (0.8 * t).sin(), 0.0, 0.0, 0.0];
        let (mut live, mut plain) = (DeckAdvisor::live(&config), DeckAdvisor::new(&config));
        for i in 0..200 {
            let t = 0.5 * i as f64;
            let (a, b) = (
                live.advise_from(&quiet(t), Some(&origin(t))),
                plain.advise_from(&quiet(t), Some(&origin(t))),
            );
            // The library's advisor, not told the columns, takes them as absent.
            assert!(b.decision.go && b.decision.frozen_dof.is_none(), "t={t}");
            let frozen = t >= crate::decision::still::STILL_AFTER_S;
            assert_eq!(a.decision.frozen_dof.is_some(), frozen, "t={t}");
            assert_eq!(a.decision.go, !frozen, "t={t}");
        }
    }

    #[test]
    fn windows_are_the_runs_within_limits() {
        let config = DeckConfig {
            point_m: [0.0, 0.0, 0.0],
            min_window_s: 1.0,
            ..DeckConfig::default()
        };
        let mut advisor = DeckAdvisor::new(&config);
        // Roll 5 deg for steps 0..4, 1 deg for 4..14, 5 deg after: one window, steps 4..=13.
        let f = forecast_with_roll(20, |k| if (4..14).contains(&k) { 1.0 } else { 5.0 }, 0.0);
        let a = advisor.advise(&f);
        assert_eq!(a.windows.len(), 1, "{a:?}");
        let w = a.windows[0];
        assert_eq!((w.start_s, w.end_s), (2.5, 7.0));
        assert_eq!(w.confidence, 1.0);
        assert!((a.max_roll_deg - 5.0).abs() < 1e-4);
        assert!(
            a.summary()
                .contains("mean within limits: 2.5-7.0s (at most 100%)"),
            "{}",
            a.summary()
        );
        // Uncertain forecasts lower the confidence; a short window is not reported.
        let f = forecast_with_roll(20, |k| if (4..14).contains(&k) { 1.0 } else { 5.0 }, 0.02);
        let c = advisor.advise(&f).windows[0].confidence;
        assert!(c > 0.0 && c < 1.0, "{c}");
        let f = forecast_with_roll(20, |k| if k == 5 { 1.0 } else { 5.0 }, 0.0);
        assert!(advisor.advise(&f).windows.is_empty());
    }

    #[test]
    fn a_deck_beyond_its_displacement_limit_has_no_window() {
        // Heave 3 m up (z down) against the 2 m limit, roll and pitch 0: no step is within
        // every limit the decision judges.
        let config = DeckConfig {
            point_m: [0.0, 0.0, 0.0],
            min_window_s: 1.0,
            ..DeckConfig::default()
        };
        let mut advisor = DeckAdvisor::new(&config);
        let mut windows = |heave_up_m: f32| {
            let mut f = forecast_with_roll(20, |_| 0.0, 0.0);
            f.mean[HEAVE][..20].fill(-heave_up_m);
            advisor.advise(&f).windows
        };
        assert!(windows(3.0).is_empty());
        // Within the limit: the whole horizon.
        assert_eq!(windows(1.5).len(), 1);
    }

    #[test]
    fn fast_deck_motion_closes_the_window() {
        // The stern heaves with pitch: a pitch ramp of 0.5 deg per step at 62 m aft gives
        // 62 * 0.5 deg / 0.5 s = 1.08 m/s vertical velocity, above the 1 m/s limit, while
        // pitch itself stays within 1.5 deg for the first steps.
        let config = DeckConfig::default();
        let mut advisor = DeckAdvisor::new(&config);
        let mut f = forecast_with_roll(6, |_| 0.0, 0.0);
        for k in 0..6 {
            f.mean[PITCH][k] = ((k as f64 - 2.5) * 0.5).to_radians() as f32;
        }
        let a = advisor.advise(&f);
        assert!(a.max_vertical_velocity_mps > 1.0, "{a:?}");
        assert!(a.windows.is_empty(), "{a:?}");
    }

    /// With the recorded motion at `time_s`, the advisory's first-step velocity is the central
    /// difference, as its decision's is (one-sided, it was the velocity 0.25 s later).
    #[test]
    fn the_advisory_takes_the_first_steps_velocity_from_the_origin() {
        let config = DeckConfig {
            point_m: [0.0; 3],
            ..DeckConfig::default()
        };
        let mut advisor = DeckAdvisor::new(&config);
        // Heave (5 - t)^2 at t = 0.5, 1.0, ..., 5.0: its speed 2 (5 - t) is largest first.
        let mut f = forecast_with_roll(10, |_| 0.0, 0.0);
        for k in 0..10 {
            let t = 0.5 * (k + 1) as f64;
            f.mean[HEAVE][k] = ((5.0 - t) * (5.0 - t)) as f32;
        }
        let one_sided = advisor.advise(&f).max_vertical_velocity_mps;
        assert!((one_sided - 8.5).abs() < 1e-5, "{one_sided}");
        let mut origin = [0.0; 6];
        origin[HEAVE] = 25.0;
        let central = advisor
            .advise_from(&f, Some(&origin))
            .max_vertical_velocity_mps;
        assert!((central - 9.0).abs() < 1e-5, "{central}");
    }
}
