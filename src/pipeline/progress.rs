//! Progress on stderr: an overall bar plus one bar per running stage (fed by
//! the stage's counters) on a terminal; plain log lines otherwise, so CI logs
//! and pipes stay readable. Nothing here writes to stdout.

use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;

/// How progress is shown.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProgressMode {
    /// Bars on a terminal, lines otherwise.
    Auto,
    Bars,
    Lines,
    Quiet,
}

/// The run-wide progress display.
pub struct Reporter {
    multi: Option<MultiProgress>,
    overall: Option<ProgressBar>,
    lines: bool,
}

impl Reporter {
    pub fn new(stages: usize, mode: ProgressMode) -> Reporter {
        let bars = match mode {
            ProgressMode::Auto => std::io::stderr().is_terminal(),
            ProgressMode::Bars => true,
            ProgressMode::Lines | ProgressMode::Quiet => false,
        };
        if !bars {
            return Reporter {
                multi: None,
                overall: None,
                lines: mode != ProgressMode::Quiet,
            };
        }
        let multi = MultiProgress::with_draw_target(ProgressDrawTarget::stderr());
        let overall = multi.add(ProgressBar::new(stages as u64));
        overall.set_style(
            ProgressStyle::with_template(
                "{prefix:>12.bold} [{bar:30.cyan/blue}] {pos}/{len} stages {elapsed}",
            )
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        overall.set_prefix("pipeline");
        Reporter {
            multi: Some(multi),
            overall: Some(overall),
            lines: false,
        }
    }

    /// A handle for one running stage.
    pub fn stage(&self, name: &str) -> Progress {
        let bar = self.multi.as_ref().map(|m| {
            let b = m.add(ProgressBar::new(0));
            b.set_style(
                ProgressStyle::with_template(
                    "{prefix:>12.dim} {spinner} {wide_msg} {pos}/{len} {per_sec}",
                )
                .unwrap_or_else(|_| ProgressStyle::default_spinner()),
            );
            b.set_prefix(truncate(name, 30));
            b.enable_steady_tick(std::time::Duration::from_millis(120));
            b
        });
        Progress { bar }
    }

    /// A stage finished: drop its bar, advance the overall bar, log a line.
    pub fn done(&self, progress: Progress, line: &str) {
        if let Some(b) = progress.bar {
            b.finish_and_clear();
            if let Some(m) = &self.multi {
                m.remove(&b);
            }
        }
        if let Some(o) = &self.overall {
            o.inc(1);
        }
        self.line(line);
    }

    /// Print a message above the bars (or as a plain line).
    pub fn line(&self, msg: &str) {
        match &self.multi {
            Some(m) => {
                let _ = m.println(msg);
            }
            None if self.lines => eprintln!("{msg}"),
            None => {}
        }
    }

    pub fn finish(&self) {
        if let Some(o) = &self.overall {
            o.finish_and_clear();
        }
    }
}

fn truncate(s: &str, n: usize) -> String {
    if s.chars().count() <= n {
        s.to_string()
    } else {
        format!("{}…", s.chars().take(n - 1).collect::<String>())
    }
}

/// A running stage's progress. Stages report what they count (evaluations,
/// BO iterations, model orders); without a terminal these calls are no-ops.
pub struct Progress {
    bar: Option<ProgressBar>,
}

impl Progress {
    /// A handle that shows nothing (tests, benches, nested work).
    pub fn hidden() -> Progress {
        Progress { bar: None }
    }

    /// Total units of work, e.g. the evaluation budget.
    pub fn set_length(&self, n: u64) {
        if let Some(b) = &self.bar {
            b.set_length(n);
        }
    }

    pub fn inc(&self, n: u64) {
        if let Some(b) = &self.bar {
            b.inc(n);
        }
    }

    /// What is being counted or done right now.
    pub fn set_message(&self, msg: impl Into<String>) {
        if let Some(b) = &self.bar {
            b.set_message(msg.into());
        }
    }
}
