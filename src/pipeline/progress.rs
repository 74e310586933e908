//! Progress on stderr: an overall bar plus one bar per running stage (fed by
//! the stage's counters) on a terminal; plain log lines otherwise, so CI logs
//! and pipes stay readable — with a heartbeat line per running stage at
//! least every 10 s, so a long stage is never silent. Nothing here writes to
//! stdout.

use crate::stages;
use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// How progress is shown.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProgressMode {
    /// Bars on a terminal, lines otherwise.
    Auto,
    Bars,
    Lines,
    Quiet,
}

/// Longest silence of a running stage in `lines` mode.
pub const HEARTBEAT: Duration = Duration::from_secs(10);

/// What a running stage has reported, shared with the heartbeat.
#[derive(Debug)]
struct Counters {
    name: String,
    started: Instant,
    position: AtomicU64,
    length: AtomicU64,
    message: Mutex<String>,
}

impl Counters {
    fn line(&self) -> String {
        let pos = self.position.load(Ordering::Relaxed);
        let len = self.length.load(Ordering::Relaxed);
        let msg = self.message.lock().map(|m| m.clone()).unwrap_or_default();
        let mut out = format!(
            "  running {} ({:.0} s)",
            self.name,
            self.started.elapsed().as_secs_f64()
        );
        if len > 0 {
            out.push_str(&format!(": {pos}/{len}"));
        } else if pos > 0 {
            out.push_str(&format!(": {pos}"));
        }
        if !msg.is_empty() {
            out.push_str(&format!(" — {msg}"));
        }
        out
    }
}

/// The run-wide progress display.
pub struct Reporter {
    multi: Option<MultiProgress>,
    overall: Option<ProgressBar>,
    lines: bool,
    running: Arc<Mutex<Vec<Arc<Counters>>>>,
    stop: Arc<AtomicBool>,
    heartbeat: Option<std::thread::JoinHandle<()>>,
}

impl Reporter {
    /// A display for `stages` stages; in `lines` mode a heartbeat line per
    /// running stage every `interval`.
    pub fn new(stages: usize, mode: ProgressMode, interval: Duration) -> Reporter {
        let bars = match mode {
            ProgressMode::Auto => std::io::stderr().is_terminal(),
            ProgressMode::Bars => true,
            ProgressMode::Lines | ProgressMode::Quiet => false,
        };
        let running: Arc<Mutex<Vec<Arc<Counters>>>> = Arc::default();
        let stop = Arc::new(AtomicBool::new(false));
        if !bars {
            let lines = mode != ProgressMode::Quiet;
            let heartbeat = lines.then(|| spawn_heartbeat(running.clone(), stop.clone(), interval));
            return Reporter {
                multi: None,
                overall: None,
                lines,
                running,
                stop,
                heartbeat,
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
            running,
            stop,
            heartbeat: None,
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
            b.enable_steady_tick(Duration::from_millis(120));
            b
        });
        let counters = Arc::new(Counters {
            name: name.to_string(),
            started: Instant::now(),
            position: AtomicU64::new(0),
            length: AtomicU64::new(0),
            message: Mutex::new(String::new()),
        });
        if self.lines {
            if let Ok(mut r) = self.running.lock() {
                r.push(counters.clone());
            }
        }
        Progress {
            bar,
            counters: Some(counters),
        }
    }

    /// A stage finished: drop its bar, advance the overall bar, log a line.
    pub fn done(&self, progress: Progress, line: &str) {
        if let Some(b) = progress.bar {
            b.finish_and_clear();
            if let Some(m) = &self.multi {
                m.remove(&b);
            }
        }
        if let (Some(c), Ok(mut r)) = (&progress.counters, self.running.lock()) {
            r.retain(|x| !Arc::ptr_eq(x, c));
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

    pub fn finish(&mut self) {
        if let Some(o) = &self.overall {
            o.finish_and_clear();
        }
        self.stop.store(true, Ordering::Relaxed);
        if let Some(h) = self.heartbeat.take() {
            h.thread().unpark();
            let _ = h.join();
        }
    }
}

impl Drop for Reporter {
    fn drop(&mut self) {
        self.finish();
    }
}

/// Every `interval`, one line per running stage with its counters.
fn spawn_heartbeat(
    running: Arc<Mutex<Vec<Arc<Counters>>>>,
    stop: Arc<AtomicBool>,
    interval: Duration,
) -> std::thread::JoinHandle<()> {
    std::thread::spawn(move || {
        let mut next = Instant::now() + interval;
        while !stop.load(Ordering::Relaxed) {
            let now = Instant::now();
            if now < next {
                std::thread::park_timeout((next - now).min(Duration::from_millis(200)));
                continue;
            }
            next = now + interval;
            let lines: Vec<String> = running
                .lock()
                .map(|r| r.iter().map(|c| c.line()).collect())
                .unwrap_or_default();
            for l in lines {
                eprintln!("{l}");
            }
        }
    })
}

fn truncate(s: &str, n: usize) -> String {
    if s.chars().count() <= n {
        s.to_string()
    } else {
        format!("{}…", s.chars().take(n - 1).collect::<String>())
    }
}

/// A running stage's progress: a bar on a terminal, counters for the
/// heartbeat lines otherwise.
pub struct Progress {
    bar: Option<ProgressBar>,
    counters: Option<Arc<Counters>>,
}

impl Progress {
    /// A handle that shows nothing (tests, benches, nested work).
    pub fn hidden() -> Progress {
        Progress {
            bar: None,
            counters: None,
        }
    }
}

impl stages::Progress for Progress {
    fn set_length(&self, n: u64) {
        if let Some(b) = &self.bar {
            b.set_length(n);
        }
        if let Some(c) = &self.counters {
            c.length.store(n, Ordering::Relaxed);
        }
    }

    fn inc(&self, n: u64) {
        if let Some(b) = &self.bar {
            b.inc(n);
        }
        if let Some(c) = &self.counters {
            c.position.fetch_add(n, Ordering::Relaxed);
        }
    }

    fn set_message(&self, msg: String) {
        if let Some(c) = &self.counters {
            if let Ok(mut m) = c.message.lock() {
                m.clone_from(&msg);
            }
        }
        if let Some(b) = &self.bar {
            b.set_message(msg);
        }
    }
}
