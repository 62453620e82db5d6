//! RAO tables from seakeeping codes, in the CSV schema of the S175 table (tests/fixtures/s175):
//! `speed_mps,heading_deg,omega_rad_s,dof,amplitude,phase_rad`, one row per DOF of every
//! (speed, heading, wave frequency) of a full grid, headings in degrees with 180 = head seas.
//!
//! Interpolation is linear in the real and imaginary parts (never amplitude and phase, whose
//! unwrapping is arbitrary), over wave frequency and heading (headings wrap at 360 deg), then
//! linear between the two nearest tabulated speeds. Outside the tabulated frequency or speed
//! range the nearest edge value is used. `ScaledRaoTable` applies Froude scaling to a
//! geometrically similar hull of another length.

use super::hull::{MAX_LENGTH_M, MIN_LENGTH_M};
use super::rao::{Rao, Response};
use super::SimError;
use faer::c64;
use shipcast_wire::Dof;
use std::collections::HashMap;
use std::io::Read;
use std::path::Path;

const COLUMNS: [&str; 6] = [
    "speed_mps",
    "heading_deg",
    "omega_rad_s",
    "dof",
    "amplitude",
    "phase_rad",
];

/// Widest gap between tabulated headings that a heading inside it is interpolated across
/// without a warning [deg]: seakeeping tables step 10-30 deg; across 90 deg head and beam seas
/// would be mixed.
pub const MAX_HEADING_GAP_DEG: f64 = 90.0;

/// How far outside the tabulated speeds a speed may lie before the edge speed standing in is
/// reported [m/s] (0.1 kn: rounding of the knots given on the command line).
const SPEED_SLACK_MPS: f64 = 0.05;

/// A full grid of complex RAOs.
#[derive(Clone, Debug)]
pub struct RaoTable {
    speeds: Vec<f64>,
    headings_deg: Vec<f64>,
    omegas: Vec<f64>,
    /// Index `(s * headings + h) * omegas + w`.
    values: Vec<Response>,
}

/// Largest response amplitude a table may hold [m/m, rad/m]: ships' RAOs peak at about 1-2
/// m/m, and roll at resonance of a lightly damped hull at a few rad/m.
const MAX_RAO_AMPLITUDE: f64 = 100.0;

fn sorted_unique(mut v: Vec<f64>) -> Vec<f64> {
    v.sort_by(f64::total_cmp);
    v.dedup();
    v
}

/// Index of the interval [v[i], v[i+1]] holding x and the weight of v[i+1], clamped at the ends.
fn bracket(v: &[f64], x: f64) -> (usize, usize, f64) {
    if v.len() == 1 || x <= v[0] {
        return (0, 0, 0.0);
    }
    let last = v.len() - 1;
    if x >= v[last] {
        return (last, last, 0.0);
    }
    let hi = v.partition_point(|&e| e <= x);
    let lo = hi - 1;
    (lo, hi, (x - v[lo]) / (v[hi] - v[lo]))
}

fn lerp(a: &Response, b: &Response, t: f64) -> Response {
    std::array::from_fn(|j| a[j] * (1.0 - t) + b[j] * t)
}

/// Opens a table file; the error names it. Shared by the RAO table loaders.
pub(crate) fn open_table(path: &Path) -> Result<std::fs::File, SimError> {
    std::fs::File::open(path).map_err(|source| SimError::TableOpen {
        path: path.to_path_buf(),
        source,
    })
}

/// A trimming CSV reader and the index of each of `columns` in its header (any order, extra
/// columns ignored); errors name `source`. Shared by the RAO table loaders.
pub(crate) fn csv_with_columns<R: Read, const N: usize>(
    reader: R,
    columns: [&str; N],
    source: &str,
) -> Result<(csv::Reader<R>, [usize; N]), SimError> {
    let err = |msg: String| SimError::table(source, msg);
    let mut rdr = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .from_reader(reader);
    let headers = rdr
        .headers()
        .map_err(|e| SimError::table_csv(source, None, e))?
        .clone();
    let mut idx = [0usize; N];
    for (slot, name) in idx.iter_mut().zip(columns) {
        *slot = headers
            .iter()
            .position(|h| h == name)
            .ok_or_else(|| err(format!("missing column '{name}'")))?;
    }
    Ok((rdr, idx))
}

impl RaoTable {
    /// Loads a table from a CSV file.
    pub fn load(path: &Path) -> Result<Self, SimError> {
        let source = path.display().to_string();
        let mut bytes = Vec::new();
        open_table(path)?
            .read_to_end(&mut bytes)
            .map_err(|e| SimError::table(&source, format!("reading: {e}")))?;
        // Regression (review): a table cut inside its last number loaded, with that number
        // cut short (as a motion CSV would not).
        if !matches!(bytes.last(), Some(b'\n' | b'\r') | None) {
            return Err(SimError::table(
                &source,
                "the last row does not end with a line break, so the file may have been cut off inside it (if the file is complete, end it with a line break)".into(),
            ));
        }
        Self::from_reader(&bytes[..], &source)
    }

    /// Parses a table; `source` names it in error messages.
    pub fn from_reader(reader: impl Read, source: &str) -> Result<Self, SimError> {
        let err = |msg: String| SimError::table(source, msg);
        let (mut rdr, idx) = csv_with_columns(reader, COLUMNS, source)?;
        let mut rows: HashMap<[u64; 3], [Option<c64>; 6]> = HashMap::new();
        let (mut speeds, mut headings, mut omegas) = (Vec::new(), Vec::new(), Vec::new());
        for (i, rec) in rdr.records().enumerate() {
            let line = i + 2;
            let rec = rec.map_err(|e| SimError::table_csv(source, Some(line), e))?;
            let num = |c: usize| -> Result<f64, SimError> {
                let text = rec.get(idx[c]).unwrap_or("");
                let v: f64 = text.parse().map_err(|_| {
                    err(format!(
                        "line {line}, column {}: '{text}' is not a number",
                        COLUMNS[c]
                    ))
                })?;
                if v.is_finite() {
                    Ok(v)
                } else {
                    Err(err(format!(
                        "line {line}, column {}: non-finite value",
                        COLUMNS[c]
                    )))
                }
            };
            let (speed, heading, omega) = (num(0)?, num(1)?.rem_euclid(360.0), num(2)?);
            let (amp, phase) = (num(4)?, num(5)?);
            if speed < 0.0 || omega <= 0.0 || amp < 0.0 {
                return Err(err(format!(
                    "line {line}: speed and amplitude must be >= 0 and omega > 0"
                )));
            }
            // Regression (review): an amplitude of 1e200 simulated heave of 8.8e201 m.
            if amp > MAX_RAO_AMPLITUDE {
                return Err(err(format!(
                    "line {line}, column amplitude: {amp:e} per metre of wave amplitude is beyond {MAX_RAO_AMPLITUDE}, which no hull reaches (m/m for translations, rad/m for rotations: a unit error?)"
                )));
            }
            let dof_text = rec.get(idx[3]).unwrap_or("");
            let dof: Dof = dof_text
                .parse()
                .map_err(|e| err(format!("line {line}, column dof: {e}")))?;
            let slot = &mut rows
                .entry([speed.to_bits(), heading.to_bits(), omega.to_bits()])
                .or_default()[dof.index()];
            if slot.is_some() {
                return Err(err(format!("line {line}: duplicate row for {dof} at speed {speed}, heading {heading}, omega {omega}")));
            }
            *slot = Some(c64::new(amp * phase.cos(), amp * phase.sin()));
            speeds.push(speed);
            headings.push(heading);
            omegas.push(omega);
        }
        if rows.is_empty() {
            return Err(err("no data rows".into()));
        }
        let (speeds, headings_deg, omegas) = (
            sorted_unique(speeds),
            sorted_unique(headings),
            sorted_unique(omegas),
        );
        let mut values = Vec::with_capacity(speeds.len() * headings_deg.len() * omegas.len());
        for &s in &speeds {
            for &h in &headings_deg {
                for &w in &omegas {
                    let row = rows
                        .get(&[s.to_bits(), h.to_bits(), w.to_bits()])
                        .ok_or_else(|| {
                            err(format!(
                                "incomplete grid: no rows for speed {s}, heading {h}, omega {w}"
                            ))
                        })?;
                    let mut full = [c64::new(0.0, 0.0); 6];
                    for (j, v) in row.iter().enumerate() {
                        full[j] = v.ok_or_else(|| {
                            err(format!(
                                "incomplete grid: no {} at speed {s}, heading {h}, omega {w}",
                                Dof::ALL[j]
                            ))
                        })?;
                    }
                    values.push(full);
                }
            }
        }
        tracing::debug!(
            speeds = speeds.len(),
            headings = headings_deg.len(),
            omegas = omegas.len(),
            "RAO table loaded from {source}"
        );
        Ok(RaoTable {
            speeds,
            headings_deg,
            omegas,
            values,
        })
    }

    /// Tabulated speeds [m/s], ascending.
    pub fn speeds(&self) -> &[f64] {
        &self.speeds
    }

    /// Tabulated headings [deg] in [0, 360), ascending.
    pub fn headings_deg(&self) -> &[f64] {
        &self.headings_deg
    }

    /// Tabulated wave frequencies [rad/s], ascending.
    pub fn omegas(&self) -> &[f64] {
        &self.omegas
    }

    fn node(&self, s: usize, h: usize, w: usize) -> &Response {
        &self.values[(s * self.headings_deg.len() + h) * self.omegas.len() + w]
    }

    /// Interpolated at one tabulated speed index.
    fn at_speed_index(&self, s: usize, heading_deg: f64, omega: f64) -> Response {
        let (w0, w1, tw) = bracket(&self.omegas, omega);
        let hs = &self.headings_deg;
        let h = heading_deg.rem_euclid(360.0);
        // Headings wrap: the interval after the last heading closes at the first one + 360.
        let (h0, h1, th) = if hs.len() == 1 {
            (0, 0, 0.0)
        } else if h < hs[0] || h >= hs[hs.len() - 1] {
            let last = hs.len() - 1;
            let span = hs[0] + 360.0 - hs[last];
            let d = (h - hs[last]).rem_euclid(360.0);
            (last, 0, d / span)
        } else {
            bracket(hs, h)
        };
        let at_h = |hi: usize| lerp(self.node(s, hi, w0), self.node(s, hi, w1), tw);
        lerp(&at_h(h0), &at_h(h1), th)
    }

    /// Why the table cannot answer for `speed` [m/s] and `heading_deg` without standing in
    /// the nearest tabulated values: a speed outside its speeds (the edge speed's RAOs are
    /// used), or a heading between tabulated ones more than [`MAX_HEADING_GAP_DEG`] apart, or
    /// off the only one (interpolating across such a gap mixes, say, head and beam seas).
    pub fn coverage_gap(&self, speed: f64, heading_deg: f64) -> Option<String> {
        let (lo, hi) = (self.speeds[0], self.speeds[self.speeds.len() - 1]);
        let speed_gap = (speed < lo - SPEED_SLACK_MPS || speed > hi + SPEED_SLACK_MPS).then(|| {
            format!(
                "a speed of {speed:.2} m/s lies outside the table's {lo:.2}..{hi:.2} m/s: the RAOs of the nearest tabulated speed stand in"
            )
        });
        match (speed_gap, self.heading_gap(heading_deg)) {
            (Some(s), Some(h)) => Some(format!("{s}; {h}")),
            (s, h) => s.or(h),
        }
    }

    fn heading_gap(&self, heading_deg: f64) -> Option<String> {
        let h = heading_deg.rem_euclid(360.0);
        let hs = &self.headings_deg;
        let apart = |a: f64, b: f64| {
            let d = (a - b).rem_euclid(360.0);
            d.min(360.0 - d)
        };
        if hs.iter().any(|&x| apart(x, h) < 1e-6) {
            return None;
        }
        let last = hs.len() - 1;
        let (from, to, gap) = if hs.len() == 1 {
            (hs[0], hs[0], 360.0)
        } else if h < hs[0] || h > hs[last] {
            (hs[last], hs[0], hs[0] + 360.0 - hs[last])
        } else {
            let i = hs.partition_point(|&e| e <= h);
            (hs[i - 1], hs[i], hs[i] - hs[i - 1])
        };
        (gap > MAX_HEADING_GAP_DEG).then(|| {
            if hs.len() == 1 {
                format!(
                    "waves from {h:.0} deg: the table holds only {from:.0} deg, whose RAOs stand in"
                )
            } else {
                format!(
                    "waves from {h:.0} deg lie between the table's headings {from:.0} and {to:.0} deg, {gap:.0} deg apart: interpolated across that gap"
                )
            }
        })
    }

    /// Complex RAOs at any speed [m/s], heading [deg] (180 = head seas) and wave frequency.
    pub fn at(&self, speed: f64, heading_deg: f64, omega: f64) -> Response {
        let (s0, s1, ts) = bracket(&self.speeds, speed);
        let a = self.at_speed_index(s0, heading_deg, omega);
        if s0 == s1 {
            return a;
        }
        lerp(&a, &self.at_speed_index(s1, heading_deg, omega), ts)
    }
}

/// A table used for a geometrically similar hull of another length (Froude scaling): with
/// lambda = L / L_table, frequencies scale with 1/sqrt(lambda), speeds with sqrt(lambda),
/// translations per metre of wave are unchanged and rotations per metre scale with 1/lambda.
#[derive(Clone, Debug)]
pub struct ScaledRaoTable {
    table: std::sync::Arc<RaoTable>,
    lambda: f64,
}

impl ScaledRaoTable {
    /// `table_length_m`: the length the table was computed for; `hull_length_m`: the ship's.
    pub fn new(
        table: std::sync::Arc<RaoTable>,
        table_length_m: f64,
        hull_length_m: f64,
    ) -> Result<Self, SimError> {
        for (name, v) in [
            ("table length", table_length_m),
            ("hull length", hull_length_m),
        ] {
            if !(v.is_finite() && (MIN_LENGTH_M..=MAX_LENGTH_M).contains(&v)) {
                return Err(SimError::Config(format!(
                    "{name} must be in [{MIN_LENGTH_M}, {MAX_LENGTH_M}] m, got {v} m"
                )));
            }
        }
        Ok(ScaledRaoTable {
            table,
            lambda: hull_length_m / table_length_m,
        })
    }

    /// The table unscaled.
    pub fn unscaled(table: std::sync::Arc<RaoTable>) -> Self {
        ScaledRaoTable { table, lambda: 1.0 }
    }

    /// The underlying table.
    pub fn table(&self) -> &RaoTable {
        &self.table
    }
}

impl Rao for ScaledRaoTable {
    fn response(&self, omega: f64, beta: f64, speed: f64) -> Response {
        let root = self.lambda.sqrt();
        let mut h = self.table.at(speed / root, beta.to_degrees(), omega * root);
        for d in [Dof::Roll, Dof::Pitch, Dof::Yaw] {
            h[d.index()] /= self.lambda;
        }
        h
    }

    fn coverage_gap(&self, speed: f64, beta_deg: f64) -> Option<String> {
        // Froude scaling: the table's speed of this hull's `speed`, and the message says so.
        let at_table = speed / self.lambda.sqrt();
        let why = self.table.coverage_gap(at_table, beta_deg)?;
        Some(if self.lambda == 1.0 {
            why
        } else {
            format!("{why} (speeds at the table's scale: this hull's {speed:.2} m/s Froude-scaled)")
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tiny() -> String {
        // Two speeds, two headings (0 and 180), two frequencies; heave real part = speed + omega
        // + heading/180, everything else zero, so interpolation is checkable by hand.
        let mut s = String::from("speed_mps,heading_deg,omega_rad_s,dof,amplitude,phase_rad\n");
        for sp in [0.0, 2.0] {
            for hd in [0.0, 180.0] {
                for w in [0.5, 1.5] {
                    for d in Dof::ALL {
                        let amp = if d == Dof::Heave {
                            sp + w + hd / 180.0
                        } else {
                            0.0
                        };
                        s += &format!("{sp},{hd},{w},{d},{amp},0\n");
                    }
                }
            }
        }
        s
    }

    #[test]
    fn interpolates_linearly_and_wraps_headings() {
        let t = RaoTable::from_reader(tiny().as_bytes(), "tiny").unwrap();
        let heave = |s, h, w| t.at(s, h, w)[2].re;
        assert!((heave(1.0, 180.0, 1.0) - 3.0).abs() < 1e-12);
        assert!((heave(0.0, 90.0, 0.5) - 1.0).abs() < 1e-12);
        // 270 deg lies halfway between 180 and 360 = 0.
        assert!((heave(0.0, 270.0, 0.5) - 1.0).abs() < 1e-12);
        assert!((heave(0.0, -90.0, 0.5) - 1.0).abs() < 1e-12);
        // Clamped outside the frequency and speed ranges.
        assert!((heave(5.0, 0.0, 9.0) - 3.5).abs() < 1e-12);
    }

    /// Regression: a table cut to one speed or one heading was used far outside it without a
    /// word (60 kn on a 0 kn table; beam seas from a head-seas-only table gave no roll).
    #[test]
    fn what_the_table_does_not_cover_is_named() {
        let t = RaoTable::from_reader(tiny().as_bytes(), "tiny").unwrap();
        // Inside: on a heading node, between the speeds, a hair past the top speed.
        for (speed, heading) in [(1.0, 180.0), (0.0, 0.0), (2.04, -180.0), (1.0, 360.0)] {
            assert_eq!(t.coverage_gap(speed, heading), None, "{speed} {heading}");
        }
        let e = t.coverage_gap(31.0, 180.0).unwrap();
        assert!(
            e.contains("31.00 m/s") && e.contains("0.00..2.00 m/s"),
            "{e}"
        );
        assert!(t.coverage_gap(-1.0, 180.0).is_some());
        // Headings 0 and 180 only: 90 and 270 lie in gaps of 180 deg.
        for h in [90.0, 270.0, -45.0] {
            let e = t.coverage_gap(1.0, h).unwrap();
            assert!(e.contains("180 deg apart"), "{e}");
        }
        // A table of one heading covers that heading alone.
        let one: String = tiny()
            .lines()
            .filter(|l| l.starts_with("speed") || l.split(',').nth(1) == Some("180"))
            .map(|l| format!("{l}\n"))
            .collect();
        let t1 = RaoTable::from_reader(one.as_bytes(), "one").unwrap();
        assert_eq!(t1.headings_deg(), &[180.0]);
        assert_eq!(t1.coverage_gap(1.0, 180.0), None);
        let e = t1.coverage_gap(1.0, 90.0).unwrap();
        assert!(e.contains("only 180 deg"), "{e}");
        // Both at once are both named.
        let e = t1.coverage_gap(9.0, 90.0).unwrap();
        assert!(e.contains("9.00 m/s") && e.contains("only 180 deg"), "{e}");
        // A Froude-scaled table reports the table's speeds: 4 m/s on a quarter-length hull is
        // 8 m/s on the table's, outside 0..2.
        let scaled = ScaledRaoTable::new(std::sync::Arc::new(t), 100.0, 25.0).unwrap();
        assert!(scaled.coverage_gap(0.5, 180.0).is_none());
        let e = scaled.coverage_gap(4.0, 180.0).unwrap();
        assert!(
            e.contains("8.00 m/s") && e.contains("this hull's 4.00 m/s"),
            "{e}"
        );
    }

    #[test]
    fn froude_scaling_of_frequency_and_rotations() {
        let t = std::sync::Arc::new(RaoTable::from_reader(tiny().as_bytes(), "tiny").unwrap());
        let half = ScaledRaoTable::new(t.clone(), 100.0, 25.0).unwrap();
        // On a quarter-length hull, omega 2.0 corresponds to table omega 1.0.
        let a = half.response(2.0, std::f64::consts::PI, 0.0)[2].re;
        assert!((a - t.at(0.0, 180.0, 1.0)[2].re).abs() < 1e-12);
        assert!(ScaledRaoTable::new(t, 0.0, 25.0).is_err());
    }

    #[test]
    fn bad_tables_give_line_and_column() {
        let e = RaoTable::from_reader("speed_mps,heading_deg\n1,2\n".as_bytes(), "x").unwrap_err();
        assert!(
            e.to_string().contains("missing column 'omega_rad_s'"),
            "{e}"
        );
        let bad_num = tiny().replacen(",0.5,heave,", ",0.5,heave,abc", 1);
        let e = RaoTable::from_reader(bad_num.as_bytes(), "x")
            .unwrap_err()
            .to_string();
        assert!(e.contains("column amplitude") && e.contains("line "), "{e}");
        let text = tiny();
        let lines: Vec<&str> = text.lines().collect();
        let missing = lines[..lines.len() - 1].join("\n");
        let e = RaoTable::from_reader(missing.as_bytes(), "x")
            .unwrap_err()
            .to_string();
        assert!(e.contains("incomplete grid"), "{e}");
        let bad_dof = tiny().replacen("surge", "bob", 1);
        assert!(RaoTable::from_reader(bad_dof.as_bytes(), "x").is_err());
    }

    /// Regressions (review): an amplitude of 1e200 simulated heave of 8.8e201 m, and a file
    /// cut inside its last number loaded with that number cut short.
    #[test]
    fn absurd_amplitudes_and_a_table_cut_short_are_refused() {
        let huge = tiny();
        let row = huge.lines().find(|l| l.contains(",heave,")).unwrap();
        let fields: Vec<&str> = row.split(',').collect();
        let edited = format!(
            "{},{},{},{},1e200,{}",
            fields[0], fields[1], fields[2], fields[3], fields[5]
        );
        let e = RaoTable::from_reader(huge.replacen(row, &edited, 1).as_bytes(), "x")
            .unwrap_err()
            .to_string();
        assert!(e.contains("column amplitude: 1e200 per metre"), "{e}");
        let dir = tempfile::tempdir().unwrap();
        let whole = dir.path().join("whole.csv");
        std::fs::write(&whole, tiny()).unwrap();
        assert!(RaoTable::load(&whole).is_ok());
        let cut = dir.path().join("cut.csv");
        let text = tiny();
        std::fs::write(&cut, &text[..text.trim_end().len() - 1]).unwrap();
        let e = RaoTable::load(&cut).unwrap_err().to_string();
        assert!(e.contains("does not end with a line break"), "{e}");
    }
}
