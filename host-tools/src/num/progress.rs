//! The progress reporter every long job shares: a bar on stderr, hidden
//! when stderr is not a terminal (so logs and tests stay clean).

use indicatif::{ProgressBar, ProgressStyle};

/// A progress bar of `n` steps labelled `what`, on stderr.
pub fn progress(n: usize, what: &str) -> ProgressBar {
    let pb = ProgressBar::new(n as u64);
    if let Ok(style) = ProgressStyle::with_template("{msg} [{bar:30}] {pos}/{len} {elapsed}") {
        pb.set_style(style.progress_chars("=> "));
    }
    pb.set_message(what.to_string());
    pb
}
