//! Design of the anti-alias filter used before decimation.

/// Kaiser window shape parameter. 4.0 balances pass-band flatness against stop-band depth for
/// the fixed length below (measured in the tests: pass-band error <= 0.4 %, stop band <= -45 dB).
const KAISER_BETA: f64 = 4.0;

/// Linear-phase low-pass FIR for decimation by `factor`: a Kaiser-windowed sinc with
/// `4 * factor + 1` taps, cut-off at half the output rate, taps normalised to unit DC gain.
///
/// - Delay: exactly `2 * factor` input samples = two output periods (1.0 s for 8 -> 2 Hz),
///   the same at every frequency (linear phase), so a decimated value is the band-limited motion
///   at the time `2 * factor` input samples before the newest input used.
/// - Pass band (0 .. 0.15 x output rate, i.e. 0 .. 0.3 Hz at 2 Hz output, where ship motion
///   lives): gain within 0.4 % of one.
/// - Stop band (0.85 x output rate .. input Nyquist, i.e. everything that folds back onto
///   0 .. 0.15 x output rate): attenuation of at least 45 dB (52 dB for factor 2).
///
/// The band between 0.15 and 0.85 x output rate is a transition band: it is attenuated only
/// partly and aliases onto frequencies above 0.15 x output rate, where ship motion has almost no
/// energy. Choosing that wide transition is what keeps the filter, and so its delay, short.
///
/// `factor` 1 gives the identity `[1.0]` with no delay.
pub fn design_lowpass(factor: usize) -> Vec<f64> {
    assert!(factor >= 1, "decimation factor must be at least 1");
    if factor == 1 {
        return vec![1.0];
    }
    let delay = 2 * factor;
    let cutoff = 0.5 / factor as f64; // cycles per input sample
    let norm = bessel_i0(KAISER_BETA);
    let mut taps: Vec<f64> = (0..=2 * delay)
        .map(|n| {
            let m = n as f64 - delay as f64;
            let sinc = if m == 0.0 {
                2.0 * cutoff
            } else {
                (2.0 * std::f64::consts::PI * cutoff * m).sin() / (std::f64::consts::PI * m)
            };
            let r = m / delay as f64;
            let window = bessel_i0(KAISER_BETA * (1.0 - r * r).max(0.0).sqrt()) / norm;
            sinc * window
        })
        .collect();
    let sum: f64 = taps.iter().sum();
    taps.iter_mut().for_each(|t| *t /= sum);
    taps
}

/// Delay of [`design_lowpass`] in input samples.
pub const fn delay_samples(factor: usize) -> usize {
    if factor <= 1 {
        0
    } else {
        2 * factor
    }
}

/// Magnitude of the frequency response of `taps` at `freq` cycles per sample.
pub fn magnitude(taps: &[f64], freq: f64) -> f64 {
    let w = 2.0 * std::f64::consts::PI * freq;
    let (re, im) = taps
        .iter()
        .enumerate()
        .fold((0.0, 0.0), |(re, im), (n, &h)| {
            let phase = w * n as f64;
            (re + h * phase.cos(), im - h * phase.sin())
        });
    re.hypot(im)
}

/// Phase response of the anti-alias filter.
///
/// `Linear` is the evaluation protocol's filter (docs/contracts.md section 4): a decimated value
/// is the motion exactly `2 * factor` input samples before the newest input. `Minimum` has the
/// same magnitude response with the smallest delay a causal filter of that length can have:
/// about `factor` input samples in the band where ship motion lives (0.46-0.49 s at 8 -> 2 Hz,
/// against 1.0 s), so every forecast step reaches half a second further ahead of the newest
/// sample for the same error (docs/results/filter_delay.md).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FilterPhase {
    #[default]
    Linear,
    Minimum,
}

impl FilterPhase {
    /// The filter's taps for decimation by `factor`, in time order (oldest input first is
    /// `taps.reverse()`; `taps[n]` weighs the input `n` samples before the newest).
    pub fn taps(self, factor: usize) -> Vec<f64> {
        match self {
            Self::Linear => design_lowpass(factor),
            Self::Minimum => design_lowpass_min_phase(factor),
        }
    }

    /// Delay of a decimated value behind the newest input, in input samples: exact for the
    /// linear-phase filter; for the minimum-phase one its group delay at zero frequency,
    /// rounded to a whole sample (its delay over the motion band differs by under half a
    /// sample).
    pub fn delay_samples(self, factor: usize) -> usize {
        match self {
            Self::Linear => delay_samples(factor),
            Self::Minimum => {
                let taps = design_lowpass_min_phase(factor);
                let moment: f64 = taps.iter().enumerate().map(|(n, h)| n as f64 * h).sum();
                (moment / taps.iter().sum::<f64>()).round().max(0.0) as usize
            }
        }
    }
}

/// The minimum-phase filter with the magnitude response of [`design_lowpass`] (same length),
/// by the real-cepstrum method: fold the cepstrum of log |H| onto positive quefrencies, which
/// moves every zero inside the unit circle, and exponentiate back. log |H| is floored at 1e-6 of
/// its peak because the linear-phase filter has zeros on the unit circle. Taps normalised to
/// unit DC gain; `factor` 1 gives the identity.
pub fn design_lowpass_min_phase(factor: usize) -> Vec<f64> {
    use rustfft::num_complex::Complex;
    let h = design_lowpass(factor);
    if h.len() == 1 {
        return h;
    }
    let n = (64 * h.len()).next_power_of_two().max(1024);
    let mut planner = rustfft::FftPlanner::<f64>::new();
    let (fft, ifft) = (planner.plan_fft_forward(n), planner.plan_fft_inverse(n));
    let mut buf: Vec<Complex<f64>> = (0..n)
        .map(|i| Complex::new(h.get(i).copied().unwrap_or(0.0), 0.0))
        .collect();
    fft.process(&mut buf);
    let peak = buf.iter().map(|c| c.norm()).fold(0.0, f64::max);
    for c in buf.iter_mut() {
        *c = Complex::new(c.norm().max(1e-6 * peak).ln(), 0.0);
    }
    ifft.process(&mut buf);
    let scale = 1.0 / n as f64;
    for (i, c) in buf.iter_mut().enumerate() {
        let fold = match i {
            0 => 1.0,
            i if i < n / 2 => 2.0,
            i if i == n / 2 => 1.0,
            _ => 0.0,
        };
        *c *= fold * scale;
    }
    fft.process(&mut buf);
    for c in buf.iter_mut() {
        *c = c.exp();
    }
    ifft.process(&mut buf);
    let mut taps: Vec<f64> = buf[..h.len()].iter().map(|c| c.re * scale).collect();
    let sum: f64 = taps.iter().sum();
    taps.iter_mut().for_each(|t| *t /= sum);
    taps
}

/// Modified Bessel function of the first kind, order zero, by its power series (converges
/// quickly for the small arguments a Kaiser window uses).
fn bessel_i0(x: f64) -> f64 {
    let mut sum = 1.0;
    let mut term = 1.0;
    let half = x / 2.0;
    for k in 1..100 {
        term *= (half / k as f64).powi(2);
        sum += term;
        if term < 1e-17 * sum {
            break;
        }
    }
    sum
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Largest |H(f) - 1| over the pass band and largest |H(f)| over the stop band, on a fine grid.
    fn measure(factor: usize) -> (f64, f64) {
        let taps = design_lowpass(factor);
        let out_rate = 1.0 / factor as f64;
        let grid = (0..=4000).map(|i| 0.5 * i as f64 / 4000.0);
        let (mut pass, mut stop) = (0.0f64, 0.0f64);
        for f in grid {
            let h = magnitude(&taps, f);
            if f <= 0.15 * out_rate {
                pass = pass.max((h - 1.0).abs());
            }
            if f >= 0.85 * out_rate {
                stop = stop.max(h);
            }
        }
        (pass, stop)
    }

    #[test]
    fn lowpass_meets_its_documented_response() {
        for factor in [2, 3, 4, 8, 16] {
            let taps = design_lowpass(factor);
            assert_eq!(taps.len(), 2 * delay_samples(factor) + 1);
            assert!((taps.iter().sum::<f64>() - 1.0).abs() < 1e-12);
            // Linear phase: symmetric taps.
            for (a, b) in taps.iter().zip(taps.iter().rev()) {
                assert!((a - b).abs() < 1e-15);
            }
            let (pass, stop) = measure(factor);
            assert!(pass <= 0.004, "factor {factor}: pass-band error {pass}");
            let stop_db = 20.0 * stop.log10();
            assert!(stop_db <= -45.0, "factor {factor}: stop band {stop_db} dB");
        }
        assert_eq!(design_lowpass(1), vec![1.0]);
        assert_eq!(delay_samples(1), 0);
    }

    #[test]
    fn minimum_phase_filter_keeps_the_magnitude_and_halves_the_delay() {
        for factor in [2, 4, 8] {
            let lin = design_lowpass(factor);
            let min = design_lowpass_min_phase(factor);
            assert_eq!(min.len(), lin.len());
            assert!((min.iter().sum::<f64>() - 1.0).abs() < 1e-12);
            // Same magnitude (the truncation to the original length costs a little).
            for i in 0..=400 {
                let f = 0.5 * i as f64 / 400.0;
                let (a, b) = (magnitude(&lin, f), magnitude(&min, f));
                assert!((a - b).abs() < 2e-3, "factor {factor} f {f}: {a} vs {b}");
            }
            // Energy first: the delay at DC is about half the linear-phase filter's.
            let delay = FilterPhase::Minimum.delay_samples(factor);
            assert!(
                delay >= factor / 2 && delay <= factor + 1,
                "factor {factor}: {delay}"
            );
            assert!(delay < delay_samples(factor));
        }
        assert_eq!(design_lowpass_min_phase(1), vec![1.0]);
        assert_eq!(FilterPhase::Minimum.delay_samples(1), 0);
    }

    #[test]
    fn bessel_i0_matches_known_values() {
        assert_eq!(bessel_i0(0.0), 1.0);
        // I0(1) and I0(4) from tables.
        assert!((bessel_i0(1.0) - 1.266_065_877_752_008).abs() < 1e-14);
        assert!((bessel_i0(4.0) - 11.301_921_952_136_33).abs() < 1e-12);
    }
}
