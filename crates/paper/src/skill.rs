//! Summaries of an error curve (RMS per step): where it crosses a level, and its size over the
//! whole horizon.

/// Lead time [s] at which `rms` (step h at `h * dt_s`) first reaches `level`, interpolating
/// linearly between steps and from an error of 0 at lead 0. `None` if it never does within the
/// horizon.
pub fn crossing_time(rms: &[f64], level: f64, dt_s: f64) -> Option<f64> {
    let mut prev = 0.0;
    for (i, &v) in rms.iter().enumerate() {
        if v >= level {
            let frac = if v > prev {
                (level - prev) / (v - prev)
            } else {
                1.0
            };
            return Some((i as f64 + frac.clamp(0.0, 1.0)) * dt_s);
        }
        prev = v;
    }
    None
}

/// RMS over all steps: sqrt(mean over h of rms_h^2), one number for a whole forecast.
pub fn overall(rms: &[f64]) -> f64 {
    if rms.is_empty() {
        return f64::NAN;
    }
    (rms.iter().map(|v| v * v).sum::<f64>() / rms.len() as f64).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crossing_interpolates_between_steps() {
        let rms = [0.2, 0.4, 0.8, 1.0];
        // 0.6 lies half way between step 2 (0.4) and step 3 (0.8): lead 2.5 steps.
        assert_eq!(crossing_time(&rms, 0.6, 0.5), Some(1.25));
        // Crossing before the first step interpolates from zero error at lead 0.
        assert_eq!(crossing_time(&rms, 0.1, 0.5), Some(0.25));
        assert_eq!(crossing_time(&rms, 0.8, 1.0), Some(3.0));
        assert_eq!(crossing_time(&rms, 1.5, 0.5), None);
        assert_eq!(crossing_time(&[], 1.0, 0.5), None);
    }

    #[test]
    fn overall_is_the_root_mean_square_of_the_steps() {
        assert!((overall(&[3.0, 4.0]) - (12.5f64).sqrt()).abs() < 1e-15);
        assert!(overall(&[]).is_nan());
    }
}
