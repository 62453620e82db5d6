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
//! - [`bound`]: the optimal linear predictor from the exact autocorrelation.

pub mod bound;
pub mod figures;
pub mod paper_values;
pub mod plan;
pub mod seas;
pub mod tables;
