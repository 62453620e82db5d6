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
        e.contains("significant wave height must be positive"),
        "{e}"
    );
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
    let e = error_of(table("/nonexistent/rao.csv".into()));
    assert!(e.contains("cannot open /nonexistent/rao.csv"), "{e}");

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
