//! Service names and zenoh keys (docs/contracts.md sections 2.1, 2.2):
//! `[<instance>/]shipcast/<vessel>/<topic>`.

use std::fmt;

/// Vessel name used when none is configured.
pub const DEFAULT_VESSEL: &str = "ddg51";

/// Why a name was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("invalid {what} '{value}': {reason}")]
pub struct NameError {
    pub what: &'static str,
    pub value: String,
    pub reason: &'static str,
}

/// The names of one pipeline: an optional instance prefix and the vessel.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Names {
    instance: Option<String>,
    vessel: String,
}

/// A name segment must be usable both as one zenoh key chunk and inside an iceoryx2 service
/// name and file-name prefix, so only a conservative character set is allowed. Readers of
/// names that come over the network (the display) hold them to the same rule.
pub fn check_segment(what: &'static str, value: &str) -> Result<(), NameError> {
    let err = |reason| NameError {
        what,
        value: value.to_string(),
        reason,
    };
    if value.is_empty() {
        return Err(err("must not be empty"));
    }
    if value.len() > 64 {
        return Err(err("longer than 64 characters"));
    }
    if !value
        .chars()
        .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_' || c == '.')
    {
        return Err(err("only letters, digits, '-', '_' and '.' are allowed"));
    }
    Ok(())
}

impl Names {
    /// Names for `vessel`, optionally under `instance`. Empty instance means none.
    pub fn new(instance: Option<&str>, vessel: &str) -> Result<Self, NameError> {
        let instance = instance.filter(|s| !s.is_empty());
        if let Some(i) = instance {
            check_segment("instance", i)?;
        }
        check_segment("vessel", vessel)?;
        Ok(Self {
            instance: instance.map(str::to_string),
            vessel: vessel.to_string(),
        })
    }

    pub fn instance(&self) -> Option<&str> {
        self.instance.as_deref()
    }

    pub fn vessel(&self) -> &str {
        &self.vessel
    }

    fn topic(&self, topic: &str) -> String {
        format!("{}{}/{topic}", self.fleet_prefix(), self.vessel)
    }

    /// What every key of every vessel of this instance starts with: `[<instance>/]shipcast/`.
    pub fn fleet_prefix(&self) -> String {
        match &self.instance {
            Some(i) => format!("{i}/shipcast/"),
            None => "shipcast/".to_string(),
        }
    }

    /// zenoh key expression of one topic of every vessel: `[<instance>/]shipcast/*/<topic>`.
    pub fn every_vessel(&self, topic: &str) -> String {
        format!("{}*/{topic}", self.fleet_prefix())
    }

    /// iceoryx2 service / zenoh key of the motion samples.
    pub fn motion(&self) -> String {
        self.topic("motion")
    }

    /// iceoryx2 service / zenoh key of the forecasts.
    pub fn forecast(&self) -> String {
        self.topic("forecast")
    }

    /// iceoryx2 service where `shipcast predictor --bench-stamps` publishes when it received
    /// each motion sample (the latency benchmark reads it).
    pub fn bench_receive(&self) -> String {
        self.topic("bench/receive")
    }

    /// iceoryx2 event service that wakes subscribers of `service` (a pub-sub service has no
    /// wake-up of its own).
    pub fn event_of(service: &str) -> String {
        format!("{service}/event")
    }

    /// zenoh key of the advisory of one station (`deck`, `crane`).
    pub fn advisory(&self, station: &str) -> String {
        self.topic(&format!("advisory/{station}"))
    }

    /// zenoh key where a service publishes its counters and state (JSON).
    pub fn status(&self, service: &str) -> String {
        self.topic(&format!("status/{service}"))
    }

    /// zenoh key of the predictor's live verification scores (JSON).
    pub fn verification(&self) -> String {
        self.topic("verification")
    }

    /// zenoh liveliness token of a service: consumers see whether its publisher is alive.
    pub fn liveliness(service: &str) -> String {
        format!("{service}/alive")
    }

    /// iceoryx2 file prefix that keeps the shared-memory files of parallel pipelines (tests)
    /// apart; the default prefix without an instance, so plain tools see the default pipeline.
    pub fn iox_prefix(&self) -> String {
        match &self.instance {
            Some(i) => format!("iox2_{i}_"),
            None => "iox2_".to_string(),
        }
    }
}

/// An instance name that no other run, process or call uses: `tag`, the process id, a
/// per-process counter and a clock reading (the counter keeps calls in the same nanosecond
/// apart, the clock keeps a reused process id apart). Parallel tests and benchmark rounds get
/// their own iceoryx2 services and zenoh keys with it.
pub fn unique_instance(tag: &str) -> String {
    use std::sync::atomic::{AtomicU64, Ordering};
    static NEXT: AtomicU64 = AtomicU64::new(0);
    let n = NEXT.fetch_add(1, Ordering::Relaxed);
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.subsec_nanos())
        .unwrap_or(0);
    format!("{tag}-{}-{n}-{nanos}", std::process::id())
}

impl fmt::Display for Names {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.topic("*"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unique_instances_differ_and_are_valid_names() {
        let a = unique_instance("t");
        let b = unique_instance("t");
        assert_ne!(a, b);
        assert!(a.starts_with("t-"));
        assert!(Names::new(Some(&a), "v").is_ok());
    }

    #[test]
    fn names_follow_the_contract() {
        let n = Names::new(None, DEFAULT_VESSEL).unwrap();
        assert_eq!(n.motion(), "shipcast/ddg51/motion");
        assert_eq!(n.forecast(), "shipcast/ddg51/forecast");
        assert_eq!(n.advisory("deck"), "shipcast/ddg51/advisory/deck");
        assert_eq!(n.iox_prefix(), "iox2_");
        assert_eq!(n.status("predictor"), "shipcast/ddg51/status/predictor");
        let n = Names::new(Some("t1"), "s175").unwrap();
        assert_eq!(n.forecast(), "t1/shipcast/s175/forecast");
        assert_eq!(n.bench_receive(), "t1/shipcast/s175/bench/receive");
        assert_eq!(
            Names::event_of(&n.motion()),
            "t1/shipcast/s175/motion/event"
        );
        assert_eq!(
            Names::liveliness(&n.forecast()),
            "t1/shipcast/s175/forecast/alive"
        );
        assert_eq!(n.iox_prefix(), "iox2_t1_");
        assert_eq!(Names::new(Some(""), "x").unwrap().instance(), None);
    }

    #[test]
    fn every_vessel_keys_cover_each_vessels_own_keys() {
        let plain = Names::new(None, "ddg51").unwrap();
        assert_eq!(plain.fleet_prefix(), "shipcast/");
        assert_eq!(plain.every_vessel("forecast"), "shipcast/*/forecast");
        let t = Names::new(Some("t1"), "ffg7").unwrap();
        assert_eq!(t.every_vessel("advisory/*"), "t1/shipcast/*/advisory/*");
        assert!(t.forecast().starts_with(&t.fleet_prefix()));
        assert_eq!(t.forecast(), "t1/shipcast/ffg7/forecast");
    }

    #[test]
    fn bad_names_are_refused_with_the_reason() {
        for bad in ["", "a/b", "a*", "a b", "$x"] {
            let err = Names::new(None, bad).unwrap_err();
            assert_eq!(err.what, "vessel");
        }
        let err = Names::new(Some("x/y"), "ddg51").unwrap_err();
        assert!(err.to_string().contains("invalid instance 'x/y'"), "{err}");
    }
}
