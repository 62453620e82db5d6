//! Wave spectra S(w) [m^2 s / rad] of a sea state given by significant wave height and peak period.
//!
//! - JONSWAP in the DNV-RP-C205 form, with the peak enhancement gamma derived from Tp / sqrt(Hs)
//!   when not given (gamma = 1 is the Pierson-Moskowitz spectrum).
//! - ITTC two-parameter (Bretschneider) spectrum in terms of Hs and the mean period T1; the peak
//!   period given by the user is converted with T1 = 0.772 Tp, which holds for that shape.

use super::SimError;
use serde::{Deserialize, Serialize};
use shipcast_wire::shown::number;
use std::f64::consts::PI;

/// Which spectral shape.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SpectrumKind {
    Jonswap,
    Ittc,
}

impl std::str::FromStr for SpectrumKind {
    type Err = SimError;
    fn from_str(s: &str) -> Result<Self, SimError> {
        super::parse_named(
            s,
            "spectrum",
            &[
                ("jonswap", SpectrumKind::Jonswap),
                ("ittc", SpectrumKind::Ittc),
            ],
        )
    }
}

/// A one-sided wave spectrum ready to evaluate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Spectrum {
    pub kind: SpectrumKind,
    pub hs_m: f64,
    pub tp_s: f64,
    /// JONSWAP peak enhancement (1 for ITTC).
    pub gamma: f64,
}

/// DNV-RP-C205 recommendation for gamma when only Hs and Tp are known.
pub fn dnv_gamma(hs_m: f64, tp_s: f64) -> f64 {
    let ratio = tp_s / hs_m.sqrt();
    if ratio <= 3.6 {
        5.0
    } else if ratio >= 5.0 {
        1.0
    } else {
        (5.75 - 1.15 * ratio).exp()
    }
}

impl Spectrum {
    /// Builds a spectrum; `gamma` = None takes the DNV value for JONSWAP.
    pub fn new(
        kind: SpectrumKind,
        hs_m: f64,
        tp_s: f64,
        gamma: Option<f64>,
    ) -> Result<Self, SimError> {
        if !(hs_m.is_finite() && hs_m > 0.0) {
            return Err(SimError::Config(format!(
                "significant wave height must be positive, got {} m",
                number(hs_m)
            )));
        }
        if !(tp_s.is_finite() && tp_s > 0.0) {
            return Err(SimError::Config(format!(
                "peak period must be positive, got {} s",
                number(tp_s)
            )));
        }
        let gamma = match kind {
            SpectrumKind::Ittc => 1.0,
            SpectrumKind::Jonswap => gamma.unwrap_or_else(|| dnv_gamma(hs_m, tp_s)),
        };
        if !(gamma.is_finite() && (1.0..=10.0).contains(&gamma)) {
            return Err(SimError::Config(format!(
                "JONSWAP gamma must lie in [1, 10], got {}",
                number(gamma)
            )));
        }
        Ok(Spectrum {
            kind,
            hs_m,
            tp_s,
            gamma,
        })
    }

    /// Peak frequency [rad/s].
    pub fn peak_omega(&self) -> f64 {
        2.0 * PI / self.tp_s
    }

    /// Spectral density at wave frequency `w` [rad/s]; zero for w <= 0.
    pub fn density(&self, w: f64) -> f64 {
        if w <= 0.0 {
            return 0.0;
        }
        let hs2 = self.hs_m * self.hs_m;
        match self.kind {
            SpectrumKind::Jonswap => {
                let wp = self.peak_omega();
                let pm =
                    5.0 / 16.0 * hs2 * wp.powi(4) * w.powi(-5) * (-1.25 * (wp / w).powi(4)).exp();
                let sigma = if w <= wp { 0.07 } else { 0.09 };
                let r = (-((w - wp) * (w - wp)) / (2.0 * sigma * sigma * wp * wp)).exp();
                (1.0 - 0.287 * self.gamma.ln()) * pm * self.gamma.powf(r)
            }
            SpectrumKind::Ittc => {
                let t1 = 0.772 * self.tp_s;
                let a = 173.0 * hs2 / t1.powi(4);
                let b = 691.0 / t1.powi(4);
                a * w.powi(-5) * (-b / w.powi(4)).exp()
            }
        }
    }

    /// Frequency band [rad/s] holding all but a negligible part (< 0.5 %) of the energy; the
    /// simulator draws its components inside it.
    pub fn band(&self) -> (f64, f64) {
        let wp = self.peak_omega();
        (0.4 * wp, 5.0 * wp)
    }

    /// Zeroth moment m0 = integral of S over all frequencies (Simpson on a wide band), so that
    /// Hs = 4 sqrt(m0) can be checked against what the spectrum really holds.
    pub fn m0(&self) -> f64 {
        let wp = self.peak_omega();
        simpson(|w| self.density(w), 0.05 * wp, 40.0 * wp, 20_000)
    }
}

/// Composite Simpson rule with `n` (made even) intervals.
pub fn simpson(f: impl Fn(f64) -> f64, a: f64, b: f64, n: usize) -> f64 {
    let n = n.max(2) + n % 2;
    let h = (b - a) / n as f64;
    let mut sum = f(a) + f(b);
    for i in 1..n {
        let w = if i % 2 == 1 { 4.0 } else { 2.0 };
        sum += w * f(a + i as f64 * h);
    }
    sum * h / 3.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn m0_gives_back_hs_for_both_shapes() {
        for kind in [SpectrumKind::Jonswap, SpectrumKind::Ittc] {
            let s = Spectrum::new(kind, 3.25, 9.7, None).unwrap();
            let hs = 4.0 * s.m0().sqrt();
            assert!((hs - 3.25).abs() / 3.25 < 0.01, "{kind:?}: Hs {hs}");
        }
        // A peaked JONSWAP: the DNV normalisation (1 - 0.287 ln gamma) is approximate, within 2 %.
        let s = Spectrum::new(SpectrumKind::Jonswap, 4.0, 7.0, Some(3.3)).unwrap();
        assert!((4.0 * s.m0().sqrt() - 4.0).abs() / 4.0 < 0.02);
    }

    #[test]
    fn jonswap_peaks_at_tp_and_gamma_follows_dnv() {
        assert_eq!(dnv_gamma(3.05, 9.7), 1.0);
        assert_eq!(dnv_gamma(4.0, 6.0), 5.0);
        let g = dnv_gamma(4.0, 8.4); // Tp/sqrt(Hs) = 4.2
        assert!((g - (5.75f64 - 1.15 * 4.2).exp()).abs() < 1e-12);
        let s = Spectrum::new(SpectrumKind::Jonswap, 4.0, 8.4, None).unwrap();
        let wp = s.peak_omega();
        assert!(s.density(wp) > s.density(wp * 0.98));
        assert!(s.density(wp) > s.density(wp * 1.02));
    }

    #[test]
    fn rejects_non_positive_parameters() {
        assert!(Spectrum::new(SpectrumKind::Jonswap, -1.0, 9.0, None).is_err());
        assert!(Spectrum::new(SpectrumKind::Ittc, 1.0, 0.0, None).is_err());
        assert!(Spectrum::new(SpectrumKind::Jonswap, 1.0, 9.0, Some(f64::NAN)).is_err());
        assert!("pm".parse::<SpectrumKind>().is_err());
    }
}
