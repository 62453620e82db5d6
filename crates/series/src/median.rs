//! The median of a handful of values, sorted in place: shared by the spike scan of records, the
//! predictor's jump guard and the decision scores, which each need one without a crate for it.

/// The median of `values` (the mean of the two middle ones for an even count), sorting them in
/// place; None if there are none. NaN sorts last (`f64::total_cmp`).
pub fn median_in_place(values: &mut [f64]) -> Option<f64> {
    values.sort_by(f64::total_cmp);
    let n = values.len();
    match n {
        0 => None,
        n if n % 2 == 1 => Some(values[n / 2]),
        n => Some(0.5 * (values[n / 2 - 1] + values[n / 2])),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn odd_even_and_empty() {
        assert_eq!(median_in_place(&mut []), None);
        assert_eq!(median_in_place(&mut [3.0, 1.0, 2.0]), Some(2.0));
        assert_eq!(median_in_place(&mut [4.0, 1.0, 3.0, 2.0]), Some(2.5));
        let mut v = [5.0, -1.0];
        assert_eq!(median_in_place(&mut v), Some(2.0));
        assert_eq!(v, [-1.0, 5.0]);
    }
}
