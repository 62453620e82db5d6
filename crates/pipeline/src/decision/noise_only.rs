//! A motion sensor that shows only noise is not a calm sea either.
//!
//! Why: a sensor can fail without repeating its value ([`super::still`] catches that one): a
//! channel that lost its signal and reads the electronics' own noise, a frozen reading with
//! dither on it. Its values keep changing, so the forecasts and their verified errors become
//! those of a few millimetres of noise, and the deck would say go on a calm that is not
//! there.
//!
//! A sea cannot do what such a sensor does: in half a minute its spread falls to a fraction of
//! what it was over the minutes before, and what is left has no memory from one look to the
//! next. Ship motion seen every 0.5 s has a lag-one autocorrelation near cos(pi / T) for a
//! period T of several seconds (0.8 at 5 s, 0.5 at 3 s); white noise has one near 0 (within
//! +-0.13 over [`LOOKS`] looks). So a DOF shows only noise when, over its last [`LOOKS`]
//! looks, both hold:
//! - the spread is below [`COLLAPSE`] times the motion's spread before (a steady sea with a
//!   noisy sensor, a sea that calms over minutes, a course change that takes the roll away with
//!   the motion still smooth: none of them);
//! - the lag-one autocorrelation is below [`NOISE_CORRELATION`];
//! - the value changed between at least [`MIN_CHANGES`] of the looks (noise changes at nearly
//!   every look; a value that sticks, with a change or two from before it in the ring, is a
//!   stillness for [`super::still`] to judge, not noise).
//!
//! It shows motion again when the spread is back above [`RECOVERED`] times the motion's before,
//! or the autocorrelation above [`MOTION_CORRELATION`] (white noise gets there about once in
//! 500,000 looks, three days at 2 Hz: the safe side, the evidence is dropped once more).
//!
//! Not caught: a failed sensor whose reading drifts smoothly (a gyro integrating its bias), and
//! one whose noise is as large as the motion it replaced.

/// Looks the test is made over (30 s at 2 Hz, as a stillness: several wave periods).
pub const LOOKS: usize = 60;

/// The spread must fall below this share of the motion's spread before.
pub const COLLAPSE: f64 = 0.2;

/// And the lag-one autocorrelation below this.
pub const NOISE_CORRELATION: f64 = 0.3;

/// Looks, of [`LOOKS`], whose value differs from the one before.
pub const MIN_CHANGES: usize = LOOKS / 3;

/// Motion is back when the spread is above this share of the motion's before...
pub const RECOVERED: f64 = 0.5;

/// ... or the lag-one autocorrelation above this.
pub const MOTION_CORRELATION: f64 = 0.6;

/// What one look changed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NoiseChange {
    /// Nothing: motion as before, or noise as before.
    None,
    /// The last [`LOOKS`] looks are noise, not motion.
    Began,
    /// Motion again after noise.
    Ended,
}

/// The last [`LOOKS`] values of one DOF and whether they are noise (fixed size: no allocation).
#[derive(Debug, Clone, Copy)]
pub struct NoiseWatch {
    ring: [f64; LOOKS],
    /// Values in the ring, and where the next goes.
    len: usize,
    next: usize,
    noisy: bool,
}

impl Default for NoiseWatch {
    fn default() -> Self {
        Self {
            ring: [0.0; LOOKS],
            len: 0,
            next: 0,
            noisy: false,
        }
    }
}

impl NoiseWatch {
    /// Whether the DOF shows only noise now.
    pub fn is_noisy(&self) -> bool {
        self.noisy
    }

    /// Forget the looks (a new run: its values are not a continuation of the old ones).
    pub fn reset(&mut self) {
        *self = Self::default();
    }

    /// One look at the DOF's `value` (finite). `motion_sd`: the spread of the motion before,
    /// which the caller holds still while the DOF is noisy (0 or NaN when not known: noise is
    /// then never found, as a DOF that never moved).
    pub fn look(&mut self, value: f64, motion_sd: f64) -> NoiseChange {
        self.ring[self.next] = value;
        self.next = (self.next + 1) % LOOKS;
        self.len = (self.len + 1).min(LOOKS);
        if self.len < LOOKS || motion_sd.is_nan() || motion_sd <= 0.0 {
            return NoiseChange::None;
        }
        let (sd, r1, changes) = self.spread_correlation_changes();
        match self.noisy {
            false
                if changes >= MIN_CHANGES
                    && sd < COLLAPSE * motion_sd
                    && r1 < NOISE_CORRELATION =>
            {
                self.noisy = true;
                NoiseChange::Began
            }
            true if sd > RECOVERED * motion_sd || r1 > MOTION_CORRELATION => {
                self.noisy = false;
                NoiseChange::Ended
            }
            _ => NoiseChange::None,
        }
    }

    /// The ring's standard deviation, lag-one autocorrelation and changes between
    /// neighbouring looks, in the order seen (a ring of one value has correlation NaN: neither
    /// noise nor motion by the tests above).
    fn spread_correlation_changes(&self) -> (f64, f64, usize) {
        let n = self.len as f64;
        let mean = self.ring.iter().sum::<f64>() / n;
        let at = |i: usize| self.ring[(self.next + i) % LOOKS] - mean;
        let (mut var, mut lag, mut changes) = (0.0, 0.0, 0);
        for i in 0..self.len {
            var += at(i) * at(i);
            if i + 1 < self.len {
                lag += at(i) * at(i + 1);
                changes += usize::from(at(i) != at(i + 1));
            }
        }
        ((var / n).sqrt(), lag / var, changes)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Deterministic uniform noise in [-1, 1] (a linear congruential generator).
    struct Noise(u64);

    impl Noise {
        fn next(&mut self) -> f64 {
            self.0 = self
                .0
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (self.0 >> 11) as f64 / (1u64 << 52) as f64 - 1.0
        }
    }

    #[test]
    fn white_noise_after_motion_is_found_and_motion_ends_it() {
        let mut w = NoiseWatch::default();
        let mut noise = Noise(7);
        // One minute of a 6 s sea of spread 0.7 m, looked at every 0.5 s.
        let sea = |i: usize| (std::f64::consts::TAU * i as f64 * 0.5 / 6.0).sin();
        for i in 0..120 {
            assert_eq!(w.look(sea(i), 0.7), NoiseChange::None, "look {i}");
        }
        // Then 5 mm of noise: found once the ring holds noise enough, within LOOKS looks.
        let mut began = None;
        for i in 0..200 {
            match w.look(0.005 * noise.next(), 0.7) {
                NoiseChange::Began => began = Some(i),
                NoiseChange::Ended => panic!("ended at {i}"),
                NoiseChange::None => {}
            }
        }
        let began = began.expect("noise was never found");
        assert!(began < LOOKS, "{began}");
        assert!(w.is_noisy());
        // The sea back: motion again within a few looks.
        let ended = (0..LOOKS).find(|&i| w.look(sea(i), 0.7) == NoiseChange::Ended);
        assert!(ended.is_some_and(|i| i < 10), "{ended:?}");
        assert!(!w.is_noisy());
    }

    fn period(t: f64, p: f64) -> f64 {
        (std::f64::consts::TAU * t / p).sin()
    }

    #[test]
    fn motion_that_calms_or_carries_noise_is_not_noise() {
        let mut noise = Noise(11);
        // A sea calming tenfold over 5 minutes; a sea of 3 s waves with a noisy sensor (noise
        // a third of the motion); roll that a course change takes from 5 to 0.3 deg in a
        // minute, smooth; a flat calm rounded to 1 cm. The caller holds the motion's spread
        // as an exponential mean over 2 minutes, as `still` does.
        type Motion = Box<dyn FnMut(f64) -> f64>;
        let cases: Vec<(&str, Motion)> = vec![
            (
                "calming",
                Box::new(|t| period(t, 8.0) * (1.0 - 0.9 * (t / 300.0).min(1.0))),
            ),
            (
                "noisy sensor",
                Box::new(move |t| period(t, 3.0) + 0.33 * noise.next()),
            ),
            (
                "course change",
                Box::new(|t| {
                    let deg = if t < 100.0 {
                        5.0
                    } else {
                        0.3f64.max(5.0 - (t - 100.0) / 12.0)
                    };
                    deg.to_radians() * period(t, 11.0)
                }),
            ),
            (
                "flat calm",
                Box::new(|t| (0.007 * period(t, 9.0) * period(t, 97.0) * 100.0).round() / 100.0),
            ),
        ];
        for (name, mut motion) in cases {
            let mut w = NoiseWatch::default();
            let (mut mean, mut var) = (0.0, 0.0);
            for i in 0..2400 {
                let t = i as f64 * 0.5;
                let v = motion(t);
                let k = (i as f64 + 1.0).min(240.0);
                let d = v - mean;
                mean += d / k;
                var += (d * (v - mean) - var) / k;
                let change = w.look(v, var.sqrt());
                assert_eq!(change, NoiseChange::None, "{name} at {t} s");
            }
        }
    }

    #[test]
    fn without_the_motion_before_nothing_is_noise() {
        let mut w = NoiseWatch::default();
        let mut noise = Noise(3);
        for _ in 0..200 {
            assert_eq!(w.look(noise.next(), 0.0), NoiseChange::None);
            assert_eq!(w.look(noise.next(), f64::NAN), NoiseChange::None);
        }
        // A value repeated exactly is a stillness (`still`), not noise.
        let mut w = NoiseWatch::default();
        for _ in 0..200 {
            assert_eq!(w.look(0.25, 1.0), NoiseChange::None);
        }
    }
}
