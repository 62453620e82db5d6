//! Range checks of numeric command-line values and configuration keys.
//!
//! Every numeric value from outside goes through one of these before any work starts, so a bad
//! value is a one-line error naming it instead of a panic (`Duration::from_secs_f64` of a huge
//! number, `Vec::with_capacity` of a huge count, `CPU_SET` past its set) or a run that never
//! ends. The upper bounds are far beyond any real use and only keep the arithmetic finite.

use std::time::Duration;

/// Longest wall-clock or record time any command accepts [s]: one year.
pub const MAX_SECONDS: f64 = 365.0 * 86_400.0;

/// Largest record time stamp a command takes as a time in the record (`--skip-s`) [s]: a
/// record may be stamped in Unix epoch seconds (1.7e9 today), so this is far beyond a year.
pub const MAX_RECORD_TIME_S: f64 = shipcast_series::motion_csv::MAX_ABS_TIME_S;

/// Highest sample, send or forecast rate any command accepts [Hz].
pub const MAX_RATE_HZ: f64 = 100_000.0;

/// Lowest sample, send or forecast rate any command accepts [Hz]: one sample in 100 s.
pub const MIN_RATE_HZ: f64 = 0.01;

/// Most hidden units and Rprop epochs of the MLP (`eval` and `[predictor.mlp]`).
pub const MAX_HIDDEN: usize = 10_000;
pub const MAX_EPOCHS: usize = 1_000_000;

/// Largest LMS step size and relative ridge accepted (far beyond any stable value).
pub const MAX_GAIN: f64 = shipcast_predict::ar_lms::MAX_GAIN;
pub const MAX_RIDGE: f64 = 1e6;

/// Highest core id that `sched_setaffinity`'s fixed-size set can hold, plus one.
pub const MAX_CORES: usize = libc::CPU_SETSIZE as usize;

/// `v` as a message shows it: in exponent form when plain digits would be long (`1e300`, not
/// 301 digits), so a refused value keeps the message on one short line. The one rule of every
/// crate (`shipcast_wire::shown::number`): this one's own, by the length of the digits, wrote
/// a delay of a third of a second as `3.333333333333333e-1` (review).
pub fn shown(v: f64) -> String {
    shipcast_wire::shown::number(v)
}

/// `v` must be finite and in `(0, max]`.
pub fn positive(name: &str, v: f64, max: f64) -> Result<f64, String> {
    if v.is_finite() && v > 0.0 && v <= max {
        Ok(v)
    } else {
        Err(format!(
            "{name} must be a number in (0, {max}], got {}",
            shown(v)
        ))
    }
}

/// `v` must be in `[0, 1)`: a fraction that must leave something (the MCA's energy
/// threshold: at 1 no direction is left as the minor space).
pub fn fraction_below_one(name: &str, v: f64) -> Result<f64, String> {
    if (0.0..1.0).contains(&v) {
        Ok(v)
    } else {
        Err(format!(
            "{name} must be a number in [0, 1), got {}",
            shown(v)
        ))
    }
}

/// `v` must be finite and in `[min, max]`.
pub fn in_range(name: &str, v: f64, min: f64, max: f64) -> Result<f64, String> {
    if v.is_finite() && (min..=max).contains(&v) {
        Ok(v)
    } else {
        Err(format!(
            "{name} must be a number in [{min}, {max}], got {}",
            shown(v)
        ))
    }
}

/// A sample rate [Hz] in `[MIN_RATE_HZ, max]`: below, a period overflows the clock types.
pub fn rate(name: &str, v: f64, max: f64) -> Result<f64, String> {
    in_range(name, v, MIN_RATE_HZ, max)
}

/// `v` must be finite and in `[0, max]`.
pub fn non_negative(name: &str, v: f64, max: f64) -> Result<f64, String> {
    if v.is_finite() && (0.0..=max).contains(&v) {
        Ok(v)
    } else {
        Err(format!(
            "{name} must be a number in [0, {max}], got {}",
            shown(v)
        ))
    }
}

/// A count in `min..=max`.
pub fn count<T>(name: &str, n: T, min: T, max: T) -> Result<T, String>
where
    T: PartialOrd + std::fmt::Display + Copy,
{
    if n >= min && n <= max {
        Ok(n)
    } else {
        Err(format!("{name} must be {min}..={max}, got {n}"))
    }
}

/// A positive number of seconds (at most [`MAX_SECONDS`]) as a `Duration`.
pub fn seconds(name: &str, s: f64) -> Result<Duration, String> {
    positive(name, s, MAX_SECONDS).map(Duration::from_secs_f64)
}

/// A non-negative number of seconds (at most [`MAX_SECONDS`]) as a `Duration`.
pub fn seconds_or_zero(name: &str, s: f64) -> Result<Duration, String> {
    non_negative(name, s, MAX_SECONDS).map(Duration::from_secs_f64)
}

/// A core id that a CPU set can hold.
pub fn core(name: &str, core: usize) -> Result<usize, String> {
    if core < MAX_CORES {
        Ok(core)
    } else {
        Err(format!(
            "{name} {core} is not a core id (at most {})",
            MAX_CORES - 1
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounds_are_inclusive_where_stated_and_reject_non_finite() {
        assert_eq!(positive("--rate", 8.0, 10.0), Ok(8.0));
        assert_eq!(positive("--rate", 10.0, 10.0), Ok(10.0));
        for v in [0.0, -1.0, 10.5, f64::NAN, f64::INFINITY] {
            let e = positive("--rate", v, 10.0).unwrap_err();
            assert!(e.starts_with("--rate must be"), "{e}");
        }
        assert_eq!(rate("--rate", MIN_RATE_HZ, 8.0), Ok(MIN_RATE_HZ));
        assert!(rate("--rate", 1e-300, 8.0).is_err());
        assert!(in_range("--x", 0.5, 1.0, 2.0).is_err());
        assert_eq!(non_negative("--s", 0.0, 1.0), Ok(0.0));
        assert!(non_negative("--s", -0.1, 1.0).is_err());
        assert!(non_negative("--s", f64::NAN, 1.0).is_err());
        assert_eq!(count("--n", 1u64, 1, 5), Ok(1));
        assert_eq!(count("--n", 5u64, 1, 5), Ok(5));
        assert_eq!(
            count("--n", 0u64, 1, 5).unwrap_err(),
            "--n must be 1..=5, got 0"
        );
        assert!(count("--n", 6u64, 1, 5).is_err());
    }

    #[test]
    fn refused_values_are_shown_short() {
        assert_eq!(
            positive("--rate", 1e300, 10.0).unwrap_err(),
            "--rate must be a number in (0, 10], got 1e300"
        );
        assert_eq!(
            rate("--rate", 1e-300, 8.0).unwrap_err(),
            format!("--rate must be a number in [{MIN_RATE_HZ}, 8], got 1e-300")
        );
        assert_eq!(
            non_negative("--s", -2.5, 1.0).unwrap_err(),
            "--s must be a number in [0, 1], got -2.5"
        );
        assert_eq!(
            non_negative("--s", f64::NAN, 1.0).unwrap_err(),
            "--s must be a number in [0, 1], got NaN"
        );
    }

    #[test]
    fn durations_convert_or_refuse_without_panicking() {
        assert_eq!(seconds("--duration", 1.5), Ok(Duration::from_millis(1500)));
        assert!(seconds("--duration", 0.0).is_err());
        // Duration::from_secs_f64 panics on these; the check refuses them first.
        assert!(seconds("--duration", 1e300).is_err());
        assert!(seconds_or_zero("--wait", f64::MAX).is_err());
        assert_eq!(seconds_or_zero("--wait", 0.0), Ok(Duration::ZERO));
    }

    #[test]
    fn cores_beyond_the_cpu_set_are_refused() {
        assert_eq!(core("--cores", 0), Ok(0));
        assert_eq!(core("--cores", MAX_CORES - 1), Ok(MAX_CORES - 1));
        let e = core("--cores", MAX_CORES).unwrap_err();
        assert!(e.contains("not a core id"), "{e}");
    }
}
