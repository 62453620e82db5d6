//! Errors as the one line a user reads: the chain of causes joined by ": " (anyhow's `{:#}`),
//! without the source locations zenoh writes into its errors, on one line.

/// `text` without the source locations zenoh writes into its errors (` at
/// /root/.cargo/registry/.../tcp.rs:61.`): they filled the 300 characters of the reason
/// `run` repeats and cut it off mid-path, and made every zenoh error a screen wide.
pub fn without_source_locations(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(i) = rest.find(" at /") {
        out.push_str(&rest[..i]);
        let after = &rest[i + 4..];
        // A location is a path without spaces ending `.rs:LINE`, then an optional '.': what
        // follows it (`]`, `",` inside a debug-printed error) stays.
        let token = &after[..after.find(char::is_whitespace).unwrap_or(after.len())];
        let line_end = token.find(".rs:").and_then(|rs| {
            let digits = token[rs + 4..]
                .find(|c: char| !c.is_ascii_digit())
                .unwrap_or(token.len() - rs - 4);
            (digits > 0).then_some(rs + 4 + digits)
        });
        match line_end {
            Some(end) => rest = after[end..].strip_prefix('.').unwrap_or(&after[end..]),
            None => {
                out.push_str(" at ");
                rest = after;
            }
        }
    }
    out.push_str(rest);
    out
}

/// The line `main` prints after `error: `: no source locations, and a message that spans lines
/// (a zenoh configuration error, a TOML parser's excerpt) joined into one.
pub fn one_line(text: &str) -> String {
    without_source_locations(text)
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zenohs_source_locations_are_left_out_of_a_repeated_reason() {
        let line = "zenoh: open peer session: Can not create a new TCP listener bound to tcp/127.0.0.1:7447: Address already in use (os error 98) at /root/.cargo/registry/src/index.crates.io-1949cf8c6b5b557f/zenoh-link-tcp-1.10.2/src/unicast.rs:61.] at /root/.cargo/registry/src/x/zenoh-1.10.2/src/net/runtime/orchestrator.rs:201.";
        assert_eq!(
            without_source_locations(line),
            "zenoh: open peer session: Can not create a new TCP listener bound to tcp/127.0.0.1:7447: Address already in use (os error 98)]"
        );
        // A path that is not a source location stays.
        let kept = "tls certificate file /etc/ship/a.pem: expired at /etc time";
        assert_eq!(without_source_locations(kept), kept);
        // Inside a debug-printed error (the examples' zenoh configuration errors).
        let debug = "Json5Err(Message { msg: \"Endpoints must be ...: garbage at /root/.cargo/registry/src/x/zenoh-protocol-1.10.2/src/core/endpoint.rs:615.\", location: None })";
        assert_eq!(
            without_source_locations(debug),
            "Json5Err(Message { msg: \"Endpoints must be ...: garbage\", location: None })"
        );
    }

    #[test]
    fn an_error_spanning_lines_is_printed_on_one() {
        let text = "config F: TOML parse error at line 3, column 1\n  |\n3 | x =\n  |    ^\nstring values must be quoted at /root/.cargo/registry/src/x/toml-0.8/src/de.rs:12.";
        assert_eq!(
            one_line(text),
            "config F: TOML parse error at line 3, column 1 | 3 | x = | ^ string values must be quoted"
        );
    }
}
