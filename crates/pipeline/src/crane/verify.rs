//! Verification of the crane tip's forecasts against the ship's observed motion, and the
//! calibration of the tip's sigma it feeds.
//!
//! The tip's sigma is linearised from the ship's six DOF sigmas with the DOF errors taken as
//! independent (`relative::point_variance`). They are not: the same unpredicted waves drive
//! sway and roll, heave and pitch. Scored on the paper sea (`scripts/two_ship_study.py`, the
//! default tip 15 m to starboard and 20 m up), that sigma covered 54-57 % of the tip's errors
//! across within +-1 sigma (86-88 % within +-2), and a point 8 m to port and 6 m up 60-64 % of
//! its vertical errors. So, as for the relative sigma, each axis and step of the tip's sigma is
//! scaled by the verified forecasts' standardised squared errors ([`SigmaScale`]).
//!
//! Forecasts wait in issue order until the ship's motion reaches their last step; a forecast
//! with a step no sample covers (a gap, a late start of the motion stream) is dropped as
//! unverifiable. Once warm it does not allocate: tracks are boxed once and reused.

use crate::deck::ShipPoint;
use crate::observed::ObservedMotion;
use crate::pending::PendingQueue;
use crate::relative::{point_displacement, PointTrack};
use crate::sigma_scale::SigmaScale;
use shipcast_wire::payload::{Forecast, MAX_STEPS};

/// Forecasts that may wait for their outcome: four per step of the longest horizon.
pub const MAX_PENDING: usize = 4 * MAX_STEPS;

/// One issued tip forecast waiting for its outcome.
#[derive(Debug, Clone, Default)]
struct Pending {
    time_s: f64,
    dt_s: f64,
    track: PointTrack,
}

/// The tip's forecasts waiting for their outcome, and the scale on the tip's sigma they teach.
#[derive(Debug)]
pub struct TipVerifier {
    tip: ShipPoint,
    pending: PendingQueue<Pending>,
    pub scale: SigmaScale,
    pub verified: u64,
}

impl TipVerifier {
    /// Verifies forecasts of `tip` into `scale`; at most `max_pending` wait (the oldest beyond
    /// that are dropped).
    pub fn new(tip: ShipPoint, scale: SigmaScale, max_pending: usize) -> Self {
        Self {
            tip,
            pending: PendingQueue::new(max_pending),
            scale,
            verified: 0,
        }
    }

    /// Keeps the tip's track of `forecast` until its outcome is known.
    pub fn push(&mut self, forecast: &Forecast) {
        let mut slot = self.pending.slot();
        slot.track
            .fill(&self.tip, 0.0, forecast, 0, forecast.valid_steps());
        self.queue(slot, forecast.time_s, forecast.dt_s);
    }

    /// Keeps `track`, the tip's track of the forecast issued at `time_s` with step `dt_s`
    /// (already computed by the caller, as `shipcast crane` does for its console line), until
    /// its outcome is known.
    pub fn push_track(&mut self, time_s: f64, dt_s: f64, track: &PointTrack) {
        let mut slot = self.pending.slot();
        slot.track.clone_from(track);
        self.queue(slot, time_s, dt_s);
    }

    fn queue(&mut self, mut slot: Box<Pending>, time_s: f64, dt_s: f64) {
        slot.time_s = time_s;
        slot.dt_s = dt_s;
        self.pending.push(slot);
    }

    /// Drops every waiting forecast as unverifiable: the ship's motion started a new run.
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
    /// `observed_until_s` (the newest observed sample's record time).
    pub fn verify_until(&mut self, observed_until_s: f64, motion: &impl ObservedMotion) {
        let end_s = |p: &Pending| p.time_s + p.track.steps as f64 * p.dt_s;
        while let Some(old) = self.pending.pop_due(observed_until_s, end_s) {
            let steps = old.track.steps.min(MAX_STEPS);
            let mut actual = [[0.0; 3]; MAX_STEPS];
            let complete = (0..steps).all(|k| {
                let t = old.time_s + (k + 1) as f64 * old.dt_s;
                motion.dof_at(t).is_some_and(|dof| {
                    actual[k] = point_displacement(&self.tip, 0.0, dof);
                    true
                })
            });
            if complete {
                let track = &old.track;
                self.scale.observe(steps, |axis, k| {
                    (actual[k][axis] - track.mean[axis][k], track.var[axis][k])
                });
                self.verified += 1;
                self.pending.recycle(old);
            } else {
                self.pending.discard(old);
            }
        }
    }

    /// The tip's sigma on `axis` at step `k` for the linearised variance `var`: scaled once
    /// enough forecasts are verified (true), else the independent one (false).
    pub fn sigma(&self, axis: usize, k: usize, var: f64) -> (f64, bool) {
        let independent = var.max(0.0).sqrt();
        match self.scale.scale(axis, k) {
            Some(s) => (s * independent, true),
            None => (independent, false),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::observed::MotionHistory;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, StandardNormal};
    use shipcast_wire::payload::MotionSample;
    use shipcast_wire::Dof;

    fn normal(rng: &mut ChaCha8Rng) -> f64 {
        StandardNormal.sample(rng)
    }

    /// A forecast of one step at `t` predicting rest, with DOF sigmas `sway` and `roll`.
    fn still(t: f64, sway: f32, roll: f32) -> Forecast {
        let mut f = Forecast {
            time_s: t,
            dt_s: 0.125,
            steps: 1,
            ..Forecast::default()
        };
        f.sigma[Dof::Sway.index()][0] = sway;
        f.sigma[Dof::Roll.index()][0] = roll;
        f
    }

    #[test]
    fn correlated_sway_and_roll_errors_widen_the_tip_sigma_across_to_what_happened() {
        // A tip 20 m above the CG moves across by sway + L roll to first order, |L| = 20 m.
        // Sway and roll errors of sigma 0.1 m and 0.005 rad, correlated 0.8 in the sense that
        // adds (the sign of L), give a tip error across of variance 0.01 + 0.01 + 2 * 0.8 *
        // 0.01 = 0.036, where independence says 0.02.
        let tip = ShipPoint::new([0.0, 0.0, -20.0]);
        let mut unit_roll = [0.0; 6];
        unit_roll[Dof::Roll.index()] = 1e-6;
        let lever = point_displacement(&tip, 0.0, unit_roll)[1] / 1e-6;
        assert!((lever.abs() - 20.0).abs() < 1e-3, "{lever}");
        let rho = 0.8 * lever.signum();
        let mut v = TipVerifier::new(tip, SigmaScale::new(f64::INFINITY, 100.0), 8);
        let mut history = MotionHistory::new(8.0, 60.0);
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let (mut expect, mut n) = (0.0, 0.0);
        for i in 0..20_000u64 {
            let t = i as f64 * 0.125;
            v.push(&still(t, 0.1, 0.005));
            let (z1, z2) = (normal(&mut rng), normal(&mut rng));
            let sway = 0.1 * z1;
            let roll = 0.005 * (rho * z1 + 0.6 * z2);
            let mut dof = [0.0; 6];
            dof[Dof::Sway.index()] = sway;
            dof[Dof::Roll.index()] = roll;
            history.push(&MotionSample {
                seq: i + 1,
                stamp_ns: 0,
                time_s: t + 0.125,
                dof,
            });
            v.verify_until(t + 0.125, &history);
            let e = point_displacement(&tip, 0.0, dof)[1];
            expect += e * e;
            n += 1.0;
        }
        assert_eq!((v.verified, v.unverifiable()), (20_000, 0));
        let var = 0.1f64.powi(2) + (20.0f64 * 0.005).powi(2);
        let (sigma, calibrated) = v.sigma(1, 0, var);
        assert!(calibrated);
        // The scaled sigma is the RMS of the errors that happened (0.036 in variance).
        let rms = (expect / n).sqrt();
        assert!((sigma - rms).abs() < 0.01 * rms, "{sigma} against {rms}");
        assert!((sigma - 0.036f64.sqrt()).abs() < 0.03 * sigma, "{sigma}");
        // Vertically the forecasts claimed no variance: no standardised error was counted, so
        // there is no scale, and a zero sigma stays zero.
        assert_eq!(v.scale.scale(2, 0), None);
        assert_eq!(v.sigma(2, 0, 0.0), (0.0, false));
    }

    #[test]
    fn forecasts_wait_for_their_steps_and_gaps_make_them_unverifiable() {
        let tip = ShipPoint::new([10.0, 15.0, -20.0]);
        let mut v = TipVerifier::new(tip, SigmaScale::new(f64::INFINITY, 1.0), 3);
        let mut history = MotionHistory::new(8.0, 60.0);
        let (sigma, calibrated) = v.sigma(2, 0, 0.04);
        assert_eq!((sigma, calibrated), (0.2, false));
        v.push(&still(1.0, 0.1, 0.0));
        // Not observed yet: it waits.
        v.verify_until(1.0, &history);
        assert_eq!((v.verified, v.pending()), (0, 1));
        // Observed up to its step, but the sample at 1.125 s is missing: unverifiable.
        for (i, t) in [0.875, 1.0, 1.25].into_iter().enumerate() {
            history.push(&MotionSample {
                seq: i as u64 + 1,
                stamp_ns: 0,
                time_s: t,
                dof: [0.0; 6],
            });
        }
        v.verify_until(1.25, &history);
        assert_eq!((v.verified, v.unverifiable(), v.pending()), (0, 1, 0));
        // Beyond `max_pending` the oldest are dropped; a restart drops what waits.
        for i in 0..5 {
            v.push(&still(10.0 + f64::from(i), 0.1, 0.0));
        }
        assert_eq!((v.pending(), v.unverifiable()), (3, 3));
        v.drop_pending();
        assert_eq!((v.pending(), v.unverifiable()), (0, 6));
    }
}
