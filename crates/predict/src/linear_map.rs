//! The forecast step shared by the linear predictors (MCA, Wiener): one dense `rows x cols`
//! matrix, row-major, applied to the most recent `cols` values.
//!
//! `apply` uses faer's matrix-vector product, which picks the widest SIMD instructions of the
//! CPU at run time; the portable plain loop `apply_loop` is kept because the benchmark
//! (`benches/predict.rs`) compares the two (MCA-800 on an AVX-512 VM: faer 4.4 us, loop 5.4 us
//! per 50-step forecast). An f32 copy of the matrix halves the memory traffic for callers that
//! accept single-precision arithmetic (`apply_f32`).
//!
//! Forecasts go through `apply_prepared`, which splits the product in two: the columns of all
//! but the newest input, which `prepare` may compute ahead of time from values already known,
//! and the newest input's column, added when that value arrives. A service that prepares right
//! after publishing a forecast then has 50 multiply-adds to do when the next value arrives
//! instead of the whole product. Both parts always run on the same internal buffers, so the
//! result is the same bit for bit whether or not `prepare` ran.
//!
//! The first part reads most of the matrix (MCA-800: 50 x 749 coefficients per DOF, 1.8 MB
//! for six DOF in f64, about what the L2 cache holds), so its speed is that of the memory. Where
//! storing the coefficients in f32 provably costs nothing that matters, it reads the f32 copy
//! and multiplies and sums in f64 ([`MIXED_MAX_ROUNDING`]): half the traffic, the same
//! arithmetic.

use faer::linalg::matmul::matmul;
use faer::{Accum, ColMut, ColRef, MatRef, Par};
use serde::{Deserialize, Serialize};
use std::ops::{Add, Mul};

/// The largest sum over a row of |c - f32(c)| at which `apply_prepared` uses the f32 copy of the
/// coefficients (with f64 products and sums). A forecast is linear in its inputs, so rounding
/// the coefficients moves it by at most this times the largest input: 10 um per metre of
/// motion, against forecast errors of centimetres to metres. Well-conditioned maps (row L1
/// norms up to a few hundred) pass; the ill-conditioned ones a tiny ridge can give on a
/// clean sea (row norms of 1e6 with cancelling terms) stay in f64.
pub const MIXED_MAX_ROUNDING: f64 = 1e-5;

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
    /// Split forecasts: the inputs but the newest, as the product saw them ...
    known: Vec<f64>,
    /// ... and their part of the product.
    partial: Vec<f64>,
    /// True when `partial` was computed from `known` (by `prepare`).
    prepared: bool,
    /// `partial` is computed from `coef_f32` with f64 arithmetic (see [`MIXED_MAX_ROUNDING`]).
    mixed: bool,
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
        // Regression (review): a hand-edited 0 x 10^12 matrix matched its empty coefficients
        // and then aborted the program allocating its scratch rows of 10^12 values.
        if rows == 0 || cols == 0 {
            return Err(format!("matrix of {rows} x {cols} is empty"));
        }
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
        let coef_f32: Vec<f32> = coef.iter().map(|&c| c as f32).collect();
        let rounding = coef
            .chunks(cols.max(1))
            .zip(coef_f32.chunks(cols.max(1)))
            .map(|(row, row32)| {
                row.iter()
                    .zip(row32)
                    .map(|(&c, &c32)| (c - f64::from(c32)).abs())
                    .sum::<f64>()
            })
            .fold(0.0, f64::max);
        Ok(Self {
            rows,
            cols,
            coef,
            coef_f32,
            x_f32: vec![0.0; cols],
            out_f32: vec![0.0; rows],
            known: vec![0.0; cols.saturating_sub(1)],
            partial: vec![0.0; rows],
            prepared: false,
            mixed: rounding <= MIXED_MAX_ROUNDING && fused_multiply_add_is_fast(),
        })
    }

    /// Whether forecasts read the f32 copy of the coefficients (with f64 arithmetic).
    pub fn is_mixed(&self) -> bool {
        self.mixed
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

    /// Compute ahead the part of the next `apply_prepared` that depends on values already known:
    /// `known` ends with the newest input so far, and the next call is expected with the last
    /// `cols - 1` of them followed by one new value. Fewer than `cols - 1` known values prepare
    /// nothing. Never allocates.
    pub fn prepare(&mut self, known: &[f64]) {
        let k = self.cols.saturating_sub(1);
        let Some(start) = known.len().checked_sub(k) else {
            self.prepared = false;
            return;
        };
        self.known.copy_from_slice(&known[start..]);
        self.product_of_known();
        self.prepared = true;
    }

    /// `out[..rows] = M * x[..cols]` for forecasts: the prepared part when `prepare` saw the
    /// same first `cols - 1` inputs (compared bit for bit), else both parts now; the result is
    /// identical either way. Callers check the lengths. Never allocates.
    pub fn apply_prepared(&mut self, x: &[f64], out: &mut [f64]) {
        let k = self.cols.saturating_sub(1);
        let same = self.prepared
            && self
                .known
                .iter()
                .zip(&x[..k])
                .all(|(a, b)| a.to_bits() == b.to_bits());
        if !same {
            self.known.copy_from_slice(&x[..k]);
            self.product_of_known();
            self.prepared = true;
        }
        let newest = x[self.cols - 1];
        for (r, (o, p)) in out[..self.rows].iter_mut().zip(&self.partial).enumerate() {
            *o = p + self.coef[r * self.cols + k] * newest;
        }
    }

    /// `partial = M[.., ..cols-1] * known`, always from the same buffers, so that the product
    /// does not depend on where the caller's values happen to lie in memory.
    fn product_of_known(&mut self) {
        let k = self.cols.saturating_sub(1);
        if k == 0 {
            self.partial.fill(0.0);
            return;
        }
        if self.mixed {
            mixed_product(&self.coef_f32, self.cols, &self.known, &mut self.partial);
            return;
        }
        let m = MatRef::from_row_major_slice(&self.coef, self.rows, self.cols).subcols(0, k);
        matmul(
            ColMut::from_slice_mut(&mut self.partial),
            Accum::Replace,
            m,
            ColRef::from_slice(&self.known),
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

/// Whether [`mixed_product`] runs on hardware fused multiply-adds: a vector path on x86_64, or
/// aarch64, whose baseline has them. Elsewhere `mul_add` is a library call per product, far
/// slower than faer's f64 product, so the mixed form is not used.
fn fused_multiply_add_is_fast() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx512f")
            || (std::arch::is_x86_feature_detected!("avx2")
                && std::arch::is_x86_feature_detected!("fma"))
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        cfg!(target_arch = "aarch64")
    }
}

/// `out[r] = sum_j f64(coef[r * cols + j]) * x[j]` over the first `x.len()` columns of each
/// row of the row-major f32 `coef`. With AVX-512 or AVX2 when the CPU has them; every path does
/// the same fused multiply-adds in the same order, so all give the same bits (the portable path
/// is used in production only where `mul_add` is an instruction: aarch64).
fn mixed_product(coef: &[f32], cols: usize, x: &[f64], out: &mut [f64]) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx512f") {
        // SAFETY: the CPU supports AVX-512F, the only feature `mixed_product_avx512` is
        // compiled for; the function touches memory only through its slice arguments.
        unsafe { mixed_product_avx512(coef, cols, x, out) };
        return;
    }
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
        // SAFETY: the CPU supports AVX2 and FMA, the features `mixed_product_avx2` is compiled
        // for; the function touches memory only through its slice arguments.
        unsafe { mixed_product_avx2(coef, cols, x, out) };
        return;
    }
    mixed_product_portable(coef, cols, x, out);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn mixed_product_avx2(coef: &[f32], cols: usize, x: &[f64], out: &mut [f64]) {
    for (row, o) in coef.chunks_exact(cols).zip(out.iter_mut()) {
        *o = mixed_dot_avx2(&row[..x.len()], x);
    }
}

/// [`mixed_dot`] with 4-wide AVX2 registers: register r holds lanes 4r..4r+4 of the portable
/// version's 32 accumulators, added in the same order, and the reduction is the portable
/// one's, so the result has the same bits.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn mixed_dot_avx2(a: &[f32], b: &[f64]) -> f64 {
    use std::arch::x86_64::{
        __m256d, _mm256_cvtps_pd, _mm256_fmadd_pd, _mm256_loadu_pd, _mm256_setzero_pd,
        _mm256_storeu_pd, _mm_loadu_ps,
    };
    const LANES: usize = 32;
    let n = a.len().min(b.len());
    let mut acc: [__m256d; LANES / 4] = [_mm256_setzero_pd(); LANES / 4];
    let mut i = 0;
    while i + LANES <= n {
        for (r, acc) in acc.iter_mut().enumerate() {
            let j = i + 4 * r;
            // SAFETY: j + 4 <= i + LANES <= n, and n is at most the length of both slices:
            // the loads read four in-bounds elements of each (unaligned loads).
            let (wide, y) = unsafe {
                (
                    _mm256_cvtps_pd(_mm_loadu_ps(a.as_ptr().add(j))),
                    _mm256_loadu_pd(b.as_ptr().add(j)),
                )
            };
            *acc = _mm256_fmadd_pd(wide, y, *acc);
        }
        i += LANES;
    }
    let mut lanes = [0.0f64; LANES];
    for (r, acc) in acc.iter().enumerate() {
        // SAFETY: lanes[4r..4r + 4] is in bounds (r < LANES / 4); an unaligned store.
        unsafe { _mm256_storeu_pd(lanes.as_mut_ptr().add(4 * r), *acc) };
    }
    let mut sum = 0.0;
    for (&x, &y) in a[i..n].iter().zip(&b[i..n]) {
        sum = f64::from(x).mul_add(y, sum);
    }
    reduce_lanes(lanes) + sum
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn mixed_product_avx512(coef: &[f32], cols: usize, x: &[f64], out: &mut [f64]) {
    // Four rows at a time share each load of x and keep 16 independent sums in flight.
    let rows = out.len().min(coef.len() / cols);
    let (coef, out) = (&coef[..rows * cols], &mut out[..rows]);
    let (blocks, rest) = (
        coef.chunks_exact(4 * cols),
        coef.chunks_exact(4 * cols).remainder(),
    );
    let mut outs = out.chunks_exact_mut(4);
    for (block, o) in blocks.zip(&mut outs) {
        let n = x.len();
        let row = |r: usize| &block[r * cols..r * cols + n];
        o.copy_from_slice(&mixed_dot4_avx512([row(0), row(1), row(2), row(3)], x));
    }
    // One to three rows left: a block of four with the last one repeated (its sum is the
    // same bits in every slot).
    let n = x.len();
    let mut left = rest.chunks_exact(cols).map(|r| &r[..n]);
    if let Some(r0) = left.next() {
        let r1 = left.next().unwrap_or(r0);
        let r2 = left.next().unwrap_or(r1);
        let sums = mixed_dot4_avx512([r0, r1, r2, r2], x);
        let o = outs.into_remainder();
        let k = o.len();
        o.copy_from_slice(&sums[..k]);
    }
}

/// [`mixed_dot`] of four rows with the same x, with 8-wide AVX-512 registers: for each row,
/// register r holds lanes 8r..8r+8 of the portable version's 32 accumulators (same order, same
/// reduction, same bits).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn mixed_dot4_avx512(a: [&[f32]; 4], b: &[f64]) -> [f64; 4] {
    use std::arch::x86_64::{
        __m512d, _mm256_loadu_ps, _mm512_cvtps_pd, _mm512_fmadd_pd, _mm512_loadu_pd,
        _mm512_setzero_pd, _mm512_storeu_pd,
    };
    const LANES: usize = 32;
    let n = a.iter().map(|r| r.len()).fold(b.len(), usize::min);
    let mut acc: [[__m512d; LANES / 8]; 4] = [[_mm512_setzero_pd(); LANES / 8]; 4];
    let mut i = 0;
    while i + LANES <= n {
        for r in 0..LANES / 8 {
            let j = i + 8 * r;
            // SAFETY: j + 8 <= i + LANES <= n, at most the length of b: eight in-bounds
            // elements (an unaligned load).
            let y = unsafe { _mm512_loadu_pd(b.as_ptr().add(j)) };
            for (row, acc) in a.iter().zip(acc.iter_mut()) {
                // SAFETY: as above, n is at most the length of every row.
                let wide = unsafe { _mm512_cvtps_pd(_mm256_loadu_ps(row.as_ptr().add(j))) };
                acc[r] = _mm512_fmadd_pd(wide, y, acc[r]);
            }
        }
        i += LANES;
    }
    let mut sums = [0.0; 4];
    for ((row, acc), s) in a.iter().zip(&acc).zip(&mut sums) {
        let mut lanes = [0.0f64; LANES];
        for (r, acc) in acc.iter().enumerate() {
            // SAFETY: lanes[8r..8r + 8] is in bounds (r < LANES / 8); an unaligned store.
            unsafe { _mm512_storeu_pd(lanes.as_mut_ptr().add(8 * r), *acc) };
        }
        let mut tail = 0.0;
        for (&x, &y) in row[i..n].iter().zip(&b[i..n]) {
            tail = f64::from(x).mul_add(y, tail);
        }
        *s = reduce_lanes(lanes) + tail;
    }
    sums
}

/// Pairwise reduction of [`mixed_dot`]'s accumulators.
#[inline(always)]
fn reduce_lanes<const LANES: usize>(mut acc: [f64; LANES]) -> f64 {
    let mut width = LANES;
    while width > 1 {
        width /= 2;
        for i in 0..width {
            acc[i] += acc[i + width];
        }
    }
    acc[0]
}

#[inline(always)]
fn mixed_product_portable(coef: &[f32], cols: usize, x: &[f64], out: &mut [f64]) {
    for (row, o) in coef.chunks_exact(cols).zip(out.iter_mut()) {
        *o = mixed_dot(&row[..x.len()], x);
    }
}

/// [`dot`] of f32 values widened to f64 with f64 values, with 32 accumulators: eight 4-wide
/// AVX2 registers in [`mixed_dot_avx2`], enough to hide the latency of the additions.
#[inline(always)]
fn mixed_dot(a: &[f32], b: &[f64]) -> f64 {
    const LANES: usize = 32;
    let mut acc = [0.0f64; LANES];
    let chunks_a = a.chunks_exact(LANES);
    let chunks_b = b.chunks_exact(LANES);
    let (tail_a, tail_b) = (chunks_a.remainder(), chunks_b.remainder());
    for (ca, cb) in chunks_a.zip(chunks_b) {
        for i in 0..LANES {
            acc[i] = f64::from(ca[i]).mul_add(cb[i], acc[i]);
        }
    }
    let mut sum = 0.0;
    for (&x, &y) in tail_a.iter().zip(tail_b) {
        sum = f64::from(x).mul_add(y, sum);
    }
    reduce_lanes(acc) + sum
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

    /// A forecast-sized map and a long input series.
    fn forecast_sized() -> (LinearMap, Vec<f64>) {
        let (rows, cols) = (50, 350);
        let coef = (0..rows * cols)
            .map(|i| ((i * 7919 % 1000) as f64 / 500.0 - 1.0) * 1e3 / 3.0)
            .collect();
        let series = (0..1200)
            .map(|t| (0.11 * t as f64).sin() + 0.3 * (0.037 * t as f64).cos())
            .collect();
        (LinearMap::from_row_major(rows, cols, coef).unwrap(), series)
    }

    #[test]
    fn prepared_forecasts_equal_unprepared_ones_bit_for_bit() {
        let (map, series) = forecast_sized();
        let (rows, cols) = (map.rows(), map.cols());
        let (mut fresh, mut prepared, mut wrong) = (map.clone(), map.clone(), map.clone());
        let (mut a, mut b, mut c) = (vec![0.0; rows], vec![0.0; rows], vec![0.0; rows]);
        let mut direct = vec![0.0; rows];
        for t in (cols..series.len()).step_by(37) {
            let x = &series[t - cols..t];
            fresh.prepared = false;
            fresh.apply_prepared(x, &mut a);
            // Prepared from the values before the newest, then given them at another address.
            prepared.prepare(&series[..t - 1]);
            let moved: Vec<f64> = x.to_vec();
            prepared.apply_prepared(&moved, &mut b);
            // Prepared for a different history: the mismatch is noticed.
            wrong.prepare(&series[..t - 2]);
            wrong.apply_prepared(x, &mut c);
            for r in 0..rows {
                assert_eq!(a[r].to_bits(), b[r].to_bits(), "t {t} row {r}");
                assert_eq!(a[r].to_bits(), c[r].to_bits(), "t {t} row {r}");
            }
            map.apply(x, &mut direct);
            for (d, e) in direct.iter().zip(&a) {
                assert!((d - e).abs() <= 1e-9 * d.abs().max(1.0), "{d} vs {e}");
            }
        }
    }

    /// A well-conditioned forecast-sized map (row L1 norms about 25).
    fn well_conditioned() -> LinearMap {
        let (rows, cols) = (50, 749);
        let coef = (0..rows * cols)
            .map(|i| ((i * 7919 % 1000) as f64 / 500.0 - 1.0) / 15.0)
            .collect();
        LinearMap::from_row_major(rows, cols, coef).unwrap()
    }

    #[test]
    fn a_well_conditioned_map_forecasts_from_f32_coefficients_within_the_bound() {
        let mut map = well_conditioned();
        // Mixed wherever fused multiply-adds are instructions (every CI machine here).
        assert_eq!(map.is_mixed(), fused_multiply_add_is_fast());
        // The ill-conditioned map of the test above (row L1 norms of about 6e4, coefficients f32
        // cannot hold) stays in f64.
        assert!(!forecast_sized().0.is_mixed());
        let (rows, cols) = (map.rows(), map.cols());
        let series: Vec<f64> = (0..3000)
            .map(|t| 2.0 * (0.11 * t as f64).sin() + 0.7 * (0.037 * t as f64).cos())
            .collect();
        let largest = series.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let (mut out, mut exact, mut again) = (vec![0.0; rows], vec![0.0; rows], vec![0.0; rows]);
        for t in (cols..series.len()).step_by(101) {
            let x = &series[t - cols..t];
            map.apply_prepared(x, &mut out);
            // The definition in f64, summed exactly enough (the terms are O(1)).
            for (r, e) in exact.iter_mut().enumerate() {
                *e = map.row(r).iter().zip(x).map(|(a, b)| a * b).sum();
            }
            for (o, e) in out.iter().zip(&exact) {
                assert!((o - e).abs() <= MIXED_MAX_ROUNDING * largest, "{o} vs {e}");
            }
            // Prepared or not, the same bits.
            map.prepare(&series[..t - 1]);
            map.apply_prepared(x, &mut again);
            assert!(out
                .iter()
                .zip(&again)
                .all(|(a, b)| a.to_bits() == b.to_bits()));
        }
    }

    #[test]
    fn the_vector_and_the_portable_mixed_products_give_the_same_bits() {
        // Row counts that leave 0 to 3 rows after the blocks of four.
        for rows in [49, 50, 51, 52] {
            same_bits_on_every_path(rows);
        }
    }

    fn same_bits_on_every_path(rows: usize) {
        let coef = (0..rows * 749)
            .map(|i| ((i * 7919 % 1000) as f64 / 500.0 - 1.0) / 15.0)
            .collect();
        let map = LinearMap::from_row_major(rows, 749, coef).unwrap();
        let x: Vec<f64> = (0..748).map(|i| (i as f64 * 0.3).cos()).collect();
        let (mut fast, mut portable) = (vec![0.0; rows], vec![0.0; rows]);
        mixed_product(&map.coef_f32, map.cols, &x, &mut fast);
        mixed_product_portable(&map.coef_f32, map.cols, &x, &mut portable);
        assert!(fast
            .iter()
            .zip(&portable)
            .all(|(a, b)| a.to_bits() == b.to_bits()));
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
        {
            // The AVX2 path too, where AVX-512 took precedence above.
            // SAFETY: the CPU supports AVX2 and FMA, the features the function is compiled for.
            unsafe { mixed_product_avx2(&map.coef_f32, map.cols, &x, &mut fast) };
            assert!(fast
                .iter()
                .zip(&portable)
                .all(|(a, b)| a.to_bits() == b.to_bits()));
        }
        assert!(fast.iter().all(|v| v.is_finite() && *v != 0.0));
    }

    #[test]
    fn a_single_column_map_has_nothing_to_prepare() {
        let mut m = LinearMap::from_row_major(2, 1, vec![2.0, -3.0]).unwrap();
        m.prepare(&[5.0]);
        let mut out = [0.0; 2];
        m.apply_prepared(&[4.0], &mut out);
        assert_eq!(out, [8.0, -12.0]);
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
