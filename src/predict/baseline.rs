//! Reference predictors every method must beat: persistence (the last value stays) and zero
//! (ship motion is zero-mean, so predicting the mean is the no-skill forecast).

use super::{check_forecast_buffers, Method, PredictError, Predictor, PredictorConfig};
use serde::{Deserialize, Serialize};

/// Predicts that the last observed value persists for every step.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct PersistencePredictor {
    order: usize,
    horizon: usize,
}

impl PersistencePredictor {
    /// Persistence needs one past value; `order` is kept so it fits the common protocol.
    pub fn new(config: &PredictorConfig) -> Result<Self, PredictError> {
        Ok(Self {
            order: config.order.max(1),
            horizon: config.horizon,
        })
    }
}

impl Predictor for PersistencePredictor {
    fn method(&self) -> Method {
        Method::Persistence
    }
    fn order(&self) -> usize {
        self.order
    }
    fn horizon(&self) -> usize {
        self.horizon
    }
    fn fit(&mut self, train: &[f64]) -> Result<(), PredictError> {
        if train.is_empty() {
            return Err(PredictError::TooShort {
                method: Method::Persistence,
                order: self.order,
                needed: 1,
                got: 0,
            });
        }
        Ok(())
    }
    fn forecast(&mut self, past: &[f64], out: &mut [f64]) -> Result<(), PredictError> {
        check_forecast_buffers(self.order, self.horizon, past, out)?;
        let last = past[past.len() - 1];
        out[..self.horizon].fill(last);
        Ok(())
    }
}

/// Predicts zero (the mean of a zero-mean motion) for every step.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ZeroPredictor {
    order: usize,
    horizon: usize,
}

impl ZeroPredictor {
    pub fn new(config: &PredictorConfig) -> Result<Self, PredictError> {
        Ok(Self {
            order: config.order.max(1),
            horizon: config.horizon,
        })
    }
}

impl Predictor for ZeroPredictor {
    fn method(&self) -> Method {
        Method::Zero
    }
    fn order(&self) -> usize {
        self.order
    }
    fn horizon(&self) -> usize {
        self.horizon
    }
    fn fit(&mut self, train: &[f64]) -> Result<(), PredictError> {
        if train.is_empty() {
            return Err(PredictError::TooShort {
                method: Method::Zero,
                order: self.order,
                needed: 1,
                got: 0,
            });
        }
        Ok(())
    }
    fn forecast(&mut self, past: &[f64], out: &mut [f64]) -> Result<(), PredictError> {
        check_forecast_buffers(self.order, self.horizon, past, out)?;
        out[..self.horizon].fill(0.0);
        Ok(())
    }
}
