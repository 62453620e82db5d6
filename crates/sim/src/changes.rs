//! Non-stationary records: a course change and a sea-state change at given record times.
//!
//! - **Course change.** The wave field stays the same (same components, fixed on the earth);
//!   the ship turns so that the mean relative wave direction goes from the configured heading
//!   to `new_heading_deg`, linearly over `turn_s` seconds from `at_s`. Every component's relative
//!   direction shifts by the same angle D(t). Its phase at the moving CG is
//!   w t - k U int_0^t cos(beta + D(s)) ds + eps (closed form for a linear ramp), so at zero speed
//!   the phases do not change at all, and at speed the encounter frequency follows the turn. The
//!   response uses the RAO at the current direction (quasi-static: right for turns slow against
//!   the wave period, which a ship's turn is). Before `at_s` the record equals the stationary
//!   simulation sample for sample; after the turn at zero speed it equals the stationary
//!   simulation at the new heading with the same seed.
//! - **Sea-state change.** A second, independent sea (seed + 1, same spectrum family, DNV
//!   gamma, new Hs and Tp) replaces the first over `ramp_s` seconds from `at_s`, as a
//!   power-preserving cross-fade: old * cos(pi u / 2) + new * sin(pi u / 2), u from 0 to 1, so
//!   the variance moves smoothly from the old to the new one. Before `at_s` the record is the
//!   old sea, after the ramp exactly the stationary simulation of the new sea (seed + 1).
//!
//! Both can be combined (the turn applies to both seas). Evaluation is direct (one sin/cos per
//! component and sample; RAOs evaluated per sample only while turning), nothing allocates per
//! sample.

use super::motion::{point, CHANNELS, WAVE_CHANNEL};
use super::rao::{signed_encounter_omega, Response};
use super::{MotionPoint, ShipMotion, SimConfig, SimError, G};
use faer::c64;
use shipcast_wire::shown::number;
use std::f64::consts::FRAC_PI_2;

/// A turn of the ship at a given record time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CourseChange {
    /// Record time the turn starts [s].
    pub at_s: f64,
    /// Mean relative wave direction after the turn [deg], 180 = head seas, 90 = beam seas.
    pub new_heading_deg: f64,
    /// Duration of the turn [s] (0 = instantaneous).
    pub turn_s: f64,
}

/// A change of sea state at a given record time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SeaChange {
    /// Record time the cross-fade starts [s].
    pub at_s: f64,
    /// Significant wave height of the new sea [m].
    pub hs_m: f64,
    /// Peak period of the new sea [s].
    pub tp_s: f64,
    /// Duration of the cross-fade [s] (0 = instantaneous).
    pub ramp_s: f64,
}

fn check_time(what: &str, at_s: f64, span_s: f64) -> Result<(), SimError> {
    if !(at_s.is_finite() && at_s >= 0.0) {
        return Err(SimError::Config(format!(
            "{what} time must be >= 0 s, got {}",
            number(at_s)
        )));
    }
    if !(span_s.is_finite() && span_s >= 0.0) {
        return Err(SimError::Config(format!(
            "{what} duration must be >= 0 s, got {}",
            number(span_s)
        )));
    }
    Ok(())
}

/// Fraction of a ramp from `at_s` over `span_s` done at `t`, in [0, 1].
fn progress(t: f64, at_s: f64, span_s: f64) -> f64 {
    if t <= at_s {
        0.0
    } else if t >= at_s + span_s {
        1.0
    } else {
        (t - at_s) / span_s
    }
}

/// One sea's components as the turning ship sees them.
#[derive(Debug)]
struct TurningSea {
    motion: ShipMotion,
    /// Responses at the initial and the final direction, per component.
    before: Vec<Response>,
    after: Vec<Response>,
    /// +1 or -1: the sign of each component's encounter frequency at the initial direction
    /// (the stationary simulator's phase convention uses |w_e|).
    sign: Vec<f64>,
}

impl TurningSea {
    fn new(motion: ShipMotion, turn_rad: f64) -> Self {
        let speed = motion.config().speed_mps();
        let rao = motion.rao();
        let before = motion
            .components()
            .iter()
            .map(|c| rao.response(c.omega, c.beta, speed))
            .collect();
        let after = motion
            .components()
            .iter()
            .map(|c| rao.response(c.omega, c.beta + turn_rad, speed))
            .collect();
        let sign = motion
            .components()
            .iter()
            .map(|c| signed_encounter_omega(c.omega, c.beta, speed).signum())
            .collect();
        TurningSea {
            motion,
            before,
            after,
            sign,
        }
    }

    /// Adds `weight` times this sea's channels at `t` to `acc`.
    fn add(&self, t: f64, course: &Turn, weight: f64, acc: &mut [f64; CHANNELS]) {
        let speed = self.motion.config().speed_mps();
        let rao = self.motion.rao();
        let turned = course.angle(t);
        for (i, c) in self.motion.components().iter().enumerate() {
            let k = c.omega * c.omega / G;
            let theta = c.omega * t - k * speed * course.integral_of_cos(c.beta, t);
            let phase = self.sign[i] * theta + c.phase;
            let (s, co) = phase.sin_cos();
            let wave = c64::new(c.amplitude * co, c.amplitude * s);
            let response: Response;
            let h = match course.stage(t) {
                Stage::Before => &self.before[i],
                Stage::After => &self.after[i],
                Stage::Turning => {
                    response = rao.response(c.omega, c.beta + turned, speed);
                    &response
                }
            };
            // The RAO convention is relative to |w_e|: when the turn flips the sign of the
            // encounter frequency against the convention used for the phase, conjugate.
            let current = signed_encounter_omega(c.omega, c.beta + turned, speed).signum();
            let flip = current != self.sign[i] && current != 0.0;
            for (a, hj) in acc.iter_mut().zip(h.iter()) {
                let hj = if flip { hj.conj() } else { *hj };
                *a += weight * (hj * wave).re;
            }
            acc[WAVE_CHANNEL] += weight * wave.re;
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Stage {
    Before,
    Turning,
    After,
}

/// The relative-direction change D(t): 0, then a linear ramp, then the full turn.
#[derive(Clone, Copy, Debug)]
struct Turn {
    at_s: f64,
    span_s: f64,
    angle_rad: f64,
}

impl Turn {
    const NONE: Turn = Turn {
        at_s: f64::INFINITY,
        span_s: 0.0,
        angle_rad: 0.0,
    };

    fn stage(&self, t: f64) -> Stage {
        if t <= self.at_s {
            Stage::Before
        } else if t >= self.at_s + self.span_s {
            Stage::After
        } else {
            Stage::Turning
        }
    }

    fn angle(&self, t: f64) -> f64 {
        self.angle_rad * progress(t, self.at_s, self.span_s)
    }

    /// int_0^t cos(beta + D(s)) ds in closed form.
    fn integral_of_cos(&self, beta: f64, t: f64) -> f64 {
        let before = t.min(self.at_s).max(0.0);
        let mut sum = before * beta.cos();
        if t > self.at_s {
            let turning = (t - self.at_s).min(self.span_s);
            let rate = if self.span_s > 0.0 {
                self.angle_rad / self.span_s
            } else {
                0.0
            };
            sum += if rate.abs() * turning < 1e-9 {
                turning * (beta + 0.5 * rate * turning).cos()
            } else {
                ((beta + rate * turning).sin() - beta.sin()) / rate
            };
            let after = t - self.at_s - self.span_s;
            if after > 0.0 {
                sum += after * (beta + self.angle_rad).cos();
            }
        }
        sum
    }
}

/// A simulated record with a course change and/or a sea-state change.
#[derive(Debug)]
pub struct ChangingMotion {
    old: TurningSea,
    new: Option<(TurningSea, SeaChange)>,
    turn: Turn,
}

impl ChangingMotion {
    /// The record of `config` with the given changes (at least one of them).
    pub fn new(
        config: &SimConfig,
        course: Option<CourseChange>,
        sea: Option<SeaChange>,
    ) -> Result<Self, SimError> {
        let turn = match course {
            Some(c) => {
                check_time("course change", c.at_s, c.turn_s)?;
                if !c.new_heading_deg.is_finite() {
                    return Err(SimError::Config(
                        "the new heading must be a finite number of degrees".into(),
                    ));
                }
                Turn {
                    at_s: c.at_s,
                    span_s: c.turn_s,
                    angle_rad: (c.new_heading_deg - config.heading_deg).to_radians(),
                }
            }
            None => Turn::NONE,
        };
        let old = TurningSea::new(ShipMotion::new(config)?, turn.angle_rad);
        let new = match sea {
            Some(change) => {
                check_time("sea-state change", change.at_s, change.ramp_s)?;
                let new_config = Self::new_sea_config(config, &change);
                let motion = ShipMotion::new(&new_config)?;
                Some((TurningSea::new(motion, turn.angle_rad), change))
            }
            None => None,
        };
        Ok(ChangingMotion { old, new, turn })
    }

    /// The stationary configuration the record turns into after a sea-state change: Hs and
    /// Tp of the change, DNV gamma, seed + 1, everything else as before.
    pub fn new_sea_config(config: &SimConfig, change: &SeaChange) -> SimConfig {
        let mut c = config.clone();
        c.hs_m = change.hs_m;
        c.tp_s = change.tp_s;
        c.gamma = None;
        c.seed = config.seed.wrapping_add(1);
        c
    }

    /// The sea before any change.
    pub fn initial(&self) -> &ShipMotion {
        &self.old.motion
    }

    /// The sea after a sea-state change, if any.
    pub fn final_sea(&self) -> Option<&ShipMotion> {
        self.new.as_ref().map(|(s, _)| &s.motion)
    }

    /// The motion at record time `t` [s].
    pub fn sample_at(&self, t: f64) -> MotionPoint {
        let mut acc = [0.0; CHANNELS];
        let (w_old, w_new) = match &self.new {
            Some((_, change)) => {
                let u = progress(t, change.at_s, change.ramp_s);
                (FRAC_PI_2 * u).cos_sin_pair()
            }
            None => (1.0, 0.0),
        };
        if w_old > 0.0 {
            self.old.add(t, &self.turn, w_old, &mut acc);
        }
        if let Some((sea, _)) = &self.new {
            if w_new > 0.0 {
                sea.add(t, &self.turn, w_new, &mut acc);
            }
        }
        point(t, &acc)
    }
}

/// (cos x, sin x) with exact 1 and 0 at the ends of the cross-fade.
trait CosSinPair {
    fn cos_sin_pair(self) -> (f64, f64);
}

impl CosSinPair for f64 {
    fn cos_sin_pair(self) -> (f64, f64) {
        if self <= 0.0 {
            (1.0, 0.0)
        } else if self >= FRAC_PI_2 {
            (0.0, 1.0)
        } else {
            (self.cos(), self.sin())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Channel, Scenario};

    fn std_over(m: &ChangingMotion, from: f64, to: f64, j: usize) -> f64 {
        let n = ((to - from) * 2.0) as usize;
        let sum_sq: f64 = (0..n)
            .map(|i| m.sample_at(from + i as f64 * 0.5).dof[j].powi(2))
            .sum();
        (sum_sq / n as f64).sqrt()
    }

    #[test]
    fn a_course_change_keeps_the_record_before_and_becomes_the_new_heading_after() {
        let mut cfg = SimConfig::scenario(Scenario::Paper);
        cfg.speed_kn = 0.0;
        cfg.heading_deg = 180.0;
        cfg.spreading = crate::Spreading::None; // long-crested: no roll in head seas
        let course = CourseChange {
            at_s: 600.0,
            new_heading_deg: 90.0,
            turn_s: 60.0,
        };
        let m = ChangingMotion::new(&cfg, Some(course), None).unwrap();
        let head = ShipMotion::new(&cfg).unwrap();
        let mut beam_cfg = cfg.clone();
        beam_cfg.heading_deg = 90.0;
        let beam = ShipMotion::new(&beam_cfg).unwrap();
        for t in [0.0, 123.4, 599.9, 600.0] {
            let (a, b) = (m.sample_at(t), head.sample_at(t));
            assert!((a.wave_m - b.wave_m).abs() < 1e-9);
            for j in 0..6 {
                assert!((a.dof[j] - b.dof[j]).abs() < 1e-9, "t {t} dof {j}");
            }
        }
        for t in [660.0, 1000.0, 3599.0] {
            let (a, b) = (m.sample_at(t), beam.sample_at(t));
            for j in 0..6 {
                assert!((a.dof[j] - b.dof[j]).abs() < 1e-9, "t {t} dof {j}");
            }
        }
        // Head seas: no roll; beam seas: roll. The turn shows in the record.
        let roll = Channel::Motion(shipcast_wire::Dof::Roll).index();
        assert!(std_over(&m, 0.0, 600.0, roll) < 1e-3 * std_over(&m, 700.0, 1300.0, roll));
    }

    #[test]
    fn a_course_change_at_speed_gives_the_new_headings_std() {
        let cfg = SimConfig::scenario(Scenario::Paper); // 11 kn, 165 deg
        let course = CourseChange {
            at_s: 300.0,
            new_heading_deg: 90.0,
            turn_s: 120.0,
        };
        let m = ChangingMotion::new(&cfg, Some(course), None).unwrap();
        let head = ShipMotion::new(&cfg).unwrap();
        let a = m.sample_at(200.0);
        let b = head.sample_at(200.0);
        for j in 0..6 {
            assert!((a.dof[j] - b.dof[j]).abs() < 1e-9, "dof {j}");
        }
        let mut beam_cfg = cfg.clone();
        beam_cfg.heading_deg = 90.0;
        let beam = ShipMotion::new(&beam_cfg).unwrap();
        for ch in [
            Channel::Motion(shipcast_wire::Dof::Heave),
            Channel::Motion(shipcast_wire::Dof::Roll),
        ] {
            let exact = beam.variance(ch).sqrt();
            let got = std_over(&m, 600.0, 3600.0, ch.index());
            assert!((got / exact - 1.0).abs() < 0.15, "{ch:?}: {got} vs {exact}");
        }
    }

    #[test]
    fn a_sea_state_change_crosses_over_to_the_new_sea() {
        let cfg = SimConfig::scenario(Scenario::Ss4);
        let (hs, tp) = Scenario::Ss6.sea_state();
        let change = SeaChange {
            at_s: 900.0,
            hs_m: hs,
            tp_s: tp,
            ramp_s: 300.0,
        };
        let m = ChangingMotion::new(&cfg, None, Some(change)).unwrap();
        let old = ShipMotion::new(&cfg).unwrap();
        let new = ShipMotion::new(&ChangingMotion::new_sea_config(&cfg, &change)).unwrap();
        for (t, reference) in [(0.0, &old), (899.0, &old), (1200.0, &new), (3000.0, &new)] {
            let (a, b) = (m.sample_at(t), reference.sample_at(t));
            assert!((a.wave_m - b.wave_m).abs() < 1e-9, "t {t}");
            for j in 0..6 {
                assert!((a.dof[j] - b.dof[j]).abs() < 1e-9, "t {t} dof {j}");
            }
        }
        let heave = Channel::Motion(shipcast_wire::Dof::Heave);
        let got = std_over(&m, 1500.0, 4500.0, heave.index());
        let exact = new.variance(heave).sqrt();
        assert!((got / exact - 1.0).abs() < 0.15, "{got} vs {exact}");
        assert!(exact > 2.0 * old.variance(heave).sqrt());
    }

    #[test]
    fn bad_change_settings_are_errors() {
        let cfg = SimConfig::default();
        let bad_time = CourseChange {
            at_s: -1.0,
            new_heading_deg: 90.0,
            turn_s: 60.0,
        };
        assert!(ChangingMotion::new(&cfg, Some(bad_time), None).is_err());
        let bad_sea = SeaChange {
            at_s: 10.0,
            hs_m: -2.0,
            tp_s: 9.0,
            ramp_s: 60.0,
        };
        assert!(ChangingMotion::new(&cfg, None, Some(bad_sea)).is_err());
    }
}
