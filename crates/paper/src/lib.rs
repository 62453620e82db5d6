//! The paper study behind `shipcast paper`: regenerates Tables 1-3 and the figures of Zhao, Xu
//! and Kwan on the simulated destroyer, with the context the paper lacks (skill against
//! persistence and zero, the optimal linear predictor from the exact autocorrelation as a bound,
//! a line-spectrum sea against a realistic dense sea).
//!
//! - [`paper_values`]: the paper's published numbers.
//! - [`tables`]: Markdown tables and number formats.
//! - [`figures`]: SVG line charts.
//! - [`plan`]: the sizes of a full or quick run.
//! - [`seas`]: the simulated seas at 2 Hz with their exact autocorrelation.
//! - [`study`]: runs the experiments.
//! - [`skill`]: crossing times and whole-horizon error of an error curve.
//! - [`plots`]: the study's figures.
//! - [`report`]: writes report.md.
//! - [`bound`]: the optimal linear predictor from the exact autocorrelation.
//! - [`variant`]: the MCA settings compared (paper, improvements, eigenvalue weighting).
//! - [`improvements`]: the report's section on those settings.
//! - [`averaging`]: the paper's averaged forecasts (mean of several predictions of one point).
//! - [`measured`]: the methods and the engine on a measured-sea record.

pub mod averaging;
pub mod bound;
pub mod figures;
pub mod improvements;
pub mod measured;
pub mod paper_values;
pub mod plan;
pub mod plots;
pub mod report;
pub mod seas;
pub mod skill;
pub mod study;
pub mod tables;
pub mod variant;

pub use plan::Plan;
pub use study::{run, run_with, NoProgress, Progress, Study};
