//! The TLS files a zenoh session is given, checked before zenoh sees them: present, readable,
//! holding PEM, and certificates within their dates. zenoh itself finds a bad file only when a
//! link is made, and then names none.

use crate::transport::cert_validity::{self, Issuer, Validity};
use crate::transport::zenoh::{err, ZenohError};
use crate::transport::zenoh_security as security;

/// The three TLS files of `tls` checked ([`check_tls_file`]), then our certificate against
/// the root CA file ([`check_issuer`]), each file read once.
pub(super) fn check_tls_files(tls: &security::TlsSettings) -> Result<(), ZenohError> {
    let root_ca = check_tls_file("root_ca", &tls.root_ca)?;
    let certificate = check_tls_file("certificate", &tls.certificate)?;
    check_tls_file("private_key", &tls.private_key)?;
    check_issuer(&certificate, &root_ca)
}

/// A TLS file as read, and how its messages name it.
#[derive(Debug)]
pub(super) struct TlsFile {
    context: String,
    text: Vec<u8>,
}

/// A TLS file that is missing, unreadable, empty or holds no PEM block, named in one line
/// before zenoh is given it: zenoh finds out only when a link is made, and a client retried
/// for its whole patience (a minute) and then reported a timeout that named no file.
pub(super) fn check_tls_file(key: &str, value: &str) -> Result<TlsFile, ZenohError> {
    let (context, text) = if security::is_inline_pem(value) {
        (format!("tls {key} (inline)"), value.as_bytes().to_vec())
    } else {
        let context = format!("tls {key} file {value}");
        let text = std::fs::read(value).map_err(err(context.clone()))?;
        if !text.windows(10).any(|w| w == b"-----BEGIN") {
            let why = if text.is_empty() {
                "the file is empty"
            } else {
                "no PEM block (-----BEGIN ...) in it"
            };
            return Err(err(context)(why));
        }
        (context, text)
    };
    let now = cert_validity::now_unix();
    match key {
        "private_key" => {}
        // A bundle of CAs (the old one and its successor while certificates are renewed) is
        // refused only if none of them is valid; an expired one beside a valid one warns.
        "root_ca" => {
            let all = cert_validity::validities(&text, now);
            if !all.iter().any(Validity::is_usable) {
                let first = all.into_iter().next().unwrap_or(Validity::Unreadable);
                judge_certificate_dates(&context, first)?;
            } else {
                for v in &all {
                    if let Validity::Expired { not_after } = v {
                        tracing::warn!(
                            "{context}: one of its CA certificates expired on {not_after}; a valid one is used"
                        );
                    }
                }
            }
        }
        _ => judge_certificate_dates(&context, cert_validity::validity(&text, now))?,
    }
    Ok(TlsFile { context, text })
}

/// Refuse our own certificate when the root CA file holds a CA of its issuer's name that did
/// not sign it: a certificate from another `shipcast certs` run than the CA's, which every
/// peer refuses at the handshake while this service would have started as if all were well.
/// Signed by a CA the file does not hold at all (trust split between nodes) only warns.
fn check_issuer(own: &TlsFile, roots: &TlsFile) -> Result<(), ZenohError> {
    match cert_validity::issued_by(&own.text, &roots.text) {
        Some(Issuer::SameNameOtherKey) => Err(err(own.context.clone())(format!(
            "not signed by the CA of its issuer's name in {} (from another `shipcast certs` run?): every peer trusting that file would refuse it",
            roots.context
        ))),
        Some(Issuer::Untrusted) => {
            tracing::warn!(
                "{}: signed by a CA that {} does not hold: peers that trust only that file will refuse this node",
                own.context,
                roots.context
            );
            Ok(())
        }
        Some(Issuer::Trusted) | None => Ok(()),
    }
}

/// Refuse a certificate (ours, or the root CA we trust) outside its dates, and warn two weeks
/// before it expires (`cert_validity`).
fn judge_certificate_dates(context: &str, validity: Validity) -> Result<(), ZenohError> {
    let renew = "make new certificates with `shipcast certs` and hand them out";
    match validity {
        Validity::Valid | Validity::Unreadable => Ok(()),
        Validity::ExpiresSoon { not_after } => {
            tracing::warn!("{context}: the certificate expires on {not_after}: {renew}");
            Ok(())
        }
        Validity::Expired { not_after } => Err(err(context)(format!(
            "the certificate expired on {not_after}: {renew}"
        ))),
        Validity::NotYetValid { not_before } => Err(err(context)(format!(
            "the certificate is not valid before {not_before}: is this machine's clock right?"
        ))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each file read once and handed to the issuer check: a certificate signed by another CA
    /// of its issuer's name than the root CA's is refused, naming both; the right CA passes.
    #[test]
    fn the_files_are_checked_and_then_the_certificate_against_the_root_ca() {
        use crate::transport::cert_validity::test_certs::{ca, leaf};
        let (ours, ours_pem) = ca("shipcast ddg51 CA");
        let (_, other_pem) = ca("shipcast ddg51 CA");
        let (leaf, leaf_key) = leaf(&ours);
        let settings = |root_ca: &str| security::TlsSettings {
            root_ca: root_ca.to_string(),
            certificate: leaf.clone(),
            private_key: leaf_key.serialize_pem(),
        };
        assert!(check_tls_files(&settings(&ours_pem)).is_ok());
        let e = format!(
            "{:#}",
            anyhow::Error::from(check_tls_files(&settings(&other_pem)).unwrap_err())
        );
        assert!(
            e.contains("tls certificate (inline): not signed by the CA of its issuer's name in tls root_ca (inline)"),
            "{e}"
        );
    }

    /// Regression: a missing, empty or garbage certificate was found by zenoh only when a
    /// link was made; a client retried for a minute and then reported a timeout.
    #[test]
    fn tls_files_are_checked_before_zenoh_and_named_in_the_error() {
        let dir = tempfile::tempdir().unwrap();
        let path = |name: &str| dir.path().join(name).to_string_lossy().into_owned();
        std::fs::write(path("empty.pem"), "").unwrap();
        std::fs::write(path("garbage.pem"), "not a certificate").unwrap();
        std::fs::write(path("ok.pem"), "-----BEGIN CERTIFICATE-----\nMIIB\n").unwrap();
        let message = |key: &str, value: &str| {
            format!(
                "{:#}",
                anyhow::Error::from(check_tls_file(key, value).unwrap_err())
            )
        };
        let missing = path("missing.pem");
        let e = message("root_ca", &missing);
        assert!(
            e.starts_with(&format!("zenoh: tls root_ca file {missing}: ")),
            "{e}"
        );
        assert!(e.contains("No such file"), "{e}");
        let e = message("certificate", &path("empty.pem"));
        assert!(e.ends_with("empty.pem: the file is empty"), "{e}");
        let e = message("private_key", &path("garbage.pem"));
        assert!(
            e.ends_with("garbage.pem: no PEM block (-----BEGIN ...) in it"),
            "{e}"
        );
        assert!(check_tls_file("certificate", &path("ok.pem")).is_ok());
        // Inline PEM (a station's configuration) is not a path.
        assert!(check_tls_file("root_ca", "-----BEGIN CERTIFICATE-----\nMIIB\n").is_ok());
    }

    /// Regression: an expired certificate of our own was found only when a peer refused it in
    /// the handshake; the service had started as if all was well.
    #[test]
    fn a_certificate_outside_its_dates_is_refused_at_start_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let mut params = rcgen::CertificateParams::new(vec!["vessel".to_string()]).unwrap();
        params.not_before = rcgen::date_time_ymd(2020, 1, 1);
        params.not_after = rcgen::date_time_ymd(2021, 1, 1);
        let key = rcgen::KeyPair::generate().unwrap();
        let expired = params.self_signed(&key).unwrap().pem();
        let file = dir.path().join("vessel.pem").to_string_lossy().into_owned();
        std::fs::write(&file, &expired).unwrap();
        let e = format!(
            "{:#}",
            anyhow::Error::from(check_tls_file("certificate", &file).unwrap_err())
        );
        assert!(
            e.starts_with(&format!(
                "zenoh: tls certificate file {file}: the certificate expired on "
            )) && e.contains("2021")
                && e.ends_with("make new certificates with `shipcast certs` and hand them out"),
            "{e}"
        );
        // Inline, and as the root CA, the same; a key file is not a certificate.
        let e = format!(
            "{:#}",
            anyhow::Error::from(check_tls_file("root_ca", &expired).unwrap_err())
        );
        assert!(
            e.starts_with("zenoh: tls root_ca (inline): the certificate expired"),
            "{e}"
        );
        assert!(check_tls_file("private_key", &expired).is_ok());
        // A CA bundle with a valid CA beside the expired one is accepted (CA rotation); our
        // own certificate first in its file is what counts.
        let mut params = rcgen::CertificateParams::new(vec!["ca".to_string()]).unwrap();
        params.not_before = rcgen::date_time_ymd(2024, 1, 1);
        params.not_after = rcgen::date_time_ymd(4000, 1, 1);
        let current = params.self_signed(&key).unwrap().pem();
        assert!(check_tls_file("root_ca", &format!("{expired}{current}")).is_ok());
        assert!(check_tls_file("certificate", &format!("{expired}{current}")).is_err());
        assert!(check_tls_file("certificate", &format!("{current}{expired}")).is_ok());
        // Before its dates (by a clock set back): the clock is named.
        let e = format!(
            "{:#}",
            anyhow::Error::from(
                judge_certificate_dates(
                    "tls certificate",
                    cert_validity::validity(expired.as_bytes(), 1_500_000_000)
                )
                .unwrap_err()
            )
        );
        assert!(e.ends_with("is this machine's clock right?"), "{e}");
    }
}
