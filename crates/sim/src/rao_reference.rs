//! Reference RAO curves to validate closed forms against: single-speed tables of a few DOF at a
//! few headings, in the CSV schema `omega_rad_s,heading_deg,dof,amplitude,phase_rad` (the
//! boundary-element solution of the DTMB 5415 in tests/fixtures/dtmb5415-bem), usable as an RAO
//! source of their own.
//!
//! Interpolation between the tabulated frequencies is linear in the real and imaginary parts, as
//! in [`super::rao_table`]; outside the tabulated range the edge value is used.

use super::rao::{Rao, Response};
use super::rao_table::{csv_with_columns, open_table};
use super::SimError;
use faer::c64;
use shipcast_wire::Dof;
use std::io::Read;
use std::path::Path;

const COLUMNS: [&str; 5] = [
    "omega_rad_s",
    "heading_deg",
    "dof",
    "amplitude",
    "phase_rad",
];

/// One tabulated curve: a DOF at a heading, ascending in wave frequency.
#[derive(Clone, Debug, PartialEq)]
pub struct ReferenceCurve {
    pub dof: Dof,
    pub heading_deg: f64,
    /// (omega [rad/s], complex RAO).
    pub points: Vec<(f64, c64)>,
}

impl ReferenceCurve {
    /// The complex RAO at `omega`, linear in real and imaginary parts, clamped at the ends.
    pub fn at(&self, omega: f64) -> c64 {
        let p = &self.points;
        let Some(first) = p.first() else {
            return c64::new(0.0, 0.0);
        };
        if omega <= first.0 {
            return first.1;
        }
        let hi = p.partition_point(|q| q.0 <= omega);
        if hi >= p.len() {
            return p[p.len() - 1].1;
        }
        let (w0, v0) = p[hi - 1];
        let (w1, v1) = p[hi];
        let t = (omega - w0) / (w1 - w0);
        v0 * (1.0 - t) + v1 * t
    }

    /// Largest tabulated amplitude.
    pub fn peak_amplitude(&self) -> f64 {
        self.points.iter().map(|p| p.1.norm()).fold(0.0, f64::max)
    }
}

/// All curves of a reference table.
#[derive(Clone, Debug, PartialEq)]
pub struct ReferenceRaos {
    pub curves: Vec<ReferenceCurve>,
}

impl ReferenceRaos {
    /// Loads a table from a CSV file.
    pub fn load(path: &Path) -> Result<Self, SimError> {
        Self::from_reader(open_table(path)?, &path.display().to_string())
    }

    /// Parses a table; `source` names it in error messages.
    pub fn from_reader(reader: impl Read, source: &str) -> Result<Self, SimError> {
        let err = |msg: String| SimError::table(source, msg);
        let (mut rdr, idx) = csv_with_columns(reader, COLUMNS, source)?;
        let mut curves: Vec<ReferenceCurve> = Vec::new();
        for (i, rec) in rdr.records().enumerate() {
            let line = i + 2;
            let rec = rec.map_err(|e| SimError::table_csv(source, Some(line), e))?;
            let num = |c: usize| -> Result<f64, SimError> {
                let text = rec.get(idx[c]).unwrap_or("");
                match text.parse::<f64>() {
                    Ok(v) if v.is_finite() => Ok(v),
                    _ => Err(err(format!(
                        "line {line}, column {}: '{text}' is not a finite number",
                        COLUMNS[c]
                    ))),
                }
            };
            let (omega, heading, amp, phase) = (num(0)?, num(1)?, num(3)?, num(4)?);
            if omega <= 0.0 || amp < 0.0 {
                return Err(err(format!(
                    "line {line}: omega must be > 0 and amplitude >= 0"
                )));
            }
            let dof: Dof = rec
                .get(idx[2])
                .unwrap_or("")
                .parse()
                .map_err(|e| err(format!("line {line}, column dof: {e}")))?;
            let value = c64::new(amp * phase.cos(), amp * phase.sin());
            match curves
                .iter_mut()
                .find(|c| c.dof == dof && c.heading_deg == heading)
            {
                Some(c) => c.points.push((omega, value)),
                None => curves.push(ReferenceCurve {
                    dof,
                    heading_deg: heading,
                    points: vec![(omega, value)],
                }),
            }
        }
        if curves.is_empty() {
            return Err(err("no data rows".into()));
        }
        for c in &mut curves {
            c.points.sort_by(|a, b| a.0.total_cmp(&b.0));
            if c.points.windows(2).any(|w| w[0].0 == w[1].0) {
                return Err(err(format!(
                    "duplicate frequency for {} at heading {}",
                    c.dof, c.heading_deg
                )));
            }
        }
        Ok(ReferenceRaos { curves })
    }

    /// The curve of `dof` at `heading_deg`, if tabulated.
    pub fn curve(&self, dof: Dof, heading_deg: f64) -> Result<&ReferenceCurve, SimError> {
        self.curves
            .iter()
            .find(|c| c.dof == dof && (c.heading_deg - heading_deg).abs() < 1e-9)
            .ok_or_else(|| {
                SimError::Config(format!(
                    "the reference table has no {dof} curve at heading {heading_deg} deg"
                ))
            })
    }
}

/// One reference curve used as an RAO source: its value in its DOF, zero elsewhere, whatever
/// the heading and speed (so use it only at its own heading and at zero speed). Passed to
/// [`super::ShipMotion::with_rao`] it gives the response the reference implies for the very
/// waves a simulation draws.
#[derive(Clone, Debug)]
pub struct CurveRao(pub ReferenceCurve);

impl Rao for CurveRao {
    fn response(&self, omega: f64, _beta: f64, _speed: f64) -> Response {
        let mut h = [c64::new(0.0, 0.0); 6];
        h[self.0.dof.index()] = self.0.at(omega);
        h
    }
}

/// Ratio of the simulated response std of `curve`'s DOF (the RAOs of `config`) to the std that
/// `curve` gives on the very same drawn waves. `config` should be long-crested at `curve`'s
/// heading and zero speed, where the reference holds.
pub fn std_ratio_on_same_waves(
    config: &super::SimConfig,
    curve: &ReferenceCurve,
) -> Result<f64, SimError> {
    let channel = super::Channel::Motion(curve.dof);
    let simulated = super::ShipMotion::new(config)?;
    let reference =
        super::ShipMotion::with_rao(config, std::sync::Arc::new(CurveRao(curve.clone())))?;
    let reference_var = reference.variance(channel);
    if reference_var.is_nan() || reference_var <= 0.0 {
        return Err(SimError::Config(format!(
            "the reference {} curve gives no response in this sea",
            curve.dof
        )));
    }
    Ok((simulated.variance(channel) / reference_var).sqrt())
}

/// The validation sea of docs/results/rao_validation.md: long-crested JONSWAP, gamma 3.3,
/// Hs 3.05 m, zero speed, at `curve`'s heading, closed-form RAOs of `hull`.
pub fn validation_sea(
    hull: super::Hull,
    curve: &ReferenceCurve,
    tp_s: f64,
    seed: u64,
) -> super::SimConfig {
    super::SimConfig {
        spectrum: super::SpectrumKind::Jonswap,
        hs_m: 3.05,
        tp_s,
        gamma: Some(3.3),
        speed_kn: 0.0,
        heading_deg: curve.heading_deg,
        spreading: super::Spreading::None,
        seed,
        rao: super::RaoSpec::ClosedForm { hull },
        ..super::SimConfig::default()
    }
}
