//! iRprop- (Igel and Huesken, 2000): resilient backpropagation without weight backtracking.
//!
//! Every parameter has its own step size. Only the sign of its gradient is used: the step grows
//! while the sign stays the same and shrinks when it flips; after a flip the parameter rests for
//! one epoch (its stored gradient is zeroed). Insensitive to the scale of the gradient, which is
//! why full-batch training of the MLP needs no learning rate.

/// Growth of a step while the gradient keeps its sign.
const GROW: f64 = 1.2;
/// Shrink of a step when the gradient changes sign.
const SHRINK: f64 = 0.5;
/// Bounds on a step, in network units (inputs and outputs are scaled to unit spread).
const STEP_MIN: f64 = 1e-9;
const STEP_MAX: f64 = 1.0;

/// Optimiser state: one step size and the previous gradient per parameter.
pub struct Rprop {
    steps: Vec<f64>,
    previous: Vec<f64>,
}

impl Rprop {
    /// Start with the given step size per parameter.
    pub fn new(initial_steps: Vec<f64>) -> Self {
        let previous = vec![0.0; initial_steps.len()];
        Self {
            steps: initial_steps,
            previous,
        }
    }

    /// Move `params` against the sign of `grad` by each parameter's step.
    pub fn step(&mut self, params: &mut [f64], grad: &[f64]) {
        let state = self.steps.iter_mut().zip(self.previous.iter_mut());
        for ((p, &g), (step, previous)) in params.iter_mut().zip(grad).zip(state) {
            let agreement = g * *previous;
            let g = if agreement > 0.0 {
                *step = (*step * GROW).min(STEP_MAX);
                g
            } else if agreement < 0.0 {
                *step = (*step * SHRINK).max(STEP_MIN);
                0.0
            } else {
                g
            };
            if g > 0.0 {
                *p -= *step;
            } else if g < 0.0 {
                *p += *step;
            }
            *previous = g;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn minimises_a_badly_scaled_quadratic() {
        // f(p) = 1e6 (p0 - 3)^2 + 1e-3 (p1 + 2)^2: gradient scales differ by 1e9, which a
        // fixed learning rate cannot handle but Rprop (signs only) can.
        let mut p = vec![0.0, 0.0];
        let mut opt = Rprop::new(vec![0.1, 0.1]);
        for _ in 0..200 {
            let grad = [2e6 * (p[0] - 3.0), 2e-3 * (p[1] + 2.0)];
            opt.step(&mut p, &grad);
        }
        assert!((p[0] - 3.0).abs() < 1e-6, "{p:?}");
        assert!((p[1] + 2.0).abs() < 1e-6, "{p:?}");
    }

    #[test]
    fn a_sign_flip_shrinks_the_step_and_rests_one_epoch() {
        let mut p = vec![0.0];
        let mut opt = Rprop::new(vec![0.5]);
        opt.step(&mut p, &[1.0]);
        assert_eq!(p, [-0.5]);
        opt.step(&mut p, &[1.0]);
        assert_eq!(p, [-0.5 - 0.6]);
        // Flip: the step halves and the parameter does not move.
        opt.step(&mut p, &[-1.0]);
        assert_eq!(p, [-1.1]);
        // Next epoch moves by the halved step.
        opt.step(&mut p, &[-1.0]);
        assert!((p[0] - (-1.1 + 0.3)).abs() < 1e-15, "{p:?}");
    }
}
