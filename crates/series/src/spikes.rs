//! Samples of a record that lie far outside the motion around them: a logger's glitch, a bit
//! error, a sensor that spiked. `eval` scores forecasts against them and `train` fits on them,
//! and one 30 m sample in a heave of 0.4 m RMS shows in every fit window it lies in, so they
//! are found and named before either runs (the predictor service takes them out itself, in
//! its jump guard).
//!
//! A value is a spike when it lies more than [`SPIKE_SCALES`] robust scales from the median of
//! its minute and from that of the nearer neighbouring minute, the scale being the largest of
//! its own and the neighbouring minutes' (`median_and_scale`): one spike hardly moves its
//! minute's median and scale, a sea that grows from one minute to the next moves both, and its
//! waves stay within about 4 scales of a Gaussian sea's.

use crate::median::median_in_place;

/// How far from its minute's median [robust scales] a value is a spike.
pub const SPIKE_SCALES: f64 = 12.0;
/// The smallest scale a column is judged against: a column of rounding noise (1e-17 on 0) is
/// no motion (review: named as 120 spikes).
const MIN_SCALE: f64 = 1e-9;

/// Spikes of one column sampled `per_minute` times a minute: their count and the index of the
/// first. Non-finite values are neither counted nor used.
pub fn find_spikes(values: &[f64], per_minute: usize) -> (usize, Option<usize>) {
    let block = per_minute.max(8);
    let blocks: Vec<(f64, f64)> = values.chunks(block).map(median_and_scale).collect();
    let (mut count, mut first) = (0, None);
    for (b, chunk) in values.chunks(block).enumerate() {
        let (median, _) = blocks[b];
        let scale = blocks[b.saturating_sub(1)..(b + 2).min(blocks.len())]
            .iter()
            .map(|&(_, s)| s)
            .fold(MIN_SCALE, f64::max);
        for (i, x) in chunk.iter().enumerate() {
            // Far from its own minute's median, and from the nearer neighbour's: a step of the
            // level near a minute's end is as far from its own minute's median as a spike, but
            // not from the next minute's (review: a list change 3 samples before a minute's
            // end was named as 3 spikes).
            let neighbour = if i < chunk.len() / 2 {
                b.checked_sub(1)
            } else {
                Some(b + 1).filter(|&n| n < blocks.len())
            };
            let far = |m: f64| (x - m).abs() > SPIKE_SCALES * scale;
            if x.is_finite() && far(median) && neighbour.is_none_or(|n| far(blocks[n].0)) {
                count += 1;
                first.get_or_insert(b * block + i);
            }
        }
    }
    (count, first)
}

/// The median of the finite values of `chunk` and their robust scale about it: 1.4826 times
/// their median absolute deviation, or 1.2533 times their mean absolute deviation if more
/// (both are the standard deviation of a Gaussian sea). The mean one keeps a quantised sensor
/// in a calm sea, most of whose values are the median itself, from a scale of 0 that made
/// every step of one quantum a spike (0 and 0 if none is finite).
fn median_and_scale(chunk: &[f64]) -> (f64, f64) {
    let mut v: Vec<f64> = chunk.iter().copied().filter(|x| x.is_finite()).collect();
    let Some(centre) = median_in_place(&mut v) else {
        return (0.0, 0.0);
    };
    for x in &mut v {
        *x = (*x - centre).abs();
    }
    let mean = v.iter().sum::<f64>() / v.len() as f64;
    let mad = median_in_place(&mut v).unwrap_or(0.0);
    (centre, (1.4826 * mad).max(1.2533 * mean))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A narrow-band sea: a sum of waves of 7-12 s with a slowly varying envelope.
    fn sea(n: usize, rate: f64, amplitude: impl Fn(f64) -> f64) -> Vec<f64> {
        (0..n)
            .map(|i| {
                let t = i as f64 / rate;
                let waves = [(7.0, 0.3), (8.3, 1.1), (9.1, 2.0), (10.4, 0.7), (12.0, 4.1)]
                    .iter()
                    .map(|(period, phase)| (std::f64::consts::TAU * t / period + phase).sin())
                    .sum::<f64>();
                amplitude(t) * waves
            })
            .collect()
    }

    #[test]
    fn a_spike_is_found_and_a_sea_that_grows_is_not() {
        let rate = 8.0;
        let per_minute = 480;
        let mut x = sea(8 * 3600, rate, |_| 1.0);
        assert_eq!(find_spikes(&x, per_minute), (0, None));
        // 30 and 20 times the sea's RMS (about 1.6) at two samples; 5 times at a third is
        // within what the scan lets pass.
        x[10_000] += 48.0;
        x[20_000] -= 32.0;
        x[25_000] += 8.0;
        assert_eq!(find_spikes(&x, per_minute), (2, Some(10_000)));
        // A sea that grows tenfold within two minutes, and one that starts from rest.
        let growing = sea(8 * 3600, rate, |t| if t < 1800.0 { 0.2 } else { 2.0 });
        assert_eq!(find_spikes(&growing, per_minute), (0, None));
        let resuming = sea(8 * 3600, rate, |t| ((t - 1800.0) / 20.0).clamp(0.0, 1.0));
        assert_eq!(find_spikes(&resuming, per_minute), (0, None));
    }

    /// Regression (review): a level step just before a minute's end, and rounding noise on a
    /// column of zeros, were named as spikes.
    #[test]
    fn a_step_at_a_minutes_end_and_rounding_noise_are_no_spikes() {
        let mut x = sea(8 * 600, 8.0, |_| 0.002);
        for v in x.iter_mut().skip(8 * 60 * 3 - 3) {
            *v += 0.2;
        }
        assert_eq!(find_spikes(&x, 480), (0, None));
        let mut zeros = vec![0.0; 4800];
        for v in zeros.iter_mut().step_by(40) {
            *v = 1e-17;
        }
        assert_eq!(find_spikes(&zeros, 480), (0, None));
    }

    #[test]
    fn non_finite_values_and_short_columns_are_no_spikes() {
        let mut x = sea(200, 2.0, |_| 1.0);
        x[5] = f64::NAN;
        x[6] = f64::INFINITY;
        assert_eq!(find_spikes(&x, 120), (0, None));
        assert_eq!(find_spikes(&[], 120), (0, None));
        assert_eq!(find_spikes(&[1.0], 0), (0, None));
    }
}
