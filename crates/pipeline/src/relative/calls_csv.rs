//! The lift calls of a two-ship study as CSV (`shipcast relative --calls-csv`): what each call
//! stated and what then happened, step by step, so that a decision can be audited and the
//! statements re-derived offline (scripts/lift_window_diagnosis.py does).
//!
//! One row per call: `time_s, stated, uncorrected, gaussian, held, ensemble_members`, then for
//! each axis (x, y, z of the crane vessel) and each step k = 1..=W of the window of MOT:
//! `mean_<axis>_<k>`, `sigma_<axis>_<k>`, `actual_<axis>_<k>` (the true relative
//! displacement). The mean and sigma are those the lift decided on: the raw difference of the
//! two forecasts and its sigma (`RelativeTrack::raw_mean`, `raw_sigma`). A statement that was
//! not made is an empty cell.

use super::study::LiftCall;
use super::AXES;
use std::io::{self, Write};

/// Writes [`LiftCall`]s as CSV rows; the header comes with the first call (it names the
/// window's steps).
#[derive(Debug)]
pub struct LiftCallsCsv<W: Write> {
    out: W,
    window: Option<usize>,
    rows: u64,
}

impl<W: Write> LiftCallsCsv<W> {
    pub fn new(out: W) -> Self {
        Self {
            out,
            window: None,
            rows: 0,
        }
    }

    pub fn write(&mut self, call: &LiftCall) -> io::Result<()> {
        let window = *self.window.get_or_insert(call.window);
        // The window is the configured MOT over the forecast step: one per study.
        if call.window != window || call.actual.len() < window || call.track.steps() < window {
            return Err(io::Error::new(
                io::ErrorKind::InvalidData,
                format!(
                    "lift call at {} s: window of {} steps, {} actual and {} forecast steps, the file's window {window}",
                    call.time_s,
                    call.window,
                    call.actual.len(),
                    call.track.steps()
                ),
            ));
        }
        if self.rows == 0 {
            write!(
                self.out,
                "time_s,stated,uncorrected,gaussian,held,ensemble_members"
            )?;
            for axis in AXES {
                for k in 1..=window {
                    write!(
                        self.out,
                        ",mean_{axis}_{k},sigma_{axis}_{k},actual_{axis}_{k}"
                    )?;
                }
            }
            writeln!(self.out)?;
        }
        let cell = |v: Option<f64>| v.map_or(String::new(), |p| p.to_string());
        write!(
            self.out,
            "{},{},{},{},{},{}",
            call.time_s,
            call.stated,
            cell(call.uncorrected),
            cell(call.gaussian),
            u8::from(call.held),
            call.ensemble_members
        )?;
        for axis in 0..AXES.len() {
            for k in 0..window {
                write!(
                    self.out,
                    ",{},{},{}",
                    call.track.raw_mean[axis][k],
                    call.track.raw_sigma[axis][k],
                    call.actual[k][axis]
                )?;
            }
        }
        writeln!(self.out)?;
        self.rows += 1;
        Ok(())
    }

    /// Flushes; the writer and the number of calls written.
    pub fn finish(mut self) -> io::Result<(W, u64)> {
        self.out.flush()?;
        Ok((self.out, self.rows))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::relative::RelativeTrack;

    fn track() -> RelativeTrack {
        let mut t = RelativeTrack::default();
        t.alignment.steps = 3;
        t.dt_s = 0.5;
        for axis in 0..3 {
            for k in 0..3 {
                t.raw_mean[axis][k] = 0.1 * (axis * 10 + k) as f64;
                t.raw_sigma[axis][k] = 0.25;
            }
        }
        t
    }

    #[test]
    fn each_call_is_one_row_under_a_header_naming_the_window_steps() {
        let t = track();
        let actual = [[1.5, -0.5, 0.25], [2.0, 0.0, -1.0], [9.0, 9.0, 9.0]];
        let call = LiftCall {
            time_s: 12.5,
            stated: 0.75,
            uncorrected: Some(0.8),
            gaussian: None,
            held: false,
            ensemble_members: 150,
            window: 2,
            track: &t,
            actual: &actual,
        };
        let mut csv = LiftCallsCsv::new(Vec::new());
        csv.write(&call).unwrap();
        csv.write(&LiftCall { held: true, ..call }).unwrap();
        let (out, rows) = csv.finish().unwrap();
        assert_eq!(rows, 2);
        let out = String::from_utf8(out).unwrap();
        let lines: Vec<&str> = out.lines().collect();
        assert_eq!(lines.len(), 3);
        let header: Vec<&str> = lines[0].split(',').collect();
        assert_eq!(header.len(), 6 + 3 * 2 * 3);
        assert_eq!(header[6..9], ["mean_x_1", "sigma_x_1", "actual_x_1"]);
        assert_eq!(header[header.len() - 1], "actual_z_2");
        let row: Vec<&str> = lines[1].split(',').collect();
        assert_eq!(row.len(), header.len());
        assert_eq!(row[..6], ["12.5", "0.75", "0.8", "", "0", "150"]);
        // z at step 2: the track's mean (axis 2, step 1), sigma, and the record's -1.0.
        let at = |name: &str| row[header.iter().position(|h| *h == name).unwrap()];
        let mean: f64 = at("mean_z_2").parse().unwrap();
        assert_eq!(mean, t.raw_mean[2][1]);
        assert_eq!(at("sigma_z_2"), "0.25");
        assert_eq!(at("actual_z_2"), "-1");
        assert_eq!(at("actual_y_1"), "-0.5");
        assert!(lines[2].split(',').nth(4) == Some("1"));
        // A call whose window does not match the file's is refused, not written.
        let mut csv = LiftCallsCsv::new(Vec::new());
        csv.write(&call).unwrap();
        let e = csv
            .write(&LiftCall { window: 3, ..call })
            .unwrap_err()
            .to_string();
        assert!(e.contains("window of 3 steps"), "{e}");
        let short = LiftCall {
            actual: &actual[..1],
            ..call
        };
        assert!(LiftCallsCsv::new(Vec::new()).write(&short).is_err());
    }
}
