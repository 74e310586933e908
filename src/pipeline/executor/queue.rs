//! Talking to Slurm: submission with `sbatch --parsable`, job states from
//! `sacct` (falling back to `squeue --states=all` where accounting is off),
//! one call for any number of jobs; [`super::monitor`] waits on them.
//!
//! The cache, not the scheduler, says whether a job succeeded: a job is done
//! when its run record (or shard record) is there, which `exec` writes last.
//! The scheduler is asked only whether the job is still pending or running,
//! and why it ended when it left no result.

use super::error::ExecutorError;
use std::path::Path;
use std::process::{Command, Stdio};

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
pub fn submit(script: &Path) -> Result<String, ExecutorError> {
    let out = Command::new("sbatch")
        .arg("--parsable")
        .arg(script)
        .stdin(Stdio::null())
        .output()
        .map_err(|cause| ExecutorError::SbatchMissing { cause })?;
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
        return Err(ExecutorError::SbatchFailed {
            script: script.to_path_buf(),
            status: out.status,
            stderr: String::from_utf8_lossy(&out.stderr).trim().to_string(),
            stdout: stdout.trim().to_string(),
        });
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
    /// Whether job states come from `sacct` (accounting is on).
    pub fn accounting(&self) -> bool {
        self.sacct
    }

    /// The states of the tasks of every job in `ids`, in one scheduler
    /// call (`sacct -j a,b,…`, or `squeue --jobs=a,b,…`); `None` when no
    /// command answered.
    pub fn query(&mut self, ids: &[String]) -> Option<Vec<TaskState>> {
        if ids.is_empty() {
            return Some(Vec::new());
        }
        let list = ids.join(",");
        if self.sacct {
            let out = Command::new("sacct")
                .args(["-X", "-n", "-P", "-o", "JobID,State,ExitCode", "-j", &list])
                .stdin(Stdio::null())
                .output();
            match out {
                Ok(o) if o.status.success() => {
                    let states = parse(&String::from_utf8_lossy(&o.stdout));
                    // Accounting lags behind submission: ask squeue for the rest.
                    if ids.iter().all(|id| states.iter().any(|s| s.job() == id)) {
                        return Some(states);
                    }
                    let mut rest = self.squeue(&list).unwrap_or_default();
                    rest.retain(|r| !states.iter().any(|s| s.job() == r.job()));
                    return Some(states.into_iter().chain(rest).collect());
                }
                _ => self.sacct = false,
            }
        }
        self.squeue(&list)
    }

    fn squeue(&self, list: &str) -> Option<Vec<TaskState>> {
        let out = Command::new("squeue")
            .args(["-h", "-t", "all", "-o", "%i|%T", "--jobs", list])
            .stdin(Stdio::null())
            .output()
            .ok()?;
        // squeue fails when no listed job is known any more.
        Some(if out.status.success() {
            parse(&String::from_utf8_lossy(&out.stdout))
        } else {
            Vec::new()
        })
    }
}

impl TaskState {
    /// The job id the line belongs to (`123` of `123_4` or `123_[5-7]`).
    pub fn job(&self) -> &str {
        self.id.split('_').next().unwrap_or(&self.id)
    }

    /// Whether the line stands for array task `task`: the task itself, or a
    /// pending range `123_[0-3,7%2]` holding it.
    pub fn covers(&self, task: usize) -> bool {
        if let Some(t) = self.task {
            return t == task;
        }
        let Some(range) = self
            .id
            .split_once("_[")
            .and_then(|(_, r)| r.strip_suffix(']'))
        else {
            return false;
        };
        let range = range.split('%').next().unwrap_or(range);
        range.split(',').any(|part| {
            let mut ends = part.splitn(2, '-').map(|x| x.trim().parse::<usize>());
            match (ends.next(), ends.next()) {
                (Some(Ok(a)), None) => a == task,
                (Some(Ok(a)), Some(Ok(b))) => a <= task && task <= b,
                _ => false,
            }
        })
    }
}

/// `slurm job 123: 2 RUNNING, 1 PENDING` for the progress line.
pub fn summary(id: &str, states: &[TaskState]) -> String {
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
    fn lines_belong_to_jobs_and_tasks() {
        let s = parse("123_4|RUNNING|0:0\n123_[5-7,9%2]|PENDING|0:0\n88|PENDING|0:0\n");
        assert_eq!((s[0].job(), s[1].job(), s[2].job()), ("123", "123", "88"));
        assert!(s[0].covers(4) && !s[0].covers(5));
        assert!(s[1].covers(5) && s[1].covers(7) && s[1].covers(9) && !s[1].covers(8));
        assert!(!s[2].covers(0));
    }
}
