//! zenoh's authentication as shipcast configures it, in one process on 127.0.0.1: a listener
//! with mutual TLS and a user/password file admits a station with a valid certificate and the
//! right password, and refuses an expired certificate, a wrong password and no password,
//! each counted under its reason by shipcast's refusal layer (`zenoh_refusals`).

use shipcast_pipeline::certs::{CertAuthority, Identity, Validity};
use shipcast_pipeline::transport::zenoh::{self as zn, Mode, ZenohSettings};
use shipcast_pipeline::transport::zenoh_refusals::{refusal_events, refusals, RefusalLayer};
use shipcast_pipeline::transport::zenoh_security::{TlsSettings, UserPassword};
use time::{Duration, OffsetDateTime};
use tracing_subscriber::layer::SubscriberExt;
use tracing_subscriber::util::SubscriberInitExt;
use tracing_subscriber::Layer;

fn tls(ca: &CertAuthority, id: &Identity) -> TlsSettings {
    // Inline PEM: the settings carry the certificates themselves.
    TlsSettings {
        root_ca: ca.certificate_pem(),
        certificate: id.certificate_pem.clone(),
        private_key: id.private_key_pem.clone(),
    }
}

fn client(endpoint: &str, tls: TlsSettings, auth: Option<(&str, &str)>) -> ZenohSettings {
    ZenohSettings {
        mode: Mode::Client,
        connect: vec![endpoint.to_string()],
        tls: Some(tls),
        auth: auth.map(|(user, password)| UserPassword {
            user: Some(user.into()),
            password: Some(password.into()),
            users_file: None,
        }),
        ..ZenohSettings::default()
    }
}

#[test]
fn expired_certificates_and_wrong_passwords_are_refused() {
    // The only test of this binary: the process-wide subscriber is its own.
    tracing_subscriber::registry()
        .with(RefusalLayer.with_filter(refusal_events()))
        .init();
    let now = Validity::days_from_now(30);
    let ca = CertAuthority::new("test CA", now).unwrap();
    let server = ca
        .issue("ddg51-pipeline", &["127.0.0.1".to_string()], now)
        .unwrap();
    let crane = ca.issue("crane", &[], now).unwrap();
    let expired = ca
        .issue(
            "old",
            &[],
            Validity {
                not_before: OffsetDateTime::now_utc() - Duration::days(10),
                not_after: OffsetDateTime::now_utc() - Duration::days(1),
            },
        )
        .unwrap();

    let dir = tempfile::tempdir().unwrap();
    let users = dir.path().join("users.txt");
    std::fs::write(&users, "crane:right-password\nold:right-password\n").unwrap();
    let endpoint = zn::free_loopback_endpoint()
        .unwrap()
        .replacen("tcp/", "tls/", 1);
    let _listener = zn::open(&ZenohSettings {
        listen: vec![endpoint.clone()],
        tls: Some(tls(&ca, &server)),
        auth: Some(UserPassword {
            users_file: Some(users.to_string_lossy().into_owned()),
            ..UserPassword::default()
        }),
        ..ZenohSettings::default()
    })
    .expect("listener opens");

    let good = zn::open(&client(
        &endpoint,
        tls(&ca, &crane),
        Some(("crane", "right-password")),
    ));
    assert!(
        good.is_ok(),
        "a valid station was refused: {:?}",
        good.err()
    );
    for (what, reason, settings) in [
        (
            "a wrong password",
            "wrong password",
            client(&endpoint, tls(&ca, &crane), Some(("crane", "wrong"))),
        ),
        (
            "no password",
            "no user/password",
            client(&endpoint, tls(&ca, &crane), None),
        ),
        (
            "an expired certificate",
            "certificate expired",
            client(
                &endpoint,
                tls(&ca, &expired),
                Some(("old", "right-password")),
            ),
        ),
    ] {
        let result = zn::open(&settings);
        assert!(result.is_err(), "{what} was let in");
        let message = result.err().map(|e| e.to_string()).unwrap_or_default();
        assert!(
            message.starts_with("zenoh: open client session"),
            "{message}"
        );
        assert_eq!(message.lines().count(), 1, "{message}");
        // The listener's side of the refusal may be logged just after the client gave up.
        let deadline = std::time::Instant::now() + std::time::Duration::from_secs(30);
        while !refusals().iter().any(|(r, n)| *r == reason && *n >= 1) {
            assert!(
                std::time::Instant::now() < deadline,
                "{what} was not counted as '{reason}': {:?}",
                refusals()
            );
            std::thread::sleep(std::time::Duration::from_millis(20));
        }
    }
    // Exactly these three refusals, one each (the valid station was not counted).
    let mut counted = refusals();
    counted.sort_unstable();
    assert_eq!(
        counted,
        [
            ("certificate expired", 1),
            ("no user/password", 1),
            ("wrong password", 1)
        ]
    );
}
