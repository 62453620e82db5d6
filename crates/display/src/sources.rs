//! Which publisher is alive on each key the display reads, from the liveliness tokens that
//! shipcast's publishers hold (`publisher_token(key, zid)` = `<key>/publisher/<zid>`).
//!
//! The deck, the crane and `run`'s view accept a forecast only from the one live publisher of
//! its key; the display does the same for every vessel under its wildcard, so a peer that
//! merely puts on a vessel's key (no token, or a token beside the real one) reaches the page
//! only as a rejection count. Like the consumers' check, this stops accidents and naive
//! injection; on an open network a determined sender can imitate a publisher, and the router's
//! access control stops the rest (docs/security.md).

use shipcast_pipeline::transport::forecast_check::{is_publisher_id, LivePublishers, Rejection};
use std::collections::HashMap;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;

/// The most keys whose publishers are followed: every key the board can show (64 vessels,
/// each a forecast, a verification report and 16 stations), so tokens on made-up keys cannot
/// grow the map without bound.
pub const MAX_KEYS: usize = crate::board::MAX_VESSELS * (2 + crate::board::MAX_STATIONS);

/// The most publishers followed on one key: one is the rule (a second makes the key's
/// messages refused as from "several publishers"), a few cover a restart's overlap.
pub const MAX_IDS_PER_KEY: usize = 8;

/// The live publishers of every followed key.
///
/// zenoh announces a token once: one refused for lack of room would never be followed, and
/// its publisher's messages refused for good. So a refusal is flagged ([`Self::take_overflowed`])
/// and the feed asks zenoh for every live token again once in a while until all fit.
#[derive(Debug, Default)]
pub struct LiveSources {
    keys: Mutex<HashMap<String, LivePublishers>>,
    overflowed: AtomicBool,
}

/// A token key split into the key it covers and the publisher's id.
pub fn parse_token(token: &str) -> Option<(&str, &str)> {
    let (key, zid) = token.rsplit_once("/publisher/")?;
    (!key.is_empty() && is_publisher_id(zid)).then_some((key, zid))
}

impl LiveSources {
    /// Publisher `zid` of `key` appeared. False (and flagged) if it is not followed because
    /// the map or the key's publishers are full.
    pub fn appeared(&self, key: &str, zid: &str) -> bool {
        let mut keys = self.keys.lock().unwrap_or_else(|p| p.into_inner());
        if let Some(live) = keys.get_mut(key) {
            if live.contains(zid) || live.len() < MAX_IDS_PER_KEY {
                live.appeared(zid);
                return true;
            }
            self.overflowed.store(true, Ordering::Relaxed);
            return false;
        }
        if keys.len() >= MAX_KEYS {
            self.overflowed.store(true, Ordering::Relaxed);
            return false;
        }
        let mut live = LivePublishers::default();
        live.appeared(zid);
        keys.insert(key.to_string(), live);
        true
    }

    /// Publisher `zid` of `key` vanished; a key left with no publisher is forgotten.
    pub fn vanished(&self, key: &str, zid: &str) {
        let mut keys = self.keys.lock().unwrap_or_else(|p| p.into_inner());
        if let Some(live) = keys.get_mut(key) {
            live.vanished(zid);
            if live.is_empty() {
                keys.remove(key);
            }
        }
    }

    /// How many keys are followed.
    pub fn len(&self) -> usize {
        self.keys.lock().unwrap_or_else(|p| p.into_inner()).len()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Whether a token was refused for lack of room since the last call (and so must be asked
    /// for again).
    pub fn take_overflowed(&self) -> bool {
        self.overflowed.swap(false, Ordering::Relaxed)
    }

    /// Ok if `publisher` (the id a message on `key` carried) is the key's one live publisher.
    pub fn admits(&self, key: &str, publisher: Option<&str>) -> Result<(), Rejection> {
        let keys = self.keys.lock().unwrap_or_else(|p| p.into_inner());
        match keys.get(key) {
            Some(live) => live.admits(publisher),
            None => LivePublishers::default().admits(publisher),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_token_names_its_key_and_publisher() {
        assert_eq!(
            parse_token("t1/shipcast/a/advisory/deck/publisher/abc"),
            Some(("t1/shipcast/a/advisory/deck", "abc"))
        );
        for bad in [
            "shipcast/a/forecast",
            "shipcast/a/forecast/publisher/",
            "/publisher/abc",
            "shipcast/a/forecast/publisher/abc/def",
            // Not a zenoh id (review: any text was followed as one).
            "shipcast/a/forecast/publisher/abcg",
            "shipcast/a/forecast/publisher/ABC",
            "shipcast/a/forecast/publisher/0123456789abcdef0123456789abcdef0",
            "shipcast/a/forecast/publisher/ab\nINFO forged",
        ] {
            assert_eq!(parse_token(bad), None, "{bad}");
        }
    }

    #[test]
    fn only_the_one_live_publisher_of_a_key_is_admitted() {
        let s = LiveSources::default();
        let key = "shipcast/a/forecast";
        assert_eq!(
            s.admits(key, Some("p1")),
            Err(Rejection::NotLivePublisher {
                got: "p1".into(),
                live: "none".into()
            })
        );
        assert!(s.appeared(key, "p1"));
        assert_eq!(s.admits(key, Some("p1")), Ok(()));
        assert_eq!(s.admits(key, None), Err(Rejection::NoPublisherId));
        assert!(s.admits("shipcast/b/forecast", Some("p1")).is_err());
        // A second token beside the real one: neither can be told apart, both are refused.
        assert!(s.appeared(key, "intruder"));
        assert_eq!(
            s.admits(key, Some("p1")),
            Err(Rejection::SeveralPublishers(2))
        );
        s.vanished(key, "intruder");
        assert_eq!(s.admits(key, Some("p1")), Ok(()));
        s.vanished(key, "p1");
        assert!(s.admits(key, Some("p1")).is_err());
    }

    #[test]
    fn tokens_on_made_up_keys_stop_at_the_bound_and_free_it_when_they_go() {
        let s = LiveSources::default();
        for i in 0..MAX_KEYS {
            assert!(s.appeared(&format!("shipcast/v{i}/forecast"), "z"));
        }
        assert!(!s.take_overflowed());
        assert!(!s.appeared("shipcast/late/forecast", "z"));
        assert!(s.admits("shipcast/late/forecast", Some("z")).is_err());
        assert!(s.take_overflowed());
        assert!(!s.take_overflowed(), "taken once");
        // A known key still follows its publishers on a full map.
        assert!(s.appeared("shipcast/v0/forecast", "y"));
        s.vanished("shipcast/v1/forecast", "z");
        assert!(s.appeared("shipcast/late/forecast", "z"));
        assert_eq!(s.admits("shipcast/late/forecast", Some("z")), Ok(()));
    }

    #[test]
    fn one_key_follows_a_bounded_number_of_publishers() {
        let s = LiveSources::default();
        let key = "shipcast/a/forecast";
        for i in 0..MAX_IDS_PER_KEY {
            assert!(s.appeared(key, &format!("z{i}")));
        }
        assert!(!s.appeared(key, "one-too-many"));
        assert!(s.take_overflowed());
        // Those already followed may appear again.
        assert!(s.appeared(key, "z0"));
        assert!(!s.take_overflowed());
    }
}
