//! Is a TLS certificate valid now? Checked when a service starts, for its own certificate and
//! the root CA it trusts.
//!
//! Why: an expired certificate was found only when a peer refused it during the handshake. The
//! service itself started as if all was well, a client retried for its whole patience, and the
//! log named the peer's alert, not the file to renew. Now the service says at start which file
//! expired and when, and warns two weeks ahead.
//!
//! A PEM block that does not parse as a certificate is not judged here: zenoh reads the file
//! itself and names what is wrong with it.

use x509_parser::certificate::X509Certificate;
use x509_parser::pem::Pem;

/// How long before expiry a service warns [s]: two weeks, time to make new certificates
/// (`shipcast certs`) and hand them out between sorties.
pub const WARN_BEFORE_EXPIRY_S: i64 = 14 * 86_400;

/// What the first certificate of a PEM text says about `now_unix` [s since 1970].
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Validity {
    /// Valid now and for longer than [`WARN_BEFORE_EXPIRY_S`].
    Valid,
    /// Valid now, but it expires within [`WARN_BEFORE_EXPIRY_S`], at the time given.
    ExpiresSoon { not_after: String },
    /// Expired at the time given.
    Expired { not_after: String },
    /// Not valid until the time given (a clock that is wrong, or certificates made ahead).
    NotYetValid { not_before: String },
    /// No certificate could be read from it: left to zenoh.
    Unreadable,
}

impl Validity {
    /// Valid now (also when it expires soon).
    pub fn is_usable(&self) -> bool {
        matches!(self, Validity::Valid | Validity::ExpiresSoon { .. })
    }
}

/// The validity of the first certificate in `pem` (a service's own certificate comes first
/// in its file; a chain may follow; blocks that are not certificates are passed over) at
/// `now_unix`.
pub fn validity(pem: &[u8], now_unix: i64) -> Validity {
    validities(pem, now_unix)
        .into_iter()
        .next()
        .unwrap_or(Validity::Unreadable)
}

/// The validity of every certificate in `pem` at `now_unix`, in order: a root CA file may
/// hold several (the old CA and its successor while certificates are being renewed).
pub fn validities(pem: &[u8], now_unix: i64) -> Vec<Validity> {
    Pem::iter_from_buffer(pem)
        .map_while(Result::ok)
        .filter(|block| block.label == "CERTIFICATE")
        .map(|block| block_validity(&block, now_unix))
        .collect()
}

fn block_validity(block: &Pem, now_unix: i64) -> Validity {
    let Ok(cert) = block.parse_x509() else {
        return Validity::Unreadable;
    };
    let v = cert.validity();
    let (not_before, not_after) = (v.not_before.timestamp(), v.not_after.timestamp());
    if now_unix < not_before {
        Validity::NotYetValid {
            not_before: v.not_before.to_string(),
        }
    } else if now_unix > not_after {
        Validity::Expired {
            not_after: v.not_after.to_string(),
        }
    } else if not_after - now_unix < WARN_BEFORE_EXPIRY_S {
        Validity::ExpiresSoon {
            not_after: v.not_after.to_string(),
        }
    } else {
        Validity::Valid
    }
}

/// How a node's own certificate stands to the CAs it trusts itself ([`issued_by`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Issuer {
    /// Signed by a CA in the root file, directly or through a chain in its own file that one
    /// of them signed.
    Trusted,
    /// Not signed by any of them, though one carries the name of its issuer: a CA of the same
    /// name from another `shipcast certs` run (every run makes a new one), so the peers that
    /// trust this node's CA file would refuse it.
    SameNameOtherKey,
    /// Signed by a CA this node does not trust itself. Legitimate where trust is split (a
    /// node's peers trust its issuer; it trusts theirs), so it is only worth a warning.
    Untrusted,
}

/// How the first certificate in `own` stands to the certificates in `roots`; None when a
/// certificate cannot be read (left to zenoh).
pub fn issued_by(own: &[u8], roots: &[u8]) -> Option<Issuer> {
    let blocks = |pem: &[u8]| -> Vec<Pem> {
        Pem::iter_from_buffer(pem)
            .map_while(Result::ok)
            .filter(|b| b.label == "CERTIFICATE")
            .collect()
    };
    let (own_blocks, root_blocks) = (blocks(own), blocks(roots));
    if root_blocks.is_empty() {
        return None;
    }
    let first = own_blocks.first()?.parse_x509().ok()?;
    let mut chain = Vec::new();
    for block in own_blocks.iter().skip(1) {
        chain.push(block.parse_x509().ok()?);
    }
    let mut cas = Vec::new();
    for block in &root_blocks {
        cas.push(block.parse_x509().ok()?);
    }
    let signs = |signer: &X509Certificate, cert: &X509Certificate| {
        cert.verify_signature(Some(signer.public_key())).is_ok()
    };
    // A chain member counts only if a trusted CA signed it in turn.
    let trusted = cas.iter().any(|ca| signs(ca, &first))
        || chain
            .iter()
            .any(|link| signs(link, &first) && cas.iter().any(|ca| signs(ca, link)));
    if trusted {
        return Some(Issuer::Trusted);
    }
    let same_name = cas.iter().any(|ca| ca.subject() == first.issuer());
    Some(if same_name {
        Issuer::SameNameOtherKey
    } else {
        Issuer::Untrusted
    })
}

/// Seconds since 1970 now, by the system clock (what the peers check against too).
pub fn now_unix() -> i64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| i64::try_from(d.as_secs()).unwrap_or(i64::MAX))
}

/// Certificates for the tests of this module and of `zenoh_tls_files`.
#[cfg(test)]
pub(crate) mod test_certs {
    use rcgen::{BasicConstraints, CertificateParams, IsCa, Issuer, KeyPair};

    /// A CA of common name `name`: what signs with it, and its PEM.
    pub fn ca(name: &str) -> (Issuer<'static, KeyPair>, String) {
        let mut params = CertificateParams::new(Vec::<String>::new()).unwrap();
        params.is_ca = IsCa::Ca(BasicConstraints::Unconstrained);
        params
            .distinguished_name
            .push(rcgen::DnType::CommonName, name);
        let key = KeyPair::generate().unwrap();
        let cert = params.self_signed(&key).unwrap();
        (Issuer::new(params, key), cert.pem())
    }

    /// A certificate for localhost signed by `ca`: its PEM and its key.
    pub fn leaf(ca: &Issuer<'static, KeyPair>) -> (String, KeyPair) {
        let key = KeyPair::generate().unwrap();
        let pem = CertificateParams::new(vec!["localhost".to_string()])
            .unwrap()
            .signed_by(&key, ca)
            .unwrap()
            .pem();
        (pem, key)
    }
}

#[cfg(test)]
mod tests {
    use super::test_certs::{ca, leaf};
    use super::*;
    use rcgen::{date_time_ymd, CertificateParams, KeyPair};

    fn pem(not_before: (i32, u8, u8), not_after: (i32, u8, u8)) -> String {
        let mut params = CertificateParams::new(vec!["vessel".to_string()]).unwrap();
        params.not_before = date_time_ymd(not_before.0, not_before.1, not_before.2);
        params.not_after = date_time_ymd(not_after.0, not_after.1, not_after.2);
        let key = KeyPair::generate().unwrap();
        params.self_signed(&key).unwrap().pem()
    }

    /// 2026-06-01 00:00:00 UTC.
    const JUNE_2026: i64 = 1_780_272_000;

    #[test]
    fn a_certificate_is_judged_against_its_dates() {
        let cert = pem((2026, 1, 1), (2027, 1, 1));
        assert_eq!(validity(cert.as_bytes(), JUNE_2026), Validity::Valid);
        // Its last day: valid, with a warning; a day later, expired.
        let last = 1_798_761_600 - 3600; // 2026-12-31 23:00 UTC
        assert!(matches!(
            validity(cert.as_bytes(), last),
            Validity::ExpiresSoon { .. }
        ));
        let after = 1_798_761_600 + 86_400;
        match validity(cert.as_bytes(), after) {
            Validity::Expired { not_after } => assert!(not_after.contains("2027"), "{not_after}"),
            other => panic!("{other:?}"),
        }
        match validity(cert.as_bytes(), 1_767_225_600 - 86_400) {
            Validity::NotYetValid { not_before } => {
                assert!(not_before.contains("2026"), "{not_before}")
            }
            other => panic!("{other:?}"),
        }
        // Fifteen days before the end: no warning yet.
        assert_eq!(
            validity(cert.as_bytes(), 1_798_761_600 - 15 * 86_400),
            Validity::Valid
        );
    }

    #[test]
    fn a_certificate_is_checked_against_the_ca_that_should_have_signed_it() {
        // Two CAs of the same name: two `shipcast certs` runs.
        let (ours, ours_pem) = ca("shipcast ddg51 CA");
        let (_, other_pem) = ca("shipcast ddg51 CA");
        let (leaf, _) = leaf(&ours);
        assert_eq!(
            issued_by(leaf.as_bytes(), ours_pem.as_bytes()),
            Some(Issuer::Trusted)
        );
        assert_eq!(
            issued_by(leaf.as_bytes(), other_pem.as_bytes()),
            Some(Issuer::SameNameOtherKey)
        );
        // A bundle holding the right CA beside another passes.
        let both = format!("{other_pem}{ours_pem}");
        assert_eq!(
            issued_by(leaf.as_bytes(), both.as_bytes()),
            Some(Issuer::Trusted)
        );
        // Split trust: signed by a CA of another name that this node does not trust itself.
        let (_, stranger_pem) = ca("shore CA");
        assert_eq!(
            issued_by(leaf.as_bytes(), stranger_pem.as_bytes()),
            Some(Issuer::Untrusted)
        );
        // A chain in the certificate's own file counts only if a trusted CA signed it: the
        // leaf with its own (other run's) CA appended is still refused against another root.
        let leaf_and_ca = format!("{leaf}{ours_pem}");
        assert_eq!(
            issued_by(leaf_and_ca.as_bytes(), other_pem.as_bytes()),
            Some(Issuer::SameNameOtherKey)
        );
        // Unreadable: left to zenoh.
        assert_eq!(issued_by(b"junk", ours_pem.as_bytes()), None);
        assert_eq!(issued_by(leaf.as_bytes(), b""), None);
    }

    #[test]
    fn only_the_first_certificate_counts_and_junk_is_left_to_zenoh() {
        let own = pem((2020, 1, 1), (2021, 1, 1));
        let chain = pem((2026, 1, 1), (2030, 1, 1));
        let both = format!("{own}{chain}");
        assert!(matches!(
            validity(both.as_bytes(), JUNE_2026),
            Validity::Expired { .. }
        ));
        for junk in [
            "",
            "not a certificate",
            "-----BEGIN CERTIFICATE-----\nMIIB\n-----END CERTIFICATE-----\n",
        ] {
            assert_eq!(validity(junk.as_bytes(), JUNE_2026), Validity::Unreadable);
        }
        // A key block first is passed over; every certificate of a bundle is judged.
        let key = KeyPair::generate().unwrap().serialize_pem();
        let keyed = format!("{key}{chain}");
        assert_eq!(validity(keyed.as_bytes(), JUNE_2026), Validity::Valid);
        let v = validities(both.as_bytes(), JUNE_2026);
        assert!(
            matches!(v[..], [Validity::Expired { .. }, Validity::Valid]),
            "{v:?}"
        );
    }
}
