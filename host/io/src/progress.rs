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
    /// Every stage started and its steps, drawn or not: what a test reads ([`Progress::stages`]).
    stages: Mutex<Vec<Stage>>,
}

/// A stage of work as [`Progress`] recorded it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Stage {
    /// What the stage does ("light transport").
    pub message: &'static str,
    /// Steps announced.
    pub total: u64,
    /// Steps reported done.
    pub done: u64,
}

impl Progress {
    /// Never drawn.
    pub fn hidden() -> Self {
        Progress {
            visible: false,
            bar: Mutex::new(None),
            stages: Mutex::new(Vec::new()),
        }
    }

    /// Drawn on stderr when stderr is a terminal.
    pub fn stderr() -> Self {
        Progress {
            visible: std::io::stderr().is_terminal(),
            bar: Mutex::new(None),
            stages: Mutex::new(Vec::new()),
        }
    }

    /// Starts a stage of `total` steps.
    pub fn start(&self, total: u64, message: &'static str) {
        self.stages.lock().expect("progress lock").push(Stage {
            message,
            total,
            done: 0,
        });
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
        if let Some(stage) = self.stages.lock().expect("progress lock").last_mut() {
            stage.done += steps;
        }
        if let Some(bar) = self.bar.lock().expect("progress lock").as_ref() {
            bar.inc(steps);
        }
    }

    /// The stages started so far, with the steps each reported.
    pub fn stages(&self) -> Vec<Stage> {
        self.stages.lock().expect("progress lock").clone()
    }

    /// Ends the current stage and clears its bar.
    pub fn finish(&self) {
        if let Some(bar) = self.bar.lock().expect("progress lock").take() {
            bar.finish_and_clear();
        }
    }
}
