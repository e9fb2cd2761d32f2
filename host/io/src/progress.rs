//! Progress bars on long work (`indicatif`), drawn on stderr only when it is a terminal, so
//! logs and pipes stay clean.

use std::io::IsTerminal;
use std::sync::Mutex;
use std::time::Duration;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// A progress report that library calls advance; shared between threads.
pub struct Progress {
    visible: bool,
    bar: Mutex<Option<ProgressBar>>,
}

impl Progress {
    /// Never drawn.
    pub fn hidden() -> Self {
        Progress {
            visible: false,
            bar: Mutex::new(None),
        }
    }

    /// Drawn on stderr when stderr is a terminal.
    pub fn stderr() -> Self {
        Progress {
            visible: std::io::stderr().is_terminal(),
            bar: Mutex::new(None),
        }
    }

    /// Starts a stage of `total` steps.
    pub fn start(&self, total: u64, message: &'static str) {
        let bar = if self.visible {
            let bar = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr());
            bar.set_style(
                ProgressStyle::with_template(
                    "{msg:>18} [{bar:40}] {pos}/{len} ({per_sec}, {eta} left)",
                )
                .expect("template is valid")
                .progress_chars("=> "),
            );
            bar.set_message(message);
            bar.enable_steady_tick(Duration::from_millis(200));
            bar
        } else {
            ProgressBar::hidden()
        };
        *self.bar.lock().expect("progress lock") = Some(bar);
    }

    /// Advances the current stage by `steps`.
    pub fn advance(&self, steps: u64) {
        if let Some(bar) = self.bar.lock().expect("progress lock").as_ref() {
            bar.inc(steps);
        }
    }

    /// Ends the current stage and clears its bar.
    pub fn finish(&self) {
        if let Some(bar) = self.bar.lock().expect("progress lock").take() {
            bar.finish_and_clear();
        }
    }
}
