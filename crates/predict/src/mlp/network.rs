//! The MLP's network: layer sizes, the layout of its parameters in one flat vector, and the
//! full-batch forward/backward pass used in training, written as faer matrix products.

use crate::vector_state::clear_upper_vector_state;
use faer::linalg::matmul::matmul;
use faer::{Accum, Mat, MatMut, MatRef, Par};
use serde::{Deserialize, Serialize};
use std::ops::Range;

/// Layer sizes of a one-hidden-layer network (tanh hidden units, linear outputs).
///
/// All parameters live in one flat vector, in this order:
/// - W1, `hidden x inputs`, row-major: the input weights of one hidden unit are contiguous;
/// - b1, `hidden`;
/// - W2, `hidden x outputs`, row-major: the output weights of one hidden unit are contiguous;
/// - b2, `outputs`.
///
/// Row-major W1 is column-major `inputs x hidden` (W1^T), which faer reads directly; keeping a
/// hidden unit's weights contiguous makes the single forecast a run of dot products and
/// `axpy`s with no scratch buffer.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Shape {
    pub inputs: usize,
    pub hidden: usize,
    pub outputs: usize,
}

impl Shape {
    pub fn w1(&self) -> Range<usize> {
        0..self.hidden * self.inputs
    }
    pub fn b1(&self) -> Range<usize> {
        let start = self.w1().end;
        start..start + self.hidden
    }
    pub fn w2(&self) -> Range<usize> {
        let start = self.b1().end;
        start..start + self.hidden * self.outputs
    }
    pub fn b2(&self) -> Range<usize> {
        let start = self.w2().end;
        start..start + self.outputs
    }

    /// Number of parameters.
    pub fn len(&self) -> usize {
        self.b2().end
    }

    /// Number of parameters, or `None` if it does not fit in `usize`.
    pub fn checked_len(&self) -> Option<usize> {
        let per_hidden = self.inputs.checked_add(self.outputs)?.checked_add(1)?;
        self.hidden
            .checked_mul(per_hidden)?
            .checked_add(self.outputs)
    }

    /// The four parameter blocks `[W1, b1, W2, b2]` of `params`.
    pub fn split<'a>(&self, params: &'a [f64]) -> [&'a [f64]; 4] {
        let (w1, rest) = params.split_at(self.w1().len());
        let (b1, rest) = rest.split_at(self.hidden);
        let (w2, b2) = rest.split_at(self.w2().len());
        [w1, b1, w2, b2]
    }

    /// The four parameter blocks `[W1, b1, W2, b2]` of `params`, mutable.
    pub fn split_mut<'a>(&self, params: &'a mut [f64]) -> [&'a mut [f64]; 4] {
        let (w1, rest) = params.split_at_mut(self.w1().len());
        let (b1, rest) = rest.split_at_mut(self.hidden);
        let (w2, b2) = rest.split_at_mut(self.w2().len());
        [w1, b1, w2, b2]
    }
}

/// Training windows as matrices: one row per window, inputs in the network's units.
pub struct TrainingSet {
    /// `windows x inputs`.
    inputs: Mat<f64>,
    /// `windows x outputs`: the values that follow each input window.
    targets: Mat<f64>,
}

impl TrainingSet {
    /// Windows of `series` starting at 0, `stride`, 2 `stride`, ... while input and target fit,
    /// every value multiplied by `gain`. Callers ensure at least one window fits.
    pub fn from_series(series: &[f64], shape: Shape, stride: usize, gain: f64) -> Self {
        let span = shape.inputs + shape.outputs;
        let windows = (series.len() - span) / stride + 1;
        let at = |row: usize, offset: usize| series[row * stride + offset] * gain;
        Self {
            inputs: Mat::from_fn(windows, shape.inputs, &at),
            targets: Mat::from_fn(windows, shape.outputs, |row, col| {
                at(row, shape.inputs + col)
            }),
        }
    }

    /// Number of windows.
    pub fn len(&self) -> usize {
        self.inputs.nrows()
    }
}

/// Scratch matrices of one full-batch pass, allocated once per training run.
pub struct Workspace {
    /// `windows x hidden`: hidden activations.
    activations: Mat<f64>,
    /// `windows x outputs`: output errors, then their gradient.
    errors: Mat<f64>,
    /// `windows x hidden`: gradient with respect to the hidden pre-activations.
    back: Mat<f64>,
}

impl Workspace {
    pub fn new(set: &TrainingSet, shape: Shape) -> Self {
        let windows = set.len();
        Self {
            activations: Mat::zeros(windows, shape.hidden),
            errors: Mat::zeros(windows, shape.outputs),
            back: Mat::zeros(windows, shape.hidden),
        }
    }
}

/// Mean over windows of half the squared output error, and its gradient with respect to every
/// parameter (written into `grad`, laid out like `params`).
pub fn loss_and_gradient(
    shape: Shape,
    params: &[f64],
    set: &TrainingSet,
    work: &mut Workspace,
    grad: &mut [f64],
) -> f64 {
    let [w1, b1, w2, b2] = shape.split(params);
    let w1t = MatRef::from_column_major_slice(w1, shape.inputs, shape.hidden);
    let w2 = MatRef::from_row_major_slice(w2, shape.hidden, shape.outputs);
    let inv_windows = 1.0 / set.len() as f64;

    // Forward: A = tanh(X W1^T + b1), E = A W2 + b2 - T.
    product(work.activations.as_mut(), set.inputs.as_ref(), w1t);
    for (unit, &bias) in b1.iter().enumerate() {
        for a in work.activations.col_as_slice_mut(unit) {
            *a = (*a + bias).tanh();
        }
    }
    product(work.errors.as_mut(), work.activations.as_ref(), w2);
    let mut loss = 0.0;
    for (out, &bias) in b2.iter().enumerate() {
        let targets = set.targets.col_as_slice(out);
        for (e, t) in work.errors.col_as_slice_mut(out).iter_mut().zip(targets) {
            *e += bias - t;
            loss += *e * *e;
            // From here on E holds dLoss/dY.
            *e *= inv_windows;
        }
    }

    // Backward.
    let [g_w1, g_b1, g_w2, g_b2] = shape.split_mut(grad);
    product(
        MatMut::from_row_major_slice_mut(g_w2, shape.hidden, shape.outputs),
        work.activations.transpose(),
        work.errors.as_ref(),
    );
    for (out, g) in g_b2.iter_mut().enumerate() {
        *g = work.errors.col_as_slice(out).iter().sum();
    }
    product(work.back.as_mut(), work.errors.as_ref(), w2.transpose());
    for (unit, g) in g_b1.iter_mut().enumerate() {
        let activations = work.activations.col_as_slice(unit);
        let back = work.back.col_as_slice_mut(unit);
        let mut sum = 0.0;
        for (d, a) in back.iter_mut().zip(activations) {
            // tanh' = 1 - tanh^2.
            *d *= 1.0 - a * a;
            sum += *d;
        }
        *g = sum;
    }
    product(
        MatMut::from_column_major_slice_mut(g_w1, shape.inputs, shape.hidden),
        set.inputs.transpose(),
        work.back.as_ref(),
    );
    0.5 * loss * inv_windows
}

/// `dst = lhs * rhs`, single-threaded: training runs next to other work on a small machine, and
/// one thread keeps the sums in a fixed order (bit-identical results for a given seed).
fn product(dst: MatMut<'_, f64>, lhs: MatRef<'_, f64>, rhs: MatRef<'_, f64>) {
    matmul(dst, Accum::Replace, lhs, rhs, 1.0, Par::Seq);
    // The tanh that follows is libm SSE code.
    clear_upper_vector_state();
}

/// The network's output for one input window of raw values (`gain` converts them to network
/// units), added into `out`, which the caller initialises: `out += W2^T tanh(gain W1 x + b1)`.
/// Forecasting goes one hidden unit at a time, so it needs no hidden-layer buffer.
pub fn accumulate_output(shape: Shape, params: &[f64], x: &[f64], gain: f64, out: &mut [f64]) {
    clear_upper_vector_state();
    let [w1, b1, w2, _] = shape.split(params);
    let rows_in = w1.chunks_exact(shape.inputs);
    let rows_out = w2.chunks_exact(shape.outputs);
    for ((w_in, &bias), w_out) in rows_in.zip(b1).zip(rows_out) {
        let activation = (gain * crate::linear_map::dot(w_in, x) + bias).tanh();
        for (o, w) in out.iter_mut().zip(w_out) {
            *o += activation * w;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tiny() -> (Shape, Vec<f64>, TrainingSet) {
        let shape = Shape {
            inputs: 3,
            hidden: 4,
            outputs: 2,
        };
        // Deterministic, irregular parameters and series, large enough to exercise tanh's
        // curvature without saturating it.
        let params: Vec<f64> = (0..shape.len())
            .map(|i| 0.6 * ((i as f64 * 1.37).sin() + 0.3 * (i as f64 * 0.41).cos()))
            .collect();
        let series: Vec<f64> = (0..12)
            .map(|t| (t as f64 * 0.9).sin() + 0.2 * t as f64 - 1.0)
            .collect();
        let set = TrainingSet::from_series(&series, shape, 2, 0.8);
        (shape, params, set)
    }

    #[test]
    fn parameter_blocks_tile_the_vector() {
        let shape = Shape {
            inputs: 5,
            hidden: 3,
            outputs: 2,
        };
        assert_eq!(shape.len(), 5 * 3 + 3 + 3 * 2 + 2);
        assert_eq!(shape.checked_len(), Some(shape.len()));
        let params: Vec<f64> = (0..shape.len()).map(|i| i as f64).collect();
        let blocks = shape.split(&params);
        let lengths: Vec<usize> = blocks.iter().map(|b| b.len()).collect();
        assert_eq!(lengths, [15, 3, 6, 2]);
        assert_eq!(blocks[1][0], shape.b1().start as f64);
        assert_eq!(blocks[3][1], (shape.len() - 1) as f64);
        let huge = Shape {
            inputs: usize::MAX / 2,
            hidden: 4,
            outputs: 1,
        };
        assert_eq!(huge.checked_len(), None);
    }

    #[test]
    fn windows_hold_the_series_in_order() {
        let shape = Shape {
            inputs: 3,
            hidden: 1,
            outputs: 2,
        };
        let series: Vec<f64> = (0..10).map(f64::from).collect();
        let set = TrainingSet::from_series(&series, shape, 2, 0.5);
        // Windows start at 0, 2, 4 (the one at 6 would need index 10).
        assert_eq!(set.len(), 3);
        assert_eq!(set.inputs[(1, 0)], 1.0);
        assert_eq!(set.inputs[(2, 2)], 3.0);
        assert_eq!(set.targets[(2, 0)], 3.5);
        assert_eq!(set.targets[(2, 1)], 4.0);
    }

    #[test]
    fn batch_pass_matches_the_single_window_forward_pass() {
        let (shape, params, set) = tiny();
        let mut work = Workspace::new(&set, shape);
        let mut grad = vec![0.0; shape.len()];
        let loss = loss_and_gradient(shape, &params, &set, &mut work, &mut grad);
        let mut expected = 0.0;
        for row in 0..set.len() {
            let x: Vec<f64> = (0..shape.inputs).map(|j| set.inputs[(row, j)]).collect();
            let mut y = shape.split(&params)[3].to_vec();
            accumulate_output(shape, &params, &x, 1.0, &mut y);
            for (k, yk) in y.iter().enumerate() {
                expected += 0.5 * (yk - set.targets[(row, k)]).powi(2);
            }
        }
        expected /= set.len() as f64;
        assert!(
            (loss - expected).abs() < 1e-12 * expected.max(1.0),
            "{loss} vs {expected}"
        );
    }

    #[test]
    fn gradient_matches_central_differences() {
        let (shape, params, set) = tiny();
        let mut work = Workspace::new(&set, shape);
        let mut grad = vec![0.0; shape.len()];
        loss_and_gradient(shape, &params, &set, &mut work, &mut grad);
        let mut scratch = vec![0.0; shape.len()];
        let step = 1e-6;
        for i in 0..shape.len() {
            let mut shifted = params.clone();
            shifted[i] = params[i] + step;
            let up = loss_and_gradient(shape, &shifted, &set, &mut work, &mut scratch);
            shifted[i] = params[i] - step;
            let down = loss_and_gradient(shape, &shifted, &set, &mut work, &mut scratch);
            let numeric = (up - down) / (2.0 * step);
            assert!(
                (grad[i] - numeric).abs() <= 1e-7 * (1.0 + numeric.abs()),
                "parameter {i}: backward {} vs finite difference {numeric}",
                grad[i]
            );
        }
        // Every block of the gradient is exercised (no block silently left at zero).
        for block in shape.split(&grad) {
            assert!(block.iter().any(|g| g.abs() > 1e-6));
        }
    }
}
