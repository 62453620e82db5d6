//! HDR histogram of one-way latencies (nanoseconds) and the summary row of one path and mode.

use super::plan::{Mode, Path, Source};
use hdrhistogram::Histogram;
use serde::Serialize;

/// Longest latency the histogram resolves; longer ones are recorded as this value (and show up
/// in `max`), never dropped.
const HIGHEST_NS: u64 = 60_000_000_000;

/// Records one-way latencies. Recording never allocates: the buckets are sized up front.
#[derive(Debug, Clone)]
pub struct LatencyRecorder {
    hist: Histogram<u64>,
}

impl Default for LatencyRecorder {
    fn default() -> Self {
        Self::new()
    }
}

impl LatencyRecorder {
    pub fn new() -> Self {
        // 3 significant digits: 0.1 % resolution over 1 ns .. 60 s. The bounds are constants
        // that hdrhistogram accepts, so this cannot fail.
        let hist = Histogram::new_with_bounds(1, HIGHEST_NS, 3)
            .expect("constant histogram bounds are valid");
        Self { hist }
    }

    /// Record the latency from `sent_ns` to `received_ns` (same CLOCK_MONOTONIC). A receive
    /// stamp before the send stamp (impossible on one clock) is recorded as 0.
    pub fn record_between(&mut self, sent_ns: u64, received_ns: u64) {
        self.record_ns(received_ns.saturating_sub(sent_ns));
    }

    pub fn record_ns(&mut self, ns: u64) {
        self.hist.saturating_record(ns);
    }

    /// Number of latencies recorded.
    pub fn count(&self) -> u64 {
        self.hist.len()
    }

    /// Add every value recorded by `other`.
    pub fn merge(&mut self, other: &LatencyRecorder) {
        // Both histograms have the same bounds, so adding cannot fail; saturate just in case.
        if self.hist.add(&other.hist).is_err() {
            for v in other.hist.iter_recorded() {
                self.hist
                    .saturating_record_n(v.value_iterated_to(), v.count_at_value());
            }
        }
    }

    /// Latency at quantile `q` in [0, 1], in nanoseconds (0 if nothing was recorded).
    pub fn quantile_ns(&self, q: f64) -> u64 {
        if self.hist.is_empty() {
            0
        } else {
            self.hist.value_at_quantile(q)
        }
    }

    /// Latency at quantile `q` in [0, 1], in microseconds (0 if nothing was recorded).
    pub fn quantile_us(&self, q: f64) -> f64 {
        self.quantile_ns(q) as f64 / 1000.0
    }

    /// The summary row. `expected` is how many latencies should have been recorded; the
    /// difference is reported as lost.
    pub fn stats(
        &self,
        path: Path,
        mode: Mode,
        source: Source,
        expected: u64,
        payload_bytes: usize,
    ) -> PathStats {
        PathStats {
            path: path.name(),
            mode: mode.name(),
            count: self.count(),
            lost: expected.saturating_sub(self.count()),
            p50_us: self.quantile_us(0.5),
            p90_us: self.quantile_us(0.9),
            p99_us: self.quantile_us(0.99),
            p999_us: self.quantile_us(0.999),
            max_us: if self.hist.is_empty() {
                0.0
            } else {
                self.hist.max() as f64 / 1000.0
            },
            payload_bytes,
            source: source.name(),
        }
    }

    /// (quantile, latency in µs) points of the distribution for plotting, up to `max_nines`
    /// nines (3 = p99.9), with the max last.
    pub fn curve(&self, max_nines: f64, points: usize) -> Vec<(f64, f64)> {
        if self.hist.is_empty() {
            return Vec::new();
        }
        let mut curve: Vec<(f64, f64)> = (0..=points)
            .map(|i| {
                let nines = max_nines * i as f64 / points as f64;
                let q = 1.0 - 10f64.powf(-nines);
                (nines, self.quantile_us(q))
            })
            .collect();
        curve.push((max_nines + 0.5, self.hist.max() as f64 / 1000.0));
        curve
    }
}

/// One row of the report (and of `--json`): count, lost and percentiles of one path and mode.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PathStats {
    pub path: &'static str,
    pub mode: &'static str,
    pub count: u64,
    pub lost: u64,
    pub p50_us: f64,
    pub p90_us: f64,
    pub p99_us: f64,
    pub p999_us: f64,
    pub max_us: f64,
    /// Size of the payload on this path (raw rows exist per payload size).
    pub payload_bytes: usize,
    /// `services` (the real producer and predictor processes), `in-process` (the bench's own
    /// pipeline threads) or `raw` (transport ping-pong).
    pub source: &'static str,
}

impl PathStats {
    /// The percentiles in increasing order: p50, p90, p99, p99.9, max.
    pub fn percentiles(&self) -> [f64; 5] {
        [
            self.p50_us,
            self.p90_us,
            self.p99_us,
            self.p999_us,
            self.max_us,
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percentiles_of_a_uniform_ramp() {
        let mut r = LatencyRecorder::new();
        // 1..=1000 µs in 1 µs steps.
        for i in 1..=1000u64 {
            r.record_between(1_000_000, 1_000_000 + i * 1000);
        }
        let s = r.stats(Path::Iceoryx2Raw, Mode::Poll, Source::Raw, 1002, 72);
        assert_eq!((s.count, s.lost), (1000, 2));
        // 3 significant digits: within 0.1 %.
        for (got, want) in s
            .percentiles()
            .iter()
            .zip([500.0, 900.0, 990.0, 999.0, 1000.0])
        {
            assert!((got - want).abs() <= want * 1e-3, "{got} vs {want}");
        }
        assert!(s.percentiles().windows(2).all(|w| w[0] <= w[1]));
    }

    #[test]
    fn merge_adds_counts_and_clock_inversion_records_zero() {
        let mut a = LatencyRecorder::new();
        let mut b = LatencyRecorder::new();
        a.record_ns(10_000);
        b.record_ns(20_000);
        b.record_between(5, 3);
        a.merge(&b);
        assert_eq!(a.count(), 3);
        assert_eq!(a.quantile_ns(0.0), 0);
        assert!(
            (a.stats(Path::ZenohRaw, Mode::Event, Source::Raw, 3, 0)
                .max_us
                - 20.0)
                .abs()
                < 0.05
        );
        // Beyond the highest trackable value: clamped, not dropped.
        a.record_ns(u64::MAX);
        assert_eq!(a.count(), 4);
    }

    #[test]
    fn empty_recorder_reports_everything_lost() {
        let r = LatencyRecorder::new();
        let s = r.stats(
            Path::SampleToForecastZenoh,
            Mode::Event,
            Source::Services,
            7,
            0,
        );
        assert_eq!((s.count, s.lost, s.max_us), (0, 7, 0.0));
        assert!(r.curve(3.0, 10).is_empty());
    }
}
