//! Reference predictors every method must beat: persistence (the last value stays) and zero
//! (ship motion is zero-mean, so predicting the mean is the no-skill forecast).

use super::{
    check_forecast_buffers, check_training, Method, PredictError, Predictor, PredictorConfig,
};
use serde::{Deserialize, Serialize};

/// Defines a baseline: nothing to learn, `order` kept only so it fits the common protocol, and a
/// forecast rule `fn(past, out)` writing `out` (exactly `horizon` long) from `past`.
macro_rules! baseline_predictor {
    ($(#[$doc:meta])* $name:ident, $method:expr, $rule:expr) => {
        $(#[$doc])*
        // A misspelt field of a hand-edited model file is an error, as for every predictor.
        #[derive(Clone, Debug, Serialize, Deserialize)]
        #[serde(deny_unknown_fields)]
        pub struct $name {
            order: usize,
            horizon: usize,
        }

        impl $name {
            pub fn new(config: &PredictorConfig) -> Result<Self, PredictError> {
                Ok(Self {
                    order: config.order.max(1),
                    horizon: config.horizon,
                })
            }
        }

        impl Predictor for $name {
            fn method(&self) -> Method {
                $method
            }
            fn order(&self) -> usize {
                self.order
            }
            fn horizon(&self) -> usize {
                self.horizon
            }
            fn fit(&mut self, train: &[f64]) -> Result<(), PredictError> {
                check_training($method, self.order, 1, train)
            }
            fn forecast(&mut self, past: &[f64], out: &mut [f64]) -> Result<(), PredictError> {
                check_forecast_buffers(self.order, self.horizon, past, out)?;
                let rule: fn(&[f64], &mut [f64]) = $rule;
                rule(past, &mut out[..self.horizon]);
                Ok(())
            }
        }
    };
}

baseline_predictor!(
    /// Predicts that the last observed value persists for every step.
    PersistencePredictor,
    Method::Persistence,
    |past, out| out.fill(past[past.len() - 1])
);

baseline_predictor!(
    /// Predicts zero (the mean of a zero-mean motion) for every step.
    ZeroPredictor,
    Method::Zero,
    |_past, out| out.fill(0.0)
);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn persistence_repeats_the_last_value_and_zero_predicts_zero() {
        let config = PredictorConfig {
            order: 3,
            horizon: 4,
            ..PredictorConfig::default()
        };
        let past = [1.0, 2.0, 3.5];
        let mut out = [9.0; 5];
        let mut p = PersistencePredictor::new(&config).unwrap();
        p.fit(&past).unwrap();
        p.forecast(&past, &mut out).unwrap();
        assert_eq!(out, [3.5, 3.5, 3.5, 3.5, 9.0]);
        let mut z = ZeroPredictor::new(&config).unwrap();
        z.fit(&past).unwrap();
        z.forecast(&past, &mut out).unwrap();
        assert_eq!(out, [0.0, 0.0, 0.0, 0.0, 9.0]);
        assert!(z.fit(&[]).is_err());
        assert!(p.forecast(&past[..2], &mut out).is_err());
    }
}
