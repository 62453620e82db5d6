//! Stated probabilities against what happened: the reliability table, the Brier score and the
//! episodes that say how much a bin's observed frequency can be trusted. One accumulator for
//! every station whose calls are scored (the deck in replay, the lift in the two-ship study),
//! so their tables mean the same thing.

use serde::Serialize;

/// Bins of the reliability table, of equal width in stated probability.
pub const BINS: usize = 10;

#[derive(Debug, Clone, Serialize)]
pub struct ReliabilityBin {
    pub p_lo: f64,
    pub p_hi: f64,
    pub count: u64,
    /// Mean stated probability of the calls in the bin.
    pub stated: f64,
    /// Fraction of them whose window held.
    pub observed: f64,
    /// Episodes among the calls: a call issued more than MOT after the start of the bin's
    /// current episode starts a new one, so the windows of different episodes do not
    /// overlap. Calls of one episode judge overlapping windows of the same sea and mostly
    /// share their outcome: the observed frequency is known to about +-1/sqrt(episodes), not
    /// +-1/sqrt(count).
    pub episodes: u64,
}

/// `a / b`, NaN when nothing was counted.
pub fn rate(a: u64, b: u64) -> f64 {
    if b > 0 {
        a as f64 / b as f64
    } else {
        f64::NAN
    }
}

#[derive(Debug, Clone, Copy, Default)]
struct Bin {
    count: u64,
    stated: f64,
    held: u64,
    episodes: u64,
    /// Issue time of the current episode's first call [s].
    episode_start_s: f64,
}

/// The calls of one station and window length (MOT).
#[derive(Debug, Clone)]
pub struct Reliability {
    mot_s: f64,
    pub calls: u64,
    pub held: u64,
    brier: f64,
    bins: [Bin; BINS],
}

impl Reliability {
    pub fn new(mot_s: f64) -> Self {
        Self {
            mot_s,
            calls: 0,
            held: 0,
            brier: 0.0,
            bins: [Bin {
                episode_start_s: f64::NEG_INFINITY,
                ..Bin::default()
            }; BINS],
        }
    }

    /// One call issued at `t0_s` stating probability `p` that its window holds; `held`: it did.
    /// Calls come in issue order.
    pub fn record(&mut self, t0_s: f64, p: f64, held: bool) {
        self.calls += 1;
        self.held += u64::from(held);
        self.brier += (p - f64::from(u8::from(held))).powi(2);
        // A NaN p lands in the first bin (`as` saturates) rather than vanishing from the count.
        let bin = &mut self.bins[((p * BINS as f64) as usize).min(BINS - 1)];
        bin.count += 1;
        bin.stated += p;
        bin.held += u64::from(held);
        if t0_s - bin.episode_start_s > self.mot_s {
            bin.episodes += 1;
            bin.episode_start_s = t0_s;
        }
    }

    /// Fraction of the calls whose window held (the base rate).
    pub fn base_rate(&self) -> f64 {
        rate(self.held, self.calls)
    }

    /// Mean squared difference between the stated probability and the outcome (0 or 1).
    pub fn brier(&self) -> f64 {
        if self.calls > 0 {
            self.brier / self.calls as f64
        } else {
            f64::NAN
        }
    }

    /// The Brier score of always stating the base rate: a Brier below it is skill.
    pub fn brier_climatology(&self) -> f64 {
        let base = self.base_rate();
        base * (1.0 - base)
    }

    pub fn table(&self) -> Vec<ReliabilityBin> {
        self.bins
            .iter()
            .enumerate()
            .map(|(i, b)| ReliabilityBin {
                p_lo: i as f64 / BINS as f64,
                p_hi: (i + 1) as f64 / BINS as f64,
                count: b.count,
                stated: if b.count > 0 {
                    b.stated / b.count as f64
                } else {
                    f64::NAN
                },
                observed: rate(b.held, b.count),
                episodes: b.episodes,
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn calls_land_in_their_bins_with_episodes_mot_apart_and_the_brier_of_the_outcomes() {
        let mut r = Reliability::new(10.0);
        // Three calls at 0.95 within 10 s of the first: one episode; a fourth 12 s after the
        // first starts another. One of the four failed.
        for (t, held) in [(0.0, true), (4.0, true), (9.5, false), (12.0, true)] {
            r.record(t, 0.95, held);
        }
        r.record(3.0, 0.05, false);
        let table = r.table();
        let top = &table[9];
        assert_eq!((top.count, top.episodes), (4, 2));
        assert!((top.stated - 0.95).abs() < 1e-12 && (top.observed - 0.75).abs() < 1e-12);
        assert_eq!((table[0].count, table[0].episodes), (1, 1));
        assert!(table[1..9]
            .iter()
            .all(|b| b.count == 0 && b.observed.is_nan()));
        // Brier by hand: three held at 0.95 (0.05^2 each), one failed at 0.95 (0.95^2), one
        // failed at 0.05 (0.05^2).
        let brier = (4.0 * 0.0025 + 0.9025) / 5.0;
        assert!((r.brier() - brier).abs() < 1e-12);
        // Base rate 3 of 5.
        assert!((r.brier_climatology() - 0.6 * 0.4).abs() < 1e-12);
        // A probability of exactly 1 belongs to the top bin.
        r.record(20.0, 1.0, true);
        assert_eq!(r.table()[9].count, 5);
    }

    #[test]
    fn nothing_recorded_states_nothing() {
        let r = Reliability::new(30.0);
        assert!(r.brier().is_nan() && r.base_rate().is_nan());
        assert!(r.table().iter().all(|b| b.count == 0 && b.stated.is_nan()));
    }
}
