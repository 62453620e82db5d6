//! The numbers Zhao, Xu and Kwan published, quoted next to ours in the report.
//!
//! Only what the paper prints is here. Its Table 1 (RMS error per method, order and horizon) is
//! not available to us, so the report says so instead of quoting made-up values.

/// A published range `low..=high`; a single figure has `low == high`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Range {
    pub low: f64,
    pub high: f64,
}

impl Range {
    const fn one(v: f64) -> Self {
        Range { low: v, high: v }
    }
    const fn span(low: f64, high: f64) -> Self {
        Range { low, high }
    }
}

/// One row of the paper's Table 2 (MATLAB on a 1.6 GHz Pentium, order 800). The ranges cover
/// the 10- and 40-point predictions; we assume the low figure belongs to 10 points (every
/// method does more work for more steps), and the report says so.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PaperTiming {
    pub method: &'static str,
    /// Training time [s]; `None` for the Wiener predictor, which the paper did not train.
    pub train_s: Option<Range>,
    /// Time for 500 predictions [s].
    pub predict_500_s: Range,
}

/// The paper's Table 2, in the order MCA, NN, AR, Wiener.
pub const TABLE2: [PaperTiming; 4] = [
    PaperTiming {
        method: "mca",
        train_s: Some(Range::one(40.0)),
        predict_500_s: Range::one(0.09),
    },
    PaperTiming {
        method: "mlp",
        train_s: Some(Range::span(1735.0, 3467.0)),
        predict_500_s: Range::span(3.4, 3.7),
    },
    PaperTiming {
        method: "ar",
        train_s: Some(Range::span(11.0, 47.0)),
        predict_500_s: Range::span(1.6, 6.4),
    },
    PaperTiming {
        method: "wiener",
        train_s: None,
        predict_500_s: Range::span(843.0, 1054.0),
    },
];

/// Noise levels of the paper's Table 3, percent of the peak amplitude.
pub const TABLE3_NOISE_PCT: [f64; 3] = [0.0, 10.0, 20.0];
/// The paper's Table 3: heave RMS error [m] of AR-800 at those noise levels.
pub const TABLE3_AR_M: [f64; 3] = [0.14, 0.31, 0.55];
/// The paper's Table 3: heave RMS error [m] of MCA-800 at those noise levels.
pub const TABLE3_MCA_M: [f64; 3] = [0.056, 0.24, 0.51];

/// Orders of the paper's Table 1.
pub const TABLE1_ORDERS: [usize; 3] = [40, 100, 800];
/// Lead times of the paper's Table 1 in steps at 2 Hz: 0.5 s, 5 s and 20 s.
pub const TABLE1_STEPS: [usize; 3] = [1, 10, 40];
/// Prediction lengths of the paper's Table 2, in steps.
pub const TABLE2_STEPS: [usize; 2] = [10, 40];
/// Number of predictions timed in the paper's Table 2.
pub const TABLE2_PREDICTIONS: usize = 500;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn published_ranges_are_ordered_and_positive() {
        for t in TABLE2 {
            for r in t.train_s.into_iter().chain([t.predict_500_s]) {
                assert!(r.low > 0.0 && r.low <= r.high, "{}: {r:?}", t.method);
            }
        }
        // Noise makes both methods worse in the paper, and MCA beats AR at every level.
        for i in 0..3 {
            assert!(TABLE3_MCA_M[i] < TABLE3_AR_M[i]);
            if i > 0 {
                assert!(TABLE3_AR_M[i] > TABLE3_AR_M[i - 1]);
                assert!(TABLE3_MCA_M[i] > TABLE3_MCA_M[i - 1]);
            }
        }
    }
}
