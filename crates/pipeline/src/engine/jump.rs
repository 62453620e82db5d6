//! A jump of a DOF's level that the forecasts did not see coming: a sensor offset, cargo that
//! shifts, a spike.
//!
//! Why: the history holds each value less the level before it, so the values after a jump
//! carry the whole jump as a deviation. A linear model reading them rings, by more than the
//! jump itself, while its sigma is that of the sea: after a 3 m heave step (the motion's std
//! 0.37 m) the forecasts were 3-8 m off with sigma 0.02-0.3 m, a 1 m step 3.4 m off with sigma
//! 0.018 m (review). The level's own step test (`level.rs`) fires only 20 s later, and never
//! for a step under 3 of the deviations' RMS.
//!
//! What shows a jump at once is a forecast that misses its first step far beyond both its own
//! sigma and what the motion can do in half a second ([`MISS_RMS`], [`MISS_SIGMAS`]). Then:
//! - the DOF is held at no skill (the level, with sigma at least the newest deviation plus the
//!   live RMS) for as long as the jump is in the models' input ([`JumpGuard::holds`]);
//! - once, [`CONFIRM_VALUES`] values after the jump, if the median deviation of those values is
//!   well beyond what a wave's is ([`STEP_RMS`]), it is a step: the stored history over them
//!   and the level move by that median, so the models and the retrains read the motion about
//!   its new level;
//! - a jump that is no step but whose first values lie far outside the others
//!   ([`SPIKE_SCALES`]) was a spike: those values are replaced by the median, so that neither
//!   the models nor the retrains read it;
//! - while it is held after a re-level, a level that steps back by about as much and stays
//!   there for [`BACK_VALUES`] values (an offset that is undone) is re-levelled back, once, from
//!   where it stepped back; the hold lasts while such a step back is pending
//!   ([`JumpGuard::judge`]);
//! - its errors stay evidence for the calibration and the change detector: they widen sigma
//!   and call for a retrain, which waits until the history is judged (left out, a DOF that
//!   stood still and then moved would keep its stillness's sigma 0 once the hold ended).
//!
//! Nothing allocates.

use shipcast_wire::payload::NUM_DOF;

/// A first-step miss of more than this many live RMS of the motion (and of [`MISS_SIGMAS`]
/// sigmas) is a jump: a ship does not move 1.5 times its RMS further than forecast in half a
/// second (on the measured Gullfaks record the misses 0.5-1.5 s ahead stay under 0.51).
pub const MISS_RMS: f64 = 1.5;
/// ... and of more than this many of the sigma the forecast was issued with.
pub const MISS_SIGMAS: f64 = 8.0;
/// The first steps watched (0.5 and 1 s ahead at 2 Hz): the decimation filter spreads a step
/// over about two values, and the first may carry too little of it.
pub const FIRST_STEPS: usize = 2;
/// Values after the jump whose median tells a step (which stays) from a spike (which goes)
/// and from motion that resumes: 10 s at 2 Hz, most of a wave's period, over which the median
/// of a wave stays well inside its RMS while a step's is the step.
pub const CONFIRM_VALUES: u64 = 20;
/// A median deviation of at least this many of the motion's RMS before the jump (and of
/// [`STEP_RMS_NOW`] of the live RMS, for motion that resumes after stillness) is a step: a
/// wave's median over 10 s of an 18 s swell reaches about one RMS (review: at 0.75 of the
/// live RMS, 7 of 12 spikes there were followed by a re-level by a wave).
pub const STEP_RMS: f64 = 1.5;
pub const STEP_RMS_NOW: f64 = 0.75;
/// Values of a jump that is no step further than this many scales from their median
/// ([`JumpGuard::judge`]) are a spike, if they are few and come first ([`SPIKE_VALUES`]): they
/// are taken out of the history (left in, one 30 m heave sample in a sea of 0.45 m RMS stayed
/// in every retrain's window for 50 minutes; review). 10 s of waves spread about as far as
/// their amplitude, so the bound works out near 7 RMS in a sea of waves; a sample at 8 Hz
/// needs about 20 RMS to stand out so far after the decimation filter has spread it (review).
pub const SPIKE_SCALES: f64 = 5.0;
/// At most this many values, all among the first this many after the jump, are a spike: the
/// decimation filter spreads one bad sample over two or three values. Motion that grows within
/// the 10 s (a wave group after stillness) has its large values later, and stays as it is.
pub const SPIKE_VALUES: usize = 3;
/// ... and the values after those lie within this share of the spike's largest value (or
/// within the bound): what the decimation filter's tail leaves of it.
pub const SPIKE_TAIL: f64 = 0.1;
/// Values a level that stepped back must stay back before it is re-levelled back: 20 s, more
/// than a swell's period. (Over 10 s, a trough of an 18 s swell was taken for a step back after
/// 7 of 18 genuine 2-RMS heave steps: review.)
pub const BACK_VALUES: usize = 2 * CONFIRM_VALUES as usize;
/// The smallest live RMS a jump is judged against: a DOF of rounding noise (1e-17) is no
/// motion.
const MIN_RMS: f64 = 1e-9;

/// How far a jump has been judged ([`JumpGuard::judge`]).
#[derive(Debug, Clone, Copy, PartialEq)]
enum Stage {
    /// Not yet: its history is about to move.
    Unjudged,
    /// Judged no step (a spike, motion that resumed), or re-levelled back already: nothing
    /// more to judge.
    Done,
    /// Re-levelled by this much: watched for the level stepping back while it is held.
    Relevelled {
        by: f64,
        /// The newest values look stepped back, not yet for [`BACK_VALUES`]: held on.
        pending: bool,
    },
}

/// One DOF's jump.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Jump {
    /// Index of the first value that showed it (the hold lasts until it has left the model's
    /// input).
    at: u64,
    stage: Stage,
    /// The live RMS when it opened: the motion's, not yet swollen by the jump.
    rms_before: f64,
}

impl Jump {
    /// Whether its history is about to move: not judged yet, or a step back pending. It is
    /// held that long at least, and no retrain copies the history meanwhile.
    fn history_may_move(&self) -> bool {
        matches!(
            self.stage,
            Stage::Unjudged | Stage::Relevelled { pending: true, .. }
        )
    }

    /// The smallest median shift that is a step of the level, not a wave's.
    fn step_threshold(&self, rms: f64) -> f64 {
        (STEP_RMS * self.rms_before).max(STEP_RMS_NOW * rms)
    }
}

/// The jumps of every DOF.
#[derive(Debug, Clone, Default)]
pub struct JumpGuard {
    open: [Option<Jump>; NUM_DOF],
    /// Jumps found per DOF.
    pub found: [u64; NUM_DOF],
    /// Of them, steps whose history was re-levelled.
    pub relevelled: [u64; NUM_DOF],
    /// Of them, spikes taken out of the history.
    pub spikes: [u64; NUM_DOF],
}

/// What to do with a DOF's history at a value ([`JumpGuard::judge`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Judgement {
    /// Move the newest `values` stored deviations, and the level, by `by`.
    Relevel { values: usize, by: f64 },
    /// No step, but a spike: replace the newest `values` stored deviations outside
    /// `[low, high]` by their median `centre`.
    Spike {
        values: usize,
        low: f64,
        high: f64,
        centre: f64,
    },
    /// Nothing to move.
    Keep,
}

impl JumpGuard {
    /// Whether the first-step miss `miss` (the value at `index` less the deviation a running
    /// model forecast for it) of a forecast issued with `sigma` shows a jump of DOF `d`, given
    /// the live RMS `rms`. Opens one if so and none is open; true when it opened one.
    pub fn observe_first_step(
        &mut self,
        d: usize,
        index: u64,
        miss: f64,
        sigma: f64,
        rms: f64,
    ) -> bool {
        let jumped = rms > MIN_RMS && miss.abs() > (MISS_RMS * rms).max(MISS_SIGMAS * sigma);
        if !jumped || self.open[d].is_some() {
            return false;
        }
        self.open[d] = Some(Jump {
            at: index,
            stage: Stage::Unjudged,
            rms_before: rms,
        });
        self.found[d] += 1;
        true
    }

    /// At value `index` (after the value is stored), with the newest stored deviations
    /// `recent` (oldest first; at least the values since the jump, or what the history holds)
    /// and the live RMS: what to do with the history.
    ///
    /// Once, [`CONFIRM_VALUES`] values after the jump, whether it is a step. (Judged again
    /// every 10 s while it held, as tried on 2026-12-07, a level stepping back inside the hold
    /// was re-levelled too, but in a long swell that grows or resumes, waves' medians were
    /// taken for steps one window after another, and the retrains copied the mangled history:
    /// review.)
    ///
    /// After a re-level by `by`, and while the jump is held, whether the level steps back: the
    /// values after the split that best fits a step back by `by` number [`BACK_VALUES`] at
    /// least, and their median, and the newest [`CONFIRM_VALUES`]' median, is a step again,
    /// nearer `-by` than 0. Only that one step, once:
    /// a second window's median in a swell is not taken for a new step, nor a step back by far
    /// more than `by`. Without it, a 2 m offset undone 30 s later left the level 2 m off until
    /// its 5-minute mean followed (heave's 5 s NRMSE 1.34, worse than predicting the level).
    /// (Judged on the newest 20 values, a window of half old and half new values was taken
    /// for a step back halfway through a larger one: review.)
    pub fn judge(&mut self, d: usize, index: u64, recent: Option<&[f64]>, rms: f64) -> Judgement {
        let Some(jump) = self.open[d].as_mut() else {
            return Judgement::Keep;
        };
        let since_jump = (index.saturating_sub(jump.at) + 1) as usize;
        let threshold = jump.step_threshold(rms);
        match jump.stage {
            Stage::Done => Judgement::Keep,
            Stage::Unjudged => {
                if since_jump < CONFIRM_VALUES as usize {
                    return Judgement::Keep;
                }
                jump.stage = Stage::Done;
                let Some(after) = recent.and_then(|r| newest(r, since_jump)) else {
                    return Judgement::Keep;
                };
                let by = median_of(after);
                if by.abs() < threshold {
                    let rms_before = jump.rms_before;
                    return self.judge_spike(d, after, by, rms_before);
                }
                jump.stage = Stage::Relevelled { by, pending: false };
                self.relevelled[d] += 1;
                Judgement::Relevel {
                    values: since_jump,
                    by,
                }
            }
            Stage::Relevelled { by, .. } => {
                let Some(after) = recent.and_then(|r| newest(r, since_jump)) else {
                    return Judgement::Keep;
                };
                let values = values_stepped_back(after, by);
                let is_back = |m: f64| m.abs() >= threshold && (m + by).abs() <= 0.5 * by.abs();
                // By what the values after the split show, not by -by: moved by -by, a level
                // that stepped back by 1.5 times as much (or drifted on) was left off by the
                // rest, too little for the level's own step test (review).
                let back = median_of(&after[after.len() - values..]);
                let pending = values > 0 && is_back(back);
                // Back over the newest 10 s too: a trough that went leaves half the values
                // after the split about 0, and their median anywhere.
                let now_back =
                    newest(after, CONFIRM_VALUES as usize).is_some_and(|w| is_back(median_of(w)));
                if !(pending && now_back) || values < BACK_VALUES {
                    jump.stage = Stage::Relevelled { by, pending };
                    return Judgement::Keep;
                }
                jump.stage = Stage::Done;
                self.relevelled[d] += 1;
                Judgement::Relevel { values, by: back }
            }
        }
    }

    /// A jump that is no step, judged on the values since it, `after`, about their median
    /// `centre`: the values further from it than [`SPIKE_SCALES`] scales are a spike if they
    /// are among the first [`SPIKE_VALUES`]. The scale is the larger of the motion's RMS before
    /// the jump and the values' own robust scale (1.4826 times their median absolute
    /// deviation): 10 s of values can hold half a slow wave and little else, and their own
    /// scale alone then took the next trough for a spike too.
    fn judge_spike(&mut self, d: usize, after: &[f64], centre: f64, rms_before: f64) -> Judgement {
        let mut deviations = [0.0; 64];
        let n = after.len().min(deviations.len());
        for (dev, x) in deviations.iter_mut().zip(&after[after.len() - n..]) {
            *dev = (x - centre).abs();
        }
        let bound = SPIKE_SCALES * (1.4826 * median_of(&deviations[..n])).max(rms_before);
        let first = SPIKE_VALUES.min(after.len());
        let peak = after[..first]
            .iter()
            .map(|x| (x - centre).abs())
            .fold(0.0, f64::max);
        // The later values may hold the filter's tail of a very large spike, a small share
        // of it (review: a -999 m logger sentinel reached past 5 RMS at the 4th and 5th
        // value and was kept); motion that grows is as large later as at first.
        let tail = bound.max(SPIKE_TAIL * peak);
        if peak <= bound || after[first..].iter().any(|x| (x - centre).abs() > tail) {
            return Judgement::Keep;
        }
        self.spikes[d] += 1;
        Judgement::Spike {
            values: after.len(),
            low: centre - bound,
            high: centre + bound,
            centre,
        }
    }

    /// Whether DOF `d` is held at no skill at value `index`: from the jump until it has left
    /// the `input` values the DOF's model reads (and been judged).
    pub fn holds(&mut self, d: usize, index: u64, input: usize) -> bool {
        match self.open[d] {
            Some(j) if j.history_may_move() || index <= j.at + input as u64 + CONFIRM_VALUES => {
                true
            }
            Some(_) => {
                self.open[d] = None;
                false
            }
            None => false,
        }
    }

    /// Whether a jump of any DOF has not been judged yet, or a step back of one is pending: its
    /// history is about to move, so no retrain should copy it now (review: a retrain during a
    /// pending step back copied the uncorrected step). (Not for the whole hold: a sensor that
    /// spikes again and again would hold off every DOF's retrains for as long.)
    pub fn unjudged(&self) -> bool {
        self.open.iter().flatten().any(Jump::history_may_move)
    }

    /// Forget every jump (the history restarted).
    pub fn clear(&mut self) {
        self.open = [None; NUM_DOF];
    }
}

/// The newest `n` of `values`, if it holds as many.
fn newest(values: &[f64], n: usize) -> Option<&[f64]> {
    values.get(values.len().checked_sub(n)?..)
}

/// How many of the newest `values` (about 0, the newest about `-by`) lie after the step back:
/// the split that fits the two levels best. Moving the values after a split by `by` changes
/// their squared deviations by `2 by x + by²` each, so the best split is where the sum of that
/// over the values after it is least.
fn values_stepped_back(values: &[f64], by: f64) -> usize {
    let (mut sum, mut best, mut count) = (0.0, 0.0, 0);
    for (i, x) in values.iter().rev().enumerate() {
        sum += by * (2.0 * x + by);
        if sum < best {
            (best, count) = (sum, i + 1);
        }
    }
    count
}

/// The median of a few values (no allocation: at most 64 are taken).
fn median_of(values: &[f64]) -> f64 {
    let mut buf = [0.0; 64];
    let n = values.len().min(buf.len());
    buf[..n].copy_from_slice(&values[values.len() - n..]);
    shipcast_series::median::median_in_place(&mut buf[..n]).unwrap_or(0.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_miss_beyond_the_motion_and_the_sigma_opens_one_jump() {
        let mut g = JumpGuard::default();
        // Within 1.5 RMS, or within 8 sigmas: no jump.
        assert!(!g.observe_first_step(2, 10, 1.4, 0.01, 1.0));
        assert!(!g.observe_first_step(2, 10, 3.0, 0.5, 1.0));
        // No motion known yet: no jump.
        assert!(!g.observe_first_step(2, 10, 3.0, 0.01, 0.0));
        assert!(g.observe_first_step(2, 10, -1.6, 0.01, 1.0));
        // One at a time per DOF; the others are apart.
        assert!(!g.observe_first_step(2, 11, 5.0, 0.01, 1.0));
        assert!(g.observe_first_step(3, 11, 5.0, 0.01, 1.0));
        assert_eq!(g.found[2], 1);
    }

    #[test]
    fn a_step_is_relevelled_and_held_until_it_leaves_the_input_and_a_spike_is_kept() {
        let mut g = JumpGuard::default();
        assert!(g.observe_first_step(2, 100, 3.0, 0.02, 0.4));
        let input = 50;
        // Held while unjudged.
        assert!(g.holds(2, 101, input));
        assert!(g.unjudged());
        // Values 100..=119 after a step of 3 with a wave on it, and older ones about 0.
        let wave = |i: usize| 0.3 * (i as f64 * 0.8).sin();
        let mut stored = vec![0.1, -0.2, 0.3];
        stored.extend((0..20).map(|i| 3.0 + wave(i)));
        let last = 100 + CONFIRM_VALUES - 1;
        assert_eq!(g.judge(2, last - 1, Some(&stored), 0.4), Judgement::Keep);
        let Judgement::Relevel { values, by } = g.judge(2, last, Some(&stored), 0.4) else {
            panic!("a step of 3 was not re-levelled");
        };
        assert_eq!(values, CONFIRM_VALUES as usize);
        assert!((by - 3.0).abs() < 0.3, "{by}");
        assert_eq!(g.relevelled[2], 1);
        // Judged once only.
        assert_eq!(g.judge(2, last + 1, Some(&stored), 0.4), Judgement::Keep);
        // Held until the jump has left the model's input, then released.
        assert!(g.holds(2, 100 + input as u64 + CONFIRM_VALUES, input));
        assert!(!g.holds(2, 101 + input as u64 + CONFIRM_VALUES, input));
        assert!(!g.holds(2, 400, input));

        // A spike: one large value, then the sea again; and motion that resumes after
        // stillness (a live RMS near 0 before it, a wave after): neither is a step.
        for (first, rms) in [(40.0, 0.4), (0.9, 0.6)] {
            let mut g = JumpGuard::default();
            assert!(g.observe_first_step(1, 100, first, 0.02, 0.01));
            let mut stored = vec![first];
            stored.extend((1..20).map(|i| 0.9 * (i as f64 * 0.5).cos()));
            let judged = g.judge(1, last, Some(&stored), rms);
            assert!(!matches!(judged, Judgement::Relevel { .. }), "{first}");
            assert_eq!(g.relevelled[1], 0);
            // Still held until the jump has left the model's input.
            assert!(g.holds(1, 130, input));
        }
    }

    /// Regression (review): one 30 m heave sample stayed in every retrain's window for 50
    /// minutes. A jump whose first values lie far outside the others is a spike, and only those
    /// values are taken out (replaced by the median); motion that grows within the 10 s, a
    /// large wave among the first values, and a spike followed by another later are not.
    #[test]
    fn a_spike_is_taken_out_and_motion_that_grows_is_not() {
        let wave = |i: usize| 0.4 * (i as f64 * 0.7).sin();
        let judged = |stored: &[f64]| {
            let mut g = JumpGuard::default();
            assert!(g.observe_first_step(2, 100, 5.0, 0.01, 0.4));
            (g.judge(2, 119, Some(stored), 0.4), g.spikes[2])
        };
        // A logger's -999 sentinel, whose filter tail still reaches 5 RMS at the 5th value
        // (review: kept): taken out with its tail.
        let mut sentinel: Vec<f64> = (0..20).map(wave).collect();
        for (i, share) in [1.0, -0.3, 0.1, -0.01, 0.004].iter().enumerate() {
            sentinel[i] += -999.0 * share;
        }
        let (j, _) = judged(&sentinel);
        let Judgement::Spike { low, high, .. } = j else {
            panic!("{j:?}");
        };
        assert_eq!(
            (0..20)
                .filter(|&i| !(low..=high).contains(&sentinel[i]))
                .count(),
            5
        );
        // One sample spread by the filter over the first two values.
        let mut stored: Vec<f64> = (0..20).map(wave).collect();
        stored[0] += 7.0;
        stored[1] -= 1.5;
        let (j, spikes) = judged(&stored);
        let Judgement::Spike {
            values,
            low,
            high,
            centre,
        } = j
        else {
            panic!("{j:?}");
        };
        assert_eq!((values, spikes), (20, 1));
        let outside: Vec<usize> = (0..20)
            .filter(|&i| !(low..=high).contains(&stored[i]))
            .collect();
        assert_eq!(outside, [0], "only the spike is taken out ({low}, {high})");
        assert!(centre.abs() < 0.4, "{centre}");
        // Kept: motion that resumes small and grows tenfold within the 10 s, a large wave at
        // the start (2.5 times the others), and a second far value later in the window.
        let growing: Vec<f64> = (0..20)
            .map(|i| wave(i) * if i < 10 { 0.2 } else { 2.0 })
            .collect();
        let mut large_first: Vec<f64> = (0..20).map(wave).collect();
        large_first[0] = 1.0;
        let mut two_apart = stored.clone();
        two_apart[12] = 7.0;
        for (case, stored) in [
            ("growing", growing),
            ("large first", large_first),
            ("two apart", two_apart),
        ] {
            assert_eq!(judged(&stored), (Judgement::Keep, 0), "{case}");
        }
    }

    /// A level is judged once per jump: a second window's median is not taken for a step
    /// (review: judged every 10 s, waves' medians in a growing 18 s swell were re-levelled one
    /// window after another).
    #[test]
    fn a_jump_is_judged_once() {
        let mut g = JumpGuard::default();
        assert!(g.observe_first_step(2, 100, 2.0, 0.02, 0.37));
        let wave = |i: usize| 0.3 * (i as f64 * 0.8).sin();
        let mut stored: Vec<f64> = (0..20).map(|i| 2.0 + wave(i)).collect();
        let Judgement::Relevel { by, .. } = g.judge(2, 119, Some(&stored), 1.0) else {
            panic!("the step up was not re-levelled");
        };
        stored.iter_mut().for_each(|v| *v -= by);
        stored.extend((20..40).map(|i| 2.0 + wave(i)));
        assert_eq!(g.judge(2, 139, Some(&stored), 1.0), Judgement::Keep);
        assert_eq!(g.relevelled[2], 1);
    }

    /// Regression (review): a 2 m offset undone 30 s later, inside the hold, left the level
    /// 2 m off until its 5-minute mean followed. A step back by about the re-level is
    /// re-levelled back, from where it stepped back, once; a wave's median, and a further step
    /// the same way, are not.
    #[test]
    fn a_level_that_steps_back_inside_the_hold_is_relevelled_back_once() {
        let wave = |i: usize| 0.3 * (i as f64 * 0.8).sin();
        let relevelled = || {
            let mut g = JumpGuard::default();
            assert!(g.observe_first_step(2, 100, 2.0, 0.02, 0.37));
            let stored: Vec<f64> = (0..20).map(|i| 2.0 + wave(i)).collect();
            let Judgement::Relevel { by, .. } = g.judge(2, 119, Some(&stored), 0.37) else {
                panic!("the step up was not re-levelled");
            };
            let stored: Vec<f64> = stored.iter().map(|v| v - by).collect();
            (g, stored, by)
        };
        // Back down at value 130, by the re-level or 1.4 times as much: held on while it is
        // pending, and the values since are moved back by what they show once BACK_VALUES of
        // them do (review: moved by the re-level, the rest of an overshoot stayed).
        let input = 10;
        for factor in [1.0, 1.4] {
            let (mut g, mut stored, by) = relevelled();
            let mut judged = Judgement::Keep;
            for i in 20..100 {
                stored.push(if i >= 30 { -factor * by } else { 0.0 } + wave(i));
                let index = 100 + i as u64;
                judged = g.judge(2, index, Some(&stored), 0.37);
                if let Judgement::Relevel { values, by: back } = judged {
                    assert_eq!(i, 29 + BACK_VALUES, "{factor}: judged at {i}");
                    assert_eq!(values, BACK_VALUES, "{factor}");
                    assert!((back + factor * by).abs() < 0.3, "{factor}: {back}");
                    assert_eq!(g.relevelled[2], 2);
                    break;
                }
                assert_eq!(judged, Judgement::Keep);
                // Past the hold's end (value 130) only while the step back is pending; and no
                // retrain copies the history meanwhile (review: one copied the uncorrected
                // step).
                assert_eq!(g.holds(2, index, input), index <= 130 || i >= 30, "at {i}");
                if i < 30 || index > 130 {
                    assert_eq!(g.unjudged(), i >= 30, "{factor} at {i}");
                }
            }
            assert_ne!(
                judged,
                Judgement::Keep,
                "{factor}: the step back was not re-levelled"
            );
            // Only once, and the hold ends.
            assert!(!g.unjudged());
            stored.extend((0..60).map(|i| 2.0 + wave(i)));
            assert_eq!(g.judge(2, 200, Some(&stored), 0.37), Judgement::Keep);
            assert!(!g.holds(2, 200, input));
        }

        // Kept: a wave's median (within the step threshold), a further step up, a step back by
        // far more than the re-level (review: caught halfway, when the newest window's median
        // passed -by), and a trough of 10 s at -by that goes (review: an 18 s swell's).
        let by = relevelled().2;
        let trough = |i: usize| if (30..50).contains(&i) { -by } else { 0.0 };
        for (case, later) in [
            ("wave", &(|_| -0.4) as &dyn Fn(usize) -> f64),
            ("further up", &|_| 2.0),
            ("far back", &|_| -4.0),
            ("trough", &trough),
        ] {
            let (mut g, mut stored, _) = relevelled();
            for i in 20..120 {
                stored.push(later(i) + wave(i));
                assert_eq!(
                    g.judge(2, 100 + i as u64, Some(&stored), 0.37),
                    Judgement::Keep,
                    "{case} at {i}"
                );
            }
            assert!(!g.holds(2, 220, input), "{case}");
        }
    }

    #[test]
    fn the_values_after_a_step_back_are_the_best_split() {
        assert_eq!(values_stepped_back(&[0.1, -0.1, 0.0, -2.1, -1.9], 2.0), 2);
        assert_eq!(values_stepped_back(&[-2.0, -2.0], 2.0), 2);
        assert_eq!(values_stepped_back(&[0.0, 0.1], 2.0), 0);
        assert_eq!(values_stepped_back(&[0.0, 3.0, 2.9], -3.0), 2);
        assert_eq!(newest(&[1.0, 2.0, 3.0], 2), Some(&[2.0, 3.0][..]));
        assert_eq!(newest(&[1.0], 2), None);
    }

    #[test]
    fn the_median_of_few_values() {
        assert_eq!(median_of(&[]), 0.0);
        assert_eq!(median_of(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median_of(&[4.0, 1.0, 3.0, 2.0]), 2.5);
    }
}
