//! Placeholder: being written (see issue 2).

use super::{Method, PredictError, Predictor, PredictorConfig};
use serde::{Deserialize, Serialize};

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct MlpPredictor {
    order: usize,
    horizon: usize,
}

impl MlpPredictor {
    pub fn new(config: &PredictorConfig) -> Result<Self, PredictError> {
        Ok(Self {
            order: config.order,
            horizon: config.horizon,
        })
    }
}

impl Predictor for MlpPredictor {
    fn method(&self) -> Method {
        Method::Mlp
    }
    fn order(&self) -> usize {
        self.order
    }
    fn horizon(&self) -> usize {
        self.horizon
    }
    fn fit(&mut self, _train: &[f64]) -> Result<(), PredictError> {
        Err(PredictError::Infeasible("not implemented yet".into()))
    }
    fn forecast(&mut self, _past: &[f64], _out: &mut [f64]) -> Result<(), PredictError> {
        Err(PredictError::NotFitted(Method::Mlp))
    }
}
