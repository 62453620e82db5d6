//! Placeholder: motion CSV reader/writer (issue 2).
