//! The models the engine starts from, before any live fit: a model file, or a fit on simulated
//! history of the configured sea.

use super::models::{self, ModelSet};
use crate::config::PipelineConfig;
use anyhow::Context;
use shipcast_series::decimate_with;
use shipcast_sim::{ShipMotion, SimConfig};
use shipcast_wire::payload::{MAX_STEPS, NUM_DOF};
use std::time::Instant;

/// Models to start with: the model file, or fitted on simulated history of the configured sea
/// (another realisation than the producer's: seed + 1, at the producer's station). Neither has been scored on the sea the
/// ship is in, so the engine treats them as unverified (no skill until verified live).
pub fn initial_models(config: &PipelineConfig) -> anyhow::Result<Option<ModelSet>> {
    let q = &config.predictor;
    if let Some(path) = &q.model {
        let set = models::load(path, q.sample_rate_hz)?;
        if set.horizon() > MAX_STEPS {
            anyhow::bail!("model horizon {} exceeds {MAX_STEPS}", set.horizon());
        }
        // Every live fit has the configured horizon, and a swap keeps the horizon the
        // forecasts have: a file with another one would have every retrain thrown away.
        if set.horizon() != q.horizon {
            anyhow::bail!(
                "{}: model horizon {} differs from predictor.horizon {}: set predictor.horizon = {} or train the model with --horizon {}",
                path.display(),
                set.horizon(),
                q.horizon,
                set.horizon(),
                q.horizon
            );
        }
        return Ok(Some(set));
    }
    if q.warmup_s <= 0.0 {
        return Ok(None);
    }
    let p = &config.producer;
    let mut sim = SimConfig::scenario(p.scenario);
    sim.seed = p.seed.wrapping_add(1);
    let motion = ShipMotion::at_station(&sim, p.station)?;
    let n = (q.warmup_s * p.rate_hz).ceil() as usize;
    let mut raw: Vec<Vec<f64>> = (0..NUM_DOF).map(|_| Vec::with_capacity(n)).collect();
    for point in motion.stream(p.rate_hz, 0.0)?.take(n) {
        for (d, series) in raw.iter_mut().enumerate() {
            series.push(point.dof[d]);
        }
    }
    let factor = config.decimation_factor()?;
    let series = raw
        .iter()
        .map(|x| decimate_with(x, factor, q.filter))
        .collect::<Result<Vec<_>, _>>()?;
    let t = Instant::now();
    let mut set = models::fit(&series, q, 1).context("training on simulated history")?;
    // Scored on the simulator's sea, not on this one.
    set.held_out.clear();
    set.score = [f64::NAN; NUM_DOF];
    tracing::info!(
        values = series[0].len(),
        seconds = t.elapsed().as_secs_f64(),
        "predictor: trained on simulated history"
    );
    Ok(Some(set))
}
