//! Motion time series: the motion CSV format ([`motion_csv`], docs/contracts.md section 2.3) and
//! the resampling every consumer of a record shares.
//!
//! Resampling motion records to the evaluation rate (docs/contracts.md section 4): a causal
//! anti-alias FIR low-pass filter followed by decimation by an integer factor.
//!
//! The same filter runs offline ([`decimate`], [`resample_motion`]) and live, sample by sample
//! ([`Decimator`], used by the predictor service for 8 -> 2 Hz), and the batch functions are the
//! streaming decimator run over the series, so evaluation and service see identical values.
//! The filter, its delay and its attenuation are documented on [`fir::design_lowpass`].
//!
//! [`atomic_file`] writes the files a run leaves for later runs (model files, the deck's
//! statements) so that a failed write never destroys the old one.

pub mod atomic_file;
pub mod decimator;
pub mod fir;
pub mod median;
pub mod motion_csv;
pub mod resample;
pub mod spikes;

pub use decimator::{decimate, decimate_with, decimated_len, decimation_inputs_for, Decimator};
pub use fir::FilterPhase;
pub use resample::{
    check_runs_on_grid, decimation_factor, gap_free_runs, median_rate, regular_step_tolerance,
    resample_motion, sample_rate, ResampleError, RATE_TOLERANCE,
};
