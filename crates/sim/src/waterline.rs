//! Longitudinal integrals of a wave over a realistic waterline, for the closed-form RAOs.
//!
//! The waterline half-beam along the length is taken as w(u) = 1 - |u|^n (u = 2x/L from -1 at
//! the stern to 1 at the bow), the usual one-parameter power-law waterline whose area coefficient
//! is C_WP = n / (n + 1) (e.g. Lewis (ed.), Principles of Naval Architecture, SNAME 1988/89,
//! vol. I, on form coefficients). A box (Jensen, Mansour and Olsen 2004) is the limit n -> inf,
//! whose Froude-Krylov integral sin(s)/s has exact zeros at k L / 2 = pi, 2 pi, ...; a fine-ended
//! waterline spreads those cancellations.
//!
//! Following strip theory (Salvesen, Tuck and Faltinsen 1970; Faltinsen 1990, ch. 3 and 7), the
//! hydrostatic (Froude-Krylov) force of a section scales with its beam w, while its 2-D added mass
//! and wave damping scale with the beam squared (Lewis-form and box sections alike, Faltinsen
//! 1990 ch. 3); so the diffraction and radiation parts of the excitation are integrated with w^2.
//! The two distributions have their zeros at different wave numbers, so their sum does not vanish.
//!
//! All integrals are over the half length u in [0, 1] (the shapes are fore-aft symmetric), by
//! Simpson's rule on a fixed grid (the shape tabulated once) with the wave phasor advanced by
//! rotation: no allocation and one sin/cos per call.

/// Simpson intervals over the half length: resolves k L / 2 up to about 100 (waves of a tenth of
/// the ship length), beyond which the responses are negligible anyway.
const INTERVALS: usize = 256;

/// Normalised longitudinal integrals of one waterline shape.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Waterline {
    /// w(u) at the Simpson nodes u = i / INTERVALS (computed once: no powf per wave).
    shape: [f64; INTERVALS + 1],
    /// int_0^1 w du (= C_WP).
    area: f64,
    /// int_0^1 w^2 du.
    area_sq: f64,
    /// int_0^1 u^2 w du.
    inertia: f64,
    /// int_0^1 u^2 w^2 du.
    inertia_sq: f64,
}

/// Transforms of w (hydrostatic part) and w^2 (added mass and damping part) at one wave number,
/// each normalised to 1 in long waves.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WaveIntegrals {
    /// int w cos(s u) / int w: vertical force.
    pub force: f64,
    /// int w^2 cos(s u) / int w^2.
    pub force_sq: f64,
    /// int u w sin(s u) / (s int u^2 w): pitch (or yaw) moment over the wave slope.
    pub moment: f64,
    /// int u w^2 sin(s u) / (s int u^2 w^2).
    pub moment_sq: f64,
}

impl Waterline {
    /// The power-law waterline with area coefficient `c_wp` in (0, 1).
    pub fn from_area_coefficient(c_wp: f64) -> Self {
        let n = c_wp / (1.0 - c_wp);
        Waterline {
            shape: std::array::from_fn(|i| 1.0 - (i as f64 / INTERVALS as f64).powf(n)),
            area: n / (n + 1.0),
            // int (1 - u^n)^2 = 1 - 2/(n+1) + 1/(2n+1)
            area_sq: 1.0 - 2.0 / (n + 1.0) + 1.0 / (2.0 * n + 1.0),
            // int u^2 (1 - u^n) = 1/3 - 1/(n+3)
            inertia: 1.0 / 3.0 - 1.0 / (n + 3.0),
            // int u^2 (1 - u^n)^2 = 1/3 - 2/(n+3) + 1/(2n+3)
            inertia_sq: 1.0 / 3.0 - 2.0 / (n + 3.0) + 1.0 / (2.0 * n + 3.0),
        }
    }

    /// int u^2 w du / int w du: the waterplane's longitudinal radius of gyration squared over
    /// (L/2)^2 (1/3 for a box).
    pub fn inertia_ratio(&self) -> f64 {
        self.inertia / self.area
    }

    /// int u^2 w^2 du / int w^2 du (1/3 for a box).
    pub fn inertia_sq_ratio(&self) -> f64 {
        self.inertia_sq / self.area_sq
    }

    /// The transforms at s = k_x L / 2 (k_x the wave number along the ship).
    pub fn integrals(&self, s: f64) -> WaveIntegrals {
        let s = s.abs();
        if s < 1e-4 {
            // Long-wave limits (the next terms are O(s^2)).
            return WaveIntegrals {
                force: 1.0,
                force_sq: 1.0,
                moment: 1.0,
                moment_sq: 1.0,
            };
        }
        let h = 1.0 / INTERVALS as f64;
        let (sin_step, cos_step) = (s * h).sin_cos();
        let (mut c, mut sn) = (1.0, 0.0);
        let (mut f1, mut f2, mut m1, mut m2) = (0.0, 0.0, 0.0, 0.0);
        for (i, &w) in self.shape.iter().enumerate() {
            let u = i as f64 * h;
            let weight = if i == 0 || i == INTERVALS {
                1.0
            } else if i % 2 == 1 {
                4.0
            } else {
                2.0
            };
            let w2 = w * w;
            f1 += weight * w * c;
            f2 += weight * w2 * c;
            m1 += weight * u * w * sn;
            m2 += weight * u * w2 * sn;
            (c, sn) = (c * cos_step - sn * sin_step, sn * cos_step + c * sin_step);
        }
        let q = h / 3.0;
        WaveIntegrals {
            force: f1 * q / self.area,
            force_sq: f2 * q / self.area_sq,
            moment: m1 * q / (s * self.inertia),
            moment_sq: m2 * q / (s * self.inertia_sq),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closed_form_moments_match_the_quadrature_limits() {
        let wl = Waterline::from_area_coefficient(0.773);
        assert!((wl.area - 0.773).abs() < 1e-12);
        // Small s: force 1 - s^2 <u^2>/2 with <u^2> = inertia / area.
        let s = 0.05;
        let i = wl.integrals(s);
        let expected = 1.0 - s * s * wl.inertia_ratio() / 2.0;
        assert!(
            (i.force - expected).abs() < 1e-6,
            "{} vs {expected}",
            i.force
        );
        assert!((i.moment - 1.0).abs() < 1e-3);
        assert!((i.force_sq - (1.0 - s * s * wl.inertia_sq_ratio() / 2.0)).abs() < 1e-6);
    }

    #[test]
    fn a_nearly_box_waterline_gives_the_sinc_and_a_parabolic_one_its_own_formula() {
        // n = 999: within 0.1 % of the box, whose force integral is sin(s)/s.
        let box_like = Waterline::from_area_coefficient(0.999);
        for s in [0.5f64, 2.0, 3.0, 6.0] {
            let f = box_like.integrals(s).force;
            assert!((f - s.sin() / s).abs() < 5e-3, "s {s}: {f}");
        }
        // n = 2 (C_WP 2/3): int_0^1 (1-u^2) cos(s u) du = 2 (sin s - s cos s) / s^3, over 2/3.
        let parabola = Waterline::from_area_coefficient(2.0 / 3.0);
        for s in [1.0f64, 3.0, 4.4934, 8.0] {
            let exact = 3.0 * (s.sin() - s * s.cos()) / (s * s * s);
            let f = parabola.integrals(s).force;
            assert!((f - exact).abs() < 1e-6, "s {s}: {f} vs {exact}");
        }
    }

    #[test]
    fn the_fine_waterline_has_no_zero_at_the_box_notch() {
        // The box cancels exactly at s = pi (wave length = ship length); the 5415 waterline not.
        let wl = Waterline::from_area_coefficient(0.773);
        let at_pi = wl.integrals(std::f64::consts::PI);
        assert!(at_pi.force > 0.1, "{}", at_pi.force);
    }
}
