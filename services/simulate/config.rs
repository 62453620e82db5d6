//! The validated configuration of `shipcast simulate`: [`Config::try_from`] turns the raw
//! [`Args`] into checked values (ranges, the scenario and its overrides, the changes, the
//! output directory of the figure) before anything is simulated.

use super::Args;
use crate::checked;
use anyhow::Context;
use shipcast_pipeline::config::MAX_PRODUCER_RATE_HZ;
use shipcast_pipeline::limits;
use shipcast_sim::{
    CourseChange, Hull, RaoSpec, Scenario, SeaChange, SimConfig, Spectrum, Station,
};
use std::path::PathBuf;

/// Seconds at each end of a measured record's segment that are tapered and not written
/// (`--edge-s`).
pub const DEFAULT_EDGE_S: f64 = 120.0;
/// Duration of a course change's turn (`--turn-s`).
pub const DEFAULT_TURN_S: f64 = 60.0;
/// Duration of a sea-state change's cross-fade (`--ramp-s`).
pub const DEFAULT_RAMP_S: f64 = 300.0;

/// What `simulate` writes, every value checked: built from [`Args`] by [`Config::try_from`],
/// the only place that validates them, so the writers below see checked values only.
#[derive(Debug, Clone)]
pub struct Config {
    /// The sea, the ship and its RAOs (checked with `SimConfig::validate`).
    pub sim: SimConfig,
    /// Output sample rate [Hz].
    pub rate_hz: f64,
    /// Output motion CSV.
    pub out: PathBuf,
    /// What drives the ship.
    pub record: Record,
    /// SVG overview to draw (stationary records only); its directory exists.
    pub plot: Option<PathBuf>,
}

/// The three kinds of record `simulate` writes.
#[derive(Debug, Clone, PartialEq)]
pub enum Record {
    /// A stationary simulated sea of `duration_s`, seen by a vessel at `station` (the
    /// reference vessel by default).
    Stationary { duration_s: f64, station: Station },
    /// A simulated sea with a course and/or a sea-state change (at least one).
    Changing {
        duration_s: f64,
        course: Option<CourseChange>,
        sea: Option<SeaChange>,
    },
    /// The ship driven by a measured elevation record.
    Measured {
        elevation: PathBuf,
        edge_s: f64,
        /// Where the simulated vessel is relative to the record's CG.
        station: Station,
    },
}

/// Most rows one record may have (about 10 GB of CSV).
pub(super) const MAX_ROWS: u64 = 100_000_000;

impl TryFrom<Args> for Config {
    type Error = anyhow::Error;

    fn try_from(args: Args) -> anyhow::Result<Self> {
        // clap's `requires` lets it through when a flag that conflicts with --elevation is
        // given too (--duration): an option that does nothing must not pass in silence.
        if args.edge_s.is_some() && args.elevation.is_none() {
            anyhow::bail!("--edge-s applies to --elevation only");
        }
        // Regression (review): these were taken, even negative, and did nothing.
        if args.turn_s.is_some() && args.course_change_s.is_none() {
            anyhow::bail!("--turn-s applies to a course change (--course-change-s) only");
        }
        if args.ramp_s.is_some() && args.sea_change_s.is_none() {
            anyhow::bail!("--ramp-s applies to a sea-state change (--sea-change-s) only");
        }
        if args.gamma.is_some() && args.spectrum.trim().eq_ignore_ascii_case("ittc") {
            anyhow::bail!("--gamma applies to --spectrum jonswap only");
        }
        // Regression (review): --rate 0.01 wrote a record every reader refuses (eval and replay
        // take no step longer than MAX_STEP_S, and replay said the 100 s step looked like
        // milliseconds).
        let rate_hz = checked(limits::in_range(
            "--rate",
            args.rate,
            1.0 / shipcast_series::resample::MAX_STEP_S,
            MAX_PRODUCER_RATE_HZ,
        ))?;
        let record = match &args.elevation {
            Some(elevation) => Record::Measured {
                elevation: {
                    crate::output_not_input("--out", &args.out, "--elevation", elevation)?;
                    if let Some(svg) = &args.plot {
                        crate::output_not_input("--plot", svg, "--elevation", elevation)?;
                    }
                    elevation.clone()
                },
                edge_s: checked(limits::non_negative(
                    "--edge-s",
                    args.edge_s.unwrap_or(DEFAULT_EDGE_S),
                    limits::MAX_SECONDS,
                ))?,
                station: station(&args)?,
            },
            None => {
                let duration_s = checked(limits::positive(
                    "--duration",
                    args.duration,
                    limits::MAX_SECONDS,
                ))?;
                // Checked before the sea is built: a record of billions of rows would run for
                // days.
                let rows = duration_s * rate_hz;
                if rows > MAX_ROWS as f64 {
                    anyhow::bail!("--duration x --rate = {rows:.0} rows, at most {MAX_ROWS}");
                }
                changes(&args, duration_s)?
            }
        };
        let sim = sim_config(&args)?;
        sim.validate()?;
        if !matches!(record, Record::Measured { .. }) {
            Spectrum::new(sim.spectrum, sim.hs_m, sim.tp_s, sim.gamma)?;
        }
        if let Record::Changing { sea: Some(s), .. } = &record {
            // The new sea has the same spectrum family (a JONSWAP with the DNV gamma; see
            // AFTER_HELP), within the ranges of any simulated sea.
            Spectrum::new(sim.spectrum, s.hs_m, s.tp_s, None).context("--new-hs/--new-tp")?;
            shipcast_sim::ChangingMotion::new_sea_config(&sim, s)
                .validate()
                .context("--new-hs/--new-tp")?;
        }
        if let Some(svg) = &args.plot {
            // Checked now: the figure is drawn after the whole record is written.
            crate::output_in_existing_dir("--plot", svg)?;
            crate::outputs_differ("--plot", svg, "--out", &args.out)?;
        }
        if let Some(table) = &args.rao_table {
            // Regression (review): `--rao-table x.csv --out x.csv` replaced the table.
            crate::output_not_input("--out", &args.out, "--rao-table", table)?;
            if let Some(svg) = &args.plot {
                crate::output_not_input("--plot", svg, "--rao-table", table)?;
            }
        }
        Ok(Config {
            sim,
            rate_hz,
            out: args.out,
            record,
            plot: args.plot,
        })
    }
}

/// The course and sea-state changes of a simulated record (clap enforces that each comes with
/// its companion options).
fn changes(args: &Args, duration_s: f64) -> anyhow::Result<Record> {
    let seconds = |name: &str, v: f64| checked(limits::non_negative(name, v, limits::MAX_SECONDS));
    let course = match (args.course_change_s, args.new_heading_deg) {
        (Some(at_s), Some(new_heading_deg)) => {
            Some(CourseChange {
                at_s: seconds("--course-change-s", at_s)?,
                new_heading_deg: if new_heading_deg.is_finite() {
                    new_heading_deg
                } else {
                    anyhow::bail!("--new-heading-deg must be a finite number of degrees, got {new_heading_deg}")
                },
                turn_s: seconds("--turn-s", args.turn_s.unwrap_or(DEFAULT_TURN_S))?,
            })
        }
        _ => None,
    };
    let sea = match (args.sea_change_s, args.new_hs, args.new_tp) {
        (Some(at_s), Some(hs_m), Some(tp_s)) => Some(SeaChange {
            at_s: seconds("--sea-change-s", at_s)?,
            hs_m,
            tp_s,
            ramp_s: seconds("--ramp-s", args.ramp_s.unwrap_or(DEFAULT_RAMP_S))?,
        }),
        _ => None,
    };
    Ok(if course.is_some() || sea.is_some() {
        Record::Changing {
            duration_s,
            course,
            sea,
        }
    } else {
        Record::Stationary {
            duration_s,
            station: station(args)?,
        }
    })
}

/// The simulator configuration the arguments describe: the scenario with the options that
/// override it.
/// The simulated vessel's place relative to the reference vessel (or the record's CG).
fn station(args: &Args) -> anyhow::Result<Station> {
    let station = Station {
        x_m: args.vessel_x_m,
        y_m: args.vessel_y_m,
        heading_offset_deg: args.vessel_heading_offset_deg,
    };
    station.validate()?;
    Ok(station)
}

fn sim_config(args: &Args) -> anyhow::Result<SimConfig> {
    let scenario: Scenario = args.scenario.parse()?;
    let mut cfg = SimConfig::scenario(scenario);
    cfg.spectrum = args.spectrum.parse()?;
    cfg.spreading = args.spreading.parse()?;
    cfg.hs_m = args.hs.unwrap_or(cfg.hs_m);
    cfg.tp_s = args.tp.unwrap_or(cfg.tp_s);
    cfg.gamma = args.gamma;
    cfg.speed_kn = args.speed_kn.unwrap_or(cfg.speed_kn);
    cfg.heading_deg = args.heading_deg.unwrap_or(cfg.heading_deg);
    cfg.components = args.components;
    cfg.seed = args.seed;
    cfg.rao = match (&args.rao_table, args.rao_table_length, args.hull_length) {
        (Some(_), None, Some(_)) => {
            anyhow::bail!("--hull-length with --rao-table needs --rao-table-length (the length the table was computed for)")
        }
        (Some(_), Some(_), None) => {
            anyhow::bail!(
                "--rao-table-length needs --hull-length (the length to scale the table to)"
            )
        }
        (Some(path), table_length_m, hull_length_m) => RaoSpec::Table {
            path: path.clone(),
            table_length_m,
            hull_length_m,
        },
        (None, Some(_), _) => anyhow::bail!("--rao-table-length needs --rao-table"),
        (None, None, Some(l)) => RaoSpec::ClosedForm {
            hull: Hull::dtmb5415().scaled_to_length(l)?,
        },
        (None, None, None) => RaoSpec::ClosedForm {
            hull: Hull::dtmb5415(),
        },
    };
    Ok(cfg)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn config(argv: &[&str]) -> anyhow::Result<Config> {
        crate::validated::<Args, Config>(argv)
    }

    fn refused(argv: &[&str]) -> String {
        crate::refused::<Args, Config>(argv)
    }

    #[test]
    fn the_record_kind_follows_the_options() {
        let c = config(&["--out", "m.csv"]).unwrap();
        assert_eq!(
            c.record,
            Record::Stationary {
                duration_s: 3600.0,
                station: Station::REFERENCE
            }
        );
        assert_eq!((c.rate_hz, c.sim.hs_m), (8.0, 3.05));
        let c = config(&[
            "--out",
            "m.csv",
            "--hs",
            "2",
            "--course-change-s",
            "100",
            "--new-heading-deg",
            "90",
        ])
        .unwrap();
        assert_eq!(c.sim.hs_m, 2.0);
        assert_eq!(
            c.record,
            Record::Changing {
                duration_s: 3600.0,
                course: Some(CourseChange {
                    at_s: 100.0,
                    new_heading_deg: 90.0,
                    turn_s: 60.0
                }),
                sea: None
            }
        );
        let c = config(&["--out", "m.csv", "--elevation", "e.csv", "--edge-s", "30"]).unwrap();
        assert_eq!(
            c.record,
            Record::Measured {
                elevation: "e.csv".into(),
                edge_s: 30.0,
                station: Station::REFERENCE
            }
        );
        let c = config(&[
            "--out",
            "m.csv",
            "--elevation",
            "e.csv",
            "--vessel-y-m",
            "40",
        ])
        .unwrap();
        assert!(matches!(c.record, Record::Measured { station, .. } if station.y_m == 40.0));
    }

    #[test]
    fn bad_values_are_refused_with_one_line_naming_the_option() {
        assert_eq!(
            refused(&["--out", "m.csv", "--duration", "1e300"]),
            format!(
                "--duration must be a number in (0, {}], got 1e300",
                limits::MAX_SECONDS
            )
        );
        assert_eq!(
            refused(&["--out", "m.csv", "--duration", "31536000", "--rate", "10"]),
            "--duration x --rate = 315360000 rows, at most 100000000"
        );
        assert_eq!(
            refused(&["--out", "m.csv", "--rao-table-length", "100"]),
            "--rao-table-length needs --rao-table"
        );
        // Regression: with --duration (which clap lets stand in for the required
        // --elevation) --edge-s was accepted and did nothing.
        assert_eq!(
            refused(&["--out", "m.csv", "--duration", "10", "--edge-s", "5"]),
            "--edge-s applies to --elevation only"
        );
        assert_eq!(
            refused(&[
                "--out",
                "m.csv",
                "--course-change-s",
                "100",
                "--new-heading-deg",
                "90",
                "--turn-s",
                "-1"
            ]),
            format!(
                "--turn-s must be a number in [0, {}], got -1",
                limits::MAX_SECONDS
            )
        );
        assert_eq!(
            refused(&["--out", "m.csv", "--hs", "-1"]),
            "invalid simulation setting: significant wave height must be in (0, 30] m, got -1"
        );
        // Regression: absurd values beyond the RAOs' reach wrote a record of zeros without a
        // word.
        for (flag, value, needle) in [
            (
                "--hs",
                "100",
                "significant wave height must be in (0, 30] m, got 100",
            ),
            (
                "--tp",
                "86400",
                "peak period must be in [0.5, 40] s, got 86400",
            ),
            (
                "--tp",
                "0.01",
                "peak period must be in [0.5, 40] s, got 0.01",
            ),
            (
                "--speed-kn",
                "1e6",
                "speed must be in [0, 60] kn, got 1000000",
            ),
            (
                "--hull-length",
                "1e-6",
                "hull length must be in [1, 500] m, got 0.000001 m",
            ),
            (
                "--hull-length",
                "1e5",
                "hull length must be in [1, 500] m, got 100000 m",
            ),
            (
                "--vessel-x-m",
                "1e300",
                "the vessel's position must be within +-10000 m of the reference vessel",
            ),
        ] {
            let e = refused(&["--out", "m.csv", flag, value]);
            assert!(e.contains(needle), "{flag} {value}: {e}");
        }
        let e = refused(&[
            "--out",
            "m.csv",
            "--sea-change-s",
            "100",
            "--new-hs",
            "3",
            "--new-tp",
            "500",
        ]);
        assert!(
            e.starts_with("--new-hs/--new-tp: invalid simulation setting: peak period must be in"),
            "{e}"
        );
        // The limits themselves are accepted.
        for limit in [
            &["--hs", "30", "--tp", "40"][..],
            &["--tp", "40"],
            &["--speed-kn", "60"],
            // The steepest sea accepted: 2 pi Hs / g Tp^2 = 1/15 at Tp 5 s.
            &["--hs", "2.6", "--tp", "5"],
        ] {
            let argv: Vec<&str> = ["--out", "m.csv"].iter().chain(limit).copied().collect();
            assert!(config(&argv).is_ok(), "{limit:?}");
        }
        // Regression (review): Hs 30 m at Tp 0.5 s, a sea that cannot exist, was simulated.
        let e = refused(&["--out", "m.csv", "--hs", "30", "--tp", "0.5"]);
        assert!(
            e.contains("a sea of Hs 30 m and Tp 0.5 s is steeper (2 pi Hs / g Tp^2 = 76.859)")
                && e.contains("Hs is at most 0.03 m"),
            "{e}"
        );
        let e = refused(&["--out", "m.csv", "--hs", "2.7", "--tp", "5"]);
        assert!(e.contains("steeper"), "{e}");
        let e = refused(&[
            "--out",
            "m.csv",
            "--sea-change-s",
            "100",
            "--new-hs",
            "12",
            "--new-tp",
            "6",
        ]);
        assert!(
            e.starts_with("--new-hs/--new-tp: ") && e.contains("steeper"),
            "{e}"
        );
        assert_eq!(
            refused(&[
                "--out",
                "m.csv",
                "--sea-change-s",
                "100",
                "--new-hs",
                "0",
                "--new-tp",
                "9"
            ]),
            "--new-hs/--new-tp: invalid simulation setting: significant wave height must be \
             positive, got 0 m"
        );
        assert_eq!(
            refused(&["--out", "m.csv", "--elevation", "e.csv", "--edge-s", "nan"]),
            format!(
                "--edge-s must be a number in [0, {}], got NaN",
                limits::MAX_SECONDS
            )
        );
    }

    /// Regression (review): each of these was accepted and did nothing, or was refused
    /// without naming the option at fault.
    #[test]
    fn options_that_would_do_nothing_are_refused_and_errors_name_the_option() {
        for (argv, expected) in [
            (
                &["--turn-s", "30"][..],
                "--turn-s applies to a course change (--course-change-s) only",
            ),
            (
                &["--ramp-s", "-30"],
                "--ramp-s applies to a sea-state change (--sea-change-s) only",
            ),
            (
                &["--spectrum", "ittc", "--gamma", "50"],
                "--gamma applies to --spectrum jonswap only",
            ),
            (
                &["--course-change-s", "10", "--new-heading-deg", "nan"],
                "--new-heading-deg must be a finite number of degrees, got NaN",
            ),
            (
                &["--rao-table", "t.csv", "--hull-length", "100"],
                "--hull-length with --rao-table needs --rao-table-length (the length the table \
                 was computed for)",
            ),
            (
                &["--rao-table", "t.csv", "--rao-table-length", "-5"],
                "--rao-table-length needs --hull-length (the length to scale the table to)",
            ),
        ] {
            let argv: Vec<&str> = ["--out", "m.csv"].iter().chain(argv).copied().collect();
            assert_eq!(refused(&argv), expected, "{argv:?}");
        }
        // Given with their change, both still take their values.
        let c = config(&[
            "--out",
            "m.csv",
            "--sea-change-s",
            "100",
            "--new-hs",
            "3",
            "--new-tp",
            "9",
            "--ramp-s",
            "30",
        ])
        .unwrap();
        assert!(matches!(c.record, Record::Changing { sea: Some(s), .. } if s.ramp_s == 30.0));
        // A scenario says what sea to draw; a measured record is the sea (clap refuses it).
        #[derive(clap::Parser)]
        struct Simulate {
            #[command(flatten)]
            args: Args,
        }
        let parse = |argv: &[&str]| <Simulate as clap::Parser>::try_parse_from(argv).map(|_| ());
        let e = parse(&[
            "s",
            "--out",
            "m.csv",
            "--elevation",
            "e.csv",
            "--scenario",
            "ss6",
        ])
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("'--elevation <ELEVATION>' cannot be used with '--scenario <SCENARIO>'"),
            "{e}"
        );
        assert!(parse(&["s", "--out", "m.csv", "--elevation", "e.csv"]).is_ok());
        // A negative length reaches the range check, not clap's "unexpected argument".
        let e = refused(&["--out", "m.csv", "--hull-length", "-5"]);
        assert!(e.contains("hull length must be in [1, 500] m"), "{e}");
    }

    #[test]
    fn a_figure_in_a_missing_directory_is_refused_before_the_record_is_made() {
        let dir = tempfile::tempdir().unwrap();
        let svg = dir.path().join("missing").join("m.svg");
        let svg = svg.to_str().unwrap();
        assert_eq!(
            refused(&["--out", "m.csv", "--plot", svg]),
            format!(
                "--plot {svg}: the directory {} does not exist",
                dir.path().join("missing").display()
            )
        );
        // A bare file name is in the current directory, which exists.
        assert!(config(&["--out", "m.csv", "--plot", "m.svg"]).is_ok());
    }

    #[test]
    fn outputs_that_would_overwrite_each_other_or_the_rao_table_are_refused() {
        // Regressions (review): the figure replaced the motion record, and the record the RAO
        // table it was computed from.
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("m.csv");
        let same_place = dir.path().join(".").join("m.csv");
        let (out, same_place) = (out.to_str().unwrap(), same_place.to_str().unwrap());
        let e = refused(&["--out", out, "--plot", same_place]);
        assert!(
            e.starts_with("--plot ") && e.contains("is the --out file"),
            "{e}"
        );
        // Also when the record exists already (a symbolic link to it is the same file).
        std::fs::write(out, "").unwrap();
        let link = dir.path().join("link.svg");
        std::os::unix::fs::symlink(out, &link).unwrap();
        let e = refused(&["--out", out, "--plot", link.to_str().unwrap()]);
        assert!(e.contains("is the --out file"), "{e}");
        let table = dir.path().join("rao.csv");
        std::fs::write(&table, "").unwrap();
        let table = table.to_str().unwrap();
        for (flag, path) in [("--out", table), ("--plot", table)] {
            let args: Vec<&str> = if flag == "--out" {
                vec!["--rao-table", table, "--out", path]
            } else {
                vec!["--rao-table", table, "--out", "m.csv", "--plot", path]
            };
            let e = refused(&args);
            assert!(
                e.starts_with(flag) && e.contains("is the --rao-table file"),
                "{e}"
            );
        }
        assert_eq!(std::fs::read_to_string(table).unwrap(), "");
    }
}
