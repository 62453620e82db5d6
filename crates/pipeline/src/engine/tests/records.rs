//! Records as replay takes them: their rate from the regular steps, the shared rate
//! tolerance, epoch time stamps.

use super::*;

#[test]
fn epoch_time_stamps_leave_the_results_and_the_trace_as_from_zero() {
    // Regression: the per-minute trace was sized by the last time stamp itself, so a record
    // stamped in epoch seconds (1.7e9) needed gigabytes and one at 1e13 aborted. It now counts
    // minutes from the record's first sample; stamps 1.7e9 s later (a multiple of 60 s, so the
    // minutes fall alike) must give the very same report.
    let config = PredictorServiceConfig {
        retrain_every_s: 0.0,
        ..PredictorServiceConfig::default()
    };
    let data = record(ar2(2 * 600, 4, |_| 1.0), 2.0);
    let mut late = data.clone();
    let offset = 60.0 * 28_333_333.0;
    late.time.iter_mut().for_each(|t| *t += offset);
    let (a, _) = replay(&data, &config, None, 60.0, false, &|_| {}).unwrap();
    let (b, _) = replay(&late, &config, None, 60.0 + offset, false, &|_| {}).unwrap();
    let (a, b) = (&a.dofs[0], &b.dofs[0]);
    assert_eq!(a.rms_10s_by_minute.len(), 11);
    assert_eq!(b.rms_10s_by_minute.len(), 11);
    assert_eq!(a.scored, b.scored);
    for (x, y) in a.nrmse.iter().zip(&b.nrmse) {
        assert!((x - y).abs() < 1e-9, "{x} {y}");
    }
}

/// Regression (review): a 6 Hz record stamped to the millisecond read as 5.988 Hz by its
/// median step and was refused by replay while eval took it; gaps and epoch stamps must still
/// give the record's own rate, and a rate that is no multiple is still refused.
#[test]
fn a_record_rate_comes_from_its_regular_steps_whatever_the_rounding_and_gaps() {
    use crate::engine::replay::record_rate;
    let ms = |t: f64| (t * 1000.0).round() / 1000.0;
    let six: Vec<f64> = (0..3000).map(|i| ms(i as f64 / 6.0)).collect();
    assert_eq!(record_rate(&six, 2.0).unwrap(), 6.0);
    // Ten hertz in epoch seconds with a 20 s gap.
    let mut ten: Vec<f64> = (0..2000).map(|i| 1.7e9 + i as f64 * 0.1).collect();
    ten.extend((2200..4000).map(|i| 1.7e9 + i as f64 * 0.1));
    assert_eq!(record_rate(&ten, 2.0).unwrap(), 10.0);
    let odd: Vec<f64> = (0..3000).map(|i| i as f64 * 0.13).collect();
    let e = record_rate(&odd, 2.0).unwrap_err().to_string();
    assert!(e.contains("typical time step is 0.13 s"), "{e}");
    // Regression (review): rates whose millisecond steps differ by more than 1 % (0.083 and
    // 0.084 s at 12 Hz) were refused as irregular.
    for rate in [12.0, 16.0, 24.0] {
        let stamped: Vec<f64> = (0..3000).map(|i| ms(100.0 + i as f64 / rate)).collect();
        assert_eq!(record_rate(&stamped, 2.0).unwrap(), rate, "{rate} Hz");
    }
}

/// Regression (review): eval took a record at 8.004 Hz (within 1e-3 of 8 Hz) while replay
/// refused it (within 1e-5 only), and the producer's `--input` took anything within 1 %. Eval
/// and replay now take and refuse the same rates, at the shared tolerance.
#[test]
fn eval_and_replay_take_and_refuse_the_same_record_rates() {
    use crate::engine::replay::record_rate;
    use shipcast_series::{decimation_factor, sample_rate, RATE_TOLERANCE};
    for (rate, taken) in [
        (8.0, true),
        (8.004, true),
        (7.9965, true),
        (8.0 * (1.0 + 0.9 * RATE_TOLERANCE), true),
        (8.0 * (1.0 + 1.5 * RATE_TOLERANCE), false),
        (8.02, false),
        (7.9, false),
    ] {
        let time: Vec<f64> = (0..4000).map(|i| 50.0 + i as f64 / rate).collect();
        let eval = sample_rate(&time).and_then(|r| decimation_factor(r, 2.0));
        let replay = record_rate(&time, 2.0);
        assert_eq!(eval.is_ok(), taken, "eval at {rate} Hz: {eval:?}");
        assert_eq!(replay.is_ok(), taken, "replay at {rate} Hz: {replay:?}");
        if taken {
            assert_eq!((eval.unwrap(), replay.unwrap()), (4, 8.0), "{rate} Hz");
        }
    }
}

/// Regression (review): a 24 Hz record 0.05 % off its rate was taken (within the shared
/// tolerance) but none of its forecasts was scored, their far steps drifting beyond the quarter
/// step that scoring matched samples within.
#[test]
fn a_record_taken_within_the_rate_tolerance_is_scored_at_every_lead() {
    let rate = 24.0 * 1.0005;
    let heave: Vec<f64> = (0..(rate * 1200.0) as usize)
        .map(|i| (std::f64::consts::TAU * i as f64 / rate / 9.0).sin())
        .collect();
    let d = run(&record(heave, rate), 600.0);
    // Forecasts issued over the last ten minutes less a horizon, two a second.
    assert!(d.scored > 2 * 500, "{}", d.scored);
    assert!(d.rms.iter().all(|r| r.is_finite()), "{:?}", d.rms);
}

/// Regression (review): the 6 slots of a 0.75 s dropout at 8 Hz, bridged, completed two
/// decimated values in one push, and the engine counted one: the forecast after the gap was
/// stamped half a step off the grid (1800.25 s) and every forecast after it was verified
/// against the value half a step before its own. The bridge was also held flat.
#[test]
fn a_short_dropout_keeps_the_forecasts_on_their_grid() {
    let rate = 8.0;
    let heave = paper_sea_heave(rate, 1800.0);
    let clean = record(heave, rate);
    let mut dropped = clean.clone();
    let at = (rate * 900.0) as usize;
    dropped.time.drain(at..at + 6);
    dropped.columns[0].values.drain(at..at + 6);
    let config = PredictorServiceConfig::default();
    let (a, _) = replay(&clean, &config, None, 60.0, false, &|_| {}).unwrap();
    let (b, forecasts) = replay(&dropped, &config, None, 60.0, true, &|_| {}).unwrap();
    assert_eq!(b.input.lost, 6);
    assert_eq!(b.history_restarts, 0);
    let delay = b.delay_s;
    for f in &forecasts {
        let slots = (f.time_s + delay) * 2.0;
        assert!(
            (slots - slots.round()).abs() < 1e-6,
            "off the grid: {}",
            f.time_s
        );
    }
    // The value the gap's slots completed is one forecast fewer, not a shifted record.
    assert_eq!(forecasts.len() + 1, a.counts.forecasts as usize);
    // Verified against their own values, the forecasts half a second ahead stay as good as
    // without the dropout (verified half a step off, they were several times worse).
    let (x, y) = (a.dofs[0].rms[0], b.dofs[0].rms[0]);
    assert!(y < 1.5 * x, "0.5 s RMS {y} against {x} without the dropout");
}

/// Regression (review): a run of non-finite samples was held flat at the last good value as it
/// came, which put a step into the models' input; the models fitted on the noise-free paper
/// sea amplify such a step many times over, as they did a dropout held flat. The run is now
/// bridged like a dropout, by a straight line once the next good sample arrives.
#[test]
fn a_short_run_of_non_finite_samples_is_bridged_like_a_dropout() {
    let rate = 8.0;
    let heave = paper_sea_heave(rate, 1800.0);
    let at = (rate * 900.0) as usize;
    let mut dropped = record(heave.clone(), rate);
    dropped.time.drain(at..at + 6);
    dropped.columns[0].values.drain(at..at + 6);
    let mut nan = record(heave, rate);
    nan.columns[0].values[at..at + 6].fill(f64::NAN);
    let config = PredictorServiceConfig::default();
    let (a, a_forecasts) = replay(&dropped, &config, None, 60.0, true, &|_| {}).unwrap();
    let (b, b_forecasts) = replay(&nan, &config, None, 60.0, true, &|_| {}).unwrap();
    assert_eq!((a.input.lost, b.input.rejected_nonfinite), (6, 6));
    assert_eq!(b.history_restarts, 0);
    // The same values reach the models either way, so the same forecasts come out.
    assert_eq!(a_forecasts.len(), b_forecasts.len());
    for (x, y) in a_forecasts.iter().zip(&b_forecasts) {
        assert_eq!(x.time_s.to_bits(), y.time_s.to_bits());
        assert_eq!(x.mean[2][..], y.mean[2][..], "at {}", x.time_s);
    }
    assert_eq!(a.dofs[0].max_abs_z.to_bits(), b.dofs[0].max_abs_z.to_bits());
    // Scored at the steps with a finite value only.
    assert!(
        b.dofs[0].rms.iter().all(|r| r.is_finite()),
        "{:?}",
        b.dofs[0].rms
    );
}

/// The first `seconds` of the default simulator's heave at `rate` Hz.
fn paper_sea_heave(rate: f64, seconds: f64) -> Vec<f64> {
    let motion = shipcast_sim::ShipMotion::new(&shipcast_sim::SimConfig::default()).unwrap();
    motion
        .stream(rate, 0.0)
        .unwrap()
        .take((seconds * rate) as usize)
        .map(|p| p.dof[2])
        .collect()
}
