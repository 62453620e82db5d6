//! Placeholder: wire payloads (issue 5).
