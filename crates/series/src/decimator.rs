//! Streaming decimation with the anti-alias filter of [`super::fir::design_lowpass`].

use super::fir::FilterPhase;
use super::ResampleError;

/// Largest decimation factor accepted (the filter has `4 * factor + 1` taps).
pub const MAX_FACTOR: usize = 1 << 16;

/// Filters and decimates one series sample by sample; the live counterpart of [`decimate`].
///
/// Push every input sample; every `factor`-th push returns the filtered output. The first output
/// comes at the push that fills the filter (`4 * factor + 1` samples), so no output is computed
/// from a partly filled history: outputs are the same whatever came before the record started.
/// Output `j` is computed from inputs `j * factor ..= j * factor + 4 * factor` and represents the
/// band-limited motion at input `j * factor + 2 * factor` (the filter's delay, [`Self::delay_samples`]
/// before the newest input): label it with that input's time.
///
/// `push` does not allocate. A non-finite input spoils only the outputs whose window holds it
/// (at most `4 + 1/factor` outputs), because the filter has no feedback.
#[derive(Clone, Debug)]
pub struct Decimator {
    /// Filter taps in time order of the inputs they weigh (oldest first).
    weights: Vec<f64>,
    /// The last `weights.len()` inputs, stored twice so that the window is always contiguous.
    ring: Vec<f64>,
    /// Where the next input goes in the first half of `ring`.
    pos: usize,
    /// Pushes left until the next output.
    until_output: usize,
    factor: usize,
    delay: usize,
}

impl Decimator {
    /// A decimator by `factor` with the evaluation protocol's linear-phase filter (1 passes
    /// every sample through unchanged).
    pub fn new(factor: usize) -> Result<Self, ResampleError> {
        Self::with_phase(factor, FilterPhase::Linear)
    }

    /// A decimator by `factor` with the filter of the given phase response.
    pub fn with_phase(factor: usize, phase: FilterPhase) -> Result<Self, ResampleError> {
        if factor == 0 {
            return Err(ResampleError::ZeroFactor);
        }
        if factor > MAX_FACTOR {
            return Err(ResampleError::FactorTooLarge(factor));
        }
        let mut weights = phase.taps(factor);
        weights.reverse();
        let len = weights.len();
        Ok(Self {
            weights,
            ring: vec![0.0; 2 * len],
            pos: 0,
            until_output: len,
            factor,
            delay: phase.delay_samples(factor),
        })
    }

    /// Push one input sample; returns the next output every `factor`-th sample once the filter
    /// is full.
    #[inline]
    pub fn push(&mut self, x: f64) -> Option<f64> {
        let len = self.weights.len();
        self.ring[self.pos] = x;
        self.ring[self.pos + len] = x;
        self.pos = if self.pos + 1 == len { 0 } else { self.pos + 1 };
        self.until_output -= 1;
        if self.until_output > 0 {
            return None;
        }
        self.until_output = self.factor;
        // After the write, ring[pos .. pos + len] holds the last `len` inputs, oldest first.
        let window = &self.ring[self.pos..self.pos + len];
        Some(window.iter().zip(&self.weights).map(|(x, w)| x * w).sum())
    }

    /// The input the last output is labelled with: the one `delay_samples` pushes before the
    /// newest (0 before any push). The output differs from it by what the filter removes and,
    /// for the minimum-phase filter, by its phase error (its group delay is not a whole
    /// number of samples): what a forecast of the outputs misses of the motion itself.
    pub fn input_at_delay(&self) -> f64 {
        let len = self.weights.len();
        // After a push, ring[pos .. pos + len] holds the last `len` inputs, oldest first.
        self.ring[self.pos + len - 1 - self.delay.min(len - 1)]
    }

    /// Forget every input, as if newly built.
    pub fn reset(&mut self) {
        self.ring.fill(0.0);
        self.pos = 0;
        self.until_output = self.weights.len();
    }

    /// Decimation factor.
    pub fn factor(&self) -> usize {
        self.factor
    }

    /// Number of filter taps (inputs needed before the first output).
    pub fn taps(&self) -> usize {
        self.weights.len()
    }

    /// Delay of an output behind the newest input it used, in input samples.
    pub fn delay_samples(&self) -> usize {
        self.delay
    }

    /// Delay in seconds at `input_rate` Hz.
    pub fn delay_s(&self, input_rate: f64) -> f64 {
        self.delay_samples() as f64 / input_rate
    }
}

/// Decimate a whole series with the filter of `phase`: exactly [`Decimator::with_phase`] run over
/// `series`, collecting its outputs.
pub fn decimate_with(
    series: &[f64],
    factor: usize,
    phase: FilterPhase,
) -> Result<Vec<f64>, ResampleError> {
    let mut decimator = Decimator::with_phase(factor, phase)?;
    Ok(series.iter().filter_map(|&x| decimator.push(x)).collect())
}

/// How many values [`decimate`] (or [`decimate_with`]) makes of `inputs` values: all of them
/// at factor 1; otherwise one per `factor` once the filter's `4 * factor + 1` taps are filled.
pub fn decimated_len(inputs: usize, factor: usize) -> usize {
    match factor {
        0 => 0,
        1 => inputs,
        f => match inputs.checked_sub(4 * f + 1) {
            Some(rest) => rest / f + 1,
            None => 0,
        },
    }
}

/// The fewest inputs from which [`decimated_len`] makes `values` values (at least one): the
/// filter's taps for the first, then `factor` more for each further one.
pub fn decimation_inputs_for(values: usize, factor: usize) -> usize {
    match factor {
        0 | 1 => values,
        f => (values.max(1) - 1) * f + 4 * f + 1,
    }
}

/// Decimate a whole series: exactly [`Decimator`] run over `series`, collecting its outputs.
/// Output `j` belongs to input index `j * factor + 2 * factor` (see [`Decimator`]).
pub fn decimate(series: &[f64], factor: usize) -> Result<Vec<f64>, ResampleError> {
    let mut decimator = Decimator::new(factor)?;
    let mut out = Vec::with_capacity(series.len() / factor + 1);
    out.extend(series.iter().filter_map(|&x| decimator.push(x)));
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fir::design_lowpass;
    use std::f64::consts::PI;

    #[test]
    fn the_input_at_the_delay_is_the_one_the_output_is_labelled_with() {
        for phase in [FilterPhase::Linear, FilterPhase::Minimum] {
            for factor in [1, 2, 4] {
                let mut d = Decimator::with_phase(factor, phase).unwrap();
                let delay = d.delay_samples();
                // Input i is i: the input labelled with is the newest less the delay.
                for i in 0..100i64 {
                    if d.push(i as f64).is_some() {
                        assert_eq!(d.input_at_delay(), (i - delay as i64) as f64);
                    }
                }
            }
        }
        // Factor 1 passes every sample: the input is the output.
        let mut d = Decimator::new(1).unwrap();
        assert_eq!(d.push(3.5), Some(3.5));
        assert_eq!(d.input_at_delay(), 3.5);
    }

    fn sine(freq: f64, rate: f64, n: usize) -> Vec<f64> {
        (0..n)
            .map(|i| (2.0 * PI * freq * i as f64 / rate + 0.3).sin())
            .collect()
    }

    #[test]
    fn batch_equals_streaming_in_any_chunking() {
        let x: Vec<f64> = (0..1000)
            .map(|i| (i as f64 * 0.37).sin() + 0.2 * (i as f64 * 2.9).cos())
            .collect();
        for factor in [1, 2, 3, 4] {
            let batch = decimate(&x, factor).unwrap();
            let taps = 4 * factor + 1;
            let expected = if factor == 1 {
                x.len()
            } else {
                (x.len() - taps) / factor + 1
            };
            assert_eq!(batch.len(), expected, "factor {factor}");
            for values in [1, 2, 3, 200] {
                let inputs = decimation_inputs_for(values, factor);
                assert_eq!(decimated_len(inputs, factor), values, "factor {factor}");
                assert_eq!(
                    decimated_len(inputs - 1, factor),
                    values - 1,
                    "factor {factor}"
                );
            }
            for n in [0, 4 * factor, 4 * factor + 1, 4 * factor + 2, 999, 1000] {
                assert_eq!(
                    decimated_len(n, factor),
                    decimate(&x[..n], factor).unwrap().len(),
                    "{n} values at factor {factor}"
                );
            }
            let mut d = Decimator::new(factor).unwrap();
            // Run twice: reset must restore the fresh state.
            for _ in 0..2 {
                let streamed: Vec<f64> = x.iter().filter_map(|&v| d.push(v)).collect();
                assert_eq!(streamed, batch);
                d.reset();
            }
        }
        assert!(matches!(Decimator::new(0), Err(ResampleError::ZeroFactor)));
        assert!(Decimator::new(MAX_FACTOR).is_ok());
        assert!(matches!(
            Decimator::new(MAX_FACTOR + 1),
            Err(ResampleError::FactorTooLarge(_))
        ));
    }

    #[test]
    fn outputs_are_the_filter_at_the_documented_inputs() {
        let x: Vec<f64> = (0..200).map(|i| ((i * 7919) % 101) as f64 - 50.0).collect();
        let factor = 4;
        let taps = design_lowpass(factor);
        let out = decimate(&x, factor).unwrap();
        for (j, y) in out.iter().enumerate() {
            let newest = j * factor + 4 * factor;
            let direct: f64 = (0..taps.len()).map(|k| taps[k] * x[newest - k]).sum();
            assert!((y - direct).abs() < 1e-9, "output {j}");
        }
    }

    #[test]
    fn passes_ship_motion_with_its_delay_and_blocks_what_would_alias() {
        let rate = 8.0;
        let factor = 4;
        // 0.1 Hz: comes through, delayed by exactly 2 * factor input samples.
        let x = sine(0.1, rate, 4000);
        let y = decimate(&x, factor).unwrap();
        let delay = Decimator::new(factor).unwrap().delay_samples();
        assert_eq!(delay, 8);
        for (j, v) in y.iter().enumerate() {
            let represents = j * factor + delay;
            assert!(
                (v - x[represents]).abs() < 0.004,
                "output {j}: {v} vs {}",
                x[represents]
            );
        }
        // 1.9 Hz would fold onto 0.1 Hz at 2 Hz output: attenuated by more than 45 dB.
        let alias = decimate(&sine(1.9, rate, 4000), factor).unwrap();
        let peak = alias.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(peak < 10f64.powf(-45.0 / 20.0), "aliased peak {peak}");
    }

    #[test]
    fn a_bad_sample_spoils_only_the_outputs_that_see_it() {
        let mut x = sine(0.05, 8.0, 400);
        x[100] = f64::NAN;
        let y = decimate(&x, 4).unwrap();
        let spoiled: Vec<usize> = (0..y.len()).filter(|&j| !y[j].is_finite()).collect();
        // Output j uses inputs 4j ..= 4j + 16.
        let expected: Vec<usize> = (0..y.len())
            .filter(|&j| 4 * j <= 100 && 100 <= 4 * j + 16)
            .collect();
        assert_eq!(spoiled, expected);
    }
}
