//! A vessel's observed motion as a live consumer keeps it to verify forecasts against: the
//! last seconds of motion samples, looked up by record time. The deck (its decisions'
//! outcomes) and the relative service (both ships' motion) keep it with this one type, and the
//! studies look records up through the same [`ObservedMotion`] trait.
//!
//! Samples are judged by [`SeqTracker`] as they arrive. A producer that starts again (seq 0
//! after a run) begins a new record whose times restart: the history forgets the old run, so
//! lookups never mix two runs' clocks and verification goes on at once instead of waiting
//! for the new run's time to pass the old one's.

use crate::transport::counters::{SeqCheck, SeqTracker};
use shipcast_wire::payload::{MotionSample, NUM_DOF};
use std::collections::VecDeque;

/// A ship's observed six DOF by record time.
pub trait ObservedMotion {
    /// The six DOF at record time `t`, if a sample was recorded there.
    fn dof_at(&self, t: f64) -> Option<[f64; NUM_DOF]>;
}

/// Whether a sample recorded at `s` stands for record time `t`, i.e. lies within `tol` of it.
/// Callers find the candidate with `partition_point` (the first sample not before `t - tol`).
pub fn matches(s: f64, t: f64, tol: f64) -> bool {
    (s - t).abs() <= tol
}

/// The recent observed motion of one ship, received sample by sample. Holds the last
/// `keep_s` seconds of the current producer run, in a ring allocated once.
#[derive(Debug, Clone)]
pub struct MotionHistory {
    samples: VecDeque<(f64, [f64; NUM_DOF])>,
    capacity: usize,
    keep_s: f64,
    /// Lookups match a sample within a quarter of the configured input step.
    tol_s: f64,
    order: SeqTracker,
}

impl MotionHistory {
    /// Keeps `keep_s` seconds of samples arriving at `input_rate_hz` (the producer's rate).
    pub fn new(input_rate_hz: f64, keep_s: f64) -> Self {
        let rate = if input_rate_hz.is_finite() && input_rate_hz > 0.0 {
            input_rate_hz
        } else {
            1.0
        };
        let keep_s = keep_s.max(0.0);
        // Room for half as many again as the rate implies: a producer a little faster than
        // configured must not push out samples still within `keep_s`.
        let capacity = ((rate * keep_s * 1.5).ceil() as usize + 16).min(1 << 20);
        Self {
            samples: VecDeque::with_capacity(capacity),
            capacity,
            keep_s,
            tol_s: 0.25 / rate,
            order: SeqTracker::new(),
        }
    }

    /// Judges `sample` and keeps it if it is accepted. On [`SeqCheck::NewRun`] the previous
    /// run's samples are forgotten first; a non-finite sample, or one whose seq or time does
    /// not move forward, is not kept.
    pub fn push(&mut self, sample: &MotionSample) -> SeqCheck {
        let verdict = self.order.check(sample);
        match verdict {
            SeqCheck::NewRun => self.samples.clear(),
            SeqCheck::Accepted { .. } => {}
            SeqCheck::BadValue | SeqCheck::OutOfOrder => return verdict,
        }
        if self.samples.len() >= self.capacity {
            self.samples.pop_front();
        }
        let time_s = sample.time_s;
        self.samples.push_back((time_s, sample.dof));
        while self
            .samples
            .front()
            .is_some_and(|&(t, _)| t < time_s - self.keep_s)
        {
            self.samples.pop_front();
        }
        verdict
    }

    /// Forgets every sample and the run they came from: the next sample starts afresh,
    /// whatever its seq (a new publisher of the motion).
    pub fn clear(&mut self) {
        self.samples.clear();
        self.order = SeqTracker::new();
    }

    /// Record time of the newest sample.
    pub fn newest_s(&self) -> Option<f64> {
        self.samples.back().map(|&(t, _)| t)
    }

    /// Half the lookup tolerance's width: a quarter of the input step.
    pub fn tolerance_s(&self) -> f64 {
        self.tol_s
    }

    pub fn len(&self) -> usize {
        self.samples.len()
    }

    pub fn is_empty(&self) -> bool {
        self.samples.is_empty()
    }
}

impl ObservedMotion for MotionHistory {
    fn dof_at(&self, t: f64) -> Option<[f64; NUM_DOF]> {
        let tol = self.tol_s;
        let i = self.samples.partition_point(|&(s, _)| s < t - tol);
        self.samples
            .get(i)
            .filter(|&&(s, _)| matches(s, t, tol))
            .map(|&(_, dof)| dof)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(seq: u64, time_s: f64, x: f64) -> MotionSample {
        MotionSample {
            seq,
            stamp_ns: 0,
            time_s,
            dof: [x, 0.0, 0.0, 0.0, 0.0, 0.0],
        }
    }

    #[test]
    fn history_finds_samples_by_time_and_forgets_the_old() {
        let mut h = MotionHistory::new(8.0, 2.0);
        assert_eq!(h.dof_at(0.0), None);
        for i in 0..40 {
            let t = i as f64 * 0.125;
            assert!(h.push(&sample(i, t, t)).is_accepted());
        }
        // Within a quarter of the configured step (1/32 s), not beyond.
        assert_eq!(h.dof_at(4.0).map(|d| d[0]), Some(4.0));
        assert_eq!(h.dof_at(4.03).map(|d| d[0]), Some(4.0));
        assert_eq!(h.dof_at(4.04), None);
        // 4.875 s is the newest; older than 2 s before it is gone.
        assert_eq!(h.newest_s(), Some(4.875));
        assert_eq!(h.dof_at(2.875).map(|d| d[0]), Some(2.875));
        assert_eq!(h.dof_at(2.75), None);
        // A sample out of order, or not finite, changes nothing.
        assert_eq!(h.push(&sample(20, 3.0, 9.0)), SeqCheck::OutOfOrder);
        assert_eq!(h.push(&sample(41, f64::NAN, 9.0)), SeqCheck::BadValue);
        assert_eq!(h.dof_at(3.0).map(|d| d[0]), Some(3.0));
        // The ring never grows past what the rate implies: samples ten times faster than
        // configured fill 4 s with 40, and fewer are kept, the newest.
        let mut fast = MotionHistory::new(1.0, 4.0);
        for i in 0..100 {
            fast.push(&sample(i, i as f64 / 10.0, 0.0));
        }
        assert!(fast.len() < 40, "{}", fast.len());
        assert_eq!(fast.newest_s(), Some(9.9));
        assert_eq!(fast.dof_at(6.0), None);
    }

    /// Regression: a producer restarted under a running consumer starts again at seq 0 and
    /// time 0. The consumer used to refuse those samples until the new run's time passed the
    /// old one's, and so stopped verifying.
    #[test]
    fn a_new_producer_run_replaces_the_old_one_at_once() {
        let mut h = MotionHistory::new(8.0, 60.0);
        for i in 0..400 {
            h.push(&sample(i, i as f64 / 8.0, 1.0));
        }
        assert_eq!(h.push(&sample(0, 0.0, 2.0)), SeqCheck::NewRun);
        assert_eq!(h.len(), 1);
        assert_eq!(h.newest_s(), Some(0.0));
        assert_eq!(h.dof_at(0.0).map(|d| d[0]), Some(2.0));
        // The old run's times are no longer found...
        assert_eq!(h.dof_at(40.0), None);
        // ...and the new run goes on being kept.
        assert!(h.push(&sample(1, 0.125, 2.0)).is_accepted());
        assert_eq!(h.dof_at(0.125).map(|d| d[0]), Some(2.0));
        // A new publisher (cleared) may start anywhere in its run.
        h.clear();
        assert!(h.is_empty());
        assert!(h.push(&sample(500, 62.5, 3.0)).is_accepted());
        assert_eq!(h.dof_at(62.5).map(|d| d[0]), Some(3.0));
    }

    #[test]
    fn lookups_match_only_within_the_tolerance() {
        // Samples at 0, 1, 2, 3 s (input rate 1 Hz, so the tolerance is 0.25 s).
        let mut h = MotionHistory::new(1.0, 10.0);
        for i in 0..4 {
            assert!(h.push(&sample(i, i as f64, i as f64)).is_accepted());
        }
        let at = |t| h.dof_at(t).map(|d| d[0]);
        assert_eq!(at(-0.3), None);
        assert_eq!(at(-0.2), Some(0.0));
        assert_eq!(at(1.1), Some(1.0));
        assert_eq!(at(1.5), None);
        assert_eq!(at(3.25), Some(3.0));
        assert_eq!(at(3.3), None);
        assert_eq!(at(f64::NAN), None);
        assert_eq!(MotionHistory::new(1.0, 10.0).dof_at(0.0), None);
        assert!(matches(1.0, 1.25, 0.25) && !matches(1.0, 1.26, 0.25));
    }
}
