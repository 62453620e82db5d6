//! The irregular sea as a finite sum of regular wave components, drawn once from a seed.
//!
//! Default: the frequency band is cut into bins (and the spread into direction bins), each cell
//! gets one component at a random frequency and direction inside it, amplitude
//! sqrt(2 S(w) dw D_bin), and a random phase. The random frequencies matter: a sum of
//! components on a fixed grid repeats itself and is perfectly predictable, which is what
//! `Components::FixedGrid` reproduces on purpose (a line spectrum of N lines at the bin centres).

use super::{encounter_omega, SimError, Spectrum, Spreading};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use std::f64::consts::TAU;

/// How the components are laid out.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Components {
    /// Random frequency and direction inside each (frequency, direction) cell.
    Random { freq_bins: usize, dir_bins: usize },
    /// `lines` components at fixed, equally spaced frequencies; with spreading, each line gets
    /// one random direction drawn from the spreading function.
    FixedGrid { lines: usize },
}

impl Components {
    /// Default layout for a spreading: at least 1000 components.
    pub fn default_for(spreading: Spreading) -> Self {
        match spreading {
            Spreading::None => Components::Random {
                freq_bins: 1000,
                dir_bins: 1,
            },
            Spreading::Cos2 => Components::Random {
                freq_bins: 80,
                dir_bins: 15,
            },
        }
    }
}

/// Upper limit on the number of components: beyond it the memory and time per sample grow
/// with no gain in realism.
pub const MAX_COMPONENTS: usize = 200_000;

/// One regular wave.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WaveComponent {
    /// Wave (absolute) frequency [rad/s].
    pub omega: f64,
    /// Direction relative to the ship [rad], pi = head seas.
    pub beta: f64,
    /// Amplitude [m].
    pub amplitude: f64,
    /// Random phase [rad].
    pub phase: f64,
    /// Encounter frequency [rad/s].
    pub omega_e: f64,
}

/// Draws the components of a sea with mean direction `mean_beta` [rad] for a ship at `speed`.
pub fn draw_components(
    spectrum: &Spectrum,
    spreading: Spreading,
    mean_beta: f64,
    speed: f64,
    layout: Components,
    seed: u64,
) -> Result<Vec<WaveComponent>, SimError> {
    let count = match layout {
        Components::Random {
            freq_bins,
            dir_bins,
        } => freq_bins.saturating_mul(if spreading == Spreading::None {
            1
        } else {
            dir_bins
        }),
        Components::FixedGrid { lines } => lines,
    };
    if count > MAX_COMPONENTS {
        return Err(SimError::Config(format!(
            "{count} wave components requested, at most {MAX_COMPONENTS} are supported"
        )));
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (w_lo, w_hi) = spectrum.band();
    let mut out = Vec::new();
    let mut push = |omega: f64, beta: f64, energy: f64, phase: f64| {
        out.push(WaveComponent {
            omega,
            beta,
            amplitude: (2.0 * energy).sqrt(),
            phase,
            omega_e: encounter_omega(omega, beta, speed),
        })
    };
    match layout {
        Components::Random {
            freq_bins,
            dir_bins,
        } => {
            if freq_bins == 0 || dir_bins == 0 {
                return Err(SimError::Config("component bins must be at least 1".into()));
            }
            let dw = (w_hi - w_lo) / freq_bins as f64;
            let dirs = spreading.bins(dir_bins);
            for i in 0..freq_bins {
                for d in &dirs {
                    let omega = w_lo + (i as f64 + rng.random::<f64>()) * dw;
                    let mu = d.lo + rng.random::<f64>() * (d.hi - d.lo);
                    let phase = rng.random::<f64>() * TAU;
                    push(
                        omega,
                        mean_beta + mu,
                        spectrum.density(omega) * dw * d.weight,
                        phase,
                    );
                }
            }
        }
        Components::FixedGrid { lines } => {
            if lines == 0 {
                return Err(SimError::Config("--components must be at least 1".into()));
            }
            let dw = (w_hi - w_lo) / lines as f64;
            for i in 0..lines {
                let omega = w_lo + (i as f64 + 0.5) * dw;
                let mu = spreading.quantile(rng.random::<f64>());
                let phase = rng.random::<f64>() * TAU;
                push(omega, mean_beta + mu, spectrum.density(omega) * dw, phase);
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::SpectrumKind;
    use std::f64::consts::PI;

    #[test]
    fn component_energy_adds_up_to_m0() {
        let s = Spectrum::new(SpectrumKind::Jonswap, 3.05, 9.7, None).unwrap();
        for spreading in [Spreading::None, Spreading::Cos2] {
            let layout = Components::default_for(spreading);
            let c = draw_components(&s, spreading, PI, 5.0, layout, 7).unwrap();
            assert!(c.len() >= 1000);
            let var: f64 = c.iter().map(|c| c.amplitude * c.amplitude / 2.0).sum();
            assert!(
                (var / s.m0() - 1.0).abs() < 0.02,
                "{spreading:?}: {var} vs {}",
                s.m0()
            );
        }
    }

    #[test]
    fn fixed_grid_has_the_requested_lines_on_a_regular_grid() {
        let s = Spectrum::new(SpectrumKind::Jonswap, 3.05, 9.7, None).unwrap();
        let c = draw_components(
            &s,
            Spreading::None,
            PI,
            0.0,
            Components::FixedGrid { lines: 8 },
            1,
        )
        .unwrap();
        assert_eq!(c.len(), 8);
        let dw = c[1].omega - c[0].omega;
        assert!(c
            .windows(2)
            .all(|p| ((p[1].omega - p[0].omega) - dw).abs() < 1e-12));
        assert!(draw_components(
            &s,
            Spreading::None,
            PI,
            0.0,
            Components::FixedGrid { lines: 0 },
            1
        )
        .is_err());
    }
}
