//! When the engine retrains and what it does with the result: the first fit on live data, the
//! scheduled refits, retrains after a change of sea (on the new sea alone while the window
//! still reaches before it) and after a model failed, and whether a finished retrain replaces
//! the running models (`retrain::replaces`).

use super::*;

impl Engine {
    /// A change of sea moves every DOF: once at least half of those that move (have errors to
    /// watch) have detected one within the detector's memory, the history before is another
    /// sea, and retrains fit and judge on the values from now on (`schedule_retrain`). One DOF
    /// alone (a wave group that stretched its errors, measured on the Gullfaks record) is only
    /// recalibrated. Later detections of the same change (a sea still growing) do not move the
    /// start: the held-out part is always the newest values, so the newest sea judges anyway,
    /// and waiting for the last detection delayed the first refit by minutes.
    pub(super) fn note_change_of_sea(&mut self) {
        if self.changed_at.is_some() {
            return;
        }
        let now = self.values;
        let memory = CHANGE_MEMORY as u64;
        let agreeing = self
            .change_seen_at
            .iter()
            .filter(|at| at.is_some_and(|a| a + memory >= now))
            .count();
        let moving = (0..NUM_DOF)
            .filter(|&d| self.change.has_evidence(d))
            .count();
        if agreeing >= moving.div_ceil(2).max(1) {
            self.changed_at = Some(now);
            self.sea_since = Some(now);
        }
    }

    /// Pick up a finished retrain; it replaces the running models only where it scored better
    /// on the newest data. A DOF whose model failed and that the retrain did not replace (it
    /// failed, it could not score that DOF, it had another horizon) asks for another, on the
    /// failures' backoff: it would otherwise wait on no skill for the next scheduled retrain.
    pub(super) fn take_models(&mut self) {
        let Some(result) = self.retrainer.take() else {
            return;
        };
        self.use_outcome(result);
        if self.failed.dof.contains(&true) {
            self.failed.unhandled = true;
        }
    }

    pub(super) fn use_outcome(&mut self, result: Result<retrain::Outcome, String>) {
        let outcome = match result {
            Ok(outcome) => outcome,
            Err(e) => {
                // The running models stay; the next scheduled retrain tries again.
                self.counts.retrain_failures += 1;
                tracing::warn!(
                    failures = self.counts.retrain_failures,
                    "predictor: retraining failed: {e}"
                );
                return;
            }
        };
        self.counts.retrains += 1;
        // Numbered when it is installed, not when it was asked for: a retrained model the
        // running one outscores must not use up a version (the contract: one more at every
        // model put in use). Regression (review): versions skipped after a kept model.
        let mut new = outcome.set;
        new.version = self.model_version() + 1;
        let Some(running) = self.models.as_ref() else {
            tracing::info!(
                version = new.version,
                models = %new.describe(),
                held_out_score = new.mean_score(),
                seconds = outcome.seconds,
                "predictor: first model fitted on live data in use"
            );
            self.counts.swaps += 1;
            self.install(new);
            return;
        };
        if running.horizon() != new.horizon() {
            tracing::warn!("predictor: retrained model has another horizon: ignored");
            return;
        }
        let (better, new_score, running_score) =
            replaces(&outcome.new_score, &outcome.running_score, &self.failed.dof);
        tracing::info!(
            reason = outcome.reason,
            new_score,
            running_score,
            held_out_score = new.mean_score(),
            seconds = outcome.seconds,
            "predictor: retrained on live history ({}); {}",
            new.describe(),
            if better {
                "the new model replaces the running one"
            } else {
                "the running model scores better and stays"
            }
        );
        if better {
            self.counts.swaps += 1;
            self.install(new);
        } else {
            self.counts.kept_running += 1;
        }
    }

    /// Values of the sea since the latest change of sea that a retrain on the newest `take`
    /// values fits on alone beside the whole window (`models::fit_recent`); None when the
    /// window holds no older sea, or the new values are too few to fit and score on alone.
    pub(super) fn new_sea_values(&self, take: usize) -> Option<usize> {
        let q = &self.config;
        self.sea_since
            .map(|at| usize::try_from(self.values - at).unwrap_or(usize::MAX))
            .filter(|&n| n < take && models::window_fits(q, n))
    }

    /// Ask for a retrain when one is due: the first after `first_fit_s` of live data, then
    /// every `retrain_every_s`, or at once when the sea changed (the one place that copies
    /// history).
    pub(super) fn schedule_retrain(&mut self) {
        let q = &self.config;
        // A jump not yet judged is about to move the history: no retrain copies it now.
        if q.retrain_every_s <= 0.0 || self.jumps.unjudged() {
            return;
        }
        let rate = q.sample_rate_hz;
        let len = self.ingest.len() as u64;
        let first = (q.first_fit_s * rate).round() as u64;
        // At least one value: 0 would mean never (the configuration refuses such periods).
        let every = ((q.retrain_every_s * rate).round() as u64).max(1);
        // After a change of sea (until the values since then fill three held-out parts, from
        // when on the held-out part is the configured one again), every retrain judges on the
        // new sea only (`models::fit_recent`), and refits come every CHANGE_REFIT_EVERY_S of
        // record time once `first` new values are held: while the new sea's data are few,
        // each minute of them improves the fit markedly. (Refitting each time they had
        // doubled left the sea-state change's surge, heave and pitch 23 minutes from their new
        // level on six seeds, against 14-21 now; docs/results/replay_study.md.) In the service
        // a refit still running when the next is due makes that one wait.
        let end = q.retrain_window.min(3 * q.holdout) as u64;
        let change_every = ((CHANGE_REFIT_EVERY_S * rate).round() as u64).max(1);
        let since_change = self.changed_at.map(|at| self.values - at);
        if since_change.is_some_and(|n| n >= end) {
            self.changed_at = None;
        }
        let since_change = since_change.filter(|&n| n < end);
        let take = self.ingest.len().min(q.retrain_window);
        if self
            .sea_since
            .is_some_and(|at| self.values - at >= take as u64)
        {
            // The window holds the new sea only: it is this sea's history again.
            self.sea_since = None;
        }
        let reason = match (self.retrain_due, self.last_fit_at, since_change) {
            (Some(r), _, _) => Some(r),
            (None, None, _) if len >= first.max(1) => Some("first fit on live data"),
            (None, Some(at), Some(n)) => (n >= first.max(1) && self.values >= at + change_every)
                .then_some("refit on the changed sea"),
            (None, Some(at), None) if every > 0 && self.values >= at + every => Some("scheduled"),
            _ => None,
        };
        let Some(reason) = reason else { return };
        // A retrain for a failure waits out the backoff after the previous one.
        if reason == REASON_MODEL_FAILED
            && self.failed.retrain_at.is_some_and(|at| {
                self.values - at < failure_gap(self.failed.streak, self.longest_input())
            })
        {
            return;
        }
        // The new sea's values, for as long as the window also holds older ones (after the
        // first minutes as well: the default window spans almost three hours, and fits on the
        // whole window alone carried the old sea along; on 3-hour course-change records the
        // pitch and yaw NRMSE at 20 s went from 0.967-0.998 to 0.956-0.988 with this,
        // docs/results/replay_study.md). Too few new values to fit and score anything on them
        // alone (the retrain at the detection itself): judged on the whole window, as without
        // a change.
        let recent = self.new_sea_values(take);
        // Checked before copying the history: while a fit is still running, or the data allow
        // no order yet, a due retrain waits without copying anything on every value.
        if !self.retrainer.is_ready()
            || !models::any_feasible_order(q, take, models::holdout_within(q, take, recent))
        {
            return;
        }
        let Some(series) = (0..NUM_DOF)
            .map(|d| self.ingest.last(d, take).map(<[f64]>::to_vec))
            .collect::<Option<Vec<_>>>()
        else {
            return;
        };
        let job = Job {
            series,
            version: self.model_version() + 1,
            running: self.models.clone(),
            recent,
            reason,
            end: self.values,
        };
        if self.retrainer.request(job) {
            if reason == REASON_MODEL_FAILED {
                self.failed.streak = next_streak(&self.failed, self.longest_input());
                self.failed.retrain_at = Some(self.values);
            }
            self.last_fit_at = Some(self.values);
            self.retrain_due = None;
            // An inline retrain is done already: use it for this very forecast.
            self.take_models();
        }
    }
}
