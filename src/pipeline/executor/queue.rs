//! Talking to Slurm: submission with `sbatch --parsable`, job states from
//! `sacct` (falling back to `squeue --states=all` where accounting is off),
//! and waiting with back-off until the job's result is in the cache or the
//! scheduler says the job ended without it.
//!
//! The cache, not the scheduler, says whether a job succeeded: a job is done
//! when its run record (or shard record) is there, which `exec` writes last.
//! The scheduler is asked only whether the job is still pending or running,
//! and why it ended when it left no result.

use crate::stages::Progress;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// One job or array task as the scheduler reports it.
#[derive(Clone, Debug, PartialEq)]
pub struct TaskState {
    /// `123`, `123_4`, or a pending range `123_[5-7]`.
    pub id: String,
    /// Array task index, when the line is one task.
    pub task: Option<usize>,
    /// First word of the state: `PENDING`, `COMPLETED`, `TIMEOUT`, ...
    pub state: String,
    /// `exit:signal` as sacct gives it (squeue does not).
    pub exit: Option<String>,
}

impl TaskState {
    pub fn terminal(&self) -> bool {
        is_terminal(&self.state)
    }
}

/// How waiting ended when the result did not appear.
#[derive(Debug)]
pub enum Ended {
    /// Every task ended; all of them as the scheduler last reported them.
    Terminal(Vec<TaskState>),
    /// The scheduler no longer (or never) knows the job.
    Vanished,
}

/// States after which a job does not run again by itself.
pub fn is_terminal(state: &str) -> bool {
    matches!(
        state,
        "COMPLETED"
            | "FAILED"
            | "TIMEOUT"
            | "CANCELLED"
            | "OUT_OF_MEMORY"
            | "NODE_FAIL"
            | "BOOT_FAIL"
            | "DEADLINE"
            | "PREEMPTED"
            | "REVOKED"
    )
}

/// Submit `script` with `sbatch --parsable`; returns the job id.
pub fn submit(script: &Path) -> Result<String, String> {
    let out = Command::new("sbatch")
        .arg("--parsable")
        .arg(script)
        .stdin(Stdio::null())
        .output()
        .map_err(|e| {
            format!("cannot run sbatch ({e}); is Slurm installed and on PATH on this machine?")
        })?;
    let stdout = String::from_utf8_lossy(&out.stdout);
    let id = stdout
        .lines()
        .last()
        .unwrap_or_default()
        .split(';')
        .next()
        .unwrap_or_default()
        .trim()
        .to_string();
    if !out.status.success() || id.is_empty() || !id.bytes().all(|b| b.is_ascii_digit()) {
        return Err(format!(
            "sbatch {} failed ({}): {}{}",
            script.display(),
            out.status,
            String::from_utf8_lossy(&out.stderr).trim(),
            stdout.trim()
        ));
    }
    Ok(id)
}

/// Parse `ID|STATE[|EXIT]` lines (sacct -P, or squeue with that format).
pub fn parse(text: &str) -> Vec<TaskState> {
    text.lines()
        .filter_map(|line| {
            let mut f = line.trim().split('|');
            let id = f.next()?.trim().to_string();
            let state = f.next()?.split_whitespace().next()?.to_string();
            let exit = f
                .next()
                .map(|e| e.trim().to_string())
                .filter(|e| !e.is_empty());
            let task = id.split_once('_').and_then(|(_, t)| t.parse().ok());
            (!id.is_empty()).then_some(TaskState {
                id,
                task,
                state,
                exit,
            })
        })
        .collect()
}

/// Which status command answers; `sacct` is dropped after it fails once
/// (accounting disabled), so every later query costs one process.
#[derive(Debug)]
pub struct Queries {
    sacct: bool,
}

impl Default for Queries {
    fn default() -> Self {
        Queries { sacct: true }
    }
}

impl Queries {
    /// The states of job `id`'s tasks, or `None` when no command knows it.
    pub fn query(&mut self, id: &str) -> Option<Vec<TaskState>> {
        if self.sacct {
            let out = Command::new("sacct")
                .args(["-X", "-n", "-P", "-o", "JobID,State,ExitCode", "-j", id])
                .stdin(Stdio::null())
                .output();
            match out {
                Ok(o) if o.status.success() => {
                    let states = parse(&String::from_utf8_lossy(&o.stdout));
                    if !states.is_empty() {
                        return Some(states);
                    }
                }
                _ => self.sacct = false,
            }
        }
        let out = Command::new("squeue")
            .args(["-h", "-t", "all", "-o", "%i|%T", "-j", id])
            .stdin(Stdio::null())
            .output()
            .ok()?;
        let states = parse(&String::from_utf8_lossy(&out.stdout));
        (out.status.success() && !states.is_empty()).then_some(states)
    }
}

/// Back-off between status queries: from 0.2 s up by half each time to `max`.
pub fn delays(max: Duration) -> impl Iterator<Item = Duration> {
    std::iter::successors(Some(Duration::from_millis(200)), move |d| {
        Some(d.mul_f64(1.5).min(max))
    })
    .map(move |d| d.min(max))
}

/// How long a job the scheduler has never shown may stay unknown (sacct
/// lags behind submission on busy clusters) before it counts as vanished.
const UNSEEN_GRACE: Duration = Duration::from_secs(120);
/// How long a completed job's result may take to become visible here
/// (attribute caching of a network file system).
const VISIBLE_GRACE: Duration = Duration::from_secs(30);

/// Wait until `ready()` (the job's result is in the cache) or the scheduler
/// reports every task of job `id` ended without it.
pub fn wait(
    id: &str,
    ready: &dyn Fn() -> bool,
    poll_max: Duration,
    progress: &dyn Progress,
) -> Result<(), Ended> {
    let start = Instant::now();
    let mut queries = Queries::default();
    let mut seen = false;
    let mut delays = delays(poll_max);
    loop {
        if ready() {
            return Ok(());
        }
        match queries.query(id) {
            Some(states) => {
                seen = true;
                if states.iter().all(TaskState::terminal) {
                    let completed = states.iter().all(|s| s.state == "COMPLETED");
                    let grace = if completed {
                        VISIBLE_GRACE
                    } else {
                        Duration::ZERO
                    };
                    return settle(ready, grace).ok_or(Ended::Terminal(states));
                }
                progress.set_message(summary(id, &states));
            }
            None if seen || start.elapsed() > UNSEEN_GRACE => {
                return settle(ready, VISIBLE_GRACE).ok_or(Ended::Vanished);
            }
            None => progress.set_message(format!("slurm job {id}: submitted")),
        }
        std::thread::sleep(delays.next().unwrap_or(poll_max));
    }
}

/// `Some(())` once `ready()` holds within `grace`.
fn settle(ready: &dyn Fn() -> bool, grace: Duration) -> Option<()> {
    let start = Instant::now();
    loop {
        if ready() {
            return Some(());
        }
        if start.elapsed() >= grace {
            return None;
        }
        std::thread::sleep(Duration::from_millis(500));
    }
}

/// `slurm job 123: 2 RUNNING, 1 PENDING` for the progress line.
fn summary(id: &str, states: &[TaskState]) -> String {
    let mut counts: Vec<(String, usize)> = Vec::new();
    for s in states {
        match counts.iter_mut().find(|(k, _)| *k == s.state) {
            Some((_, n)) => *n += 1,
            None => counts.push((s.state.clone(), 1)),
        }
    }
    let parts: Vec<String> = counts.iter().map(|(k, n)| format!("{n} {k}")).collect();
    format!("slurm job {id}: {}", parts.join(", "))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_sacct_and_squeue_lines() {
        let s = parse("123_0|COMPLETED|0:0\n123_1|CANCELLED by 0|0:15\n123_[2-3]|PENDING|0:0\n");
        assert_eq!(s.len(), 3);
        assert_eq!((s[0].task, s[0].state.as_str()), (Some(0), "COMPLETED"));
        assert_eq!(
            (s[1].state.as_str(), s[1].exit.as_deref()),
            ("CANCELLED", Some("0:15"))
        );
        assert_eq!(s[2].task, None);
        assert!(s[0].terminal() && s[1].terminal() && !s[2].terminal());
        let q = parse("77|TIMEOUT\n");
        assert_eq!((q[0].id.as_str(), q[0].exit.clone()), ("77", None));
        assert!(parse("\n  \n").is_empty());
        assert_eq!(
            summary("123", &s),
            "slurm job 123: 1 COMPLETED, 1 CANCELLED, 1 PENDING"
        );
    }

    #[test]
    fn back_off_grows_to_its_cap() {
        let d: Vec<u128> = delays(Duration::from_secs(1))
            .take(8)
            .map(|d| d.as_millis())
            .collect();
        assert_eq!(d, [200, 300, 450, 675, 1000, 1000, 1000, 1000]);
    }
}
