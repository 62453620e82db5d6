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

#[cfg(test)]
mod tests {
    use super::number;

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
