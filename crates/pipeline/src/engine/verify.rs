//! Live verification: every delivered forecast is scored, step by step, as the values it
//! predicted arrive, over a rolling window of record time. The report is what the predictor
//! publishes on zenoh `.../verification` and what `shipcast run` shows.

use super::rolling::RollingSums;
use serde::Serialize;
use shipcast_wire::payload::{MAX_STEPS, NUM_DOF};
use shipcast_wire::Dof;

const N: usize = 0;
const EE: usize = 1;
const XX: usize = 2;
const PP: usize = 3;
const IN1: usize = 4;
const IN2: usize = 5;
const SS: usize = 6;
const SX: usize = 7;

/// One issued forecast, kept until its last step has been scored.
#[derive(Debug, Clone)]
pub struct Issued {
    /// Decimated-value index of the newest value the forecast used.
    pub index: u64,
    pub steps: usize,
    /// Model version that made it (only its own forecasts teach a model's calibration).
    pub version: u32,
    /// The newest value per DOF (persistence's forecast).
    pub last: [f64; NUM_DOF],
    /// The level per DOF the forecast was issued about (`level.rs`).
    pub level: [f64; NUM_DOF],
    /// The model's own output, before recalibration: the deviation from `level`.
    pub raw: [[f64; MAX_STEPS]; NUM_DOF],
    /// What was delivered.
    pub mean: [[f64; MAX_STEPS]; NUM_DOF],
    pub sigma: [[f64; MAX_STEPS]; NUM_DOF],
    /// The RMS sigma the calibrator measured, before the shape factor and the change
    /// detector's inflation: what the detector and the shape factor measure against.
    pub sigma_calibrated: [[f64; MAX_STEPS]; NUM_DOF],
    /// Per DOF, the RMS of the recorded sample less the decimated value at issue
    /// (`Engine::label_mismatch`): with `sigma_calibrated`, what an error against the recorded
    /// motion is measured against by the shape factor.
    pub label_miss: [f64; NUM_DOF],
    /// Per DOF, whether it was delivered as no skill (held after a jump, without its input,
    /// implausible, or a failed model): the level, with a sigma floor of its own.
    pub no_skill: [bool; NUM_DOF],
    /// Per DOF, whether it was held at no skill after a jump of its level (`jump.rs`): its
    /// model's output then is about the jump, not the sea.
    pub held: [bool; NUM_DOF],
}

impl Default for Issued {
    fn default() -> Self {
        Self {
            index: 0,
            steps: 0,
            version: 0,
            last: [0.0; NUM_DOF],
            level: [0.0; NUM_DOF],
            raw: [[0.0; MAX_STEPS]; NUM_DOF],
            mean: [[0.0; MAX_STEPS]; NUM_DOF],
            sigma: [[0.0; MAX_STEPS]; NUM_DOF],
            held: [false; NUM_DOF],
            label_miss: [0.0; NUM_DOF],
            no_skill: [false; NUM_DOF],
            sigma_calibrated: [[0.0; MAX_STEPS]; NUM_DOF],
        }
    }
}

/// The last `MAX_STEPS` forecasts, newest last; a slot is reused once its forecast is done.
#[derive(Debug, Clone)]
pub struct ForecastLog {
    slots: Vec<Issued>,
    next: usize,
    len: usize,
}

impl Default for ForecastLog {
    fn default() -> Self {
        Self {
            slots: vec![Issued::default(); MAX_STEPS + 1],
            next: 0,
            len: 0,
        }
    }
}

impl ForecastLog {
    /// The slot for a new forecast (overwrites the oldest).
    pub fn push(&mut self) -> &mut Issued {
        let i = self.next;
        self.next = (self.next + 1) % self.slots.len();
        self.len = (self.len + 1).min(self.slots.len());
        &mut self.slots[i]
    }

    /// Forecasts that have a step at value index `index`, with that step's index (0-based).
    pub fn due(&self, index: u64) -> impl Iterator<Item = (&Issued, usize)> {
        let cap = self.slots.len();
        (0..self.len).filter_map(move |back| {
            let f = &self.slots[(self.next + cap - 1 - back) % cap];
            let lead = index.checked_sub(f.index)?;
            (lead >= 1 && (lead as usize) <= f.steps).then(|| (f, lead as usize - 1))
        })
    }

    /// Forget every pending forecast (the record broke: what they predicted never comes).
    pub fn clear(&mut self) {
        self.len = 0;
    }
}

/// Rolling scores of the delivered forecasts.
#[derive(Debug, Clone)]
pub struct Verifier {
    sums: RollingSums<8>,
}

impl Verifier {
    pub fn new(window_values: usize) -> Self {
        Self {
            sums: RollingSums::new(window_values, 20),
        }
    }

    /// Step index `k` of a delivered forecast (`mean`, `sigma`), issued when the value was
    /// `last`, turned out to be `x`.
    #[inline]
    pub fn observe(&mut self, d: usize, k: usize, mean: f64, sigma: f64, last: f64, x: f64) {
        let e = x - mean;
        let p = x - last;
        let a = e.abs();
        self.sums.add(
            d,
            k,
            [
                1.0,
                e * e,
                x * x,
                p * p,
                f64::from(u8::from(a <= sigma)),
                f64::from(u8::from(a <= 2.0 * sigma)),
                sigma * sigma,
                x,
            ],
        );
    }

    pub fn tick(&mut self) {
        self.sums.tick();
    }

    pub fn clear(&mut self, d: usize) {
        self.sums.clear(d);
    }

    /// The scores over the window, per DOF with any scored step, `dt_s` apart.
    pub fn report(&self, steps: usize, dt_s: f64, window_s: f64) -> VerificationReport {
        let mut dofs = Vec::new();
        for dof in Dof::ALL {
            let d = dof.index();
            let mut s = DofVerification {
                dof: dof.name(),
                ..DofVerification::default()
            };
            for k in 0..steps.min(MAX_STEPS) {
                let v = self.sums.get(d, k);
                let n = v[N];
                s.scored.push(n as u64);
                let ratio = |a: f64| if n > 0.0 { (a / n).sqrt() } else { f64::NAN };
                s.rms.push(ratio(v[EE]));
                s.zero_rms.push(ratio(v[XX]));
                s.persistence_rms.push(ratio(v[PP]));
                s.mean_sigma.push(ratio(v[SS]));
                let frac = |a: f64| if n > 0.0 { a / n } else { f64::NAN };
                s.coverage_1sigma.push(frac(v[IN1]));
                s.coverage_2sigma.push(frac(v[IN2]));
                // About the window's mean: a list or trim is motion the forecast need not
                // find, and would make a forecast look skilful for longer.
                // NaN (null in the JSON) where nothing was scored: `max` would make it 0.
                let mean = frac(v[SX]);
                let var = frac(v[XX] - n * mean * mean);
                s.std.push(if var.is_nan() {
                    var
                } else {
                    var.max(0.0).sqrt()
                });
            }
            if s.scored.iter().all(|&n| n == 0) {
                continue;
            }
            s.nrmse_zero = s.rms.iter().zip(&s.zero_rms).map(|(a, b)| a / b).collect();
            s.nrmse_persistence = s
                .rms
                .iter()
                .zip(&s.persistence_rms)
                .map(|(a, b)| a / b)
                .collect();
            s.skill_horizon_s = skill_horizon(&s.rms, &s.std, dt_s);
            dofs.push(s);
        }
        VerificationReport {
            window_s,
            dt_s,
            dofs,
        }
    }
}

/// Lead [s] up to which the error stays below 70 % of the motion's std (per step, over the
/// window): the first step that reaches it ends the trustworthy horizon (0 if step 1 already
/// does; the whole horizon if none).
pub fn skill_horizon(rms: &[f64], std: &[f64], dt_s: f64) -> f64 {
    for (k, (e, z)) in rms.iter().zip(std).enumerate() {
        // A NaN error (nothing scored) ends the horizon too.
        if e.is_nan() || *e >= 0.7 * z {
            return k as f64 * dt_s;
        }
    }
    rms.len() as f64 * dt_s
}

/// The live scores (zenoh `.../verification`, JSON).
#[derive(Debug, Clone, Default, Serialize)]
pub struct VerificationReport {
    /// Rolling window of record time the scores cover.
    pub window_s: f64,
    pub dt_s: f64,
    pub dofs: Vec<DofVerification>,
}

/// Per step (index k = lead (k + 1) * dt_s): the delivered forecast's scores.
#[derive(Debug, Clone, Default, Serialize)]
pub struct DofVerification {
    pub dof: &'static str,
    pub scored: Vec<u64>,
    pub rms: Vec<f64>,
    pub zero_rms: Vec<f64>,
    pub persistence_rms: Vec<f64>,
    pub nrmse_zero: Vec<f64>,
    pub nrmse_persistence: Vec<f64>,
    pub mean_sigma: Vec<f64>,
    pub coverage_1sigma: Vec<f64>,
    pub coverage_2sigma: Vec<f64>,
    /// The motion's standard deviation about its mean over the window, at each step's values.
    pub std: Vec<f64>,
    /// Lead at which the live error reaches 70 % of the motion's std.
    pub skill_horizon_s: f64,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_finds_each_step_once_at_its_lead() {
        let mut log = ForecastLog::default();
        for i in 0..300u64 {
            let f = log.push();
            f.index = i;
            f.steps = 5;
        }
        // At index 300, forecasts 295..=299 have a due step (leads 5..=1).
        let mut due: Vec<(u64, usize)> = log.due(300).map(|(f, k)| (f.index, k)).collect();
        due.sort();
        assert_eq!(due, vec![(295, 4), (296, 3), (297, 2), (298, 1), (299, 0)]);
        log.clear();
        assert_eq!(log.due(300).count(), 0);
    }

    #[test]
    fn coverage_and_rms_of_known_errors() {
        let mut v = Verifier::new(1000);
        // Errors alternate 0.5 and 1.5 with sigma 1: half inside 1 sigma, all inside 2 sigma.
        for i in 0..100 {
            let e = if i % 2 == 0 { 0.5 } else { 1.5 };
            v.observe(0, 0, 0.0, 1.0, 0.0, e);
            v.tick();
        }
        let r = v.report(1, 0.5, 500.0);
        assert_eq!(r.dofs.len(), 1);
        let d = &r.dofs[0];
        assert_eq!(d.coverage_1sigma[0], 0.5);
        assert_eq!(d.coverage_2sigma[0], 1.0);
        assert!((d.rms[0] - (1.25f64).sqrt()).abs() < 1e-12);
        assert_eq!(d.mean_sigma[0], 1.0);
        // The values 0.5 and 1.5 (forecast 0): mean 1, std 0.5.
        assert!((d.std[0] - 0.5).abs() < 1e-12, "{}", d.std[0]);
        // A step with nothing scored has no std (null), not 0.
        let r = v.report(2, 0.5, 500.0);
        assert!(r.dofs[0].std[1].is_nan(), "{:?}", r.dofs[0].std);
    }

    /// Regression: the skill horizon compared the error with the motion's RMS about zero, so
    /// a list (a constant the forecast carries) lengthened it without any gain in skill.
    #[test]
    fn a_list_does_not_lengthen_the_skill_horizon() {
        let horizon_with_list = |list: f64| {
            let mut v = Verifier::new(10_000);
            // A sine of amplitude 1 (std 0.71) about `list`, forecast with an error growing
            // with the step: 0.1, 0.3, 0.5, 0.7 at steps 1 to 4.
            for i in 0..2000 {
                let x = list + (i as f64 * 0.37).sin();
                for k in 0..4 {
                    let e = 0.1 + 0.2 * k as f64;
                    v.observe(0, k, x - e, 1.0, x, x);
                }
                v.tick();
            }
            v.report(4, 0.5, 1000.0).dofs[0].skill_horizon_s
        };
        // 70 % of the std 0.707 is 0.495: step 3's error 0.5 ends the horizon at 1.0 s.
        assert_eq!(horizon_with_list(0.0), 1.0);
        assert_eq!(horizon_with_list(3.0), 1.0);
    }

    #[test]
    fn skill_horizon_is_the_first_lead_past_70_percent() {
        let zero = [1.0; 6];
        assert_eq!(
            skill_horizon(&[0.1, 0.3, 0.69, 0.71, 0.5, 0.9], &zero, 0.5),
            1.5
        );
        assert_eq!(skill_horizon(&[0.1; 6], &zero, 0.5), 3.0);
        assert_eq!(skill_horizon(&[0.8; 6], &zero, 0.5), 0.0);
    }
}
