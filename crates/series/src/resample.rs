//! Bringing a motion record to the evaluation rate: estimate its rate from `time_s`, check that
//! the target divides it, filter and decimate every column.

use super::decimator::decimate;
use super::fir::delay_samples;
use crate::motion_csv::{Column, MotionData};

/// Largest relative deviation of one time step from the median step still called regular,
/// for stamps printed with enough decimals ([`regular_step_tolerance`] widens it for rounded
/// ones).
const STEP_TOLERANCE: f64 = 0.01;
/// Roundings of time stamps [`regular_step_tolerance`] recognises, coarsest first.
const STAMP_QUANTA: [f64; 4] = [1.0, 0.1, 0.01, 0.001];
/// Fewest steps off the typical one that [`check_stamp_rounding`] takes for rounding.
const MIN_ROUNDED_STEPS: usize = 20;
/// Largest relative deviation of a record's rate from the integer multiple of the forecast rate
/// it is taken as: eval, replay and the producer's `--input` all take a record within it and
/// refuse one beyond it. Within it, a 25 s forecast's last step lands within 25 ms of its time.
pub const RATE_TOLERANCE: f64 = 1e-3;

/// Longest typical time step [s] of a motion record: stamps further apart cannot even resolve
/// waves of 10 s (waves of 5 to 20 s move a ship). A longer one is most often stamped in
/// another unit than seconds ([`ResampleError::TooSlow`]).
pub const MAX_STEP_S: f64 = 5.0;

/// Why a record could not be resampled.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ResampleError {
    #[error("decimation factor must be at least 1")]
    ZeroFactor,
    #[error("decimation factor {0} is too large (at most {max})", max = super::decimator::MAX_FACTOR)]
    FactorTooLarge(usize),
    #[error("the record's sample rate, {} Hz, is more than {max} times the target {} Hz: time_s is in seconds (stamps in another unit?)", shipcast_wire::shown::number(*.input), shipcast_wire::shown::number(*.target), max = super::decimator::MAX_FACTOR)]
    RateTooHigh { input: f64, target: f64 },
    #[error("need at least two samples to estimate the sample rate, got {0}")]
    TooFewForRate(usize),
    #[error("irregular sampling: time step {index} (after t = {after_s} s) is {step} s, the typical step is {median} s")]
    Irregular {
        index: usize,
        /// The time the step starts from: where to look in the file.
        after_s: f64,
        step: f64,
        median: f64,
    },
    #[error("irregular sampling: time step {index} (after t = {after_s} s) is {step} s and the next {next} s, together about two typical steps of {median} s: a stamp off its slot by more than a quarter step, which a fixed-rate reader takes for a lost sample (stamps jittered that much must be put on their grid first)")]
    Jittered {
        index: usize,
        after_s: f64,
        step: f64,
        next: f64,
        median: f64,
    },
    #[error("irregular sampling: the rate drifts: sample {index} is stamped {time_s} s, {grid_s:.3} s on the grid of the gap-free stretch from t = {stretch_from_s} s (its first stamp plus its mean step per sample)")]
    OffGrid {
        index: usize,
        time_s: f64,
        grid_s: f64,
        /// First stamp of the stretch (the record's first in `eval`, which takes no gaps).
        stretch_from_s: f64,
    },
    #[error("time stamps rounded to {quantum} s are too coarse for the record's rate: {off} of its {steps} time steps differ from the typical step {median} s, while every stamp stays within a rounding of one regular grid (write the stamps with more decimals; or samples were lost at regular intervals)")]
    CoarseStamps {
        quantum: f64,
        median: f64,
        off: usize,
        steps: usize,
    },
    #[error("the record's typical time step is {step} s: no ship's motion is sampled that seldom (at most every {MAX_STEP_S} s); time_s is in seconds{hint}")]
    TooSlow {
        step: f64,
        /// Which unit the stamps look like, if any.
        hint: String,
    },
    #[error("the record's first time stamp is {first}: time_s is in seconds, and it looks like epoch time in {unit}: divide the column by {per_s:.0}")]
    EpochUnit {
        first: f64,
        unit: &'static str,
        per_s: f64,
    },
    #[error("the record's time does not increase (typical step {0} s)")]
    NotIncreasing(f64),
    #[error("target sample rate {0} Hz must be positive and finite")]
    BadTarget(f64),
    #[error("input rate {input} Hz is not an integer multiple of the target rate {target} Hz")]
    NotMultiple { input: f64, target: f64 },
    #[error("{samples} samples at {input} Hz are too few to decimate to {target} Hz: the filter needs {needed}")]
    TooShort {
        samples: usize,
        input: f64,
        target: f64,
        needed: usize,
    },
}

/// How far [s] a step of `time` may lie from its typical step `median_step` and still be
/// called regular: 1 % of the step, or, when every stamp is rounded to a quantum (whole
/// seconds, 0.1, 0.01 or 0.001 s) at most a quarter of the step, that quantum: two rounded
/// stamps make a step up to one quantum off. Regression (review): a 12, 16 or 24 Hz record
/// stamped to the millisecond has steps 1.2 to 2.4 % apart (0.083 and 0.084 s) and was
/// refused as irregular by eval and replay.
///
/// The rounding must show in the steps, not only in the stamps: at least a tenth of them a
/// half quantum or more off the median (a 12 Hz record stamped to the millisecond has a third
/// of them 1 ms off). Stamps that are exact multiples of the step (2 Hz stamped 0.0, 0.5,
/// 1.0) are multiples of 0.1 s too, yet not rounded: their tolerance stays 1 %. Regression
/// (review): one stamp 0.1 s late in such a record passed as rounding.
pub fn regular_step_tolerance(time: &[f64], median_step: f64) -> f64 {
    let relative = STEP_TOLERANCE * median_step;
    // The coarsest rounding every stamp shows (whole seconds are also whole tenths).
    let Some(q) = stamp_quantum(time).filter(|&q| q <= 0.25 * median_step) else {
        return relative;
    };
    let steps = time.len().saturating_sub(1);
    let rounded = time
        .windows(2)
        .map(|p| (p[1] - p[0] - median_step).abs())
        .filter(|off| (0.5 * q..=1.01 * q).contains(off))
        .count();
    if rounded * 10 < steps {
        return relative;
    }
    // A hair over one quantum: the two roundings' error can reach it exactly.
    relative.max(1.01 * q)
}

/// The coarsest rounding (one of [`STAMP_QUANTA`]) every stamp of `time` shows, if any.
fn stamp_quantum(time: &[f64]) -> Option<f64> {
    STAMP_QUANTA.into_iter().find(|&q| {
        time.iter().all(|&t| {
            let units = t / q;
            // Within float precision of a whole number of quanta (epoch stamps carry
            // 1e-7 s of representation error).
            (units - units.round()).abs() <= 1e-3
        })
    })
}

/// Sample rate [Hz] of regularly sampled times: 1 / mean step. Every step must be within
/// [`regular_step_tolerance`] of the median step (the typical one, unmoved by a single gap),
/// otherwise the sampling is irregular and no rate is returned.
pub fn sample_rate(time: &[f64]) -> Result<f64, ResampleError> {
    if time.len() < 2 {
        return Err(ResampleError::TooFewForRate(time.len()));
    }
    let steps: Vec<f64> = time.windows(2).map(|p| p[1] - p[0]).collect();
    let median = median_of(steps.clone());
    check_step_in_seconds(time, median)?;
    check_stamp_rounding(time, median)?;
    let tolerance = regular_step_tolerance(time, median);
    for (index, &step) in steps.iter().enumerate() {
        if step.is_nan() || step <= 0.0 || (step - median).abs() > tolerance {
            return Err(ResampleError::Irregular {
                index: index + 1,
                after_s: time[index],
                step,
                median,
            });
        }
    }
    on_grid(time, 0, consecutive(), mean_step(time))?;
    Ok(1.0 / mean_step(time))
}

/// The mean step of `run` (at least two stamps): its span over its steps.
fn mean_step(run: &[f64]) -> f64 {
    (run[run.len() - 1] - run[0]) / (run.len() - 1) as f64
}

/// One slot per stamp: the slots of a run without gaps.
fn consecutive() -> impl Iterator<Item = f64> {
    (0u32..).map(f64::from)
}

/// The stamp of `run` farthest from its place on a grid of step `grid` from the first stamp
/// (the k-th stamp in slot `slots[k]`), with that place, if it is farther than `tolerance`.
/// The farthest, not the first: where the rate changes (8 Hz at 0.125 s, then 0.124 s) the
/// stamps lie farthest from the mean grid, while the first beyond the tolerance came 113
/// samples into the record, where nothing is wrong (review).
fn farthest_off_grid(
    run: &[f64],
    slots: impl Iterator<Item = f64>,
    grid: f64,
    tolerance: f64,
) -> Option<(usize, f64)> {
    run.iter()
        .zip(slots)
        .enumerate()
        .map(|(i, (&t, slot))| (i, t, run[0] + slot * grid))
        .max_by(|a, b| (a.1 - a.2).abs().total_cmp(&(b.1 - b.2).abs()))
        .filter(|&(_, t, at)| (t - at).abs() > tolerance)
        .map(|(i, _, at)| (i, at))
}

/// Checks that the stamps of one gap-free run `run` (starting at index `offset` of the
/// record) lie within half a step of their slots (`slots`, one per stamp) on a grid of step
/// `grid` from its first stamp. Each step may be regular while the rate drifts (16 ms steps,
/// then 15 ms ones); the samples' count then no longer tells their time. Regression (review).
fn on_grid(
    run: &[f64],
    offset: usize,
    slots: impl Iterator<Item = f64>,
    grid: f64,
) -> Result<(), ResampleError> {
    if run.len() < 3 {
        return Ok(());
    }
    match farthest_off_grid(run, slots, grid, 0.5 * grid) {
        Some((i, slot)) => Err(ResampleError::OffGrid {
            index: offset + i,
            time_s: run[i],
            grid_s: slot,
            stretch_from_s: run[0],
        }),
        None => Ok(()),
    }
}

/// The index ranges of the gap-free stretches of `time`: maximal runs of stamps whose steps
/// lie within `tolerance` of `median_step` (a stamp after a gap starts a new one).
pub fn gap_free_runs(
    time: &[f64],
    median_step: f64,
    tolerance: f64,
) -> impl Iterator<Item = std::ops::Range<usize>> + '_ {
    let regular = move |step: f64| (step - median_step).abs() <= tolerance;
    let mut start = 0;
    (1..=time.len()).filter_map(move |i| {
        let ends = i == time.len() || !regular(time[i] - time[i - 1]);
        ends.then(|| {
            let run = start..i;
            start = i;
            run
        })
    })
}

/// Checks a record that may hold gaps as a fixed-rate consumer takes it (the predictor's
/// engine counts samples): each sample goes into the slot `max(1, round(step / median_step))`
/// after the one before, a gap of up to `bridged` empty slots is bridged, and a longer one
/// starts a new stretch with a phase of its own. Within each stretch the stamps must lie within
/// half a step of their slots on the stretch's grid (its span over its slots), and that grid's
/// step must be the record's typical one (within [`regular_step_tolerance`], and what half a
/// step of jitter at each end allows).
///
/// Regressions (review):
/// - the stretches were the runs of steps within [`regular_step_tolerance`] of the typical
///   one: a record at 8 Hz that went on at 16 Hz (or held one sample inserted half a step
///   late) cut into single samples, and replay scored it as if at 8 Hz without a word;
/// - each stretch was checked against its own mean step only: 8 Hz, a pause, then 10 Hz (or a
///   clock 2 % slow) passed, and the later part was fed as 8 Hz; so did 8 Hz then 5 Hz, every
///   step of 1.6 taken for a gap;
/// - a step shorter than half the typical one was refused, and with it stamps jittered by
///   more than a quarter step, which the engine places right. Stamps jittered so far that a
///   step rounds to two slots are refused: the engine would bridge a sample that is there.
pub fn check_runs_on_grid(
    time: &[f64],
    median_step: f64,
    bridged: usize,
) -> Result<(), ResampleError> {
    let regular = regular_step_tolerance(time, median_step);
    let slots_of = |i: usize| ((time[i] - time[i - 1]) / median_step).round().max(1.0);
    let restarts = |i: usize| slots_of(i) - 1.0 > bridged as f64;
    let mut start = 0;
    for end in (1..=time.len()).filter(|&i| i == time.len() || restarts(i)) {
        check_stretch(time, start, end, median_step, regular, &slots_of)?;
        start = end;
    }
    Ok(())
}

/// [`check_runs_on_grid`] for the stretch `time[start..end]`.
fn check_stretch(
    time: &[f64],
    start: usize,
    end: usize,
    median_step: f64,
    regular: f64,
    slots_of: &dyn Fn(usize) -> f64,
) -> Result<(), ResampleError> {
    if end - start < 3 {
        return Ok(());
    }
    let slots = ((start + 1)..end).map(slots_of).sum::<f64>();
    let grid = (time[end - 1] - time[start]) / slots;
    // Where to look when the stretch fails: a stamp so late that its step rounds to two slots
    // while the next step makes up for it (jitter), or else its first step that is no whole
    // number of typical steps (where the rate changed), as eval names it.
    let first_irregular = || {
        let late = ((start + 1)..end.saturating_sub(1)).find(|&i| {
            let (step, next) = (time[i] - time[i - 1], time[i + 1] - time[i]);
            slots_of(i) >= 2.0 && ((step + next) / median_step).round() < slots_of(i) + 1.0
        });
        if let Some(index) = late {
            return Some(ResampleError::Jittered {
                index,
                after_s: time[index - 1],
                step: time[index] - time[index - 1],
                next: time[index + 1] - time[index],
                median: median_step,
            });
        }
        ((start + 1)..end)
            .find(|&i| {
                let step = time[i] - time[i - 1];
                (step - slots_of(i) * median_step).abs() > regular
            })
            .map(|index| ResampleError::Irregular {
                index,
                after_s: time[index - 1],
                step: time[index] - time[index - 1],
                median: median_step,
            })
    };
    // Half a step of jitter at either end moves the grid's step by up to one step over the
    // slots.
    if (grid - median_step).abs() > regular + median_step / slots {
        return Err(first_irregular().unwrap_or(ResampleError::OffGrid {
            index: end - 1,
            time_s: time[end - 1],
            grid_s: time[start] + slots * median_step,
            stretch_from_s: time[start],
        }));
    }
    let slots_so_far = std::iter::once(0.0).chain(((start + 1)..end).scan(0.0, |slot, i| {
        *slot += slots_of(i);
        Some(*slot)
    }));
    on_grid(&time[start..end], start, slots_so_far, grid)
}
/// Units time stamps come in, with how many of them make a second.
const TIME_UNITS: [(f64, &str); 4] = [
    (1.0, "seconds"),
    (1e3, "milliseconds"),
    (1e6, "microseconds"),
    (1e9, "nanoseconds"),
];
/// Epoch time in seconds lies in this range (1973 to 2286): a first stamp this size in some
/// unit is epoch time in that unit.
const EPOCH_S: std::ops::Range<f64> = 1e8..1e10;
/// The shortest typical step [s] a motion record has (1 kHz).
const MIN_STEP_S: f64 = 1e-3;

/// The unit (how many make a second, and its name) in which `t` is epoch time, if any.
pub(crate) fn epoch_unit(t: f64) -> Option<(f64, &'static str)> {
    TIME_UNITS
        .into_iter()
        .find(|&(per_s, _)| EPOCH_S.contains(&(t.abs() / per_s)))
}

/// Refuses stamps that are not seconds, saying which unit they look like: a first stamp that is
/// epoch time in milliseconds, microseconds or nanoseconds (its size tells the unit), or a
/// typical step longer than [`MAX_STEP_S`]. A record stamped in nanoseconds read as 0 Hz, one in
/// milliseconds as 0.008 Hz (review); epoch milliseconds at 1 kHz passed as a 1 Hz record.
fn check_step_in_seconds(time: &[f64], median: f64) -> Result<(), ResampleError> {
    let first = time.first().map_or(0.0, |t| t.abs());
    let epoch = epoch_unit(first);
    if let Some((per_s, unit)) = epoch.filter(|&(per_s, _)| per_s > 1.0) {
        return Err(ResampleError::EpochUnit { first, unit, per_s });
    }
    // NaN and non-increasing time are refused by the checks that know them.
    if !(median > MAX_STEP_S && median.is_finite()) {
        return Ok(());
    }
    let hint = if epoch.is_some() {
        // Epoch seconds: the step is one of seconds.
        String::new()
    } else {
        let plausible: Vec<String> = TIME_UNITS[1..]
            .iter()
            .filter(|&&(per_s, _)| (MIN_STEP_S..=MAX_STEP_S).contains(&(median / per_s)))
            .map(|&(per_s, unit)| format!("{unit} (divide the column by {per_s:.0})"))
            .collect();
        if plausible.is_empty() {
            String::new()
        } else {
            format!(
                ", and a step of {median} looks like {}",
                plausible.join(" or ")
            )
        }
    };
    Err(ResampleError::TooSlow { step: median, hint })
}

/// The upper median of `values` (at least one).
fn median_of(mut values: Vec<f64>) -> f64 {
    values.sort_by(f64::total_cmp);
    values[values.len() / 2]
}

/// Sample rate [Hz] of a record that may hold gaps: one over the median step, which gaps and
/// a few jittered stamps do not move.
pub fn median_rate(time: &[f64]) -> Result<f64, ResampleError> {
    if time.len() < 2 {
        return Err(ResampleError::TooFewForRate(time.len()));
    }
    let median = median_of(time.windows(2).map(|p| p[1] - p[0]).collect());
    if !(median > 0.0 && median.is_finite()) {
        return Err(ResampleError::NotIncreasing(median));
    }
    check_step_in_seconds(time, median)?;
    check_stamp_rounding(time, median)?;
    Ok(1.0 / median)
}

/// Refuses stamps rounded more coarsely than a quarter of the typical step `median`: they
/// cannot carry the record's rate. 8 Hz stamped to 0.1 s gives steps of 0.1 and 0.2 s and
/// read as 10 Hz with a gap every fourth sample (review). Their mark: many steps off the
/// median (a tenth), while every stamp stays within one rounding of a regular grid. Samples
/// lost from a 10 Hz stream stamped to 0.1 s make steps as long, but push the later stamps
/// off any such grid.
fn check_stamp_rounding(time: &[f64], median: f64) -> Result<(), ResampleError> {
    if let Some(quantum) = stamp_quantum(time).filter(|&q| q > 0.25 * median) {
        let steps = time.len() - 1;
        let off = time
            .windows(2)
            .filter(|p| (p[1] - p[0] - median).abs() > 0.5 * quantum)
            .count();
        let regular =
            farthest_off_grid(time, consecutive(), mean_step(time), 1.01 * quantum).is_none();
        // At least MIN_ROUNDED_STEPS of them: in a short record one lost sample is a tenth.
        if off * 10 >= steps && off >= MIN_ROUNDED_STEPS && regular {
            return Err(ResampleError::CoarseStamps {
                quantum,
                // To a microsecond: the step as the stamps give it (0.1, not 0.10000000000002).
                median: (median * 1e6).round() / 1e6,
                off,
                steps,
            });
        }
    }
    Ok(())
}

/// Integer factor taking `input` Hz to `target` Hz (1 when they are equal), or an error naming
/// both rates.
pub fn decimation_factor(input: f64, target: f64) -> Result<usize, ResampleError> {
    if !(target > 0.0 && target.is_finite()) {
        return Err(ResampleError::BadTarget(target));
    }
    let ratio = input / target;
    let factor = ratio.round();
    if factor < 1.0 || ((ratio - factor) / ratio).abs() > RATE_TOLERANCE {
        return Err(ResampleError::NotMultiple { input, target });
    }
    Ok(factor as usize)
}

/// The record at `target` Hz. A record already at that rate is returned unchanged; otherwise
/// every column goes through the same [`super::Decimator`] filter and each output is labelled
/// with the time of the input sample it represents (the filter's delay before the newest input
/// used), so times stay on the input clock and the columns stay aligned.
pub fn resample_motion(data: &MotionData, target: f64) -> Result<MotionData, ResampleError> {
    let input = sample_rate(&data.time)?;
    let factor = decimation_factor(input, target)?;
    if factor == 1 {
        return Ok(data.clone());
    }
    // Regression (review): a record of sub-normal time steps was "decimation factor
    // 18446744073709551615 is too large", the factor saturated and the rate not named.
    if factor > super::decimator::MAX_FACTOR {
        return Err(ResampleError::RateTooHigh { input, target });
    }
    let needed = 4 * factor + 1;
    if data.len() < needed {
        return Err(ResampleError::TooShort {
            samples: data.len(),
            input,
            target,
            needed,
        });
    }
    let delay = delay_samples(factor);
    let outputs = (data.len() - needed) / factor + 1;
    let time = (0..outputs)
        .map(|j| data.time[j * factor + delay])
        .collect();
    let columns = data
        .columns
        .iter()
        .map(|c| {
            Ok(Column {
                name: c.name.clone(),
                values: decimate(&c.values, factor)?,
            })
        })
        .collect::<Result<_, ResampleError>>()?;
    Ok(MotionData {
        time,
        columns,
        ignored: data.ignored.clone(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(rate: f64, n: usize) -> MotionData {
        let time: Vec<f64> = (0..n).map(|i| 10.0 + i as f64 / rate).collect();
        let heave = time.iter().map(|t| (0.6 * t).sin()).collect();
        let wave = time.iter().map(|t| (0.5 * t).cos()).collect();
        MotionData {
            ignored: Vec::new(),
            time,
            columns: vec![
                Column {
                    name: "heave_m".into(),
                    values: heave,
                },
                Column {
                    name: "wave_m".into(),
                    values: wave,
                },
            ],
        }
    }

    #[test]
    fn a_record_stamped_in_another_unit_than_seconds_is_refused_saying_which() {
        let at = |step: f64, from: f64| -> Vec<f64> {
            (0..100).map(|i| from + i as f64 * step).collect()
        };
        // Steps too long for seconds, from 0: every unit that gives a plausible rate is named.
        for (time, named, not_named) in [
            (
                at(125.0, 0.0),
                vec!["milliseconds (divide the column by 1000)"],
                vec!["micro"],
            ),
            (
                at(1e6, 0.0),
                vec!["microseconds (divide the column by 1000000)"],
                vec!["milli"],
            ),
            // 200 Hz in microseconds, or 0.2 Hz in milliseconds.
            (
                at(5000.0, 0.0),
                vec!["milliseconds", "microseconds"],
                vec!["nano"],
            ),
            (at(1e11, 0.0), vec![], vec!["looks like"]),
            // Epoch seconds every 10 s: seconds, however seldom.
            (at(10.0, 1.7e9), vec![], vec!["looks like", "epoch"]),
        ] {
            for e in [median_rate(&time), sample_rate(&time)] {
                let e = e.unwrap_err();
                assert!(matches!(e, ResampleError::TooSlow { .. }), "{e}");
                let e = e.to_string();
                assert!(named.iter().all(|n| e.contains(n)), "{e}");
                assert!(not_named.iter().all(|n| !e.contains(n)), "{e}");
            }
        }
        // Epoch time in another unit tells it by its size, whatever the step (epoch ms at
        // 1 kHz passed as a 1 Hz record: review).
        for (time, unit) in [
            (at(1.0, 1.7e12), "milliseconds: divide the column by 1000"),
            (
                at(125_000.0, 1.7e15),
                "microseconds: divide the column by 1000000",
            ),
            (
                at(1e6, 1.7e18),
                "nanoseconds: divide the column by 1000000000",
            ),
        ] {
            for e in [median_rate(&time), sample_rate(&time)] {
                let e = e.unwrap_err();
                assert!(matches!(e, ResampleError::EpochUnit { .. }), "{e}");
                assert!(e.to_string().contains(unit), "{e}");
            }
        }
        // Epoch seconds at 8 Hz are a record.
        assert_eq!(median_rate(&at(0.125, 1.7e9)), Ok(8.0));
        // At most one step every MAX_STEP_S seconds is a record (1 Hz, 0.2 Hz).
        assert_eq!(median_rate(&at(1.0, 0.0)), Ok(1.0));
        assert_eq!(median_rate(&at(MAX_STEP_S, 0.0)), Ok(1.0 / MAX_STEP_S));
    }

    #[test]
    fn median_rate_ignores_gaps_and_refuses_time_that_does_not_increase() {
        // 8 Hz with a 10 s hole and one stamp jittered by 1 ms: the median step is 0.125 s.
        let mut time: Vec<f64> = (0..100).map(|i| i as f64 * 0.125).collect();
        time.extend((100..200).map(|i| 10.0 + i as f64 * 0.125));
        time[50] += 0.001;
        assert_eq!(median_rate(&time), Ok(8.0));
        assert_eq!(median_rate(&[1.0]), Err(ResampleError::TooFewForRate(1)));
        assert_eq!(
            median_rate(&[3.0, 2.0, 1.0]),
            Err(ResampleError::NotIncreasing(-1.0))
        );
    }

    #[test]
    fn estimates_rate_and_rejects_irregular_sampling() {
        let t: Vec<f64> = (0..100).map(|i| i as f64 * 0.125).collect();
        assert!((sample_rate(&t).unwrap() - 8.0).abs() < 1e-12);
        // Rounded time stamps (3 decimals at 3 Hz) are still regular.
        let rounded: Vec<f64> = (0..100)
            .map(|i| (i as f64 / 3.0 * 1000.0).round() / 1000.0)
            .collect();
        assert!((sample_rate(&rounded).unwrap() - 3.0).abs() < 1e-3);
        let mut gap = t.clone();
        gap.iter_mut().skip(50).for_each(|v| *v += 0.125);
        let message = sample_rate(&gap).unwrap_err().to_string();
        assert!(
            message.contains("irregular sampling: time step 50 (after t = 6.125 s) is 0.25 s"),
            "{message}"
        );
        assert!(matches!(
            sample_rate(&[1.0]),
            Err(ResampleError::TooFewForRate(1))
        ));
    }

    /// Regression (review): millisecond stamps at 12, 16 and 24 Hz make steps 1.2 to 2.4 %
    /// apart; they are regular, while a step off by more than the rounding explains is not.
    #[test]
    fn rounded_stamps_are_regular_up_to_their_rounding_and_no_further() {
        let ms = |t: f64| (t * 1000.0).round() / 1000.0;
        for rate in [12.0, 16.0, 24.0, 64.0] {
            let time: Vec<f64> = (0..2000).map(|i| ms(50.0 + i as f64 / rate)).collect();
            let got = sample_rate(&time).unwrap();
            assert!((got - rate).abs() < 1e-3 * rate, "{rate} Hz read as {got}");
            // One stamp 2 ms late: a step 2.5 ms off (0.0858 s at 12 Hz) is not rounding.
            let mut late = time.clone();
            late[1000] += 0.002;
            assert!(
                matches!(sample_rate(&late), Err(ResampleError::Irregular { .. })),
                "{rate} Hz"
            );
        }
        // Exact stamps of a 2 Hz record are multiples of 0.1 s, but show no rounding: one
        // stamp 0.1 s late is irregular (regression, review), and so is a drifting rate.
        let mut late: Vec<f64> = (0..400).map(|i| i as f64 * 0.5).collect();
        late[200] += 0.1;
        assert!(matches!(
            sample_rate(&late),
            Err(ResampleError::Irregular { index: 200, .. })
        ));
        let mut drift: Vec<f64> = (0..5000).map(|i| ms(i as f64 * 0.016)).collect();
        let end = drift[4999];
        drift.extend((1..3000).map(|i| ms(end + i as f64 * 0.015)));
        let e = sample_rate(&drift).unwrap_err().to_string();
        assert!(e.starts_with("irregular sampling: the rate drifts"), "{e}");
        // Whole-second stamps at 1 Hz: the rounding is the step itself and widens nothing.
        let mut seconds: Vec<f64> = (0..100).map(f64::from).collect();
        seconds.iter_mut().skip(50).for_each(|t| *t += 0.2);
        assert!(matches!(
            sample_rate(&seconds),
            Err(ResampleError::Irregular { index: 50, .. })
        ));
        let whole: Vec<f64> = (0..100).map(f64::from).collect();
        assert_eq!(regular_step_tolerance(&whole, 1.0), 0.01);
    }

    /// Regression (review): 8 Hz stamped to 0.1 s read as 10 Hz with a gap every fourth
    /// sample in replay (and as irregular in eval). Samples lost from a true 10 Hz stream
    /// stamped alike are still a 10 Hz record with gaps.
    #[test]
    fn stamps_too_coarse_for_the_rate_are_refused_and_lost_samples_are_not() {
        let tenth = |t: f64| (t * 10.0).round() / 10.0;
        let eight: Vec<f64> = (0..4000).map(|i| tenth(i as f64 / 8.0)).collect();
        for e in [median_rate(&eight), sample_rate(&eight)] {
            match e {
                Err(ResampleError::CoarseStamps { quantum, off, .. }) => {
                    assert_eq!(quantum, 0.1);
                    assert!((900..=1100).contains(&off), "{off} steps off");
                }
                other => panic!("8 Hz at 0.1 s read as {other:?}"),
            }
        }
        // One sample in five lost, at random, from 10 Hz stamped to 0.1 s.
        let mut state = 12345u64;
        let mut lossy = Vec::new();
        for i in 0..5000 {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            if !(state >> 33).is_multiple_of(5) {
                lossy.push(tenth(i as f64 * 0.1));
            }
        }
        assert!((median_rate(&lossy).unwrap() - 10.0).abs() < 1e-9);
        // Regression (review): a short record with one sample lost has a tenth of its steps
        // off, on one grid within a rounding; it is a gap, not rounding.
        let short: Vec<f64> = (0..12)
            .filter(|&i| i != 6)
            .map(|i| tenth(i as f64 * 0.1))
            .collect();
        assert!((median_rate(&short).unwrap() - 10.0).abs() < 1e-9);
        // Whole-second stamps of a 1 Hz record: rounded as coarsely as the step, every step alike.
        let seconds: Vec<f64> = (0..100).map(f64::from).collect();
        assert_eq!(median_rate(&seconds).unwrap(), 1.0);
    }

    /// A rate that drifts inside one gap-free stretch is refused even when the record has
    /// gaps (replay's check); the gaps alone are not a drift.
    #[test]
    fn a_drift_within_a_stretch_between_gaps_is_refused() {
        let ms = |t: f64| (t * 1000.0).round() / 1000.0;
        let mut time: Vec<f64> = (0..3000).map(|i| ms(i as f64 * 0.016)).collect();
        let gap_end = time[2999] + 5.0;
        time.extend((0..3000).map(|i| ms(gap_end + i as f64 * 0.016)));
        let median = 1.0 / median_rate(&time).unwrap();
        check_runs_on_grid(&time, median, 8).unwrap();
        let end = time[5999];
        time.extend((1..3000).map(|i| ms(end + i as f64 * 0.015)));
        match check_runs_on_grid(&time, median, 8) {
            Err(ResampleError::OffGrid { index, .. }) => assert!(index >= 3000, "{index}"),
            other => panic!("a drift after the gap read as {other:?}"),
        }
    }

    /// Regression (review): a rate that changes (8 Hz, then 16 Hz or 10 Hz) and a sample
    /// inserted half a step late cut the regular runs into single samples and passed; stamps
    /// jittered by up to a fifth of a step about their grid, with gaps, still pass.
    #[test]
    fn a_rate_that_changes_or_a_sample_out_of_place_is_refused_and_jitter_is_not() {
        let step = 0.125;
        let first: Vec<f64> = (0..2400).map(|i| i as f64 * step).collect();
        let end = first[2399];
        for (later, what) in [(0.0625, "16 Hz"), (0.1, "10 Hz")] {
            let mut time = first.clone();
            time.extend((1..2400).map(|i| end + i as f64 * later));
            let median = 1.0 / median_rate(&time).unwrap();
            assert!(
                check_runs_on_grid(&time, median, 8).is_err(),
                "8 Hz then {what}"
            );
        }
        let mut inserted = first.clone();
        inserted.insert(800, inserted[799] + 0.5 * step);
        let median = 1.0 / median_rate(&inserted).unwrap();
        // A third of the way in: the stamps before it lie 2/3 of a step off the stretch's grid.
        assert!(
            matches!(
                check_runs_on_grid(&inserted, median, 8),
                Err(ResampleError::OffGrid { .. } | ResampleError::Irregular { .. })
            ),
            "an inserted sample passed"
        );
        // Jitter of +-25 ms about an 8 Hz grid (a sign pattern, no drift), and two gaps of
        // 3 and 40 samples.
        let jitter = |i: usize| 0.025 * [1.0, -1.0, 0.6, -0.2, 0.0, -0.8, 0.4][i % 7];
        let jittered: Vec<f64> = (0..4800)
            .filter(|i| !(1000..1003).contains(i) && !(3000..3040).contains(i))
            .map(|i| i as f64 * step + jitter(i))
            .collect();
        // Against the rate the record runs at (the median step of such a pattern is biased).
        check_runs_on_grid(&jittered, step, 8).unwrap();
        // Jitter of +-0.4 step that alternates (steps of 0.2 and 1.8 typical ones): the
        // engine places the close pairs right, but takes each long step for a lost sample,
        // and bridges one that is there: refused. +-0.2 step keeps every step below 1.5.
        let alternate = |amount: f64| -> Vec<f64> {
            (0..2400)
                .map(|i| i as f64 * step + if i % 2 == 0 { amount } else { -amount } * step)
                .collect()
        };
        assert!(matches!(
            check_runs_on_grid(&alternate(0.4), step, 8),
            Err(ResampleError::Jittered { index: 2, .. })
        ));
        check_runs_on_grid(&alternate(0.2), step, 8).unwrap();
        // After a pause of 30 s: 10 Hz, a clock 2 % slow, or 5 Hz (each step 1.6 typical
        // ones, taken for a gap) are another rate; 4 Hz is 8 Hz with every other sample lost.
        for (later, refused) in [(0.1, true), (0.1275, true), (0.2, true), (0.25, false)] {
            let mut time = first.clone();
            let resume = end + 30.0;
            time.extend((0..2400).map(|i| resume + i as f64 * later));
            let got = check_runs_on_grid(&time, step, 8);
            assert_eq!(
                got.is_err(),
                refused,
                "8 Hz, a pause, then steps of {later} s: {got:?}"
            );
        }
    }

    #[test]
    fn factor_must_be_an_integer_multiple() {
        assert_eq!(decimation_factor(8.0, 2.0).unwrap(), 4);
        assert_eq!(decimation_factor(2.0, 2.0).unwrap(), 1);
        assert_eq!(decimation_factor(8.0000001, 2.0).unwrap(), 4);
        let message = decimation_factor(5.0, 2.0).unwrap_err().to_string();
        assert!(
            message.contains("5 Hz") && message.contains("2 Hz"),
            "{message}"
        );
        assert!(decimation_factor(1.0, 2.0).is_err());
        assert!(decimation_factor(8.0, 0.0).is_err());
        assert!(decimation_factor(8.0, f64::NAN).is_err());
        // A tiny target rate gives a factor no filter should be built for.
        let tiny = MotionData {
            ignored: Vec::new(),
            time: vec![0.0, 1.0, 2.0],
            columns: vec![],
        };
        let e = resample_motion(&tiny, 1e-300).unwrap_err();
        assert!(matches!(e, ResampleError::RateTooHigh { .. }), "{e}");
        assert_eq!(
            e.to_string(),
            "the record's sample rate, 1 Hz, is more than 65536 times the target 1e-300 Hz: time_s is in seconds (stamps in another unit?)"
        );
    }

    #[test]
    fn resampled_record_is_aligned_and_labelled_by_represented_time() {
        let data = record(8.0, 800);
        let same = resample_motion(&data, 8.0).unwrap();
        assert_eq!(same, data);
        let low = resample_motion(&data, 2.0).unwrap();
        assert_eq!(low.len(), (800 - 17) / 4 + 1);
        assert!((sample_rate(&low.time).unwrap() - 2.0).abs() < 1e-9);
        // Labelled at the represented time, each value is the slow motion at that time.
        assert_eq!(low.time[0], data.time[8]);
        for (i, t) in low.time.iter().enumerate() {
            assert!((low.column("heave_m").unwrap()[i] - (0.6 * t).sin()).abs() < 0.005);
            assert!((low.column("wave_m").unwrap()[i] - (0.5 * t).cos()).abs() < 0.005);
        }
        assert_eq!(
            low.column("heave_m").unwrap(),
            decimate(data.column("heave_m").unwrap(), 4).unwrap()
        );
        assert!(matches!(
            resample_motion(&record(8.0, 16), 2.0),
            Err(ResampleError::TooShort { needed: 17, .. })
        ));
    }
}
