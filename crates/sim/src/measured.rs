//! Ship motion driven by a measured wave-elevation record instead of a simulated sea.
//!
//! Method, per NaN-free segment of the record (a gap, NaN values or a time jump, splits it):
//! 1. remove the segment's mean and taper its first and last `edge_s / 2` seconds with a raised
//!    cosine, so that the Fourier series (periodic over the segment) has no jump at the wrap;
//! 2. FFT (`rustfft`): the segment becomes the sum of cosines a_k cos(w_k t + eps_k) on the
//!    grid w_k = 2 pi k / (N dt), Nyquist line included (the DC line, the small mean the taper
//!    leaves, goes into `wave_m` only);
//! 3. each cosine is one long-crested wave component from the configured direction beta: the
//!    motion is Re(H(w_k, beta, U) a_k exp(i (w_e,k t + eps_k))) with the RAOs of [`super::rao`];
//! 4. the sum is evaluated at any output rate (`Phasors`), which is the band-limited
//!    (trigonometric) interpolation of the record, not a linear one;
//! 5. only the segment's interior is written: the first and last `edge_s` seconds (the taper and
//!    the time the responses need to forget it) are left out.
//!
//! Assumptions: the waves are long-crested and come from beta; the elevation is measured at (or
//! has been transferred to) the ship's centre of gravity; the response is linear. At zero speed
//! this is exact for that model: the output `wave_m` equals the measured elevation at the
//! measured instants (interior of a segment). At speed U the ship does not stay at the gauge:
//! the sea is taken to be the long-crested field whose fixed-point record is the segment's
//! Fourier series, and the ship, leaving the gauge at the segment's start, meets component k at
//! the encounter frequency w_e = |w_k - w_k^2 U cos(beta) / g| (Doppler). `wave_m` is then the
//! elevation at the moving CG, no longer the record. This is an approximation: the real field
//! away from the gauge is not known, and the field assumed is periodic in time over the segment.

use super::motion::{sum_at, Coefficients, Phasors, CHANNELS, WAVE_CHANNEL};
use super::rao::signed_encounter_omega;
use super::{MotionPoint, Rao, SimError, Station};
use rustfft::num_complex::Complex;
use std::f64::consts::{PI, TAU};

/// A time jump larger than this many sample intervals is a gap.
const GAP_FACTOR: f64 = 1.5;
/// Relative tolerance on the sample interval inside a segment.
const DT_TOLERANCE: f64 = 1e-3;

/// One NaN-free, evenly sampled stretch of a measured elevation record.
#[derive(Clone, Debug, PartialEq)]
pub struct ElevationSegment {
    /// Time of the first sample [s].
    pub start_s: f64,
    /// Sample interval [s].
    pub dt_s: f64,
    /// Elevation [m], positive up.
    pub values: Vec<f64>,
}

impl ElevationSegment {
    /// Time of the last sample [s].
    pub fn end_s(&self) -> f64 {
        self.start_s + (self.values.len().saturating_sub(1)) as f64 * self.dt_s
    }
}

/// Splits a record (`time` strictly increasing, `wave` NaN where missing) into even segments.
/// The sample interval is the median step of the record; a step above 1.5 of it, or a NaN
/// value, starts a new segment; any other uneven step is an error naming its CSV line (the
/// header is line 1, the first sample line 2).
pub fn split_segments(time: &[f64], wave: &[f64]) -> Result<Vec<ElevationSegment>, SimError> {
    if time.len() != wave.len() {
        return Err(SimError::Config(format!(
            "{} times for {} elevation values",
            time.len(),
            wave.len()
        )));
    }
    let mut steps: Vec<f64> = time.windows(2).map(|p| p[1] - p[0]).collect();
    steps.sort_by(f64::total_cmp);
    let dt = steps.get(steps.len() / 2).copied().unwrap_or(f64::NAN);
    if !(dt.is_finite() && dt > 0.0) {
        return Err(SimError::Config(
            "an elevation record needs at least two samples with increasing time".into(),
        ));
    }
    let mut segments = Vec::new();
    let mut current: Option<ElevationSegment> = None;
    for (i, (&t, &z)) in time.iter().zip(wave).enumerate() {
        if i > 0 {
            let step = t - time[i - 1];
            if step > GAP_FACTOR * dt {
                segments.extend(current.take());
            } else if (step - dt).abs() > DT_TOLERANCE * dt {
                // To the microsecond: 0.4 s, not the 0.39999999999997726 of subtracted stamps.
                let us = |s: f64| (s * 1e6).round() / 1e6;
                return Err(SimError::Record(format!(
                    "line {}: time step {} s, but the record is sampled every {} s \
                     (an uneven step, neither a sample nor a gap)",
                    i + 2,
                    us(step),
                    us(dt)
                )));
            }
        }
        if z.is_nan() {
            segments.extend(current.take());
            continue;
        }
        match &mut current {
            Some(seg) => seg.values.push(z),
            None => {
                current = Some(ElevationSegment {
                    start_s: t,
                    dt_s: dt,
                    values: vec![z],
                })
            }
        }
    }
    segments.extend(current);
    // The interval of each segment from its own span: the decimal times of a long record
    // (10799.6 s) differ by 0.4 s only to ~1e-12, which would shift late phases measurably.
    let mut first = 0;
    for seg in &mut segments {
        let start = time[first..]
            .iter()
            .position(|&t| t == seg.start_s)
            .map_or(first, |p| first + p);
        let end = start + seg.values.len() - 1;
        if end > start && end < time.len() {
            seg.dt_s = (time[end] - time[start]) / (end - start) as f64;
        }
        first = end + 1;
    }
    Ok(segments)
}

/// The ship's response to one segment, ready to be sampled at any rate.
#[derive(Debug)]
pub struct SegmentResponse {
    coefficients: Vec<Coefficients>,
    /// First and last instant written [s] (the segment without its edges).
    from_s: f64,
    to_s: f64,
}

impl SegmentResponse {
    /// Fourier-analyses `segment` and applies the RAOs of waves from `beta` [rad] (pi = head
    /// seas) for a ship at `speed` [m/s]. `edge_s` is the taper-and-settle margin at each end;
    /// `None` when the segment is not longer than two margins (nothing would be written).
    /// `station`: the ship whose motion is wanted, relative to the one at the gauge (each
    /// Fourier line is a long-crested component, placed as [`Station::place`] places a
    /// simulated one; [`Station::REFERENCE`] for the ship at the gauge).
    pub fn new(
        segment: &ElevationSegment,
        rao: &dyn Rao,
        beta: f64,
        speed: f64,
        edge_s: f64,
        station: &Station,
    ) -> Result<Option<Self>, SimError> {
        station.validate()?;
        if !(edge_s.is_finite() && edge_s >= 0.0) {
            return Err(SimError::Config(format!(
                "the segment edge must be >= 0 s, got {edge_s}"
            )));
        }
        if !(beta.is_finite() && speed.is_finite() && speed >= 0.0) {
            return Err(SimError::Config(
                "wave direction and speed must be finite, speed >= 0".into(),
            ));
        }
        let n = segment.values.len();
        let (from_s, to_s) = (segment.start_s + edge_s, segment.end_s() - edge_s);
        if n < 4 || to_s <= from_s {
            return Ok(None);
        }
        let dt = segment.dt_s;
        let mean = segment.values.iter().sum::<f64>() / n as f64;
        let ramp = edge_s / 2.0;
        let mut buffer: Vec<Complex<f64>> = segment
            .values
            .iter()
            .enumerate()
            .map(|(i, &z)| {
                let from_end = (i as f64 * dt).min((n - 1 - i) as f64 * dt);
                let w = if from_end < ramp {
                    0.5 * (1.0 - (PI * from_end / ramp).cos())
                } else {
                    1.0
                };
                Complex::new((z - mean) * w, 0.0)
            })
            .collect();
        rustfft::FftPlanner::new()
            .plan_fft_forward(n)
            .process(&mut buffer);

        let mut coefficients = Vec::with_capacity(n / 2 + 1);
        // The taper leaves a small mean (the DC line); the elevation keeps it, so that inside
        // the edges `wave_m` is the record minus its mean, and the motion ignores it (no
        // wave, no response).
        let mut dc = Coefficients {
            omega_e: 0.0,
            re: [0.0; CHANNELS],
            im: [0.0; CHANNELS],
        };
        dc.re[WAVE_CHANNEL] = buffer[0].re / n as f64;
        coefficients.push(dc);
        for (k, x) in buffer.iter().enumerate().take(n / 2 + 1).skip(1) {
            // x_n = sum_k X_k exp(2 pi i k n / N) / N: one-sided amplitude 2 X_k / N, except
            // the Nyquist line (even N), which has no negative-frequency twin.
            let scale = if 2 * k == n { 1.0 } else { 2.0 } / n as f64;
            let omega = TAU * k as f64 / (n as f64 * dt);
            let signed = signed_encounter_omega(omega, beta, speed);
            let omega_e = signed.abs();
            // Elevation at the CG: Re(c exp(i w_s (t - t0))); written as Re(w exp(i w_e t)),
            // conjugated when the ship overtakes the component (w_s < 0).
            let mut c = x * scale;
            if signed < 0.0 {
                c = c.conj();
            }
            let shift = station.phase_shift(omega, beta, speed);
            let wave = c * Complex::from_polar(1.0, shift - omega_e * segment.start_s);
            let h = rao.response(omega, station.direction(beta), speed);
            let mut coefficient = Coefficients {
                omega_e,
                re: [0.0; CHANNELS],
                im: [0.0; CHANNELS],
            };
            for (j, hj) in h.iter().enumerate() {
                let m = Complex::new(hj.re, hj.im) * wave;
                coefficient.re[j] = m.re;
                coefficient.im[j] = m.im;
            }
            coefficient.re[WAVE_CHANNEL] = wave.re;
            coefficient.im[WAVE_CHANNEL] = wave.im;
            if coefficient
                .re
                .iter()
                .chain(&coefficient.im)
                .any(|v| !v.is_finite())
            {
                return Err(SimError::Config(format!(
                    "non-finite response at {omega:.4} rad/s (RAO source or record)"
                )));
            }
            coefficients.push(coefficient);
        }
        Ok(Some(SegmentResponse {
            coefficients,
            from_s,
            to_s,
        }))
    }

    /// First instant written [s].
    pub fn from_s(&self) -> f64 {
        self.from_s
    }

    /// Last instant written [s].
    pub fn to_s(&self) -> f64 {
        self.to_s
    }

    /// The motion at instant `t` [s] (direct evaluation).
    pub fn sample_at(&self, t: f64) -> MotionPoint {
        sum_at(&self.coefficients, t)
    }

    /// The samples on the grid j / `rate_hz` (j integer) inside [from_s, to_s], so that every
    /// segment of a record lands on one common time grid.
    pub fn stream(&self, rate_hz: f64) -> Result<SegmentStream<'_>, SimError> {
        if !(rate_hz.is_finite() && rate_hz > 0.0) {
            return Err(SimError::Config(format!(
                "sample rate must be positive, got {rate_hz} Hz"
            )));
        }
        let first = (self.from_s * rate_hz - 1e-9).ceil();
        let last = (self.to_s * rate_hz + 1e-9).floor();
        let count = if last >= first {
            (last - first) as u64 + 1
        } else {
            0
        };
        Ok(SegmentStream {
            response: self,
            phasors: Phasors::new(&self.coefficients, rate_hz, first / rate_hz)?,
            remaining: count,
        })
    }
}

/// The samples of one [`SegmentResponse`]; allocates nothing per sample.
#[derive(Debug)]
pub struct SegmentStream<'a> {
    response: &'a SegmentResponse,
    phasors: Phasors,
    remaining: u64,
}

impl Iterator for SegmentStream<'_> {
    type Item = MotionPoint;

    fn next(&mut self) -> Option<MotionPoint> {
        if self.remaining == 0 {
            return None;
        }
        self.remaining -= 1;
        Some(self.phasors.next_point(&self.response.coefficients))
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let n = usize::try_from(self.remaining).unwrap_or(usize::MAX);
        (n, Some(n))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{ClosedFormRao, Hull};

    fn sinusoid(omega: f64, dt: f64, n: usize, t0: f64) -> ElevationSegment {
        ElevationSegment {
            start_s: t0,
            dt_s: dt,
            values: (0..n)
                .map(|i| 0.7 * (omega * (t0 + i as f64 * dt) + 0.3).cos())
                .collect(),
        }
    }

    /// Amplitude and phase of the response to a cosine, against the RAO itself.
    fn check_against_rao(seg: &ElevationSegment, omega: f64, edge: f64, tol: f64) {
        check_at_station(seg, omega, edge, tol, &Station::REFERENCE);
    }

    /// The same for a ship at `station` (zero speed): the RAO at the direction seen from its
    /// bow, the wave delayed by k times the distance along its travel (deep water).
    fn check_at_station(
        seg: &ElevationSegment,
        omega: f64,
        edge: f64,
        tol: f64,
        station: &Station,
    ) {
        let rao = ClosedFormRao::new(Hull::dtmb5415());
        let beta = 165f64.to_radians();
        let r = SegmentResponse::new(seg, &rao, beta, 0.0, edge, station)
            .unwrap()
            .unwrap();
        let h = rao.response(omega, beta - station.heading_offset_deg.to_radians(), 0.0);
        let delay =
            omega * omega / crate::G * (station.x_m * beta.cos() + station.y_m * beta.sin());
        let (mut worst, mut samples) = (0.0f64, 0usize);
        for p in r.stream(8.0).unwrap() {
            samples += 1;
            let wave = Complex::from_polar(0.7, omega * p.time_s + 0.3 - delay);
            for (j, hj) in h.iter().enumerate() {
                let expected = (Complex::new(hj.re, hj.im) * wave).re;
                let scale = 0.7 * hj.norm();
                if scale > 1e-6 {
                    worst = worst.max((p.dof[j] - expected).abs() / scale);
                }
            }
            worst = worst.max((p.wave_m - wave.re).abs() / 0.7);
        }
        assert!(samples > 100, "only {samples} samples checked");
        assert!(worst < tol, "worst relative error {worst}");
    }

    #[test]
    fn a_cosine_on_the_fourier_grid_gives_the_rao_amplitude_and_phase_exactly() {
        let (dt, n) = (0.4, 2000);
        let omega = TAU * 96.0 / (n as f64 * dt); // 0.754 rad/s, period 8.3 s
        check_against_rao(&sinusoid(omega, dt, n, 100.0), omega, 0.0, 1e-9);
    }

    #[test]
    fn a_second_ship_sees_the_cosine_at_its_own_place_and_heading() {
        let (dt, n) = (0.4, 2000);
        let omega = TAU * 96.0 / (n as f64 * dt);
        let seg = sinusoid(omega, dt, n, 100.0);
        // 40 m to starboard, bow 10 deg to starboard; 15 m ahead; both (the sea comes from
        // 165 deg, so both offsets move the ship along the waves' travel).
        for (x_m, y_m, heading_offset_deg) in
            [(0.0, 40.0, 10.0), (15.0, 0.0, 0.0), (-30.0, 25.0, 30.0)]
        {
            let station = Station {
                x_m,
                y_m,
                heading_offset_deg,
            };
            check_at_station(&seg, omega, 0.0, 1e-9, &station);
        }
        let far = Station {
            y_m: f64::NAN,
            ..Station::REFERENCE
        };
        let rao = ClosedFormRao::new(Hull::dtmb5415());
        assert!(SegmentResponse::new(&seg, &rao, PI, 0.0, 0.0, &far).is_err());
    }

    #[test]
    fn a_cosine_off_the_grid_is_right_inside_the_tapered_edges() {
        let (dt, n) = (0.25, 9000);
        let omega = 0.61; // not a multiple of 2 pi / 2250 s
                          // Roll, lightly damped, still remembers the taper 60 s after it (0.6 % at the first
                          // sample written); the other channels are within 0.02 %.
        check_against_rao(&sinusoid(omega, dt, n, 0.0), omega, 120.0, 1e-2);
    }

    #[test]
    fn gaps_split_the_record_and_uneven_steps_are_errors() {
        let time: Vec<f64> = (0..10)
            .map(|i| i as f64 * 0.5 + if i >= 6 { 20.0 } else { 0.0 })
            .collect();
        let mut wave = vec![1.0; 10];
        wave[2] = f64::NAN;
        let segs = split_segments(&time, &wave).unwrap();
        let spans: Vec<(f64, usize)> = segs.iter().map(|s| (s.start_s, s.values.len())).collect();
        assert_eq!(spans, vec![(0.0, 2), (1.5, 3), (23.0, 4)]);
        let mut uneven = time.clone();
        uneven[4] += 0.2;
        let e = split_segments(&uneven, &wave).unwrap_err().to_string();
        assert!(e.contains("line 6: time step"), "{e}");
        assert!(split_segments(&[1.0], &[0.0]).is_err());
    }

    #[test]
    fn a_long_record_with_decimal_times_is_reproduced_at_its_own_instants() {
        // Times as a record prints them (10799.6): their differences are 0.4 only to ~1e-12.
        let n = 27000;
        let time: Vec<f64> = (0..n)
            .map(|i| format!("{:.1}", i as f64 * 0.4).parse().unwrap())
            .collect();
        let omega = TAU * 1234.0 / (n as f64 * 0.4);
        let wave: Vec<f64> = time.iter().map(|t| (omega * t).cos()).collect();
        let segments = split_segments(&time, &wave).unwrap();
        assert_eq!(segments.len(), 1);
        assert_eq!(segments[0].dt_s, (time[n - 1] - time[0]) / (n - 1) as f64);
        let rao = ClosedFormRao::new(Hull::dtmb5415());
        let r = SegmentResponse::new(&segments[0], &rao, PI, 0.0, 0.0, &Station::REFERENCE)
            .unwrap()
            .unwrap();
        for i in [0, 1, n / 2, n - 2, n - 1] {
            let got = r.sample_at(time[i]).wave_m;
            assert!(
                (got - wave[i]).abs() < 1e-9,
                "sample {i}: {got} vs {}",
                wave[i]
            );
        }
    }

    #[test]
    fn a_segment_shorter_than_its_edges_writes_nothing() {
        let seg = sinusoid(0.6, 0.5, 400, 0.0); // 200 s
        let rao = ClosedFormRao::new(Hull::dtmb5415());
        assert!(
            SegmentResponse::new(&seg, &rao, PI, 0.0, 100.0, &Station::REFERENCE)
                .unwrap()
                .is_none()
        );
        assert!(SegmentResponse::new(&seg, &rao, PI, 0.0, -1.0, &Station::REFERENCE).is_err());
    }
}
