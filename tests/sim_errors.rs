//! Bad input to the simulator gives clear errors, never a panic.

use shipcast_sim::{RaoSpec, Scenario, ShipMotion, SimConfig, SpectrumKind, Spreading};
use std::io::Write;

fn error_of(cfg: SimConfig) -> String {
    ShipMotion::new(&cfg).unwrap_err().to_string()
}

#[test]
fn unknown_names_are_rejected_with_the_choices() {
    let e = "ss7".parse::<Scenario>().unwrap_err().to_string();
    assert!(
        e.contains("unknown scenario 'ss7'") && e.contains("paper"),
        "{e}"
    );
    assert!("cos4"
        .parse::<Spreading>()
        .unwrap_err()
        .to_string()
        .contains("cos2"));
    assert!("pm"
        .parse::<SpectrumKind>()
        .unwrap_err()
        .to_string()
        .contains("jonswap"));
}

#[test]
fn non_physical_settings_are_rejected() {
    let base = SimConfig::default();
    let e = error_of(SimConfig {
        hs_m: -1.0,
        ..base.clone()
    });
    assert!(
        e.contains("significant wave height must be in (0, 30] m, got -1"),
        "{e}"
    );
    // Regression: seas and speeds far outside any a ship meets wrote a record of zeros.
    for (cfg, needle) in [
        (
            SimConfig {
                hs_m: 1e3,
                ..base.clone()
            },
            "significant wave height must be in (0, 30] m",
        ),
        (
            SimConfig {
                tp_s: 1e5,
                ..base.clone()
            },
            "peak period must be in [0.5, 40] s",
        ),
        (
            SimConfig {
                speed_kn: 1e6,
                ..base.clone()
            },
            "speed must be in [0, 60] kn",
        ),
    ] {
        let e = error_of(cfg);
        assert!(e.contains(needle), "{e}");
    }
    let e = error_of(SimConfig {
        tp_s: f64::NAN,
        ..base.clone()
    });
    assert!(e.contains("peak period"), "{e}");
    let e = error_of(SimConfig {
        speed_kn: -3.0,
        ..base.clone()
    });
    assert!(e.contains("speed"), "{e}");
    let e = error_of(SimConfig {
        components: Some(0),
        ..base.clone()
    });
    assert!(e.contains("at least 1"), "{e}");
    let e = error_of(SimConfig {
        components: Some(usize::MAX),
        ..base.clone()
    });
    assert!(e.contains("at most"), "{e}");
    let m = ShipMotion::new(&base).unwrap();
    assert!(m.stream(-8.0, 0.0).is_err());
}

#[test]
fn bad_rao_table_files_are_rejected_with_the_reason() {
    let table = |path: std::path::PathBuf| SimConfig {
        rao: RaoSpec::Table {
            path,
            table_length_m: None,
            hull_length_m: None,
        },
        ..SimConfig::default()
    };
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("missing-rao.csv");
    let e = error_of(table(missing.clone()));
    assert!(
        e.contains(&format!("cannot open {}", missing.display())),
        "{e}"
    );

    let mut f = tempfile::NamedTempFile::new().unwrap();
    writeln!(
        f,
        "speed_mps,heading_deg,omega_rad_s,dof,amplitude,phase_rad"
    )
    .unwrap();
    writeln!(f, "0,180,0.5,heave,one,0").unwrap();
    let e = error_of(table(f.path().to_path_buf()));
    assert!(
        e.contains("line 2, column amplitude: 'one' is not a number"),
        "{e}"
    );

    let mut f = tempfile::NamedTempFile::new().unwrap();
    writeln!(
        f,
        "speed_mps,heading_deg,omega_rad_s,dof,amplitude,phase_rad"
    )
    .unwrap();
    writeln!(f, "0,180,0.5,heave,1,0").unwrap();
    let e = error_of(table(f.path().to_path_buf()));
    assert!(e.contains("incomplete grid"), "{e}");

    let mut f = tempfile::NamedTempFile::new().unwrap();
    writeln!(f, "a,b,c").unwrap();
    let e = error_of(table(f.path().to_path_buf()));
    assert!(e.contains("missing column 'speed_mps'"), "{e}");
}

/// The line the binary prints for `e` (`error: {e:#}` in services/main.rs), without `error: `.
fn printed(e: shipcast_sim::SimError) -> String {
    format!("{:#}", anyhow::Error::from(e))
}

#[test]
fn an_unreadable_rao_table_names_the_file_and_prints_the_os_error_once() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("missing-rao.csv");
    let io = std::fs::File::open(&path).unwrap_err().to_string();
    let cfg = SimConfig {
        rao: RaoSpec::Table {
            path: path.clone(),
            table_length_m: None,
            hull_length_m: None,
        },
        ..SimConfig::default()
    };
    let e = printed(ShipMotion::new(&cfg).unwrap_err());
    assert_eq!(
        e,
        format!("RAO table: cannot open {}: {io}", path.display())
    );
    assert_eq!(e.matches(&io).count(), 1, "{e}");

    // A directory opens but does not read: the I/O error is the cause.
    let dir = tempfile::tempdir().unwrap();
    let eisdir = std::fs::read(dir.path()).unwrap_err().to_string();
    let cfg = SimConfig {
        rao: RaoSpec::Table {
            path: dir.path().to_path_buf(),
            table_length_m: None,
            hull_length_m: None,
        },
        ..SimConfig::default()
    };
    let e = printed(ShipMotion::new(&cfg).unwrap_err());
    assert_eq!(
        e,
        format!("RAO table: {}: reading: {eisdir}", dir.path().display())
    );
    assert_eq!(e.matches(&eisdir).count(), 1, "{e}");
}

#[test]
fn a_figure_in_a_missing_directory_names_it_and_prints_the_os_error_once() {
    let m = ShipMotion::new(&SimConfig {
        components: Some(20),
        ..SimConfig::default()
    })
    .unwrap();
    let dir = tempfile::tempdir().unwrap();
    let svg = dir.path().join("missing").join("overview.svg");
    let io = std::fs::File::create(&svg).unwrap_err().to_string();
    let e = printed(shipcast_sim::plot::plot_overview(&m, &svg, 5.0, 2.0).unwrap_err());
    let head = format!("plot {}: cannot draw or write the figure: ", svg.display());
    assert!(e.starts_with(&head) && e.ends_with(&io), "{e}");
    assert_eq!(e.matches(&io).count(), 1, "{e}");
    assert_eq!(e.lines().count(), 1, "{e}");
}
