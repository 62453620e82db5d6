//! `shipcast certs`: a secure deployment in one command. Writes a new CA, the certificates and
//! keys of the vessel's pipeline and of each station, the pipeline configuration
//! (`shipcast.toml`, used as it is by `shipcast run --config`) and, per station, a zenoh client
//! configuration (`<station>.json5`, for any zenoh client) and a shipcast consumer
//! configuration (`<station>.toml`, for `shipcast crane --config`). docs/security.md has the
//! steps.

use anyhow::Context;
use shipcast_pipeline::certs::{endpoint_host, server_names, CertAuthority, Validity};
use shipcast_pipeline::config::ZenohConfig;
use shipcast_pipeline::limits;
use shipcast_pipeline::transport::zenoh::{self as zn, ZenohSettings};
use shipcast_pipeline::transport::zenoh_security::{AccessRules, TlsSettings};
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
    /// Vessel name (keys `shipcast/<vessel>/...`).
    #[arg(long, value_name = "NAME", default_value = shipcast_pipeline::transport::naming::DEFAULT_VESSEL)]
    pub vessel: String,
    /// Endpoint the predictor listens on, e.g. tls/10.0.0.5:7447.
    #[arg(long, value_name = "ENDPOINT")]
    pub listen: String,
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

pub fn run(args: Args) -> anyhow::Result<()> {
    let names = Names::new(args.instance.as_deref(), &args.vessel)?;
    let host = endpoint_host(&args.listen)?;
    let pipeline = pipeline_name(&args.vessel);
    for s in &args.station {
        let plain = |c: char| c.is_ascii_alphanumeric() || c == '-' || c == '_' || c == '.';
        if s.is_empty() || s.len() > 64 || !s.chars().all(plain) {
            anyhow::bail!("--station '{s}': 1 to 64 letters, digits, '-', '_' or '.'");
        }
        if *s == pipeline {
            anyhow::bail!("--station '{s}' is the pipeline's own name");
        }
    }
    // Beyond about a century the certificate's end date overflows its time type.
    limits::count("--days", args.days, 1, MAX_DAYS).map_err(anyhow::Error::msg)?;
    if args.out.join("ca.pem").exists() {
        anyhow::bail!(
            "{} already holds a ca.pem; choose another --out (a new CA makes every old certificate useless)",
            args.out.display()
        );
    }
    std::fs::create_dir_all(&args.out).with_context(|| format!("create {}", args.out.display()))?;

    let validity = Validity::days_from_now(args.days);
    let ca = CertAuthority::new(&format!("shipcast {} CA", args.vessel), validity)?;
    let pipeline_id = ca.issue(&pipeline, &server_names(host, &args.host), validity)?;
    let out = &args.out;
    write(out, "ca.pem", &ca.certificate_pem(), false)?;
    write(out, "pipeline.pem", &pipeline_id.certificate_pem, false)?;
    write(out, "pipeline.key", &pipeline_id.private_key_pem, true)?;

    // Every key of this pipeline: `[<instance>/]shipcast/<vessel>/**`.
    let forecast = names.forecast();
    let vessel_keys = format!("{}**", forecast.trim_end_matches("forecast"));
    let pipeline_zenoh = ZenohConfig {
        listen: vec![args.listen.clone()],
        tls: Some(TlsSettings {
            root_ca: "ca.pem".into(),
            certificate: "pipeline.pem".into(),
            private_key: "pipeline.key".into(),
        }),
        access: Some(AccessRules {
            key_exprs: vec![vessel_keys],
            publishers: vec![pipeline.clone()],
            subscribers: args.station.clone(),
        }),
        ..ZenohConfig::default()
    };
    let toml = consumer_toml(&names, &pipeline_zenoh)?;
    write(
        out,
        "shipcast.toml",
        &format!(
            "# Secure pipeline of vessel {} (shipcast certs). Paths are relative to this file.\n\
             # Only the certificate '{pipeline}' may publish; stations {:?} may subscribe.\n{toml}",
            args.vessel, args.station
        ),
        false,
    )?;

    for station in &args.station {
        let id = ca.issue(station, &[], validity)?;
        let zenoh = ZenohConfig {
            listen: Vec::new(),
            connect: vec![args.listen.clone()],
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
            args.vessel,
            serde_json::to_string_pretty(&document)?
        );
        write(out, &format!("{station}.json5"), &json5, true)?;
        let toml = consumer_toml(&names, &zenoh)?;
        write(
            out,
            &format!("{station}.toml"),
            &format!("# shipcast consumer configuration of station '{station}' (shipcast certs).\n{toml}"),
            true,
        )?;
    }
    let _ = writeln!(
        std::io::stdout(),
        "wrote a new CA and certificates for '{pipeline}' and {} station(s) into {}; start the pipeline with: shipcast run --config {}",
        args.station.len(),
        out.display(),
        out.join("shipcast.toml").display()
    );
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
/// only.
fn write(dir: &Path, name: &str, text: &str, secret: bool) -> anyhow::Result<()> {
    use std::os::unix::fs::OpenOptionsExt;
    let path = dir.join(name);
    let mut file = std::fs::OpenOptions::new()
        .write(true)
        .create(true)
        .truncate(true)
        .mode(if secret { 0o600 } else { 0o644 })
        .open(&path)
        .with_context(|| format!("write {}", path.display()))?;
    file.write_all(text.as_bytes())
        .with_context(|| format!("write {}", path.display()))?;
    Ok(())
}
