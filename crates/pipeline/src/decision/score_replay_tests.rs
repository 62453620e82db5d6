//! Replays of whole records through the engine with the deck scored: the decision scorer
//! as `shipcast replay` drives it (split from `score.rs`, whose own tests drive it by hand), on
//! seas whose forecast errors are Gaussian by construction.

use crate::config::{DeckConfig, PredictorServiceConfig};
use crate::engine::replay::replay_scored;
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};
use shipcast_series::motion_csv::{Column, MotionData};

/// A resonant AR(2) heave at 2 Hz (period 8 s, pole radius 0.95).
fn ar2_heave(n: usize, seed: u64) -> MotionData {
    let theta = std::f64::consts::TAU / 16.0;
    let (a1, a2) = (2.0 * 0.95 * theta.cos(), -0.95 * 0.95);
    let noise = Normal::new(0.0, 0.1).unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut x = vec![0.0; n];
    for t in 2..n {
        x[t] = a1 * x[t - 1] + a2 * x[t - 2] + noise.sample(&mut rng);
    }
    MotionData {
        ignored: Vec::new(),
        time: (0..n).map(|i| i as f64 / 2.0).collect(),
        columns: vec![Column {
            name: "heave_m".into(),
            values: x,
        }],
    }
}

#[test]
fn on_a_stationary_gaussian_sea_the_stated_probabilities_hold_within_chance() {
    // Two hours of the AR(2) heave, limit about its RMS: the engine's errors are Gaussian
    // and stationary, so once verified errors decide, every well-filled bin's observed
    // frequency must lie within chance of what it stated. Chance: the binomial spread of
    // the bin's episodes (calls at least MOT apart), at 3 sigma, with 2 points for the
    // ensemble's own sampling.
    let data = ar2_heave(2 * 7200, 11);
    let rms = (data.columns[0].values.iter().map(|v| v * v).sum::<f64>()
        / data.columns[0].values.len() as f64)
        .sqrt();
    let deck = DeckConfig {
        point_m: [0.0; 3],
        vertical_displacement_limit_m: 1.2 * rms,
        vertical_velocity_limit_mps: 100.0,
        ..DeckConfig::default()
    };
    let config = PredictorServiceConfig::default();
    let (report, _) =
        replay_scored(&data, &config, None, 600.0, false, Some(&deck), &|_| {}).unwrap();
    let mot10 = &report.decisions[0];
    let filled: Vec<_> = mot10
        .reliability
        .iter()
        .filter(|b| b.episodes >= 30)
        .collect();
    assert!(filled.len() >= 5, "{mot10:?}");
    for b in filled {
        let spread = (b.stated * (1.0 - b.stated) / b.episodes as f64).sqrt();
        assert!(
            (b.observed - b.stated).abs() <= 3.0 * spread + 0.02,
            "{b:?} (3 sigma {:.3})",
            3.0 * spread
        );
    }
}

#[test]
fn a_replay_starts_from_the_statements_an_earlier_run_left_and_adds_its_own() {
    use crate::decision::statements_file::load;
    let dir = tempfile::tempdir().unwrap();
    let deck = |file: &str| DeckConfig {
        point_m: [0.0; 3],
        vertical_displacement_limit_m: 1.0,
        vertical_velocity_limit_mps: 10.0,
        statements_file: Some(dir.path().join(file)),
        ..DeckConfig::default()
    };
    let config = PredictorServiceConfig::default();
    let calls_in = |file: &str| -> f64 {
        let f = load(&dir.path().join(file)).unwrap().unwrap();
        let records = f.records(0.5).unwrap();
        records.iter().map(|(_, r)| r.calls()).sum()
    };
    let replay = |seed: u64, file: &str| {
        replay_scored(
            &ar2_heave(2 * 1000, seed),
            &config,
            None,
            200.0,
            false,
            Some(&deck(file)),
            &|_| {},
        )
        .unwrap()
        .0
    };
    // A first run leaves its verified statements; a run of another record alone, its own.
    replay(5, "kept.json");
    let alone = replay(6, "alone.json");
    let (n1, n2) = (calls_in("kept.json"), calls_in("alone.json"));
    assert!(n1 > 500.0 && n2 > 500.0, "{n1} {n2}");
    // The second record after the first: it starts from the first's statements (so its
    // statements are corrected from its first call, and differ) and adds exactly its own.
    let after = replay(6, "kept.json");
    assert_eq!(calls_in("kept.json"), n1 + n2);
    assert_eq!(after.decisions[0].calls, alone.decisions[0].calls);
    assert_ne!(after.decisions[0].brier, alone.decisions[0].brier);
    // A file edited by hand stops the replay with an error naming it, and is left as it is.
    let edited = dir.path().join("kept.json");
    let text = std::fs::read_to_string(&edited).unwrap().replacen(
        "\"window_steps\":20",
        "\"window_steps\":0",
        1,
    );
    std::fs::write(&edited, &text).unwrap();
    let e = replay_scored(
        &ar2_heave(2 * 1000, 7),
        &config,
        None,
        200.0,
        false,
        Some(&deck("kept.json")),
        &|_| {},
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("kept.json") && e.contains("0 steps"), "{e}");
    assert_eq!(std::fs::read_to_string(&edited).unwrap(), text);
}

/// A deck at the centre of gravity with a heave limit of 1 m and a velocity limit that never
/// binds: its windows are those of the AR(2) heave alone.
fn heave_deck() -> DeckConfig {
    DeckConfig {
        point_m: [0.0; 3],
        vertical_displacement_limit_m: 1.0,
        vertical_velocity_limit_mps: 10.0,
        ..DeckConfig::default()
    }
}

#[test]
fn replay_scores_decisions_for_both_mots() {
    let data = ar2_heave(2 * 1000, 5);
    let deck = heave_deck();
    let config = PredictorServiceConfig::default();
    let (report, forecasts) =
        replay_scored(&data, &config, None, 200.0, true, Some(&deck), &|_| {}).unwrap();
    let [mot10, mot30] = &report.decisions[..] else {
        panic!("{:?}", report.decisions);
    };
    assert_eq!((mot10.mot_s, mot30.mot_s), (10.0, 30.0));
    // Calls begin once verified errors back a probability: the MIN_MEMBERS-th kept member
    // of the forecasts (one in DEFAULT_STRIDE, 0.5 s apart, from the first one on: the deck
    // learns before --skip-s too, as the live deck would have) is verified when its 25 s
    // horizon has happened; they are scored from 200 s on. They run, 2 a second, to the
    // last forecast whose horizon lies in the 1000 s record (975 s).
    let first = forecasts.first().map(|f| f.time_s).unwrap();
    let ready = first
        + ((crate::decision::ensemble::MIN_MEMBERS - 1) * crate::decision::ensemble::DEFAULT_STRIDE)
            as f64
            * 0.5
        + 25.5;
    assert!(ready > 200.0, "{ready}");
    let expected = 2.0 * (975.0 - ready);
    assert!(
        (mot10.calls as f64 - expected).abs() <= 10.0,
        "{} calls, {expected} expected",
        mot10.calls
    );
    // The default 25 s horizon holds no 30 s window: no call, and no hit rate either.
    assert_eq!(mot30.calls, 0);
    assert_eq!(mot30.quiet_periods, 0);
    assert!(mot30.hit_rate.is_nan(), "{mot30:?}");
    let counted: u64 = mot10.reliability.iter().map(|b| b.count).sum();
    assert_eq!(counted, mot10.calls);
    for b in mot10.reliability.iter().filter(|b| b.count > 0) {
        assert!(b.stated >= b.p_lo && b.stated <= b.p_hi, "{b:?}");
    }
    assert!(mot10.brier >= 0.0 && mot10.brier <= 1.0);
    assert!(mot10.quiet_periods > 0);
    // Without a replay's deck section nothing is scored.
    let (plain, _) =
        crate::engine::replay::replay(&data, &config, None, 200.0, false, &|_| {}).unwrap();
    assert!(plain.decisions.is_empty());
}

/// Regression: with `--skip-s`, the deck's error ensemble and corrections started from nothing
/// at the skip, unlike the deck the service would have run; the first ~6 minutes after it
/// had no call. Now the deck learns from the whole record and only the scoring starts late:
/// every forecast scored after a skip beyond the ensemble's start-up is a call.
#[test]
fn a_skipped_stretch_still_teaches_the_deck() {
    let data = ar2_heave(2 * 1200, 7);
    let deck = heave_deck();
    let config = PredictorServiceConfig::default();
    let (report, _) =
        replay_scored(&data, &config, None, 700.0, false, Some(&deck), &|_| {}).unwrap();
    let mot10 = &report.decisions[0];
    assert!(report.dofs[0].scored > 500, "{:?}", report.dofs[0].scored);
    assert_eq!(mot10.calls, report.dofs[0].scored, "{mot10:?}");
}
