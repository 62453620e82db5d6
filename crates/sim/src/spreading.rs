//! Directional spreading of the wave energy around the mean wave direction.
//!
//! `Cos2` is D(mu) = (2/pi) cos^2(mu) for |mu| <= pi/2 (zero outside), which integrates to one;
//! `None` is a long-crested sea where every component travels in the mean direction.

use super::SimError;
use serde::{Deserialize, Serialize};
use std::f64::consts::{FRAC_PI_2, PI};

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Spreading {
    /// Long-crested sea.
    None,
    /// cos^2 spreading over +-90 deg.
    Cos2,
}

impl std::str::FromStr for Spreading {
    type Err = SimError;
    fn from_str(s: &str) -> Result<Self, SimError> {
        super::parse_named(
            s,
            "spreading",
            &[("cos2", Spreading::Cos2), ("none", Spreading::None)],
        )
    }
}

/// One direction bin: its edges relative to the mean direction [rad] and the share of the
/// energy it holds (the integral of D over the bin).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DirectionBin {
    pub lo: f64,
    pub hi: f64,
    pub weight: f64,
}

/// Cumulative distribution of the cos^2 spreading function on [-pi/2, pi/2].
fn cos2_cdf(mu: f64) -> f64 {
    let mu = mu.clamp(-FRAC_PI_2, FRAC_PI_2);
    (2.0 / PI) * (mu / 2.0 + (2.0 * mu).sin() / 4.0) + 0.5
}

impl Spreading {
    /// Splits the spread into `n` equal-width bins (one bin of zero width for `None`).
    pub fn bins(self, n: usize) -> Vec<DirectionBin> {
        match self {
            Spreading::None => vec![DirectionBin {
                lo: 0.0,
                hi: 0.0,
                weight: 1.0,
            }],
            Spreading::Cos2 => {
                let n = n.max(1);
                let width = PI / n as f64;
                (0..n)
                    .map(|i| {
                        let lo = -FRAC_PI_2 + i as f64 * width;
                        let hi = lo + width;
                        DirectionBin {
                            lo,
                            hi,
                            weight: cos2_cdf(hi) - cos2_cdf(lo),
                        }
                    })
                    .collect()
            }
        }
    }

    /// Direction offset [rad] whose cumulative probability is `u` in [0, 1] (inverse transform
    /// sampling; bisection because the CDF has no closed-form inverse).
    pub fn quantile(self, u: f64) -> f64 {
        match self {
            Spreading::None => 0.0,
            Spreading::Cos2 => {
                let (mut lo, mut hi) = (-FRAC_PI_2, FRAC_PI_2);
                for _ in 0..60 {
                    let mid = 0.5 * (lo + hi);
                    if cos2_cdf(mid) < u {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                0.5 * (lo + hi)
            }
        }
    }

    /// Density D(mu) [1/rad]; for `None` this is a Dirac pulse, reported as 0 except at mu = 0.
    pub fn density(self, mu: f64) -> f64 {
        match self {
            Spreading::None => f64::from(u8::from(mu == 0.0)),
            Spreading::Cos2 if mu.abs() <= FRAC_PI_2 => (2.0 / PI) * mu.cos().powi(2),
            Spreading::Cos2 => 0.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cos2_bins_sum_to_one_and_are_symmetric() {
        let bins = Spreading::Cos2.bins(12);
        let total: f64 = bins.iter().map(|b| b.weight).sum();
        assert!((total - 1.0).abs() < 1e-12);
        assert!((bins[0].weight - bins[11].weight).abs() < 1e-12);
        assert!(bins[6].weight > bins[0].weight * 10.0);
        assert_eq!(Spreading::None.bins(12).len(), 1);
    }

    #[test]
    fn quantile_inverts_the_cdf() {
        assert!(Spreading::Cos2.quantile(0.5).abs() < 1e-9);
        for u in [0.1, 0.3, 0.9] {
            assert!((cos2_cdf(Spreading::Cos2.quantile(u)) - u).abs() < 1e-9);
        }
        assert!("cos4".parse::<Spreading>().is_err());
    }
}
