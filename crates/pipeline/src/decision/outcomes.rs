//! Outcomes of live decisions: a live service that decides on forecasts also receives the
//! motion samples, keeps the last horizon of them, and once a forecast's whole horizon has
//! happened hands the decider what really happened at its steps ([`Decider::verify`]): the
//! errors join its ensemble as replay's do from the record. Step k (1-based) of a forecast is
//! matched to the sample recorded at `time_s + k dt`, within a quarter of the input step.
//!
//! Buffers are sized once ([`Outcomes::new`]); pushing samples and decisions and verifying
//! them do not allocate.

use super::{Decider, ErrorCorrelation, Tracks, NUM_QUANTITIES};
use crate::observed::{MotionHistory, ObservedMotion};
use crate::transport::counters::SeqCheck;
use shipcast_wire::payload::{Forecast, MotionSample};
use std::collections::VecDeque;

/// A decision waiting for its horizon to happen: the forecast's time and its tracks (which
/// carry its steps and dt).
struct Waiting {
    time_s: f64,
    /// The recorded values at `time_s` the forecast was loaded with, if any.
    origin: Option<[f64; 6]>,
    predicted: Tracks,
    /// The decision's window length and uncorrected probability now, if from the ensemble.
    raw_now: Option<(usize, f64)>,
}

/// What became of the decisions handed to [`Outcomes`].
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct OutcomeCounts {
    /// Decisions verified against the motion.
    pub verified: u64,
    /// Dropped: a step had no sample (gap, late start, too many waiting, or the producer
    /// started a new run before the horizon had happened).
    pub unverifiable: u64,
    /// Producer runs seen start again (seq 0 after a run).
    #[serde(default)]
    pub restarts: u64,
    /// Motion samples not kept: a non-finite value, or seq or time not moving forward.
    #[serde(default)]
    pub rejected_samples: u64,
    /// Decisions dropped because they were made before a sensor moved again after repeating
    /// its value: their horizon is partly the stillness ([`Decider::takes_evidence_from`]).
    #[serde(default)]
    pub before_a_thaw: u64,
    /// Record time (`time_s`) of the newest verified decision: on which producer run's clock
    /// the deck verifies.
    #[serde(default)]
    pub newest_verified_s: Option<f64>,
}

pub struct Outcomes {
    samples: MotionHistory,
    waiting: VecDeque<Box<Waiting>>,
    spare: Vec<Box<Waiting>>,
    waiting_capacity: usize,
    actual: Box<Forecast>,
    actual_tracks: Box<Tracks>,
    /// `actual_tracks` with central velocity differences at its ends: what a window's
    /// outcome is judged on.
    judged_tracks: Box<Tracks>,
    /// The step-to-step correlation of the verified errors, which the decider's Gaussian
    /// model uses as replay's does (review: the live deck kept the configured one for good).
    correlation: ErrorCorrelation,
    pub counts: OutcomeCounts,
}

impl Outcomes {
    /// `input_rate_hz`: the motion samples' rate; `horizon_s`: the forecasts' horizon;
    /// `forecast_rate_hz`: how often forecasts arrive at most; `error_correlation`: the
    /// configured step-to-step correlation, used until verified errors estimate it.
    pub fn new(
        input_rate_hz: f64,
        horizon_s: f64,
        forecast_rate_hz: f64,
        error_correlation: [f64; NUM_QUANTITIES],
    ) -> Self {
        // A margin beyond the horizon: forecasts lag the newest sample (the decimation
        // filter's delay) and arrive a little after it.
        let span = horizon_s.max(0.0) + 10.0;
        let waiting_capacity = ((forecast_rate_hz.max(0.1) * span).ceil() as usize).clamp(4, 1024);
        let spare = (0..=waiting_capacity)
            .map(|_| {
                Box::new(Waiting {
                    time_s: f64::NAN,
                    origin: None,
                    predicted: Tracks::default(),
                    raw_now: None,
                })
            })
            .collect();
        Self {
            samples: MotionHistory::new(input_rate_hz, span),
            waiting: VecDeque::with_capacity(waiting_capacity + 1),
            spare,
            waiting_capacity,
            actual: Box::default(),
            actual_tracks: Box::default(),
            judged_tracks: Box::default(),
            correlation: ErrorCorrelation::new(error_correlation),
            counts: OutcomeCounts::default(),
        }
    }

    /// The correlation estimated from the errors verified so far.
    pub fn correlation(&self) -> &ErrorCorrelation {
        &self.correlation
    }

    /// A motion sample, judged as [`MotionHistory::push`] does (an older or non-finite one is
    /// not kept). A new producer run drops the decisions waiting on the old run's clock.
    pub fn push_sample(&mut self, sample: &MotionSample) -> SeqCheck {
        let verdict = self.samples.push(sample);
        if !verdict.is_accepted() {
            self.counts.rejected_samples += 1;
        }
        if verdict == SeqCheck::NewRun {
            self.counts.restarts += 1;
            self.counts.unverifiable += self.waiting.len() as u64;
            self.spare.extend(self.waiting.drain(..));
        }
        verdict
    }

    /// The recorded DOF values at record time `t` (at the precision of a forecast's values),
    /// if a sample stands for it: a forecast's origin ([`Decider::decide_from`]).
    pub fn recorded_at(&self, t: f64) -> Option<[f64; 6]> {
        self.samples
            .dof_at(t)
            .map(|dof| dof.map(|v| f64::from(v as f32)))
    }

    /// The forecast `decider` just decided on (its tracks are copied), to be verified once it
    /// has happened.
    pub fn push_decision(&mut self, forecast: &Forecast, decider: &Decider) {
        if self.waiting.len() >= self.waiting_capacity {
            if let Some(old) = self.waiting.pop_front() {
                self.counts.unverifiable += 1;
                self.spare.push(old);
            }
        }
        let Some(mut w) = self.spare.pop() else {
            return;
        };
        w.time_s = forecast.time_s;
        w.origin = decider.origin();
        w.predicted.clone_from(decider.tracks());
        w.raw_now = decider.raw_now();
        self.waiting.push_back(w);
    }

    /// Verify every waiting decision whose horizon the samples now cover.
    pub fn verify_ready(&mut self, decider: &mut Decider) {
        let Some(newest) = self.samples.newest_s() else {
            return;
        };
        while let Some(w) = self.waiting.front() {
            let end = w.time_s + w.predicted.steps as f64 * w.predicted.dt_s;
            // A forecast whose time is not finite never comes due: drop it now.
            if end.is_finite() && end > newest + self.samples.tolerance_s() {
                break;
            }
            let Some(w) = self.waiting.pop_front() else {
                break;
            };
            if !decider.takes_evidence_from(w.time_s) {
                self.counts.before_a_thaw += 1;
            } else if self.fill_actual(&w) {
                // The origin the forecast was decided with (the errors at its first step are
                // taken as its tracks were made), and the value past its horizon if here yet.
                let dt = w.predicted.dt_s;
                let after = self.recorded_at(w.time_s + (w.predicted.steps + 1) as f64 * dt);
                decider.fill_happened(
                    &self.actual,
                    w.origin.as_ref(),
                    after.as_ref(),
                    &mut self.actual_tracks,
                    &mut self.judged_tracks,
                );
                let steps = decider.verify(&w.predicted, &self.actual_tracks);
                for (q, u) in decider.verified_errors().iter().enumerate() {
                    self.correlation.add(q, &u[..steps]);
                }
                decider.set_error_correlation(self.correlation.rho());
                decider.set_error_matrices(&self.correlation, steps);
                if let Some((n, p)) = w.raw_now {
                    let held = decider.window_held(&self.judged_tracks, n);
                    decider.add_outcome(n, p, held);
                }
                self.counts.verified += 1;
                self.counts.newest_verified_s = Some(w.time_s);
            } else {
                self.counts.unverifiable += 1;
            }
            self.spare.push(w);
        }
    }

    /// The recorded motion at the steps of `w` into `self.actual`; false if a step has none.
    fn fill_actual(&mut self, w: &Waiting) -> bool {
        let (steps, dt_s) = (w.predicted.steps, w.predicted.dt_s);
        if !(w.time_s.is_finite() && dt_s > 0.0) {
            return false;
        }
        self.actual.time_s = w.time_s;
        self.actual.dt_s = dt_s;
        self.actual.steps = steps as u32;
        for k in 0..steps {
            let t = w.time_s + (k + 1) as f64 * dt_s;
            let Some(dof) = self.samples.dof_at(t) else {
                return false;
            };
            for (d, v) in dof.iter().enumerate() {
                self.actual.mean[d][k] = *v as f32;
            }
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::DeckConfig;
    use crate::decision::{ensemble, standardised_errors, standardised_means};
    use crate::deck::tests::forecast_with_roll;
    use shipcast_wire::payload::MAX_STEPS;
    use shipcast_wire::Dof;

    /// Roll of a slow swell [deg] sampled at 8 Hz; forecasts at 2 Hz whose mean is 0.8 of
    /// it, so the errors are not what the Gaussian model assumes.
    fn roll_deg(t: f64) -> f64 {
        2.2 * (t * std::f64::consts::TAU / 40.0).sin()
    }

    fn roll_at(t: f64) -> f64 {
        roll_deg(t).to_radians()
    }

    fn forecast_at(t0: f64) -> Forecast {
        let f = forecast_with_roll(
            50,
            |k| 0.8 * roll_deg(t0 + (k + 1) as f64 * 0.5),
            0.2f64.to_radians() as f32,
        );
        Forecast { time_s: t0, ..f }
    }

    fn sample(i: u64) -> MotionSample {
        let t = i as f64 / 8.0;
        let mut dof = [0.0; 6];
        dof[3] = roll_at(t);
        MotionSample {
            seq: i,
            stamp_ns: 0,
            time_s: t,
            dof,
        }
    }

    /// Outcomes of 8 Hz motion, a 25 s horizon and forecasts at 2 Hz, with the default deck's
    /// configured error correlation.
    fn outcomes_8_hz() -> Outcomes {
        Outcomes::new(8.0, 25.0, 2.0, DeckConfig::default().error_correlation)
    }

    /// The live path (samples in, outcomes found by time) teaches the decider exactly what
    /// the replay path (errors from the record, handed over once the horizon passed) does.
    #[test]
    fn live_outcomes_teach_the_same_as_replay() {
        let config = DeckConfig {
            point_m: [0.0; 3],
            ..DeckConfig::default()
        };
        let mut live = Decider::new(&config);
        let mut replay = Decider::new(&config);
        let mut outcomes = outcomes_8_hz();
        // As replay's scorer estimates the errors' correlation (decision/score.rs).
        let mut correlation = ErrorCorrelation::new(config.error_correlation);
        type Paths = Box<[[f64; MAX_STEPS]; 4]>;
        type Due = (f64, Paths, Paths, usize);
        let mut queue: VecDeque<Due> = VecDeque::new();
        let mut i = 0u64;
        let mut last = None;
        for step in 0..(2 * 600) {
            let t0 = step as f64 * 0.5;
            // The motion up to t0 arrives first.
            while (i as f64) / 8.0 <= t0 + 1e-9 {
                outcomes.push_sample(&sample(i));
                i += 1;
            }
            outcomes.verify_ready(&mut live);
            while queue.front().is_some_and(|q| q.0 <= t0) {
                if let Some((_, u, z, steps)) = queue.pop_front() {
                    replay.add_verified(&u, &z, steps);
                    for (q, u) in u.iter().enumerate() {
                        correlation.add(q, &u[..steps]);
                    }
                    replay.set_error_correlation(correlation.rho());
                }
            }
            let f = forecast_at(t0);
            let d_live = live.decide(&f);
            let d_replay = replay.decide(&f);
            assert_eq!(d_live, d_replay, "t0 {t0}");
            outcomes.push_decision(&f, &live);
            let mut truth = f;
            for k in 0..50 {
                truth.mean[3][k] = roll_at(t0 + (k + 1) as f64 * 0.5) as f32;
            }
            let mut actual = Tracks::default();
            replay.fill_tracks(&truth, &mut actual);
            let mut u = Box::new([[f64::NAN; MAX_STEPS]; 4]);
            let steps = standardised_errors(replay.tracks(), &actual, &mut u);
            let mut z = Box::new([[f64::NAN; MAX_STEPS]; 4]);
            standardised_means(replay.tracks(), &mut z);
            queue.push_back((t0 + 25.0, u, z, steps));
            last = Some(d_live);
        }
        assert!(outcomes.counts.verified > 1000, "{:?}", outcomes.counts);
        assert_eq!(outcomes.counts.unverifiable, 0);
        assert!(live.ensemble().len() >= ensemble::MIN_MEMBERS);
        // The last decision came from the ensemble of verified errors.
        let last = last.unwrap();
        assert_eq!(last.ensemble_members, live.ensemble().len(), "{last:?}");
        // Regression (review): the live deck kept the configured error correlation for good;
        // replay's estimated it from the verified errors.
        assert_eq!(live.error_correlation(), replay.error_correlation());
        assert_ne!(live.error_correlation(), config.error_correlation);
    }

    /// Regression (review): the decisions waiting for their horizon when a stuck sensor moved
    /// again were verified after the thaw had dropped the evidence of the stillness, so their
    /// errors and outcomes (partly of the stillness) were the first evidence of the new motion.
    #[test]
    fn decisions_waiting_at_a_thaw_are_not_evidence() {
        let mut decider = Decider::new(&DeckConfig::default());
        decider.set_present_dofs(&[Dof::Roll]);
        let mut outcomes = outcomes_8_hz();
        // Roll moves, repeats one value from 60 s, moves again from 120 s.
        let roll = |t: f64| {
            if (60.0..120.0).contains(&t) {
                roll_at(65.0)
            } else {
                roll_at(t)
            }
        };
        let mut i = 0u64;
        let (mut thaw_s, mut was_frozen) = (None, false);
        for step in 0..(2 * 200) {
            let t0 = step as f64 * 0.5;
            while (i as f64) / 8.0 <= t0 + 1e-9 {
                let mut s = sample(i);
                s.dof[3] = roll(s.time_s);
                outcomes.push_sample(&s);
                i += 1;
            }
            outcomes.verify_ready(&mut decider);
            let f = forecast_at(t0);
            let d = decider.decide_from(&f, outcomes.recorded_at(t0).as_ref());
            if was_frozen && d.frozen_dof.is_none() && thaw_s.is_none() {
                thaw_s = Some(t0);
            }
            was_frozen = d.frozen_dof.is_some();
            outcomes.push_decision(&f, &decider);
        }
        // The thaw is seen at the first forecast of the moving roll; the 49 decisions issued
        // in the 25 s before it were waiting and are dropped, those after it are verified.
        assert_eq!(thaw_s, Some(120.0));
        let c = outcomes.counts;
        assert_eq!(c.before_a_thaw, 49, "{c:?}");
        assert_eq!(c.unverifiable, 0, "{c:?}");
        let waiting = outcomes.waiting.len() as u64;
        assert_eq!(c.verified + c.before_a_thaw + waiting, 400, "{c:?}");
        assert!(decider.takes_evidence_from(120.0) && !decider.takes_evidence_from(119.5));
    }

    #[test]
    fn a_gap_in_the_motion_makes_a_decision_unverifiable() {
        let mut decider = Decider::new(&DeckConfig::default());
        let mut outcomes = outcomes_8_hz();
        let f = forecast_at(0.0);
        decider.decide(&f);
        outcomes.push_decision(&f, &decider);
        for i in (0..(8 * 30)).filter(|i| !(80..90).contains(i)) {
            outcomes.push_sample(&sample(i)); // 10 s .. 11.125 s missing
        }
        // Out of order and non-finite samples are not kept, and counted.
        outcomes.push_sample(&MotionSample {
            seq: 5,
            time_s: 1.0,
            ..MotionSample::default()
        });
        outcomes.push_sample(&MotionSample {
            time_s: f64::NAN,
            ..MotionSample::default()
        });
        outcomes.verify_ready(&mut decider);
        assert_eq!(
            outcomes.counts,
            OutcomeCounts {
                verified: 0,
                unverifiable: 1,
                restarts: 0,
                rejected_samples: 2,
                before_a_thaw: 0,
                newest_verified_s: None,
            }
        );
        assert!(decider.ensemble().is_empty());
    }

    #[test]
    fn a_forecast_with_a_non_finite_time_is_dropped_not_kept_forever() {
        let mut decider = Decider::new(&DeckConfig::default());
        let mut outcomes = outcomes_8_hz();
        let mut f = forecast_at(0.0);
        f.time_s = f64::NAN;
        outcomes.push_decision(&f, &decider);
        outcomes.push_sample(&sample(0));
        outcomes.verify_ready(&mut decider);
        assert_eq!(outcomes.counts.unverifiable, 1);
    }

    /// Regression: the producer restarted under a running deck (seq 0, time 0 again). The
    /// deck used to ignore the new run's samples until its time passed the old run's, and so
    /// verified nothing for that long.
    #[test]
    fn a_new_producer_run_drops_the_old_decisions_and_verifies_the_new_ones() {
        let mut decider = Decider::new(&DeckConfig::default());
        let mut outcomes = outcomes_8_hz();
        let f = forecast_at(20.0);
        decider.decide(&f);
        outcomes.push_decision(&f, &decider);
        for i in 0..(8 * 30) {
            outcomes.push_sample(&sample(i));
        }
        // The old run's decision at 20 s waits for 45 s; the run ends at 30 s.
        outcomes.verify_ready(&mut decider);
        assert_eq!(outcomes.counts, OutcomeCounts::default());
        assert_eq!(outcomes.push_sample(&sample(0)), SeqCheck::NewRun);
        assert_eq!(
            outcomes.counts,
            OutcomeCounts {
                verified: 0,
                unverifiable: 1,
                restarts: 1,
                rejected_samples: 0,
                before_a_thaw: 0,
                newest_verified_s: None,
            }
        );
        // On the new run's clock, a decision at 0 s is verified once 25 s have happened.
        let f = forecast_at(0.0);
        decider.decide(&f);
        outcomes.push_decision(&f, &decider);
        for i in 1..(8 * 26) {
            outcomes.push_sample(&sample(i));
        }
        outcomes.verify_ready(&mut decider);
        assert_eq!(outcomes.counts.verified, 1, "{:?}", outcomes.counts);
        assert_eq!(outcomes.counts.newest_verified_s, Some(0.0));
        assert_eq!(decider.ensemble().len(), 1);
    }
}
