//! The MCA settings the study compares: the paper's, the improvements to its minor-component
//! rule (ridge, validated energy threshold), and shipcast's eigenvalue-weighted MCA (every
//! eigen-direction weighted by 1/(lambda + eps): the conditional mean, not the paper's method).

use super::plan::Plan;
use shipcast_predict::{McaWeighting, PredictorConfig};

/// Settings of MCA: the paper's, or an improvement the predictor offers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Variant {
    Paper,
    Ridge,
    Validated,
    RidgeValidated,
    /// Inverse weighting with the paper's window shift and the default ridge.
    Inverse,
    /// Inverse weighting with overlapping windows (`Plan::inverse_shift`) and the ridge chosen
    /// by validation on the end of the training segment.
    InverseValidated,
}

impl Variant {
    /// Every variant besides the paper's, in the order the report lists them.
    pub const IMPROVED: [Variant; 5] = [
        Variant::Ridge,
        Variant::Validated,
        Variant::RidgeValidated,
        Variant::Inverse,
        Variant::InverseValidated,
    ];

    /// The eigenvalue-weighted variants (shipcast's, not the paper's method).
    pub const INVERSE: [Variant; 2] = [Variant::Inverse, Variant::InverseValidated];

    pub fn name(self) -> &'static str {
        match self {
            Variant::Paper => "paper settings",
            Variant::Ridge => "ridge",
            Variant::Validated => "validated energy",
            Variant::RidgeValidated => "ridge + validated energy",
            Variant::Inverse => "1/lambda weighting, shift 10",
            Variant::InverseValidated => "1/lambda weighting, shift 2, validated ridge",
        }
    }

    pub fn is_inverse(self) -> bool {
        Self::INVERSE.contains(&self)
    }

    /// The predictor configuration of this variant at `order` and `horizon`.
    pub fn config(self, plan: &Plan, order: usize, horizon: usize) -> PredictorConfig {
        let mut c = PredictorConfig {
            order,
            horizon,
            mlp_epochs: plan.mlp_epochs,
            seed: plan.seed,
            ..PredictorConfig::default()
        };
        match self {
            Variant::Paper => {}
            Variant::Ridge => c.mca_ridge = plan.mca_ridge,
            Variant::Validated => c.mca_validate_energy = true,
            Variant::RidgeValidated => {
                c.mca_ridge = plan.mca_ridge;
                c.mca_validate_energy = true;
            }
            // mca_ridge 0 selects the predictor's default eps for inverse weighting.
            Variant::Inverse => c.mca_weighting = McaWeighting::Inverse,
            Variant::InverseValidated => {
                c.mca_weighting = McaWeighting::Inverse;
                c.mca_shift = plan.inverse_shift;
                c.mca_validate_energy = true;
            }
        }
        c
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn configs_differ_from_the_paper_only_where_the_variant_says() {
        let plan = Plan::full(1);
        let paper = Variant::Paper.config(&plan, 800, 50);
        assert_eq!(paper.mca_weighting, McaWeighting::Paper);
        assert_eq!((paper.mca_shift, paper.mca_ridge), (10, 0.0));
        assert!(!paper.mca_validate_energy);

        let ridge = Variant::Ridge.config(&plan, 800, 50);
        assert_eq!(ridge.mca_ridge, plan.mca_ridge);
        assert!(!ridge.mca_validate_energy);

        let inverse = Variant::Inverse.config(&plan, 800, 50);
        assert_eq!(inverse.mca_weighting, McaWeighting::Inverse);
        assert_eq!((inverse.mca_shift, inverse.mca_ridge), (10, 0.0));
        assert!(!inverse.mca_validate_energy);

        let validated = Variant::InverseValidated.config(&plan, 800, 50);
        assert_eq!(validated.mca_weighting, McaWeighting::Inverse);
        assert_eq!(validated.mca_shift, plan.inverse_shift);
        assert!(validated.mca_validate_energy);

        assert!(Variant::IMPROVED.iter().all(|v| *v != Variant::Paper));
        assert!(Variant::IMPROVED
            .iter()
            .all(|v| v.is_inverse() == Variant::INVERSE.contains(v)));
    }
}
