//! The progress bar that long subcommands draw on stderr (hidden when stderr is not a terminal,
//! so logs and CI output stay clean).

use indicatif::{ProgressBar, ProgressStyle};
use shipcast_eval::progress::Progress;
use std::io::IsTerminal;

/// A bar with elapsed time, position and the job just finished.
pub struct Bar(ProgressBar);

/// A bar of `len` steps drawn on stderr with `template`, or a hidden one when stderr is not a
/// terminal (logs and CI output stay clean).
pub fn styled(len: u64, template: &str) -> ProgressBar {
    if !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(len);
    // The templates are constants; should one ever fail to parse, the default style remains.
    if let Ok(style) = ProgressStyle::with_template(template) {
        bar.set_style(style.progress_chars("=> "));
    }
    bar
}

impl Bar {
    pub fn new() -> Self {
        Self(styled(
            0,
            "{elapsed_precise} [{bar:30}] {pos}/{len} {wide_msg}",
        ))
    }

    pub fn finish(&self) {
        self.0.finish_and_clear();
    }
}

impl Progress for Bar {
    fn start(&self, jobs: u64) {
        self.0.set_length(jobs);
    }
    fn advance(&self, what: &str) {
        self.0.set_message(what.to_string());
        self.0.inc(1);
    }
}
