//! Frozen sensors on either ship: the lift's counterpart of the deck's watch
//! ([`crate::decision::still`], whose rules it applies to each ship).
//!
//! Why: the relative motion is made of both ships' heave, roll and pitch (and surge, sway and
//! yaw, which are not watched: below). A sensor on either ship
//! that repeats its value makes that ship's forecasts and verified errors those of a motion
//! that is not there: the lift then learns from errors of nothing and says go on a calm that
//! never was. So, as the deck does:
//! - while a watched DOF of either ship is frozen the lift states no probability and says no
//!   go, and the advisory names the ship and the DOF;
//! - when it moves again (or that ship's record restarts while it was frozen) the verified
//!   relative errors are dropped, the lift's statements go back to what they were when the
//!   stillness began, the relative forecasts still waiting for their horizon are dropped
//!   unverified (their horizons straddle the thaw), and the sigma calibration and the mean's
//!   shrinkage start afresh, as at start-up: learnt while one ship's errors were those of
//!   nothing, they would leave the relative sigma too narrow after it (review). So go waits
//!   for errors verified on the motion as it is now.
//!
//! Each ship is looked at at its own forecast's origin: the two may be steps apart.
//!
//! Surge, sway and yaw are not watched. Watched with the same rules (2026-12-07, taken out after
//! its review), a heading sensor that reports 0.1 deg on a ship holding station in a calm, its
//! heading wandering slowly by 0.5-1 deg, stays within one step for 30 s near each turn of the
//! wander: in simulation the lift was frozen 7-53 % of the time, with 3-12 thaws an hour (each
//! restarting its evidence), and a position held to 1 cm without dither 14-39 %. The deck's
//! rule assumes motion at wave frequency, which these DOFs do not keep to.

use crate::decision::still::{StillWatch, Stillness, WATCHED};
use crate::observed::ObservedMotion;
use serde::{Deserialize, Serialize};
use shipcast_wire::Dof;

/// Which of the two ships.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Ship {
    /// Ship A, with the crane.
    Crane,
    /// Ship B, with the landing spot.
    Target,
}

impl Ship {
    pub const BOTH: [Ship; 2] = [Ship::Crane, Ship::Target];

    pub fn name(self) -> &'static str {
        match self {
            Ship::Crane => "crane",
            Ship::Target => "target",
        }
    }
}

/// A watched DOF of one ship that repeats its recorded value.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FrozenSensor {
    pub ship: Ship,
    pub dof: Dof,
}

/// The deck's watch of the recorded heave, roll and pitch, once per ship.
#[derive(Debug, Clone, Default)]
pub struct ShipsStillWatch {
    watches: [StillWatch; 2],
}

impl ShipsStillWatch {
    /// Heave, roll and pitch are taken as present in both ships' motion, so one that never
    /// moves is a frozen sensor (the live service: a producer sends 0 for a column its record
    /// lacks, and a lift decided on a roll of 0 that was never measured would be a guess).
    pub fn live() -> Self {
        let mut watch = Self::default();
        for ship in Ship::BOTH {
            watch.set_present(ship, &WATCHED);
        }
        watch
    }

    /// `ship`'s record is known to have these DOFs' columns
    /// ([`StillWatch::set_present`]).
    pub fn set_present(&mut self, ship: Ship, dofs: &[Dof]) {
        self.watches[ship as usize].set_present(dofs);
    }

    /// Look at each ship's recorded values at its own forecast's origin (`times_s`: the
    /// crane's, the target's; each ship's in order, the same again ignored). Each at its own:
    /// the two may be steps apart, on clocks or sample grids out of phase, and a ship looked up
    /// at the other's origin was never found (review). A ship without a sample there is not
    /// looked at this time.
    ///
    /// True at a thaw: a frozen sensor moved again, or the record of a ship with a frozen
    /// sensor restarted, so the evidence gathered since the stillness began is worthless.
    pub fn observe(
        &mut self,
        times_s: [f64; 2],
        crane: &impl ObservedMotion,
        target: &impl ObservedMotion,
    ) -> bool {
        let mut thawed = false;
        let values = [crane.dof_at(times_s[0]), target.dof_at(times_s[1])];
        for ((watch, values), time_s) in self.watches.iter_mut().zip(values).zip(times_s) {
            let Some(values) = values else { continue };
            let frozen_before = watch.frozen().is_some();
            let look = watch.observe(time_s, &values);
            thawed |= look.dofs.contains(&Stillness::Resumed) || (look.restarted && frozen_before);
        }
        thawed
    }

    /// The first frozen sensor, the crane ship's first.
    pub fn frozen(&self) -> Option<FrozenSensor> {
        Ship::BOTH.into_iter().find_map(|ship| {
            self.watches[ship as usize]
                .frozen()
                .map(|dof| FrozenSensor { ship, dof })
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A record whose heave follows `heave(t)` (one sample every 0.125 s).
    struct Record<F: Fn(f64) -> f64>(F);

    impl<F: Fn(f64) -> f64> ObservedMotion for Record<F> {
        fn dof_at(&self, t: f64) -> Option<[f64; 6]> {
            let h = (self.0)(t);
            Some([0.0, 0.0, h, 0.1 * h, 0.05 * h, 0.0])
        }
    }

    struct Nothing;

    impl ObservedMotion for Nothing {
        fn dof_at(&self, _: f64) -> Option<[f64; 6]> {
            None
        }
    }

    #[test]
    fn a_sensor_frozen_on_either_ship_is_named_until_it_moves_again() {
        let moving = Record(|t: f64| (0.7 * t).sin());
        // The target's heave holds its value from 60 s to 120 s (rounded to the sample).
        let stuck =
            Record(|t: f64| (0.7 * t.clamp(0.0, 60.0)).sin() + if t > 120.0 { t } else { 0.0 });
        let mut watch = ShipsStillWatch::live();
        let mut thawed = 0;
        let mut t = 0.0;
        while t <= 150.0 {
            thawed += usize::from(watch.observe([t, t], &moving, &stuck));
            let frozen = watch.frozen();
            // Frozen once it has repeated its value for STILL_AFTER_S, until it moves.
            let expected = (60.0 + crate::decision::still::STILL_AFTER_S..=120.0).contains(&t);
            assert_eq!(frozen.is_some(), expected, "t={t}: {frozen:?}");
            if let Some(f) = frozen {
                assert_eq!(f.ship, Ship::Target);
                // Roll and pitch are made of heave here: the first watched DOF is named.
                assert_eq!(f.dof, Dof::Heave);
            }
            t += 0.5;
        }
        assert_eq!(thawed, 1);
        // The same on the crane's side names the crane.
        let mut watch = ShipsStillWatch::live();
        let mut t = 0.0;
        while t <= 100.0 {
            watch.observe([t, t], &stuck, &moving);
            t += 0.5;
        }
        assert_eq!(watch.frozen().map(|f| f.ship), Some(Ship::Crane));
    }

    /// A record that has samples only on its own grid of 0.125 s, shifted by `offset_s`.
    struct Grid(f64, fn(f64) -> f64);

    impl ObservedMotion for Grid {
        fn dof_at(&self, t: f64) -> Option<[f64; 6]> {
            let i = ((t - self.0) / 0.125).round();
            ((t - self.0 - i * 0.125).abs() < 0.01).then(|| {
                let h = (self.1)(t);
                [0.0, 0.0, h, 0.1 * h, 0.05 * h, 0.0]
            })
        }
    }

    /// Regression (review): both ships were looked up at the later forecast's origin, where a
    /// ship whose samples lie out of phase, or whose forecast is steps older, has no sample: its
    /// frozen sensor was never found.
    #[test]
    fn each_ship_is_looked_at_at_its_own_origin() {
        let crane = Grid(0.0, |t| (0.7 * t).sin());
        // The target samples 1/16 s later and runs 1 s behind; its heave sticks from 60 s.
        let target = Grid(0.0625, |t| (0.7 * t.min(60.0)).sin());
        let mut watch = ShipsStillWatch::live();
        let mut t = 0.0;
        while t < 120.0 {
            watch.observe([t, t - 1.0 + 0.0625], &crane, &target);
            t += 0.5;
        }
        assert_eq!(
            watch.frozen(),
            Some(FrozenSensor {
                ship: Ship::Target,
                dof: Dof::Heave
            })
        );
    }

    #[test]
    fn a_restart_while_frozen_is_a_thaw_and_a_ship_without_samples_is_not_looked_at() {
        let moving = Record(|t: f64| (0.7 * t).sin());
        let stuck = Record(|t: f64| (0.7 * t.min(30.0)).sin());
        let mut watch = ShipsStillWatch::live();
        let mut t = 0.0;
        while t <= 90.0 {
            watch.observe([t, t], &stuck, &moving);
            t += 0.5;
        }
        assert!(watch.frozen().is_some());
        // No samples from either ship: nothing changes.
        assert!(!watch.observe([95.0, 95.0], &Nothing, &Nothing));
        assert!(watch.frozen().is_some());
        // The crane's record starts again (its time goes back): the stillness is over.
        assert!(watch.observe([1.0, 96.0], &moving, &moving));
        assert_eq!(watch.frozen(), None);
    }
}
