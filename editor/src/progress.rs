//! Progress bars for long generations (hidden when stderr is not a terminal or when asked).

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// A progress counter that only touches the bar every so often.
#[derive(Debug)]
pub struct Progress {
    bar: ProgressBar,
    pending: u64,
    step: u64,
}

impl Progress {
    /// A bar counting to `total` (e.g. cells), labelled `label`; `show = false` hides it.
    pub fn new(total: u64, label: &str, show: bool) -> Self {
        let bar = if show {
            ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr())
        } else {
            ProgressBar::hidden()
        };
        bar.set_style(
            ProgressStyle::with_template("{msg} [{elapsed_precise}] {wide_bar} {percent}% (eta {eta})")
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        bar.set_message(label.to_string());
        Self {
            bar,
            pending: 0,
            step: (total / 1000).max(1),
        }
    }
    /// A bar that shows nothing.
    pub fn hidden() -> Self {
        Self::new(1, "", false)
    }
    /// Count `n` more units done.
    #[inline]
    pub fn inc(&mut self, n: u64) {
        self.pending += n;
        if self.pending >= self.step {
            self.bar.inc(self.pending);
            self.pending = 0;
        }
    }
    /// Finish and clear the bar.
    pub fn finish(&mut self) {
        self.bar.inc(self.pending);
        self.pending = 0;
        self.bar.finish_and_clear();
    }
}
