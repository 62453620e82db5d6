//! Neural-network predictor (docs/contracts.md section 4): `order` inputs, `mlp_hidden` tanh hidden
//! units, `horizon` linear outputs, trained full-batch with iRprop- on the windows of the
//! training segment.
//!
//! Departures from the paper, all deterministic:
//! - inputs and outputs are divided by the standard deviation of the training segment, so the
//!   initial weights and Rprop's step bounds suit any units (metres or radians); forecasts are
//!   scaled back;
//! - only when the training matrix would exceed `MAX_TRAINING_VALUES` (128 MB) are the windows
//!   thinned; at the paper's sizes every window is used (`MLP_WINDOW_STRIDE` = 1): MLP-800 with
//!   200 epochs trains on 5000 values in about 6 s on a 2-core VM, within the budget of
//!   `shipcast eval --method all` (under a minute);
//! - initial weights are uniform in +-sqrt(3 / fan_in) (unit-variance pre-activations for
//!   unit-variance inputs), biases zero, drawn from ChaCha8 seeded with `seed`;
//! - the batch products run on one thread (`Par::Seq`), so a seed gives bit-identical weights.

mod network;
mod rprop;

use super::{
    check_forecast_buffers, check_training, Method, PredictError, Predictor, PredictorConfig,
};
use network::{Shape, TrainingSet, Workspace};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rprop::Rprop;
use serde::{Deserialize, Serialize};

/// Training windows start this many values apart.
const MLP_WINDOW_STRIDE: usize = 1;

/// The training matrix holds at most this many values (8 bytes each); longer training series
/// use a wider window stride so memory stays bounded.
const MAX_TRAINING_VALUES: usize = 1 << 24;

/// Rprop's initial step, as a fraction of each layer's initial weight range.
const INITIAL_STEP_FRACTION: f64 = 0.1;

/// One-hidden-layer perceptron predicting all `horizon` steps at once.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(remote = "Self", deny_unknown_fields)]
pub struct MlpPredictor {
    shape: Shape,
    epochs: usize,
    window_stride: usize,
    seed: u64,
    /// Standard deviation of the training segment: network units are values divided by it.
    scale: f64,
    /// Flat parameter vector, laid out as described by [`Shape`].
    params: Vec<f64>,
    /// Training loss at the last epoch (half the squared error summed over steps, averaged
    /// over windows, in network units); `None` before the first fit.
    final_loss: Option<f64>,
}

serde_validated!(MlpPredictor);

/// Most weights an MLP may have (80 MB per copy of them).
pub const MAX_MLP_PARAMETERS: usize = 10_000_000;

impl MlpPredictor {
    /// What a model file must satisfy (see `serde_validated!`): once fitted, as many finite
    /// parameters as the shape needs and a positive finite scale.
    fn validate(&self) -> Result<(), String> {
        if self.params.is_empty() {
            return Ok(());
        }
        let needed = self.shape.checked_len();
        if needed != Some(self.params.len()) {
            return Err(format!(
                "MLP params hold {} values; {} inputs, {} hidden units and {} outputs need {}",
                self.params.len(),
                self.shape.inputs,
                self.shape.hidden,
                self.shape.outputs,
                needed.map_or("more than memory holds".to_string(), |n| n.to_string())
            ));
        }
        if self.params.iter().any(|p| !p.is_finite()) {
            return Err("MLP params hold a non-finite value".into());
        }
        if !(self.scale.is_finite() && self.scale > 0.0) {
            return Err(format!(
                "MLP scale must be positive and finite, got {}",
                self.scale
            ));
        }
        Ok(())
    }

    /// An unfitted network; fails on zero hidden units or epochs, or a network too large to
    /// address.
    pub fn new(config: &PredictorConfig) -> Result<Self, PredictError> {
        if config.mlp_hidden == 0 {
            return Err(PredictError::Infeasible(
                "MLP needs at least one hidden unit".into(),
            ));
        }
        if config.mlp_epochs == 0 {
            return Err(PredictError::Infeasible(
                "MLP needs at least one training epoch".into(),
            ));
        }
        let shape = Shape {
            inputs: config.order,
            hidden: config.mlp_hidden,
            outputs: config.horizon,
        };
        // Training keeps about five vectors of this size (parameters, gradient, Rprop's
        // steps and previous gradient, the best so far): beyond the budget, options each
        // within their own limits aborted the process on a failed allocation (review:
        // --order 10000 --hidden 10000).
        if shape.checked_len().is_none_or(|n| n > MAX_MLP_PARAMETERS) {
            return Err(PredictError::Infeasible(format!(
                "MLP with {} inputs, {} hidden units and {} outputs is too large: at most {MAX_MLP_PARAMETERS} weights (hidden x (inputs + outputs + 1) + outputs); lower the order or the hidden units",
                shape.inputs, shape.hidden, shape.outputs
            )));
        }
        Ok(Self {
            shape,
            epochs: config.mlp_epochs,
            window_stride: MLP_WINDOW_STRIDE,
            seed: config.seed,
            scale: 1.0,
            params: Vec::new(),
            final_loss: None,
        })
    }

    /// Training loss at the last epoch of the last fit: half the squared error summed over the
    /// steps, averaged over windows, in units of the training standard deviation squared.
    pub fn final_loss(&self) -> Option<f64> {
        self.final_loss
    }

    /// Seeded initial weights and the matching initial Rprop steps.
    fn initial_params(&self) -> (Vec<f64>, Vec<f64>) {
        let shape = self.shape;
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed);
        let mut params = vec![0.0; shape.len()];
        let mut steps = vec![0.0; shape.len()];
        let [w1, b1, w2, b2] = shape.split_mut(&mut params);
        let [s_w1, s_b1, s_w2, s_b2] = shape.split_mut(&mut steps);
        for (weights, steps, fan_in) in [(w1, s_w1, shape.inputs), (w2, s_w2, shape.hidden)] {
            let range = (3.0 / fan_in as f64).sqrt();
            for w in weights.iter_mut() {
                *w = rng.random_range(-range..range);
            }
            steps.fill(INITIAL_STEP_FRACTION * range);
        }
        // Biases start at zero; their steps match the output layer's.
        let bias_step = INITIAL_STEP_FRACTION * (3.0 / shape.hidden as f64).sqrt();
        b1.fill(0.0);
        b2.fill(0.0);
        s_b1.fill(bias_step);
        s_b2.fill(bias_step);
        (params, steps)
    }

    /// Window stride actually used for a training series of `len` values: the configured one,
    /// widened if the training matrix would exceed `MAX_TRAINING_VALUES`.
    fn effective_stride(&self, len: usize) -> usize {
        let positions = len - self.shape.inputs - self.shape.outputs + 1;
        let max_windows = (MAX_TRAINING_VALUES / self.shape.inputs).max(1);
        let needed = positions.div_ceil(max_windows);
        self.window_stride.max(needed)
    }
}

impl Predictor for MlpPredictor {
    fn method(&self) -> Method {
        Method::Mlp
    }

    fn order(&self) -> usize {
        self.shape.inputs
    }

    fn horizon(&self) -> usize {
        self.shape.outputs
    }

    fn fit(&mut self, train: &[f64]) -> Result<(), PredictError> {
        let shape = self.shape;
        check_training(
            Method::Mlp,
            shape.inputs,
            shape.inputs + shape.outputs,
            train,
        )?;
        self.params.clear();
        self.final_loss = None;
        let mean = train.iter().sum::<f64>() / train.len() as f64;
        let variance = train.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / train.len() as f64;
        // A constant series has no spread to normalise by; its values are used as they are.
        self.scale = if variance > 0.0 { variance.sqrt() } else { 1.0 };
        let stride = self.effective_stride(train.len());
        if stride != self.window_stride {
            tracing::info!(stride, "MLP training series is long: windows are thinned");
        }
        let set = TrainingSet::from_series(train, shape, stride, 1.0 / self.scale);
        let mut work = Workspace::new(&set, shape);
        let (mut params, steps) = self.initial_params();
        let mut optimiser = Rprop::new(steps);
        let mut grad = vec![0.0; shape.len()];
        let mut loss = f64::NAN;
        for epoch in 0..self.epochs {
            loss = network::loss_and_gradient(shape, &params, &set, &mut work, &mut grad);
            if !loss.is_finite() {
                return Err(PredictError::Numerical(format!(
                    "MLP training loss became {loss} at epoch {epoch}"
                )));
            }
            optimiser.step(&mut params, &grad);
        }
        tracing::debug!(
            windows = set.len(),
            epochs = self.epochs,
            loss,
            "MLP trained"
        );
        self.params = params;
        self.final_loss = Some(loss);
        Ok(())
    }

    fn forecast(&mut self, past: &[f64], out: &mut [f64]) -> Result<(), PredictError> {
        if self.params.is_empty() {
            return Err(PredictError::NotFitted(Method::Mlp));
        }
        // A model file edited by hand must not index out of range or scale by nonsense.
        if self.params.len() != self.shape.len() || !(self.scale.is_finite() && self.scale > 0.0) {
            return Err(PredictError::Numerical(format!(
                "MLP model holds {} parameters with scale {}; its shape needs {} and a positive scale",
                self.params.len(),
                self.scale,
                self.shape.len()
            )));
        }
        let (order, horizon) = (self.shape.inputs, self.shape.outputs);
        check_forecast_buffers(order, horizon, past, out)?;
        let window = &past[past.len() - order..];
        if window.iter().any(|v| !v.is_finite()) {
            return Err(PredictError::NonFinite("MLP forecast window"));
        }
        let out = &mut out[..horizon];
        out.copy_from_slice(&self.params[self.shape.b2()]);
        network::accumulate_output(self.shape, &self.params, window, 1.0 / self.scale, out);
        for v in out.iter_mut() {
            *v *= self.scale;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests;
