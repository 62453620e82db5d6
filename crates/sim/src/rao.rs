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
//! The closed form (`ClosedFormRao`) is a documented approximation from main particulars, so
//! any hull can be simulated. It generalises Jensen, Mansour and Olsen (Ocean Eng. 31, 2004):
//! - Their homogeneous box barge (beam C_B B, draught T) becomes the equivalent hull with the
//!   ship's waterplane area C_WP L B and volume C_B L B T: mean beam C_WP B, mean depth
//!   T_m = C_B T / C_WP. With their added mass equal to the displaced mass, the heave natural
//!   frequency is sqrt(g / 2 T_m) (theirs, sqrt(g / 2 T), is the case C_WP = C_B).
//! - The Froude-Krylov force is integrated over a power-law waterline of the ship's C_WP rather
//!   than a uniform box, and the diffraction (added mass) and radiation (damping) parts with the
//!   beam squared, as strip theory's sectional coefficients scale ([`super::waterline`]). Their
//!   forcing terms (1 - k T) and A^2 / (k B alpha^3) become these two parts, with A their
//!   sectional wave-damping amplitude 2 sin(k_e B_m / 2) exp(-k_e T_m). The box's exact
//!   sinc zeros go; heave still dips to about 0.4 of the boundary-element solution near
//!   0.75 rad/s for the DTMB 5415 (docs/results/rao_validation.md).
//! - Pitch has its own natural frequency, sqrt(C55 / (I55 + A55)) with C55 from the waterplane's
//!   second moment, I55 from the pitch gyradius and A55 from the same added-mass distribution
//!   (textbook uncoupled pitch, e.g. Lewis (ed.), PNA vol. III, 1989, ch. 8).
//! - Roll is the single-DOF oscillator with a fixed damping ratio (as in Fossen's MSS) at the wet
//!   natural frequency (added inertia A44 / I44 of the hull, [`Hull::roll_natural_omega`]),
//!   driven by the effective wave slope k sin(beta) gamma(k) with gamma = 1 / (1 + k B / 2): the
//!   excitation of a real hull falls off with frequency as pressure decays over the draught and
//!   averages over the beam, but algebraically, not as exp(-k T) (an effective wave slope
//!   coefficient in the sense of Lewis, PNA vol. III, ch. 8; this form is ours, checked against
//!   the boundary-element solution of the DTMB 5415, docs/results/rao_validation.md).
//!
//! Heave and pitch are not coupled (the shapes are fore-aft symmetric). Surge, sway and yaw are
//! our own approximations: the ship follows the horizontal orbital motion of long waves (surge
//! and sway -> 1, yaw -> the rotation of the orbital field along the hull,
//! k sin(beta) cos(beta)), reduced by the Froude-Krylov averaging over the waterline and beam and
//! the decay exp(-k T) over the draught. There is no restoring force in these three, hence no
//! resonance.

use super::waterline::Waterline;
use super::{Hull, G};
use faer::c64;

/// Complex responses of the six DOF (in wire order) per metre of wave amplitude.
pub type Response = [c64; 6];

/// A source of response amplitude operators: closed form, a loaded table, or anything else.
pub trait Rao: Send + Sync + std::fmt::Debug {
    /// Responses to a wave component of frequency `omega` [rad/s] and direction `beta` [rad]
    /// (pi = head seas) for a ship at speed `speed` [m/s], in the convention of this module.
    fn response(&self, omega: f64, beta: f64, speed: f64) -> Response;

    /// Why this source cannot answer for a ship at `speed` [m/s] meeting waves from
    /// `beta_deg` (180 = head seas) without standing in the nearest value it has (None: it
    /// can). A closed form covers everything; a table only its own grid. (The arguments in
    /// the order of [`crate::rao_table::RaoTable::at`].)
    fn coverage_gap(&self, _speed: f64, _beta_deg: f64) -> Option<String> {
        None
    }
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

/// sin(x)/x, with its limit at 0 (averaging over the beam).
fn sinc(x: f64) -> f64 {
    if x.abs() < 1e-6 {
        1.0 - x * x / 6.0
    } else {
        x.sin() / x
    }
}

/// Closed-form responses from main dimensions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClosedFormRao {
    pub hull: Hull,
    waterline: Waterline,
    /// Mean depth of the equivalent hull, C_B T / C_WP [m].
    mean_depth: f64,
    /// Mean beam of the equivalent hull, C_WP B [m].
    mean_beam: f64,
    /// Heave natural frequency sqrt(g / 2 T_m) [rad/s].
    heave_omega: f64,
    /// Pitch natural frequency [rad/s].
    pitch_omega: f64,
    /// Lever of the pitch added-mass (diffraction) moment: A55 / (rho L B (L/2)^2 2 int u^2 w)
    /// over the waterplane's, so that the moment's inertia part is k k_e this [m].
    pitch_inertia_depth: f64,
    /// Pitch damping over heave damping in the same normalisation (1 for a box).
    pitch_damping_factor: f64,
}

impl ClosedFormRao {
    pub fn new(hull: Hull) -> Self {
        let waterline = Waterline::from_area_coefficient(hull.waterplane_coefficient);
        let mean_depth = hull.mean_depth_m();
        let half = hull.lpp_m / 2.0;
        // Per unit rho: C55 / g = B (L/2)^3 2 int u^2 w; the displaced volume V carries the
        // added mass (Jensen et al.), spread like w^2, so A55 = V (L/2)^2 <u^2>_{w^2}.
        let volume = hull.block_coefficient * hull.lpp_m * hull.beam_m * hull.draft_m;
        let c55 = hull.beam_m
            * half.powi(3)
            * 2.0
            * waterline.inertia_ratio()
            * hull.waterplane_coefficient;
        let inertia55 =
            volume * (hull.pitch_gyradius_m.powi(2) + half * half * waterline.inertia_sq_ratio());
        ClosedFormRao {
            hull,
            waterline,
            mean_depth,
            mean_beam: hull.waterplane_coefficient * hull.beam_m,
            heave_omega: (G / (2.0 * mean_depth)).sqrt(),
            pitch_omega: (G * c55 / inertia55).sqrt(),
            pitch_inertia_depth: mean_depth * waterline.inertia_sq_ratio()
                / waterline.inertia_ratio(),
            pitch_damping_factor: waterline.inertia_sq_ratio() / waterline.inertia_ratio(),
        }
    }

    /// Undamped heave natural frequency [rad/s].
    pub fn heave_natural_omega(&self) -> f64 {
        self.heave_omega
    }

    /// Undamped pitch natural frequency [rad/s].
    pub fn pitch_natural_omega(&self) -> f64 {
        self.pitch_omega
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
        let (tm, bm) = (self.mean_depth, self.mean_beam);
        let (sb, cb) = beta.sin_cos();
        let k = omega * omega / G;
        let k_e = (k * cb).abs();
        let we_signed = signed_encounter_omega(omega, beta, speed);
        let we = we_signed.abs();
        let alpha = we / omega;
        let along = self.waterline.integrals(k_e * l / 2.0);
        let kappa = (-k_e * tm).exp();

        // Jensen et al. (2004): sectional wave-damping amplitude A of the equivalent section;
        // damping over stiffness at the encounter frequency (damp_eta) and at the wave frequency
        // (damp_f). A^2 / (k B alpha^2) vanishes as alpha -> 0 (A ~ k B alpha^2).
        let k_enc = k * alpha * alpha;
        let a_term = 2.0 * (k_enc * bm / 2.0).sin() * (-k_enc * tm).exp();
        let (damp_f, damp_eta) = if alpha < 1e-6 {
            (0.0, 0.0)
        } else {
            let q = a_term * a_term / (k_enc * bm);
            (q / alpha, q)
        };
        // Hydrostatic part over the waterline, inertia and damping parts over its square.
        let heave_force = c64::new(
            along.force - k * tm * along.force_sq,
            damp_f * along.force_sq,
        ) * kappa;
        let pd = self.pitch_damping_factor;
        let pitch_moment = c64::new(
            along.moment - k * self.pitch_inertia_depth * along.moment_sq,
            damp_f * pd * along.moment_sq,
        ) * (kappa * k_e);
        let oscillator = |r: f64, damping: f64| c64::new(1.0, 0.0) / c64::new(1.0 - r * r, damping);
        let heave_dyn = oscillator(we / self.heave_omega, damp_eta);
        let pitch_dyn = oscillator(we / self.pitch_omega, damp_eta * pd);

        // Long-wave kinematics (before the conjugation for overtaken waves, see below).
        let minus_i = c64::new(0.0, -1.0);
        let depth_decay = (-k_e * t).exp();
        let beam_average = sinc(k * sb.abs() * h.beam_m / 2.0);
        let horizontal = depth_decay * along.force * beam_average;
        let kin_surge = minus_i * (cb * horizontal);
        let kin_sway = minus_i * (sb * horizontal);
        let kin_heave = -heave_force; // z down: the hull rises with a crest
        let kin_pitch = minus_i * pitch_moment * cb.signum();
        let roll_slope = k * sb * along.force / (1.0 + k * h.beam_m / 2.0);
        let kin_roll = c64::new(0.0, roll_slope);
        let kin_yaw = c64::new(
            -k * sb * cb * depth_decay * along.moment * beam_average,
            0.0,
        );

        let r = we / h.roll_natural_omega();
        let roll_dyn = oscillator(r, 2.0 * h.roll_damping_ratio * r);

        // The kinematic factors hold for the wave as the moving ship sees it, cos(w_e,signed t);
        // for an overtaken wave (w_e,signed < 0) that is cos(w_e t - eps), so in the common form
        // with +eps the kinematic factor is conjugated while the (causal) dynamics keep theirs.
        let adjust = |z: c64| if we_signed < 0.0 { z.conj() } else { z };
        [
            adjust(kin_surge),
            adjust(kin_sway),
            adjust(kin_heave) * heave_dyn,
            adjust(kin_roll) * roll_dyn,
            adjust(kin_pitch) * pitch_dyn,
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
