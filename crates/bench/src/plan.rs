//! What a benchmark run measures: paths, receive modes and the run parameters.

use std::fmt;
use std::str::FromStr;

/// A measured path. The names are the `path` field of the JSON rows (issue 6).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Path {
    /// MotionSample.stamp_ns -> received by the predictor.
    ProducerToPredictor,
    /// MotionSample.stamp_ns -> Forecast.issued_stamp_ns.
    SampleToForecastPublished,
    /// MotionSample.stamp_ns -> forecast received by a co-located iceoryx2 consumer.
    SampleToForecastLocal,
    /// MotionSample.stamp_ns -> forecast received by a zenoh consumer on 127.0.0.1.
    SampleToForecastZenoh,
    /// One leg of an iceoryx2 ping-pong.
    Iceoryx2Raw,
    /// One leg of a zenoh ping-pong.
    ZenohRaw,
}

impl Path {
    pub const ALL: [Path; 6] = [
        Path::ProducerToPredictor,
        Path::SampleToForecastPublished,
        Path::SampleToForecastLocal,
        Path::SampleToForecastZenoh,
        Path::Iceoryx2Raw,
        Path::ZenohRaw,
    ];

    pub const fn name(self) -> &'static str {
        match self {
            Path::ProducerToPredictor => "producer-to-predictor",
            Path::SampleToForecastPublished => "sample-to-forecast-published",
            Path::SampleToForecastLocal => "sample-to-forecast-local",
            Path::SampleToForecastZenoh => "sample-to-forecast-zenoh",
            Path::Iceoryx2Raw => "iceoryx2-raw",
            Path::ZenohRaw => "zenoh-raw",
        }
    }
}

impl fmt::Display for Path {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// What produced a row: the real service processes, the bench's in-process pipeline, or a raw
/// transport ping-pong.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Source {
    Services,
    InProcess,
    /// A ping-pong between two threads of this process.
    Raw,
    /// A ping-pong between this process and a child process (the boundary shipcast's own
    /// zenoh path crosses).
    RawProcesses,
}

impl Source {
    pub const fn name(self) -> &'static str {
        match self {
            Source::Services => "services",
            Source::InProcess => "in-process",
            Source::Raw => "raw",
            Source::RawProcesses => "raw-processes",
        }
    }
}

/// How receivers wait for data.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Mode {
    /// Blocking wait, woken by a notification (iceoryx2 Listener, zenoh channel receive).
    Event,
    /// Spinning on the receive queue.
    Poll,
}

impl Mode {
    pub const fn name(self) -> &'static str {
        match self {
            Mode::Event => "event",
            Mode::Poll => "poll",
        }
    }
}

impl fmt::Display for Mode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The `--mode` flag: one mode or both.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ModeSelect {
    Event,
    Poll,
    Both,
}

impl ModeSelect {
    pub fn modes(self) -> &'static [Mode] {
        match self {
            ModeSelect::Event => &[Mode::Event],
            ModeSelect::Poll => &[Mode::Poll],
            ModeSelect::Both => &[Mode::Event, Mode::Poll],
        }
    }
}

impl FromStr for ModeSelect {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.trim().to_ascii_lowercase().as_str() {
            "event" => Ok(ModeSelect::Event),
            "poll" => Ok(ModeSelect::Poll),
            "both" => Ok(ModeSelect::Both),
            _ => Err(format!("unknown mode '{s}' (expected event, poll or both)")),
        }
    }
}

/// Parameters shared by every measurement of one run.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    /// Measured exchanges (ping-pong) or samples (pipeline), after the warm-up, over all rounds.
    pub samples: u64,
    /// Exchanges or samples sent first and not recorded (caches, lazy port connection), in
    /// every round.
    pub warmup: u64,
    /// The measurements take turns this many times, each with its share of `samples`, so a
    /// burst of noise from the host (a virtual machine's neighbours) falls on every path alike
    /// instead of on whichever path was being measured at the time.
    pub rounds: u64,
    /// Send rate in Hz.
    pub rate_hz: f64,
    /// Cores of the sending side (producer) and the receiving side (predictor).
    pub cores: (usize, usize),
    /// Unique prefix of every iceoryx2 service and zenoh key of this run.
    pub instance: String,
    /// The `shipcast` executable whose `producer` and `predictor` subcommands are measured as
    /// child processes; none: only the in-process pipeline and the raw floors.
    pub shipcast_exe: Option<std::path::PathBuf>,
}

/// Most measured samples per path and mode (the recorded latencies are held in memory).
pub const MAX_SAMPLES: u64 = 10_000_000;

/// Most unsent warm-up samples.
pub const MAX_WARMUP: u64 = 1_000_000;

impl Plan {
    /// Check the parameters, so a bad flag is a one-line error and not a hang or a panic.
    pub fn validate(&self) -> Result<(), String> {
        shipcast_pipeline::limits::count("--samples", self.samples, 1, MAX_SAMPLES)?;
        shipcast_pipeline::limits::count("--warmup", self.warmup, 0, MAX_WARMUP)?;
        shipcast_pipeline::limits::core("--cores", self.cores.0)?;
        shipcast_pipeline::limits::core("--cores", self.cores.1)?;
        if self.rounds == 0 || self.rounds > self.samples {
            return Err(format!(
                "--rounds {} must be at least 1 and at most --samples {}",
                self.rounds, self.samples
            ));
        }
        shipcast_pipeline::limits::rate(
            "--rate",
            self.rate_hz,
            shipcast_pipeline::limits::MAX_RATE_HZ,
        )?;
        Ok(())
    }

    /// The plan of round `round` (0-based) of `rounds`: its share of the samples (the first
    /// rounds take the remainder) and an instance of its own, so no round meets services or
    /// keys that an earlier one left behind.
    pub fn round(&self, round: u64) -> Plan {
        let share = self.samples / self.rounds + u64::from(round < self.samples % self.rounds);
        Plan {
            samples: share,
            rounds: 1,
            instance: format!("{}-r{round}", self.instance),
            ..self.clone()
        }
    }

    /// Time between two sends.
    pub fn period(&self) -> std::time::Duration {
        std::time::Duration::from_secs_f64(1.0 / self.rate_hz)
    }

    /// A run-unique instance name: process id and a clock reading, so parallel runs and tests
    /// never share iceoryx2 services or zenoh keys.
    pub fn unique_instance(tag: &str) -> String {
        shipcast_pipeline::transport::unique_instance(&format!("bench-{tag}"))
    }
}

/// Paces sends at the plan's rate (`Pacer::new(plan.period())`).
pub use shipcast_pipeline::pacing::Pacer;

/// Parse `--cores A,B` (two distinct core ids).
pub fn parse_cores(s: &str) -> Result<(usize, usize), String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    let [a, b] = parts.as_slice() else {
        return Err(format!("--cores '{s}': expected two core ids as A,B"));
    };
    let parse = |v: &str| {
        v.parse::<usize>()
            .map_err(|_| format!("--cores '{s}': '{v}' is not a core id"))
    };
    let (a, b) = (parse(a)?, parse(b)?);
    // A core past the CPU set would make CPU_SET panic in the forked child, before exec.
    shipcast_pipeline::limits::core("--cores", a)?;
    shipcast_pipeline::limits::core("--cores", b)?;
    if a == b {
        return Err(format!("--cores '{s}': the two cores must differ"));
    }
    Ok((a, b))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cores_and_modes_parse_or_explain() {
        assert_eq!(parse_cores("0,1"), Ok((0, 1)));
        assert_eq!(parse_cores(" 3 , 2 "), Ok((3, 2)));
        assert!(parse_cores("1,1").unwrap_err().contains("must differ"));
        assert!(parse_cores("0").unwrap_err().contains("two core ids"));
        assert!(parse_cores("0,5000").unwrap_err().contains("not a core id"));
        assert!(parse_cores("0,x").unwrap_err().contains("'x'"));
        assert_eq!("BOTH".parse::<ModeSelect>().unwrap().modes().len(), 2);
        assert_eq!("poll".parse::<ModeSelect>().unwrap().modes(), &[Mode::Poll]);
        assert!("fast".parse::<ModeSelect>().is_err());
    }

    #[test]
    fn bad_plans_are_refused() {
        let mut plan = Plan {
            samples: 10,
            warmup: 1,
            rounds: 3,
            rate_hz: 100.0,
            cores: (0, 1),
            instance: "x".into(),
            shipcast_exe: None,
        };
        assert!(plan.validate().is_ok());
        plan.rate_hz = f64::NAN;
        assert!(plan.validate().is_err());
        plan.rate_hz = 0.0;
        assert!(plan.validate().is_err());
        plan.rate_hz = 10.0;
        plan.samples = 0;
        assert!(plan.validate().is_err());
        plan.samples = 10;
        plan.rounds = 0;
        assert!(plan.validate().is_err());
        plan.rounds = 11;
        assert!(plan.validate().is_err());
    }

    #[test]
    fn rounds_share_the_samples_and_have_their_own_instance() {
        let plan = Plan {
            samples: 10,
            warmup: 2,
            rounds: 3,
            rate_hz: 100.0,
            cores: (0, 1),
            instance: "x".into(),
            shipcast_exe: None,
        };
        let rounds: Vec<Plan> = (0..3).map(|r| plan.round(r)).collect();
        assert_eq!(
            rounds.iter().map(|p| p.samples).collect::<Vec<_>>(),
            [4, 3, 3]
        );
        assert!(rounds.iter().all(|p| p.rounds == 1 && p.warmup == 2));
        assert_eq!(rounds[2].instance, "x-r2");
        assert!(rounds.iter().all(|p| p.validate().is_ok()));
    }
}
