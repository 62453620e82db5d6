//! Ship-to-ship relative motion: the forecast of a point on ship A (the crane tip) relative to a
//! point on ship B (the landing spot), from both ships' forecasts, with sigma, and a go/no-go
//! on the relative excursion limits (docs/two_ships.md).
//!
//! Kinematics (small, linearised rigid-body motion; docs/two_ships.md section "Kinematics"):
//! - A point at lever arm r from a ship's centre of gravity moves by
//!   d = (surge, sway, heave) + R(roll, pitch, yaw) r - r, in that ship's axes (the mean uses
//!   the exact rotation, [`ShipPoint::displacement`]). Its variance per axis is linearised,
//!   d = t + theta x r, with the six DOF errors of one ship taken as independent:
//!   var dx = s_surge^2 + (r_z s_pitch)^2 + (r_y s_yaw)^2,
//!   var dy = s_sway^2 + (r_z s_roll)^2 + (r_x s_yaw)^2,
//!   var dz = s_heave^2 + (r_y s_roll)^2 + (r_x s_pitch)^2.
//! - Ship B keeps station: its rest position and heading offset psi in A's axes are fixed. B's
//!   displacement is turned into A's axes by the rotation psi about z (down); the relative
//!   displacement (how the vector from the spot to the tip changes from rest) is
//!   d_A(tip) - R_z(psi) d_B(spot), in A's axes (x forward, y starboard, z down).
//! - Sigma: the errors of two ships in the same sea are correlated (the same unpredicted waves
//!   reach both), so sqrt(var_A + var_B) is only where sigma starts. [`calibrate`] scales it per
//!   axis and step by the ratio of the verified relative errors' mean square to the
//!   independent variance, from forecasts whose whole horizon has passed (causal); until
//!   enough are verified the independent sigma is used and the output says so.
//! - Mean: the difference of the two forecasts over-predicts where the two points move nearly
//!   together; [`shrink`] shrinks it per axis and step towards no relative motion by the
//!   least-squares factor of verified forecasts, so that it is not worse than predicting none.
//!
//! The two forecasts must share a clock (`time_s`: the simulator's record time in the two-ship
//! scenario, a common time base such as UTC for real ships). They are aligned on the later
//! origin: the older forecast's steps are shifted by the whole number of steps between them.

pub mod calibrate;
pub mod calls_csv;
pub mod lift;
pub mod shrink;
pub mod still;
pub mod study;
pub mod verify;

use crate::config::RelativeConfig;
use crate::deck::ShipPoint;
use calibrate::SigmaCalibration;
pub use lift::{LiftDecider, LiftDecision, LiftEvidence, LiftLimits};
use serde::{Deserialize, Serialize};
use shipcast_wire::payload::{Forecast, MAX_STEPS};
use shipcast_wire::Dof;
use shrink::MeanShrinkage;

/// Axes of every per-axis array here: x forward, y starboard, z down (A's axes).
pub const AXES: [&str; 3] = ["x", "y", "z"];

const SURGE: usize = Dof::Surge.index();
const SWAY: usize = Dof::Sway.index();
const HEAVE: usize = Dof::Heave.index();
const ROLL: usize = Dof::Roll.index();
const PITCH: usize = Dof::Pitch.index();
const YAW: usize = Dof::Yaw.index();

/// Where the two points are: the tip on A (A's axes), the spot on B (B's axes), B's station.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Geometry {
    pub tip: ShipPoint,
    pub spot: ShipPoint,
    /// B's centre of gravity forward and to starboard of A's [m].
    pub target_position_m: [f64; 2],
    /// B's bow turned this far to starboard of A's heading [rad].
    pub target_heading_offset_rad: f64,
}

impl Geometry {
    /// The geometry of a configuration: `tip_m` on the crane vessel, the rest from `relative`.
    pub fn new(tip_m: [f64; 3], relative: &RelativeConfig) -> Self {
        Self {
            tip: ShipPoint::new(tip_m),
            spot: ShipPoint::new(relative.landing_spot_m),
            target_position_m: relative.target_position_m,
            target_heading_offset_rad: relative.target_heading_offset_deg.to_radians(),
        }
    }

    /// The vector from the spot to the tip at rest, in A's axes [m].
    pub fn rest_m(&self) -> [f64; 3] {
        let spot = rotate_z(
            self.target_heading_offset_rad,
            self.spot.lever_arm.to_array(),
        );
        let t = self.tip.lever_arm;
        [
            t.x - self.target_position_m[0] - spot[0],
            t.y - self.target_position_m[1] - spot[1],
            t.z - spot[2],
        ]
    }
}

/// `v` given in axes turned `psi` to starboard, expressed in the unturned axes.
fn rotate_z(psi: f64, v: [f64; 3]) -> [f64; 3] {
    let (s, c) = psi.sin_cos();
    [c * v[0] - s * v[1], s * v[0] + c * v[1], v[2]]
}

/// Displacement of `point` for the ship's six DOF values, turned into A's axes by `psi`.
pub fn point_displacement(point: &ShipPoint, psi: f64, dof: [f64; 6]) -> [f64; 3] {
    rotate_z(psi, point.displacement(dof).to_array())
}

/// Linearised variance per axis of a point's displacement from the six DOF sigmas (independent
/// within one ship), in the ship's own axes, and the covariance of its x and y: with the lever
/// arm r, dx = surge + r_z pitch - r_y yaw and dy = sway + r_x yaw - r_z roll share the yaw,
/// so cov(dx, dy) = -r_x r_y var(yaw). A turn about z mixes x and y, and without it a spot
/// off both axes on a ship turned 45 deg, (10, 10) with a yaw sigma of 0.01 rad and nothing
/// else, had its x sigma 0.10 m where it is 0.14 m (review).
pub fn point_variance(point: &ShipPoint, sigma: [f64; 6]) -> ([f64; 3], f64) {
    let r = point.lever_arm;
    let v: [f64; 6] = sigma.map(|s| s * s);
    (
        [
            v[SURGE] + r.z * r.z * v[PITCH] + r.y * r.y * v[YAW],
            v[SWAY] + r.z * r.z * v[ROLL] + r.x * r.x * v[YAW],
            v[HEAVE] + r.y * r.y * v[ROLL] + r.x * r.x * v[PITCH],
        ],
        -r.x * r.y * v[YAW],
    )
}

/// A variance per axis and the x-y covariance given in axes turned `psi`, as variances per
/// axis in the unturned axes (x' = c x - s y, y' = s x + c y).
fn rotate_variance(psi: f64, (v, cov_xy): ([f64; 3], f64)) -> [f64; 3] {
    let (s, c) = psi.sin_cos();
    let cross = 2.0 * c * s * cov_xy;
    [
        (c * c * v[0] + s * s * v[1] - cross).max(0.0),
        (s * s * v[0] + c * c * v[1] + cross).max(0.0),
        v[2],
    ]
}

/// One point's predicted displacement and its variance per axis and step, in A's axes.
#[derive(Debug, Clone)]
pub struct PointTrack {
    pub steps: usize,
    pub mean: [[f64; MAX_STEPS]; 3],
    pub var: [[f64; MAX_STEPS]; 3],
}

impl Default for PointTrack {
    fn default() -> Self {
        Self {
            steps: 0,
            mean: [[0.0; MAX_STEPS]; 3],
            var: [[0.0; MAX_STEPS]; 3],
        }
    }
}

impl PointTrack {
    /// Steps `skip..skip + steps` of `forecast` for `point` on a ship turned `psi` from A.
    pub fn fill(
        &mut self,
        point: &ShipPoint,
        psi: f64,
        forecast: &Forecast,
        skip: usize,
        steps: usize,
    ) {
        self.steps = steps;
        for k in 0..steps {
            let j = k + skip;
            let dof: [f64; 6] = std::array::from_fn(|d| f64::from(forecast.mean[d][j]));
            let sigma: [f64; 6] = std::array::from_fn(|d| f64::from(forecast.sigma[d][j]));
            let m = point_displacement(point, psi, dof);
            let v = rotate_variance(psi, point_variance(point, sigma));
            for a in 0..3 {
                self.mean[a][k] = m[a];
                self.var[a][k] = v[a];
            }
        }
    }
}

/// How two forecasts line up on their shared clock.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Alignment {
    /// The later of the two origins: step k of the relative forecast is at time_s + (k+1) dt.
    pub time_s: f64,
    /// Steps of A's and B's forecast to skip.
    pub skip_a: usize,
    pub skip_b: usize,
    pub steps: usize,
    /// How far the older forecast's shifted steps are from the common step times [s]
    /// (at most half a step).
    pub misalignment_s: f64,
    /// A's origin is the later one (B's steps are the shifted ones).
    pub a_later: bool,
}

impl Alignment {
    /// Record times of A's and B's own step behind relative step `k` (steps of `dt_s`): the
    /// later ship's at time_s + (k + 1) dt, the older one's `misalignment_s` earlier. Each
    /// ship's motion is verified at its own step's time: on two sample grids out of phase,
    /// looking both up at the later ship's time missed every sample of the other (review).
    pub fn step_times_s(&self, k: usize, dt_s: f64) -> (f64, f64) {
        let t = self.time_s + (k + 1) as f64 * dt_s;
        let older = t - self.misalignment_s;
        if self.a_later {
            (t, older)
        } else {
            (older, t)
        }
    }
}

/// Why two forecasts cannot be combined.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum AlignError {
    #[error("the forecasts' steps differ ({0} s against {1} s)")]
    StepMismatch(f64, f64),
    #[error("the forecasts' origins are {0:.1} s apart, no step in common")]
    TooFarApart(f64),
    #[error(
        "{0} has sent no forecast while the other vessel's advanced {1:.1} s of record time \
         (more than {2:.1} s: predictor.stale_after_s, at least 4 forecast steps); it has \
         stopped or fallen behind"
    )]
    Stale(&'static str, f64, f64),
}

/// Whether two ships' latest forecasts are current enough to pair live: how far each ship's
/// forecasts advanced in record time since the other's latest arrived. Why: a vessel whose
/// predictor stopped leaves its last forecast behind, and [`align`] alone pairs every new
/// forecast of the other ship with it, its steps shifted, until the two no longer overlap: a
/// lift go stated from a forecast up to a horizon old, with a calibration learnt on pairs
/// issued together (review, 2026-12-06). The origins themselves are not compared: two
/// producers started a few seconds apart keep their record clocks that far apart for good.
#[derive(Debug, Clone, Default)]
pub struct PairCurrency {
    /// Per ship (0 the crane vessel, 1 the target): record time its forecasts advanced since
    /// the other's latest arrived [s], its latest origin, and whether the other's arrived
    /// since (the step to the next one then spans the other's arrival, and counts nothing:
    /// a vessel speaking again after a silence has not left the other behind).
    advanced_s: [f64; 2],
    last_s: [Option<f64>; 2],
    other_since: [bool; 2],
}

impl PairCurrency {
    /// A forecast of `ship` (0 the crane vessel, 1 the target) with origin `time_s` arrived.
    pub fn arrived(&mut self, ship: usize, time_s: f64) {
        let ship = ship.min(1);
        if let (Some(last), false) = (self.last_s[ship], self.other_since[ship]) {
            let step = time_s - last;
            // A clock that went back (a restarted producer) advances nothing.
            if step.is_finite() && step > 0.0 {
                self.advanced_s[ship] += step;
            }
        }
        self.last_s[ship] = Some(time_s);
        self.other_since[ship] = false;
        self.advanced_s[1 - ship] = 0.0;
        self.other_since[1 - ship] = true;
    }

    /// Ok while neither ship's forecasts advanced more than `max_s` past the other's latest.
    pub fn check(&self, max_s: f64) -> Result<(), AlignError> {
        for (ship, silent) in [(0, "the target vessel"), (1, "the crane vessel")] {
            if self.advanced_s[ship] > max_s {
                return Err(AlignError::Stale(silent, self.advanced_s[ship], max_s));
            }
        }
        Ok(())
    }
}

/// Aligns `a` and `b` on the later origin.
pub fn align(a: &Forecast, b: &Forecast) -> Result<Alignment, AlignError> {
    let dt = a.dt_s;
    if !(dt > 0.0 && (a.dt_s - b.dt_s).abs() <= 1e-9 * dt) {
        return Err(AlignError::StepMismatch(a.dt_s, b.dt_s));
    }
    let gap = a.time_s - b.time_s;
    let shift = (gap.abs() / dt).round();
    let misalignment_s = gap.abs() - shift * dt;
    let (skip_a, skip_b) = if gap >= 0.0 {
        (0, shift as usize)
    } else {
        (shift as usize, 0)
    };
    let steps_a = a.valid_steps().saturating_sub(skip_a);
    let steps_b = b.valid_steps().saturating_sub(skip_b);
    let steps = steps_a.min(steps_b);
    if !gap.is_finite() || steps == 0 {
        return Err(AlignError::TooFarApart(gap.abs()));
    }
    Ok(Alignment {
        time_s: a.time_s.max(b.time_s),
        skip_a,
        skip_b,
        steps,
        misalignment_s,
        a_later: gap >= 0.0,
    })
}

/// Where the relative sigma came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SigmaBasis {
    /// sqrt(var_A + var_B): the two ships' errors taken as independent (nothing verified yet).
    Independent,
    /// Scaled by verified relative errors (every step and axis had enough of them).
    Calibrated,
    /// Some steps or axes calibrated, the others independent.
    Partly,
}

/// The relative forecast of one pair of forecasts (work buffers included: reused, it does not
/// allocate).
#[derive(Debug, Clone)]
pub struct RelativeTrack {
    pub alignment: Alignment,
    pub dt_s: f64,
    /// Relative displacement of the tip from the spot, from rest, per axis and step [m]: the
    /// raw difference shrunk towards no relative motion ([`shrink`]).
    pub mean: [[f64; MAX_STEPS]; 3],
    /// The raw difference of the two points' forecasts, tip - spot, and the sigma calibrated
    /// on its errors: what the lift decides on ([`lift`]).
    pub raw_mean: [[f64; MAX_STEPS]; 3],
    pub raw_sigma: [[f64; MAX_STEPS]; 3],
    pub sigma: [[f64; MAX_STEPS]; 3],
    /// sqrt(var_A + var_B), what independence would give.
    pub sigma_independent: [[f64; MAX_STEPS]; 3],
    pub basis: SigmaBasis,
    pub tip: PointTrack,
    pub spot: PointTrack,
    /// The lift decision's uncorrected probability, when it came from verified errors
    /// (`LiftDecider::decide` notes it): verification records its outcome against it.
    pub lift_statement: Option<f64>,
}

impl Default for RelativeTrack {
    fn default() -> Self {
        Self {
            alignment: Alignment {
                time_s: 0.0,
                skip_a: 0,
                skip_b: 0,
                steps: 0,
                misalignment_s: 0.0,
                a_later: true,
            },
            dt_s: 0.0,
            mean: [[0.0; MAX_STEPS]; 3],
            raw_mean: [[0.0; MAX_STEPS]; 3],
            raw_sigma: [[0.0; MAX_STEPS]; 3],
            sigma: [[0.0; MAX_STEPS]; 3],
            sigma_independent: [[0.0; MAX_STEPS]; 3],
            basis: SigmaBasis::Independent,
            tip: PointTrack::default(),
            spot: PointTrack::default(),
            lift_statement: None,
        }
    }
}

impl RelativeTrack {
    pub fn steps(&self) -> usize {
        self.alignment.steps
    }

    /// Combines `a` (the crane vessel's forecast) and `b` (the target's) for `geometry`,
    /// the mean shrunk by `shrinkage` and sigma scaled by `calibration`.
    pub fn fill(
        &mut self,
        geometry: &Geometry,
        a: &Forecast,
        b: &Forecast,
        calibration: &SigmaCalibration,
        shrinkage: &MeanShrinkage,
    ) -> Result<(), AlignError> {
        let al = align(a, b)?;
        self.alignment = al;
        self.dt_s = a.dt_s;
        self.tip.fill(&geometry.tip, 0.0, a, al.skip_a, al.steps);
        self.spot.fill(
            &geometry.spot,
            geometry.target_heading_offset_rad,
            b,
            al.skip_b,
            al.steps,
        );
        let (mut scaled, mut total) = (0usize, 0usize);
        for axis in 0..3 {
            for k in 0..al.steps {
                let raw = self.tip.mean[axis][k] - self.spot.mean[axis][k];
                self.raw_mean[axis][k] = raw;
                self.mean[axis][k] = shrinkage.beta(axis, k) * raw;
                let independent = (self.tip.var[axis][k] + self.spot.var[axis][k]).sqrt();
                self.sigma_independent[axis][k] = independent;
                total += 1;
                self.sigma[axis][k] = match calibration.scale(axis, k) {
                    Some(s) => {
                        scaled += 1;
                        s * independent
                    }
                    None => independent,
                };
                self.raw_sigma[axis][k] =
                    calibration.scale_raw(axis, k).unwrap_or(1.0) * independent;
            }
        }
        self.basis = match scaled {
            0 => SigmaBasis::Independent,
            n if n == total => SigmaBasis::Calibrated,
            _ => SigmaBasis::Partly,
        };
        // A new forecast: no lift statement made on it yet.
        self.lift_statement = None;
        Ok(())
    }

    /// Horizontal distance of the relative mean from rest at step k [m].
    pub fn horizontal_m(&self, k: usize) -> f64 {
        self.mean[0][k].hypot(self.mean[1][k])
    }
}

/// The relative forecast as published on zenoh `.../advisory/relative` (JSON).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RelativeAdvisory {
    pub crane_vessel: String,
    pub target_vessel: String,
    pub crane_seq: u64,
    pub target_seq: u64,
    pub time_s: f64,
    pub dt_s: f64,
    pub misalignment_s: f64,
    /// Vector from the spot to the tip at rest, A's axes [m].
    pub rest_m: [f64; 3],
    /// Relative displacement per axis (x forward, y starboard, z down of the crane vessel)
    /// and step [m].
    pub mean_m: [Vec<f64>; 3],
    pub sigma_m: [Vec<f64>; 3],
    pub sigma_independent_m: [Vec<f64>; 3],
    pub sigma_basis: SigmaBasis,
    pub decision: LiftDecision,
}

impl RelativeAdvisory {
    /// One console line: the relative vertical motion (positive: tip rising away from the
    /// spot) at a few leads and the decision.
    pub fn summary(&self) -> String {
        let mut line = format!(
            "lift {}->{} t={:.1}s:",
            self.crane_vessel, self.target_vessel, self.time_s
        );
        for target in [5.0, 10.0, 20.0] {
            let k = ((target / self.dt_s).round() as usize).saturating_sub(1);
            if let (Some(m), Some(s)) = (self.mean_m[2].get(k), self.sigma_m[2].get(k)) {
                line.push_str(&format!(" +{target:.0}s up {:+.2}±{:.2} m", -m, s));
            }
        }
        let d = &self.decision;
        line.push_str(&format!(
            " | {} (MOT {:.0}s, {}), sigma {:?}",
            if d.go { "GO" } else { "NO-GO" },
            d.mot_s,
            match d.probability_now {
                Some(p) => format!("{:.0}%", 100.0 * p),
                None if d.frozen_dof.is_some() => format!(
                    "the {} vessel's {} sensor repeats its value",
                    d.frozen_ship.map_or("?", still::Ship::name),
                    d.frozen_dof.map_or("?", Dof::name)
                ),
                None if d.awaiting_verified_errors =>
                    "no probability before verified errors".into(),
                None => "MOT beyond the horizon".into(),
            },
            self.sigma_basis
        ));
        if let (false, Some(s), Some(p)) = (d.go, d.next_window_s, d.next_window_probability) {
            line.push_str(&format!(", next go window in {s:.1}s ({:.0}%)", 100.0 * p));
        }
        line
    }
}

/// Builds the advisory of `track` (allocates the published vectors).
pub fn advisory(
    track: &RelativeTrack,
    geometry: &Geometry,
    names: (&str, &str),
    seqs: (u64, u64),
    decision: LiftDecision,
) -> RelativeAdvisory {
    let n = track.steps();
    let per_axis = |v: &[[f64; MAX_STEPS]; 3]| std::array::from_fn(|a| v[a][..n].to_vec());
    RelativeAdvisory {
        crane_vessel: names.0.to_string(),
        target_vessel: names.1.to_string(),
        crane_seq: seqs.0,
        target_seq: seqs.1,
        time_s: track.alignment.time_s,
        dt_s: track.dt_s,
        misalignment_s: track.alignment.misalignment_s,
        rest_m: geometry.rest_m(),
        mean_m: per_axis(&track.mean),
        sigma_m: per_axis(&track.sigma),
        sigma_independent_m: per_axis(&track.sigma_independent),
        sigma_basis: track.basis,
        decision,
    }
}

#[cfg(test)]
mod tests;
