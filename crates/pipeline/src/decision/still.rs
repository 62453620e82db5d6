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
//! - a DOF that repeats its value for [`STILL_AFTER_S`] is frozen, and the deck says no go while
//!   it is (a sensor fault, not a licence to land), if it moved before or the record is known to
//!   have that column ([`StillWatch::set_present`]: replay knows its record's columns, and the
//!   live deck takes heave, roll and pitch as present, `DeckAdvisor::live`);
//! - a DOF that moves again after such a stillness (whether it had moved before it or not)
//!   makes the evidence gathered during the stillness worthless: the deck drops its verified
//!   errors and goes back to the verified statements it had when the stillness began, so go
//!   waits for verified errors of the motion as it is now;
//! - a time that goes back (a new producer run) starts the watch afresh.
//!
//! A DOF that has never moved, in a record not known to have it, is taken as absent (a
//! producer sends zeros for a missing column) and withholds nothing until it moves.
//!
//! A sensor quantised coarsely repeats one value for 30 s in a flat calm (heave to 1 cm in
//! +-7 mm). Such a stillness does not count: only one that follows motion whose standard
//! deviation over the last two minutes was more than [`RESOLVED_STEPS`] of the sensor's
//! resolution (the smallest change it has shown in the last few minutes). Review: counted, it
//! left the deck frozen or waiting for 3469 s of a simulated calm hour.
//!
//! Not caught: a frozen sensor that adds noise of its own (it does not repeat its value), and
//! a coarsely quantised sensor that freezes while the motion is within a few of its steps. A
//! watch of noise after motion (a spread collapsed to a fifth with no lag-one autocorrelation
//! left, 2026-12-07) was tried and taken out: a real calm seen through a noisy sensor (a
//! harbour entry, the end of a passing wake, a trim change) met its tests and left the deck
//! frozen for the rest of the calm, and at a look rate of 1 Hz a 4-5 s sea did too.

use shipcast_wire::Dof;

/// Seconds a DOF must repeat its value before it counts as still: several wave periods.
pub const STILL_AFTER_S: f64 = 30.0;

/// How many of the sensor's resolution steps the motion's standard deviation must
/// exceed for a stillness after it to count.
pub const RESOLVED_STEPS: f64 = 4.0;

/// Looks over which the motion's spread is averaged (2 minutes of forecasts at 2 Hz).
const MOTION_MEMORY: f64 = 240.0;

/// Looks per block, and blocks, of the resolution's memory (2.5 minutes at 2 Hz).
const RESOLUTION_BLOCK: u32 = 60;
const RESOLUTION_BLOCKS: usize = 5;

/// Changes a DOF must have shown before its resolution is judged.
const MIN_CHANGES: u32 = 8;

/// The DOFs the deck's quantities are made of.
pub const WATCHED: [Dof; 3] = [Dof::Heave, Dof::Roll, Dof::Pitch];

/// What one look found for one watched DOF.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stillness {
    /// It changed, or has repeated its value for less than [`STILL_AFTER_S`].
    Moving,
    /// It has now repeated its value for [`STILL_AFTER_S`]: a stillness begins.
    Began,
    /// It goes on repeating its value.
    Still,
    /// It moved again after repeating its value for at least [`STILL_AFTER_S`].
    Resumed,
}

/// What one look at the recorded values found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Look {
    /// Per watched DOF, in the order of [`WATCHED`].
    pub dofs: [Stillness; WATCHED.len()],
    /// The time went back (a new run): the watch started afresh with this look.
    pub restarted: bool,
}

impl Look {
    const NOTHING: Look = Look {
        dofs: [Stillness::Moving; WATCHED.len()],
        restarted: false,
    };
}

#[derive(Debug, Clone, Copy)]
struct Watch {
    /// The value last seen, and the time it was first seen since it last changed.
    value: f64,
    since_s: f64,
    moved: bool,
    /// The value's mean and variance over about the last [`MOTION_MEMORY`] looks before the
    /// current stillness, and the looks they average.
    mean: f64,
    variance: f64,
    looks: f64,
    /// Changes seen, and the smallest change in each of the last blocks of
    /// [`RESOLUTION_BLOCK`] looks (newest first): the sensor's resolution as it shows it now, a
    /// glitch or an earlier, finer sensor forgotten after a few minutes.
    changes: u32,
    smallest: [f64; RESOLUTION_BLOCKS],
    in_block: u32,
    /// Whether the current stillness counts (decided when it begins).
    counts: bool,
}

impl Watch {
    fn new(value: f64, time_s: f64) -> Self {
        Self {
            value,
            since_s: time_s,
            moved: false,
            mean: value,
            variance: 0.0,
            looks: 0.0,
            changes: 0,
            smallest: [f64::INFINITY; RESOLUTION_BLOCKS],
            in_block: 0,
            counts: false,
        }
    }

    /// Count one look at `value` (the current stillness not begun) into the motion and the
    /// resolution.
    fn count_look(&mut self, value: f64) {
        let delta = value - self.value;
        self.looks += 1.0;
        let k = self.looks.min(MOTION_MEMORY);
        let d = value - self.mean;
        self.mean += d / k;
        self.variance += (d * (value - self.mean) - self.variance) / k;
        if delta != 0.0 {
            self.changes = self.changes.saturating_add(1);
            self.smallest[0] = self.smallest[0].min(delta.abs());
        }
        self.in_block += 1;
        if self.in_block == RESOLUTION_BLOCK {
            self.in_block = 0;
            self.smallest.rotate_right(1);
            self.smallest[0] = f64::INFINITY;
        }
    }

    /// A stillness beginning now counts: the DOF never moved, or changed too few times to show
    /// its resolution (a column stuck from the start, an absent one, or one that changed once
    /// and stuck), or it moved by well more than its resolution.
    fn stillness_counts(&self) -> bool {
        let resolution = self.smallest.iter().copied().fold(f64::INFINITY, f64::min);
        !self.moved
            || self.changes < MIN_CHANGES
            || self.variance.sqrt() > RESOLVED_STEPS * resolution
    }
}

/// Per watched DOF, how long its recorded value has stayed the same.
#[derive(Debug, Clone, Default)]
pub struct StillWatch {
    /// The time of the last look, and what it saw (None before the first).
    last_s: f64,
    watches: Option<[Watch; WATCHED.len()]>,
    /// Which watched DOFs the record is known to have (None: not known).
    present: Option<[bool; WATCHED.len()]>,
}

impl StillWatch {
    /// The record is known to have these DOFs' columns: one of them that never moves is a
    /// frozen sensor, not an absent column.
    pub fn set_present(&mut self, dofs: &[Dof]) {
        self.present = Some(WATCHED.map(|d| dofs.contains(&d)));
    }

    /// Look at the recorded values at `time_s` (forecast times, in order). The same time again,
    /// or a non-finite value, is ignored; a time before the last starts the watch afresh.
    pub fn observe(&mut self, time_s: f64, values: &[f64; 6]) -> Look {
        if !time_s.is_finite() || WATCHED.iter().any(|d| !values[d.index()].is_finite()) {
            return Look::NOTHING;
        }
        let restarted = self.watches.is_some() && time_s < self.last_s;
        let watches = match self.watches.as_mut() {
            Some(w) if !restarted => w,
            _ => {
                // What a sensor has shown of itself (that it moves, its resolution, its motion)
                // outlives a producer run; only the stillness starts afresh.
                let old = self.watches;
                self.watches = Some(std::array::from_fn(|i| {
                    let value = values[WATCHED[i].index()];
                    match old {
                        Some(o) => Watch {
                            value,
                            since_s: time_s,
                            counts: false,
                            ..o[i]
                        },
                        None => Watch::new(value, time_s),
                    }
                }));
                self.last_s = time_s;
                return Look {
                    restarted,
                    ..Look::NOTHING
                };
            }
        };
        if time_s == self.last_s {
            return Look::NOTHING;
        }
        let mut look = Look::NOTHING;
        for ((w, dof), found) in watches.iter_mut().zip(WATCHED).zip(&mut look.dofs) {
            // Still for as long as it was seen unchanged: up to the last look, not up to now.
            let was_still = self.last_s - w.since_s >= STILL_AFTER_S;
            let v = values[dof.index()];
            if v == w.value {
                *found = match (was_still, time_s - w.since_s >= STILL_AFTER_S) {
                    (true, _) if w.counts => Stillness::Still,
                    (true, _) => Stillness::Moving,
                    (false, true) => {
                        w.counts = w.stillness_counts();
                        if w.counts {
                            Stillness::Began
                        } else {
                            Stillness::Moving
                        }
                    }
                    (false, false) => {
                        w.count_look(v);
                        Stillness::Moving
                    }
                };
                continue;
            }
            if was_still && w.counts {
                *found = Stillness::Resumed;
            }
            w.count_look(v);
            w.value = v;
            w.since_s = time_s;
            w.moved = true;
            w.counts = false;
        }
        self.last_s = time_s;
        look
    }

    /// A DOF that has repeated its value for [`STILL_AFTER_S`], and moved before or is known to
    /// be in the record.
    pub fn frozen(&self) -> Option<Dof> {
        let watches = self.watches.as_ref()?;
        let present = self.present.unwrap_or([false; WATCHED.len()]);
        watches
            .iter()
            .zip(WATCHED)
            .zip(present)
            .find(|((w, _), known)| {
                (w.moved || *known) && w.counts && self.last_s - w.since_s >= STILL_AFTER_S
            })
            .map(|((_, d), _)| d)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use Stillness::*;

    fn at(heave: f64, roll: f64) -> [f64; 6] {
        [0.0, 0.0, heave, roll, 0.0, 0.0]
    }

    /// The heave entry (first watched DOF) of a look.
    fn heave(look: Look) -> Stillness {
        look.dofs[0]
    }

    #[test]
    fn a_dof_that_repeats_its_value_after_moving_is_frozen_until_it_moves_again() {
        let mut w = StillWatch::default();
        let mut t = 0.0;
        // Heave moves for a minute; roll and pitch never do (absent columns).
        while t < 60.0 {
            assert_eq!(w.observe(t, &at(t.sin(), 0.0)).dofs[0], Moving);
            assert_eq!(w.frozen(), None, "t={t}");
            t += 0.5;
        }
        // Heave sticks: frozen once it has repeated its value for STILL_AFTER_S, not before,
        // and the look that gets there says the stillness began.
        let stuck = (t - 0.5f64).sin();
        let mut began = 0;
        while t < 60.0 + 2.0 * STILL_AFTER_S {
            let look = heave(w.observe(t, &at(stuck, 0.0)));
            let still_for = t - 59.5;
            let expected = match still_for {
                s if s < STILL_AFTER_S => Moving,
                s if s < STILL_AFTER_S + 0.5 => Began,
                _ => Still,
            };
            assert_eq!(look, expected, "still for {still_for} s");
            began += usize::from(look == Began);
            assert_eq!(
                w.frozen().is_some(),
                still_for >= STILL_AFTER_S,
                "{still_for} s"
            );
            t += 0.5;
        }
        assert_eq!((began, w.frozen()), (1, Some(Dof::Heave)));
        // It moves again: the evidence must go, and it is no longer frozen.
        assert_eq!(heave(w.observe(t, &at(0.3, 0.0))), Resumed);
        assert_eq!(w.frozen(), None);
        assert_eq!(heave(w.observe(t + 0.5, &at(0.4, 0.0))), Moving);
    }

    #[test]
    fn a_dof_that_never_moved_is_absent_unless_the_record_is_known_to_have_it() {
        let run = |w: &mut StillWatch| {
            for i in 0..1200 {
                let t = i as f64 * 0.5;
                w.observe(t, &at((t * 0.7).sin(), 0.0));
            }
        };
        // Ten minutes of zero roll: an absent column, not a frozen sensor...
        let mut unknown = StillWatch::default();
        run(&mut unknown);
        assert_eq!(unknown.frozen(), None);
        // ... unless the record has a roll column: then it is a sensor stuck from the start.
        let mut known = StillWatch::default();
        known.set_present(&[Dof::Heave, Dof::Roll]);
        run(&mut known);
        assert_eq!(known.frozen(), Some(Dof::Roll));
        // Either way, when it starts to move the stillness is over.
        for w in [&mut unknown, &mut known] {
            assert_eq!(w.observe(600.0, &at(0.1, 0.01)).dofs[1], Resumed);
            assert_eq!(w.frozen(), None);
        }
    }

    #[test]
    fn a_time_that_goes_back_starts_the_watch_afresh() {
        let mut w = StillWatch::default();
        for i in 0..200 {
            w.observe(
                3000.0 + i as f64 * 0.5,
                &at(if i < 50 { i as f64 } else { 1.0 }, 0.0),
            );
        }
        assert_eq!(w.frozen(), Some(Dof::Heave));
        // A new producer run from t = 0: nothing of the old run's stillness is carried over.
        let look = w.observe(0.0, &at(2.0, 0.0));
        assert!(look.restarted);
        assert_eq!(w.frozen(), None);
        // ... and a sensor stuck in the new run is found after STILL_AFTER_S of it.
        for i in 1..=60 {
            w.observe(i as f64 * 0.5, &at((i as f64 * 0.4).sin(), 0.0));
        }
        for i in 61..=122 {
            w.observe(i as f64 * 0.5, &at(24f64.sin(), 0.0));
        }
        assert_eq!(w.frozen(), Some(Dof::Heave));
    }

    #[test]
    fn a_coarsely_quantised_sensor_in_a_flat_calm_is_not_frozen_but_one_in_a_sea_is() {
        let cm = |x: f64| (x * 100.0).round() / 100.0;
        // Heave within +-7 mm rounded to 1 cm, an hour: it repeats 0 for 30 s now and then.
        let mut calm = StillWatch::default();
        let mut repeats_of_30_s = 0;
        let (mut run, mut moved) = (0, false);
        let mut last = f64::NAN;
        for i in 0..7200 {
            let t = i as f64 * 0.5;
            let h = cm(0.007 * (t / 9.0).sin() * (t / 97.0).sin());
            run = if h == 0.0 { run + 1 } else { 0 };
            repeats_of_30_s += usize::from(moved && run == 61);
            let look = calm.observe(t, &at(h, 0.0));
            // Up to its first change the channel may be an absent one switched on late (whose
            // start resets the evidence once): the calm is judged after it.
            let had_moved = moved;
            moved |= i > 0 && h != last;
            last = h;
            if had_moved {
                assert_eq!(look.dofs[0], Moving, "t={t}");
            }
            assert_eq!(calm.frozen(), None, "t={t}");
        }
        // The case is real: the calm does repeat its value for 30 s, several times.
        assert!(repeats_of_30_s >= 3, "{repeats_of_30_s}");
        // The same sensor on a sea of 1 m, then stuck: frozen, and its thaw resets.
        let mut sea = StillWatch::default();
        let mut t = 0.0;
        while t < 300.0 {
            sea.observe(t, &at(cm((t * 0.8).sin()), 0.0));
            t += 0.5;
        }
        let stuck = cm((t * 0.8).sin());
        let mut began = false;
        while t < 360.0 {
            began |= heave(sea.observe(t, &at(stuck, 0.0))) == Began;
            t += 0.5;
        }
        assert!(began);
        assert_eq!(sea.frozen(), Some(Dof::Heave));
        assert_eq!(heave(sea.observe(t, &at(stuck + 0.5, 0.0))), Resumed);
    }

    /// Heave of a 10 s sea with RMS `rms`, rounded to 1 cm, at time `t`.
    fn sea_cm(t: f64, rms: f64) -> f64 {
        let h = rms * std::f64::consts::SQRT_2 * (std::f64::consts::TAU * t / 10.0).sin();
        (h * 100.0).round() / 100.0
    }

    /// Seconds of `0..end_s` (looks every 0.5 s) in which heave is frozen, heave at `t` given.
    fn frozen_seconds(w: &mut StillWatch, from_s: f64, end_s: f64, h: impl Fn(f64) -> f64) -> f64 {
        let mut frozen = 0.0;
        let mut t = from_s;
        while t < end_s {
            w.observe(t, &at(h(t), 0.0));
            if w.frozen().is_some() {
                frozen += 0.5;
            }
            t += 0.5;
        }
        frozen
    }

    /// Regressions (review of the resolution test): a sea of a few resolution steps, a glitch
    /// finer than the sensor, a column that changed once, a stuck sensor through a restart.
    #[test]
    fn the_resolution_is_recent_and_the_motion_is_judged_by_its_spread() {
        // 1 cm heave of RMS 0.10 m (10 steps), stuck from 600 s: frozen (its change between
        // looks was judged before, and fell short).
        let mut w = StillWatch::default();
        let stuck = sea_cm(599.5, 0.1);
        let h = |t: f64| if t < 600.0 { sea_cm(t, 0.1) } else { stuck };
        assert!(frozen_seconds(&mut w, 0.0, 900.0, h) >= 900.0 - 600.0 - STILL_AFTER_S - 1.0);
        // The calm hour with one glitch of 0.2 mm at 200 s: the glitch is forgotten within
        // minutes, not kept as the resolution for the rest of the hour.
        let mut w = StillWatch::default();
        let calm = |t: f64| {
            let h = ((0.007 * (t / 9.0).sin() * (t / 97.0).sin()) * 100.0).round() / 100.0;
            if t == 200.0 {
                h + 0.0002
            } else {
                h
            }
        };
        frozen_seconds(&mut w, 0.0, 600.0, calm);
        assert_eq!(frozen_seconds(&mut w, 600.0, 3600.0, calm), 0.0);
        // A column that changes once (0 until its first reading) and then sticks, in a record
        // known to have it: frozen, though one change shows no resolution.
        let mut w = StillWatch::default();
        w.set_present(&[Dof::Heave]);
        let once = |t: f64| if t < 60.0 { 0.0 } else { 0.37 };
        let f = frozen_seconds(&mut w, 0.0, 300.0, once);
        assert!(f >= 300.0 - 60.0 - STILL_AFTER_S - 1.0, "{f}");
        // A sensor stuck through a producer restart, on a live deck that does not know the
        // columns: the new run's watch remembers that it moved, and finds it frozen again.
        let mut w = StillWatch::default();
        frozen_seconds(&mut w, 1000.0, 1300.0, |t| {
            if t < 1200.0 {
                (t * 0.8).sin()
            } else {
                0.4
            }
        });
        assert!(w.frozen().is_some());
        assert!(w.observe(0.0, &at(0.4, 0.0)).restarted);
        let f = frozen_seconds(&mut w, 0.5, 120.0, |_| 0.4);
        assert!(f >= 120.0 - STILL_AFTER_S - 1.0, "{f}");
    }

    #[test]
    fn brief_repeats_and_gaps_in_what_was_seen_are_not_stillness() {
        let mut w = StillWatch::default();
        // A value held for less than STILL_AFTER_S (a quantised sensor in a calm moment).
        w.observe(0.0, &at(1.0, 0.0));
        w.observe(0.5, &at(2.0, 0.0));
        w.observe(STILL_AFTER_S, &at(2.0, 0.0));
        assert_eq!(w.frozen(), None);
        assert_eq!(heave(w.observe(STILL_AFTER_S + 0.5, &at(3.0, 0.0))), Moving);
        // Ten minutes without a look (a gap in the forecasts), then a new value: nothing was
        // seen still.
        assert_eq!(
            heave(w.observe(STILL_AFTER_S + 600.0, &at(4.0, 0.0))),
            Moving
        );
        // The same time again and non-finite values are ignored.
        assert_eq!(
            w.observe(STILL_AFTER_S + 600.0, &at(9.0, 0.0)),
            Look::NOTHING
        );
        assert_eq!(w.observe(1e9, &at(f64::NAN, 0.0)), Look::NOTHING);
        assert_eq!(
            heave(w.observe(STILL_AFTER_S + 600.5, &at(4.0, 0.0))),
            Moving
        );
        assert_eq!(w.frozen(), None);
    }
}
