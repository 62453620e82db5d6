//! zenoh's own security, configured from shipcast settings: TLS with mutual authentication
//! (`transport_tls`), user/password authentication (`auth_usrpwd`) and access control (zenoh's
//! ACL, default deny). This module only translates settings into zenoh configuration entries;
//! zenoh does the enforcing (docs/security.md explains the model).

use serde::{Deserialize, Serialize};

/// A certificate or key: a file path, or the PEM text itself (anything starting with
/// `-----BEGIN`).
pub fn is_inline_pem(value: &str) -> bool {
    value.trim_start().starts_with("-----BEGIN")
}

/// TLS identity of a node. Every node of a deployment trusts one CA and presents its own
/// certificate, so both ends of every link are authenticated (mutual TLS).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TlsSettings {
    /// The CA that signed every certificate of the deployment (path or inline PEM).
    pub root_ca: String,
    /// This node's certificate (path or inline PEM); its common name is the node's identity
    /// in the access rules.
    pub certificate: String,
    /// This node's private key (path or inline PEM).
    pub private_key: String,
}

/// zenoh's user/password authentication. A node that listens checks connecting nodes against
/// `users_file` (`user:password` per line); a node that connects presents `user`/`password`.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct UserPassword {
    pub user: Option<String>,
    pub password: Option<String>,
    /// Path of the `user:password` file the listening side accepts.
    pub users_file: Option<String>,
}

/// Access rules held by the node consumers connect to (the predictor, or the router of a
/// fleet). zenoh applies them to that node's links, so consumers must reach the data only
/// through it: they run in client mode with scouting off.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AccessRules {
    /// Key expressions covered, e.g. `shipcast/ddg51/**`. Everything else is denied.
    pub key_exprs: Vec<String>,
    /// Certificate common names that may publish (put, declare tokens and queryables) and
    /// subscribe: the vessel's pipeline.
    pub publishers: Vec<String>,
    /// Certificate common names that may only subscribe, query and watch liveliness.
    pub subscribers: Vec<String>,
    /// Wider key expressions on which subscribers and publishers may declare their interest
    /// (subscribe, query, watch liveliness), e.g. `shipcast/*/**`: a fleet router's
    /// subscriptions at a vessel, the display's (`shipcast/*/forecast`) anywhere. zenoh checks
    /// that a declaration's key lies within a rule's, and data still flows only on `key_exprs`.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub interest_key_exprs: Vec<String>,
    /// The vessels of a fleet, at its router: each pipeline identity may publish only on its
    /// own vessel's keys (and hear the interest of subscribers on `key_exprs`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub vessels: Vec<VesselAccess>,
}

/// One vessel's publisher in a fleet router's access rules.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VesselAccess {
    /// Certificate common name of the vessel's pipeline.
    pub publisher: String,
    /// The vessel's keys, e.g. `shipcast/ddg51/**`.
    pub key_exprs: Vec<String>,
}

const ALL_MESSAGES: [&str; 9] = [
    "put",
    "delete",
    "declare_subscriber",
    "query",
    "declare_queryable",
    "reply",
    "liveliness_token",
    "declare_liveliness_subscriber",
    "liveliness_query",
];

/// What a subscriber may send to the node holding the rules.
const SUBSCRIBER_INGRESS: [&str; 4] = [
    "declare_subscriber",
    "query",
    "declare_liveliness_subscriber",
    "liveliness_query",
];

/// What the node holding the rules may send to a subscriber.
const SUBSCRIBER_EGRESS: [&str; 3] = ["put", "reply", "liveliness_token"];

impl AccessRules {
    /// zenoh's `access_control` section (JSON), default deny.
    pub fn to_zenoh_json(&self) -> serde_json::Value {
        use serde_json::json;
        let rule_on = |id: &str, messages: &[&str], flows: &[&str], keys: &[String]| {
            json!({
                "id": id,
                "messages": messages,
                "flows": flows,
                "permission": "allow",
                "key_exprs": keys,
            })
        };
        let rule = |id: &str, messages: &[&str], flows: &[&str]| {
            rule_on(id, messages, flows, &self.key_exprs)
        };
        let mut rules = Vec::new();
        let mut subjects = Vec::new();
        let mut policies = Vec::new();
        if !self.publishers.is_empty() {
            rules.push(rule("publish", &ALL_MESSAGES, &["ingress", "egress"]));
            let mut publisher_rules = vec!["publish"];
            // The display runs with the pipeline's identity and subscribes to every vessel.
            if !self.interest_key_exprs.is_empty() {
                rules.push(rule_on(
                    "publish-interest",
                    &SUBSCRIBER_INGRESS,
                    &["ingress"],
                    &self.interest_key_exprs,
                ));
                publisher_rules.push("publish-interest");
            }
            subjects.push(json!({"id": "publishers", "cert_common_names": self.publishers}));
            policies.push(
                json!({"id": "publishers", "rules": publisher_rules, "subjects": ["publishers"]}),
            );
        }
        if !self.subscribers.is_empty() {
            let interest: Vec<String> = self
                .key_exprs
                .iter()
                .chain(&self.interest_key_exprs)
                .cloned()
                .collect();
            rules.push(rule_on(
                "subscribe-in",
                &SUBSCRIBER_INGRESS,
                &["ingress"],
                &interest,
            ));
            rules.push(rule("subscribe-out", &SUBSCRIBER_EGRESS, &["egress"]));
            subjects.push(json!({"id": "subscribers", "cert_common_names": self.subscribers}));
            policies.push(json!({
                "id": "subscribers",
                "rules": ["subscribe-in", "subscribe-out"],
                "subjects": ["subscribers"],
            }));
        }
        if !self.vessels.is_empty() {
            // The router tells every vessel of the subscribers' interest in the fleet's keys,
            // so that the vessel sends its forecasts; nothing else of the fleet reaches it.
            rules.push(rule("fleet-interest", &SUBSCRIBER_INGRESS, &["egress"]));
        }
        for (i, vessel) in self.vessels.iter().enumerate() {
            let id = format!("vessel-{i}");
            rules.push(rule_on(
                &id,
                &ALL_MESSAGES,
                &["ingress", "egress"],
                &vessel.key_exprs,
            ));
            subjects.push(json!({"id": id, "cert_common_names": [vessel.publisher]}));
            policies.push(json!({"id": id, "rules": [id, "fleet-interest"], "subjects": [id]}));
        }
        json!({
            "enabled": true,
            "default_permission": "deny",
            "rules": rules,
            "subjects": subjects,
            "policies": policies,
        })
    }
}

/// Base64 of a PEM text, as zenoh's `*_base64` TLS keys expect.
fn base64_of(text: &str) -> String {
    use base64::Engine;
    base64::engine::general_purpose::STANDARD.encode(text.as_bytes())
}

/// One TLS file entry: `name` with a path, or `name_base64` with inline PEM.
fn tls_entry(name: &str, value: &str) -> (String, serde_json::Value) {
    if is_inline_pem(value) {
        (
            format!("transport/link/tls/{name}_base64"),
            base64_of(value).into(),
        )
    } else {
        (format!("transport/link/tls/{name}"), value.into())
    }
}

/// zenoh configuration entries (key path, JSON value) for TLS. `listens` adds the listening
/// side's certificate and key.
pub fn tls_entries(tls: &TlsSettings, listens: bool) -> Vec<(String, serde_json::Value)> {
    let mut out = vec![
        tls_entry("root_ca_certificate", &tls.root_ca),
        tls_entry("connect_certificate", &tls.certificate),
        tls_entry("connect_private_key", &tls.private_key),
        // Both ends present certificates: a listener requires one from every node that
        // connects, and a connecting node sends its own only when this is on.
        ("transport/link/tls/enable_mtls".into(), true.into()),
        // The certificate of the node connected to must name the host of the endpoint.
        (
            "transport/link/tls/verify_name_on_connect".into(),
            true.into(),
        ),
        // A link whose certificate expires is closed, not kept on the old handshake.
        (
            "transport/link/tls/close_link_on_expiration".into(),
            true.into(),
        ),
    ];
    if listens {
        out.push(tls_entry("listen_certificate", &tls.certificate));
        out.push(tls_entry("listen_private_key", &tls.private_key));
    }
    out
}

/// zenoh configuration entries for user/password authentication.
pub fn usrpwd_entries(auth: &UserPassword) -> Vec<(String, serde_json::Value)> {
    let mut out = Vec::new();
    for (key, value) in [
        ("user", &auth.user),
        ("password", &auth.password),
        ("dictionary_file", &auth.users_file),
    ] {
        if let Some(v) = value {
            out.push((format!("transport/auth/usrpwd/{key}"), v.clone().into()));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inline_pem_goes_base64_and_paths_stay_paths() {
        let tls = TlsSettings {
            root_ca: "/etc/ca.pem".into(),
            certificate: "-----BEGIN CERTIFICATE-----\nAAAA\n-----END CERTIFICATE-----\n".into(),
            private_key: "key.pem".into(),
        };
        let entries = tls_entries(&tls, false);
        let get = |k: &str| entries.iter().find(|(key, _)| key == k).map(|(_, v)| v);
        assert_eq!(
            get("transport/link/tls/root_ca_certificate"),
            Some(&"/etc/ca.pem".into())
        );
        let b64 = get("transport/link/tls/connect_certificate_base64")
            .and_then(|v| v.as_str())
            .unwrap();
        use base64::Engine;
        let decoded = base64::engine::general_purpose::STANDARD
            .decode(b64)
            .unwrap();
        assert_eq!(decoded, tls.certificate.as_bytes());
        assert_eq!(get("transport/link/tls/enable_mtls"), Some(&true.into()));
        assert!(get("transport/link/tls/listen_certificate").is_none());
        assert!(tls_entries(&tls, true)
            .iter()
            .any(|(k, _)| k == "transport/link/tls/listen_private_key"));
    }

    #[test]
    fn access_rules_are_accepted_by_zenoh_and_deny_by_default() {
        let rules = AccessRules {
            key_exprs: vec!["shipcast/ddg51/**".into()],
            publishers: vec!["ddg51-predictor".into()],
            subscribers: vec!["crane".into(), "shore".into()],
            ..AccessRules::default()
        };
        let json = rules.to_zenoh_json();
        assert_eq!(json["default_permission"], "deny");
        let mut config = zenoh::Config::default();
        config
            .insert_json5("access_control", &json.to_string())
            .unwrap();
        // Subscribers get no rule that lets them put.
        let subscriber_rules: Vec<&serde_json::Value> = json["rules"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|r| r["id"].as_str().unwrap().starts_with("subscribe"))
            .collect();
        assert_eq!(subscriber_rules.len(), 2);
        for r in subscriber_rules {
            let puts_in = r["flows"] == serde_json::json!(["ingress"])
                && r["messages"].as_array().unwrap().iter().any(|m| m == "put");
            assert!(!puts_in, "{r}");
        }
    }

    #[test]
    fn wider_interest_admits_declarations_of_publishers_and_subscribers_never_puts() {
        let rules = AccessRules {
            key_exprs: vec!["i/shipcast/ddg51/**".into()],
            publishers: vec!["ddg51-pipeline".into()],
            subscribers: vec!["crane".into()],
            interest_key_exprs: vec!["i/shipcast/*/**".into()],
            ..AccessRules::default()
        };
        let json = rules.to_zenoh_json();
        let mut config = zenoh::Config::default();
        config
            .insert_json5("access_control", &json.to_string())
            .expect("zenoh accepts the rules");
        let wide: Vec<&serde_json::Value> = json["rules"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|r| {
                r["key_exprs"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .any(|k| k == "i/shipcast/*/**")
            })
            .collect();
        // One rule for each kind of subject, and on the wide keys nothing but declarations.
        assert_eq!(wide.len(), 2, "{json}");
        for r in wide {
            assert_eq!(r["flows"], serde_json::json!(["ingress"]), "{r}");
            let messages = r["messages"].as_array().unwrap();
            assert!(
                messages
                    .iter()
                    .all(|m| SUBSCRIBER_INGRESS.contains(&m.as_str().unwrap())),
                "{r}"
            );
        }
        let publishers = json["policies"]
            .as_array()
            .unwrap()
            .iter()
            .find(|p| p["id"] == "publishers")
            .unwrap();
        assert_eq!(
            publishers["rules"],
            serde_json::json!(["publish", "publish-interest"])
        );
    }

    #[test]
    fn a_fleet_router_limits_each_vessel_to_its_own_keys() {
        let rules = AccessRules {
            key_exprs: vec!["shipcast/*/**".into()],
            subscribers: vec!["shore".into()],
            vessels: ["a", "b"]
                .iter()
                .map(|v| VesselAccess {
                    publisher: format!("{v}-pipeline"),
                    key_exprs: vec![format!("shipcast/{v}/**")],
                })
                .collect(),
            ..AccessRules::default()
        };
        let json = rules.to_zenoh_json();
        let mut config = zenoh::Config::default();
        config
            .insert_json5("access_control", &json.to_string())
            .expect("zenoh accepts the rules");
        let rule = |id: &str| {
            json["rules"]
                .as_array()
                .unwrap()
                .iter()
                .find(|r| r["id"] == id)
                .unwrap_or_else(|| panic!("no rule {id} in {json}"))
                .clone()
        };
        // Each vessel may put only on its own keys; the fleet-wide rule it shares carries
        // only declarations of interest, towards it.
        assert_eq!(
            rule("vessel-1")["key_exprs"],
            serde_json::json!(["shipcast/b/**"])
        );
        let fleet = rule("fleet-interest");
        assert_eq!(fleet["flows"], serde_json::json!(["egress"]));
        assert!(!fleet["messages"]
            .as_array()
            .unwrap()
            .iter()
            .any(|m| m == "put"));
        let policy_of_b = json["policies"]
            .as_array()
            .unwrap()
            .iter()
            .find(|p| p["id"] == "vessel-1")
            .unwrap();
        assert_eq!(
            policy_of_b["rules"],
            serde_json::json!(["vessel-1", "fleet-interest"])
        );
        // No "publishers": nobody may put on the fleet-wide keys.
        assert!(json["rules"]
            .as_array()
            .unwrap()
            .iter()
            .all(|r| r["id"] != "publish"));
    }
}
