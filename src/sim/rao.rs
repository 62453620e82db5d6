//! Response amplitude operators: the complex motion per metre of wave amplitude.
//!
//! Convention (the one of the S175 table in tests/fixtures/s175, i.e. MSS / ShipX): body axes
//! x forward, y starboard, z down; roll positive starboard down, pitch positive bow up, yaw
//! positive bow to starboard. A wave component of direction beta (pi = head seas, 0 = following
//! seas) travels along (cos beta, sin beta) in body axes. (The table's README calls 90 deg
//! "waves from starboard"; its numbers, sway -i and roll +i k at 90 deg in long waves, are what
//! this module matches, so closed form and table agree in sign.) With the wave elevation at the centre
//! of gravity a cos(w_e t + eps), the motion of DOF j is Re(H_j a exp(i (w_e t + eps))), where
//! w_e = |w - w^2 U cos(beta) / g| is the encounter frequency.
//!
//! The closed form (`ClosedFormRao`) follows Jensen, Mansour and Olsen (Ocean Eng. 31, 2004) for
//! heave and pitch: a homogeneously loaded box barge of length L, draught T and beam C_B B, with
//! the forcing functions F (heave) and G (pitch) and one damped oscillator with natural frequency
//! sqrt(g / 2T). Roll is their single-DOF roll oscillator with a fixed damping ratio (the
//! simplification Fossen's MSS uses) but driven by the effective wave slope, so that its
//! low-frequency limit is the wave slope k sin(beta). Surge, sway and yaw are our own
//! approximations: the ship follows the horizontal orbital motion of long waves (surge and sway
//! -> 1, yaw -> the rotation of the orbital field along the hull, k sin(beta) cos(beta)), reduced by
//! the Froude-Krylov averaging over the length and beam and the decay exp(-k T) over the draught.
//! There is no restoring force in these three, hence no resonance.

use super::{Hull, G};
use faer::c64;

/// Complex responses of the six DOF (in wire order) per metre of wave amplitude.
pub type Response = [c64; 6];

/// A source of response amplitude operators: closed form, a loaded table, or anything else.
pub trait Rao: Send + Sync + std::fmt::Debug {
    /// Responses to a wave component of frequency `omega` [rad/s] and direction `beta` [rad]
    /// (pi = head seas) for a ship at speed `speed` [m/s], in the convention of this module.
    fn response(&self, omega: f64, beta: f64, speed: f64) -> Response;
}

/// Signed encounter frequency w - w^2 U cos(beta) / g; negative when following waves are
/// overtaken by the ship.
pub fn signed_encounter_omega(omega: f64, beta: f64, speed: f64) -> f64 {
    omega - omega * omega * speed * beta.cos() / G
}

/// Encounter frequency |w - w^2 U cos(beta) / g| [rad/s].
pub fn encounter_omega(omega: f64, beta: f64, speed: f64) -> f64 {
    signed_encounter_omega(omega, beta, speed).abs()
}

/// sin(x)/x, with its limit at 0.
fn sinc(x: f64) -> f64 {
    if x.abs() < 1e-6 {
        1.0 - x * x / 6.0
    } else {
        x.sin() / x
    }
}

/// 3 (sin x - x cos x) / x^3: the first moment of a cosine load over a symmetric span,
/// normalised to 1 at x = 0 (pitch and yaw moments over the length, roll over the beam).
fn moment_factor(x: f64) -> f64 {
    if x.abs() < 1e-3 {
        1.0 - x * x / 10.0
    } else {
        3.0 * (x.sin() - x * x.cos()) / (x * x * x)
    }
}

/// Closed-form responses from main dimensions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClosedFormRao {
    pub hull: Hull,
}

impl ClosedFormRao {
    pub fn new(hull: Hull) -> Self {
        ClosedFormRao { hull }
    }
}

impl Rao for ClosedFormRao {
    fn response(&self, omega: f64, beta: f64, speed: f64) -> Response {
        let zero = [c64::new(0.0, 0.0); 6];
        if !(omega.is_finite() && omega > 0.0) {
            return zero;
        }
        let h = &self.hull;
        let (l, t) = (h.lpp_m, h.draft_m);
        let b = h.block_coefficient * h.beam_m;
        let (sb, cb) = beta.sin_cos();
        let k = omega * omega / G;
        let k_e = (k * cb).abs();
        let we_signed = signed_encounter_omega(omega, beta, speed);
        let we = we_signed.abs();
        let alpha = we / omega;
        let sigma = k_e * l / 2.0;
        let kappa = (-k_e * t).exp();

        // Jensen et al. (2004): sectional damping term A and the forcing correction f.
        let a_term = 2.0 * (k * b * alpha * alpha / 2.0).sin() * (-k * t * alpha * alpha).exp();
        // A^2 / (k B alpha^3) and A^2 / (k B alpha^2) vanish as alpha -> 0 (A ~ k B alpha^2).
        let (damp_f, damp_eta) = if alpha < 1e-6 {
            (0.0, 0.0)
        } else {
            let q = a_term * a_term / (k * b * alpha * alpha);
            (q / alpha, q)
        };
        let f = ((1.0 - k * t).powi(2) + damp_f * damp_f).sqrt();
        let heave_force = kappa * f * sinc(sigma);
        // G of the paper, written as k_e times the normalised moment factor.
        let pitch_moment = kappa * f * k_e * moment_factor(sigma);
        let vertical = c64::new(1.0, 0.0) / c64::new(1.0 - 2.0 * k * t * alpha * alpha, damp_eta);

        // Long-wave kinematics (before the conjugation for overtaken waves, see below).
        let minus_i = c64::new(0.0, -1.0);
        let beam_average = sinc(k * sb.abs() * h.beam_m / 2.0);
        let along = kappa * sinc(sigma) * beam_average;
        let kin_surge = minus_i * (cb * along);
        let kin_sway = minus_i * (sb * along);
        let kin_heave = c64::new(-heave_force, 0.0); // z down: the hull rises with a crest
        let kin_pitch = minus_i * (cb.signum() * pitch_moment);
        let roll_slope = k
            * sb
            * (-k * t / 2.0).exp()
            * sinc(sigma)
            * moment_factor(k * sb.abs() * h.beam_m / 2.0);
        let kin_roll = c64::new(0.0, roll_slope);
        let kin_yaw = c64::new(
            -k * sb * cb * kappa * moment_factor(sigma) * beam_average,
            0.0,
        );

        let r = we / h.roll_natural_omega();
        let roll_dyn = c64::new(1.0, 0.0) / c64::new(1.0 - r * r, 2.0 * h.roll_damping_ratio * r);

        // The kinematic factors hold for the wave as the moving ship sees it, cos(w_e,signed t);
        // for an overtaken wave (w_e,signed < 0) that is cos(w_e t - eps), so in the common form
        // with +eps the kinematic factor is conjugated while the (causal) dynamics keep theirs.
        let adjust = |z: c64| if we_signed < 0.0 { z.conj() } else { z };
        [
            adjust(kin_surge),
            adjust(kin_sway),
            adjust(kin_heave) * vertical,
            adjust(kin_roll) * roll_dyn,
            adjust(kin_pitch) * vertical,
            adjust(kin_yaw),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn long_waves_heave_to_one_and_pitch_to_wave_slope_in_head_seas() {
        let rao = ClosedFormRao::new(Hull::dtmb5415());
        let w = 0.08;
        let k = w * w / G;
        let h = rao.response(w, PI, 5.0);
        assert!((h[2].norm() - 1.0).abs() < 0.01, "heave {}", h[2]);
        assert!((h[4].norm() / k - 1.0).abs() < 0.01, "pitch {} k {k}", h[4]);
        assert!((h[0].norm() - 1.0).abs() < 0.01, "surge {}", h[0]);
        // Same phases as the S175 table: heave pi (z down), pitch and surge +pi/2.
        assert!(h[2].re < 0.0 && h[4].im > 0.0 && h[0].im > 0.0);
    }

    #[test]
    fn short_waves_are_filtered_out() {
        let rao = ClosedFormRao::new(Hull::dtmb5415());
        let h = rao.response(2.5, PI, 5.0);
        for (j, z) in h.iter().enumerate() {
            assert!(z.norm() < 0.05, "dof {j}: {z}");
        }
    }

    #[test]
    fn encounter_frequency_rises_in_head_and_falls_in_following_seas() {
        let w = 0.6;
        assert!(encounter_omega(w, PI, 5.0) > w);
        assert!(encounter_omega(w, 0.0, 5.0) < w);
        assert!((encounter_omega(w, PI / 2.0, 5.0) - w).abs() < 1e-12);
    }
}
