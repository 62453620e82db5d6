//! Verification of relative forecasts against what the two ships then did, the one path that
//! both the study (records) and the live service (each ship's motion over zenoh) take.
//!
//! Relative forecasts wait in issue order until both ships' observed motion reaches their last
//! step; then each is verified (its tip and spot displacements at every step fed to the sigma
//! calibration) or, if a step has no observed sample (a gap, a late start of the motion
//! stream), dropped as unverifiable. Only whole horizons are verified, so the calibration is
//! causal. Each verified forecast also teaches the lift decision ([`super::lift`]).

use super::calibrate::SigmaCalibration;
use super::lift::{LiftEvidence, LiftLimits};
use super::shrink::MeanShrinkage;
use super::still::{Ship, ShipsStillWatch};
use super::{point_displacement, Geometry, RelativeTrack};
use crate::config::RelativeConfig;
use crate::observed::ObservedMotion;
use crate::pending::PendingQueue;

/// Relative forecasts that may wait for their outcome: one per forecast value over the
/// longest horizon, four times over (forecasts arrive at most once per value).
pub const MAX_PENDING: usize = 4 * shipcast_wire::payload::MAX_STEPS;

/// Relative forecasts waiting for their outcome, and the calibration they feed.
#[derive(Debug)]
pub struct RelativeVerifier {
    /// Boxes of verified tracks are reused for the next ones (no allocation once warm).
    pending: PendingQueue<RelativeTrack>,
    tip: Vec<[f64; 3]>,
    spot: Vec<[f64; 3]>,
    pub calibration: SigmaCalibration,
    /// The relative mean's shrinkage towards no relative motion.
    pub shrinkage: MeanShrinkage,
    /// What the verified forecasts teach the lift decision.
    pub lift: LiftEvidence,
    /// The true relative displacement of the forecast being verified, per step.
    actual: Vec<[f64; 3]>,
    pub verified: u64,
    /// Both ships' frozen sensors ([`super::still`]), and the lift's statements as they were
    /// when the current stillness began.
    sensors: ShipsStillWatch,
    /// The calibration and shrinkage as they were before any forecast was verified: what a
    /// thaw starts them afresh from.
    fresh: Box<(SigmaCalibration, MeanShrinkage)>,
    statements_before_still: Option<crate::decision::recalibrate::StatementRecord>,
    /// Forecasts dropped unverified because a frozen sensor moved again while they waited.
    pub dropped_at_thaw: u64,
}

impl RelativeVerifier {
    /// The verifier of a configuration: its calibration's half-life and minimum, its lift
    /// limits and mean shrinkage.
    pub fn from_config(r: &RelativeConfig, max_pending: usize) -> Self {
        Self::new(
            SigmaCalibration::new(r.calibration_halflife, r.calibration_min_verified),
            MeanShrinkage::new(
                r.shrink_mean,
                r.calibration_halflife,
                r.calibration_min_verified,
            ),
            LiftLimits::new(r),
            max_pending,
        )
    }

    /// At most `max_pending` forecasts wait; the oldest beyond that are dropped. `lift`: the
    /// limits whose windows the lift statements are judged by.
    pub fn new(
        calibration: SigmaCalibration,
        shrinkage: MeanShrinkage,
        lift: LiftLimits,
        max_pending: usize,
    ) -> Self {
        Self {
            fresh: Box::new((calibration.clone(), shrinkage.clone())),
            pending: PendingQueue::new(max_pending),
            tip: Vec::with_capacity(shipcast_wire::payload::MAX_STEPS),
            spot: Vec::with_capacity(shipcast_wire::payload::MAX_STEPS),
            calibration,
            shrinkage,
            lift: LiftEvidence::new(lift),
            actual: Vec::with_capacity(shipcast_wire::payload::MAX_STEPS),
            verified: 0,
            sensors: ShipsStillWatch::default(),
            statements_before_still: None,
            dropped_at_thaw: 0,
        }
    }

    /// Watch both ships' sensors as the live service does: heave, roll and pitch taken as
    /// present ([`ShipsStillWatch::live`]).
    pub fn watching_live(mut self) -> Self {
        self.sensors = ShipsStillWatch::live();
        self
    }

    /// `ship`'s record is known to have these DOFs (a study knows its records' columns).
    pub fn set_present_dofs(&mut self, ship: Ship, dofs: &[shipcast_wire::Dof]) {
        self.sensors.set_present(ship, dofs);
    }

    /// Look at each ship's recorded values at its own forecast's origin (`times_s`: the crane's
    /// and the target's, [`ShipsStillWatch::observe`]) before the relative forecast of the two
    /// is decided ([`super::still`]): the lift's evidence learns which sensor is frozen now. At
    /// a thaw the verified errors go, the statements go back to those of before the stillness,
    /// the forecasts waiting for their horizon are dropped, and the sigma calibration and the
    /// mean's shrinkage start afresh (learnt while one ship's errors were those of nothing,
    /// they would leave the relative sigma too narrow after it).
    pub fn watch_sensors(
        &mut self,
        times_s: [f64; 2],
        crane: &impl ObservedMotion,
        target: &impl ObservedMotion,
    ) {
        if self.sensors.observe(times_s, crane, target) {
            let waiting = self.pending.len();
            tracing::warn!(
                "relative: a frozen sensor moves again at t={:.1}s; the verified relative \
                 errors, the sigma calibration, the lift statements verified since it stopped \
                 and the {waiting} forecasts waiting for their horizon are dropped, and go \
                 waits for new ones",
                times_s[0].max(times_s[1])
            );
            self.lift.ensemble.clear();
            if let Some(before) = self.statements_before_still.take() {
                self.lift.statements = before;
            }
            self.calibration.clone_from(&self.fresh.0);
            self.shrinkage.clone_from(&self.fresh.1);
            self.dropped_at_thaw += waiting as u64;
            self.pending.drop_all();
        }
        self.lift.frozen = self.sensors.frozen();
        // The statements as they are when a sensor is first found frozen (rare: the copy is no
        // burden on deciding). After a thaw with another sensor still frozen, the statements
        // just restored: that stillness goes back as far as the one that ended. Review: taken
        // at any stillness that began, a column absent from a record left a snapshot of its
        // first 30 s that the first real thaw went back to.
        if self.lift.frozen.is_some() && self.statements_before_still.is_none() {
            self.statements_before_still = Some(self.lift.statements.clone());
        }
    }

    /// Keep a copy of `track` until its outcome is known. A track with the same origin as the
    /// last one kept replaces it: live, a pair is combined again when the second vessel's
    /// forecast of that origin arrives, and one origin must count once in the calibration.
    pub fn push(&mut self, track: &RelativeTrack) {
        if let Some(last) = self.pending.back_mut() {
            if (last.alignment.time_s - track.alignment.time_s).abs() <= 1e-9 {
                last.clone_from(track);
                return;
            }
        }
        let mut slot = self.pending.slot();
        (*slot).clone_from(track);
        self.pending.push(slot);
    }

    /// Drops every waiting forecast as unverifiable: a ship's motion started a new run (its
    /// record time restarted), so no outcome on the old run's clock will come.
    pub fn drop_pending(&mut self) {
        self.pending.drop_all();
    }

    /// Forecasts dropped: a step without an observed sample, too many waiting, or a restart.
    pub fn unverifiable(&self) -> u64 {
        self.pending.dropped
    }

    /// Forecasts waiting.
    pub fn pending(&self) -> usize {
        self.pending.len()
    }

    /// Verifies, in issue order, every waiting forecast whose last step is at or before
    /// `observed_until_s` (the time up to which both ships' motion has been observed).
    pub fn verify_until(
        &mut self,
        observed_until_s: f64,
        geometry: &Geometry,
        a: &impl ObservedMotion,
        b: &impl ObservedMotion,
    ) {
        let end_s = |t: &RelativeTrack| t.alignment.time_s + t.steps() as f64 * t.dt_s;
        while let Some(old) = self.pending.pop_due(observed_until_s, end_s) {
            if observed(&old, geometry, a, b, &mut self.tip, &mut self.spot) {
                self.calibration
                    .observe(&old, &self.tip, &self.spot, &self.shrinkage);
                self.actual.clear();
                let relative = self.tip.iter().zip(&self.spot);
                self.actual
                    .extend(relative.map(|(t, s)| std::array::from_fn(|a| t[a] - s[a])));
                self.shrinkage.observe(&old, &self.actual);
                self.lift.learn(&old, &self.actual);
                self.verified += 1;
                self.pending.recycle(old);
            } else {
                self.pending.discard(old);
            }
        }
    }
}

/// The observed tip and spot displacements (A's axes) at every step of `track`, if all were
/// recorded.
pub fn observed(
    track: &RelativeTrack,
    geometry: &Geometry,
    a: &impl ObservedMotion,
    b: &impl ObservedMotion,
    tip: &mut Vec<[f64; 3]>,
    spot: &mut Vec<[f64; 3]>,
) -> bool {
    tip.clear();
    spot.clear();
    for k in 0..track.steps() {
        let (ta, tb) = track.alignment.step_times_s(k, track.dt_s);
        let (Some(da), Some(db)) = (a.dof_at(ta), b.dof_at(tb)) else {
            return false;
        };
        tip.push(point_displacement(&geometry.tip, 0.0, da));
        spot.push(point_displacement(
            &geometry.spot,
            geometry.target_heading_offset_rad,
            db,
        ));
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::observed::MotionHistory;
    use shipcast_wire::payload::{MotionSample, MAX_STEPS};

    fn at_rest(seq: u64, time_s: f64) -> MotionSample {
        MotionSample {
            seq,
            stamp_ns: 0,
            time_s,
            dof: [0.0; 6],
        }
    }

    /// A relative forecast of one step at origin `t` whose tip mean on z is `z`, with unit
    /// independent variance.
    fn track(t: f64, z: f64) -> RelativeTrack {
        let mut tr = RelativeTrack::default();
        tr.alignment.time_s = t;
        tr.alignment.steps = 1;
        tr.dt_s = 0.5;
        tr.tip.mean[2][0] = z;
        tr.tip.var[2][0] = 1.0;
        tr
    }

    #[test]
    fn forecasts_are_verified_once_both_ships_have_passed_them_and_an_origin_counts_once() {
        let geometry = Geometry::new([0.0; 3], &crate::config::RelativeConfig::default());
        let limits = LiftLimits::new(&crate::config::RelativeConfig::default());
        let mut v = RelativeVerifier::new(
            SigmaCalibration::new(f64::INFINITY, 1.0),
            MeanShrinkage::new(false, f64::INFINITY, 1.0),
            limits,
            8,
        );
        let (mut a, mut b) = (MotionHistory::new(8.0, 60.0), MotionHistory::new(8.0, 60.0));
        // The same origin twice (the second vessel's forecast came in): the later one stands.
        v.push(&track(1.0, 5.0));
        v.push(&track(1.0, 0.0));
        v.push(&track(1.5, 0.0));
        assert_eq!(v.pending(), 2);
        // Nothing observed yet: nothing verified.
        v.verify_until(f64::NEG_INFINITY, &geometry, &a, &b);
        assert_eq!((v.verified, v.unverifiable()), (0, 0));
        // Both ships still at rest when the steps come due (1.5 s and 2.0 s): errors of
        // zero. A's motion has passed 2.0 s, B's only 1.5 s: the second waits.
        for i in 0..=16 {
            a.push(&at_rest(i, i as f64 * 0.125));
        }
        for i in 0..=12 {
            b.push(&at_rest(i, i as f64 * 0.125));
        }
        let until = a.newest_s().unwrap().min(b.newest_s().unwrap());
        v.verify_until(until, &geometry, &a, &b);
        assert_eq!((v.verified, v.pending()), (1, 1));
        // Its errors joined the lift's ensemble (one verified forecast, kept at stride 4).
        assert_eq!(v.lift.ensemble.len(), 1);
        // Had the replaced forecast (tip mean 5) counted, the scale would be above 0.
        assert_eq!(v.calibration.scale(2, 0), Some(0.0));
        // B misses the sample at 2.0 s: that forecast cannot be verified and is dropped.
        b.push(&at_rest(18, 2.25));
        v.verify_until(2.25, &geometry, &a, &b);
        assert_eq!((v.verified, v.unverifiable(), v.pending()), (1, 1, 0));
        // Beyond `max_pending` the oldest is dropped.
        for i in 0..10 {
            v.push(&track(10.0 + i as f64, 0.0));
        }
        assert_eq!((v.pending(), v.unverifiable()), (8, 3));
        // A ship's producer started again: what waits was issued on the old run's clock.
        v.drop_pending();
        assert_eq!((v.pending(), v.unverifiable()), (0, 11));
    }

    /// Regression guard: the error the lift learns is (tip - spot) - forecast, the sense in
    /// which `fill` forecasts the relative motion. The other sense makes an exact forecast
    /// look like one that missed by twice its mean.
    #[test]
    fn the_lift_learns_the_error_of_tip_minus_spot() {
        let config = crate::config::RelativeConfig::default();
        let geometry = Geometry::new([0.0; 3], &config);
        let mut v = RelativeVerifier::new(
            SigmaCalibration::new(f64::INFINITY, 1.0),
            MeanShrinkage::new(false, f64::INFINITY, 1.0),
            LiftLimits::new(&config),
            8,
        );
        let (mut a, mut b) = (MotionHistory::new(8.0, 60.0), MotionHistory::new(8.0, 60.0));
        // A sits 1 m lower (heave is positive down), B at rest: the tip is 1 m below the
        // spot, relative z = +1 m, and the forecast said exactly that.
        for i in 0..=8 {
            let mut sample = at_rest(i, i as f64 * 0.125);
            sample.dof[2] = 1.0;
            a.push(&sample);
            b.push(&at_rest(i, i as f64 * 0.125));
        }
        let mut exact = track(0.0, 1.0);
        // The lift learns in the frame it decides in: the raw difference and its sigma.
        exact.raw_mean[2][0] = 1.0;
        exact.raw_sigma[2][0] = 1.0;
        v.push(&exact);
        v.verify_until(1.0, &geometry, &a, &b);
        assert_eq!((v.verified, v.lift.ensemble.len()), (1, 1));
        // Put on a forecast of no relative motion with sigma 1, the learnt error (0) keeps a
        // 0.5 m vertical limit; an error of -2 sigma (the wrong sense) would break it.
        let (mut mean, mut sigma) = ([[0.0; MAX_STEPS]; 3], [[0.0; MAX_STEPS]; 3]);
        sigma[2][0] = 1.0;
        mean[2][0] = 0.0;
        let (mut fail_before, mut usable) = (Vec::new(), Vec::new());
        v.lift.ensemble.failures(
            &mean,
            &sigma,
            &[10.0, 10.0, 0.5],
            1,
            &mut fail_before,
            &mut usable,
        );
        assert!(usable[0]);
        assert_eq!(fail_before[1], 0, "an exact forecast was learnt as a miss");
    }
}
