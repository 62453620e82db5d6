//! A motion sensor that repeats its value is not a calm sea.
//!
//! Why: a DOF whose recorded value stays exactly the same for minutes (a frozen sensor, a
//! channel that feeds a constant) gives forecasts and verified errors of nothing. The deck then
//! decides from an ensemble of zero errors, and when the DOF moves again its first go calls are
//! made on that evidence: on a replayed record with three DOF still for ten minutes, 52 go
//! calls followed in the first seconds of motion and 69 % of them were false.
//!
//! So the deck watches the recorded values its quantities are made of (heave, roll, pitch) at
//! each forecast's time:
//! - a DOF that has moved before and then repeats its value for [`STILL_AFTER_S`] is frozen,
//!   and the deck says no go while it is (a sensor fault, not a licence to land);
//! - a DOF that moves again after such a stillness (whether it had moved before it or not)
//!   makes the evidence gathered so far worthless, and the deck forgets it: go waits for
//!   verified errors of the motion as it is now.
//!
//! A DOF that has never moved is taken as absent (a record without that column feeds zeros) and
//! withholds nothing until it moves. A real sea never repeats a value to the last bit over
//! several wave periods; a quantised sensor in flat calm may, and then the deck is merely
//! cautious.

use shipcast_wire::Dof;

/// Seconds a DOF must repeat its value before it counts as still: several wave periods.
pub const STILL_AFTER_S: f64 = 30.0;

/// The DOFs the deck's quantities are made of.
pub const WATCHED: [Dof; 3] = [Dof::Heave, Dof::Roll, Dof::Pitch];

/// What one look at the recorded values found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stillness {
    /// Nothing to act on.
    Moving,
    /// A DOF moved again after being still for at least [`STILL_AFTER_S`]: forget the evidence.
    Resumed(Dof),
}

#[derive(Debug, Clone, Copy)]
struct Watch {
    /// The value last seen, and the time it was first seen since it last changed.
    value: f64,
    since_s: f64,
    moved: bool,
}

/// Per watched DOF, how long its recorded value has stayed the same.
#[derive(Debug, Clone, Default)]
pub struct StillWatch {
    /// The time of the last look, and what it saw (None before the first).
    last_s: f64,
    watches: Option<[Watch; WATCHED.len()]>,
}

impl StillWatch {
    /// Look at the recorded values at `time_s` (forecast times, in order). A time that does not
    /// move forward, or a non-finite value, is ignored.
    pub fn observe(&mut self, time_s: f64, values: &[f64; 6]) -> Stillness {
        if !time_s.is_finite() || WATCHED.iter().any(|d| !values[d.index()].is_finite()) {
            return Stillness::Moving;
        }
        let Some(watches) = self.watches.as_mut() else {
            self.watches = Some(WATCHED.map(|d| Watch {
                value: values[d.index()],
                since_s: time_s,
                moved: false,
            }));
            self.last_s = time_s;
            return Stillness::Moving;
        };
        if time_s <= self.last_s {
            return Stillness::Moving;
        }
        let mut found = Stillness::Moving;
        for (w, dof) in watches.iter_mut().zip(WATCHED) {
            let v = values[dof.index()];
            if v == w.value {
                continue;
            }
            // Still for as long as it was seen unchanged: up to the last look, not up to now.
            if self.last_s - w.since_s >= STILL_AFTER_S {
                found = Stillness::Resumed(dof);
            }
            *w = Watch {
                value: v,
                since_s: time_s,
                moved: true,
            };
        }
        self.last_s = time_s;
        found
    }

    /// A DOF that moved before and has now repeated its value for [`STILL_AFTER_S`].
    pub fn frozen(&self) -> Option<Dof> {
        let watches = self.watches.as_ref()?;
        watches
            .iter()
            .zip(WATCHED)
            .find(|(w, _)| w.moved && self.last_s - w.since_s >= STILL_AFTER_S)
            .map(|(_, d)| d)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(heave: f64, roll: f64) -> [f64; 6] {
        [0.0, 0.0, heave, roll, 0.0, 0.0]
    }

    #[test]
    fn a_dof_that_repeats_its_value_after_moving_is_frozen_until_it_moves_again() {
        let mut w = StillWatch::default();
        let mut t = 0.0;
        // Heave moves for a minute; roll and pitch never do (absent columns).
        while t < 60.0 {
            assert_eq!(w.observe(t, &at(t.sin(), 0.0)), Stillness::Moving);
            assert_eq!(w.frozen(), None, "t={t}");
            t += 0.5;
        }
        // Heave sticks: frozen once it has repeated its value for STILL_AFTER_S, not before.
        let stuck = (t - 0.5f64).sin();
        while t < 60.0 + 2.0 * STILL_AFTER_S {
            assert_eq!(w.observe(t, &at(stuck, 0.0)), Stillness::Moving);
            let still_for = t - 59.5;
            assert_eq!(
                w.frozen().is_some(),
                still_for >= STILL_AFTER_S,
                "still for {still_for} s"
            );
            t += 0.5;
        }
        assert_eq!(w.frozen(), Some(Dof::Heave));
        // It moves again: the evidence must go, and it is no longer frozen.
        assert_eq!(w.observe(t, &at(0.3, 0.0)), Stillness::Resumed(Dof::Heave));
        assert_eq!(w.frozen(), None);
        assert_eq!(w.observe(t + 0.5, &at(0.4, 0.0)), Stillness::Moving);
    }

    #[test]
    fn a_dof_that_never_moved_is_absent_until_it_starts_and_then_resets_the_evidence() {
        let mut w = StillWatch::default();
        for i in 0..1200 {
            let t = i as f64 * 0.5;
            assert_eq!(w.observe(t, &at((t * 0.7).sin(), 0.0)), Stillness::Moving);
            // Ten minutes of zero roll: an absent column, not a frozen sensor.
            assert_eq!(w.frozen(), None);
        }
        assert_eq!(
            w.observe(600.0, &at(0.1, 0.01)),
            Stillness::Resumed(Dof::Roll)
        );
    }

    #[test]
    fn brief_repeats_and_gaps_in_what_was_seen_are_not_stillness() {
        let mut w = StillWatch::default();
        // A value held for less than STILL_AFTER_S (a quantised sensor in a calm moment).
        w.observe(0.0, &at(1.0, 0.0));
        w.observe(0.5, &at(2.0, 0.0));
        w.observe(STILL_AFTER_S, &at(2.0, 0.0));
        assert_eq!(w.frozen(), None);
        assert_eq!(
            w.observe(STILL_AFTER_S + 0.5, &at(3.0, 0.0)),
            Stillness::Moving
        );
        // Ten minutes without a look (a gap in the forecasts), then a new value: nothing was
        // seen still.
        assert_eq!(
            w.observe(STILL_AFTER_S + 600.0, &at(4.0, 0.0)),
            Stillness::Moving
        );
        // Times that do not move forward and non-finite values are ignored.
        assert_eq!(w.observe(0.0, &at(9.0, 0.0)), Stillness::Moving);
        assert_eq!(w.observe(1e9, &at(f64::NAN, 0.0)), Stillness::Moving);
        assert_eq!(
            w.observe(STILL_AFTER_S + 600.5, &at(4.0, 0.0)),
            Stillness::Moving
        );
        assert_eq!(w.frozen(), None);
    }
}
