//! Certificates for a secure deployment (`shipcast certs`), made with rcgen: one new CA per run,
//! a certificate for the vessel's pipeline (the predictor and its local consumers) and one per
//! station. The certificate's common name is the identity zenoh's access rules name.

use rcgen::{
    BasicConstraints, CertificateParams, CertifiedIssuer, DnType, ExtendedKeyUsagePurpose, IsCa,
    KeyPair, KeyUsagePurpose,
};
use std::net::IpAddr;
use time::{Duration, OffsetDateTime};

/// Why certificates could not be made. rcgen's error is the `source`, left out of the
/// message, so `{:#}` prints it once.
#[derive(Debug, thiserror::Error)]
pub enum CertError {
    #[error("certs: cannot make a key or certificate")]
    Rcgen(#[from] rcgen::Error),
    /// A listen or router endpoint that a certificate cannot name.
    #[error("certs: endpoint '{endpoint}' is not tls/HOST:PORT (port 1-65535: a certificate names a fixed address)")]
    Endpoint { endpoint: String },
}

/// A certificate and its private key, both PEM.
#[derive(Debug, Clone)]
pub struct Identity {
    /// Common name: the identity in access rules.
    pub name: String,
    pub certificate_pem: String,
    pub private_key_pem: String,
}

/// Validity of issued certificates.
#[derive(Debug, Clone, Copy)]
pub struct Validity {
    pub not_before: OffsetDateTime,
    pub not_after: OffsetDateTime,
}

impl Validity {
    /// From an hour ago (clock skew between ships) for `days` days.
    pub fn days_from_now(days: u32) -> Self {
        let now = OffsetDateTime::now_utc();
        Self {
            not_before: now - Duration::hours(1),
            not_after: now + Duration::days(days as i64),
        }
    }
}

/// A certificate authority that exists only in memory while certificates are issued.
pub struct CertAuthority {
    issuer: CertifiedIssuer<'static, KeyPair>,
}

impl CertAuthority {
    /// A new CA with a fresh key: two calls give two unrelated CAs.
    pub fn new(name: &str, validity: Validity) -> Result<Self, CertError> {
        let mut params = CertificateParams::new(Vec::<String>::new())?;
        params.distinguished_name.push(DnType::CommonName, name);
        params.is_ca = IsCa::Ca(BasicConstraints::Constrained(0));
        params.key_usages = vec![
            KeyUsagePurpose::KeyCertSign,
            KeyUsagePurpose::CrlSign,
            KeyUsagePurpose::DigitalSignature,
        ];
        params.not_before = validity.not_before;
        params.not_after = validity.not_after;
        let issuer = CertifiedIssuer::self_signed(params, KeyPair::generate()?)?;
        Ok(Self { issuer })
    }

    pub fn certificate_pem(&self) -> String {
        self.issuer.pem()
    }

    /// Issue a certificate for `common_name`, valid as a TLS server for `hosts` (DNS names or
    /// IP addresses) and as a TLS client.
    pub fn issue(
        &self,
        common_name: &str,
        hosts: &[String],
        validity: Validity,
    ) -> Result<Identity, CertError> {
        let mut params = CertificateParams::new(hosts.to_vec())?;
        params
            .distinguished_name
            .push(DnType::CommonName, common_name);
        params.is_ca = IsCa::ExplicitNoCa;
        params.key_usages = vec![
            KeyUsagePurpose::DigitalSignature,
            KeyUsagePurpose::KeyEncipherment,
        ];
        params.extended_key_usages = vec![
            ExtendedKeyUsagePurpose::ServerAuth,
            ExtendedKeyUsagePurpose::ClientAuth,
        ];
        params.use_authority_key_identifier_extension = true;
        params.not_before = validity.not_before;
        params.not_after = validity.not_after;
        let key = KeyPair::generate()?;
        let cert = params.signed_by(&key, &self.issuer)?;
        Ok(Identity {
            name: common_name.to_string(),
            certificate_pem: cert.pem(),
            private_key_pem: key.serialize_pem(),
        })
    }
}

/// The host of a zenoh endpoint such as `tls/10.0.0.5:7447` or `tls/[::1]:7447`.
pub fn endpoint_host(endpoint: &str) -> Result<&str, CertError> {
    let bad = || CertError::Endpoint {
        endpoint: endpoint.to_string(),
    };
    let address = endpoint.strip_prefix("tls/").ok_or_else(bad)?;
    // Endpoint options (`#...`, `?...`) are not part of the address.
    let address = address.split(['#', '?']).next().unwrap_or(address);
    let (host, port) = address.rsplit_once(':').ok_or_else(bad)?;
    if host.is_empty() || !port.parse::<u16>().is_ok_and(|p| p != 0) {
        return Err(bad());
    }
    Ok(host.trim_start_matches('[').trim_end_matches(']'))
}

/// The names a listener's certificate must carry for nodes connecting to `host` (a wildcard
/// address is no name: nodes connect to one of the machine's real names, given as `extra`).
pub fn server_names(host: &str, extra: &[String]) -> Vec<String> {
    let wildcard = matches!(host.parse::<IpAddr>(), Ok(ip) if ip.is_unspecified());
    let mut names: Vec<String> = Vec::new();
    for n in std::iter::once(host.to_string())
        .filter(|_| !wildcard)
        .chain(extra.iter().cloned())
        .chain(["localhost".to_string(), "127.0.0.1".to_string()])
    {
        if !names.contains(&n) {
            names.push(n);
        }
    }
    names
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn endpoint_hosts_are_parsed() {
        assert_eq!(endpoint_host("tls/127.0.0.1:7447").unwrap(), "127.0.0.1");
        assert_eq!(endpoint_host("tls/[::1]:7447").unwrap(), "::1");
        assert_eq!(
            endpoint_host("tls/ship.example:7447#x=1").unwrap(),
            "ship.example"
        );
        for bad in [
            "tcp/127.0.0.1:7447",
            "tls/127.0.0.1",
            "tls/:7447",
            "tls/h:port",
            "tls/127.0.0.1:0",
        ] {
            let e = anyhow::Error::from(endpoint_host(bad).unwrap_err());
            assert_eq!(
                format!("{e:#}"),
                format!("certs: endpoint '{bad}' is not tls/HOST:PORT (port 1-65535: a certificate names a fixed address)")
            );
        }
        assert_eq!(
            server_names("0.0.0.0", &["ship.example".into()]),
            ["ship.example", "localhost", "127.0.0.1"]
        );
        assert_eq!(server_names("127.0.0.1", &[]), ["127.0.0.1", "localhost"]);
    }

    #[test]
    fn two_authorities_are_unrelated_and_leaves_carry_their_name() {
        let v = Validity::days_from_now(1);
        let a = CertAuthority::new("a", v).unwrap();
        let b = CertAuthority::new("b", v).unwrap();
        assert_ne!(a.certificate_pem(), b.certificate_pem());
        let id = a.issue("crane", &["localhost".into()], v).unwrap();
        assert!(id
            .certificate_pem
            .starts_with("-----BEGIN CERTIFICATE-----"));
        assert!(id.private_key_pem.contains("PRIVATE KEY"));
        // The common name is in the DER (UTF8String "crane").
        let der = pem_body(&id.certificate_pem);
        assert!(der.windows(5).any(|w| w == b"crane"));
    }

    fn pem_body(pem: &str) -> Vec<u8> {
        use base64::Engine;
        let body: String = pem.lines().filter(|l| !l.starts_with("-----")).collect();
        base64::engine::general_purpose::STANDARD
            .decode(body)
            .unwrap()
    }
}
