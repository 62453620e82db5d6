//! Retraining: the engine hands over a copy of the recent history and the running models; the
//! new fit and both scores on the newest data come back. In the service this runs on its own
//! thread, so fitting never delays a forecast; `shipcast replay` runs it inline, so a replay is
//! deterministic.

use super::models::{self, ModelSet};
use crate::config::PredictorServiceConfig;
use shipcast_wire::payload::NUM_DOF;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, Receiver, SyncSender, TrySendError};
use std::sync::Arc;
use std::time::Instant;

/// Does a new model set (scores `new`, per DOF) replace the running one (`running`), and
/// the two mean scores over the DOF compared? Only DOF both can be scored on count: a DOF
/// absent from the record or constant scores NaN for both (0 / 0), and summed in, it made
/// every retrain replace the running set. A DOF only the new set can be scored on (the
/// running one could not forecast it, or has too long an order for the data) makes the new
/// set replace it, as before; so does one whose running model `failed`, whatever it scored
/// (`failures::FailedModels`): that DOF would otherwise stay on no skill until a retrain
/// happened to score better on the others.
pub fn replaces(
    new: &[f64; NUM_DOF],
    running: &[f64; NUM_DOF],
    failed: &[bool; NUM_DOF],
) -> (bool, f64, f64) {
    let mut compared = 0;
    let (mut new_total, mut running_total) = (0.0, 0.0);
    let mut only_new = false;
    for ((n, r), failed) in new.iter().zip(running).zip(failed) {
        match (n.is_finite(), r.is_finite() && !failed) {
            (true, true) => {
                compared += 1;
                new_total += n;
                running_total += r;
            }
            (true, false) => only_new = true,
            _ => {}
        }
    }
    let mean = |total: f64| match compared {
        0 => f64::NAN,
        n => total / n as f64,
    };
    let better = only_new || compared == 0 || running_total > new_total;
    (better, mean(new_total), mean(running_total))
}

/// What a retrain is asked to do.
pub struct Job {
    pub series: Vec<Vec<f64>>,
    pub version: u32,
    /// The running models, scored on the same newest data as the new fit.
    pub running: Option<ModelSet>,
    /// After a change of sea, how many of the newest values are from the new sea (fitted on
    /// and scored on separately: `models::fit_recent`).
    pub recent: Option<usize>,
    /// Why it was asked for (logs).
    pub reason: &'static str,
    /// The engine's count of values when the job was made: `series` ends there.
    pub end: u64,
}

/// A finished retrain.
pub struct Outcome {
    pub set: ModelSet,
    /// The new fit's and the running models' scores on the same held-out values, those the
    /// running models were not fitted on (`models::comparison_split`; NaN: not scored).
    pub new_score: [f64; NUM_DOF],
    pub running_score: [f64; NUM_DOF],
    pub reason: &'static str,
    pub seconds: f64,
}

/// Fit and score, on whichever thread calls it.
pub fn run_job(job: Job, config: &PredictorServiceConfig) -> anyhow::Result<Outcome> {
    let t = Instant::now();
    // Values newer than the running models' training data (all of them for a set never fitted
    // on live data).
    let fresh = job
        .running
        .as_ref()
        .and_then(|r| r.trained_through)
        .map(|t| usize::try_from(job.end.saturating_sub(t)).unwrap_or(usize::MAX));
    let (mut set, new_score) =
        models::fit_recent(&job.series, config, job.version, job.recent, fresh)?;
    set.trained_through = Some(job.end);
    let running_score = match job.running {
        Some(mut running) => models::score_on(&mut running, &job.series, config, job.recent, fresh),
        None => [f64::NAN; NUM_DOF],
    };
    Ok(Outcome {
        set,
        new_score,
        running_score,
        reason: job.reason,
        seconds: t.elapsed().as_secs_f64(),
    })
}

/// Where retraining runs.
pub enum Retrainer {
    /// On a thread of its own (the service).
    Background {
        jobs: SyncSender<Job>,
        /// A fit, or why it failed (the engine counts and logs failures).
        done: Receiver<Result<Outcome, String>>,
        /// Set while the thread fits.
        busy: Arc<AtomicBool>,
    },
    /// In the caller's step, finished before the step returns (replay).
    Inline {
        config: Box<PredictorServiceConfig>,
        /// Boxed: an outcome is large beside the background variant.
        done: Option<Box<Result<Outcome, String>>>,
    },
}

impl Retrainer {
    pub fn background(config: PredictorServiceConfig) -> anyhow::Result<Self> {
        // One job at a time: a request while a fit is running is skipped, not queued.
        let (jobs, job_rx) = mpsc::sync_channel::<Job>(0);
        let (done_tx, done) = mpsc::channel();
        let busy = Arc::new(AtomicBool::new(false));
        let busy_in_thread = Arc::clone(&busy);
        std::thread::Builder::new()
            .name("retrain".into())
            .spawn(move || {
                for job in job_rx {
                    busy_in_thread.store(true, Ordering::Release);
                    let values = job.series.first().map_or(0, Vec::len);
                    let result = run_job(job, &config).map_err(|e| format!("{e:#}"));
                    if let Ok(outcome) = &result {
                        tracing::debug!(
                            values,
                            seconds = outcome.seconds,
                            "predictor: retrain done"
                        );
                    }
                    if done_tx.send(result).is_err() {
                        return;
                    }
                    busy_in_thread.store(false, Ordering::Release);
                }
            })?;
        Ok(Self::Background { jobs, done, busy })
    }

    pub fn inline(config: PredictorServiceConfig) -> Self {
        Self::Inline {
            config: Box::new(config),
            done: None,
        }
    }

    /// True if retraining runs in the caller's step.
    pub fn is_inline(&self) -> bool {
        matches!(self, Self::Inline { .. })
    }

    /// False while a background fit is running (a request now would be dropped).
    pub fn is_ready(&self) -> bool {
        match self {
            Self::Background { busy, .. } => !busy.load(Ordering::Acquire),
            Self::Inline { .. } => true,
        }
    }

    /// Ask for a retrain; false if one is still running (the request is dropped).
    pub fn request(&mut self, job: Job) -> bool {
        match self {
            Self::Background { jobs, .. } => match jobs.try_send(job) {
                Ok(()) => true,
                Err(TrySendError::Full(_)) => false,
                Err(TrySendError::Disconnected(_)) => {
                    tracing::warn!("predictor: retraining thread is gone");
                    false
                }
            },
            Self::Inline { config, done } => {
                *done = Some(Box::new(run_job(job, config).map_err(|e| format!("{e:#}"))));
                true
            }
        }
    }

    /// A finished retrain (or why it failed), if any.
    pub fn take(&mut self) -> Option<Result<Outcome, String>> {
        match self {
            Self::Background { done, .. } => done.try_recv().ok(),
            Self::Inline { done, .. } => done.take().map(|d| *d),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use shipcast_predict::{AnyPredictor, Predictor};

    /// A job too short to fit any order, on either kind of retrainer.
    fn failing_job() -> Job {
        Job {
            series: vec![vec![0.0; 10]; NUM_DOF],
            version: 2,
            running: None,
            recent: None,
            reason: "test",
            end: 10,
        }
    }

    #[test]
    fn the_running_model_is_compared_only_on_values_it_was_not_fitted_on() {
        // Regression: the running model, refitted on its own held-out part, was scored on the
        // next retrain's held-out values, most of which it had been fitted on, against a new
        // fit scored out of sample; after a change of sea that kept newer fits out.
        let series: Vec<Vec<f64>> = (0..NUM_DOF)
            .map(|d| {
                (0..1200)
                    .map(|i| {
                        let t = i as f64;
                        (t * 0.31).sin()
                            + 0.5 * (t * (0.17 + 0.01 * d as f64)).sin()
                            + 0.2 * (t * 1.3).sin() * (t * 0.011).cos()
                    })
                    .collect()
            })
            .collect();
        let config = PredictorServiceConfig {
            order: 12,
            horizon: 8,
            holdout: 300,
            candidate_orders: vec![12],
            // The paper's estimate: a least-squares fit of these few sinusoids is so close to
            // exact that every score is next to 0 and the scores could not be told apart.
            wiener: Some(crate::config::WienerSettings {
                fit: shipcast_predict::WienerFit::Autocorrelation,
            }),
            ..PredictorServiceConfig::default()
        };
        // The running set was fitted on the first 1000 values, 200 before the job's end.
        let mut running = models::fit(
            &series
                .iter()
                .map(|x| x[..1000].to_vec())
                .collect::<Vec<_>>(),
            &config,
            1,
        )
        .unwrap();
        running.trained_through = Some(4000);
        let job = Job {
            series: series.clone(),
            version: 2,
            running: Some(running.clone()),
            recent: None,
            reason: "test",
            end: 4200,
        };
        let outcome = run_job(job, &config).unwrap();
        assert_eq!(outcome.set.trained_through, Some(4200));
        let pc = shipcast_predict::PredictorConfig {
            order: 12,
            ..config.predictor_config()
        };
        for (d, x) in series.iter().enumerate() {
            // Both on the newest 200 values: the running model as it is, the new one as
            // chosen (fitted on the 900 values before the held-out part, not refitted).
            let (_, running_expected) =
                models::held_out_pairs(&mut running.predictors[d], x, 1000).unwrap();
            let mut chosen = AnyPredictor::new(config.method, &pc).unwrap();
            chosen.fit(&x[..900]).unwrap();
            let (_, new_expected) = models::held_out_pairs(&mut chosen, x, 1000).unwrap();
            assert!((outcome.running_score[d] - running_expected).abs() < 1e-12);
            assert!((outcome.new_score[d] - new_expected).abs() < 1e-12);
            // The new set's own score is over its whole held-out part (from 900).
            assert!((outcome.set.score[d] - new_expected).abs() > 1e-9);
        }
    }

    #[test]
    fn a_failed_fit_comes_back_as_its_reason_on_both_retrainers() {
        // Regression: a failure was only logged by the retrainer, so nothing counted it.
        let config = PredictorServiceConfig::default();
        let mut inline = Retrainer::inline(config.clone());
        assert!(inline.request(failing_job()));
        let e = inline.take().expect("a result").err().expect("a failure");
        assert!(e.contains("too few to fit"), "{e}");
        assert!(inline.take().is_none());

        let mut background = Retrainer::background(config).unwrap();
        let (patience, poll) = (
            std::time::Duration::from_secs(30),
            std::time::Duration::from_millis(10),
        );
        // The job is handed over only once the thread waits for one (a rendezvous).
        let sent = crate::pacing::poll_until(patience, poll, || {
            background.request(failing_job()).then_some(())
        });
        assert!(sent.is_some(), "the retraining thread never took a job");
        let result = crate::pacing::poll_until(patience, poll, || background.take());
        let e = result.expect("a result").err().expect("a failure");
        assert!(e.contains("too few to fit"), "{e}");
    }
}
