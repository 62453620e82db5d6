//! Markdown tables: a small builder and the number formats the report uses.

use super::seas::STUDY_RATE_HZ;
use super::study::Failure;
use std::fmt::Write;

/// A Markdown table: a header row and body rows of the same width. Cells are plain text; a `|`
/// inside a cell is escaped so it cannot break the row.
#[derive(Clone, Debug, Default)]
pub struct Table {
    header: Vec<String>,
    rows: Vec<Vec<String>>,
}

impl Table {
    pub fn new<S: AsRef<str>>(header: &[S]) -> Self {
        Self {
            header: header.iter().map(|s| s.as_ref().to_string()).collect(),
            rows: Vec::new(),
        }
    }

    /// Append a row; short rows are padded with empty cells, long rows are cut to the header.
    pub fn row(&mut self, cells: Vec<String>) -> &mut Self {
        let mut cells = cells;
        cells.resize(self.header.len(), String::new());
        self.rows.push(cells);
        self
    }

    pub fn len(&self) -> usize {
        self.rows.len()
    }

    pub fn is_empty(&self) -> bool {
        self.rows.is_empty()
    }

    /// The table as Markdown, first column left-aligned, the others right-aligned (numbers).
    pub fn to_markdown(&self) -> String {
        let mut s = String::new();
        push_row(&mut s, &self.header);
        let rule: Vec<String> = (0..self.header.len())
            .map(|i| if i == 0 { ":---" } else { "---:" }.to_string())
            .collect();
        push_row(&mut s, &rule);
        for r in &self.rows {
            push_row(&mut s, r);
        }
        s
    }
}

fn push_row(s: &mut String, cells: &[String]) {
    s.push('|');
    for c in cells {
        let _ = write!(s, " {} |", c.replace('|', "\\|"));
    }
    s.push('\n');
}

/// A value with `sig` significant digits in plain notation (no exponent), so every number in
/// the report reads the same way. Non-finite values are written as Rust prints them ("NaN",
/// "inf") on purpose: the report test looks for them, and a failed computation must show.
pub fn num(v: f64, sig: usize) -> String {
    if !v.is_finite() {
        return format!("{v}");
    }
    if v == 0.0 {
        return "0".to_string();
    }
    let magnitude = v.abs().log10().floor() as i64;
    let decimals = (sig as i64 - 1 - magnitude).clamp(0, 12) as usize;
    format!("{v:.decimals$}")
}

/// A duration in seconds with a unit suited to its size (us, ms or s).
pub fn seconds(v: f64) -> String {
    if !v.is_finite() {
        return format!("{v} s");
    }
    if v < 1e-3 {
        format!("{} us", num(v * 1e6, 3))
    } else if v < 1.0 {
        format!("{} ms", num(v * 1e3, 3))
    } else {
        format!("{} s", num(v, 3))
    }
}

/// A ratio such as a speed-up, "1234x".
pub fn ratio(v: f64) -> String {
    format!("{}x", num(v, 3))
}

/// Time step of the study rate [s].
pub const DT_S: f64 = 1.0 / STUDY_RATE_HZ;

pub fn lead_s(step: usize) -> f64 {
    step as f64 * DT_S
}

/// A cell: the number, or why there is none (infeasible MCA, failed fit).
pub fn cell(v: Result<f64, impl Into<Failure>>, sig: usize) -> String {
    match v.map_err(Into::into) {
        Ok(v) => num(v, sig),
        Err(Failure::Infeasible(_)) => "infeasible (H >= n)".into(),
        // The predictor's validation rejected every candidate (each map beyond its size
        // bound or unusable): a designed outcome, not a crash.
        Err(Failure::NoUsableCandidate(_)) => "no candidate passed validation".into(),
        Err(Failure::Other(e)) => format!("failed: {}", e.chars().take(80).collect::<String>()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn markdown_has_header_rule_and_padded_rows() {
        let mut t = Table::new(&["method", "rms"]);
        t.row(vec!["mca".into(), "0.1".into()]);
        t.row(vec!["a|b".into()]);
        assert_eq!(
            t.to_markdown(),
            "| method | rms |\n| :--- | ---: |\n| mca | 0.1 |\n| a\\|b |  |\n"
        );
        assert_eq!(t.len(), 2);
    }

    #[test]
    fn numbers_keep_significant_digits_without_exponent() {
        assert_eq!(num(0.056123, 3), "0.0561");
        assert_eq!(num(1234.56, 3), "1235");
        assert_eq!(num(-2.5, 2), "-2.5");
        assert_eq!(num(0.0, 3), "0");
        assert_eq!(num(f64::NAN, 3), "NaN");
        assert_eq!(num(f64::INFINITY, 3), "inf");
    }

    #[test]
    fn durations_pick_a_readable_unit() {
        assert_eq!(seconds(2.5e-6), "2.50 us");
        assert_eq!(seconds(0.0123), "12.3 ms");
        assert_eq!(seconds(40.0), "40.0 s");
        assert_eq!(ratio(123.4), "123x");
    }
}
