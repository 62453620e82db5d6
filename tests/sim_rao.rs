//! Closed-form RAOs of the default hull: long-wave limits and roll resonance (see also
//! tests/sim_bem.rs for the comparison with a boundary-element solution).

use shipcast_sim::rao_reference::{CurveRao, ReferenceRaos};
use shipcast_sim::{
    Channel, ClosedFormRao, Hull, Rao, Scenario, ShipMotion, SimConfig, Spreading, G,
};
use shipcast_wire::Dof;
use std::f64::consts::PI;
use std::path::Path;
use std::sync::Arc;

#[test]
fn heave_tends_to_one_and_pitch_to_the_wave_number_in_long_head_seas() {
    let rao = ClosedFormRao::new(Hull::dtmb5415());
    for speed in [0.0, 5.66] {
        for w in [0.05, 0.1] {
            let k = w * w / G;
            let h = rao.response(w, PI, speed);
            assert!(
                (h[Dof::Heave.index()].norm() - 1.0).abs() < 0.02,
                "heave at {w}"
            );
            assert!(
                (h[Dof::Pitch.index()].norm() / k - 1.0).abs() < 0.02,
                "pitch at {w}"
            );
        }
    }
    // In beam seas the long waves lift the ship without pitching it.
    let h = rao.response(0.1, PI / 2.0, 0.0);
    assert!((h[Dof::Heave.index()].norm() - 1.0).abs() < 0.02);
    assert!(h[Dof::Pitch.index()].norm() < 1e-6);
    assert!((h[Dof::Sway.index()].norm() - 1.0).abs() < 0.02);
}

#[test]
fn roll_resonates_near_the_hull_roll_period_in_beam_seas() {
    let hull = Hull::dtmb5415();
    let rao = ClosedFormRao::new(hull);
    let (mut best_w, mut best) = (0.0, 0.0);
    for i in 1..2000 {
        let w = i as f64 * 0.001;
        let r = rao.response(w, PI / 2.0, 0.0)[Dof::Roll.index()].norm();
        if r > best {
            (best_w, best) = (w, r);
        }
    }
    let period = 2.0 * PI / best_w;
    assert!(
        (period / hull.roll_period_s() - 1.0).abs() < 0.1,
        "roll RAO peaks at {period:.2} s, hull roll period {:.2} s",
        hull.roll_period_s()
    );
    // Dynamic amplification over the static wave slope is about 1 / (2 zeta) at resonance.
    let slope = best_w * best_w / G;
    assert!(
        best / slope > 0.5 / hull.roll_damping_ratio * 0.6,
        "amplification {}",
        best / slope
    );
}

#[test]
fn roll_record_peaks_between_the_wave_and_the_roll_period_as_the_bem_hull_does() {
    // SS3 has Tp 7.5 s, well away from the 11 s wet roll period of the hull, and a real hull's
    // roll excitation falls off above resonance: the record peaks between the two, where the
    // boundary-element RAO (tests/fixtures/dtmb5415-bem) puts it for the very same waves.
    let cfg = SimConfig {
        heading_deg: 90.0,
        speed_kn: 0.0,
        spreading: Spreading::None,
        ..SimConfig::scenario(Scenario::Ss3)
    };
    let m = ShipMotion::new(&cfg).unwrap();
    let roll = m.peak_encounter_period(Channel::Motion(Dof::Roll)).unwrap();
    let wave = m.peak_encounter_period(Channel::Wave).unwrap();
    let path =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/dtmb5415-bem/motion_rao.csv");
    let bem_roll = ReferenceRaos::load(&path)
        .unwrap()
        .curve(Dof::Roll, 90.0)
        .unwrap()
        .clone();
    let reference = ShipMotion::with_rao(&cfg, Arc::new(CurveRao(bem_roll))).unwrap();
    let bem = reference
        .peak_encounter_period(Channel::Motion(Dof::Roll))
        .unwrap();
    let t4 = Hull::dtmb5415().roll_period_s();
    println!(
        "roll record peak {roll:.2} s, BEM {bem:.2} s, wave {wave:.2} s, roll period {t4:.2} s"
    );
    assert!(
        (roll / bem - 1.0).abs() < 0.05,
        "roll peak {roll:.2} s, BEM {bem:.2} s"
    );
    assert!(
        roll > 1.15 * wave && roll < t4 * 1.02,
        "roll peak {roll:.2} s"
    );
    assert!((wave / 7.5 - 1.0).abs() < 0.1, "wave peak {wave:.2} s");
}

#[test]
fn responses_stay_finite_and_continuous_where_the_encounter_frequency_vanishes() {
    // In following seas w_e = w - w^2 U / g is zero at w = g / U: the wave keeps pace with the
    // ship. The closed form's damping terms divide by powers of w_e / w there.
    let rao = ClosedFormRao::new(Hull::dtmb5415());
    let speed = 10.0;
    let w0 = G / speed;
    let below = rao.response(w0 * (1.0 - 1e-6), 0.0, speed);
    let at = rao.response(w0, 0.0, speed);
    let above = rao.response(w0 * (1.0 + 1e-6), 0.0, speed);
    for j in 0..6 {
        assert!(at[j].norm().is_finite());
        assert!((below[j].norm() - above[j].norm()).abs() < 1e-4, "dof {j}");
        assert!((below[j].norm() - at[j].norm()).abs() < 1e-4, "dof {j}");
    }
}
