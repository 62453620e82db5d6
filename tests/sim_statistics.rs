//! Statistics of simulated records against the spectra they come from (issue 3, "Must show").

mod fixtures;

use shipcast_sim::{
    encounter_omega, Channel, Rao, RaoSpec, ShipMotion, SimConfig, Spectrum, Spreading, KNOT_MPS,
};
use shipcast_wire::Dof;
use std::f64::consts::PI;

/// Time-average variance of every channel over `seconds` sampled at `rate` Hz.
fn record_variances(m: &ShipMotion, seconds: f64, rate: f64) -> [f64; 7] {
    let n = (seconds * rate) as usize;
    let mut sum = [0.0; 7];
    let mut sum2 = [0.0; 7];
    for p in m.stream(rate, 0.0).unwrap().take(n) {
        for (j, v) in p.dof.iter().chain(std::iter::once(&p.wave_m)).enumerate() {
            sum[j] += v;
            sum2[j] += v * v;
        }
    }
    std::array::from_fn(|j| sum2[j] / n as f64 - (sum[j] / n as f64).powi(2))
}

/// Independent reference: the double integral of |H|^2 S D over frequency and direction, by
/// the midpoint rule on a fine grid (no use of the drawn components).
fn spectral_variance(cfg: &SimConfig, rao: &dyn Rao, dof: Dof) -> f64 {
    let s = Spectrum::new(cfg.spectrum, cfg.hs_m, cfg.tp_s, cfg.gamma).unwrap();
    let (lo, hi) = (0.2 * s.peak_omega(), 8.0 * s.peak_omega());
    let nw = 4000;
    let dw = (hi - lo) / nw as f64;
    let dirs: Vec<(f64, f64)> = match cfg.spreading {
        Spreading::None => vec![(0.0, 1.0)],
        Spreading::Cos2 => {
            let n = 180;
            let dmu = PI / n as f64;
            (0..n)
                .map(|i| {
                    let mu = -PI / 2.0 + (i as f64 + 0.5) * dmu;
                    (mu, Spreading::Cos2.density(mu) * dmu)
                })
                .collect()
        }
    };
    let mean = cfg.heading_deg.to_radians();
    let mut total = 0.0;
    for i in 0..nw {
        let w = lo + (i as f64 + 0.5) * dw;
        let sw = s.density(w) * dw;
        for &(mu, weight) in &dirs {
            let h = rao.response(w, mean + mu, cfg.speed_mps())[dof.index()];
            total += h.norm_sqr() * sw * weight;
        }
    }
    total
}

#[test]
fn significant_height_of_the_record_is_four_root_m0() {
    for spreading in [Spreading::Cos2, Spreading::None] {
        let cfg = SimConfig {
            spreading,
            seed: 11,
            ..SimConfig::default()
        };
        let m = ShipMotion::new(&cfg).unwrap();
        // Sampling at 1 Hz aliases the spectrum but leaves the variance as it is; ten hours
        // bring the intrinsic scatter of a variance estimate down to about 2 %.
        let var = record_variances(&m, 10.0 * 3600.0, 1.0)[6];
        let hs_record = 4.0 * var.sqrt();
        let hs_spectrum = 4.0 * m.spectrum().m0().sqrt();
        assert!(
            (hs_record / hs_spectrum - 1.0).abs() < 0.05,
            "{spreading:?}: record Hs {hs_record:.3} m, spectrum {hs_spectrum:.3} m"
        );
    }
}

#[test]
fn dof_variances_match_the_spectral_integral_of_rao_squared_times_s() {
    // Oblique bow seas excite all six DOF. A variance estimated from a record of length T
    // scatters by about sqrt(2 pi / (T bandwidth)): 3 h leave 5 % for pitch, so 20 h at 1 Hz.
    let cfg = SimConfig {
        heading_deg: 135.0,
        seed: 5,
        ..SimConfig::default()
    };
    let m = ShipMotion::new(&cfg).unwrap();
    let rec = record_variances(&m, 20.0 * 3600.0, 1.0);
    for dof in Dof::ALL {
        let reference = spectral_variance(&cfg, m.rao(), dof);
        let exact = m.variance(Channel::Motion(dof));
        let got = rec[dof.index()];
        eprintln!("{dof}: record {got:.4e} exact {exact:.4e} integral {reference:.4e}");
        assert!(
            (got / reference - 1.0).abs() < 0.05,
            "{dof}: record variance {got:.4e}, spectral integral {reference:.4e}"
        );
        // The exact variance of the drawn sea lies between both.
        assert!(
            (exact / reference - 1.0).abs() < 0.05,
            "{dof}: exact {exact:.4e}"
        );
    }
}

#[test]
fn autocorrelation_at_zero_lag_is_the_variance_and_decays() {
    let m = ShipMotion::new(&SimConfig::default()).unwrap();
    let r = m.autocorrelation(Dof::Heave, 0.5, 400);
    assert_eq!(r.len(), 401);
    assert!((r[0] - m.variance(Channel::Motion(Dof::Heave))).abs() < 1e-12 * r[0]);
    assert!(r.iter().all(|v| v.abs() <= r[0] * (1.0 + 1e-12)));
    // A dense sea forgets: after 200 s the correlation is small.
    assert!(
        r[400].abs() < 0.2 * r[0],
        "R(200 s) / R(0) = {}",
        r[400] / r[0]
    );
}

#[test]
fn record_autocorrelation_matches_the_exact_one() {
    let m = ShipMotion::new(&SimConfig::default()).unwrap();
    let x: Vec<f64> = m
        .stream(2.0, 0.0)
        .unwrap()
        .take(14_400)
        .map(|p| p.dof[Dof::Pitch.index()])
        .collect();
    let exact = m.autocorrelation(Dof::Pitch, 0.5, 20);
    for (lag, &want) in exact.iter().enumerate().step_by(5) {
        let got: f64 = x.iter().zip(&x[lag..]).map(|(a, b)| a * b).sum::<f64>() / x.len() as f64;
        assert!(
            (got - want).abs() < 0.05 * exact[0],
            "lag {lag}: {got:.3e} vs {want:.3e}"
        );
    }
}

#[test]
fn encounter_period_is_shorter_in_head_seas_and_longer_in_following_seas() {
    let period = |heading_deg: f64| {
        let cfg = SimConfig {
            heading_deg,
            spreading: Spreading::None,
            ..SimConfig::default()
        };
        ShipMotion::new(&cfg)
            .unwrap()
            .peak_encounter_period(Channel::Wave)
            .unwrap()
    };
    let tp = SimConfig::default().tp_s;
    let (head, beam, following) = (period(180.0), period(90.0), period(0.0));
    assert!(head < 0.85 * tp, "head seas {head:.2} s vs Tp {tp} s");
    assert!((beam / tp - 1.0).abs() < 0.1, "beam seas {beam:.2} s");
    assert!(following > 1.3 * tp, "following seas {following:.2} s");
    // Roll is not excited at all in long-crested head seas.
    let head_seas = SimConfig {
        heading_deg: 180.0,
        spreading: Spreading::None,
        ..SimConfig::default()
    };
    let m = ShipMotion::new(&head_seas).unwrap();
    assert_eq!(m.peak_encounter_period(Channel::Motion(Dof::Roll)), None);
    // Consistent with the encounter frequency of the spectral peak.
    let we = encounter_omega(2.0 * PI / tp, PI, 11.0 * KNOT_MPS);
    assert!((head / (2.0 * PI / we) - 1.0).abs() < 0.1);
}

#[test]
fn same_seed_same_record_other_seed_other_record() {
    let cfg = SimConfig::default();
    let a: Vec<_> = ShipMotion::new(&cfg)
        .unwrap()
        .stream(8.0, 0.0)
        .unwrap()
        .take(500)
        .collect();
    let b: Vec<_> = ShipMotion::new(&cfg)
        .unwrap()
        .stream(8.0, 0.0)
        .unwrap()
        .take(500)
        .collect();
    assert_eq!(a, b);
    let other = SimConfig { seed: 2, ..cfg };
    let c: Vec<_> = ShipMotion::new(&other)
        .unwrap()
        .stream(8.0, 0.0)
        .unwrap()
        .take(500)
        .collect();
    assert_ne!(a, c);
}

#[test]
fn fixed_grid_gives_a_line_spectrum_of_exactly_n_lines() {
    let cfg = SimConfig {
        components: Some(20),
        spreading: Spreading::None,
        ..SimConfig::default()
    };
    let m = ShipMotion::new(&cfg).unwrap();
    let mut we: Vec<f64> = m.components().iter().map(|c| c.omega_e).collect();
    we.sort_by(f64::total_cmp);
    we.dedup();
    assert_eq!(we.len(), 20);
    // Every channel is then a sum of 20 sinusoids: its autocorrelation never dies out.
    let r = m.autocorrelation(Dof::Heave, 0.5, 4000);
    let late = r[3000..].iter().fold(0.0f64, |acc, v| acc.max(v.abs()));
    assert!(late > 0.3 * r[0], "max |R| after 1500 s: {}", late / r[0]);
}

#[test]
fn rao_table_spec_without_both_lengths_is_rejected() {
    let cfg = SimConfig {
        rao: RaoSpec::Table {
            path: fixtures::s175_rao_table(),
            table_length_m: Some(175.0),
            hull_length_m: None,
        },
        ..SimConfig::default()
    };
    let e = ShipMotion::new(&cfg).unwrap_err().to_string();
    assert!(e.contains("both"), "{e}");
}
