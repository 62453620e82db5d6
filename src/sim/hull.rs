//! Main particulars of a hull, enough for the closed-form response functions.

use super::SimError;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// Main dimensions and roll properties of a monohull.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Hull {
    /// Length between perpendiculars [m].
    pub lpp_m: f64,
    /// Moulded beam [m].
    pub beam_m: f64,
    /// Draught [m].
    pub draft_m: f64,
    /// Block coefficient C_B.
    pub block_coefficient: f64,
    /// Transverse metacentric height GM_T [m].
    pub gm_m: f64,
    /// Roll radius of gyration including added inertia [m].
    pub roll_gyradius_m: f64,
    /// Linearised roll damping as a fraction of critical (wave, viscous and bilge keels).
    pub roll_damping_ratio: f64,
}

impl Default for Hull {
    fn default() -> Self {
        Hull::dtmb5415()
    }
}

impl Hull {
    /// DTMB 5415 combatant, the public proxy of a DDG-51 destroyer (roll period about 10 s).
    pub fn dtmb5415() -> Self {
        Hull {
            lpp_m: 142.0,
            beam_m: 19.06,
            draft_m: 6.15,
            block_coefficient: 0.507,
            gm_m: 1.95,
            roll_gyradius_m: 0.37 * 19.06,
            // A destroyer with bilge keels under way: about 0.1 of critical.
            roll_damping_ratio: 0.1,
        }
    }

    /// S175 container ship (tests/fixtures/s175/main_particulars.json); its roll gyradius there
    /// is the dry one, so the natural period here is shorter than the table's (no added inertia).
    pub fn s175() -> Self {
        Hull {
            lpp_m: 175.0,
            beam_m: 25.4,
            draft_m: 9.5,
            block_coefficient: 0.569,
            gm_m: 0.996,
            roll_gyradius_m: 8.331,
            roll_damping_ratio: 0.1,
        }
    }

    /// Geometrically similar hull of another length (all lengths scaled alike).
    pub fn scaled_to_length(&self, lpp_m: f64) -> Result<Self, SimError> {
        if !(lpp_m.is_finite() && lpp_m > 0.0) {
            return Err(SimError::Config(format!(
                "hull length must be positive, got {lpp_m} m"
            )));
        }
        let f = lpp_m / self.lpp_m;
        Ok(Hull {
            lpp_m,
            beam_m: self.beam_m * f,
            draft_m: self.draft_m * f,
            gm_m: self.gm_m * f,
            roll_gyradius_m: self.roll_gyradius_m * f,
            ..*self
        })
    }

    /// Natural roll frequency [rad/s] of the undamped roll oscillator: sqrt(g GM) / k_xx.
    pub fn roll_natural_omega(&self) -> f64 {
        (super::G * self.gm_m).sqrt() / self.roll_gyradius_m
    }

    /// Natural roll period [s].
    pub fn roll_period_s(&self) -> f64 {
        2.0 * PI / self.roll_natural_omega()
    }

    /// Checks that every particular is physically meaningful.
    pub fn validate(&self) -> Result<(), SimError> {
        let positive = [
            ("lpp_m", self.lpp_m),
            ("beam_m", self.beam_m),
            ("draft_m", self.draft_m),
            ("gm_m", self.gm_m),
            ("roll_gyradius_m", self.roll_gyradius_m),
        ];
        for (name, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err(SimError::Config(format!(
                    "hull {name} must be positive, got {v}"
                )));
            }
        }
        if !(self.block_coefficient > 0.0 && self.block_coefficient <= 1.0) {
            return Err(SimError::Config(format!(
                "hull block coefficient must lie in (0, 1], got {}",
                self.block_coefficient
            )));
        }
        if !(self.roll_damping_ratio > 0.0 && self.roll_damping_ratio < 1.0) {
            return Err(SimError::Config(format!(
                "roll damping ratio must lie in (0, 1), got {}",
                self.roll_damping_ratio
            )));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dtmb5415_rolls_at_about_ten_seconds() {
        let t = Hull::dtmb5415().roll_period_s();
        assert!((9.5..10.7).contains(&t), "roll period {t}");
    }

    #[test]
    fn scaling_keeps_ratios_and_rejects_nonsense() {
        let h = Hull::dtmb5415().scaled_to_length(71.0).unwrap();
        assert!((h.beam_m - 9.53).abs() < 1e-9);
        // Froude similarity: periods scale with sqrt(length).
        let ratio = Hull::dtmb5415().roll_period_s() / h.roll_period_s();
        assert!((ratio - 2f64.sqrt()).abs() < 1e-9);
        assert!(Hull::dtmb5415().scaled_to_length(-3.0).is_err());
        let bad = Hull {
            block_coefficient: 1.5,
            ..Hull::dtmb5415()
        };
        assert!(bad.validate().is_err());
    }
}
