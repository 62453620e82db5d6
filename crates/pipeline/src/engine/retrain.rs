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
}

/// A finished retrain.
pub struct Outcome {
    pub set: ModelSet,
    /// The running models' scores on the new fit's held-out data (NaN: not scored).
    pub running_score: [f64; NUM_DOF],
    pub reason: &'static str,
    pub seconds: f64,
}

/// Fit and score, on whichever thread calls it.
pub fn run_job(job: Job, config: &PredictorServiceConfig) -> anyhow::Result<Outcome> {
    let t = Instant::now();
    let set = models::fit_recent(&job.series, config, job.version, job.recent)?;
    let running_score = match job.running {
        Some(mut running) => models::score_on(&mut running, &job.series, config, job.recent),
        None => [f64::NAN; NUM_DOF],
    };
    Ok(Outcome {
        set,
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
        done: Option<Result<Outcome, String>>,
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
                *done = Some(run_job(job, config).map_err(|e| format!("{e:#}")));
                true
            }
        }
    }

    /// A finished retrain (or why it failed), if any.
    pub fn take(&mut self) -> Option<Result<Outcome, String>> {
        match self {
            Self::Background { done, .. } => done.try_recv().ok(),
            Self::Inline { done, .. } => done.take(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A job too short to fit any order, on either kind of retrainer.
    fn failing_job() -> Job {
        Job {
            series: vec![vec![0.0; 10]; NUM_DOF],
            version: 2,
            running: None,
            recent: None,
            reason: "test",
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
