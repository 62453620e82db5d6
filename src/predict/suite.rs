//! Placeholder: shared test suite every predictor passes (issue 2).
