//! `shipcast run`'s live view: the newest forecast, advisories, predictor status and live
//! skill, redrawn every second, with whatever has gone silent shown as STALE.

use shipcast_pipeline::deck::Advisory;
use shipcast_pipeline::relative::RelativeAdvisory;
use shipcast_pipeline::transport::forecast_check::{check_source, LivePublishers, PublisherWatch};
use shipcast_pipeline::transport::log_throttle::LogThrottle;
use shipcast_pipeline::transport::status::PredictorStatus;
use shipcast_pipeline::transport::zenoh::{LatestSubscriber, ZenohError};
use shipcast_wire::payload::Forecast;
use std::time::{Duration, Instant};
use zenoh::Session;

/// What the live view shows, updated from zenoh.
#[derive(Default)]
pub(super) struct View {
    pub(super) forecast: Option<Forecast>,
    pub(super) advisory: Option<Advisory>,
    /// The relative service's lift advisory (two ships only).
    pub(super) lift: Option<Option<RelativeAdvisory>>,
    pub(super) status: Option<PredictorStatus>,
    pub(super) verification: Option<serde_json::Value>,
    /// When each of the above last arrived (forecast, advisory, lift, status, verification):
    /// what has not been heard of for [`VIEW_STALE_AFTER`] is shown as STALE, not as current.
    pub(super) heard: Heard,
    /// Forecasts rejected (by reason) and status or verification documents rejected.
    pub(super) rejected: (
        shipcast_pipeline::transport::forecast_check::RejectionCounts,
        u64,
    ),
}

/// Wall time without news after which the live view shows an item as STALE (the display's
/// default `--stale-after-s`): every service publishes several times a second or every second.
const VIEW_STALE_AFTER: Duration = Duration::from_secs(3);

#[derive(Default)]
pub(super) struct Heard {
    pub(super) forecast: Option<Instant>,
    pub(super) advisory: Option<Instant>,
    pub(super) lift: Option<Instant>,
    pub(super) status: Option<Instant>,
    pub(super) verification: Option<Instant>,
}

/// Seconds since `at` when that is longer than [`VIEW_STALE_AFTER`].
fn silent_for(at: Option<Instant>, now: Instant) -> Option<f64> {
    let age = now.saturating_duration_since(at?);
    (age > VIEW_STALE_AFTER).then_some(age.as_secs_f64())
}

impl View {
    /// The view at `now`. Regression: with the predictor stopped (SIGSTOP) the view went on
    /// printing its last forecast, the last deck advisory and "live" as current.
    pub(super) fn lines(&self, header: &str, now: Instant) -> Vec<String> {
        let mut lines = vec![header.to_string()];
        let heard = &self.heard;
        lines.push(match (&self.status, silent_for(heard.status, now)) {
            (None, _) => "predictor  starting (training on simulated history)".into(),
            (Some(_), Some(age)) => format!("predictor  STALE: no status for {age:.0} s"),
            (Some(s), None) => format!(
                "predictor  model v{}  forecasts {}  history {}/{}  received {} lost {} rejected {}  {}",
                s.model_version,
                s.forecasts,
                s.history,
                s.order,
                s.counters.received,
                s.counters.lost,
                s.counters.rejected(),
                if s.stale { "STALE" } else { "live" }
            ),
        });
        // Leads are shown from the newest sample: step k is at time_s + k dt_s, and time_s
        // lags the newest sample by the decimation filter's delay.
        let delay_s = self.status.as_ref().map_or(0.0, |s| s.delay_s);
        lines.push(match (&self.forecast, silent_for(heard.forecast, now)) {
            (None, _) => "forecast   none yet (the history fills first)".into(),
            (Some(_), Some(age)) => format!("forecast   STALE: none for {age:.0} s"),
            (Some(f), None) if f.valid_steps() == 0 => "forecast   empty (0 steps)".into(),
            (Some(f), None) => {
                let at = |d: usize, lead_s: f64| {
                    let k = (((lead_s + delay_s) / f.dt_s).round() as usize)
                        .clamp(1, f.valid_steps())
                        - 1;
                    (f.mean[d][k], f.sigma[d][k])
                };
                let mut line = format!("forecast   t={:.1}s", f.time_s + delay_s);
                for (name, d, scale, unit) in [
                    ("heave", 2, 1.0, "m"),
                    ("roll", 3, 180.0 / std::f32::consts::PI, "deg"),
                    ("pitch", 4, 180.0 / std::f32::consts::PI, "deg"),
                ] {
                    let (m5, s5) = at(d, 5.0);
                    let (m20, s20) = at(d, 20.0);
                    line.push_str(&format!(
                        "  {name} +5s {:+.2}±{:.2} +20s {:+.2}±{:.2} {unit}",
                        m5 * scale,
                        s5 * scale,
                        m20 * scale,
                        s20 * scale
                    ));
                }
                line
            }
        });
        match silent_for(heard.verification, now) {
            Some(age) => lines.push(format!("skill      STALE: no verification for {age:.0} s")),
            None => lines.extend(self.skill_lines(delay_s)),
        }
        lines.push(match (&self.advisory, silent_for(heard.advisory, now)) {
            (None, _) => "deck       no advisory yet".into(),
            (Some(_), Some(age)) => format!("deck       STALE: no advisory for {age:.0} s"),
            (Some(a), None) => a.summary(),
        });
        match (&self.lift, silent_for(heard.lift, now)) {
            (None, _) => {}
            (Some(None), _) => lines.push("lift       no relative forecast yet".into()),
            (Some(Some(_)), Some(age)) => {
                lines.push(format!("lift       STALE: no advisory for {age:.0} s"))
            }
            (Some(Some(a)), None) => lines.push(a.summary()),
        }
        let (f, other) = self.rejected;
        lines.push(format!(
            "checks     rejected forecasts {} ({} source, {} seq, {} payload), status/verification/advisories {other}",
            f.total(),
            f.source,
            f.seq,
            f.payload
        ));
        lines
    }
}

impl View {
    /// One line per DOF of the live verification: error relative to predicting zero, coverage
    /// of the sigma bands, and the longest lead that can be trusted right now.
    fn skill_lines(&self, delay_s: f64) -> Vec<String> {
        let Some(v) = &self.verification else {
            return vec![
                "skill      not verified yet (forecasts are scored as their values arrive)".into(),
            ];
        };
        let dt = v["dt_s"].as_f64().unwrap_or(0.5);
        let mut out = Vec::new();
        for d in v["dofs"].as_array().into_iter().flatten() {
            let name = d["dof"].as_str().unwrap_or("?");
            if !["heave", "roll", "pitch"].contains(&name) {
                continue;
            }
            let at = |key: &str, lead_s: f64| -> String {
                let k = ((lead_s + delay_s) / dt).round() as usize;
                d[key]
                    .as_array()
                    .and_then(|a| a.get(k.saturating_sub(1)))
                    .and_then(serde_json::Value::as_f64)
                    .map_or("-".into(), |x| format!("{x:.2}"))
            };
            let horizon = d["skill_horizon_s"].as_f64().unwrap_or(0.0) - delay_s;
            out.push(format!(
                "skill      {name:<5} trust to +{:.0}s  error/zero +5s {} +10s {} +20s {}  within 1 sigma {} 2 sigma {}  (+10s)",
                horizon.max(0.0),
                at("nrmse_zero", 5.0),
                at("nrmse_zero", 10.0),
                at("nrmse_zero", 20.0),
                at("coverage_1sigma", 10.0),
                at("coverage_2sigma", 10.0),
            ));
        }
        out
    }
}

/// The newest JSON document of one key whose publisher is the key's one live publisher; others
/// are rejected, counted and logged.
pub(super) struct CheckedJson {
    key: String,
    subscriber: LatestSubscriber,
    watch: PublisherWatch,
    live: LivePublishers,
    pub(super) rejected: u64,
    log: LogThrottle,
}

impl CheckedJson {
    pub(super) fn new(session: &Session, key: &str) -> Result<Self, ZenohError> {
        Ok(Self {
            key: key.to_string(),
            subscriber: LatestSubscriber::new(session, key)?,
            watch: PublisherWatch::new(session, key)?,
            live: LivePublishers::default(),
            rejected: 0,
            log: LogThrottle::default(),
        })
    }

    pub(super) fn latest(&mut self) -> Result<Option<serde_json::Value>, ZenohError> {
        self.latest_as()
    }

    /// The newest document that comes from the live publisher and decodes as `T`; every other
    /// one is rejected, counted and logged.
    pub(super) fn latest_as<T: serde::de::DeserializeOwned>(
        &mut self,
    ) -> Result<Option<T>, ZenohError> {
        let mut newest = None;
        while let Some(received) = self.subscriber.try_recv_with_source()? {
            self.watch.update(&mut self.live);
            let checked = check_source(&self.live, &received)
                .map_err(|e| e.to_string())
                .and_then(|_| {
                    serde_json::from_slice(&received.payload).map_err(|e| format!("JSON: {e}"))
                });
            match checked {
                Ok(v) => newest = Some(v),
                Err(e) => {
                    self.rejected += 1;
                    shipcast_pipeline::warn_rejected!(
                        self.log,
                        self.rejected,
                        "run: {} rejected: {e}",
                        self.key
                    );
                }
            }
        }
        Ok(newest)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn what_has_not_been_heard_of_for_the_stale_limit_is_shown_stale() {
        let now = Instant::now();
        let ten_ago = now.checked_sub(Duration::from_secs(10));
        let status = PredictorStatus {
            model_version: 2,
            forecasts: 5,
            history: 50,
            order: 50,
            ..PredictorStatus::default()
        };
        let mut view = View {
            forecast: Some(Forecast::default()),
            status: Some(status),
            ..View::default()
        };
        view.heard.forecast = ten_ago;
        view.heard.status = ten_ago;
        let lines = view.lines("header", now);
        assert!(
            lines.contains(&"forecast   STALE: none for 10 s".to_string()),
            "{lines:?}"
        );
        assert!(
            lines.contains(&"predictor  STALE: no status for 10 s".to_string()),
            "{lines:?}"
        );
        // Heard just now: shown as it is.
        view.heard.forecast = Some(now);
        view.heard.status = Some(now);
        let lines = view.lines("header", now);
        assert!(!lines.iter().any(|l| l.contains("STALE")), "{lines:?}");
        assert!(lines.iter().any(|l| l.contains("model v2")), "{lines:?}");
    }
}
