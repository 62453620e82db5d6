//! Background retraining: the forecasting thread hands over a copy of the recent history, this
//! thread fits new models and measures their sigma, and the forecasting thread picks them up
//! between two forecasts. Fitting never runs on the forecasting thread.

use super::models::{self, ModelSet};
use shipcast::config::PredictorServiceConfig;
use std::sync::mpsc::{self, Receiver, SyncSender, TrySendError};
use std::time::Instant;

struct Job {
    series: Vec<Vec<f64>>,
    version: u32,
}

pub struct Retrainer {
    jobs: SyncSender<Job>,
    done: Receiver<ModelSet>,
}

impl Retrainer {
    pub fn spawn(config: PredictorServiceConfig) -> anyhow::Result<Self> {
        // One job at a time: a request while a fit is running is skipped, not queued.
        let (jobs, job_rx) = mpsc::sync_channel::<Job>(0);
        let (done_tx, done) = mpsc::channel();
        std::thread::Builder::new()
            .name("retrain".into())
            .spawn(move || {
                for job in job_rx {
                    let t = Instant::now();
                    match models::fit(&job.series, &config, job.version) {
                        Ok(set) => {
                            tracing::info!(
                                version = job.version,
                                values = job.series[0].len(),
                                seconds = t.elapsed().as_secs_f64(),
                                "predictor: retrained on live history"
                            );
                            if done_tx.send(set).is_err() {
                                return;
                            }
                        }
                        Err(e) => tracing::warn!("predictor: retraining failed: {e:#}"),
                    }
                }
            })?;
        Ok(Self { jobs, done })
    }

    /// Ask for a retrain on `series`; skipped (with a log line) if one is still running.
    pub fn request(&self, series: Vec<Vec<f64>>, version: u32) {
        match self.jobs.try_send(Job { series, version }) {
            Ok(()) => {}
            Err(TrySendError::Full(_)) => {
                tracing::info!("predictor: previous retrain still running, skipped")
            }
            Err(TrySendError::Disconnected(_)) => {
                tracing::warn!("predictor: retraining thread is gone")
            }
        }
    }

    /// A finished model set, if any.
    pub fn take(&self) -> Option<ModelSet> {
        self.done.try_recv().ok()
    }
}
