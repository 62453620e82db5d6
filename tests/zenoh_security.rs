//! zenoh's authentication as shipcast configures it, in one process on 127.0.0.1: a listener
//! with mutual TLS and a user/password file admits a station with a valid certificate and the
//! right password, and refuses an expired certificate, a wrong password and no password,
//! each counted under its reason by shipcast's refusal layer (`zenoh_refusals`). Our own
//! client refuses to start with an expired certificate; the listener's refusal is tested with
//! a client that does not check.

use shipcast_pipeline::certs::{CertAuthority, Identity, Validity};
use shipcast_pipeline::transport::zenoh::{self as zn, Mode, ZenohSettings};
use shipcast_pipeline::transport::zenoh_refusals::{refusal_events, refusals, RefusalLayer};
use shipcast_pipeline::transport::zenoh_security::{tls_entries, TlsSettings, UserPassword};
use time::{Duration, OffsetDateTime};
use tracing_subscriber::layer::SubscriberExt;
use tracing_subscriber::util::SubscriberInitExt;
use tracing_subscriber::Layer;
use zenoh::Wait;

/// One try to open a client session; the error as its message.
type Attempt<'a> = dyn Fn() -> Result<(), String> + 'a;

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
    // Our own client refuses to start with an expired certificate, naming it, before any
    // handshake (`cert_validity`).
    let old_station = client(
        &endpoint,
        tls(&ca, &expired),
        Some(("old", "right-password")),
    );
    let message = zn::open(&old_station)
        .err()
        .map(|e| format!("{:#}", anyhow::Error::from(e)))
        .unwrap_or_default();
    assert!(
        message.starts_with("zenoh: tls certificate (inline): the certificate expired on "),
        "{message}"
    );
    // The listener refuses one that does not check (any other TLS client): the configuration
    // of a valid station with the expired certificate put in.
    let mut foreign = zn::zenoh_config(&client(
        &endpoint,
        tls(&ca, &crane),
        Some(("old", "right-password")),
    ))
    .unwrap();
    for (key, value) in tls_entries(&tls(&ca, &expired), false) {
        foreign.insert_json5(&key, &value.to_string()).unwrap();
    }
    let foreign = || {
        zenoh::open(foreign.clone())
            .wait()
            .map(drop)
            .map_err(|e| format!("zenoh: open client session: {e}"))
    };
    let refused =
        |settings: ZenohSettings| move || zn::open(&settings).map(drop).map_err(|e| e.to_string());
    let attempts: [(&str, &str, Box<Attempt<'_>>); 3] = [
        (
            "a wrong password",
            "wrong password",
            Box::new(refused(client(
                &endpoint,
                tls(&ca, &crane),
                Some(("crane", "wrong")),
            ))),
        ),
        (
            "no password",
            "no user/password",
            Box::new(refused(client(&endpoint, tls(&ca, &crane), None))),
        ),
        (
            "an expired certificate",
            "certificate expired",
            Box::new(foreign),
        ),
    ];
    for (what, reason, attempt) in attempts {
        let result = attempt();
        assert!(result.is_err(), "{what} was let in");
        let message = result.err().unwrap_or_default();
        assert!(
            message.starts_with("zenoh: open client session"),
            "{message}"
        );
        // Ours are one line (zenoh's own, of the foreign client, need not be).
        if reason != "certificate expired" {
            assert_eq!(message.lines().count(), 1, "{message}");
        }
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
