//! The level each DOF moves about: a static list or trim (cargo, ballast, a steady wind), a
//! sensor's offset. Wave-driven motion oscillates about it, and the predictors, which are
//! linear maps without a constant term, forecast the oscillation; fed the level as well, a
//! Wiener fit spends its coefficients on carrying it and forecasts the motion worse than
//! predicting the level (on the paper sea a 0.05 rad list made the roll error 5 s ahead 3.7
//! times larger). So the history the predictors read and are fitted on holds each value less
//! the level, the delivered forecast adds the level back, and "no skill" means the level, not
//! zero.
//!
//! The level is an exponentially weighted mean over about 5 minutes (`MEMORY_VALUES`): wave
//! motion has next to no energy at zero frequency, so its mean over a few minutes hardly moves
//! (about sigma / (omega T): under 1 % of sigma for a 10 s period over 5 minutes), while a new
//! list is followed within minutes. Nothing allocates.

use shipcast_wire::payload::NUM_DOF;

/// Memory of the level [values]: 5 minutes at 2 Hz.
pub const MEMORY_VALUES: f64 = 600.0;

/// Per-DOF level and the deviations from it.
#[derive(Debug, Clone, Default)]
pub struct Level {
    level: [f64; NUM_DOF],
    /// Values seen per DOF (the level is their plain mean until `MEMORY_VALUES` of them).
    seen: [u64; NUM_DOF],
}

impl Level {
    /// The deviation of the new value `y` of DOF `d` from the level before it; then the level
    /// takes `y` in. The first value is its own level (deviation 0).
    pub fn remove(&mut self, d: usize, y: f64) -> f64 {
        if self.seen[d] == 0 {
            self.level[d] = y;
        }
        let deviation = y - self.level[d];
        self.seen[d] += 1;
        let a = (1.0 / self.seen[d] as f64).max(1.0 / MEMORY_VALUES);
        self.level[d] += a * deviation;
        deviation
    }

    /// The level of DOF `d` now (after the newest value).
    pub fn get(&self, d: usize) -> f64 {
        self.level[d]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_constant_is_its_own_level_with_no_deviation() {
        let mut l = Level::default();
        for _ in 0..10 {
            assert_eq!(l.remove(3, 0.05), 0.0);
        }
        assert_eq!(l.get(3), 0.05);
        assert_eq!(l.get(0), 0.0);
    }

    #[test]
    fn a_list_under_a_sinusoid_is_found_and_the_oscillation_is_kept() {
        // Roll of amplitude 0.02 rad and period 10 s (20 values) about a 0.05 rad list.
        let mut l = Level::default();
        let roll = |i: usize| 0.05 + 0.02 * (std::f64::consts::TAU * i as f64 / 20.0).sin();
        let mut last = 0.0;
        for i in 0..3000 {
            last = l.remove(3, roll(i));
        }
        // The level is the list to well under 1 % of the amplitude...
        assert!((l.get(3) - 0.05).abs() < 2e-4, "{}", l.get(3));
        // ...and the deviation is the oscillation.
        assert!((last - (roll(2999) - 0.05)).abs() < 2e-4, "{last}");
    }

    #[test]
    fn a_new_list_is_followed_within_the_memory() {
        let mut l = Level::default();
        for _ in 0..2000 {
            l.remove(4, 0.0);
        }
        for _ in 0..(3.0 * MEMORY_VALUES) as usize {
            l.remove(4, 0.03);
        }
        // After three memories, e^-3 of the step is left.
        let left = (0.03 - l.get(4)) / 0.03;
        assert!(left > 0.0 && left < 0.06, "{left}");
    }
}
