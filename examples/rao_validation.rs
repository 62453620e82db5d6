//! Closed-form RAOs of the DTMB 5415 against the boundary-element solution in
//! tests/fixtures/dtmb5415-bem: writes docs/results/rao_validation.svg (both RAOs per DOF) and
//! prints the table of docs/results/rao_validation.md (response std ratios and the worst
//! frequency-by-frequency ratio).
//!
//! Run from the repository root: `cargo run --release --example rao_validation`
//! (`-- --out FILE.svg` writes the figure elsewhere).

use shipcast_sim::rao_plot::{plot_rao_panels, RaoPanel};
use shipcast_sim::rao_reference::{std_ratio_on_same_waves, validation_sea, ReferenceRaos};
use shipcast_sim::{Channel, ClosedFormRao, Hull, Rao, ShipMotion, SimConfig};
use shipcast_wire::Dof;
use std::path::Path;
use std::process::ExitCode;

const USAGE: &str = "usage: rao_validation [--out FILE.svg]";

/// Errors as one line `error: ...` (not the debug form `main` would print), `--help` as help.
fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.iter().any(|a| a == "--help" || a == "-h") {
        println!("{USAGE} (default: docs/results/rao_validation.svg)");
        return ExitCode::SUCCESS;
    }
    match run(&args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run(args: &[String]) -> Result<(), Box<dyn std::error::Error>> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let out = match args {
        [] => root.join("docs/results/rao_validation.svg"),
        [flag, path] if flag == "--out" => Path::new(path).to_path_buf(),
        _ => return Err(format!("{USAGE}, got {}", args.join(" ")).into()),
    };
    let bem = ReferenceRaos::load(&root.join("tests/fixtures/dtmb5415-bem/motion_rao.csv"))?;
    let hull = Hull::dtmb5415();
    let rao = ClosedFormRao::new(hull);
    let cases = [(Dof::Heave, 180.0), (Dof::Pitch, 180.0), (Dof::Roll, 90.0)];
    println!(
        "natural frequencies [rad/s]: heave {:.3}, pitch {:.3}, roll {:.3} (period {:.2} s)",
        rao.heave_natural_omega(),
        rao.pitch_natural_omega(),
        hull.roll_natural_omega(),
        hull.roll_period_s()
    );
    println!(
        "\n| Tp | heave (head seas) | pitch (head seas) | roll (beam seas) |\n|---|---|---|---|"
    );
    for tp in [7.5, 9.7, 12.4] {
        let mut row = format!("| {tp} s |");
        for (dof, heading) in cases {
            let curve = bem.curve(dof, heading)?;
            let r = std_ratio_on_same_waves(&validation_sea(hull, curve, tp, 1), curve)?;
            row += &format!(" {r:.2} |");
        }
        println!("{row}");
    }
    println!("\nwhere the BEM amplitude is above 10 % of its peak:");
    let mut panels = Vec::new();
    for (dof, heading) in cases {
        let curve = bem.curve(dof, heading)?;
        let amplitude = |w: f64| rao.response(w, f64::to_radians(heading), 0.0)[dof.index()].norm();
        let floor = 0.1 * curve.peak_amplitude();
        let (mut lo, mut hi, mut at) = (f64::INFINITY, 0.0f64, 0.0);
        let mut below_half = Vec::new();
        for &(w, v) in curve.points.iter().filter(|p| p.1.norm() > floor) {
            let r = amplitude(w) / v.norm();
            hi = hi.max(r);
            if r < lo {
                (lo, at) = (r, w);
            }
            if r < 0.5 {
                below_half.push(format!("{w:.3}"));
            }
        }
        println!("  {dof}: closed form / BEM from {lo:.2} (at {at:.3} rad/s) to {hi:.2}");
        if !below_half.is_empty() {
            println!(
                "    below half of the BEM at {} rad/s",
                below_half.join(", ")
            );
        }
        let scale = if dof.is_rotation() {
            180.0 / std::f64::consts::PI
        } else {
            1.0
        };
        let grid: Vec<f64> = (0..=260).map(|i| 0.3 + i as f64 * 0.005).collect();
        panels.push(RaoPanel {
            title: format!(
                "{dof}, {} seas, zero speed",
                if heading == 90.0 { "beam" } else { "head" }
            ),
            unit: if dof.is_rotation() {
                "deg per m of wave amplitude".into()
            } else {
                "m per m of wave amplitude".into()
            },
            curves: vec![
                (
                    "boundary elements (Capytaine)".into(),
                    curve
                        .points
                        .iter()
                        .map(|&(w, v)| (w, v.norm() * scale))
                        .collect(),
                ),
                (
                    "closed form (shipcast)".into(),
                    grid.iter().map(|&w| (w, amplitude(w) * scale)).collect(),
                ),
            ],
        });
    }
    // What the change means for the default input of `shipcast run` and the paper study.
    let paper = ShipMotion::new(&SimConfig::default())?;
    let mut rms = String::from("\npaper scenario (11 kn, 165 deg, cos^2), RMS:");
    for dof in Dof::ALL {
        let v = paper.variance(Channel::Motion(dof)).sqrt();
        let (v, unit) = if dof.is_rotation() {
            (v.to_degrees(), "deg")
        } else {
            (v, "m")
        };
        rms += &format!(" {dof} {v:.3} {unit};");
    }
    println!("{rms}");
    plot_rao_panels(&panels, &out)?;
    println!("\nwrote {}", out.display());
    Ok(())
}
