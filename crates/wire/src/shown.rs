//! Numbers as one-line messages show them, for every crate's errors and warnings.

/// `x` in exponent form when plain digits would be long or unreadable (`1e300`, not 301
/// digits; `1e-300`, not 300 zeros), as written otherwise; NaN and infinities as Rust writes
/// them.
pub fn number(x: f64) -> String {
    if x != 0.0 && x.is_finite() && !(1e-6..1e15).contains(&x.abs()) {
        format!("{x:e}")
    } else {
        format!("{x}")
    }
}

/// `x` with `decimals` decimals, for a table's column, or "-" where it is no number (a ratio
/// over nothing: no go call, a DOF that never moves, a persistence that never errs).
pub fn fixed_or_dash(x: f64, decimals: usize) -> String {
    if x.is_finite() {
        format!("{x:.decimals$}")
    } else {
        "-".to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::{fixed_or_dash, number};

    #[test]
    fn a_table_shows_a_dash_for_what_is_no_number() {
        assert_eq!(fixed_or_dash(0.12345, 3), "0.123");
        assert_eq!(fixed_or_dash(2.0, 0), "2");
        assert_eq!(fixed_or_dash(f64::NAN, 3), "-");
        assert_eq!(fixed_or_dash(f64::NEG_INFINITY, 3), "-");
    }

    #[test]
    fn long_numbers_are_shown_in_exponent_form_and_others_as_written() {
        assert_eq!(number(1e300), "1e300");
        assert_eq!(number(-2.5e-300), "-2.5e-300");
        assert_eq!(number(1764860000.5), "1764860000.5");
        assert_eq!(number(0.125), "0.125");
        assert_eq!(number(0.0), "0");
        assert_eq!(number(f64::NAN), "NaN");
        assert_eq!(number(f64::NEG_INFINITY), "-inf");
    }
}
