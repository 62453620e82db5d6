//! The `mean` and `sigma` arrays of a forecast's JSON form, parsed in place: at most
//! [`NUM_DOF`] rows of at most [`MAX_STEPS`] values are kept in fixed arrays, and every row and
//! value is counted (the shape errors name the counts), with no heap allocation.
//!
//! Why: every consumer parses each received forecast (twice a second per followed vessel), and
//! rows parsed into `Vec<Vec<f32>>` grew by doubling, dozens of allocations per forecast
//! (allocation review, 2026-12-06). A forged forecast with a row of a million values also cost
//! a million values' memory before its shape was refused; here it costs none.

use crate::payload::{MAX_STEPS, NUM_DOF};
use serde::de::{DeserializeSeed, Deserializer, SeqAccess, Visitor};
use serde::Deserialize;
use std::fmt;

/// One of `mean` or `sigma` as received.
#[derive(Debug, Clone, PartialEq)]
pub struct Rows {
    /// The first `MAX_STEPS` values of each of the first `NUM_DOF` rows.
    pub values: [[f32; MAX_STEPS]; NUM_DOF],
    /// The length of each of the first `NUM_DOF` rows, values beyond `MAX_STEPS` counted.
    pub lens: [usize; NUM_DOF],
    /// Rows in the array, those beyond `NUM_DOF` counted.
    pub count: usize,
}

impl<'de> Deserialize<'de> for Rows {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        deserializer.deserialize_seq(RowsVisitor)
    }
}

struct RowsVisitor;

impl<'de> Visitor<'de> for RowsVisitor {
    type Value = Rows;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("an array of rows of numbers")
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Rows, A::Error> {
        let mut rows = Rows {
            values: [[0.0; MAX_STEPS]; NUM_DOF],
            lens: [0; NUM_DOF],
            count: 0,
        };
        loop {
            let kept = rows.values.get_mut(rows.count);
            let Some(len) = seq.next_element_seed(Row(kept))? else {
                break;
            };
            if let Some(l) = rows.lens.get_mut(rows.count) {
                *l = len;
            }
            rows.count += 1;
        }
        Ok(rows)
    }
}

/// One row: its values written into the slot (if it is one of the rows kept), its length
/// returned.
struct Row<'a>(Option<&'a mut [f32; MAX_STEPS]>);

impl<'de> DeserializeSeed<'de> for Row<'_> {
    type Value = usize;

    fn deserialize<D: Deserializer<'de>>(self, deserializer: D) -> Result<usize, D::Error> {
        deserializer.deserialize_seq(self)
    }
}

impl<'de> Visitor<'de> for Row<'_> {
    type Value = usize;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("an array of numbers")
    }

    fn visit_seq<A: SeqAccess<'de>>(mut self, mut seq: A) -> Result<usize, A::Error> {
        let mut len = 0;
        while let Some(v) = seq.next_element::<f32>()? {
            if let Some(x) = self.0.as_deref_mut().and_then(|row| row.get_mut(len)) {
                *x = v;
            }
            len += 1;
        }
        Ok(len)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(json: &str) -> Result<Rows, serde_json::Error> {
        serde_json::from_str(json)
    }

    #[test]
    fn rows_are_kept_in_place_and_counted() {
        let r = parse("[[1, 2.5], [], [3], [4], [5], [6, 7, 8]]").unwrap();
        assert_eq!(r.count, 6);
        assert_eq!(r.lens, [2, 0, 1, 1, 1, 3]);
        assert_eq!(&r.values[0][..2], &[1.0, 2.5]);
        assert_eq!(&r.values[5][..3], &[6.0, 7.0, 8.0]);
        // Values past a row's end stay zero.
        assert_eq!(r.values[0][2], 0.0);
    }

    #[test]
    fn extra_rows_and_overlong_rows_are_counted_not_kept() {
        let long: Vec<String> = (0..MAX_STEPS + 5).map(|i| i.to_string()).collect();
        let json = format!("[[{}], [], [], [], [], [], [1], [2, 3]]", long.join(","));
        let r = parse(&json).unwrap();
        assert_eq!(r.count, 8);
        assert_eq!(r.lens[0], MAX_STEPS + 5);
        assert_eq!(r.values[0][MAX_STEPS - 1], (MAX_STEPS - 1) as f32);
    }

    #[test]
    fn what_is_not_an_array_of_arrays_of_numbers_is_refused() {
        for bad in ["{}", "[1, 2]", "[[\"a\"]]", "[[1, null]]", "null"] {
            assert!(parse(bad).is_err(), "{bad} accepted");
        }
    }
}
