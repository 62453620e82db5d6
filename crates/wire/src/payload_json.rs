//! The forecast's and the motion sample's zenoh JSON (docs/contracts.md section 2.2), written
//! by serde_json ([`Forecast::write_json`]'s form) into one reusable buffer that zenoh can take
//! without a copy ([`ForecastJsonEncoder::encode_shared`] with `JsonPublisher::put_shared`).
//!
//! A hand-written encoder (literal field names, `itoa` and `zmij`, a cache of the sigma text)
//! stood here until issue 12 measured it against serde_json into a reused buffer on the
//! engine's own forecasts: the live calibration changes sigma at every forecast, so the cache
//! never hit, and both took the same time (p50 12.4 against 12.2 µs, `cargo bench --bench
//! hot_path`, the forecast-path table), well under the 10 % of the zenoh path's p50 it had to
//! save to stay.

use crate::payload::{Forecast, MotionSample, MAX_STEPS, NUM_DOF};
use bytes::{Bytes, BytesMut};

/// Longest text of a `u64` (`u64::MAX` has 20 digits).
const MAX_U64_LEN: usize = 20;
/// Longest text serde_json writes for a finite `f64` (zmij's buffer size), e.g.
/// `-0.000012345678901234567` or `-1.2345678901234567e-308`; `null` is shorter.
const MAX_F64_LEN: usize = 24;
/// Longest text serde_json writes for a finite `f32`, e.g. `-0.0000010000001` (fixed notation
/// is used down to 1e-6).
const MAX_F32_LEN: usize = 16;
/// Longest `[[...],...]` of one array field: NUM_DOF rows of MAX_STEPS floats.
const MAX_ROWS_LEN: usize = 2 + NUM_DOF * (2 + MAX_STEPS * (MAX_F32_LEN + 1));

/// Upper bound of the length of an encoded forecast: the field names and punctuation (under
/// 160 bytes), four `u64`, two `f64`, two `u32`, and the two arrays. The encoder's buffer
/// holds this much, so no forecast, however corrupt its values or `steps`, makes it grow.
pub const MAX_JSON_LEN: usize = 160 + 4 * MAX_U64_LEN + 2 * MAX_F64_LEN + 2 * 10 + 2 * MAX_ROWS_LEN;

/// Encodes forecasts as JSON ([`Forecast::write_json`]'s bytes) into one buffer of
/// [`MAX_JSON_LEN`] bytes, allocated once. The buffer is reference-counted: a text handed to
/// zenoh with [`Self::encode_shared`] is not copied, and its buffer is written again once zenoh
/// has dropped it.
///
/// ```
/// use shipcast_wire::payload::Forecast;
/// use shipcast_wire::payload_json::ForecastJsonEncoder;
///
/// let f = Forecast { steps: 2, ..Forecast::default() };
/// let mut encoder = ForecastJsonEncoder::new();
/// let mut reference = Vec::new();
/// f.write_json(&mut reference).unwrap();
/// assert_eq!(encoder.encode(&f).unwrap(), &reference[..]);
/// ```
pub struct ForecastJsonEncoder {
    out: BytesMut,
}

impl Default for ForecastJsonEncoder {
    fn default() -> Self {
        Self::new()
    }
}

impl ForecastJsonEncoder {
    pub fn new() -> Self {
        Self {
            out: BytesMut::with_capacity(MAX_JSON_LEN),
        }
    }

    /// Encode `f` and return its JSON, valid until the next call.
    pub fn encode(&mut self, f: &Forecast) -> Result<&[u8], serde_json::Error> {
        self.write(f)?;
        Ok(&self.out)
    }

    /// Encode `f` and return its JSON as a shared handle to the encoder's buffer, for
    /// `JsonPublisher::put_shared` (no copy). The next call writes into the same buffer once
    /// every handle to it has been dropped (zenoh drops its own when it has written the put to
    /// its links); while one is still held, that call allocates a new buffer.
    pub fn encode_shared(&mut self, f: &Forecast) -> Result<Bytes, serde_json::Error> {
        self.write(f)?;
        Ok(self.out.split().freeze())
    }

    fn write(&mut self, f: &Forecast) -> Result<(), serde_json::Error> {
        self.out.clear();
        // Takes the whole buffer back when the last text handed out is no longer held (a
        // pointer reset, no allocation); the first `split` made it shared, once.
        self.out.reserve(MAX_JSON_LEN);
        serde_json::to_writer(AppendTo(&mut self.out), &f.json_view())
    }
}

/// Upper bound of the length of an encoded motion sample: field names and punctuation (under
/// 60 bytes), two `u64` and seven `f64`.
pub const MAX_MOTION_JSON_LEN: usize = 60 + 2 * MAX_U64_LEN + (1 + NUM_DOF) * (MAX_F64_LEN + 1);

/// Encodes motion samples as JSON into one buffer allocated once, shared with zenoh like
/// [`ForecastJsonEncoder`]'s.
///
/// ```
/// use shipcast_wire::payload::MotionSample;
/// use shipcast_wire::payload_json::MotionJsonEncoder;
///
/// let m = MotionSample { seq: 3, time_s: 1.5, dof: [0.1, 0.0, -0.25, 0.0, 0.01, 0.0], ..MotionSample::default() };
/// let mut encoder = MotionJsonEncoder::new();
/// let text = encoder.encode_shared(&m).unwrap();
/// assert_eq!(MotionSample::from_json(&text).unwrap(), m);
/// ```
pub struct MotionJsonEncoder {
    out: BytesMut,
}

impl Default for MotionJsonEncoder {
    fn default() -> Self {
        Self::new()
    }
}

impl MotionJsonEncoder {
    pub fn new() -> Self {
        Self {
            out: BytesMut::with_capacity(MAX_MOTION_JSON_LEN),
        }
    }

    /// Encode `m` and return its JSON as a shared handle to the encoder's buffer (see
    /// [`ForecastJsonEncoder::encode_shared`]).
    pub fn encode_shared(&mut self, m: &MotionSample) -> Result<Bytes, serde_json::Error> {
        self.out.clear();
        self.out.reserve(MAX_MOTION_JSON_LEN);
        serde_json::to_writer(AppendTo(&mut self.out), m)?;
        Ok(self.out.split().freeze())
    }
}

/// serde_json's writer: appends straight to the buffer (`bytes`' own `Writer` goes through
/// `BufMut::put_slice` and a bound check per write, and serde_json writes every number, comma
/// and bracket separately: about 1300 writes per forecast).
struct AppendTo<'a>(&'a mut BytesMut);

impl std::io::Write for AppendTo<'_> {
    fn write(&mut self, bytes: &[u8]) -> std::io::Result<usize> {
        self.0.extend_from_slice(bytes);
        Ok(bytes.len())
    }

    fn write_all(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        self.0.extend_from_slice(bytes);
        Ok(())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn reference(f: &Forecast) -> Vec<u8> {
        let mut out = Vec::new();
        f.write_json(&mut out)
            .expect("serde encodes every forecast");
        out
    }

    /// Any f32: zeros of both signs, subnormals, integers, magnitudes 1e-30..1e30 of both
    /// signs, the extremes, NaN and infinities, and raw bit patterns.
    fn any_f32(rng: &mut ChaCha8Rng) -> f32 {
        let sign = if rng.random_bool(0.5) { -1.0 } else { 1.0 };
        match rng.random_range(0..16) {
            0 => 0.0,
            1 => -0.0,
            2 => sign * f32::from_bits(rng.random_range(1..0x0080_0000)),
            3 => rng.random_range(-100_000..=100_000) as f32,
            4 => f32::from_bits(rng.random()),
            5 => [
                f32::NAN,
                -f32::NAN,
                f32::INFINITY,
                f32::NEG_INFINITY,
                f32::MAX,
                f32::MIN,
                f32::MIN_POSITIVE,
                f32::EPSILON,
                f32::from_bits(1),
            ][rng.random_range(0..9)],
            _ => sign * 10f64.powf(rng.random_range(-30.0..30.0)) as f32,
        }
    }

    fn any_f64(rng: &mut ChaCha8Rng) -> f64 {
        let sign = if rng.random_bool(0.5) { -1.0 } else { 1.0 };
        match rng.random_range(0..12) {
            0 => 0.0,
            1 => -0.0,
            2 => f64::from_bits(rng.random()),
            3 => [
                f64::NAN,
                f64::INFINITY,
                f64::NEG_INFINITY,
                f64::MAX,
                f64::MIN_POSITIVE,
                f64::from_bits(1),
            ][rng.random_range(0..6)],
            4 => rng.random_range(-100_000..=100_000) as f64,
            _ => sign * 10f64.powf(rng.random_range(-300.0..300.0)),
        }
    }

    fn any_u64(rng: &mut ChaCha8Rng) -> u64 {
        match rng.random_range(0..4) {
            0 => 0,
            1 => u64::MAX,
            2 => rng.random_range(0..1000),
            _ => rng.random(),
        }
    }

    fn any_steps(rng: &mut ChaCha8Rng) -> u32 {
        match rng.random_range(0..8) {
            0 => 0,
            1 => 1,
            2 => 50,
            3 => MAX_STEPS as u32,
            4 => 10_000,
            5 => rng.random(),
            _ => rng.random_range(0..=MAX_STEPS as u32),
        }
    }

    /// A forecast with every field random, including the array entries beyond `steps`.
    fn any_forecast(rng: &mut ChaCha8Rng, steps: u32) -> Forecast {
        let mut f = Forecast {
            seq: any_u64(rng),
            source_seq: any_u64(rng),
            source_stamp_ns: any_u64(rng),
            issued_stamp_ns: any_u64(rng),
            time_s: any_f64(rng),
            dt_s: any_f64(rng),
            steps,
            model_version: if rng.random_bool(0.2) {
                u32::MAX
            } else {
                rng.random()
            },
            ..Forecast::default()
        };
        for row in f.mean.iter_mut().chain(f.sigma.iter_mut()) {
            for v in row.iter_mut() {
                *v = any_f32(rng);
            }
        }
        f
    }

    #[test]
    fn round_trips_through_from_json() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let mut encoder = ForecastJsonEncoder::new();
        for _ in 0..500 {
            let steps = rng.random_range(0..=MAX_STEPS as u32);
            let mut f = any_forecast(&mut rng, steps);
            for v in [&mut f.time_s, &mut f.dt_s] {
                if !v.is_finite() {
                    *v = 1.25;
                }
            }
            // from_json leaves the entries beyond `steps` at zero.
            for row in f.mean.iter_mut().chain(f.sigma.iter_mut()) {
                for (k, v) in row.iter_mut().enumerate() {
                    if k >= steps as usize || !v.is_finite() {
                        *v = 0.0;
                    }
                }
            }
            let back = Forecast::from_json(encoder.encode(&f).unwrap()).expect("valid JSON");
            assert_eq!(back, f);
        }
    }

    #[test]
    fn shared_text_is_reused_once_released_and_never_overwritten_while_held() {
        let mut encoder = ForecastJsonEncoder::new();
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        let (f, g) = (any_forecast(&mut rng, 50), any_forecast(&mut rng, 50));
        let first = encoder.encode_shared(&f).unwrap();
        assert_eq!(&first[..], &reference(&f)[..]);
        let at = first.as_ptr();
        drop(first);
        // Released: the next text is written into the same buffer.
        let second = encoder.encode_shared(&g).unwrap();
        assert_eq!((&second[..], second.as_ptr()), (&reference(&g)[..], at));
        // Still held (zenoh has not written it yet): the next text goes elsewhere and the held
        // one keeps its bytes.
        let third = encoder.encode_shared(&f).unwrap();
        assert_ne!(third.as_ptr(), second.as_ptr());
        assert_eq!(&second[..], &reference(&g)[..]);
        assert_eq!(&third[..], &reference(&f)[..]);
        drop((second, third));
        assert_eq!(encoder.encode(&g).unwrap(), &reference(&g)[..]);
    }

    #[test]
    fn motion_samples_round_trip_and_the_longest_fits_the_buffer() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let mut encoder = MotionJsonEncoder::new();
        let finite = |rng: &mut ChaCha8Rng| loop {
            let v = any_f64(rng);
            if v.is_finite() {
                break v;
            }
        };
        for _ in 0..500 {
            let m = MotionSample {
                seq: any_u64(&mut rng),
                stamp_ns: any_u64(&mut rng),
                time_s: finite(&mut rng),
                dof: std::array::from_fn(|_| finite(&mut rng)),
            };
            let text = encoder.encode_shared(&m).unwrap();
            assert_eq!(MotionSample::from_json(&text).unwrap(), m);
        }
        let longest64 = f64_with_text_len(-1.234_567_890_123_4e-5, MAX_F64_LEN);
        let longest = MotionSample {
            seq: u64::MAX,
            stamp_ns: u64::MAX,
            time_s: longest64,
            dof: [longest64; NUM_DOF],
        };
        let text = encoder.encode_shared(&longest).unwrap();
        assert!(text.len() <= MAX_MOTION_JSON_LEN, "{}", text.len());
        // A value that JSON cannot carry (written as null), a wrong DOF count, a missing field
        // and a truncated text are refused.
        let mut nan = longest;
        nan.dof[2] = f64::NAN;
        let text = encoder.encode_shared(&nan).unwrap();
        assert!(MotionSample::from_json(&text).is_err());
        for bad in [
            r#"{"seq":1,"stamp_ns":0,"time_s":0.5,"dof":[0,0,0,0,0]}"#,
            r#"{"seq":1,"stamp_ns":0,"dof":[0,0,0,0,0,0]}"#,
            r#"{"seq":1,"stamp_ns":0,"time_s":0.5,"dof":[0,0,0"#,
        ] {
            assert!(MotionSample::from_json(bad.as_bytes()).is_err(), "{bad}");
        }
    }

    /// serde_json's text of `v`.
    fn text_len<T: serde::Serialize>(v: &T, buf: &mut Vec<u8>) -> usize {
        buf.clear();
        serde_json::to_writer(&mut *buf, v).expect("numbers serialise");
        buf.len()
    }

    /// The first float after `start` (walking its bit patterns) whose text has `len` bytes.
    fn f32_with_text_len(start: f32, len: usize) -> f32 {
        let mut buf = Vec::new();
        (0..100_000)
            .map(|i| f32::from_bits(start.to_bits() + i))
            .find(|v| text_len(v, &mut buf) == len)
            .expect("such a float exists near start")
    }

    fn f64_with_text_len(start: f64, len: usize) -> f64 {
        let mut buf = Vec::new();
        (0..100_000)
            .map(|i| f64::from_bits(start.to_bits() + i))
            .find(|v| text_len(v, &mut buf) == len)
            .expect("such a float exists near start")
    }

    #[test]
    fn float_text_lengths_are_bounded_as_assumed() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let mut buf = Vec::new();
        for _ in 0..300_000 {
            let v = f32::from_bits(rng.random());
            if v.is_finite() {
                assert!(text_len(&v, &mut buf) <= MAX_F32_LEN, "{v:e}");
            }
            let w = f64::from_bits(rng.random());
            if w.is_finite() {
                assert!(text_len(&w, &mut buf) <= MAX_F64_LEN, "{w:e}");
            }
        }
        // The bounds are reached.
        f32_with_text_len(-1.000_000_1e-6, MAX_F32_LEN);
        f64_with_text_len(-1.234_567_890_123_4e-5, MAX_F64_LEN);
    }

    #[test]
    fn the_longest_forecast_fits_and_encoding_never_reallocates() {
        let mut encoder = ForecastJsonEncoder::new();
        let (at, capacity) = (encoder.out.as_ptr(), encoder.out.capacity());
        // The longest forecast there is: every number at its longest text.
        let longest32 = f32_with_text_len(-1.000_000_1e-6, MAX_F32_LEN);
        let longest64 = f64_with_text_len(-1.234_567_890_123_4e-5, MAX_F64_LEN);
        let longest = Forecast {
            seq: u64::MAX,
            source_seq: u64::MAX,
            source_stamp_ns: u64::MAX,
            issued_stamp_ns: u64::MAX,
            time_s: longest64,
            dt_s: longest64,
            steps: u32::MAX,
            model_version: u32::MAX,
            mean: [[longest32; MAX_STEPS]; NUM_DOF],
            sigma: [[longest32; MAX_STEPS]; NUM_DOF],
        };
        let text = encoder.encode(&longest).unwrap();
        assert_eq!(text, &reference(&longest)[..]);
        assert!(
            text.len() <= MAX_JSON_LEN,
            "{} > {MAX_JSON_LEN}",
            text.len()
        );
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for i in 0..100 {
            let f = if i % 10 == 0 {
                longest
            } else {
                let steps = any_steps(&mut rng);
                any_forecast(&mut rng, steps)
            };
            assert_eq!(encoder.encode(&f).unwrap(), &reference(&f)[..]);
            assert_eq!(
                (encoder.out.as_ptr(), encoder.out.capacity()),
                (at, capacity)
            );
        }
    }
}
