//! The third-party S175 RAO table (the fixture tests/fixtures/s175, 0 and 10 kn): its documented
//! limits, and the closed-form RAOs of the S175 main particulars compared with it in a stated sea.

mod fixtures;

use shipcast_sim::{
    Channel, ClosedFormRao, Hull, Rao, RaoTable, ScaledRaoTable, Scenario, ShipMotion, SimConfig,
    Spreading, G, KNOT_MPS,
};
use shipcast_wire::Dof;
use std::sync::Arc;

fn table() -> RaoTable {
    RaoTable::load(&fixtures::s175_rao_table()).expect("S175 table loads")
}

#[test]
fn s175_table_has_the_documented_grid_and_low_frequency_limits() {
    let t = table();
    // The fixture keeps the original's speeds 0 and 10 kn, with all its headings and frequencies.
    assert_eq!(t.speeds().len(), 2);
    assert_eq!(t.speeds()[0], 0.0);
    assert!((t.speeds()[1] - 10.0 * KNOT_MPS).abs() < 1e-6);
    assert_eq!(t.headings_deg().len(), 36);
    assert_eq!(t.omegas().len(), 36);
    let w = t.omegas()[0];
    let k = w * w / G;
    let head = t.at(0.0, 180.0, w);
    assert!((head[Dof::Heave.index()].norm() - 1.0).abs() < 0.01);
    assert!((head[Dof::Surge.index()].norm() - 1.0).abs() < 0.01);
    assert!((head[Dof::Pitch.index()].norm() / k - 1.0).abs() < 0.05);
    let beam = t.at(0.0, 90.0, w);
    assert!((beam[Dof::Sway.index()].norm() - 1.0).abs() < 0.01);
    // Roll peaks near 0.31 rad/s in beam seas at zero speed (period about 20 s).
    let (mut best_w, mut best) = (0.0, 0.0);
    for i in 0..400 {
        let w = 0.15 + i as f64 * 0.002;
        let r = t.at(0.0, 90.0, w)[Dof::Roll.index()].norm();
        if r > best {
            (best_w, best) = (w, r);
        }
    }
    assert!((best_w - 0.31).abs() < 0.03, "roll peak at {best_w} rad/s");
}

#[test]
fn closed_form_agrees_in_sign_and_limit_with_the_table() {
    // Same axes and phases: at long waves both give the same complex responses.
    let t = ScaledRaoTable::unscaled(Arc::new(table()));
    let cf = ClosedFormRao::new(Hull::s175());
    let w = 0.15;
    for beta_deg in [180.0f64, 140.0, 40.0] {
        let (a, b) = (
            t.response(w, beta_deg.to_radians(), 0.0),
            cf.response(w, beta_deg.to_radians(), 0.0),
        );
        for dof in [Dof::Surge, Dof::Sway, Dof::Heave, Dof::Pitch, Dof::Yaw] {
            let (x, y) = (a[dof.index()], b[dof.index()]);
            let scale = x.norm().max(y.norm());
            if scale > 1e-4 {
                assert!(
                    (x - y).norm() < 0.25 * scale,
                    "{dof} at {beta_deg} deg: table {x}, closed form {y}"
                );
            }
        }
    }
}

/// RMS heave [m] and pitch [deg] from the closed form and from the table on the very same drawn
/// long-crested head sea.
fn rms_pair(scenario: Scenario, speed_kn: f64) -> ((f64, f64), (f64, f64)) {
    let cfg = SimConfig {
        speed_kn,
        heading_deg: 180.0,
        spreading: Spreading::None,
        ..SimConfig::scenario(scenario)
    };
    let rms = |rao: Arc<dyn Rao>| {
        let m = ShipMotion::with_rao(&cfg, rao).unwrap();
        let heave = m.variance(Channel::Motion(Dof::Heave)).sqrt();
        let pitch = m.variance(Channel::Motion(Dof::Pitch)).sqrt().to_degrees();
        (heave, pitch)
    };
    let closed = rms(Arc::new(ClosedFormRao::new(Hull::s175())));
    let tabled = rms(Arc::new(ScaledRaoTable::unscaled(Arc::new(table()))));
    println!(
        "S175 {scenario:?} head seas {speed_kn} kn: RMS heave closed form {:.3} m, table {:.3} m; \
         RMS pitch closed form {:.3} deg, table {:.3} deg",
        closed.0, tabled.0, closed.1, tabled.1
    );
    (closed, tabled)
}

/// The stated comparison: SS5 (Hs 3.25 m, Tp 9.7 s, JONSWAP), long-crested head seas, 10 kn.
/// The closed form's heave forcing still partly cancels along the hull where the wave is
/// shorter than the ship, right where the S175's encounter frequency meets its heave
/// resonance at 10 kn, so it under-predicts heave there (0.70 of the table; pitch 1.02); in
/// longer waves (SS6) both agree better. The bounds below record that known behaviour and catch
/// anything worse.
#[test]
fn closed_form_and_s175_table_rms_in_ss5_head_seas_at_10_kn() {
    let ((h_cf, p_cf), (h_tab, p_tab)) = rms_pair(Scenario::Ss5, 10.0);
    assert!(
        (0.35..1.1).contains(&(h_cf / h_tab)),
        "heave {h_cf} vs {h_tab}"
    );
    assert!(
        (0.5..1.1).contains(&(p_cf / p_tab)),
        "pitch {p_cf} vs {p_tab}"
    );
    let ((h6, p6), (h6t, p6t)) = rms_pair(Scenario::Ss6, 10.0);
    assert!(
        (h6 / h6t - 1.0).abs() < (h_cf / h_tab - 1.0).abs(),
        "SS6 heave {h6} vs {h6t}"
    );
    assert!((p6 / p6t - 1.0).abs() < 0.35, "SS6 pitch {p6} vs {p6t}");
}
