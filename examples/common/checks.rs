//! What an example checks in a forecast before printing from it. Shared memory and the network
//! carry whatever another process wrote: a value the pipeline's own consumers would refuse
//! (NaN, a negative sigma, a step beyond `steps`, a lead of 1e308 s) is skipped with one line,
//! never printed as if it were a forecast.

use shipcast_wire::payload::{Forecast, MAX_ABS_MOTION, MAX_STEPS};

/// Longest forecast step accepted [s]: the pipeline forecasts at 0.5 s; a minute is already
/// no forecast a ship acts on.
const MAX_DT_S: f64 = 60.0;

/// The index of the step at `lead_s` (the nearest one, within the forecast), after checking
/// the forecast's shape and the values of `dofs` at that step.
pub fn step_at(f: &Forecast, lead_s: f64, dofs: &[usize]) -> Result<usize, String> {
    if f.steps == 0 || f.steps as usize > MAX_STEPS {
        return Err(format!("steps {} (1..={MAX_STEPS})", f.steps));
    }
    if !(f.dt_s > 0.0 && f.dt_s <= MAX_DT_S) {
        return Err(format!("dt_s {} (0 < dt_s <= {MAX_DT_S})", f.dt_s));
    }
    if !f.time_s.is_finite() {
        return Err(format!("time_s {}", f.time_s));
    }
    let k = ((lead_s / f.dt_s).round() as usize).clamp(1, f.steps as usize) - 1;
    for &d in dofs {
        let (mean, sigma) = (f64::from(f.mean[d][k]), f64::from(f.sigma[d][k]));
        // NaN is in no range: refused as well.
        let bounded = (-MAX_ABS_MOTION..=MAX_ABS_MOTION).contains(&mean);
        if !bounded || !(0.0..=MAX_ABS_MOTION).contains(&sigma) {
            return Err(format!(
                "DOF {d} step {}: mean {mean}, sigma {sigma}",
                k + 1
            ));
        }
    }
    Ok(k)
}
