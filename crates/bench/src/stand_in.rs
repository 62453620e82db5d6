//! The bench's own forecasting step, assembled from shipcast's library parts exactly as the
//! pipeline uses them: per-DOF 8 -> 2 Hz [`Decimator`], a history window of `order` values, an
//! MCA model per DOF, and the [`Forecast`] payload. The `in-process` rows of the report run it
//! to separate the transport's cost from the process boundary; the `services` rows measure the
//! real `shipcast predictor` (receive stamps via `--bench-stamps`). It repeats the service's
//! history handling in small (services/predictor/history.rs): a known twin, kept only while the
//! in-process rows are. Nothing here allocates after construction.

use anyhow::Context;
use shipcast_pipeline::config::PredictorServiceConfig;
use shipcast_predict::{McaPredictor, Predictor};
use shipcast_series::decimator::Decimator;
use shipcast_wire::payload::{Forecast, MotionSample, MAX_STEPS, NUM_DOF};

/// Input rate of the motion record (the producer's 8 Hz), whatever the wall-clock send rate.
pub const RECORD_RATE_HZ: f64 = 8.0;

/// One DOF: decimator, history window and model.
struct Channel {
    decimator: Decimator,
    /// The last values at the decimated rate; the newest `order` are contiguous at the end.
    history: Vec<f64>,
    model: McaPredictor,
    out: Vec<f64>,
}

/// Turns motion samples into forecasts, one every `decimation` samples.
pub struct ForecastStep {
    channels: Vec<Channel>,
    order: usize,
    horizon: usize,
    dt_s: f64,
    forecast: Forecast,
    /// The models have prepared for the next decimated value.
    prepared: bool,
}

/// Synthetic training motion: incommensurate swell components, different per DOF, so the MCA
/// models are well conditioned. Latency does not depend on the values.
pub fn swell(dof: usize, t: f64) -> f64 {
    let d = dof as f64;
    (0.55 + 0.05 * d).mul_add(t, d).sin()
        + 0.6 * (0.83 * t + 0.3 * d).sin()
        + 0.3 * (1.21 * t + 1.7).sin()
        + 0.1 * (0.37 * t + 0.2 * d).cos()
}

impl ForecastStep {
    /// Fit one MCA model per DOF on synthetic history with the predictor service's default
    /// settings, and fill the histories so forecasts start at the first decimated value.
    pub fn new() -> anyhow::Result<Self> {
        let service = PredictorServiceConfig::default();
        let config = service.predictor_config();
        let decimation = (RECORD_RATE_HZ / service.sample_rate_hz).round() as usize;
        let dt_s = 1.0 / service.sample_rate_hz;
        let (order, horizon) = (config.order, config.horizon.min(MAX_STEPS));
        let train_len = (8 * order).max(2000);
        let mut channels = Vec::with_capacity(NUM_DOF);
        for d in 0..NUM_DOF {
            let train: Vec<f64> = (0..train_len).map(|i| swell(d, i as f64 * dt_s)).collect();
            let mut model = McaPredictor::new(&config).context("stand-in MCA model")?;
            model.fit(&train).context("fit stand-in MCA model")?;
            let mut history = Vec::with_capacity(2 * order);
            history.extend_from_slice(&train[train_len - order..]);
            channels.push(Channel {
                decimator: Decimator::new(decimation).context("stand-in decimator")?,
                history,
                model,
                out: vec![0.0; config.horizon],
            });
        }
        Ok(Self {
            channels,
            order,
            horizon,
            dt_s,
            forecast: Forecast::default(),
            prepared: false,
        })
    }

    /// Feed one sample. When a decimated value completes, forecast all six DOF and return the
    /// payload (stamps filled except `issued_stamp_ns`, which the publisher sets).
    pub fn push(&mut self, sample: &MotionSample) -> anyhow::Result<Option<&mut Forecast>> {
        let mut complete = false;
        for (ch, &x) in self.channels.iter_mut().zip(&sample.dof) {
            if let Some(y) = ch.decimator.push(x) {
                if ch.history.len() == 2 * self.order {
                    // Keep the newest order - 1 values at the front: amortised O(1), no
                    // allocation.
                    let keep = self.order - 1;
                    let from = ch.history.len() - keep;
                    ch.history.copy_within(from.., 0);
                    ch.history.truncate(keep);
                }
                ch.history.push(y);
                complete = true;
            }
        }
        if !complete {
            return Ok(None);
        }
        self.prepared = false;
        let f = &mut self.forecast;
        for (d, ch) in self.channels.iter_mut().enumerate() {
            let past = &ch.history[ch.history.len() - self.order..];
            ch.model.forecast(past, &mut ch.out)?;
            for (dst, src) in f.mean[d].iter_mut().zip(&ch.out[..self.horizon]) {
                *dst = *src as f32;
            }
        }
        f.seq += 1;
        f.source_seq = sample.seq;
        f.source_stamp_ns = sample.stamp_ns;
        f.time_s = sample.time_s;
        f.dt_s = self.dt_s;
        f.steps = self.horizon as u32;
        Ok(Some(f))
    }

    /// Do ahead the part of the next forecast that the values so far determine, once per
    /// forecast (as the predictor service does on a sample that completes no forecast; see
    /// `Predictor::prepare`).
    pub fn prepare_next(&mut self) -> anyhow::Result<()> {
        if self.prepared {
            return Ok(());
        }
        for ch in &mut self.channels {
            ch.model.prepare(&ch.history)?;
        }
        self.prepared = true;
        Ok(())
    }

    /// Samples per forecast.
    pub fn decimation(&self) -> usize {
        self.channels.first().map_or(1, |c| c.decimator.factor())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_forecast_per_decimated_value_carrying_the_source_stamps() {
        let mut step = ForecastStep::new().unwrap();
        let n = step.decimation() as u64;
        assert_eq!(n, 4);
        let mut forecasts = Vec::new();
        for seq in 0..400u64 {
            let t = seq as f64 / RECORD_RATE_HZ;
            let s = MotionSample {
                seq,
                stamp_ns: 1000 + seq,
                time_s: t,
                dof: std::array::from_fn(|d| swell(d, t)),
            };
            if let Some(f) = step.push(&s).unwrap() {
                forecasts.push((f.seq, f.source_seq, f.source_stamp_ns, f.steps));
                assert!(f.mean_of(2).iter().all(|v| v.is_finite() && v.abs() < 10.0));
            }
        }
        // The decimator's first output needs its filter full; then one every n samples.
        let first = forecasts[0].1;
        assert_eq!(forecasts.len() as u64, (400 - first - 1) / n + 1);
        for (i, &(seq, src, stamp, steps)) in forecasts.iter().enumerate() {
            assert_eq!(
                (seq, src, stamp, steps),
                (i as u64 + 1, first + i as u64 * n, 1000 + src, 50)
            );
        }
    }
}
