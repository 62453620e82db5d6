//! The paper's averaged forecasts, measured: MCA with the paper's settings and with the
//! predictor service's default, each forecast combined with those of the same instants from the
//! K - 1 origins before it (uniform mean or least-squares weights fitted on the training segment,
//! see [`shipcast_predict::averaging`]), on the dense sea, on another realisation of it (trained on
//! one seed, tested on another) and on a measured-sea motion record when one is given.

use super::plan::sim_config;
use super::plan::Plan;
use super::seas::SeaKind;
use super::seas::{Sea, STUDY_RATE_HZ};
use super::skill::overall;
use super::tables::{num, Table};
use super::variant::Variant;
use shipcast_eval::{score_with_average, std_dev, EvalError};
use shipcast_predict::{AnyPredictor, AverageMode, Averaging, Method, Predictor, PredictorConfig};
use shipcast_series::motion_csv::MotionData;
use shipcast_series::resample_motion;
use shipcast_wire::Dof;
use std::fmt::Write;

/// A measured-sea motion record's heave at the study rate (2 Hz).
#[derive(Clone, Debug)]
pub struct MeasuredSeries {
    /// What the report calls it (the file name).
    pub title: String,
    pub heave: Vec<f64>,
    /// The record as read, at its own rate (what the engine's replay runs on).
    pub data: MotionData,
}

impl MeasuredSeries {
    /// Read a motion CSV with a `heave_m` column and bring it to 2 Hz with the evaluation's
    /// own filter.
    pub fn read(path: &std::path::Path) -> anyhow::Result<Self> {
        use anyhow::Context;
        let data = MotionData::read_path(path)
            .with_context(|| format!("reading the measured record {}", path.display()))?;
        let resampled = resample_motion(&data, STUDY_RATE_HZ)
            .with_context(|| format!("resampling {}", path.display()))?;
        let heave = resampled
            .dof(Dof::Heave)
            .with_context(|| format!("measured record {}", path.display()))?
            .to_vec();
        if heave.len() < MIN_MEASURED_VALUES {
            anyhow::bail!(
                "measured record {}: {} values at {STUDY_RATE_HZ} Hz ({:.0} s) are too few for the study: it needs at least {MIN_MEASURED_VALUES} ({:.0} minutes)",
                path.display(),
                heave.len(),
                heave.len() as f64 / STUDY_RATE_HZ,
                MIN_MEASURED_VALUES as f64 / STUDY_RATE_HZ / 60.0
            );
        }
        // Regression (review): a dead heave channel (all 0, or held at one value) gave a
        // report of NaN and inf rows, 100 % coverage, and exit 0. The study trains on the
        // first half and scores on the second: each must move.
        let (first, second) = heave.split_at(heave.len() / 2);
        for (half, part) in [("first", first), ("second", second)] {
            let (lo, hi) = part
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &x| {
                    (lo.min(x), hi.max(x))
                });
            if hi - lo <= 1e-9 * hi.abs().max(lo.abs()).max(1e-12) {
                anyhow::bail!(
                    "measured record {}: heave_m does not move in the {half} half of the record (a dead or frozen sensor?): there is no motion to study",
                    path.display()
                );
            }
        }
        let title = path.file_name().map_or_else(
            || path.display().to_string(),
            |n| n.to_string_lossy().into_owned(),
        );
        Ok(Self { title, heave, data })
    }
}

/// The fewest values (at the study's 2 Hz) a measured record must hold: half trains, and the
/// small order (100) with the horizon (50) must fit twice in that half. Regression (review):
/// a record of 2 s gave a section of "MCA-0" rows, every one failed, and exit 0.
pub const MIN_MEASURED_VALUES: usize = 600;

/// The numbers of forecasts combined (1 = the newest alone).
pub const AVERAGE_KS: [usize; 4] = [1, 2, 5, 10];

/// Which series the averaging runs on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AverageSea {
    /// Train and test on the dense sea, as Table 1.
    Dense,
    /// Train on the dense sea, test on another realisation (seed + 1) at the same positions.
    OtherRealisation,
    /// Train and test on the measured-sea motion given with `--measured`.
    Measured,
}

impl AverageSea {
    pub const ALL: [AverageSea; 3] = [
        AverageSea::Dense,
        AverageSea::OtherRealisation,
        AverageSea::Measured,
    ];

    pub fn name(self) -> &'static str {
        match self {
            AverageSea::Dense => "dense sea",
            AverageSea::OtherRealisation => "other realisation",
            AverageSea::Measured => "measured sea",
        }
    }
}

/// Which MCA settings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AverageSetting {
    /// The paper's settings at the big order.
    Paper,
    /// shipcast's eigenvalue-weighted MCA (inverse weighting, shift 2, validated ridge) at
    /// order 400 (at most the plan's big order): the predictor service's default when this
    /// section was written; the service now defaults to a validated Wiener predictor.
    WeightedMca,
}

/// Order of the weighted-MCA rows (the service's former default).
const WEIGHTED_MCA_ORDER: usize = 400;

impl AverageSetting {
    pub const ALL: [AverageSetting; 2] = [AverageSetting::Paper, AverageSetting::WeightedMca];

    /// The predictor configuration of this setting in `plan`.
    pub fn config(self, plan: &Plan) -> PredictorConfig {
        match self {
            AverageSetting::Paper => Variant::Paper.config(plan, plan.big_order(), plan.horizon),
            AverageSetting::WeightedMca => PredictorConfig {
                order: WEIGHTED_MCA_ORDER.min(plan.big_order()),
                horizon: plan.horizon,
                seed: plan.seed,
                mca_weighting: shipcast_predict::McaWeighting::Inverse,
                mca_shift: 2,
                mca_validate_energy: true,
                ..PredictorConfig::default()
            },
        }
    }

    pub fn describe(self, plan: &Plan) -> String {
        let c = self.config(plan);
        match self {
            AverageSetting::Paper => format!("MCA-{}, paper settings", c.order),
            AverageSetting::WeightedMca => format!(
                "MCA-{}, shipcast weighted ({} weighting, shift {}, validated)",
                c.order, c.mca_weighting, c.mca_shift
            ),
        }
    }
}

/// The combinations measured: K = 1 once, then uniform and weighted for every larger K.
pub fn averagings() -> Vec<Averaging> {
    let mut all = vec![Averaging::NONE];
    for &k in AVERAGE_KS.iter().filter(|&&k| k > 1) {
        for mode in [AverageMode::Uniform, AverageMode::Weighted] {
            all.push(Averaging { k, mode });
        }
    }
    all
}

/// One combination's result.
#[derive(Clone, Debug)]
pub struct AveragedScores {
    pub average: Averaging,
    pub origins: usize,
    pub rms: Vec<f64>,
    /// Weighted: the fitted weights (newest first) of every step, all K available.
    pub weights: Option<Vec<Vec<f64>>>,
}

/// Every combination on one series.
#[derive(Clone, Debug)]
pub struct AveragedSeries {
    /// Standard deviation of the test segment: about the error of forecasting zero.
    pub test_std: f64,
    /// K = 1 first.
    pub scores: Vec<AveragedScores>,
}

/// One (series, setting) with every combination, or why it could not run.
#[derive(Clone, Debug)]
pub struct AverageOutcome {
    pub sea: AverageSea,
    pub setting: AverageSetting,
    pub result: Result<AveragedSeries, String>,
}

/// Fit MCA with `config` on `train[..plan.train]` and score every combination on
/// `test[plan.train..]` (history before that index is the test series' own). MCA learns
/// nothing online, so one fit serves every combination; the weights see `train[..plan.train]`
/// only.
pub fn measure(
    config: &PredictorConfig,
    plan: &Plan,
    train: &[f64],
    test: &[f64],
) -> Result<AveragedSeries, EvalError> {
    let first = plan.train;
    let training = train.get(..first).ok_or(EvalError::TooShort {
        len: train.len(),
        train: first,
        order: config.order,
        horizon: config.horizon,
        needed: first + config.order + config.horizon,
    })?;
    let mut predictor = AnyPredictor::new(Method::Mca, config)?;
    predictor.fit(training)?;
    let mut all = Vec::new();
    for average in averagings() {
        let (scores, weights) = score_with_average(
            &mut predictor,
            training,
            test,
            first,
            plan.stride,
            None,
            average,
            &|_| {},
        )?;
        all.push(AveragedScores {
            average,
            origins: scores.origins,
            rms: scores.rms,
            weights,
        });
    }
    Ok(AveragedSeries {
        test_std: std_dev(&test[first..]),
        scores: all,
    })
}

/// The heave series the averaging runs on.
pub struct Seas<'a> {
    pub dense: &'a [f64],
    /// Another realisation of the dense sea.
    pub other: &'a [f64],
    pub measured: Option<&'a MeasuredSeries>,
}

/// The dense sea of the study simulated with the next seed (same length as the study's seas).
pub fn other_realisation(plan: &Plan) -> anyhow::Result<Sea> {
    let mut config = sim_config(SeaKind::Dense, plan);
    config.seed = plan.seed.wrapping_add(1);
    Sea::simulate(
        "other",
        "dense sea, another realisation".into(),
        &config,
        plan.len(),
    )
}

/// MCA heave with every averaging, trained and tested as `sea` says.
pub fn outcome(
    sea: AverageSea,
    setting: AverageSetting,
    plan: &Plan,
    seas: &Seas<'_>,
) -> AverageOutcome {
    let series = match sea {
        AverageSea::Dense => Ok((seas.dense, seas.dense)),
        AverageSea::OtherRealisation => Ok((seas.dense, seas.other)),
        AverageSea::Measured => seas
            .measured
            .map(|m| (m.heave.as_slice(), m.heave.as_slice()))
            .ok_or_else(|| "no measured record given".to_string()),
    };
    let result = series.and_then(|(train, test)| {
        measure(&setting.config(plan), plan, train, test).map_err(|e| e.to_string())
    });
    AverageOutcome {
        sea,
        setting,
        result,
    }
}

/// Only this section of the study (`shipcast paper --averaging-only`): simulate the dense sea
/// and its other realisation, run every (series, setting), return the section's Markdown.
pub fn run_alone(plan: &Plan, measured: Option<&MeasuredSeries>) -> anyhow::Result<String> {
    plan.validate().map_err(anyhow::Error::msg)?;
    let dense = Sea::simulate(
        "dense",
        "realistic dense sea".into(),
        &sim_config(SeaKind::Dense, plan),
        plan.len(),
    )?;
    let other = other_realisation(plan)?;
    let seas = Seas {
        dense: dense.series(Dof::Heave),
        other: other.series(Dof::Heave),
        measured,
    };
    let mut outcomes = Vec::new();
    for sea in AverageSea::ALL {
        if sea == AverageSea::Measured && measured.is_none() {
            continue;
        }
        for setting in AverageSetting::ALL {
            tracing::info!(sea = sea.name(), setting = ?setting, "averaged forecasts");
            outcomes.push(outcome(sea, setting, plan, &seas));
        }
    }
    let mut s = String::new();
    section(&outcomes, plan, measured.map(|m| m.title.as_str()), &mut s);
    Ok(s)
}

/// Steps (1-based) of the table's leads at 2 Hz: 5, 10 and 20 s.
const TABLE_STEPS: [usize; 3] = [10, 20, 40];

/// The report's section: one table row per (series, setting, combination).
pub fn section(
    outcomes: &[AverageOutcome],
    plan: &Plan,
    measured_title: Option<&str>,
    s: &mut String,
) {
    let _ = writeln!(
        s,
        "## Averaged forecasts (the paper's mean of several predictions of the same point)\n\n\
         Every origin forecasts the next {h} steps, so an instant is predicted by the last K \
         origins at K different leads. 'uniform K' is the paper's mean of those forecasts; \
         'weighted K' combines them with least-squares weights per step, fitted on forecasts \
         made inside the training segment and scored against it (ridge {ridge} relative to the \
         mean diagonal). Forecasts are made at every origin; the scored origins are every \
         {stride}-th of the test segment. Heave RMS error [m] at 5, 10 and 20 s, the whole \
         horizon ('all', root mean square over the steps) and its change against the newest \
         forecast alone (K = 1); 'test std' is about the error of forecasting zero, and a sum of \
         weights well below 1 means the weighted combination mostly shrinks the forecast towards \
         zero. 'other realisation': trained on seed {seed}, tested on the \
         same positions of seed {other} (the out-of-sample check).{measured}\n",
        h = plan.horizon,
        ridge = shipcast_predict::averaging::WEIGHT_RIDGE,
        stride = plan.stride,
        seed = plan.seed,
        other = plan.seed.wrapping_add(1),
        measured = measured_title.map_or(String::new(), |t| format!(
            " 'measured sea': {t}, first {} values (2 Hz) for training, the rest for testing.",
            plan.train
        )),
    );
    let mut table = Table::new(&[
        "series",
        "MCA",
        "forecast",
        "5 s",
        "10 s",
        "20 s",
        "all",
        "vs K = 1",
        "sum of weights at 10 s",
        "test std",
    ]);
    for o in outcomes {
        let setting = o.setting.describe(plan);
        let (rows, test_std) = match &o.result {
            Ok(r) => (&r.scores, r.test_std),
            Err(e) => {
                table.row(vec![o.sea.name().into(), setting, format!("error: {e}")]);
                continue;
            }
        };
        let base = rows.first().map(|r| overall(&r.rms));
        for r in rows {
            let at = |step: usize| r.rms.get(step - 1).map_or("-".into(), |v| num(*v, 3));
            let all = overall(&r.rms);
            let change = base.map_or("-".into(), |b| format!("{:+.1} %", 100.0 * (all / b - 1.0)));
            let weight_sum = r
                .weights
                .as_ref()
                .and_then(|w| w.get(TABLE_STEPS[1] - 1))
                .map_or("-".into(), |w| num(w.iter().sum(), 3));
            let name = match (r.average.k, r.average.mode) {
                (1, _) => "newest (K = 1)".to_string(),
                (k, mode) => format!("{mode} {k}"),
            };
            let mut cells = vec![o.sea.name().into(), setting.clone(), name];
            cells.extend(TABLE_STEPS.iter().map(|&st| at(st)));
            cells.extend([num(all, 3), change, weight_sum, num(test_std, 3)]);
            table.row(cells);
        }
    }
    let _ = writeln!(s, "{}", table.to_markdown());
    let _ = writeln!(s, "{}\n", verdict(outcomes));
}

/// Plain words: for each series and setting, whether the best uniform and the best weighted
/// combination beat the newest forecast over the whole horizon, and whether that beats
/// forecasting zero (about the test segment's standard deviation).
pub fn verdict(outcomes: &[AverageOutcome]) -> String {
    let mut lines = Vec::new();
    for o in outcomes {
        let Ok(series) = &o.result else { continue };
        let rows = &series.scores;
        let Some(base) = rows.first().map(|r| overall(&r.rms)) else {
            continue;
        };
        let best = |mode: AverageMode| {
            rows.iter()
                .filter(|r| !r.average.is_none() && r.average.mode == mode)
                .map(|r| (r.average.k, overall(&r.rms)))
                .min_by(|a, b| a.1.total_cmp(&b.1))
        };
        let say = |mode: AverageMode| match best(mode) {
            Some((k, e)) => {
                let change = 100.0 * (e / base - 1.0);
                let effect = if e < base { "helps" } else { "does not help" };
                let zero = if e >= series.test_std {
                    ", no better than forecasting zero"
                } else {
                    ""
                };
                format!("{mode} {effect} (best K = {k}, {change:+.1} %{zero})")
            }
            None => format!("{mode} not run"),
        };
        lines.push(format!(
            "- {}, {}: {}; {}.",
            o.sea.name(),
            match o.setting {
                AverageSetting::Paper => "paper settings",
                AverageSetting::WeightedMca => "weighted MCA",
            },
            say(AverageMode::Uniform),
            say(AverageMode::Weighted)
        ));
    }
    lines.join("\n")
}
