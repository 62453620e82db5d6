//! The six fitted predictors the service forecasts with, and the per-step error (sigma) measured
//! on held-out data that goes into every forecast.

use anyhow::Context;
use shipcast::config::PredictorServiceConfig;
use shipcast::eval::forecast_sigma;
use shipcast::model::ModelFile;
use shipcast::payload::{MAX_STEPS, NUM_DOF};
use shipcast::predict::{AnyPredictor, Predictor};
use shipcast::Dof;
use std::path::Path;

/// One predictor per DOF plus its measured error.
#[derive(Clone)]
pub struct ModelSet {
    pub predictors: Vec<AnyPredictor>,
    pub sigma: [[f32; MAX_STEPS]; NUM_DOF],
    pub version: u32,
}

impl ModelSet {
    pub fn order(&self) -> usize {
        self.predictors[0].order()
    }

    pub fn horizon(&self) -> usize {
        self.predictors[0].horizon()
    }
}

fn sigma_row(sigma: &[f64]) -> [f32; MAX_STEPS] {
    let mut row = [0.0; MAX_STEPS];
    for (r, s) in row.iter_mut().zip(sigma) {
        *r = *s as f32;
    }
    row
}

/// Fit six predictors on `series` (per DOF, oldest first) minus its last `holdout` values, and
/// measure sigma on those with the evaluation's scoring (every origin, stride 1).
pub fn fit(
    series: &[Vec<f64>],
    config: &PredictorServiceConfig,
    version: u32,
) -> anyhow::Result<ModelSet> {
    let pc = config.predictor_config();
    let len = series.iter().map(Vec::len).min().unwrap_or(0);
    let split = len.saturating_sub(config.holdout);
    let mut predictors = Vec::with_capacity(NUM_DOF);
    let mut sigma = [[0.0; MAX_STEPS]; NUM_DOF];
    for (d, x) in series.iter().enumerate().take(NUM_DOF) {
        let name = Dof::ALL[d].name();
        let mut p = AnyPredictor::new(config.method, &pc)
            .with_context(|| format!("building the {} predictor", config.method))?;
        p.fit(&x[..split])
            .with_context(|| format!("fitting {} on {name}", config.method))?;
        let rms = forecast_sigma(&mut p, &x[..len], split, 1)
            .with_context(|| format!("measuring sigma of {name} on the held-out data"))?;
        sigma[d] = sigma_row(&rms);
        predictors.push(p);
    }
    Ok(ModelSet {
        predictors,
        sigma,
        version,
    })
}

/// Load a model file from `shipcast train`; it must hold all six DOF and match the service's
/// forecast rate.
pub fn load(path: &Path, sample_rate_hz: f64) -> anyhow::Result<ModelSet> {
    let file = ModelFile::load(path)?;
    if (file.sample_rate - sample_rate_hz).abs() > 1e-9 {
        anyhow::bail!(
            "{}: model forecasts at {} Hz, the predictor runs at {sample_rate_hz} Hz",
            path.display(),
            file.sample_rate
        );
    }
    let mut predictors = Vec::with_capacity(NUM_DOF);
    let mut sigma = [[0.0; MAX_STEPS]; NUM_DOF];
    for dof in Dof::ALL {
        let m = file
            .dofs
            .iter()
            .find(|m| m.dof == dof)
            .with_context(|| format!("{}: no model for {}", path.display(), dof.name()))?;
        if m.predictor.horizon() > MAX_STEPS {
            anyhow::bail!(
                "{}: horizon {} exceeds the forecast capacity {MAX_STEPS}",
                path.display(),
                m.predictor.horizon()
            );
        }
        sigma[dof.index()] = sigma_row(&m.sigma);
        predictors.push(m.predictor.clone());
    }
    let (order, horizon) = (predictors[0].order(), predictors[0].horizon());
    if predictors
        .iter()
        .any(|p| p.order() != order || p.horizon() != horizon)
    {
        anyhow::bail!(
            "{}: the six DOF models differ in order or horizon",
            path.display()
        );
    }
    Ok(ModelSet {
        predictors,
        sigma,
        version: 1,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use shipcast::predict::Method;

    #[test]
    fn sigma_is_the_held_out_rms_error_per_step() {
        // Persistence on a linear ramp: the h-step error is exactly h * slope at every origin.
        let series: Vec<Vec<f64>> = (0..NUM_DOF)
            .map(|d| (0..400).map(|i| i as f64 * 0.01 * (d + 1) as f64).collect())
            .collect();
        let config = PredictorServiceConfig {
            method: Method::Persistence,
            order: 10,
            horizon: 5,
            holdout: 100,
            ..PredictorServiceConfig::default()
        };
        let set = fit(&series, &config, 3).unwrap();
        assert_eq!(set.version, 3);
        for d in 0..NUM_DOF {
            for h in 0..5 {
                let expect = (h + 1) as f64 * 0.01 * (d + 1) as f64;
                assert!((set.sigma[d][h] as f64 - expect).abs() < 1e-6, "{d} {h}");
            }
            assert_eq!(set.sigma[d][5], 0.0);
        }
    }

    #[test]
    fn too_little_data_is_an_error() {
        let series = vec![vec![0.0; 20]; NUM_DOF];
        let config = PredictorServiceConfig {
            method: Method::Persistence,
            order: 10,
            horizon: 5,
            holdout: 3,
            ..PredictorServiceConfig::default()
        };
        assert!(fit(&series, &config, 0).is_err());
    }
}
