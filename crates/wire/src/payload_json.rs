//! A hand-written, allocation-free JSON encoder for [`Forecast`], byte-identical to the serde
//! form written by [`Forecast::write_json`].
//!
//! Encoding a forecast sits on the latency-critical path of the predictor service
//! (forecast -> JSON -> zenoh put). [`Forecast::write_json`] stays the reference
//! implementation; [`ForecastJsonEncoder`] writes exactly the same bytes, faster:
//! - no serde machinery: the fixed field names are copied as literals, integers are written with
//!   `itoa` and floats with `zmij`, the same crates, calls and `null` rule that serde_json uses
//!   (serde_json 1.0.154 formats floats with `zmij`, not `ryu`: the two disagree on large
//!   exponents, `1e+30` against `1e30`, so `ryu` would not be byte-identical);
//! - one output buffer, sized for the longest possible forecast at construction, so encoding
//!   never allocates;
//! - a sigma cache: sigma only changes when the model changes, so the encoded `,"sigma":[...]`
//!   part is kept with the bit patterns of the sigma values it was made from, and copied when the
//!   next forecast's sigma is bitwise equal. That halves the float formatting, which is nearly
//!   all of the work.

use crate::payload::{Forecast, MAX_STEPS, NUM_DOF};

/// Longest text of a `u64` (`u64::MAX` has 20 digits).
const MAX_U64_LEN: usize = 20;
/// Longest text zmij writes for a finite `f64` (its buffer size), e.g.
/// `-0.000012345678901234567` or `-1.2345678901234567e-308`; `null` is shorter.
const MAX_F64_LEN: usize = 24;
/// Longest text zmij writes for a finite `f32`, e.g. `-0.0000010000001` (found by formatting
/// every f32 once; fixed notation is used down to 1e-6).
const MAX_F32_LEN: usize = 16;
/// Longest `[[...],...]` of one array field: NUM_DOF rows of MAX_STEPS floats.
const MAX_ROWS_LEN: usize = 2 + NUM_DOF * (2 + MAX_STEPS * (MAX_F32_LEN + 1));

const SIGMA_KEY: &[u8] = b",\"sigma\":";
/// Longest cached `,"sigma":[...]` part.
const MAX_SIGMA_LEN: usize = SIGMA_KEY.len() + MAX_ROWS_LEN;

/// Upper bound of the length of an encoded forecast: the field names and punctuation (under
/// 160 bytes), four `u64`, two `f64`, two `u32`, and the two arrays. The encoder preallocates
/// this much, so no forecast, however corrupt its values or `steps`, makes it reallocate.
pub const MAX_JSON_LEN: usize = 160 + 4 * MAX_U64_LEN + 2 * MAX_F64_LEN + 2 * 10 + 2 * MAX_ROWS_LEN;

/// Encodes forecasts as JSON into one reusable buffer, byte-identical to
/// [`Forecast::write_json`] (same field order and names, no whitespace, arrays cut to
/// [`Forecast::valid_steps`], `steps` written as `valid_steps()`, non-finite floats as `null`).
///
/// It is a struct, not a function, for its buffers and its sigma cache: the text of the sigma
/// part is reused while the sigma values are bitwise equal (compared with `to_bits`, so `-0.0`
/// and `0.0`, or two NaN payloads, count as different) over the valid steps of all DOF, and
/// `valid_steps()` is the same. Nothing allocates after [`ForecastJsonEncoder::new`].
///
/// ```
/// use shipcast_wire::payload::Forecast;
/// use shipcast_wire::payload_json::ForecastJsonEncoder;
///
/// let f = Forecast { steps: 2, ..Forecast::default() };
/// let mut encoder = ForecastJsonEncoder::new();
/// let mut reference = Vec::new();
/// f.write_json(&mut reference).unwrap();
/// assert_eq!(encoder.encode(&f), &reference[..]);
/// ```
pub struct ForecastJsonEncoder {
    /// The encoded forecast; capacity MAX_JSON_LEN.
    out: Vec<u8>,
    /// Cached `,"sigma":[...]` text; capacity MAX_SIGMA_LEN. Empty until the first forecast
    /// (a cached text always starts with the key).
    sigma_json: Vec<u8>,
    /// Bit patterns of the sigma values `sigma_json` was made from; the first `sigma_steps` of
    /// each row are meaningful.
    sigma_bits: Box<[[u32; MAX_STEPS]; NUM_DOF]>,
    sigma_steps: usize,
    /// Times the sigma part was formatted rather than copied (for the tests).
    sigma_misses: u64,
}

impl Default for ForecastJsonEncoder {
    fn default() -> Self {
        Self::new()
    }
}

impl ForecastJsonEncoder {
    /// An encoder with its buffers allocated for the longest possible forecast
    /// ([`MAX_JSON_LEN`] bytes) and an empty sigma cache.
    pub fn new() -> Self {
        Self {
            out: Vec::with_capacity(MAX_JSON_LEN),
            sigma_json: Vec::with_capacity(MAX_SIGMA_LEN),
            sigma_bits: Box::new([[0; MAX_STEPS]; NUM_DOF]),
            sigma_steps: 0,
            sigma_misses: 0,
        }
    }

    /// Encode `f` and return its JSON, valid until the next call. The bytes equal those of
    /// [`Forecast::write_json`]; nothing is allocated.
    pub fn encode(&mut self, f: &Forecast) -> &[u8] {
        let steps = f.valid_steps();
        let out = &mut self.out;
        out.clear();
        out.extend_from_slice(b"{\"seq\":");
        write_u64(out, f.seq);
        out.extend_from_slice(b",\"source_seq\":");
        write_u64(out, f.source_seq);
        out.extend_from_slice(b",\"source_stamp_ns\":");
        write_u64(out, f.source_stamp_ns);
        out.extend_from_slice(b",\"issued_stamp_ns\":");
        write_u64(out, f.issued_stamp_ns);
        out.extend_from_slice(b",\"time_s\":");
        write_f64(out, f.time_s);
        out.extend_from_slice(b",\"dt_s\":");
        write_f64(out, f.dt_s);
        out.extend_from_slice(b",\"steps\":");
        write_u64(out, steps as u64);
        out.extend_from_slice(b",\"model_version\":");
        write_u64(out, u64::from(f.model_version));
        out.extend_from_slice(b",\"mean\":");
        write_rows(out, &f.mean, steps);

        if !self.sigma_cache_matches(f, steps) {
            self.sigma_json.clear();
            self.sigma_json.extend_from_slice(SIGMA_KEY);
            write_rows(&mut self.sigma_json, &f.sigma, steps);
            for (bits, row) in self.sigma_bits.iter_mut().zip(&f.sigma) {
                for (b, v) in bits[..steps].iter_mut().zip(&row[..steps]) {
                    *b = v.to_bits();
                }
            }
            self.sigma_steps = steps;
            self.sigma_misses += 1;
        }
        self.out.extend_from_slice(&self.sigma_json);
        self.out.push(b'}');
        &self.out
    }

    /// True if the cached sigma text was made from the same `steps` and bitwise the same valid
    /// sigma values as `f`'s.
    fn sigma_cache_matches(&self, f: &Forecast, steps: usize) -> bool {
        !self.sigma_json.is_empty()
            && self.sigma_steps == steps
            && self.sigma_bits.iter().zip(&f.sigma).all(|(bits, row)| {
                // Branch-free within a row, so the comparison vectorises.
                bits[..steps]
                    .iter()
                    .zip(&row[..steps])
                    .fold(0, |diff, (b, v)| diff | (b ^ v.to_bits()))
                    == 0
            })
    }
}

fn write_u64(out: &mut Vec<u8>, v: u64) {
    out.extend_from_slice(itoa::Buffer::new().format(v).as_bytes());
}

/// As serde_json: `null` for NaN and infinities, else zmij's shortest round-trip text.
fn write_f64(out: &mut Vec<u8>, v: f64) {
    if v.is_finite() {
        out.extend_from_slice(zmij::Buffer::new().format_finite(v).as_bytes());
    } else {
        out.extend_from_slice(b"null");
    }
}

/// `[[r0...],[r1...],...]` with each row cut to `steps`, floats as serde_json writes `f32`.
fn write_rows(out: &mut Vec<u8>, rows: &[[f32; MAX_STEPS]; NUM_DOF], steps: usize) {
    let mut buf = zmij::Buffer::new();
    out.push(b'[');
    for (d, row) in rows.iter().enumerate() {
        if d > 0 {
            out.push(b',');
        }
        out.push(b'[');
        for (k, &v) in row[..steps].iter().enumerate() {
            if k > 0 {
                out.push(b',');
            }
            if v.is_finite() {
                out.extend_from_slice(buf.format_finite(v).as_bytes());
            } else {
                out.extend_from_slice(b"null");
            }
        }
        out.push(b']');
    }
    out.push(b']');
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

    /// Asserts byte equality with the serde form, showing both texts on failure.
    fn assert_same_as_serde(encoder: &mut ForecastJsonEncoder, f: &Forecast) {
        let want = reference(f);
        let got = encoder.encode(f);
        assert!(
            got == &want[..],
            "encoder output differs from serde\n  got: {}\n want: {}",
            String::from_utf8_lossy(got),
            String::from_utf8_lossy(&want)
        );
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
    fn byte_identical_to_serde_for_random_forecasts() {
        let mut rng = ChaCha8Rng::seed_from_u64(0x5eed);
        let mut reused = ForecastJsonEncoder::new();
        let mut prev = Forecast::default();
        for i in 0..3000 {
            let steps = any_steps(&mut rng);
            let mut f = any_forecast(&mut rng, steps);
            // Half the stream keeps the previous sigma (a cache hit when steps also agree).
            if i % 2 == 1 {
                f.sigma = prev.sigma;
                if rng.random_bool(0.5) {
                    f.steps = prev.steps;
                }
            }
            assert_same_as_serde(&mut ForecastJsonEncoder::new(), &f);
            assert_same_as_serde(&mut reused, &f);
            prev = f;
        }
        assert!(reused.sigma_misses < 3000, "the cache was never hit");
    }

    #[test]
    fn fixed_cases_match_serde() {
        let mut encoder = ForecastJsonEncoder::new();
        for steps in [0, 1, 50, MAX_STEPS as u32, 10_000] {
            let mut f = Forecast {
                seq: u64::MAX,
                source_seq: u64::MAX,
                source_stamp_ns: u64::MAX,
                issued_stamp_ns: u64::MAX,
                time_s: f64::NAN,
                dt_s: f64::INFINITY,
                steps,
                model_version: u32::MAX,
                ..Forecast::default()
            };
            let specials = [
                3.0,
                -0.0,
                1e-30,
                -1e30,
                1e12,
                1e13,
                1e-6,
                1.5e-7,
                f32::from_bits(1),
                f32::NAN,
                f32::INFINITY,
                f32::NEG_INFINITY,
            ];
            for d in 0..NUM_DOF {
                for k in 0..MAX_STEPS {
                    f.mean[d][k] = specials[(d + k) % specials.len()];
                    f.sigma[d][k] = specials[(d * 7 + k) % specials.len()];
                }
            }
            assert_same_as_serde(&mut encoder, &f);
            f.time_s = f64::NEG_INFINITY;
            f.dt_s = -0.0;
            assert_same_as_serde(&mut encoder, &f);
        }
        let text = encoder.encode(&Forecast {
            steps: 1,
            time_s: f64::NAN,
            ..Forecast::default()
        });
        assert_eq!(
            std::str::from_utf8(text).unwrap(),
            "{\"seq\":0,\"source_seq\":0,\"source_stamp_ns\":0,\"issued_stamp_ns\":0,\
             \"time_s\":null,\"dt_s\":0.0,\"steps\":1,\"model_version\":0,\
             \"mean\":[[0.0],[0.0],[0.0],[0.0],[0.0],[0.0]],\
             \"sigma\":[[0.0],[0.0],[0.0],[0.0],[0.0],[0.0]]}"
        );
    }

    fn forecast_with_sigma(seed: u64, sigma_scale: f32) -> Forecast {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut f = Forecast {
            seq: seed,
            time_s: 12.5,
            dt_s: 0.5,
            steps: 50,
            model_version: 1,
            ..Forecast::default()
        };
        for d in 0..NUM_DOF {
            for k in 0..MAX_STEPS {
                f.mean[d][k] = rng.random_range(-3.0..3.0);
                f.sigma[d][k] = sigma_scale * (0.05 + 0.001 * k as f32);
            }
        }
        f
    }

    #[test]
    fn sigma_cache_hits_only_on_bitwise_equal_sigma() {
        let a = forecast_with_sigma(1, 1.0);
        let b = forecast_with_sigma(2, 1.0); // same sigma, different mean
        let c = forecast_with_sigma(3, 2.0); // different sigma
        assert_ne!(a.mean, b.mean);
        let mut encoder = ForecastJsonEncoder::new();
        for (f, misses) in [(&a, 1), (&b, 1), (&c, 2), (&a, 3), (&a, 3)] {
            assert_same_as_serde(&mut encoder, f);
            assert_eq!(encoder.sigma_misses, misses);
        }

        // One bit of one valid sigma value.
        let mut one_bit = a;
        one_bit.sigma[4][17] = f32::from_bits(a.sigma[4][17].to_bits() ^ 1);
        assert_same_as_serde(&mut encoder, &one_bit);
        assert_eq!(encoder.sigma_misses, 4);

        // -0.0 against 0.0: equal as floats, different bits and text.
        let mut zero = a;
        zero.sigma[0][0] = 0.0;
        let mut neg_zero = a;
        neg_zero.sigma[0][0] = -0.0;
        assert_same_as_serde(&mut encoder, &zero);
        assert_same_as_serde(&mut encoder, &neg_zero);
        assert_eq!(encoder.sigma_misses, 6);

        // Same values, fewer valid steps: the cached text is too long.
        let mut shorter = neg_zero;
        shorter.steps -= 1;
        assert_same_as_serde(&mut encoder, &shorter);
        assert_eq!(encoder.sigma_misses, 7);

        // A change beyond the valid steps is not part of the text: a hit.
        let mut beyond = shorter;
        beyond.sigma[2][MAX_STEPS - 1] = 42.0;
        beyond.mean[0][0] = 7.0;
        assert_same_as_serde(&mut encoder, &beyond);
        assert_eq!(encoder.sigma_misses, 7);

        // Two NaN payloads both write null, but are different bits.
        let mut nan = a;
        nan.sigma[5][3] = f32::NAN;
        let mut other_nan = a;
        other_nan.sigma[5][3] = f32::from_bits(f32::NAN.to_bits() | 1);
        assert_same_as_serde(&mut encoder, &nan);
        assert_same_as_serde(&mut encoder, &other_nan);
        assert_eq!(encoder.sigma_misses, 9);
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
            let back = Forecast::from_json(encoder.encode(&f)).expect("valid JSON");
            assert_eq!(back, f);
        }
    }

    /// The first float after `start` (walking its bit patterns) whose text has `len` bytes.
    fn f32_with_text_len(start: f32, len: usize) -> f32 {
        let mut buf = zmij::Buffer::new();
        (0..100_000)
            .map(|i| f32::from_bits(start.to_bits() + i))
            .find(|v| buf.format_finite(*v).len() == len)
            .expect("such a float exists near start")
    }

    fn f64_with_text_len(start: f64, len: usize) -> f64 {
        let mut buf = zmij::Buffer::new();
        (0..100_000)
            .map(|i| f64::from_bits(start.to_bits() + i))
            .find(|v| buf.format_finite(*v).len() == len)
            .expect("such a float exists near start")
    }

    #[test]
    fn float_text_lengths_are_bounded_as_assumed() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let (mut b32, mut b64) = (zmij::Buffer::new(), zmij::Buffer::new());
        for _ in 0..1_000_000 {
            let v = f32::from_bits(rng.random());
            if v.is_finite() {
                assert!(b32.format_finite(v).len() <= MAX_F32_LEN, "{v:e}");
            }
            let w = f64::from_bits(rng.random());
            if w.is_finite() {
                assert!(b64.format_finite(w).len() <= MAX_F64_LEN, "{w:e}");
            }
        }
        // The bounds are reached.
        f32_with_text_len(-1.000_000_1e-6, MAX_F32_LEN);
        f64_with_text_len(-1.234_567_890_123_4e-5, MAX_F64_LEN);
    }

    #[test]
    fn encode_never_reallocates() {
        let mut encoder = ForecastJsonEncoder::new();
        let (out_ptr, out_cap) = (encoder.out.as_ptr(), encoder.out.capacity());
        let (sigma_ptr, sigma_cap) = (encoder.sigma_json.as_ptr(), encoder.sigma_json.capacity());

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
        assert_same_as_serde(&mut encoder, &longest);
        assert!(encoder.out.len() <= MAX_JSON_LEN);
        assert!(encoder.sigma_json.len() <= MAX_SIGMA_LEN);

        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for i in 0..100 {
            let f = if i % 10 == 0 {
                longest
            } else {
                let steps = any_steps(&mut rng);
                any_forecast(&mut rng, steps)
            };
            encoder.encode(&f);
            assert_eq!(encoder.out.as_ptr(), out_ptr);
            assert_eq!(encoder.out.capacity(), out_cap);
            assert_eq!(encoder.sigma_json.as_ptr(), sigma_ptr);
            assert_eq!(encoder.sigma_json.capacity(), sigma_cap);
        }
    }
}
