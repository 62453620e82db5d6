//! A second vessel in the same sea: where it sits relative to the reference vessel and how the
//! reference vessel's wave components look from there.
//!
//! The sea is drawn once (same seed) in the frame of the reference vessel: body axes x forward,
//! y starboard, z down, moving with it. A vessel keeping station at (x, y) in that frame with its
//! bow turned `heading_offset_deg` to starboard of the reference heading sees every component
//! - from the direction beta - offset (beta is the direction relative to the reference vessel,
//!   the offset rotates the body axes about z, which points down);
//! - with the phase shifted by the wave number times the distance along the component's
//!   direction of travel: a component travelling along (cos beta, sin beta) is
//!   a cos(w_e t + eps - k (x cos beta + y sin beta)) at (x, y), with k = w^2 / g (deep water).
//!   The simulator writes a component of negative signed encounter frequency (a following wave
//!   overtaken by the ship) as a cos(|w_e| t + eps); its spatial shift has the opposite sign;
//! - at the reference vessel's encounter frequency: keeping station, both move with the same
//!   velocity through the same field.
//!
//! The RAOs are evaluated at the station's own direction and the common speed. That is exact at
//! zero speed or with equal headings (ships side by side on one course, the usual transfer at
//! sea); with different headings at speed it is an approximation (the station vessel's speed
//! along its own heading is then U cos(offset), and it would also crab).

use super::rao::signed_encounter_omega;
use super::{SimError, WaveComponent, G};
use serde::{Deserialize, Serialize};
use shipcast_wire::shown::number;

/// Farthest a second vessel may sit from the reference vessel, along either axis [m].
pub const MAX_STATION_OFFSET_M: f64 = 10_000.0;

/// Position and heading of a simulated vessel relative to the reference vessel.
#[derive(Clone, Copy, Debug, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Station {
    /// Forward of the reference vessel's centre of gravity [m].
    pub x_m: f64,
    /// To starboard of it [m].
    pub y_m: f64,
    /// Bow turned to starboard of the reference heading [deg].
    pub heading_offset_deg: f64,
}

impl Station {
    /// The reference vessel itself.
    pub const REFERENCE: Station = Station {
        x_m: 0.0,
        y_m: 0.0,
        heading_offset_deg: 0.0,
    };

    /// Checks that the station is a finite position and heading.
    pub fn validate(&self) -> Result<(), SimError> {
        if !self.heading_offset_deg.is_finite() {
            return Err(SimError::Config(
                "the vessel's heading offset must be a finite number of degrees".into(),
            ));
        }
        // Two ships in one operation sit within a few hundred metres of each other; far
        // beyond, the phase shifts lose every digit (and the sea would not be the same).
        if ![self.x_m, self.y_m]
            .iter()
            .all(|v| v.is_finite() && v.abs() <= MAX_STATION_OFFSET_M)
        {
            return Err(SimError::Config(format!(
                "the vessel's position must be within +-{MAX_STATION_OFFSET_M} m of the reference vessel, got ({}, {}) m",
                number(self.x_m),
                number(self.y_m)
            )));
        }
        Ok(())
    }

    /// The reference vessel's components (drawn for a ship at `speed` [m/s]) as seen from this
    /// station: direction relative to the station's bow, phase at its position, the reference
    /// encounter frequency.
    pub fn place(&self, components: &[WaveComponent], speed: f64) -> Vec<WaveComponent> {
        components
            .iter()
            .map(|c| WaveComponent {
                beta: self.direction(c.beta),
                phase: c.phase + self.phase_shift(c.omega, c.beta, speed),
                ..*c
            })
            .collect()
    }

    /// The direction [rad] relative to this station's bow of a component that comes from
    /// `beta` relative to the reference bow.
    pub fn direction(&self, beta: f64) -> f64 {
        beta - self.heading_offset_deg.to_radians()
    }

    /// What to add to the phase [rad] of a component (frequency `omega`, from `beta` relative
    /// to the reference bow, met at `speed`) written as a cos(|w_e| t + phase) at the
    /// reference vessel, to have it at this station: -k times the distance along its travel,
    /// the other sign for a component the ship overtakes.
    pub fn phase_shift(&self, omega: f64, beta: f64, speed: f64) -> f64 {
        let k = omega * omega / G;
        let along = self.x_m * beta.cos() + self.y_m * beta.sin();
        let sign = signed_encounter_omega(omega, beta, speed).signum();
        -sign * k * along
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    fn wave(omega: f64, beta: f64) -> WaveComponent {
        WaveComponent {
            omega,
            beta,
            amplitude: 1.0,
            phase: 0.3,
            omega_e: omega,
        }
    }

    #[test]
    fn the_reference_station_changes_nothing() {
        let c = [wave(0.6, PI), wave(0.9, 2.0)];
        assert_eq!(Station::REFERENCE.place(&c, 5.0), c.to_vec());
    }

    #[test]
    fn the_shift_is_the_wave_number_times_the_distance_along_the_travel() {
        let omega = 0.8;
        let k = omega * omega / G;
        // Beam waves from port travel to starboard (beta = 90 deg): 10 m to starboard is
        // 10 m further along them; 10 m forward is across them.
        let c = [wave(omega, PI / 2.0)];
        let starboard = Station {
            y_m: 10.0,
            ..Station::REFERENCE
        };
        let forward = Station {
            x_m: 10.0,
            ..Station::REFERENCE
        };
        assert!((starboard.place(&c, 0.0)[0].phase - (0.3 - 10.0 * k)).abs() < 1e-12);
        assert!((forward.place(&c, 0.0)[0].phase - 0.3).abs() < 1e-12);
        // A following wave overtaken by the ship (negative encounter frequency) shifts the
        // other way in the simulator's |w_e| convention.
        let overtaken = [wave(1.2, 0.0)];
        assert!(signed_encounter_omega(1.2, 0.0, 10.0) < 0.0);
        assert!((forward.place(&overtaken, 10.0)[0].phase - (0.3 + 10.0 * 1.44 / G)).abs() < 1e-12);
        // Turning the bow 30 deg to starboard brings head waves 30 deg onto the port bow.
        let turned = Station {
            heading_offset_deg: 30.0,
            ..Station::REFERENCE
        };
        let b = turned.place(&[wave(0.5, PI)], 0.0)[0];
        assert!((b.beta - (PI - PI / 6.0)).abs() < 1e-12);
        assert_eq!(b.omega_e, 0.5);
        assert!(Station {
            x_m: f64::NAN,
            ..Station::REFERENCE
        }
        .validate()
        .is_err());
    }
}
