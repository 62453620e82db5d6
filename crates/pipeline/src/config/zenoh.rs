//! `[zenoh]`: endpoints, mode and security of the zenoh sessions.

use super::{ConfigError, CLIENT_CONNECT_PATIENCE_MS, CONSUMER_LISTEN, DEFAULT_ZENOH_ENDPOINT};
use crate::transport::zenoh::{Mode, ZenohSettings};
use crate::transport::zenoh_security::{is_inline_pem, AccessRules, TlsSettings, UserPassword};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// zenoh endpoints and security: the predictor listens, consumers connect.
///
/// Plain TCP on loopback is the default, for development and tests. With `tls` set (see
/// `shipcast certs` and docs/security.md) every link is mutual TLS, consumers are zenoh
/// clients of the predictor (or of a router), and the predictor enforces `access`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ZenohConfig {
    /// Endpoints the publishing side (predictor) listens on.
    pub listen: Vec<String>,
    /// Extra endpoints every process connects to (a router or remote peer).
    pub connect: Vec<String>,
    /// UDP multicast scouting (off by default: explicit endpoints only).
    pub multicast_scouting: bool,
    /// TLS identity of this configuration's processes (paths relative to the config file, or
    /// inline PEM).
    pub tls: Option<TlsSettings>,
    /// zenoh user/password authentication.
    pub auth: Option<UserPassword>,
    /// Access rules the predictor enforces on its links (by certificate common name).
    pub access: Option<AccessRules>,
}

impl Default for ZenohConfig {
    fn default() -> Self {
        Self {
            listen: vec![DEFAULT_ZENOH_ENDPOINT.to_string()],
            connect: Vec::new(),
            multicast_scouting: false,
            tls: None,
            auth: None,
            access: None,
        }
    }
}

impl ZenohConfig {
    /// Settings of the process that publishes (listens on `listen`, enforces `access`).
    pub fn publisher_side(&self) -> ZenohSettings {
        ZenohSettings {
            mode: Mode::Peer,
            listen: self.listen.clone(),
            connect: self.connect.clone(),
            multicast_scouting: self.multicast_scouting,
            tls: self.tls.clone(),
            auth: self.auth.clone(),
            access: self.access.clone(),
            downsample_egress: None,
            client_connect_patience_ms: None,
        }
    }

    /// Settings of a consumer: connects to the publisher's listen endpoints and the extra ones.
    ///
    /// Plain: a peer listening on an ephemeral loopback port. Peers route only their own
    /// traffic, so two consumers (the deck publishing its advisory, `shipcast run` showing it)
    /// must be able to connect to each other directly; gossip through the predictor tells them
    /// where. Secure (`tls` set): a client that reaches everything through the node it
    /// connects to, so nothing goes around that node's access rules.
    pub fn consumer_side(&self) -> ZenohSettings {
        // The predictor's own consumers reach a wildcard listen address on this machine's
        // loopback, which `shipcast certs` always names in the certificate (0.0.0.0 is no
        // name: with TLS every consumer was refused).
        let mut connect: Vec<String> = self.listen.iter().map(|e| on_loopback(e)).collect();
        connect.extend(self.connect.iter().cloned());
        let secure = self.tls.is_some();
        ZenohSettings {
            mode: if secure { Mode::Client } else { Mode::Peer },
            listen: if secure {
                Vec::new()
            } else {
                vec![CONSUMER_LISTEN.to_string()]
            },
            connect,
            multicast_scouting: self.multicast_scouting && !secure,
            tls: self.tls.clone(),
            auth: self.auth.clone().map(|a| UserPassword {
                users_file: None,
                ..a
            }),
            access: None,
            downsample_egress: None,
            client_connect_patience_ms: secure.then_some(CLIENT_CONNECT_PATIENCE_MS),
        }
    }

    /// Make the relative paths of certificates, keys and the users file relative to `base`
    /// (the config file's directory), and absolute, so the file works from any working
    /// directory and in `shipcast run`'s children. (A path left relative, as `fleet/ca.pem`
    /// from `--config fleet/ddg51.toml`, was written into the children's configuration in the
    /// log directory and resolved again there.)
    pub fn resolve_paths(&mut self, base: &Path) {
        let resolve = |v: &mut String| {
            if !is_inline_pem(v) && Path::new(v.as_str()).is_relative() {
                let joined = base.join(v.as_str());
                // absolute() fails only for an empty path or without a working directory:
                // then the joined path is the best there is.
                let path = std::path::absolute(&joined).unwrap_or(joined);
                *v = path.to_string_lossy().into_owned();
            }
        };
        if let Some(t) = &mut self.tls {
            resolve(&mut t.root_ca);
            resolve(&mut t.certificate);
            resolve(&mut t.private_key);
        }
        if let Some(f) = self.auth.as_mut().and_then(|a| a.users_file.as_mut()) {
            resolve(f);
        }
    }

    /// Check the endpoints' shape and the security settings that parse but cannot work.
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.validate_with_flag("--zenoh-listen")
    }

    /// [`Self::validate`] for a command whose listen endpoints come from `listen_flag`
    /// (`shipcast router --listen`), so that its errors name the flag it has.
    pub fn validate_with_flag(&self, listen_flag: &str) -> Result<(), ConfigError> {
        let bad = |m: &str| Err(ConfigError::Invalid(format!("zenoh.{m}")));
        for (key, flag, endpoints) in [
            ("listen", listen_flag, &self.listen),
            ("connect", "--zenoh-connect", &self.connect),
        ] {
            if let Some(e) = endpoints.iter().find(|e| !endpoint_shape_ok(e)) {
                return bad(&format!(
                    "{key} (or {flag}) endpoint '{e}' is not PROTOCOL/HOST:PORT, with a port other than 0, e.g. tcp/127.0.0.1:7447 or tls/10.0.0.5:7447"
                ));
            }
            // Regression (review): a listen endpoint given twice failed as "Address already in
            // use", which sent the reader after another process holding the port.
            if let Some((i, e)) = endpoints
                .iter()
                .enumerate()
                .find(|(i, e)| endpoints[..*i].contains(e))
            {
                return bad(&format!(
                    "{key} (or {flag}) endpoint '{e}' is given twice (entries {} and {})",
                    endpoints[..i].iter().position(|o| o == e).unwrap_or(0) + 1,
                    i + 1
                ));
            }
        }
        let tls_endpoint = self
            .listen
            .iter()
            .chain(&self.connect)
            .any(|e| e.starts_with("tls/"));
        if tls_endpoint && self.tls.is_none() {
            return bad("tls (root_ca, certificate, private_key) is required for tls/ endpoints");
        }
        // Regression: a plain endpoint beside the TLS one served every forecast, unencrypted
        // and unauthenticated, to any client (found by a security audit).
        if self.tls.is_some() {
            for (key, flag, endpoints) in [
                ("listen", listen_flag, &self.listen),
                ("connect", "--zenoh-connect", &self.connect),
            ] {
                if let Some(e) = endpoints.iter().find(|e| !e.starts_with("tls/")) {
                    let default = if e == DEFAULT_ZENOH_ENDPOINT {
                        "; it is the default: give listen = [] for a station that only connects"
                    } else {
                        ""
                    };
                    return bad(&format!(
                        "{key} (or {flag}) endpoint '{e}' is not tls/: with [zenoh.tls] every link must be mutual TLS (a plain endpoint would carry the data unencrypted, to anyone){default}"
                    ));
                }
            }
        }
        if self.tls.is_some() && self.multicast_scouting {
            return bad("multicast_scouting must be off with tls: consumers reach the data only through the node that enforces the access rules");
        }
        if let Some(a) = &self.access {
            if a.key_exprs.is_empty() || (a.publishers.is_empty() && a.vessels.is_empty()) {
                return bad(
                    "access needs key_exprs and publishers or vessels (everything else is denied)",
                );
            }
            if self.tls.is_none() {
                return bad("access names certificate common names, so it needs tls");
            }
        }
        if let Some(a) = &self.auth {
            if a.user.is_some() != a.password.is_some() {
                return bad("auth needs both user and password");
            }
        }
        Ok(())
    }
}

/// `endpoint` with an unspecified host (0.0.0.0, [::]) replaced by a loopback address (with
/// TLS always 127.0.0.1, the one the certificate names); any other endpoint as it is.
pub fn on_loopback(endpoint: &str) -> String {
    let Some((protocol, rest)) = endpoint.split_once('/') else {
        return endpoint.to_string();
    };
    let split = rest.find(['?', '#']).unwrap_or(rest.len());
    let (address, options) = rest.split_at(split);
    let Some((host, port)) = address.rsplit_once(':') else {
        return endpoint.to_string();
    };
    // TLS checks the name connected to against the certificate, which `certs` makes for
    // 127.0.0.1 and localhost, never ::1 (and zenoh's TLS link takes no bracketed address as
    // a name): a [::] listener, dual-stack, is reached on 127.0.0.1.
    let named = matches!(protocol, "tls" | "quic");
    let loopback = match host.trim_start_matches('[').trim_end_matches(']').parse() {
        Ok(std::net::IpAddr::V4(ip)) if ip.is_unspecified() => "127.0.0.1",
        Ok(std::net::IpAddr::V6(ip)) if ip.is_unspecified() && named => "127.0.0.1",
        Ok(std::net::IpAddr::V6(ip)) if ip.is_unspecified() => "[::1]",
        _ => return endpoint.to_string(),
    };
    format!("{protocol}/{loopback}:{port}{options}")
}

/// Whether an endpoint has zenoh's `protocol/address` shape with a port for the IP protocols
/// (zenoh itself checks the rest when it opens, but its error names its own JSON key, not
/// ours). Endpoint options after `?` or `#` are left to zenoh.
fn endpoint_shape_ok(endpoint: &str) -> bool {
    let core = endpoint.split(['?', '#']).next().unwrap_or("");
    let Some((protocol, address)) = core.split_once('/') else {
        return false;
    };
    match protocol {
        // Port 0 lets the system pick one that nobody can be told: consumers copy the
        // listen endpoints to connect to, and connected to port 0 they heard nothing.
        "tcp" | "udp" | "tls" | "quic" | "ws" => {
            address.rsplit_once(':').is_some_and(|(host, port)| {
                !host.is_empty() && port.parse::<u16>().is_ok_and(|p| p != 0)
            })
        }
        "" => false,
        // Other transports (unixsock-stream, serial, ...) have addresses of their own.
        _ => !address.is_empty(),
    }
}
