//! The report's measured-sea section (`shipcast paper --measured FILE.csv`): the paper's methods
//! and the references trained on the first part of a measured-sea heave record and scored at
//! every origin of the rest, and the engine run over the whole record exactly as the service
//! runs it ([`shipcast_pipeline::engine::replay::replay`], default configuration, no start-up model), with
//! its delivered error and the coverage of its sigma.

use super::averaging::MeasuredSeries;
use super::plan::Plan;
use super::seas::STUDY_RATE_HZ;
use super::tables::{num, Table};
use super::variant::Variant;
use shipcast_eval::{evaluate_method, prepare_series, EvalSettings};
use shipcast_pipeline::config::PredictorServiceConfig;
use shipcast_pipeline::engine::replay::replay;
use shipcast_predict::{Averaging, Method};
use shipcast_wire::Dof;
use std::fmt::Write;

/// Leads of the section's tables [s] and their steps at 2 Hz.
pub const LEADS_S: [f64; 3] = [5.0, 10.0, 20.0];
const STEPS: [usize; 3] = [10, 20, 40];
/// The smaller Wiener order of the section (the paper's 100).
const SMALL_ORDER: usize = 100;

/// One row of the section: an offline method, or the engine.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MeasuredRow {
    /// MCA with the paper's settings at the big order.
    McaPaper,
    /// shipcast's eigenvalue-weighted MCA (shift 2, validated ridge) at the big order.
    McaWeighted,
    WienerSmall,
    WienerBig,
    Persistence,
    Zero,
    /// The engine as the service runs it, over the whole record.
    Engine,
}

impl MeasuredRow {
    pub const ALL: [MeasuredRow; 7] = [
        MeasuredRow::McaPaper,
        MeasuredRow::McaWeighted,
        MeasuredRow::WienerSmall,
        MeasuredRow::WienerBig,
        MeasuredRow::Persistence,
        MeasuredRow::Zero,
        MeasuredRow::Engine,
    ];

    /// Method, order and MCA variant of an offline row (`None` for the engine).
    fn method(self, split: &Split) -> Option<(Method, usize, Variant)> {
        let big = split.big_order;
        Some(match self {
            MeasuredRow::McaPaper => (Method::Mca, big, Variant::Paper),
            MeasuredRow::McaWeighted => (Method::Mca, big, Variant::InverseValidated),
            MeasuredRow::WienerSmall => (Method::Wiener, split.small_order, Variant::Paper),
            MeasuredRow::WienerBig => (Method::Wiener, big, Variant::Paper),
            MeasuredRow::Persistence => (Method::Persistence, SMALL_ORDER, Variant::Paper),
            MeasuredRow::Zero => (Method::Zero, SMALL_ORDER, Variant::Paper),
            MeasuredRow::Engine => return None,
        })
    }

    pub fn label(self, split: &Split) -> String {
        match self.method(split) {
            None => "engine as the service runs it (default configuration, delivered)".into(),
            Some((Method::Mca, order, Variant::Paper)) => format!("MCA-{order}, paper settings"),
            Some((Method::Mca, order, v)) => {
                format!("shipcast MCA-{order}, {} (not the paper's)", v.name())
            }
            Some((Method::Wiener, order, _)) => format!("Wiener-{order}"),
            Some((method, _, _)) => method.to_string(),
        }
    }
}

/// How a record is split: values of the training part (2 Hz) and the orders it allows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Split {
    pub train: usize,
    pub test: usize,
    pub big_order: usize,
    pub small_order: usize,
}

impl Split {
    /// The plan's training length, or the first half of a shorter record; the plan's big order,
    /// or half the training part when that is shorter (MCA's validation needs 1.25 times the
    /// order).
    pub fn of(plan: &Plan, len: usize) -> Self {
        let train = plan.train.min(len / 2);
        let big_order = plan.big_order().min(train / 2);
        Self {
            train,
            test: len - train,
            big_order,
            small_order: SMALL_ORDER.min(big_order),
        }
    }
}

/// The engine's delivered scores on heave at [`LEADS_S`].
#[derive(Clone, Debug, PartialEq)]
pub struct EngineScores {
    pub nrmse: [f64; 3],
    pub coverage_1sigma: [f64; 3],
    pub coverage_2sigma: [f64; 3],
    pub scored: u64,
    pub retrains: u64,
    pub implausible: u64,
    /// Largest error over the motion's standard deviation about its mean.
    pub max_error_over_std: f64,
}

/// What one row measured.
#[derive(Clone, Debug, PartialEq)]
pub enum RowScores {
    /// Error over the test segment's std at [`LEADS_S`], and the origins scored.
    Offline {
        nrmse: [f64; 3],
        origins: usize,
    },
    Engine(EngineScores),
}

#[derive(Clone, Debug)]
pub struct MeasuredOutcome {
    pub row: MeasuredRow,
    pub result: Result<RowScores, String>,
}

/// Value at each of [`STEPS`] of a per-step curve.
fn at_steps(curve: &[f64]) -> Result<[f64; 3], String> {
    let mut out = [0.0; 3];
    for (o, &s) in out.iter_mut().zip(&STEPS) {
        *o = *curve
            .get(s - 1)
            .ok_or_else(|| format!("horizon {} shorter than step {s}", curve.len()))?;
    }
    Ok(out)
}

/// What the report says about a record.
#[derive(Clone, Debug, PartialEq)]
pub struct RecordInfo {
    pub title: String,
    /// Heave values at 2 Hz.
    pub len: usize,
    /// Record time of the first sample [s].
    pub start_s: f64,
}

impl RecordInfo {
    pub fn of(record: &MeasuredSeries) -> Self {
        Self {
            title: record.title.clone(),
            len: record.heave.len(),
            start_s: record.data.time.first().copied().unwrap_or(0.0),
        }
    }

    /// Record time at which the test part begins: the engine's scores start there.
    fn test_start_s(&self, split: &Split) -> f64 {
        self.start_s + split.train as f64 / STUDY_RATE_HZ
    }
}

/// Run one row on `record`.
pub fn outcome(row: MeasuredRow, plan: &Plan, record: &MeasuredSeries) -> MeasuredOutcome {
    let split = Split::of(plan, record.heave.len());
    let result = match row.method(&split) {
        Some((method, order, variant)) => {
            let settings = EvalSettings {
                train: split.train,
                stride: 1,
                sample_rate: STUDY_RATE_HZ,
                noise_pct: 0.0,
                seed: plan.seed,
                average: Averaging::NONE,
            };
            let config = variant.config(plan, order, plan.horizon);
            prepare_series(&record.heave, Dof::Heave, &settings)
                .and_then(|p| evaluate_method(&p, Dof::Heave, method, &config, &settings, &|_| {}))
                .map_err(|e| e.to_string())
                .and_then(|r| {
                    Ok(RowScores::Offline {
                        nrmse: at_steps(&r.nrmse)?,
                        origins: r.origins,
                    })
                })
        }
        None => engine(record, &split).map(RowScores::Engine),
    };
    MeasuredOutcome { row, result }
}

fn engine(record: &MeasuredSeries, split: &Split) -> Result<EngineScores, String> {
    let config = PredictorServiceConfig::default();
    let skip_s = RecordInfo::of(record).test_start_s(split);
    let (report, _) = replay(&record.data, &config, None, skip_s, false, &|_| {})
        .map_err(|e| format!("{e:#}"))?;
    let heave = report
        .dofs
        .iter()
        .find(|d| d.dof == Dof::Heave.name())
        .ok_or("the replay scored no heave")?;
    if heave.scored == 0 {
        return Err(format!("no forecast issued after {skip_s} s was scored"));
    }
    Ok(EngineScores {
        nrmse: at_steps(&heave.nrmse)?,
        coverage_1sigma: at_steps(&heave.coverage_1sigma)?,
        coverage_2sigma: at_steps(&heave.coverage_2sigma)?,
        scored: heave.scored,
        retrains: heave.retrains,
        implausible: heave.implausible,
        max_error_over_std: heave.max_abs_error / heave.std,
    })
}

/// Every row on `record` (for `shipcast paper --measured-only`), in order.
pub fn run_alone(plan: &Plan, record: &MeasuredSeries) -> String {
    let outcomes: Vec<MeasuredOutcome> = MeasuredRow::ALL
        .into_iter()
        .map(|row| {
            tracing::info!(row = ?row, "measured sea");
            outcome(row, plan, record)
        })
        .collect();
    let mut s = String::new();
    section(&outcomes, plan, &RecordInfo::of(record), &mut s);
    s
}

fn nrmse_of(o: &MeasuredOutcome) -> Option<[f64; 3]> {
    match &o.result {
        Ok(RowScores::Offline { nrmse, .. }) => Some(*nrmse),
        Ok(RowScores::Engine(e)) => Some(e.nrmse),
        Err(_) => None,
    }
}

fn mean3(v: [f64; 3]) -> f64 {
    v.iter().sum::<f64>() / 3.0
}

/// The section's verdict: which offline method has the lowest error averaged over the three
/// leads, where the engine stands against it, and against predicting zero (NRMSE 1).
pub fn verdict(outcomes: &[MeasuredOutcome], split: &Split) -> String {
    let best = outcomes
        .iter()
        .filter(|o| o.row != MeasuredRow::Engine)
        .filter_map(|o| nrmse_of(o).map(|n| (o.row, n)))
        .filter(|(_, n)| n.iter().all(|v| v.is_finite()))
        .min_by(|a, b| mean3(a.1).total_cmp(&mean3(b.1)));
    let Some((best_row, best)) = best else {
        return "No offline method produced a score on this record.".into();
    };
    let leads = |n: [f64; 3]| n.iter().map(|v| num(*v, 3)).collect::<Vec<_>>().join(" / ");
    let mut s = format!(
        "On this record the offline method with the lowest error averaged over 5, 10 and 20 s \
         is {} ({} at 5 / 10 / 20 s).",
        best_row.label(split),
        leads(best)
    );
    let per_lead: Vec<String> = LEADS_S
        .iter()
        .enumerate()
        .filter_map(|(i, lead)| {
            outcomes
                .iter()
                .filter(|o| o.row != MeasuredRow::Engine)
                .filter_map(|o| nrmse_of(o).map(|n| (o.row, n[i])))
                .filter(|(_, v)| v.is_finite())
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .filter(|(row, _)| *row != best_row)
                .map(|(row, v)| {
                    format!(
                        "at {} s {} is lower ({})",
                        num(*lead, 2),
                        row.label(split),
                        num(v, 3)
                    )
                })
        })
        .collect();
    if !per_lead.is_empty() {
        let _ = write!(s, " Lead by lead: {}.", per_lead.join("; "));
    }
    let worse_than_zero: Vec<String> = LEADS_S
        .iter()
        .zip(best)
        .filter(|(_, v)| *v >= 1.0)
        .map(|(l, _)| format!("{} s", num(*l, 2)))
        .collect();
    if !worse_than_zero.is_empty() {
        let _ = write!(
            s,
            " It is no better than predicting zero at {}.",
            worse_than_zero.join(", ")
        );
    }
    if let Some(e) = outcomes.iter().find_map(|o| match &o.result {
        Ok(RowScores::Engine(e)) => Some(e),
        _ => None,
    }) {
        let cmp: Vec<String> = LEADS_S
            .iter()
            .enumerate()
            .map(|(i, l)| {
                let word = if e.nrmse[i] <= best[i] {
                    "at or below"
                } else {
                    "above"
                };
                format!("{} at {} s ({word})", num(e.nrmse[i], 3), num(*l, 2))
            })
            .collect();
        let _ = write!(
            s,
            " The engine, which picks its order per DOF on held-out data and shrinks towards \
             zero, delivers {} against that method; its error is {} the motion's standard \
             deviation (what predicting its mean scores) at every lead.",
            cmp.join(", "),
            if e.nrmse.iter().all(|v| *v <= 1.0) {
                "at or below"
            } else {
                "not always below"
            }
        );
    }
    s
}

/// The report's section.
pub fn section(outcomes: &[MeasuredOutcome], plan: &Plan, record: &RecordInfo, s: &mut String) {
    let split = Split::of(plan, record.len);
    let _ = writeln!(
        s,
        "## Measured sea: {title}\n\n\
         Heave of the measured-sea record {title}, brought to 2 Hz with the evaluation's filter \
         ({len} values, {mins} min). The offline methods are trained on the first {train} values \
         ({train_min} min) and scored at every origin (stride 1) of the remaining {test}. The \
         engine runs over the whole record as the service would (`shipcast replay`: default \
         predictor configuration, no start-up model, retraining on live history), and its \
         delivered forecasts issued from {skip} s of record time on (the start of the offline \
         test part) are scored against the record. Every number is error / std of the \
         motion (for the engine too, its standard deviation about the mean): 1 is about what \
         predicting zero scores on this zero-mean record. A lead \
         counts from the newest value each one forecasts from, the time that value represents: \
         the offline series' is its filter's delay (1 s for an 8 Hz record) before the newest sample it holds, the \
         engine's its minimum-phase filter's delay (0.5 s for an 8 Hz record); the offline methods are scored \
         against that filtered series, the engine against the recorded samples.\n",
        title = record.title,
        len = record.len,
        mins = num(record.len as f64 / STUDY_RATE_HZ / 60.0, 3),
        train = split.train,
        train_min = num(split.train as f64 / STUDY_RATE_HZ / 60.0, 3),
        test = split.test,
        skip = num(record.test_start_s(&split), 4),
    );
    let mut t = Table::new(&["method", "5 s", "10 s", "20 s", "forecasts scored"]);
    for o in outcomes {
        let mut row = vec![o.row.label(&split)];
        match &o.result {
            Ok(RowScores::Offline { nrmse, origins }) => {
                row.extend(nrmse.iter().map(|v| num(*v, 3)));
                row.push(origins.to_string());
            }
            Ok(RowScores::Engine(e)) => {
                row.extend(e.nrmse.iter().map(|v| num(*v, 3)));
                row.push(e.scored.to_string());
            }
            Err(e) => row.push(format!(
                "failed: {}",
                e.chars().take(80).collect::<String>()
            )),
        }
        t.row(row);
    }
    let _ = writeln!(s, "{}", t.to_markdown());
    if let Some(e) = outcomes.iter().find_map(|o| match &o.result {
        Ok(RowScores::Engine(e)) => Some(e),
        _ => None,
    }) {
        let mut c = Table::new(&["engine, heave", "5 s", "10 s", "20 s"]);
        for (label, v) in [
            ("within +-1 sigma (nominal 68.3 %)", e.coverage_1sigma),
            ("within +-2 sigma (nominal 95.4 %)", e.coverage_2sigma),
        ] {
            let mut row = vec![label.to_string()];
            row.extend(v.iter().map(|x| format!("{} %", num(100.0 * x, 3))));
            c.row(row);
        }
        let _ = writeln!(
            s,
            "Coverage of the engine's sigma, {} retrains over the record, {} implausible \
             forecasts replaced, largest error {} times the motion's std:\n\n{}",
            e.retrains,
            e.implausible,
            num(e.max_error_over_std, 3),
            c.to_markdown()
        );
    }
    let _ = writeln!(s, "**Which method wins.** {}\n", verdict(outcomes, &split));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn split_keeps_the_plan_on_long_records_and_halves_short_ones() {
        let plan = Plan::full(1);
        let long = Split::of(&plan, 30_000);
        assert_eq!(
            (long.train, long.big_order, long.small_order),
            (5000, 800, 100)
        );
        assert_eq!(long.test, 25_000);
        let short = Split::of(&plan, 1000);
        assert_eq!((short.train, short.test), (500, 500));
        assert_eq!((short.big_order, short.small_order), (250, 100));
        let tiny = Split::of(&plan, 100);
        assert_eq!((tiny.big_order, tiny.small_order), (25, 25));
    }

    #[test]
    fn at_steps_picks_5_10_and_20_s_or_says_the_horizon_is_short() {
        let curve: Vec<f64> = (1..=50).map(f64::from).collect();
        assert_eq!(at_steps(&curve).unwrap(), [10.0, 20.0, 40.0]);
        assert!(at_steps(&curve[..30]).unwrap_err().contains("step 40"));
    }

    fn offline(row: MeasuredRow, nrmse: [f64; 3]) -> MeasuredOutcome {
        MeasuredOutcome {
            row,
            result: Ok(RowScores::Offline { nrmse, origins: 10 }),
        }
    }

    #[test]
    fn verdict_names_the_lowest_mean_and_the_leads_where_another_is_lower() {
        let split = Split::of(&Plan::full(1), 30_000);
        let outcomes = [
            offline(MeasuredRow::WienerSmall, [0.5, 0.8, 1.05]),
            offline(MeasuredRow::WienerBig, [0.45, 0.9, 1.1]),
            offline(MeasuredRow::Zero, [1.0, 1.0, 1.0]),
        ];
        let v = verdict(&outcomes, &split);
        assert!(v.contains("is Wiener-100 (0.500 / 0.800 / 1.05"), "{v}");
        assert!(v.contains("at 5.0 s Wiener-800 is lower (0.450)"), "{v}");
        assert!(v.contains("at 20 s zero is lower"), "{v}");
        assert!(v.contains("no better than predicting zero at 20 s"), "{v}");
        assert!(!v.contains("engine"), "{v}");
    }
}
