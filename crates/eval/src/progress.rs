//! How long library jobs report progress: the CLI shows a bar, tests and other callers pass
//! [`NoProgress`]. The library never draws anything itself.

/// Where a long job reports progress.
pub trait Progress: Sync {
    /// The number of jobs about to run.
    fn start(&self, jobs: u64);
    /// One job finished.
    fn advance(&self, what: &str);
}

/// Progress that goes nowhere.
pub struct NoProgress;

impl Progress for NoProgress {
    fn start(&self, _jobs: u64) {}
    fn advance(&self, _what: &str) {}
}
