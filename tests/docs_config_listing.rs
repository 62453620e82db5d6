//! examples/README.md lists "all keys with their defaults" (README points users there). These
//! tests keep that listing true: it is exactly the default configuration, and every key the
//! defaults hold appears in it (keys without a default are shown commented out).

use shipcast_pipeline::config::PipelineConfig;
use std::path::Path;

const HEADING: &str = "All keys with their defaults:";

/// The TOML block right after the listing's heading.
fn listing() -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/README.md");
    let text = std::fs::read_to_string(&path).expect("examples/README.md");
    let after = &text[text.find(HEADING).expect("the listing's heading") + HEADING.len()..];
    let block = &after[after.find("```toml\n").expect("a toml block") + "```toml\n".len()..];
    block[..block.find("```").expect("the block's end")].to_string()
}

#[test]
fn the_listed_configuration_is_the_default_one() {
    let listed = PipelineConfig::from_toml(&listing(), Path::new("examples/README.md"))
        .unwrap_or_else(|e| panic!("the listing does not load: {e}"));
    assert_eq!(listed, PipelineConfig::default());
}

/// Keys (dotted paths) of `table` missing from `listed`.
fn missing(table: &toml::Table, listed: &toml::Table, path: &str, out: &mut Vec<String>) {
    for (key, value) in table {
        let here = format!("{path}{key}");
        match (value, listed.get(key)) {
            (_, None) => out.push(here),
            (toml::Value::Table(inner), Some(toml::Value::Table(shown))) => {
                missing(inner, shown, &format!("{here}."), out)
            }
            _ => {}
        }
    }
}

#[test]
fn every_key_with_a_default_is_listed() {
    let defaults: toml::Table =
        toml::from_str(&PipelineConfig::default().to_toml().unwrap()).unwrap();
    let listed: toml::Table = toml::from_str(&listing()).unwrap();
    let mut absent = Vec::new();
    missing(&defaults, &listed, "", &mut absent);
    assert!(
        absent.is_empty(),
        "keys missing from examples/README.md: {absent:?}"
    );
}
