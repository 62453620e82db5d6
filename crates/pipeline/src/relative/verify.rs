//! Verification of relative forecasts against what the two ships then did, the one path that
//! both the study (records) and the live service (each ship's motion over zenoh) take.
//!
//! Relative forecasts wait in issue order until both ships' observed motion reaches their last
//! step; then each is verified (its tip and spot displacements at every step fed to the sigma
//! calibration) or, if a step has no observed sample (a gap, a late start of the motion
//! stream), dropped as unverifiable. Only whole horizons are verified, so the calibration is
//! causal.

use super::calibrate::SigmaCalibration;
use super::{point_displacement, Geometry, RelativeTrack};
use std::collections::VecDeque;

/// Relative forecasts that may wait for their outcome: one per forecast value over the
/// longest horizon, four times over (forecasts arrive at most once per value).
pub const MAX_PENDING: usize = 4 * shipcast_wire::payload::MAX_STEPS;

/// A ship's observed six DOF by record time.
pub trait ObservedMotion {
    /// The six DOF at record time `t`, if a sample was recorded there.
    fn dof_at(&self, t: f64) -> Option<[f64; 6]>;
}

/// The recent observed motion of one ship, received sample by sample (live). Holds the last
/// `keep_s` seconds of record time.
#[derive(Debug, Clone)]
pub struct MotionHistory {
    samples: VecDeque<(f64, [f64; 6])>,
    capacity: usize,
    keep_s: f64,
    /// Smallest spacing seen between two samples: lookups match within a quarter of it.
    step_s: f64,
}

impl MotionHistory {
    /// Keeps `keep_s` seconds; `capacity` samples are allocated up front.
    pub fn new(keep_s: f64, capacity: usize) -> Self {
        Self {
            samples: VecDeque::with_capacity(capacity.max(1)),
            capacity: capacity.max(1),
            keep_s,
            step_s: f64::INFINITY,
        }
    }

    /// Appends a sample; one not later than the newest is ignored (the gate refuses those).
    pub fn push(&mut self, time_s: f64, dof: [f64; 6]) {
        if let Some(&(last, _)) = self.samples.back() {
            // Also refuses a NaN time.
            if time_s.partial_cmp(&last) != Some(std::cmp::Ordering::Greater) {
                return;
            }
            self.step_s = self.step_s.min(time_s - last);
        }
        // Keeps the capacity it was given: the oldest go before the ring would grow.
        if self.samples.len() >= self.capacity {
            self.samples.pop_front();
        }
        self.samples.push_back((time_s, dof));
        while self
            .samples
            .front()
            .is_some_and(|&(t, _)| t < time_s - self.keep_s)
        {
            self.samples.pop_front();
        }
    }

    /// Record time of the newest sample.
    pub fn newest_s(&self) -> Option<f64> {
        self.samples.back().map(|&(t, _)| t)
    }

    pub fn len(&self) -> usize {
        self.samples.len()
    }

    pub fn is_empty(&self) -> bool {
        self.samples.is_empty()
    }
}

impl ObservedMotion for MotionHistory {
    fn dof_at(&self, t: f64) -> Option<[f64; 6]> {
        let tol = if self.step_s.is_finite() {
            0.25 * self.step_s
        } else {
            1e-9
        };
        let i = self.samples.partition_point(|&(x, _)| x < t - tol);
        self.samples
            .get(i)
            .filter(|&&(x, _)| (x - t).abs() <= tol)
            .map(|&(_, dof)| dof)
    }
}

/// Relative forecasts waiting for their outcome, and the calibration they feed.
#[derive(Debug)]
pub struct RelativeVerifier {
    pending: VecDeque<Box<RelativeTrack>>,
    /// Boxes of verified tracks, reused for the next ones (no allocation once warm).
    spare: Vec<Box<RelativeTrack>>,
    max_pending: usize,
    tip: Vec<[f64; 3]>,
    spot: Vec<[f64; 3]>,
    pub calibration: SigmaCalibration,
    pub verified: u64,
    /// Dropped: a step without an observed sample, or too many waiting.
    pub unverifiable: u64,
}

impl RelativeVerifier {
    /// At most `max_pending` forecasts wait; the oldest beyond that are dropped.
    pub fn new(calibration: SigmaCalibration, max_pending: usize) -> Self {
        let max_pending = max_pending.max(1);
        Self {
            pending: VecDeque::with_capacity(max_pending + 1),
            spare: Vec::with_capacity(max_pending + 1),
            max_pending,
            tip: Vec::with_capacity(shipcast_wire::payload::MAX_STEPS),
            spot: Vec::with_capacity(shipcast_wire::payload::MAX_STEPS),
            calibration,
            verified: 0,
            unverifiable: 0,
        }
    }

    /// Keep a copy of `track` until its outcome is known. A track with the same origin as the
    /// last one kept replaces it: live, a pair is combined again when the second vessel's
    /// forecast of that origin arrives, and one origin must count once in the calibration.
    pub fn push(&mut self, track: &RelativeTrack) {
        if let Some(last) = self.pending.back_mut() {
            if (last.alignment.time_s - track.alignment.time_s).abs() <= 1e-9 {
                (**last).clone_from(track);
                return;
            }
        }
        let mut slot = self.spare.pop().unwrap_or_default();
        (*slot).clone_from(track);
        self.pending.push_back(slot);
        while self.pending.len() > self.max_pending {
            if let Some(old) = self.pending.pop_front() {
                self.unverifiable += 1;
                self.spare.push(old);
            }
        }
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
        while let Some(old) = self.pending.front() {
            let end = old.alignment.time_s + old.steps() as f64 * old.dt_s;
            if end > observed_until_s + 1e-9 {
                break;
            }
            let Some(old) = self.pending.pop_front() else {
                break;
            };
            if observed(&old, geometry, a, b, &mut self.tip, &mut self.spot) {
                self.calibration.observe(&old, &self.tip, &self.spot);
                self.verified += 1;
            } else {
                self.unverifiable += 1;
            }
            self.spare.push(old);
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
        let t = track.alignment.time_s + (k + 1) as f64 * track.dt_s;
        let (Some(da), Some(db)) = (a.dof_at(t), b.dof_at(t)) else {
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
        let mut v = RelativeVerifier::new(SigmaCalibration::new(f64::INFINITY, 1.0), 8);
        let (mut a, mut b) = (MotionHistory::new(60.0, 256), MotionHistory::new(60.0, 256));
        // The same origin twice (the second vessel's forecast came in): the later one stands.
        v.push(&track(1.0, 5.0));
        v.push(&track(1.0, 0.0));
        v.push(&track(1.5, 0.0));
        assert_eq!(v.pending(), 2);
        // Nothing observed yet: nothing verified.
        v.verify_until(f64::NEG_INFINITY, &geometry, &a, &b);
        assert_eq!((v.verified, v.unverifiable), (0, 0));
        // Both ships still at rest when the steps come due (1.5 s and 2.0 s): errors of
        // zero. A's motion has passed 2.0 s, B's only 1.5 s: the second waits.
        for i in 0..=16 {
            a.push(i as f64 * 0.125, [0.0; 6]);
        }
        for i in 0..=12 {
            b.push(i as f64 * 0.125, [0.0; 6]);
        }
        let until = a.newest_s().unwrap().min(b.newest_s().unwrap());
        v.verify_until(until, &geometry, &a, &b);
        assert_eq!((v.verified, v.pending()), (1, 1));
        // Had the replaced forecast (tip mean 5) counted, the scale would be above 0.
        assert_eq!(v.calibration.scale(2, 0), Some(0.0));
        // B misses the sample at 2.0 s: that forecast cannot be verified and is dropped.
        b.push(2.25, [0.0; 6]);
        v.verify_until(2.25, &geometry, &a, &b);
        assert_eq!((v.verified, v.unverifiable, v.pending()), (1, 1, 0));
        // Beyond `max_pending` the oldest is dropped.
        for i in 0..10 {
            v.push(&track(10.0 + i as f64, 0.0));
        }
        assert_eq!((v.pending(), v.unverifiable), (8, 3));
    }

    #[test]
    fn history_finds_samples_by_time_and_forgets_the_old() {
        let mut h = MotionHistory::new(2.0, 64);
        assert_eq!(h.dof_at(0.0), None);
        for i in 0..40 {
            let t = i as f64 * 0.125;
            h.push(t, [t, 0.0, 0.0, 0.0, 0.0, 0.0]);
        }
        // Within a quarter of the spacing, not beyond.
        assert_eq!(h.dof_at(4.0).map(|d| d[0]), Some(4.0));
        assert_eq!(h.dof_at(4.02).map(|d| d[0]), Some(4.0));
        assert_eq!(h.dof_at(4.06), None);
        // 4.875 s is the newest; older than 2 s before it is gone.
        assert_eq!(h.newest_s(), Some(4.875));
        assert_eq!(h.dof_at(2.875).map(|d| d[0]), Some(2.875));
        assert_eq!(h.dof_at(2.75), None);
        // A sample out of order changes nothing.
        h.push(3.0, [9.0; 6]);
        assert_eq!(h.dof_at(3.0).map(|d| d[0]), Some(3.0));
        // The ring never grows past its capacity.
        let mut small = MotionHistory::new(100.0, 4);
        for i in 0..10 {
            small.push(i as f64, [0.0; 6]);
        }
        assert_eq!(small.len(), 4);
        assert_eq!(small.dof_at(5.0), None);
        assert!(small.dof_at(6.0).is_some());
    }
}
