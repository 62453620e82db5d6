//! Placeholder: Levinson-Durbin solver (issue 2).
