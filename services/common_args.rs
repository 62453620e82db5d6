//! The flags every pipeline subcommand accepts, kept apart from the validated configuration
//! they produce (`shipcast_pipeline::config::PipelineConfig`): the library knows nothing of
//! the command line.

use shipcast_pipeline::config::{ConfigError, PipelineConfig};
use shipcast_pipeline::limits;
use std::path::PathBuf;

/// Flags every pipeline subcommand accepts; they override the config file.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct CommonArgs {
    /// Pipeline configuration (TOML); every key has a default.
    #[arg(long, value_name = "FILE.toml")]
    pub config: Option<PathBuf>,
    /// Prefix of every service name and zenoh key (keeps parallel pipelines apart).
    #[arg(long, value_name = "NAME")]
    pub instance: Option<String>,
    /// Vessel name in service names and keys.
    #[arg(long, value_name = "NAME")]
    pub vessel: Option<String>,
    /// zenoh endpoint the predictor listens on (repeatable; replaces the configured ones).
    #[arg(long, value_name = "ENDPOINT")]
    pub zenoh_listen: Vec<String>,
    /// zenoh endpoint to connect to (repeatable; replaces the configured ones).
    #[arg(long, value_name = "ENDPOINT")]
    pub zenoh_connect: Vec<String>,
    /// Pacing of the producer: 1 = real time, 0 = as fast as possible (producer and run;
    /// the other services take their pace from what they receive).
    #[arg(long, value_name = "F")]
    pub speed: Option<f64>,
    /// Stop after this many seconds of wall-clock time.
    #[arg(long, value_name = "S")]
    pub duration: Option<f64>,
}

impl CommonArgs {
    /// The config file (or the defaults) with the flags applied, validated.
    pub fn load(&self) -> Result<PipelineConfig, ConfigError> {
        let config = self.load_unvalidated()?;
        config.validate()?;
        Ok(config)
    }

    /// [`Self::load`] without the checks, for a command with flags of its own: it applies
    /// them, then calls [`PipelineConfig::validate`] once.
    pub fn load_unvalidated(&self) -> Result<PipelineConfig, ConfigError> {
        let mut config = PipelineConfig::load_unvalidated(self.config.as_deref())?;
        if let Some(i) = &self.instance {
            config.instance = Some(i.clone());
        }
        if let Some(v) = &self.vessel {
            config.vessel = v.clone();
        }
        if !self.zenoh_listen.is_empty() {
            config.zenoh.listen = self.zenoh_listen.clone();
        }
        if !self.zenoh_connect.is_empty() {
            config.zenoh.connect = self.zenoh_connect.clone();
        }
        if let Some(s) = self.speed {
            config.producer.speed = s;
        }
        Ok(config)
    }

    /// Wall-clock limit, if any.
    pub fn duration(&self) -> Result<Option<std::time::Duration>, ConfigError> {
        self.duration
            .map(|s| limits::seconds("--duration", s).map_err(ConfigError::Invalid))
            .transpose()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flags_override_the_config_file_and_are_checked() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.toml");
        std::fs::write(&path, "vessel = \"s175\"\n[producer]\nspeed = 5.0\n").unwrap();
        let args = CommonArgs {
            config: Some(path),
            instance: Some("i1".into()),
            zenoh_listen: vec!["tcp/127.0.0.1:9".into()],
            speed: Some(100.0),
            ..CommonArgs::default()
        };
        let c = args.load().unwrap();
        assert_eq!(c.vessel, "s175");
        assert_eq!(c.instance.as_deref(), Some("i1"));
        assert_eq!(c.producer.speed, 100.0);
        assert_eq!(c.zenoh.listen, vec!["tcp/127.0.0.1:9"]);
        let bad = CommonArgs {
            duration: Some(-1.0),
            ..CommonArgs::default()
        };
        assert!(bad
            .duration()
            .unwrap_err()
            .to_string()
            .contains("--duration"));
    }
}
