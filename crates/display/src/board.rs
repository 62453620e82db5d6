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
    /// Start of the first window that reaches `go_probability` (the lift decision has none).
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
        let views = self
            .dofs
            .iter()
            .filter(|d| shown.iter().any(|s| s.name() == d.dof))
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
    skill: Vec<SkillView>,
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
            None => {
                self.rejected_unheard
                    .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            }
        }
    }

    /// Put a station's advisory on the board, received at `now`. Regression: a dead deck's
    /// last advisory (a GO among them) was shown as current for as long as the vessel's
    /// forecasts kept coming; now it is marked stale once older than the stale limit.
    pub fn advisory(&self, vessel: &str, station: &str, advisory: AdvisoryView, now: Instant) {
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
    }

    /// Take the live skill from a verification message; false (and counted) if it is malformed.
    pub fn verification(&self, vessel: &str, report: &VerificationIn) -> bool {
        match report.skill() {
            Some(skill) => {
                self.with_vessel(vessel, None, |v| v.skill = skill);
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
                    // A stale vessel's skill is its dead predictor's: withheld like its forecast.
                    skill: if stale { Vec::new() } else { v.skill.clone() },
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
mod tests {
    use super::*;

    fn board() -> Board {
        Board::new(
            Limits {
                roll_deg: 2.5,
                pitch_deg: 1.5,
            },
            Duration::from_secs(3),
        )
    }

    fn forecast(seq: u64, heave: f32, roll_rad: f32) -> Forecast {
        let mut f = Forecast {
            seq,
            time_s: seq as f64 * 0.5,
            dt_s: 0.5,
            steps: 4,
            model_version: 1,
            ..Forecast::default()
        };
        for k in 0..4 {
            f.mean[Dof::Heave.index()][k] = heave;
            f.sigma[Dof::Heave.index()][k] = 0.1 * (k + 1) as f32;
            f.mean[Dof::Roll.index()][k] = roll_rad;
        }
        f
    }

    #[test]
    fn a_forecast_is_shown_in_metres_and_degrees_with_only_its_valid_steps() {
        let b = board();
        let t0 = Instant::now();
        b.forecast(
            "ddg51",
            &forecast(7, 1.25, std::f32::consts::PI / 180.0),
            t0,
        )
        .unwrap();
        let s = b.snapshot(t0);
        assert_eq!(s.vessels.len(), 1);
        let v = &s.vessels[0];
        assert!(!v.stale);
        let f = v.forecast.as_ref().unwrap();
        assert_eq!(f.seq, 7);
        assert_eq!(f.heave.mean, vec![1.25; 4]);
        assert_eq!(f.heave.sigma.len(), 4);
        assert!((f.heave.sigma[3] - 0.4).abs() < 1e-6);
        assert!(
            f.roll.mean.iter().all(|r| (r - 1.0).abs() < 1e-5),
            "{:?}",
            f.roll
        );
    }

    #[test]
    fn a_repeated_or_older_seq_from_a_live_vessel_is_refused_and_counted() {
        let b = board();
        let t0 = Instant::now();
        b.forecast("a", &forecast(10, 1.0, 0.0), t0).unwrap();
        let t1 = t0 + Duration::from_millis(500);
        assert_eq!(
            b.forecast("a", &forecast(10, 9.99, 0.0), t1),
            Err(Refused::Seq { last: 10, got: 10 })
        );
        assert!(b.forecast("a", &forecast(3, 9.99, 0.0), t1).is_err());
        let v = &b.snapshot(t1).vessels[0];
        assert_eq!(v.rejected, 2);
        assert_eq!(
            v.forecast.as_ref().unwrap().heave.mean[0],
            1.0,
            "the forgery is not shown"
        );
    }

    #[test]
    fn made_up_vessel_and_station_names_are_bounded_and_counted() {
        // Regression: every vessel name a key carried (forged ones included, even in a
        // malformed message) was kept for good and sent to every page.
        let b = board();
        let t0 = Instant::now();
        for i in 0..MAX_VESSELS {
            b.forecast(&format!("v{i}"), &forecast(1, 1.0, 0.0), t0)
                .unwrap();
        }
        assert_eq!(
            b.forecast("one-too-many", &forecast(1, 1.0, 0.0), t0),
            Err(Refused::BeyondBounds)
        );
        // A refused message makes no entry: counted apart.
        b.reject("another");
        // A vessel already held is still served.
        b.forecast("v0", &forecast(2, 2.0, 0.0), t0).unwrap();
        let s = b.snapshot(t0);
        assert_eq!(s.vessels.len(), MAX_VESSELS);
        assert_eq!((s.beyond_bounds, s.rejected_unheard), (1, 1));
        assert!(s.vessels.iter().all(|v| v.vessel != "another"));
        let mut advisor = shipcast_pipeline::deck::DeckAdvisor::new(
            &shipcast_pipeline::config::DeckConfig::default(),
        );
        let json = serde_json::to_vec(&advisor.advise(&calm_forecast(50))).unwrap();
        for i in 0..=MAX_STATIONS {
            let a: AdvisoryView = serde_json::from_slice(&json).unwrap();
            b.advisory("v1", &format!("s{i}"), a, t0);
        }
        let s = b.snapshot(t0);
        let v1 = s.vessels.iter().find(|v| v.vessel == "v1").unwrap();
        assert_eq!(v1.advisories.len(), MAX_STATIONS);
        assert_eq!(s.beyond_bounds, 2);
    }

    /// Regression: junk on 64 made-up vessel keys filled the board with entries that never
    /// had a forecast, and a real vessel was kept off it for good.
    #[test]
    fn a_full_board_makes_room_for_a_live_vessel_by_dropping_the_stalest() {
        let b = board();
        let t0 = Instant::now();
        let stale_after = Duration::from_secs_f64(b.snapshot(t0).stale_after_s);
        // 63 vessels that once sent a forecast, at t0, and one that never did (an advisory
        // alone makes an entry).
        for i in 0..MAX_VESSELS - 1 {
            b.forecast(&format!("v{i}"), &forecast(1, 1.0, 0.0), t0)
                .unwrap();
        }
        let json = serde_json::to_vec(
            &shipcast_pipeline::deck::DeckAdvisor::new(
                &shipcast_pipeline::config::DeckConfig::default(),
            )
            .advise(&calm_forecast(50)),
        )
        .unwrap();
        b.advisory("never", "deck", serde_json::from_slice(&json).unwrap(), t0);
        // While all the others are live, the one that never sent a forecast makes room.
        b.forecast("real", &forecast(1, 1.0, 0.0), t0).unwrap();
        let names = |t| -> Vec<String> {
            b.snapshot(t)
                .vessels
                .into_iter()
                .map(|v| v.vessel)
                .collect()
        };
        assert!(!names(t0).contains(&"never".to_string()));
        assert_eq!(names(t0).len(), MAX_VESSELS);
        // A board of live vessels refuses the next one.
        assert_eq!(
            b.forecast("late", &forecast(1, 1.0, 0.0), t0),
            Err(Refused::BeyondBounds)
        );
        // Once they are stale, the stalest (v0..v62 at t0; "real" refreshed later) go first.
        let later = t0 + stale_after + Duration::from_secs(1);
        b.forecast("real", &forecast(2, 1.0, 0.0), later).unwrap();
        b.forecast("late", &forecast(1, 1.0, 0.0), later).unwrap();
        let now = names(later);
        assert!(now.contains(&"late".to_string()) && now.contains(&"real".to_string()));
        assert_eq!(now.len(), MAX_VESSELS);
    }

    /// A calm forecast of `steps` steps: every motion small, sigma small.
    fn calm_forecast(steps: usize) -> Forecast {
        let mut f = Forecast {
            seq: 7,
            time_s: 100.0,
            dt_s: 0.5,
            steps: steps as u32,
            ..Forecast::default()
        };
        for d in 0..6 {
            for k in 0..steps {
                f.mean[d][k] = 0.001;
                f.sigma[d][k] = 0.001;
            }
        }
        f
    }

    #[test]
    fn the_deck_advisory_the_deck_publishes_parses_with_its_decision() {
        // The real advisor's JSON, not a copy of its shape: a drift between the two fails here.
        use shipcast_pipeline::config::DeckConfig;
        use shipcast_pipeline::deck::DeckAdvisor;
        // A fresh deck has verified no forecast yet: no probability, no go.
        let mut fresh = DeckAdvisor::new(&DeckConfig::default());
        let json = serde_json::to_vec(&fresh.advise(&calm_forecast(50))).unwrap();
        let a: AdvisoryView = serde_json::from_slice(&json).unwrap();
        assert!(!a.decision.go && a.decision.ensemble_members == Some(0));
        assert_eq!(a.decision.probability_now, None);
        assert!(a.decision.awaiting_verified_errors);
        let mut advisor = DeckAdvisor::new(&DeckConfig {
            go_needs_verified_errors: false,
            ..DeckConfig::default()
        });
        let json = serde_json::to_vec(&advisor.advise(&calm_forecast(50))).unwrap();
        let a: AdvisoryView = serde_json::from_slice(&json).unwrap();
        assert_eq!(a.time_s, 100.0);
        assert!(a.max_roll_deg.is_some() && a.max_pitch_deg.is_some());
        // A calm sea with tiny sigma: go now, no exceedance.
        assert!(a.decision.go, "{:?}", a.decision);
        assert!(a.decision.probability_now.unwrap() > 0.99);
        assert_eq!(a.decision.next_exceedance_s, None);
        // A heave far beyond the displacement limit from step 20 on: no go later.
        let mut f = calm_forecast(50);
        for k in 20..50 {
            f.mean[2][k] = 10.0;
        }
        let json = serde_json::to_vec(&advisor.advise(&f)).unwrap();
        let a: AdvisoryView = serde_json::from_slice(&json).unwrap();
        assert!(a.decision.next_exceedance_s.unwrap() > 9.0);
    }

    #[test]
    fn a_lift_advisory_parses_and_a_message_without_a_decision_is_refused() {
        let lift = serde_json::json!({
            "crane_vessel": "a", "target_vessel": "b", "time_s": 12.5,
            "decision": {"mot_s": 10.0, "go_probability": 0.9, "go": false,
                         "probability_now": 0.4, "next_exceedance_s": 3.0}
        });
        let a: AdvisoryView = serde_json::from_value(lift).unwrap();
        assert!(!a.decision.go);
        assert_eq!(a.decision.next_window_s, None);
        assert_eq!(a.max_roll_deg, None);
        let old = serde_json::json!({"forecast_seq": 1, "time_s": 1.0, "windows": []});
        assert!(serde_json::from_value::<AdvisoryView>(old).is_err());
    }

    /// Regression: a predictor restarted within the stale limit counts seq from 0 again; its
    /// forecasts were refused and the dead one's last forecast stayed on the page as live.
    #[test]
    fn a_new_publisher_starts_its_own_seq_and_one_stream_must_move_forward() {
        let b = board();
        let t0 = Instant::now();
        b.forecast_from("a", &forecast(49, 1.0, 0.0), Some("old"), t0)
            .unwrap();
        let t1 = t0 + Duration::from_secs(1);
        assert!(b
            .forecast_from("a", &forecast(48, 1.5, 0.0), Some("old"), t1)
            .is_err());
        b.forecast_from("a", &forecast(0, 2.0, 0.0), Some("new"), t1)
            .unwrap();
        let s = b.snapshot(t1);
        assert_eq!(s.vessels[0].forecast.as_ref().unwrap().seq, 0);
        // Within the new stream seq must move forward again.
        assert!(b
            .forecast_from("a", &forecast(0, 2.5, 0.0), Some("new"), t1)
            .is_err());
        b.forecast_from("a", &forecast(1, 2.5, 0.0), Some("new"), t1)
            .unwrap();
    }

    #[test]
    fn a_vessel_without_forecasts_for_longer_than_the_limit_is_stale_and_shows_none() {
        let b = board();
        let t0 = Instant::now();
        b.forecast("a", &forecast(1, 1.0, 0.0), t0).unwrap();
        b.advisory(
            "a",
            "deck",
            AdvisoryView {
                time_s: 0.5,
                max_roll_deg: Some(1.0),
                max_pitch_deg: Some(1.0),
                decision: DecisionView {
                    mot_s: 10.0,
                    go_probability: 0.95,
                    go: true,
                    probability_now: Some(0.97),
                    next_window_s: Some(0.0),
                    next_window_probability: Some(0.97),
                    next_exceedance_s: None,
                    ensemble_members: Some(300),
                    awaiting_verified_errors: false,
                },
                stale_s: None,
            },
            t0,
        );
        let just_in_time = b.snapshot(t0 + Duration::from_secs(3));
        assert_eq!(just_in_time.vessels[0].advisories["deck"].stale_s, None);
        assert!(!just_in_time.vessels[0].stale);
        assert_eq!(just_in_time.vessels[0].advisories.len(), 1);
        let late = b.snapshot(t0 + Duration::from_millis(3001));
        let v = &late.vessels[0];
        assert!(v.stale);
        assert!(v.forecast.is_none() && v.advisories.is_empty());
        assert!((v.age_s.unwrap() - 3.001).abs() < 1e-9);
        // After a gap a restarted predictor's seq 0 is accepted again.
        let later = t0 + Duration::from_secs(10);
        b.forecast("a", &forecast(0, 2.0, 0.0), later).unwrap();
        let back = b.snapshot(later);
        assert!(!back.vessels[0].stale);
        // Regression: the deck that died with it came back as current with its old GO. Its
        // advisory is 10 s old: shown, but marked stale with its age.
        let deck = &back.vessels[0].advisories["deck"];
        assert!(deck.decision.go);
        assert!((deck.stale_s.unwrap() - 10.0).abs() < 1e-9, "{deck:?}");
        // And while forecasts keep coming but the deck is silent, the same.
        b.forecast("a", &forecast(1, 2.5, 0.0), later + Duration::from_secs(1))
            .unwrap();
        let s = b.snapshot(later + Duration::from_secs(1));
        assert!(!s.vessels[0].stale);
        assert!(s.vessels[0].advisories["deck"].stale_s.unwrap() > 10.0);
    }

    #[test]
    fn skill_is_read_at_5_10_and_20_s_and_a_bad_report_is_counted() {
        let b = board();
        let report: VerificationIn = serde_json::from_str(
            r#"{"window_s":1200,"dt_s":0.5,"dofs":[
                {"dof":"heave","nrmse_zero":[0.1,0.2,0.3,0.4,0.5,0.6,0.7,0.8,0.9,0.91],"skill_horizon_s":3.5},
                {"dof":"surge","nrmse_zero":[0.5],"skill_horizon_s":1.0}]}"#,
        )
        .unwrap();
        let t0 = Instant::now();
        b.forecast("a", &forecast(1, 1.0, 0.0), t0).unwrap();
        assert!(b.verification("a", &report));
        let s = b.snapshot(t0);
        let skill = &s.vessels[0].skill;
        assert_eq!(skill.len(), 1, "only heave, roll and pitch are shown");
        // 5 s at 2 Hz is step 10 (index 9); 10 and 20 s lie beyond this report's steps.
        assert_eq!(skill[0].nrmse_at, [Some(0.91), None, None]);
        assert_eq!(skill[0].skill_horizon_s, 3.5);
        let bad = VerificationIn {
            dt_s: 0.0,
            dofs: vec![],
        };
        assert!(!b.verification("a", &bad));
        assert_eq!(b.snapshot(t0).vessels[0].rejected, 1);
        // A stale vessel's skill is its silent predictor's: withheld with its forecast.
        let stale = b.snapshot(t0 + Duration::from_secs(4));
        assert!(stale.vessels[0].stale && stale.vessels[0].skill.is_empty());
    }

    #[test]
    fn the_snapshot_is_json_the_page_can_read() {
        let b = board();
        b.forecast("ddg51", &forecast(1, 0.5, 0.0), Instant::now())
            .unwrap();
        let v: serde_json::Value = serde_json::from_str(&b.snapshot_json(Instant::now())).unwrap();
        assert_eq!(v["vessels"][0]["vessel"], "ddg51");
        assert_eq!(v["limits"]["roll_deg"], 2.5);
        assert_eq!(v["vessels"][0]["forecast"]["heave"]["mean"][0], 0.5);
    }
}
