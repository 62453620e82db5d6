//! One clear shipcast log line when zenoh refuses a client. zenoh reports a refused TLS
//! handshake as a warning of `zenoh_link_tls::unicast` with a misleading hint ("increase the
//! system open file limit"), and a failed user/password check only as a debug event of
//! `zenoh_transport::unicast::establishment::accept`. A tracing layer recognises those events
//! (texts from zenoh 1.10's and rustls 0.23's sources), counts them, and emits at most one
//! `refused zenoh client: REASON` line per second, saying how many were not printed.
//!
//! Neither event names the client's address, so the line cannot either. Access-control
//! denials are not reported here: zenoh decides every action of a key expression when it first
//! sees it (a station that only subscribes is "unauthorized to Put" in zenoh's trace), so its
//! events cannot tell an attempted put from a legitimate subscription.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};
use tracing::field::{Field, Visit};
use tracing::{Event, Level, Subscriber};
use tracing_subscriber::filter::Targets;
use tracing_subscriber::layer::{Context, Layer};

/// zenoh's TLS listener (handshake failures, as warnings).
const TLS_TARGET: &str = "zenoh_link_tls::unicast";
/// zenoh's transport establishment on the accepting side (authentication failures, as debug).
const ACCEPT_TARGET: &str = "zenoh_transport::unicast::establishment::accept";
/// The suffix zenoh appends to every accept error of its TLS listener.
const TLS_HINT: &str = ". Hint: increase the system open file limit.";

/// Shortest time between two printed lines of one reason.
const PRINT_EVERY: Duration = Duration::from_secs(1);

/// Why zenoh refused a client: one of a few fixed reasons, and zenoh's own words where the
/// reason is not one of the known ones.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Refusal {
    pub reason: &'static str,
    pub detail: Option<String>,
}

/// Per reason: refusals counted, when its last line was printed, refusals not printed since.
struct Tally {
    reason: &'static str,
    count: u64,
    printed_at: Instant,
    unprinted: u64,
}

/// Every reason seen so far (a handful at most: reasons are fixed strings).
static TALLIES: Mutex<Vec<Tally>> = Mutex::new(Vec::new());
static REFUSED: AtomicU64 = AtomicU64::new(0);

/// Clients refused since the process started (all reasons).
pub fn refused_total() -> u64 {
    REFUSED.load(Ordering::Relaxed)
}

/// Clients refused since the process started, per reason.
pub fn refusals() -> Vec<(&'static str, u64)> {
    TALLIES
        .lock()
        .map(|t| t.iter().map(|t| (t.reason, t.count)).collect())
        .unwrap_or_default()
}

fn known(reason: &'static str) -> Option<Refusal> {
    Some(Refusal {
        reason,
        detail: None,
    })
}

/// Why zenoh refused a client, from one of its log events; `None` if the event is not a
/// refusal.
pub fn classify(target: &str, message: &str) -> Option<Refusal> {
    if target == TLS_TARGET {
        let detail = message.strip_suffix(TLS_HINT)?;
        // A listener error (e.g. out of file descriptors) carries the same hint.
        if detail.contains("os error") {
            return None;
        }
        // A CA of the same name (every `shipcast certs` run names its CA after the vessel)
        // gives BadSignature rather than UnknownIssuer.
        return if detail.contains("UnknownIssuer") || detail.contains("BadSignature") {
            known("certificate not signed by our CA")
        } else if detail.ends_with("received fatal alert: CertificateExpired") {
            // The client sent the alert: it is *our* certificate that expired.
            Some(Refusal {
                reason: "the client rejected our certificate: it has expired (renew it with shipcast certs)",
                detail: Some("fatal alert CertificateExpired".into()),
            })
        } else if detail.contains("certificate expired") || detail.ends_with("Expired") {
            known("certificate expired")
        } else if detail.contains("not valid yet") || detail.ends_with("NotValidYet") {
            known("certificate not valid yet")
        } else if detail.contains("peer sent no certificates") {
            known("no client certificate")
        } else if let Some(alert) = ["UnknownCA", "BadCertificate", "DecryptError"]
            .into_iter()
            .find(|a| detail.ends_with(&format!("received fatal alert: {a}")))
        {
            // The client ended the handshake on our certificate: a client that trusts another
            // CA sends DecryptError (seen with zenoh 1.10 and rustls 0.23), others UnknownCA.
            Some(Refusal {
                reason: "the client rejected our certificate (does it trust another CA, or connect by a name the certificate does not carry?)",
                detail: Some(format!("fatal alert {alert}")),
            })
        } else if detail.contains("received corrupt message") {
            known("not a TLS handshake (plain TCP on the TLS port?)")
        } else if detail.contains("Timeout during TLS handshake") {
            known("TLS handshake timed out")
        } else {
            Some(Refusal {
                reason: "TLS handshake failed",
                detail: Some(detail.to_string()),
            })
        };
    }
    if target == ACCEPT_TARGET && message.contains("UsrPwd extension") {
        return if message.contains("Invalid password") {
            known("wrong password")
        } else if message.contains("Invalid user") {
            known("unknown user")
        } else if message.contains("Expected extension") {
            known("no user/password")
        } else {
            known("user/password authentication failed")
        };
    }
    None
}

/// The events [`RefusalLayer`] needs to see, whatever the level of the printed log.
pub fn refusal_events() -> Targets {
    Targets::new()
        .with_target(TLS_TARGET, Level::WARN)
        .with_target(ACCEPT_TARGET, Level::DEBUG)
}

/// Recognises zenoh's refusal events (give it [`refusal_events`] as its filter), counts them
/// and logs one shipcast line for them, at most one per reason and second.
#[derive(Default)]
pub struct RefusalLayer;

struct Message(String);

impl Visit for Message {
    fn record_debug(&mut self, field: &Field, value: &dyn std::fmt::Debug) {
        if field.name() == "message" {
            self.0 = format!("{value:?}");
        }
    }

    fn record_str(&mut self, field: &Field, value: &str) {
        if field.name() == "message" {
            self.0 = value.to_string();
        }
    }
}

/// Count one refusal; returns how many of its reason went unprinted before it if its line is
/// due now.
fn count(reason: &'static str) -> Option<u64> {
    count_at(reason, Instant::now())
}

/// [`count`] at `now` (tests drive the clock).
fn count_at(reason: &'static str, now: Instant) -> Option<u64> {
    REFUSED.fetch_add(1, Ordering::Relaxed);
    let mut tallies = TALLIES.lock().ok()?;
    let Some(t) = tallies.iter_mut().find(|t| t.reason == reason) else {
        tallies.push(Tally {
            reason,
            count: 1,
            printed_at: now,
            unprinted: 0,
        });
        return Some(0);
    };
    t.count += 1;
    if now.saturating_duration_since(t.printed_at) < PRINT_EVERY {
        t.unprinted += 1;
        return None;
    }
    t.printed_at = now;
    Some(std::mem::take(&mut t.unprinted))
}

impl<S: Subscriber> Layer<S> for RefusalLayer {
    fn on_event(&self, event: &Event<'_>, _ctx: Context<'_, S>) {
        let mut message = Message(String::new());
        event.record(&mut message);
        let Some(refusal) = classify(event.metadata().target(), &message.0) else {
            return;
        };
        let Some(unprinted) = count(refusal.reason) else {
            return;
        };
        let reason = match &refusal.detail {
            Some(d) => format!("{}: {d}", refusal.reason),
            None => refusal.reason.to_string(),
        };
        let total = refused_total();
        if unprinted > 0 {
            tracing::warn!(
                refused = total,
                "refused zenoh client: {reason} ({unprinted} more for this reason since its last line)"
            );
        } else {
            tracing::warn!(refused = total, "refused zenoh client: {reason}");
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zenoh_refusal_events_are_named() {
        let tls = |detail: &str| {
            classify(TLS_TARGET, &format!("{detail}{TLS_HINT}")).map(|r| match r.detail {
                Some(d) => format!("{}: {d}", r.reason),
                None => r.reason.to_string(),
            })
        };
        assert_eq!(
            tls("invalid peer certificate: UnknownIssuer").as_deref(),
            Some("certificate not signed by our CA")
        );
        assert_eq!(
            tls("invalid peer certificate: BadSignature").as_deref(),
            Some("certificate not signed by our CA")
        );
        assert_eq!(
            tls("invalid peer certificate: certificate expired: verification time 1 (UNIX), but certificate is not valid after 0 (1 seconds ago)").as_deref(),
            Some("certificate expired")
        );
        // Regression: the alert a client sends when *our* certificate has expired was logged
        // as the client's certificate having expired.
        assert_eq!(
            tls("received fatal alert: CertificateExpired").as_deref(),
            Some("the client rejected our certificate: it has expired (renew it with shipcast certs): fatal alert CertificateExpired")
        );
        assert_eq!(
            tls("peer sent no certificates").as_deref(),
            Some("no client certificate")
        );
        assert_eq!(
            tls("received corrupt message of type InvalidContentType").as_deref(),
            Some("not a TLS handshake (plain TCP on the TLS port?)")
        );
        assert_eq!(
            tls("received fatal alert: DecryptError").as_deref(),
            Some("the client rejected our certificate (does it trust another CA, or connect by a name the certificate does not carry?): fatal alert DecryptError")
        );
        assert_eq!(
            tls("peer is incompatible: Tls12NotOffered").as_deref(),
            Some("TLS handshake failed: peer is incompatible: Tls12NotOffered")
        );
        // The same hint on a listener error is not a refused client.
        assert_eq!(tls("Too many open files (os error 24)"), None);
        assert_eq!(
            classify(TLS_TARGET, "Skipping name verification of TLS server"),
            None
        );
        let accept = |m: &str| classify(ACCEPT_TARGET, m).map(|r| r.reason);
        assert_eq!(
            accept("UsrPwd extension - Recv OpenSyn. Invalid password. at src/x.rs:424."),
            Some("wrong password")
        );
        assert_eq!(
            accept("UsrPwd extension - Recv OpenSyn. Invalid user. at src/x.rs:418."),
            Some("unknown user")
        );
        assert_eq!(
            accept("UsrPwd extension - Recv InitSyn. Expected extension. at src/x.rs:380."),
            Some("no user/password")
        );
        assert_eq!(accept("Received a close message (reason MAX_LINKS)"), None);
        assert_eq!(
            classify("shipcast", "invalid peer certificate: UnknownIssuer"),
            None
        );
    }

    #[test]
    fn lines_are_rate_limited_per_reason_and_every_refusal_is_counted() {
        // A reason of its own, so that other tests in this process do not share its tally.
        // The clock is driven: no real second passes (test-quality review).
        let reason = "test reason";
        let start = Instant::now();
        assert_eq!(count_at(reason, start), Some(0));
        for i in 0..5 {
            let t = start + PRINT_EVERY * i / 5;
            assert_eq!(count_at(reason, t), None);
        }
        assert_eq!(
            count_at("test reason 2", start),
            Some(0),
            "another reason has its own limit"
        );
        let tally = |r| refusals().into_iter().find(|t| t.0 == r).map(|t| t.1);
        assert_eq!(tally(reason), Some(6));
        assert_eq!(
            count_at(reason, start + PRINT_EVERY),
            Some(5),
            "the next line says how many were not printed"
        );
        assert_eq!(tally(reason), Some(7));
    }
}
