//! What the page shows, per vessel, and when a vessel counts as stale.
//!
//! The board keeps only the newest accepted message of each kind per vessel; a snapshot is what
//! one server-sent event carries. A vessel whose newest forecast is older than `stale_after` is
//! shown as stale: its forecast and advisory are withheld, never shown as if current.

use serde::{Deserialize, Serialize};
use shipcast_wire::payload::Forecast;
use shipcast_wire::Dof;
use std::collections::BTreeMap;
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// The deck limits drawn on the roll and pitch charts.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Limits {
    pub roll_deg: f64,
    pub pitch_deg: f64,
}

/// One motion's forecast: the mean and sigma per step (heave in m, roll and pitch in deg).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Track {
    pub mean: Vec<f32>,
    pub sigma: Vec<f32>,
}

impl Track {
    fn of(f: &Forecast, dof: Dof, scale: f32) -> Self {
        Track {
            mean: f.mean_of(dof.index()).iter().map(|v| v * scale).collect(),
            sigma: f.sigma_of(dof.index()).iter().map(|v| v * scale).collect(),
        }
    }
}

/// The newest accepted forecast of a vessel, as the page draws it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ForecastView {
    pub seq: u64,
    pub time_s: f64,
    pub model_version: u32,
    pub dt_s: f64,
    pub steps: u32,
    pub heave: Track,
    pub roll: Track,
    pub pitch: Track,
}

impl ForecastView {
    pub fn of(f: &Forecast) -> Self {
        let deg = 180.0 / std::f32::consts::PI;
        ForecastView {
            seq: f.seq,
            time_s: f.time_s,
            model_version: f.model_version,
            dt_s: f.dt_s,
            steps: f.steps,
            heave: Track::of(f, Dof::Heave, 1.0),
            roll: Track::of(f, Dof::Roll, deg),
            pitch: Track::of(f, Dof::Pitch, deg),
        }
    }
}

/// The go/no-go of a station's advisory, as the deck's landing decision and the lift decision
/// of `shipcast relative` publish it (`decision` in their JSON): the fields the page shows.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DecisionView {
    pub mot_s: f64,
    pub go_probability: f64,
    pub go: bool,
    /// Probability that every limit holds over the window of MOT from now; None when the
    /// horizon is shorter than MOT or (`awaiting_verified_errors`) before verified errors.
    pub probability_now: Option<f64>,
    /// Start of the first window that reaches `go_probability` (absent from a lift decision
    /// of a service older than 2026-12-07).
    #[serde(default)]
    pub next_window_s: Option<f64>,
    #[serde(default)]
    pub next_window_probability: Option<f64>,
    /// First step at which a predicted mean breaks a limit.
    pub next_exceedance_s: Option<f64>,
    /// Verified error paths behind the probability; 0 while it still comes from the Gaussian
    /// model (absent from a lift decision of a service older than 2026-12-05).
    #[serde(default)]
    pub ensemble_members: Option<usize>,
    /// The station states no probability yet: no verified errors back one.
    #[serde(default)]
    pub awaiting_verified_errors: bool,
    /// The station states no probability: this DOF's sensor repeats its value (a frozen sensor).
    #[serde(default)]
    pub frozen_dof: Option<Dof>,
    /// A lift decision's frozen sensor is on this ship (the deck's is on its own).
    #[serde(default)]
    pub frozen_ship: Option<shipcast_pipeline::relative::still::Ship>,
}

/// A station's advisory, as published on `.../advisory/<station>`; parsing it into this type
/// is its check (a message without a decision is rejected).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AdvisoryView {
    pub time_s: f64,
    /// The deck's predicted maxima over the horizon (a lift advisory has none).
    #[serde(default)]
    pub max_roll_deg: Option<f64>,
    #[serde(default)]
    pub max_pitch_deg: Option<f64>,
    pub decision: DecisionView,
    /// Set by the board, never read from the wire: seconds since this advisory arrived, once
    /// that is longer than the stale limit (its station stopped publishing: the page shows
    /// the station as stale, not its last decision).
    #[serde(default, skip_deserializing)]
    pub stale_s: Option<f64>,
}

impl AdvisoryView {
    /// Whether the advisory makes sense before the page shows it: probabilities in [0, 1],
    /// times finite and not negative, and a go only with a probability that reaches its
    /// threshold. Regression: a forged `go: true` without a probability was drawn as a green
    /// "NO-GO", and absurd numbers went on the page as they came.
    pub fn check(&self) -> Result<(), String> {
        let d = &self.decision;
        let probability = |what: &str, p: Option<f64>| match p {
            Some(p) if !(0.0..=1.0).contains(&p) => Err(format!("{what} {p} is not in [0, 1]")),
            _ => Ok(()),
        };
        let time = |what: &str, t: Option<f64>| match t {
            Some(t) if !(t.is_finite() && t >= 0.0) => {
                Err(format!("{what} {t} is not a finite time >= 0"))
            }
            _ => Ok(()),
        };
        probability("probability_now", d.probability_now)?;
        probability("next_window_probability", d.next_window_probability)?;
        if !(d.go_probability > 0.0 && d.go_probability <= 1.0) {
            return Err(format!(
                "go_probability {} is not in (0, 1]",
                d.go_probability
            ));
        }
        if !(d.mot_s.is_finite() && d.mot_s > 0.0) {
            return Err(format!("mot_s {} is not a finite time > 0", d.mot_s));
        }
        time("next_window_s", d.next_window_s)?;
        time("next_exceedance_s", d.next_exceedance_s)?;
        if !self.time_s.is_finite() {
            return Err(format!("time_s {} is not finite", self.time_s));
        }
        for (what, v) in [
            ("max_roll_deg", self.max_roll_deg),
            ("max_pitch_deg", self.max_pitch_deg),
        ] {
            if v.is_some_and(|v| !v.is_finite()) {
                return Err(format!("{what} is not finite"));
            }
        }
        if d.go && !d.probability_now.is_some_and(|p| p >= d.go_probability) {
            return Err("go without a probability that reaches go_probability".into());
        }
        // A station that waits for verified errors, or has a frozen sensor, states no
        // probability and never says go (review: a forged go with both was drawn as a green GO).
        if d.go && d.awaiting_verified_errors {
            return Err("go while awaiting verified errors".into());
        }
        if d.go && (d.frozen_dof.is_some() || d.frozen_ship.is_some()) {
            return Err("go with a frozen sensor".into());
        }
        Ok(())
    }
}

/// The live skill of one DOF: NRMSE against predicting zero at 5, 10 and 20 s (None where the
/// horizon or the scored forecasts do not reach), and the lead where skill ends.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SkillView {
    pub dof: String,
    pub nrmse_at: [Option<f64>; 3],
    pub skill_horizon_s: f64,
}

/// Leads at which the page shows the live skill [s].
pub const SKILL_LEADS_S: [f64; 3] = [5.0, 10.0, 20.0];

/// The part of the predictor's verification JSON the page uses.
#[derive(Debug, Deserialize)]
pub struct VerificationIn {
    pub dt_s: f64,
    pub dofs: Vec<DofVerificationIn>,
}

#[derive(Debug, Deserialize)]
pub struct DofVerificationIn {
    pub dof: String,
    pub nrmse_zero: Vec<Option<f64>>,
    pub skill_horizon_s: Option<f64>,
}

impl VerificationIn {
    /// Skill of heave, roll and pitch; None when the message does not make sense.
    fn skill(&self) -> Option<Vec<SkillView>> {
        if !(self.dt_s.is_finite() && self.dt_s > 0.0) {
            return None;
        }
        let shown = [Dof::Heave, Dof::Roll, Dof::Pitch];
        // The first entry of each shown DOF only: a forged report repeating one DOF must not
        // make the board keep (and send to every page) a row per repetition (review).
        let views = shown
            .iter()
            .filter_map(|s| self.dofs.iter().find(|d| d.dof == s.name()))
            .map(|d| SkillView {
                dof: d.dof.clone(),
                nrmse_at: SKILL_LEADS_S.map(|lead| {
                    let k = (lead / self.dt_s).round() as usize;
                    k.checked_sub(1)
                        .and_then(|i| d.nrmse_zero.get(i).copied().flatten())
                        .filter(|v| v.is_finite())
                }),
                skill_horizon_s: d.skill_horizon_s.filter(|v| v.is_finite()).unwrap_or(0.0),
            })
            .collect();
        Some(views)
    }
}

/// What one vessel shows in one snapshot.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct VesselView {
    pub vessel: String,
    /// No forecast for longer than the stale limit (or none yet): nothing current to show.
    pub stale: bool,
    /// Seconds since the newest accepted forecast arrived (None: none yet).
    pub age_s: Option<f64>,
    /// The newest accepted forecast; withheld while stale.
    pub forecast: Option<ForecastView>,
    /// Deck advisories per station; withheld while stale.
    pub advisories: BTreeMap<String, AdvisoryView>,
    pub skill: Vec<SkillView>,
    /// Messages refused for this vessel (receive checks, malformed JSON).
    pub rejected: u64,
}

/// One server-sent event: every vessel heard so far.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Snapshot {
    pub limits: Limits,
    pub stale_after_s: f64,
    pub vessels: Vec<VesselView>,
    /// Messages dropped because they named a vessel or station beyond the board's bounds.
    pub beyond_bounds: u64,
    /// Messages refused (bad JSON, failed checks) for a vessel not on the board: counted
    /// here, so that a refused message never makes a board entry.
    pub rejected_unheard: u64,
}

/// Most vessels, and stations per vessel, the board holds. Names come from zenoh keys, which
/// any peer allowed to publish can make up: without a bound each made-up name would be kept
/// for good and sent to every page.
pub const MAX_VESSELS: usize = 64;
pub const MAX_STATIONS: usize = 16;

/// Why a forecast was not put on the board.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Refused {
    #[error("forecast seq {got} does not follow {last} from a live publisher")]
    Seq { last: u64, got: u64 },
    #[error("the board holds {MAX_VESSELS} vessels already")]
    BeyondBounds,
}

#[derive(Debug, Default)]
struct Vessel {
    forecast: Option<ForecastView>,
    forecast_at: Option<Instant>,
    /// The zenoh id of the session that sent the shown forecast (its attachment).
    publisher: Option<String>,
    /// Each station's last advisory and when it arrived.
    advisories: BTreeMap<String, (AdvisoryView, Instant)>,
    /// The live skill and when it arrived: withheld once older than the stale limit, so that
    /// a dead predictor's skill is not shown beside a new one's forecasts (review).
    skill: Vec<SkillView>,
    skill_at: Option<Instant>,
    rejected: u64,
}

/// The shared state of the display: written by the zenoh callbacks, read by the server.
#[derive(Debug)]
pub struct Board {
    vessels: Mutex<BTreeMap<String, Vessel>>,
    limits: Limits,
    stale_after: Duration,
    beyond_bounds: std::sync::atomic::AtomicU64,
    rejected_unheard: std::sync::atomic::AtomicU64,
}

impl Board {
    pub fn new(limits: Limits, stale_after: Duration) -> Self {
        Board {
            vessels: Mutex::new(BTreeMap::new()),
            limits,
            stale_after,
            beyond_bounds: Default::default(),
            rejected_unheard: Default::default(),
        }
    }

    /// Run `f` on the vessel's entry, made if new; None (and counted) when the board holds
    /// `MAX_VESSELS` others already. With `make_room` (a forecast arriving at that instant) a
    /// full board first drops the entry stale the longest (one never sent a forecast first):
    /// names made up by stray or hostile messages must not keep a live vessel off the board
    /// for good. A board of 64 live vessels still refuses the 65th.
    fn with_vessel<R>(
        &self,
        vessel: &str,
        make_room: Option<Instant>,
        f: impl FnOnce(&mut Vessel) -> R,
    ) -> Option<R> {
        // A panic elsewhere never leaves the map half-written (every update is one assignment),
        // so a poisoned lock is still safe to use.
        let mut map = self.vessels.lock().unwrap_or_else(|p| p.into_inner());
        // A known vessel (every message but its first): its name is not copied again.
        if let Some(v) = map.get_mut(vessel) {
            return Some(f(v));
        }
        if map.len() >= MAX_VESSELS {
            let stalest = make_room.and_then(|now| {
                map.iter()
                    .filter(|(_, v)| self.is_stale(v.forecast_at, now))
                    .min_by_key(|(_, v)| v.forecast_at)
                    .map(|(name, _)| name.clone())
            });
            match stalest {
                Some(name) => {
                    map.remove(&name);
                }
                None => {
                    self.count_beyond_bounds();
                    return None;
                }
            }
        }
        Some(f(map.entry(vessel.to_string()).or_default()))
    }

    fn count_beyond_bounds(&self) {
        let n = self
            .beyond_bounds
            .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        if n.is_power_of_two() || n == 0 {
            tracing::warn!(
                dropped = n + 1,
                "display: messages naming more than {MAX_VESSELS} vessels or {MAX_STATIONS} stations per vessel are dropped"
            );
        }
    }

    fn is_stale(&self, at: Option<Instant>, now: Instant) -> bool {
        at.is_none_or(|t| now.saturating_duration_since(t) > self.stale_after)
    }

    /// Put a forecast (already through the content checks) on the board. Its seq must follow
    /// the shown one, except after the vessel went stale (a restarted predictor counts from 0).
    pub fn forecast(&self, vessel: &str, f: &Forecast, now: Instant) -> Result<(), Refused> {
        self.forecast_from(vessel, f, None, now)
    }

    /// [`Board::forecast`] from the session `publisher` (the id its put carries): seq must
    /// follow the shown one within one publisher's stream only. Regression: a predictor
    /// restarted within the stale limit had its forecasts refused (seq from 0 again) while
    /// the dead one's last forecast stayed on the page as live.
    pub fn forecast_from(
        &self,
        vessel: &str,
        f: &Forecast,
        publisher: Option<&str>,
        now: Instant,
    ) -> Result<(), Refused> {
        self.with_vessel(vessel, Some(now), |v| {
            let live = !self.is_stale(v.forecast_at, now);
            let same_stream = v.publisher.as_deref() == publisher;
            if let (true, true, Some(shown)) = (live, same_stream, &v.forecast) {
                if f.seq <= shown.seq {
                    v.rejected += 1;
                    return Err(Refused::Seq {
                        last: shown.seq,
                        got: f.seq,
                    });
                }
            }
            v.forecast = Some(ForecastView::of(f));
            v.forecast_at = Some(now);
            // Copied only when it changes (a new publisher), not with every forecast.
            if v.publisher.as_deref() != publisher {
                v.publisher = publisher.map(str::to_string);
            }
            Ok(())
        })
        .unwrap_or(Err(Refused::BeyondBounds))
    }

    /// Count a message refused before it reached the board (bad JSON, failed checks): on the
    /// vessel's entry if it has one, else in `rejected_unheard` (a refused message never makes
    /// an entry: junk on 64 made-up keys filled the board and kept real vessels off it).
    pub fn reject(&self, vessel: &str) {
        let mut map = self.vessels.lock().unwrap_or_else(|p| p.into_inner());
        match map.get_mut(vessel) {
            Some(v) => v.rejected += 1,
            None => self.reject_unheard(),
        }
    }

    /// Count a message refused before it could name a vessel (a key whose names break the
    /// naming rule).
    pub fn reject_unheard(&self) {
        self.rejected_unheard
            .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    }

    /// Put a station's advisory on the board, received at `now`. Regression: a dead deck's
    /// last advisory (a GO among them) was shown as current for as long as the vessel's
    /// forecasts kept coming; now it is marked stale once older than the stale limit.
    /// An advisory that fails [`AdvisoryView::check`] is refused and counted (false).
    pub fn advisory(
        &self,
        vessel: &str,
        station: &str,
        advisory: AdvisoryView,
        now: Instant,
    ) -> bool {
        if let Err(e) = advisory.check() {
            tracing::debug!("display: {vessel}/{station}: refused advisory: {e}");
            self.reject(vessel);
            return false;
        }
        let kept = self.with_vessel(vessel, None, |v| {
            if let Some(kept) = v.advisories.get_mut(station) {
                *kept = (advisory, now);
                return true;
            }
            if v.advisories.len() >= MAX_STATIONS {
                return false;
            }
            v.advisories.insert(station.to_string(), (advisory, now));
            true
        });
        if kept == Some(false) {
            self.count_beyond_bounds();
        }
        true
    }

    /// Take the live skill from a verification message received at `now`; false (and
    /// counted) if it is malformed.
    pub fn verification(&self, vessel: &str, report: &VerificationIn, now: Instant) -> bool {
        match report.skill() {
            Some(skill) => {
                self.with_vessel(vessel, None, |v| {
                    v.skill = skill;
                    v.skill_at = Some(now);
                });
                true
            }
            None => {
                self.reject(vessel);
                false
            }
        }
    }

    pub fn snapshot(&self, now: Instant) -> Snapshot {
        let map = self.vessels.lock().unwrap_or_else(|p| p.into_inner());
        let vessels = map
            .iter()
            .map(|(name, v)| {
                let stale = self.is_stale(v.forecast_at, now);
                VesselView {
                    vessel: name.clone(),
                    stale,
                    age_s: v
                        .forecast_at
                        .map(|t| now.saturating_duration_since(t).as_secs_f64()),
                    forecast: if stale { None } else { v.forecast.clone() },
                    advisories: if stale {
                        BTreeMap::new()
                    } else {
                        v.advisories
                            .iter()
                            .map(|(station, (a, at))| {
                                let mut a = a.clone();
                                a.stale_s = self
                                    .is_stale(Some(*at), now)
                                    .then(|| now.saturating_duration_since(*at).as_secs_f64());
                                (station.clone(), a)
                            })
                            .collect()
                    },
                    // A stale vessel's skill is its dead predictor's: withheld like its forecast,
                    // and so is skill no report has renewed within the stale limit.
                    skill: if stale || self.is_stale(v.skill_at, now) {
                        Vec::new()
                    } else {
                        v.skill.clone()
                    },
                    rejected: v.rejected,
                }
            })
            .collect();
        Snapshot {
            limits: self.limits,
            stale_after_s: self.stale_after.as_secs_f64(),
            vessels,
            beyond_bounds: self
                .beyond_bounds
                .load(std::sync::atomic::Ordering::Relaxed),
            rejected_unheard: self
                .rejected_unheard
                .load(std::sync::atomic::Ordering::Relaxed),
        }
    }

    /// The snapshot as the JSON one event carries.
    pub fn snapshot_json(&self, now: Instant) -> String {
        // Plain numbers, strings and maps with string keys: serialising cannot fail; if it
        // ever did, the page would keep its last picture rather than get garbage.
        serde_json::to_string(&self.snapshot(now)).unwrap_or_else(|_| "{}".to_string())
    }
}

#[cfg(test)]
mod tests;
