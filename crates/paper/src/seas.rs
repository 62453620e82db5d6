//! The two seas of the study, simulated at the paper's 8 Hz and decimated to 2 Hz with the
//! evaluation's own anti-alias filter, with the exact autocorrelation of each decimated DOF.

use super::bound::filtered_autocorrelation;
use anyhow::Context;
use shipcast_series::{decimate, decimation_factor, fir::design_lowpass};
use shipcast_sim::{ShipMotion, SimConfig};
use shipcast_wire::Dof;

/// Which sea a job runs on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SeaKind {
    /// The paper scenario with the simulator's default dense, randomised spectrum.
    Dense,
    /// The paper scenario as a line spectrum of few components on a fixed grid.
    Line,
    /// Another realisation of the dense sea (seed + 1), for testing only: the model is fitted
    /// on the training segment of [`SeaKind::Dense`] and scored here at every origin (stride
    /// 1); the bound is this realisation's own.
    OtherRealisation,
}

/// Rate of the simulated record, as in the paper [Hz].
pub const RECORD_RATE_HZ: f64 = 8.0;
/// Rate the predictors work at [Hz].
pub const STUDY_RATE_HZ: f64 = 2.0;

/// A simulated sea at the study rate.
pub struct Sea {
    /// Short name used in file names ("dense", "line").
    pub key: &'static str,
    /// What the report calls it.
    pub title: String,
    pub motion: ShipMotion,
    /// 2 Hz series per DOF (index = `Dof::index`), all of the same length.
    series: Vec<Vec<f64>>,
    factor: usize,
}

impl Sea {
    /// Simulate `config` for `len` values at 2 Hz (plus the filter's warm-up at 8 Hz).
    pub fn simulate(
        key: &'static str,
        title: String,
        config: &SimConfig,
        len: usize,
    ) -> anyhow::Result<Self> {
        let motion = ShipMotion::new(config).context("building the simulated sea")?;
        let factor = decimation_factor(RECORD_RATE_HZ, STUDY_RATE_HZ)?;
        // The decimator's first output needs one full filter length of input.
        let raw_len = len * factor + design_lowpass(factor).len();
        let mut raw: Vec<Vec<f64>> = vec![Vec::with_capacity(raw_len); Dof::ALL.len()];
        for p in motion.stream(RECORD_RATE_HZ, 0.0)?.take(raw_len) {
            for (column, v) in raw.iter_mut().zip(p.dof) {
                column.push(v);
            }
        }
        let mut series = Vec::with_capacity(raw.len());
        for column in &raw {
            let mut d = decimate(column, factor)?;
            anyhow::ensure!(
                d.len() >= len,
                "decimation gave {} values, {len} needed",
                d.len()
            );
            d.truncate(len);
            series.push(d);
        }
        Ok(Self {
            key,
            title,
            motion,
            series,
            factor,
        })
    }

    pub fn series(&self, dof: Dof) -> &[f64] {
        &self.series[dof.index()]
    }

    pub fn len(&self) -> usize {
        self.series.first().map_or(0, Vec::len)
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Number of wave components drawn.
    pub fn components(&self) -> usize {
        self.motion.components().len()
    }

    /// Exact autocorrelation of the decimated series of `dof` for 2 Hz lags `0..lags`: the
    /// simulator's exact autocorrelation at 8 Hz passed through the decimation filter.
    pub fn autocorrelation(&self, dof: Dof, lags: usize) -> anyhow::Result<Vec<f64>> {
        let taps = design_lowpass(self.factor);
        let max_lag = lags.saturating_sub(1) * self.factor + taps.len();
        let r_in = self
            .motion
            .autocorrelation(dof, 1.0 / RECORD_RATE_HZ, max_lag);
        filtered_autocorrelation(&r_in, &taps, self.factor, lags).map_err(anyhow::Error::msg)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The exact filtered autocorrelation must describe the decimated record: its lag-0 value
    /// is the variance, which a long record's sample variance matches within a few percent.
    #[test]
    fn exact_variance_matches_the_decimated_record() {
        let sea = Sea::simulate("dense", "test".into(), &SimConfig::default(), 6000).unwrap();
        assert_eq!(sea.len(), 6000);
        for dof in [Dof::Heave, Dof::Pitch, Dof::Roll] {
            let x = sea.series(dof);
            let var = x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64;
            let r = sea.autocorrelation(dof, 30).unwrap();
            assert!(
                (var / r[0] - 1.0).abs() < 0.1,
                "{dof:?}: record variance {var}, exact {}",
                r[0]
            );
            // Lag 1 (0.5 s) of a motion with a ~10 s period stays strongly correlated.
            assert!(r[1] > 0.5 * r[0] && r[1] < r[0], "{dof:?}: {r:?}");
        }
    }
}
