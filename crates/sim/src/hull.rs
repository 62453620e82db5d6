//! Main particulars of a hull, enough for the closed-form response functions.

use super::SimError;
use serde::{Deserialize, Serialize};
use shipcast_wire::shown::number;
use std::f64::consts::PI;

/// Hull lengths accepted [m], from a model-basin hull to the largest ships afloat.
pub const MIN_LENGTH_M: f64 = 1.0;
pub const MAX_LENGTH_M: f64 = 500.0;

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
    /// Waterplane area coefficient C_WP (waterplane area over L B); at least C_B.
    pub waterplane_coefficient: f64,
    /// Transverse metacentric height GM_T [m].
    pub gm_m: f64,
    /// Dry roll radius of gyration k44 [m] (the ship's own mass only).
    pub roll_gyradius_m: f64,
    /// Added roll inertia over the dry roll inertia, A44 / I44 (typically 0.1-0.3).
    pub roll_added_inertia_ratio: f64,
    /// Dry pitch radius of gyration k55 [m] (about 0.25 L for most ships).
    pub pitch_gyradius_m: f64,
    /// Linearised roll damping as a fraction of critical (wave, viscous and bilge keels).
    pub roll_damping_ratio: f64,
}

impl Default for Hull {
    fn default() -> Self {
        Hull::dtmb5415()
    }
}

impl Hull {
    /// DTMB 5415 combatant, the public proxy of a DDG-51 destroyer. C_WP 0.773 and A44/I44 = 0.19
    /// are those of the boundary-element solution in tests/fixtures/dtmb5415-bem (wet roll period
    /// 11.0 s; 10.1 s dry).
    pub fn dtmb5415() -> Self {
        Hull {
            lpp_m: 142.0,
            beam_m: 19.06,
            draft_m: 6.15,
            block_coefficient: 0.507,
            waterplane_coefficient: 0.773,
            gm_m: 1.95,
            roll_gyradius_m: 0.37 * 19.06,
            roll_added_inertia_ratio: 0.19,
            pitch_gyradius_m: 0.25 * 142.0,
            // A destroyer with bilge keels under way: about 0.1 of critical.
            roll_damping_ratio: 0.1,
        }
    }

    /// S175 container ship (main particulars of the S175 RAO table, tests/fixtures/s175). The
    /// table gives no C_WP: it is estimated as (1 + 2 C_B) / 3 (Schneekluth and Bertram, Ship
    /// Design for Efficiency and Economy, 1998). A44/I44 = 0.46 puts the wet roll frequency at
    /// the table's roll peak, 0.31 rad/s (the dry gyradius alone gives 0.375 rad/s).
    pub fn s175() -> Self {
        Hull {
            lpp_m: 175.0,
            beam_m: 25.4,
            draft_m: 9.5,
            block_coefficient: 0.569,
            waterplane_coefficient: (1.0 + 2.0 * 0.569) / 3.0,
            gm_m: 0.996,
            roll_gyradius_m: 8.331,
            roll_added_inertia_ratio: 0.46,
            pitch_gyradius_m: 42.0,
            roll_damping_ratio: 0.1,
        }
    }

    /// Geometrically similar hull of another length (all lengths scaled alike).
    pub fn scaled_to_length(&self, lpp_m: f64) -> Result<Self, SimError> {
        if !(lpp_m.is_finite() && (MIN_LENGTH_M..=MAX_LENGTH_M).contains(&lpp_m)) {
            return Err(SimError::Config(format!(
                "hull length must be in [{MIN_LENGTH_M}, {MAX_LENGTH_M}] m, got {} m",
                number(lpp_m)
            )));
        }
        let f = lpp_m / self.lpp_m;
        Ok(Hull {
            lpp_m,
            beam_m: self.beam_m * f,
            draft_m: self.draft_m * f,
            gm_m: self.gm_m * f,
            roll_gyradius_m: self.roll_gyradius_m * f,
            pitch_gyradius_m: self.pitch_gyradius_m * f,
            ..*self
        })
    }

    /// Wet natural roll frequency [rad/s] of the undamped roll oscillator,
    /// sqrt(C44 / (I44 + A44)) = sqrt(g GM / (k44^2 (1 + A44/I44))) (Fossen, Handbook of Marine
    /// Craft Hydrodynamics and Motion Control, 2011, ch. 4; Faltinsen 1990, ch. 3).
    pub fn roll_natural_omega(&self) -> f64 {
        (super::G * self.gm_m).sqrt()
            / (self.roll_gyradius_m * (1.0 + self.roll_added_inertia_ratio).sqrt())
    }

    /// Mean draught of the waterplane, displaced volume over waterplane area: C_B T / C_WP [m].
    pub fn mean_depth_m(&self) -> f64 {
        self.block_coefficient * self.draft_m / self.waterplane_coefficient
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
            ("pitch_gyradius_m", self.pitch_gyradius_m),
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
        if !(self.waterplane_coefficient >= self.block_coefficient
            && self.waterplane_coefficient < 1.0)
        {
            return Err(SimError::Config(format!(
                "hull waterplane coefficient must lie in [C_B, 1) = [{}, 1), got {}",
                self.block_coefficient, self.waterplane_coefficient
            )));
        }
        if !(self.roll_added_inertia_ratio >= 0.0 && self.roll_added_inertia_ratio < 2.0) {
            return Err(SimError::Config(format!(
                "roll added inertia ratio A44/I44 must lie in [0, 2), got {}",
                self.roll_added_inertia_ratio
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
    fn dtmb5415_rolls_at_the_wet_period_of_the_bem_solution() {
        // 11.0 s from the boundary-element solution (tests/fixtures/dtmb5415-bem/README.md).
        let t = Hull::dtmb5415().roll_period_s();
        assert!((t / 11.0 - 1.0).abs() < 0.03, "roll period {t}");
        let dry = Hull {
            roll_added_inertia_ratio: 0.0,
            ..Hull::dtmb5415()
        };
        assert!((dry.roll_period_s() - 10.13).abs() < 0.05);
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
        let thin_waterplane = Hull {
            waterplane_coefficient: 0.4,
            ..Hull::dtmb5415()
        };
        let e = thin_waterplane.validate().unwrap_err().to_string();
        assert!(e.contains("waterplane coefficient"), "{e}");
        assert!(Hull {
            roll_added_inertia_ratio: -0.1,
            ..Hull::dtmb5415()
        }
        .validate()
        .is_err());
    }
}
