//! The forecast step shared by the linear predictors (MCA, Wiener): one dense `rows x cols`
//! matrix, row-major, applied to the most recent `cols` values.
//!
//! `apply` uses faer's matrix-vector product, which picks the widest SIMD instructions of the
//! CPU at run time; the portable plain loop `apply_loop` is kept because the benchmark
//! (`benches/predict.rs`) compares the two (MCA-800 on an AVX-512 VM: faer 4.4 us, loop 5.4 us
//! per 50-step forecast). An f32 copy of the matrix halves the memory traffic for callers that
//! accept single-precision arithmetic.

use faer::linalg::matmul::matmul;
use faer::{Accum, ColMut, ColRef, MatRef, Par};
use serde::{Deserialize, Serialize};
use std::ops::{Add, Mul};

/// A dense row-major matrix with preallocated scratch space, so applying it never allocates.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(try_from = "LinearMapData", into = "LinearMapData")]
pub struct LinearMap {
    rows: usize,
    cols: usize,
    coef: Vec<f64>,
    coef_f32: Vec<f32>,
    x_f32: Vec<f32>,
    out_f32: Vec<f32>,
}

/// What is stored in a model file: the f64 matrix only; the f32 copy and the scratch buffer
/// are rebuilt on load.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct LinearMapData {
    rows: usize,
    cols: usize,
    coef: Vec<f64>,
}

impl TryFrom<LinearMapData> for LinearMap {
    type Error = String;
    fn try_from(data: LinearMapData) -> Result<Self, Self::Error> {
        LinearMap::from_row_major(data.rows, data.cols, data.coef)
    }
}

impl From<LinearMap> for LinearMapData {
    fn from(map: LinearMap) -> Self {
        LinearMapData {
            rows: map.rows,
            cols: map.cols,
            coef: map.coef,
        }
    }
}

impl LinearMap {
    /// Wrap a row-major `rows x cols` matrix. Fails if the length does not match or a value is
    /// not finite (a model file may have been edited by hand).
    pub fn from_row_major(rows: usize, cols: usize, coef: Vec<f64>) -> Result<Self, String> {
        if rows.checked_mul(cols) != Some(coef.len()) {
            return Err(format!(
                "matrix of {rows} x {cols} needs {} coefficients, got {}",
                rows.saturating_mul(cols),
                coef.len()
            ));
        }
        if let Some(i) = coef.iter().position(|c| !c.is_finite()) {
            return Err(format!(
                "matrix coefficient {i} (row {}, column {}) is not finite",
                i / cols.max(1),
                i % cols.max(1)
            ));
        }
        let coef_f32 = coef.iter().map(|&c| c as f32).collect();
        Ok(Self {
            rows,
            cols,
            coef,
            coef_f32,
            x_f32: vec![0.0; cols],
            out_f32: vec![0.0; rows],
        })
    }

    /// Number of outputs.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Number of inputs.
    pub fn cols(&self) -> usize {
        self.cols
    }

    /// The matrix, row-major.
    pub fn coefficients(&self) -> &[f64] {
        &self.coef
    }

    /// Row `r` of the matrix.
    pub fn row(&self, r: usize) -> &[f64] {
        &self.coef[r * self.cols..(r + 1) * self.cols]
    }

    /// `out[..rows] = M * x[..cols]` with faer's matrix-vector product (single thread).
    /// Callers check the lengths.
    pub fn apply(&self, x: &[f64], out: &mut [f64]) {
        let m = MatRef::from_row_major_slice(&self.coef, self.rows, self.cols);
        matmul(
            ColMut::from_slice_mut(&mut out[..self.rows]),
            Accum::Replace,
            m,
            ColRef::from_slice(&x[..self.cols]),
            1.0,
            Par::Seq,
        );
    }

    /// `out[..rows] = M * x[..cols]` in f64 with a plain loop (portable, no run-time dispatch).
    pub fn apply_loop(&self, x: &[f64], out: &mut [f64]) {
        let x = &x[..self.cols];
        for (row, o) in self.coef.chunks_exact(self.cols).zip(&mut out[..self.rows]) {
            *o = dot(row, x);
        }
    }

    /// `out[..rows] = M * x[..cols]` with the f32 copy of the matrix: the input is rounded to
    /// f32 once, products are summed in f32 by faer, the result is widened back.
    pub fn apply_f32(&mut self, x: &[f64], out: &mut [f64]) {
        for (d, &s) in self.x_f32.iter_mut().zip(&x[..self.cols]) {
            *d = s as f32;
        }
        let m = MatRef::from_row_major_slice(&self.coef_f32, self.rows, self.cols);
        matmul(
            ColMut::from_slice_mut(&mut self.out_f32),
            Accum::Replace,
            m,
            ColRef::from_slice(&self.x_f32),
            1.0f32,
            Par::Seq,
        );
        for (o, &v) in out[..self.rows].iter_mut().zip(&self.out_f32) {
            *o = f64::from(v);
        }
    }
}

/// Dot product with eight independent accumulators: the compiler keeps them in vector
/// registers, which a single running sum (a serial dependency chain) would prevent.
pub(crate) fn dot<T>(a: &[T], b: &[T]) -> T
where
    T: Copy + Default + Add<Output = T> + Mul<Output = T>,
{
    const LANES: usize = 8;
    let mut acc = [T::default(); LANES];
    let chunks_a = a.chunks_exact(LANES);
    let chunks_b = b.chunks_exact(LANES);
    let (tail_a, tail_b) = (chunks_a.remainder(), chunks_b.remainder());
    for (ca, cb) in chunks_a.zip(chunks_b) {
        for i in 0..LANES {
            acc[i] = acc[i] + ca[i] * cb[i];
        }
    }
    let mut sum = T::default();
    for (&x, &y) in tail_a.iter().zip(tail_b) {
        sum = sum + x * y;
    }
    // Pairwise reduction of the lanes.
    let mut width = LANES;
    while width > 1 {
        width /= 2;
        for i in 0..width {
            acc[i] = acc[i] + acc[i + width];
        }
    }
    acc[0] + sum
}

#[cfg(test)]
mod tests {
    use super::*;

    fn example() -> LinearMap {
        // 3 x 11: enough columns to use both the vector body and the tail of `dot`.
        let coef = (0..33).map(|i| (i as f64 * 0.37).sin()).collect();
        LinearMap::from_row_major(3, 11, coef).unwrap()
    }

    #[test]
    fn all_products_agree_with_the_definition() {
        let mut m = example();
        let x: Vec<f64> = (0..11).map(|i| 1.0 - 0.1 * i as f64).collect();
        let expected: Vec<f64> = (0..3)
            .map(|r| m.row(r).iter().zip(&x).map(|(a, b)| a * b).sum())
            .collect();
        let mut out = [0.0; 3];
        m.apply(&x, &mut out);
        for (o, e) in out.iter().zip(&expected) {
            assert!((o - e).abs() < 1e-12, "{o} vs {e}");
        }
        m.apply_loop(&x, &mut out);
        for (o, e) in out.iter().zip(&expected) {
            assert!((o - e).abs() < 1e-12, "{o} vs {e}");
        }
        m.apply_f32(&x, &mut out);
        for (o, e) in out.iter().zip(&expected) {
            assert!((o - e).abs() < 1e-5, "{o} vs {e}");
        }
    }

    #[test]
    fn rejects_wrong_length_and_non_finite_coefficients() {
        let err = LinearMap::from_row_major(2, 3, vec![0.0; 5]).unwrap_err();
        assert!(err.contains("needs 6 coefficients, got 5"), "{err}");
        let err =
            LinearMap::from_row_major(2, 3, vec![0.0, 0.0, 0.0, 0.0, f64::NAN, 0.0]).unwrap_err();
        assert!(err.contains("row 1, column 1"), "{err}");
    }

    #[test]
    fn serde_round_trip_rebuilds_the_f32_copy() {
        let mut m = example();
        let json = serde_json::to_string(&m).unwrap();
        let mut back: LinearMap = serde_json::from_str(&json).unwrap();
        assert_eq!(back.coefficients(), m.coefficients());
        let x = [0.5; 11];
        let (mut a, mut b) = ([0.0; 3], [0.0; 3]);
        m.apply_f32(&x, &mut a);
        back.apply_f32(&x, &mut b);
        assert_eq!(a, b);
        let bad = r#"{"rows":2,"cols":2,"coef":[1.0]}"#;
        assert!(serde_json::from_str::<LinearMap>(bad).is_err());
    }
}
