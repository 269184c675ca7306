//! Progress bars for long jobs: drawn on stderr only when it is a terminal and only once the
//! job has run for a second, so short runs and pipes stay clean.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;
use std::time::{Duration, Instant};

/// A progress bar that appears after [`Progress::DELAY`] on a terminal, never elsewhere.
pub struct Progress {
    bar: ProgressBar,
    start: Instant,
    shown: bool,
    terminal: bool,
}

impl Progress {
    /// How long a job runs before its bar appears.
    pub const DELAY: Duration = Duration::from_secs(1);

    /// A bar for `len` units of work called `what`.
    pub fn new(len: u64, what: &str) -> Self {
        Self::hidden(
            Some(len),
            what,
            ProgressStyle::with_template("{msg:>10} [{bar:40}] {pos}/{len} ({eta} left)")
                .expect("a valid template")
                .progress_chars("=> "),
        )
    }

    /// A counter of work whose total is not known (simulated cycles): the count and the
    /// rate, shown as [`Progress::new`]'s bar is.
    pub fn counter(what: &str) -> Self {
        Self::hidden(
            None,
            what,
            ProgressStyle::with_template("{msg:>10} {human_pos} ({per_sec}) {elapsed}")
                .expect("a valid template"),
        )
    }

    /// A bar drawn nowhere until [`Progress::inc`] finds the job long enough.
    fn hidden(len: Option<u64>, what: &str, style: ProgressStyle) -> Self {
        let bar = ProgressBar::with_draw_target(len, ProgressDrawTarget::hidden());
        bar.set_style(style);
        bar.set_message(what.to_string());
        Progress {
            bar,
            start: Instant::now(),
            shown: false,
            terminal: std::io::stderr().is_terminal() && std::env::var_os("CI").is_none(),
        }
    }

    /// Sets the work done to `n`.
    pub fn set(&mut self, n: u64) {
        let d = n.saturating_sub(self.bar.position());
        self.inc(d);
    }

    /// Adds `n` units of work done.
    pub fn inc(&mut self, n: u64) {
        self.bar.inc(n);
        if !self.shown && self.terminal && self.start.elapsed() >= Self::DELAY {
            self.bar.set_draw_target(ProgressDrawTarget::stderr());
            self.shown = true;
        }
    }

    /// Removes the bar.
    pub fn finish(self) {
        self.bar.finish_and_clear();
    }
}
