//! `shipcast certs`: a secure deployment in one command. Writes a new CA, the certificates and
//! keys of the vessel's pipeline and of each station, the pipeline configuration
//! (`shipcast.toml`, used as it is by `shipcast run --config`) and, per station, a zenoh client
//! configuration (`<station>.json5`, for any zenoh client) and a shipcast consumer
//! configuration (`<station>.toml`, for `shipcast crane --config`). With `--router`, a fleet:
//! the router's certificate and `router.toml` (for `shipcast router --config`, with access
//! rules that let each vessel's pipeline publish only on its own vessel's keys and stations
//! only subscribe), one `<vessel>.toml` per vessel connecting to the router, and station files
//! that connect to the router. docs/security.md has the steps.

use crate::checked;
use anyhow::Context;
use shipcast_pipeline::certs::{endpoint_host, server_names, CertAuthority, Validity};
use shipcast_pipeline::config::ZenohConfig;
use shipcast_pipeline::limits;
use shipcast_pipeline::transport::zenoh::{self as zn, ZenohSettings};
use shipcast_pipeline::transport::zenoh_security::{AccessRules, TlsSettings, VesselAccess};
use shipcast_pipeline::transport::Names;
use std::io::Write;
use std::path::{Path, PathBuf};

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Directory to write into (created; must not already hold a ca.pem).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Prefix of every service name and key, as `--instance` of the pipeline commands.
    #[arg(long, value_name = "NAME")]
    pub instance: Option<String>,
    /// Vessel name (keys `shipcast/<vessel>/...`); repeatable with `--router`.
    #[arg(long, value_name = "NAME", default_value = shipcast_pipeline::transport::naming::DEFAULT_VESSEL)]
    pub vessel: Vec<String>,
    /// Endpoint the predictor listens on, e.g. tls/10.0.0.5:7447 (with `--router`: on every
    /// vessel, for its own consumers).
    #[arg(long, value_name = "ENDPOINT")]
    pub listen: String,
    /// Endpoint of the fleet's router, e.g. tls/shore.example:7447: write a fleet setup.
    #[arg(long, value_name = "ENDPOINT")]
    pub router: Option<String>,
    /// A station that may subscribe (repeatable); its name is its certificate's common name.
    #[arg(long, value_name = "NAME")]
    pub station: Vec<String>,
    /// Another host name or address stations use to reach the predictor (repeatable).
    #[arg(long, value_name = "HOST")]
    pub host: Vec<String>,
    /// Days the certificates stay valid.
    #[arg(long, value_name = "N", default_value_t = 365)]
    pub days: u32,
}

/// Common name of the vessel pipeline's certificate.
pub fn pipeline_name(vessel: &str) -> String {
    format!("{vessel}-pipeline")
}

/// Longest validity of a certificate [days]: 100 years.
const MAX_DAYS: u32 = 36_525;
/// Common name of a fleet router's certificate.
pub const ROUTER_NAME: &str = "router";

/// Every key of a vessel's pipeline: `[<instance>/]shipcast/<vessel>/**`.
fn vessel_keys(names: &Names) -> String {
    format!("{}{}/**", names.fleet_prefix(), names.vessel())
}

/// Every key of every vessel: `[<instance>/]shipcast/*/**`.
fn fleet_keys(names: &Names) -> String {
    names.every_vessel("**")
}

/// The setup `certs` writes, every value checked: built from [`Args`] by
/// [`Config::try_from`], the only place that validates them.
#[derive(Debug, Clone)]
pub struct Config {
    /// Output directory; it holds no ca.pem yet.
    pub out: PathBuf,
    /// Where the files are written first: `out` until [`run`] stages them in a directory of
    /// their own inside it ([`Staging`]).
    pub stage: PathBuf,
    /// The names of each vessel (one unless a fleet), all different.
    pub vessels: Vec<Names>,
    /// The predictor's listen endpoint and its host.
    pub listen: String,
    pub listen_host: String,
    /// The endpoint stations connect to: `listen`, or with a wildcard host the first `--host`.
    pub station_connect: String,
    /// The fleet router's endpoint and host, for a fleet.
    pub router: Option<(String, String)>,
    /// Station names: plain, and none a pipeline's or the router's.
    pub stations: Vec<String>,
    /// Extra host names of the predictor.
    pub hosts: Vec<String>,
    pub days: u32,
}

impl Config {
    fn vessel_names(&self) -> Vec<&str> {
        self.vessels.iter().map(Names::vessel).collect()
    }
}

impl TryFrom<Args> for Config {
    type Error = anyhow::Error;

    fn try_from(args: Args) -> anyhow::Result<Self> {
        let vessels = args
            .vessel
            .iter()
            .map(|v| Names::new(args.instance.as_deref(), v))
            .collect::<Result<Vec<_>, _>>()?;
        if vessels.len() > 1 && args.router.is_none() {
            anyhow::bail!("several --vessel make a fleet: give its --router endpoint too");
        }
        if let Some(v) = args
            .vessel
            .iter()
            .enumerate()
            .find_map(|(i, v)| args.vessel[..i].contains(v).then_some(v))
        {
            anyhow::bail!("--vessel '{v}' is given twice");
        }
        let listen_host = endpoint_host(&args.listen)?.to_string();
        for h in &args.host {
            if !is_host_name(h) {
                anyhow::bail!(
                    "--host '{h}': a host name (letters, digits, '-', '.') or an IP address"
                );
            }
        }
        // Regression: a wildcard listen without --host, or stations told to connect to
        // 0.0.0.0, which no certificate names (found by a security audit).
        let station_connect = if is_wildcard(&listen_host) {
            let Some(first) = args.host.first() else {
                anyhow::bail!(
                    "--listen '{}' is a wildcard address, which stations cannot connect to: give --host with the name or address they use",
                    args.listen
                );
            };
            with_host(&args.listen, first)
        } else {
            args.listen.clone()
        };
        let mut taken: Vec<String> = args.vessel.iter().map(|v| pipeline_name(v)).collect();
        // The configurations written beside the stations' `<station>.toml`: a station of the
        // same name would overwrite one (and the report would still point at it).
        let configs: Vec<String> = if args.router.is_some() {
            if args.vessel.iter().any(|v| v == ROUTER_NAME) {
                anyhow::bail!(
                    "--vessel '{ROUTER_NAME}': {ROUTER_NAME}.toml is the fleet router's configuration; choose another vessel name"
                );
            }
            taken.push(ROUTER_NAME.to_string());
            args.vessel.clone()
        } else {
            vec!["shipcast".to_string()]
        };
        for (i, s) in args.station.iter().enumerate() {
            // The second would overwrite the first's files, and the report count both.
            if args.station[..i].contains(s) {
                anyhow::bail!("--station '{s}' is given twice");
            }
            let plain = |c: char| c.is_ascii_alphanumeric() || c == '-' || c == '_' || c == '.';
            if s.is_empty() || s.len() > 64 || !s.chars().all(plain) {
                anyhow::bail!("--station '{s}': 1 to 64 letters, digits, '-', '_' or '.'");
            }
            if taken.contains(s) {
                anyhow::bail!("--station '{s}' is the name of a pipeline or of the router");
            }
            if configs.contains(s) {
                anyhow::bail!(
                    "--station '{s}': {s}.toml is a pipeline's configuration in this setup; choose another station name"
                );
            }
        }
        // Beyond about a century the certificate's end date overflows its time type.
        let days = checked(limits::count("--days", args.days, 1, MAX_DAYS))?;
        if args.out.join("ca.pem").exists() {
            anyhow::bail!(
                "{} already holds a ca.pem; choose another --out (a new CA makes every old certificate useless)",
                args.out.display()
            );
        }
        let router = match args.router {
            Some(r) => {
                let host = endpoint_host(&r)?.to_string();
                if is_wildcard(&host) {
                    anyhow::bail!(
                        "--router '{r}': vessels and stations connect to the router, so it must name its host, not a wildcard address"
                    );
                }
                Some((r, host))
            }
            None => None,
        };
        Ok(Config {
            stage: args.out.clone(),
            out: args.out,
            vessels,
            listen: args.listen,
            listen_host,
            station_connect,
            router,
            stations: args.station,
            hosts: args.host,
            days,
        })
    }
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let mut setup = Config::try_from(args)?;
    std::fs::create_dir_all(&setup.out)
        .with_context(|| format!("create {}", setup.out.display()))?;
    // Regression (review): files were written straight into --out, replacing a shipcast.toml
    // or a key of another setup there, and a run that failed half-way left a mix behind. They
    // are written beside it first and moved in only if none is there yet.
    let staging = Staging::new(&setup.out)?;
    setup.stage = staging.dir.clone();
    let done = write_setup(&setup)?;
    staging.publish(&setup.out)?;
    let _ = writeln!(std::io::stdout(), "{done}");
    Ok(())
}

/// A private directory inside `--out` that the files are written into before any is moved to
/// `--out`; removed with whatever is left in it.
struct Staging {
    dir: PathBuf,
}

impl Staging {
    fn new(out: &Path) -> anyhow::Result<Self> {
        use std::os::unix::fs::DirBuilderExt;
        // A name of its own each time: a directory left by an interrupted run (the same
        // process id, PID 1 in a container) blocked every later run (review).
        let salt = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.subsec_nanos());
        let mut attempt = 0;
        loop {
            let dir = out.join(format!(
                ".shipcast-certs-{}-{salt:x}-{attempt}",
                std::process::id()
            ));
            match std::fs::DirBuilder::new().mode(0o700).create(&dir) {
                Ok(()) => return Ok(Self { dir }),
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists && attempt < 100 => {
                    attempt += 1;
                }
                Err(e) => {
                    return Err(e).with_context(|| format!("create {}", dir.display()));
                }
            }
        }
    }

    /// Move every staged file into `out`, ca.pem last (it marks a setup as complete), after
    /// checking that none of their names is taken there; on a failure half-way the files
    /// already moved are taken back out.
    fn publish(&self, out: &Path) -> anyhow::Result<()> {
        let mut names = Vec::new();
        for entry in std::fs::read_dir(&self.dir)? {
            names.push(entry?.file_name());
        }
        names.sort_by(|a, b| (a == "ca.pem", a).cmp(&(b == "ca.pem", b)));
        let taken: Vec<String> = names
            .iter()
            .filter(|n| out.join(n).symlink_metadata().is_ok())
            .map(|n| n.to_string_lossy().into_owned())
            .collect();
        if !taken.is_empty() {
            anyhow::bail!(
                "{} already holds {}: nothing was written; choose an empty --out (or move those files away)",
                out.display(),
                taken.join(", ")
            );
        }
        let mut moved = Vec::new();
        for name in &names {
            // A hard link never replaces a file that appeared since the check; where the
            // file system has none (FAT, many network shares: review), a rename after
            // checking again.
            let (from, to) = (self.dir.join(name), out.join(name));
            let moved_in = match std::fs::hard_link(&from, &to) {
                Err(e) if e.kind() != std::io::ErrorKind::AlreadyExists => {
                    if to.symlink_metadata().is_ok() {
                        Err(std::io::Error::from(std::io::ErrorKind::AlreadyExists))
                    } else {
                        std::fs::rename(&from, &to)
                    }
                }
                linked => linked,
            };
            if let Err(e) = moved_in {
                for m in &moved {
                    let _ = std::fs::remove_file(out.join(m));
                }
                return Err(e).with_context(|| {
                    format!("move {} into {}", name.to_string_lossy(), out.display())
                });
            }
            moved.push(name);
        }
        Ok(())
    }
}

impl Drop for Staging {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// Write the whole setup into `setup.stage`; returns what to tell the user once it is in
/// `setup.out`.
fn write_setup(setup: &Config) -> anyhow::Result<String> {
    let validity = Validity::days_from_now(setup.days);
    let ca = CertAuthority::new(
        &format!("shipcast {} CA", setup.vessel_names().join(" ")),
        validity,
    )?;
    let (out, vessels, host) = (&setup.stage, &setup.vessels, setup.listen_host.as_str());
    let Some((router, router_host)) = &setup.router else {
        return single_vessel(setup, &vessels[0], host, &ca, validity);
    };
    let router_id = ca.issue(
        ROUTER_NAME,
        &server_names(router_host, &setup.hosts),
        validity,
    )?;
    write(out, "router.pem", &router_id.certificate_pem, false)?;
    write(out, "router.key", &router_id.private_key_pem, true)?;
    let fleet = fleet_keys(&vessels[0]);
    let router_zenoh = ZenohConfig {
        listen: vec![router.clone()],
        tls: Some(TlsSettings {
            root_ca: "ca.pem".into(),
            certificate: "router.pem".into(),
            private_key: "router.key".into(),
        }),
        access: Some(AccessRules {
            key_exprs: vec![fleet.clone()],
            subscribers: setup.stations.clone(),
            vessels: vessels
                .iter()
                .map(|n| VesselAccess {
                    publisher: pipeline_name(n.vessel()),
                    key_exprs: vec![vessel_keys(n)],
                })
                .collect(),
            ..AccessRules::default()
        }),
        ..ZenohConfig::default()
    };
    write(
        out,
        "router.toml",
        &format!(
            "# Router of the fleet {:?} (shipcast certs): shipcast router --config router.toml\n\
             # Each vessel's pipeline may publish only on its own keys; stations {:?} may only\n\
             # subscribe and query. TLS and users_file paths are relative to this file (others, such\n\
             # as producer.input, to the working directory).\n{}",
            setup.vessel_names(),
            setup.stations,
            consumer_toml(&vessels[0], &router_zenoh)?
        ),
        false,
    )?;
    for names in vessels {
        let pipeline = pipeline_name(names.vessel());
        let id = ca.issue(&pipeline, &server_names(host, &setup.hosts), validity)?;
        write(out, &format!("{pipeline}.pem"), &id.certificate_pem, false)?;
        write(out, &format!("{pipeline}.key"), &id.private_key_pem, true)?;
        let zenoh = ZenohConfig {
            listen: vec![setup.listen.clone()],
            connect: vec![router.clone()],
            tls: Some(TlsSettings {
                root_ca: "ca.pem".into(),
                certificate: format!("{pipeline}.pem"),
                private_key: format!("{pipeline}.key"),
            }),
            // The router may subscribe with its fleet-wide interest; the pipeline publishes.
            access: Some(AccessRules {
                key_exprs: vec![vessel_keys(names)],
                publishers: vec![pipeline.clone()],
                subscribers: vec![ROUTER_NAME.into()],
                interest_key_exprs: vec![fleet.clone()],
                ..AccessRules::default()
            }),
            ..ZenohConfig::default()
        };
        write(
            out,
            &format!("{}.toml", names.vessel()),
            &format!(
                "# Secure pipeline of vessel {} in a fleet (shipcast certs): shipcast run --config {}.toml\n\
                 # Listens on {} for its own consumers and connects to the router {router}.\n{}",
                names.vessel(),
                names.vessel(),
                setup.listen,
                consumer_toml(names, &zenoh)?
            ),
            false,
        )?;
    }
    write_stations(setup, &vessels[0], router, &ca, validity)?;
    write(out, "ca.pem", &ca.certificate_pem(), false)?;
    Ok(format!(
        "wrote a new CA and certificates for the router, {} vessel(s) and {} station(s) into {}; start the router with: shipcast router --config {}",
        vessels.len(),
        setup.stations.len(),
        setup.out.display(),
        setup.out.join("router.toml").display()
    ))
}

/// One vessel whose consumers connect to its predictor.
fn single_vessel(
    setup: &Config,
    names: &Names,
    host: &str,
    ca: &CertAuthority,
    validity: Validity,
) -> anyhow::Result<String> {
    let out = &setup.stage;
    let pipeline = pipeline_name(names.vessel());
    let pipeline_id = ca.issue(&pipeline, &server_names(host, &setup.hosts), validity)?;
    write(out, "pipeline.pem", &pipeline_id.certificate_pem, false)?;
    write(out, "pipeline.key", &pipeline_id.private_key_pem, true)?;

    let vessel_keys = vessel_keys(names);
    let pipeline_zenoh = ZenohConfig {
        listen: vec![setup.listen.clone()],
        tls: Some(TlsSettings {
            root_ca: "ca.pem".into(),
            certificate: "pipeline.pem".into(),
            private_key: "pipeline.key".into(),
        }),
        access: Some(AccessRules {
            key_exprs: vec![vessel_keys],
            publishers: vec![pipeline.clone()],
            subscribers: setup.stations.clone(),
            // The display (of `run`, or a station's) subscribes to every vessel at once.
            interest_key_exprs: vec![fleet_keys(names)],
            ..AccessRules::default()
        }),
        ..ZenohConfig::default()
    };
    let toml = consumer_toml(names, &pipeline_zenoh)?;
    write(
        out,
        "shipcast.toml",
        &format!(
            "# Secure pipeline of vessel {} (shipcast certs). TLS and users_file paths are relative to this\n\
             # file (others, such as producer.input or predictor.model, to the working directory).\n\
             # Only the certificate '{pipeline}' may publish; stations {:?} may subscribe.\n{toml}",
            names.vessel(),
            setup.stations
        ),
        false,
    )?;
    write_stations(setup, names, &setup.station_connect, ca, validity)?;
    write(out, "ca.pem", &ca.certificate_pem(), false)?;
    Ok(format!(
        "wrote a new CA and certificates for '{pipeline}' and {} station(s) into {}; start the pipeline with: shipcast run --config {}",
        setup.stations.len(),
        setup.out.display(),
        setup.out.join("shipcast.toml").display()
    ))
}

/// An unspecified IP address (0.0.0.0, ::): a listener's wildcard, no one's name.
fn is_wildcard(host: &str) -> bool {
    matches!(host.parse::<std::net::IpAddr>(), Ok(ip) if ip.is_unspecified())
}

/// A DNS name or an IP address, as a certificate's subject alternative name takes it.
fn is_host_name(host: &str) -> bool {
    host.parse::<std::net::IpAddr>().is_ok()
        || (!host.is_empty()
            && host.len() <= 253
            && host.split('.').all(|label| {
                !label.is_empty()
                    && label.len() <= 63
                    && !label.starts_with('-')
                    && !label.ends_with('-')
                    && label.chars().all(|c| c.is_ascii_alphanumeric() || c == '-')
            }))
}

/// `endpoint` (`tls/HOST:PORT[options]`) with another host.
fn with_host(endpoint: &str, host: &str) -> String {
    let address = endpoint.strip_prefix("tls/").unwrap_or(endpoint);
    let split = address.find(['#', '?']).unwrap_or(address.len());
    let (address, options) = address.split_at(split);
    let port = address.rsplit_once(':').map_or("", |(_, p)| p);
    if host.contains(':') {
        format!("tls/[{host}]:{port}{options}")
    } else {
        format!("tls/{host}:{port}{options}")
    }
}

/// `<station>.json5` and `<station>.toml` of every station, connecting to `endpoint`.
fn write_stations(
    setup: &Config,
    names: &Names,
    endpoint: &str,
    ca: &CertAuthority,
    validity: Validity,
) -> anyhow::Result<()> {
    let out = &setup.stage;
    for station in &setup.stations {
        let id = ca.issue(station, &[], validity)?;
        let zenoh = ZenohConfig {
            listen: Vec::new(),
            connect: vec![endpoint.to_string()],
            // Inline: the station's files are all it needs, wherever they are copied.
            tls: Some(TlsSettings {
                root_ca: ca.certificate_pem(),
                certificate: id.certificate_pem.clone(),
                private_key: id.private_key_pem.clone(),
            }),
            ..ZenohConfig::default()
        };
        // zenoh's own connection behaviour for other clients: one attempt, a clear failure.
        let document = zn::config_document(&ZenohSettings {
            client_connect_patience_ms: None,
            ..zenoh.consumer_side()
        });
        let json5 = format!(
            "// zenoh client configuration of station '{station}' of vessel {} (shipcast certs).\n\
             // Client mode, scouting off, mutual TLS with this station's certificate.\n{}\n",
            names.vessel(),
            serde_json::to_string_pretty(&document)?
        );
        write(out, &format!("{station}.json5"), &json5, true)?;
        let toml = consumer_toml(names, &zenoh)?;
        write(
            out,
            &format!("{station}.toml"),
            &format!("# shipcast consumer configuration of station '{station}' (shipcast certs).\n{toml}"),
            true,
        )?;
    }
    Ok(())
}

/// A pipeline configuration with only the names and the zenoh section.
fn consumer_toml(names: &Names, zenoh: &ZenohConfig) -> anyhow::Result<String> {
    #[derive(serde::Serialize)]
    struct Doc<'a> {
        #[serde(skip_serializing_if = "Option::is_none")]
        instance: Option<&'a str>,
        vessel: &'a str,
        zenoh: &'a ZenohConfig,
    }
    Ok(toml::to_string(&Doc {
        instance: names.instance(),
        vessel: names.vessel(),
        zenoh,
    })?)
}

/// Write `name` into `dir`; secrets (private keys, files embedding one) readable by the owner
/// only, never through a symlink planted at the name.
fn write(dir: &Path, name: &str, text: &str, secret: bool) -> anyhow::Result<()> {
    crate::private_files::write_new(&dir.join(name), text, secret)
}

#[cfg(test)]
mod tests {
    use super::*;

    const LISTEN: &str = "tls/127.0.0.1:7447";

    /// An output folder that does not exist yet, inside a temp dir the test owns.
    fn fresh_out() -> (tempfile::TempDir, String) {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("certs").to_string_lossy().into_owned();
        (dir, out)
    }

    fn refused(argv: &[&str]) -> String {
        let (_dir, out) = fresh_out();
        let mut full = vec!["--out", &out, "--listen", LISTEN];
        full.extend_from_slice(argv);
        crate::refused::<Args, Config>(&full)
    }

    #[test]
    fn a_fleet_setup_is_checked_before_anything_is_written() {
        let (dir, out) = fresh_out();
        let c = crate::validated::<Args, Config>(&[
            "--out",
            &out,
            "--listen",
            LISTEN,
            "--router",
            "tls/shore.example:7447",
            "--vessel",
            "a",
            "--vessel",
            "b",
            "--station",
            "crane",
        ])
        .unwrap();
        assert_eq!(c.vessel_names(), ["a", "b"]);
        assert_eq!(c.listen_host, "127.0.0.1");
        assert_eq!(
            c.router,
            Some(("tls/shore.example:7447".into(), "shore.example".into()))
        );
        assert_eq!(c.stations, ["crane"]);
        // Validation wrote nothing.
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
        assert_eq!(
            refused(&["--vessel", "a", "--vessel", "b"]),
            "several --vessel make a fleet: give its --router endpoint too"
        );
        assert_eq!(
            refused(&["--router", "tls/r:1", "--vessel", "a", "--vessel", "a"]),
            "--vessel 'a' is given twice"
        );
        assert_eq!(
            refused(&["--station", "ddg51-pipeline"]),
            "--station 'ddg51-pipeline' is the name of a pipeline or of the router"
        );
        // Regression: a station named like a configuration beside it overwrote that file.
        assert_eq!(
            refused(&["--station", "shipcast"]),
            "--station 'shipcast': shipcast.toml is a pipeline's configuration in this setup; choose another station name"
        );
        assert_eq!(
            refused(&["--router", "tls/r:1", "--vessel", "a", "--station", "a"]),
            "--station 'a': a.toml is a pipeline's configuration in this setup; choose another station name"
        );
        assert_eq!(
            refused(&["--router", "tls/r:1", "--vessel", "router"]),
            "--vessel 'router': router.toml is the fleet router's configuration; choose another vessel name"
        );
        assert_eq!(
            refused(&["--station", "a b"]),
            "--station 'a b': 1 to 64 letters, digits, '-', '_' or '.'"
        );
        assert_eq!(
            refused(&["--days", "0"]),
            format!("--days must be 1..={MAX_DAYS}, got 0")
        );
        assert_eq!(
            refused(&["--router", "tcp/r:1"]),
            "certs: endpoint 'tcp/r:1' is not tls/HOST:PORT (port 1-65535: a certificate names a fixed address)"
        );
        let bad = crate::refused::<Args, Config>(&["--out", "x", "--listen", "tcp/h:1"]);
        assert_eq!(bad, "certs: endpoint 'tcp/h:1' is not tls/HOST:PORT (port 1-65535: a certificate names a fixed address)");
    }

    /// Regression: a key written over an existing world-readable file kept its mode, and
    /// one written at a planted symlink went where the link pointed.
    #[test]
    fn a_key_is_written_anew_readable_by_its_owner_only() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let mode = |p: &Path| p.metadata().unwrap().permissions().mode() & 0o777;
        let key = dir.path().join("pipeline.key");
        std::fs::write(&key, "old").unwrap();
        std::fs::set_permissions(&key, std::fs::Permissions::from_mode(0o644)).unwrap();
        write(dir.path(), "pipeline.key", "secret", true).unwrap();
        assert_eq!(mode(&key), 0o600);
        assert_eq!(std::fs::read_to_string(&key).unwrap(), "secret");
        let elsewhere = dir.path().join("elsewhere");
        std::fs::write(&elsewhere, "untouched").unwrap();
        let link = dir.path().join("router.key");
        std::os::unix::fs::symlink(&elsewhere, &link).unwrap();
        write(dir.path(), "router.key", "secret", true).unwrap();
        assert_eq!(std::fs::read_to_string(&elsewhere).unwrap(), "untouched");
        assert!(!link.symlink_metadata().unwrap().file_type().is_symlink());
        assert_eq!(mode(&link), 0o600);
    }

    /// Regression: `--listen tls/0.0.0.0:P` without `--host` was accepted, and with it the
    /// stations' files still connected to 0.0.0.0, which no certificate names.
    #[test]
    fn a_wildcard_listen_needs_a_host_that_stations_connect_to() {
        let (_dir, out) = fresh_out();
        let wildcard =
            crate::refused::<Args, Config>(&["--out", &out, "--listen", "tls/0.0.0.0:7447"]);
        assert!(wildcard.contains("give --host"), "{wildcard}");
        let c = crate::validated::<Args, Config>(&[
            "--out",
            &out,
            "--listen",
            "tls/0.0.0.0:7447",
            "--host",
            "ship.example",
            "--host",
            "10.0.0.5",
        ])
        .unwrap();
        assert_eq!(c.listen, "tls/0.0.0.0:7447");
        assert_eq!(c.station_connect, "tls/ship.example:7447");
        assert_eq!(
            with_host("tls/[::]:7447#iface=eth0", "fd00::5"),
            "tls/[fd00::5]:7447#iface=eth0"
        );
        // A named listen host is what stations connect to.
        let c = crate::validated::<Args, Config>(&["--out", &out, "--listen", LISTEN]).unwrap();
        assert_eq!(c.station_connect, LISTEN);
        for bad in ["", "a b", "x..y", "-"] {
            let e = refused(&["--host", bad]);
            assert!(e.starts_with(&format!("--host '{bad}'")), "{e}");
        }
        assert!(refused(&["--router", "tls/0.0.0.0:7447"]).contains("not a wildcard"));
    }

    /// Regressions: ca.pem was written first, so a run that failed on a later file left it,
    /// and the retry was refused as if a setup were there; then (review) the files before the
    /// failing one were left, and a shipcast.toml of another setup in --out was replaced.
    #[test]
    fn a_refused_run_writes_nothing_replaces_nothing_and_can_be_retried() {
        let (_dir, out) = fresh_out();
        let out_dir = Path::new(&out);
        std::fs::create_dir_all(out_dir.join("pipeline.key")).unwrap();
        std::fs::write(out_dir.join("shipcast.toml"), "precious").unwrap();
        let argv = ["--out", &out, "--listen", LISTEN, "--station", "ops"];
        let e = format!("{:#}", run(crate::parse_args::<Args>(&argv)).unwrap_err());
        assert!(
            e.contains("already holds pipeline.key, shipcast.toml: nothing was written"),
            "{e}"
        );
        let mut left: Vec<_> = std::fs::read_dir(out_dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().into_string().unwrap())
            .collect();
        left.sort();
        assert_eq!(left, ["pipeline.key", "shipcast.toml"]);
        assert_eq!(
            std::fs::read_to_string(out_dir.join("shipcast.toml")).unwrap(),
            "precious"
        );
        std::fs::remove_dir(out_dir.join("pipeline.key")).unwrap();
        std::fs::remove_file(out_dir.join("shipcast.toml")).unwrap();
        run(crate::parse_args::<Args>(&argv)).unwrap();
        for name in [
            "ca.pem",
            "pipeline.key",
            "shipcast.toml",
            "ops.json5",
            "ops.toml",
        ] {
            assert!(out_dir.join(name).is_file(), "{name}");
        }
        assert_eq!(std::fs::read_dir(out_dir).unwrap().count(), 6);
    }

    #[test]
    fn an_existing_ca_is_never_overwritten() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("ca.pem"), "old").unwrap();
        let out = dir.path().to_str().unwrap();
        assert_eq!(
            crate::refused::<Args, Config>(&["--out", out, "--listen", LISTEN]),
            format!("{out} already holds a ca.pem; choose another --out (a new CA makes every old certificate useless)")
        );
    }
}
