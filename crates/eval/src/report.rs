//! The human-readable table of `shipcast eval`.

use super::run::Entry;
use std::fmt::Write;

/// Lead times [s] shown in the table (those within the horizon).
pub const TABLE_LEADS_S: [f64; 4] = [0.5, 5.0, 10.0, 20.0];

/// Skill of a forecast against persistence: 1 - (rms / persistence rms)^2 (mean-square-error
/// skill score; 1 is perfect, 0 no better than holding the last value, negative is worse).
pub fn skill(rms: f64, persistence_rms: f64) -> f64 {
    1.0 - (rms / persistence_rms).powi(2)
}

/// Steps (1-based) nearest the table's lead times at `sample_rate`, within `horizon`, each
/// once and labelled with its own lead (step / rate); the first and last step where none of
/// them fits. Regression (review): at 1 Hz the "0.5 s" column showed the 1 s step, at 0.1 Hz
/// the "5 s" and "10 s" columns both the 10 s step, and at 8 Hz with a horizon of 3 the table
/// had no error column at all.
fn lead_steps(sample_rate: f64, horizon: usize) -> Vec<(f64, usize)> {
    let mut steps: Vec<usize> = TABLE_LEADS_S
        .iter()
        .map(|&lead| ((lead * sample_rate).round() as usize).max(1))
        .filter(|&step| step <= horizon)
        .collect();
    steps.dedup();
    if steps.is_empty() && horizon >= 1 {
        steps = vec![1, horizon];
        steps.dedup();
    }
    steps
        .into_iter()
        .map(|step| (step as f64 / sample_rate, step))
        .collect()
}

/// One row per (dof, method): RMS error and skill at a few lead times, training and forecast
/// times, and the number of minor components for MCA; failed pairs show their error.
pub fn table(entries: &[Entry], sample_rate: f64, horizon: usize) -> String {
    let leads = lead_steps(sample_rate, horizon);
    let mut out = String::new();
    // Every entry of one run shares the averaging; name it when there is one.
    let averaged = entries.iter().find_map(|e| match e {
        Entry::Done(r) if !r.average.is_none() => Some(r.average),
        _ => None,
    });
    if let Some(average) = averaged {
        let _ = writeln!(
            out,
            "forecasts averaged: {} (--average {} --average-mode {})",
            average.describe(),
            average.k,
            average.mode
        );
    }
    let _ = write!(out, "{:<6} {:<12} {:>7}", "dof", "method", "origins");
    for (lead, _) in &leads {
        let _ = write!(out, " {:>17}", format!("rms/skill {lead} s"));
    }
    let _ = writeln!(out, " {:>9} {:>11} {:>5}", "train s", "forecast us", "mc");
    for entry in entries {
        match entry {
            Entry::Done(r) => {
                let _ = write!(
                    out,
                    "{:<6} {:<12} {:>7}",
                    r.dof.name(),
                    r.method.name(),
                    r.origins
                );
                for &(_, step) in &leads {
                    let rms = r.rms[step - 1];
                    // Against a persistence that never errs (a constant series) there is no
                    // skill to state: "-", where the table said -inf or NaN (review).
                    let s = skill(rms, r.persistence_rms[step - 1]);
                    let _ = write!(
                        out,
                        " {:>10.4} {:>6}",
                        rms,
                        shipcast_wire::shown::fixed_or_dash(s, 3)
                    );
                }
                let mc = r
                    .minor_components
                    .map_or_else(|| "-".to_string(), |m| m.to_string());
                let _ = writeln!(
                    out,
                    " {:>9.3} {:>11.2} {:>5}",
                    r.train_seconds,
                    r.predict_seconds * 1e6,
                    mc
                );
            }
            Entry::Failed(f) => {
                let _ = writeln!(
                    out,
                    "{:<6} {:<12} error: {}",
                    f.dof.name(),
                    f.method.name(),
                    f.error
                );
            }
        }
    }
    let _ = writeln!(
        out,
        "rms in m (surge, sway, heave) or rad (roll, pitch, yaw); skill = 1 - (rms / rms of persistence)^2"
    );
    out
}

#[cfg(test)]
mod tests {
    use super::super::run::{EvalFailure, EvalResult};
    use super::*;
    use shipcast_predict::{Averaging, Method};
    use shipcast_wire::Dof;

    /// Regression (review): columns named by the nominal lead showed another step at rates
    /// other than 2 Hz, twice the same step, or none at all.
    #[test]
    fn each_column_is_a_step_of_its_own_labelled_with_its_own_lead() {
        // 2 Hz, the protocol's rate: the nominal leads are steps 1, 10, 20, 40.
        assert_eq!(
            lead_steps(2.0, 50),
            [(0.5, 1), (5.0, 10), (10.0, 20), (20.0, 40)]
        );
        // 1 Hz: 0.5 s is no step; the nearest is 1 s, and the column says so.
        assert_eq!(lead_steps(1.0, 10), [(1.0, 1), (5.0, 5), (10.0, 10)]);
        // 0.1 Hz: 0.5 s, 5 s and 10 s all round to the first step, shown once.
        assert_eq!(lead_steps(0.1, 5), [(10.0, 1), (20.0, 2)]);
        // 8 Hz with a horizon of 3 steps: no nominal lead fits; the first and last steps.
        assert_eq!(lead_steps(8.0, 3), [(0.125, 1), (0.375, 3)]);
        assert_eq!(lead_steps(8.0, 1), [(0.125, 1)]);
    }

    /// A heave result at 2 Hz with `horizon` steps, its errors left at zero.
    fn heave_result(method: Method, horizon: usize) -> EvalResult {
        EvalResult {
            dof: Dof::Heave,
            method,
            order: 40,
            horizon,
            train: 100,
            stride: 1,
            sample_rate: 2.0,
            noise_pct: 0.0,
            seed: 1,
            origins: 77,
            rms: vec![0.0; horizon],
            nrmse: vec![0.0; horizon],
            persistence_rms: vec![0.0; horizon],
            rms_clean: None,
            test_std: 1.0,
            train_seconds: 0.5,
            predict_seconds: 2e-6,
            update_seconds: 0.0,
            minor_components: None,
            energy: None,
            ridge: None,
            mca_weighting: None,
            average: Averaging::NONE,
            average_weights: None,
        }
    }

    #[test]
    fn table_shows_leads_within_horizon_and_failures() {
        let horizon = 12; // 6 s at 2 Hz: 0.5 s and 5 s only
        let mut result = heave_result(Method::Mca, horizon);
        result.rms = (1..=horizon).map(|h| h as f64 * 0.01).collect();
        result.persistence_rms = vec![0.2; horizon];
        result.minor_components = Some(13);
        let failure = EvalFailure {
            dof: Dof::Heave,
            method: Method::Mlp,
            error: "infeasible configuration: x".into(),
        };
        let text = table(&[Entry::Done(result), Entry::Failed(failure)], 2.0, horizon);
        assert!(text.contains("rms/skill 0.5 s") && text.contains("rms/skill 5 s"));
        assert!(!text.contains("10 s"));
        // Step 1 (0.5 s): rms 0.01, skill 1 - (0.01/0.2)^2 = 0.9975; step 10 (5 s): rms 0.1, skill 0.75.
        assert!(text.contains("0.0100  0.998"), "{text}");
        assert!(text.contains("0.1000  0.750"), "{text}");
        assert!(text.contains("   13\n"), "{text}");
        assert!(text.contains("mlp          error: infeasible configuration: x"));
    }

    #[test]
    fn skill_over_a_persistence_that_never_errs_is_shown_as_a_dash() {
        let result = |rms: f64| EvalResult {
            rms: vec![rms],
            persistence_rms: vec![0.0],
            test_std: 0.0,
            ..heave_result(Method::Wiener, 1)
        };
        let text = table(
            &[Entry::Done(result(0.0)), Entry::Done(result(0.5))],
            2.0,
            1,
        );
        assert!(!text.contains("inf") && !text.contains("NaN"), "{text}");
        assert!(
            text.contains("0.0000      -") && text.contains("0.5000      -"),
            "{text}"
        );
    }
}
