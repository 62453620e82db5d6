//! Named scenarios and the simulator's configuration.
//!
//! Sea-state presets are the Bales (1983) North Atlantic means (Hs) and most probable peak
//! periods (Tp). The `paper` scenario is the study of Zhao, Xu and Kwan: their "sea state 3,
//! about 10 ft" is inconsistent (10 ft = 3.05 m is sea state 5), so it uses Hs 3.05 m with the
//! SS5 peak period 9.7 s, a DDG-51-like hull at 11 kn with waves 15 deg off the bow.
//! Every preset uses the same ship operation (11 kn, heading 165 deg) unless overridden.

use super::{Hull, SimError, SpectrumKind, Spreading};
use serde::{Deserialize, Serialize};
use shipcast_wire::shown::number;
use std::path::PathBuf;

/// Metres per second in one knot.
pub const KNOT_MPS: f64 = 1852.0 / 3600.0;

/// A named starting point for a simulation.
/// Read from a configuration as from the command line ([`std::str::FromStr`]: any case,
/// spaces around ignored). Regression (review): `--scenario SS4` was taken while
/// `scenario = "SS4"` in a configuration was an unknown variant.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase", try_from = "String")]
pub enum Scenario {
    Paper,
    Ss3,
    Ss4,
    Ss5,
    Ss6,
}

impl std::str::FromStr for Scenario {
    type Err = SimError;
    fn from_str(s: &str) -> Result<Self, SimError> {
        super::parse_named(
            s,
            "scenario",
            &[
                ("paper", Scenario::Paper),
                ("ss3", Scenario::Ss3),
                ("ss4", Scenario::Ss4),
                ("ss5", Scenario::Ss5),
                ("ss6", Scenario::Ss6),
            ],
        )
    }
}

impl TryFrom<String> for Scenario {
    type Error = SimError;
    fn try_from(s: String) -> Result<Self, SimError> {
        s.parse()
    }
}

impl Scenario {
    /// (Hs [m], Tp [s]).
    pub fn sea_state(self) -> (f64, f64) {
        match self {
            Scenario::Paper => (3.05, 9.7),
            Scenario::Ss3 => (0.88, 7.5),
            Scenario::Ss4 => (1.88, 8.8),
            Scenario::Ss5 => (3.25, 9.7),
            Scenario::Ss6 => (5.0, 12.4),
        }
    }
}

/// Where the RAOs come from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RaoSpec {
    /// Closed-form RAOs of a hull given by its main particulars.
    ClosedForm { hull: Hull },
    /// A CSV table; with both lengths given it is Froude-scaled from `table_length_m` to
    /// `hull_length_m`.
    Table {
        path: PathBuf,
        table_length_m: Option<f64>,
        hull_length_m: Option<f64>,
    },
}

/// Everything that defines a simulated record (the record rate is chosen when streaming).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SimConfig {
    pub spectrum: SpectrumKind,
    pub hs_m: f64,
    pub tp_s: f64,
    /// JONSWAP peak enhancement; None = DNV value from Tp / sqrt(Hs).
    pub gamma: Option<f64>,
    pub speed_kn: f64,
    /// Mean wave direction relative to the ship [deg], 180 = head seas.
    pub heading_deg: f64,
    pub spreading: Spreading,
    /// Some(N): a line spectrum of N components on a fixed frequency grid.
    pub components: Option<usize>,
    pub seed: u64,
    pub rao: RaoSpec,
}

impl Default for SimConfig {
    fn default() -> Self {
        SimConfig::scenario(Scenario::Paper)
    }
}

/// Fastest ship speed accepted [kn]: the fastest naval craft make about 60.
pub const MAX_SPEED_KN: f64 = 60.0;

/// Highest significant wave height accepted [m]: the highest measured are about 20 m.
pub const MAX_HS_M: f64 = 30.0;

/// Peak periods accepted [s]: from a model basin's waves (a 1 m model of a 140 m ship at
/// Froude scale sees 0.8 s for 9.7 s) to the longest swell.
pub const MIN_TP_S: f64 = 0.5;
pub const MAX_TP_S: f64 = 40.0;

/// Steepest sea state accepted: the significant steepness 2 pi Hs / (g Tp^2). Waves break
/// beyond about 1/7 one by one; DNV-RP-C205 (3.5.5) gives 1/15 as the limit of a sea state
/// (for Tp up to 8 s, less for longer periods). Regression (review): Hs 30 m at Tp 0.5 s
/// was simulated as if such a sea could exist.
pub const MAX_STEEPNESS: f64 = 1.0 / 15.0;

impl SimConfig {
    /// The configuration of a named scenario with the default DTMB 5415 hull.
    pub fn scenario(scenario: Scenario) -> Self {
        let (hs_m, tp_s) = scenario.sea_state();
        SimConfig {
            spectrum: SpectrumKind::Jonswap,
            hs_m,
            tp_s,
            gamma: None,
            speed_kn: 11.0,
            heading_deg: 165.0,
            spreading: Spreading::Cos2,
            components: None,
            seed: 1,
            rao: RaoSpec::ClosedForm {
                hull: Hull::dtmb5415(),
            },
        }
    }

    /// Ship speed [m/s].
    pub fn speed_mps(&self) -> f64 {
        self.speed_kn * KNOT_MPS
    }

    /// Checks the ship operation and that the sea state is one a ship meets (the spectrum
    /// checks its own shape when it is built). Unbounded, absurd values (a speed of 1e6 kn, a
    /// peak period of a day) drove every component beyond the RAOs' reach and wrote a record of
    /// zeros without a word.
    pub fn validate(&self) -> Result<(), SimError> {
        if !(self.speed_kn.is_finite() && (0.0..=MAX_SPEED_KN).contains(&self.speed_kn)) {
            return Err(SimError::Config(format!(
                "speed must be in [0, {MAX_SPEED_KN}] kn, got {}",
                number(self.speed_kn)
            )));
        }
        if !(self.hs_m.is_finite() && self.hs_m > 0.0 && self.hs_m <= MAX_HS_M) {
            return Err(SimError::Config(format!(
                "significant wave height must be in (0, {MAX_HS_M}] m, got {}",
                number(self.hs_m)
            )));
        }
        if !(self.tp_s.is_finite() && (MIN_TP_S..=MAX_TP_S).contains(&self.tp_s)) {
            return Err(SimError::Config(format!(
                "peak period must be in [{MIN_TP_S}, {MAX_TP_S}] s, got {}",
                number(self.tp_s)
            )));
        }
        let steepness = 2.0 * std::f64::consts::PI * self.hs_m / (super::G * self.tp_s * self.tp_s);
        if steepness > MAX_STEEPNESS {
            return Err(SimError::Config(format!(
                "a sea of Hs {} m and Tp {} s is steeper (2 pi Hs / g Tp^2 = {steepness:.3}) than any sea state (at most 1/15): at this Tp, Hs is at most {:.2} m",
                self.hs_m,
                self.tp_s,
                MAX_STEEPNESS * super::G * self.tp_s * self.tp_s / (2.0 * std::f64::consts::PI)
            )));
        }
        if !self.heading_deg.is_finite() {
            return Err(SimError::Config(
                "heading must be a finite number of degrees".into(),
            ));
        }
        if let RaoSpec::ClosedForm { hull } = &self.rao {
            hull.validate()?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_scenario_is_read_from_text_in_any_case_and_written_in_lower_case() {
        let read = |text: &str| serde_json::from_str::<Scenario>(text).map_err(|e| e.to_string());
        assert_eq!(read(r#""SS4""#), Ok(Scenario::Ss4));
        assert_eq!(read(r#"" paper ""#), Ok(Scenario::Paper));
        let e = read(r#""ss9""#).unwrap_err();
        assert!(
            e.contains("unknown scenario 'ss9' (expected paper, ss3, ss4, ss5, ss6)"),
            "{e}"
        );
        assert_eq!(serde_json::to_string(&Scenario::Ss6).unwrap(), r#""ss6""#);
    }

    #[test]
    fn scenarios_parse_and_paper_is_ten_feet() {
        let c = SimConfig::scenario("PAPER".parse().unwrap());
        assert!((c.hs_m - 10.0 * 0.3048).abs() < 0.01);
        assert_eq!("ss6".parse::<Scenario>().unwrap().sea_state(), (5.0, 12.4));
        let e = "ss9".parse::<Scenario>().unwrap_err().to_string();
        assert!(e.contains("unknown scenario 'ss9'"), "{e}");
        assert!((SimConfig::default().speed_mps() - 5.659).abs() < 0.001);
    }

    /// Regression (review): a refused 1e300 was shown as 301 digits.
    #[test]
    fn a_refused_huge_value_is_shown_in_exponent_form() {
        let c = SimConfig {
            hs_m: 1e300,
            ..SimConfig::default()
        };
        let e = c.validate().unwrap_err().to_string();
        assert!(
            e.ends_with("significant wave height must be in (0, 30] m, got 1e300"),
            "{e}"
        );
    }
}
