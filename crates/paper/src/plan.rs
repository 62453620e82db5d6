//! The sizes of one study run: the full study of the paper, or `--quick` for smoke tests (same
//! report structure, shorter records, smaller orders, fewer MLP epochs).

use super::seas::SeaKind;
use shipcast_sim::{Scenario, SimConfig};

/// Everything that sizes a run. The record rate (8 Hz) and study rate (2 Hz) are fixed by the
/// paper and live in [`super::seas`].
#[derive(Clone, Debug, PartialEq)]
pub struct Plan {
    pub quick: bool,
    /// Seed of the seas (and of the MLP's initial weights and the noise).
    pub seed: u64,
    /// Training segment length at 2 Hz (paper: 5000).
    pub train: usize,
    /// Test segment length at 2 Hz.
    pub test: usize,
    /// Spacing of scored forecast origins.
    pub stride: usize,
    /// The orders of Table 1, ascending; the last one plays the paper's 800 everywhere else.
    pub orders: Vec<usize>,
    /// Steps forecast (paper: 50 at 2 Hz = 25 s; MCA's window keeps order - horizon past values).
    pub horizon: usize,
    /// MLP Rprop epochs.
    pub mlp_epochs: usize,
    /// Components of the line-spectrum sea.
    pub line_components: usize,
    /// Length of the "predicted against true" figures, 2 Hz samples.
    pub trace_len: usize,
    /// Ridge of the improved MCA variant, relative to the mean diagonal of B2^T B2.
    pub mca_ridge: f64,
    /// Window shift of the validated eigenvalue-weighted MCA: overlapping windows give R full
    /// rank (the paper's shift 10 leaves fewer windows than dimensions at order 800).
    pub inverse_shift: usize,
}

impl Plan {
    /// The paper's study: 5000 training points, orders 40, 100 and 800, 50 steps, a 3000 s test
    /// segment scored every second.
    pub fn full(seed: u64) -> Self {
        Self {
            quick: false,
            seed,
            train: 5000,
            test: 6000,
            stride: 2,
            orders: vec![40, 100, 800],
            horizon: 50,
            mlp_epochs: shipcast_predict::PredictorConfig::default().mlp_epochs,
            line_components: 50,
            trace_len: 600,
            mca_ridge: 1e-3,
            inverse_shift: 2,
        }
    }

    /// A smoke-test study that finishes in well under two minutes: shorter records and orders
    /// 20, 60 and 150 (MCA is infeasible below the horizon, as at order 40 in the full study).
    pub fn quick(seed: u64) -> Self {
        Self {
            quick: true,
            train: 1500,
            test: 1200,
            stride: 10,
            orders: vec![20, 60, 150],
            mlp_epochs: 20,
            trace_len: 300,
            ..Self::full(seed)
        }
    }

    /// The order that plays the paper's 800.
    pub fn big_order(&self) -> usize {
        self.orders.last().copied().unwrap_or(0)
    }

    /// Total record length at 2 Hz.
    pub fn len(&self) -> usize {
        self.train + self.test
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Check that every experiment has at least one forecast origin and the timing runs have
    /// their 500 predictions.
    pub fn validate(&self) -> Result<(), String> {
        let big = self.big_order();
        if self.orders.is_empty()
            || self.horizon == 0
            || self.stride == 0
            || self.inverse_shift == 0
        {
            return Err("the plan needs orders, a horizon, a stride and an MCA shift".into());
        }
        let timing = big + self.horizon + super::paper_values::TABLE2_PREDICTIONS;
        if self.test < timing || self.test < big + self.horizon + self.trace_len {
            return Err(format!(
                "test segment of {} values is too short for order {big}, horizon {} and 500 timed predictions",
                self.test, self.horizon
            ));
        }
        Ok(())
    }
}

/// The paper scenario's simulator settings for a sea kind.
pub fn sim_config(kind: SeaKind, plan: &Plan) -> SimConfig {
    let mut config = SimConfig::scenario(Scenario::Paper);
    config.seed = plan.seed;
    if kind == SeaKind::Line {
        config.components = Some(plan.line_components);
    }
    config
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn both_plans_are_valid_and_quick_is_smaller() {
        let (full, quick) = (Plan::full(1), Plan::quick(1));
        full.validate().unwrap();
        quick.validate().unwrap();
        assert_eq!(full.big_order(), 800);
        assert!(quick.len() < full.len() && quick.big_order() < full.big_order());
        let bad = Plan {
            test: 900,
            ..Plan::full(1)
        };
        assert!(bad.validate().unwrap_err().contains("too short"));
    }
}
