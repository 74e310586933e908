//! Submissions in flight, persisted per stage key in the cache
//! (`cache/jobs/<key>/inflight-<unit>.json`, unit `job`, `merge` or
//! `shards`) from `sbatch` until the job's result is committed or it ended
//! without one. A new `modalflow run` whose stage has such a record adopts
//! the job (waits on it) instead of submitting the stage again, so a killed
//! or disconnected submitter costs nothing; `modalflow status` reports it.

use super::error::ExecutorError;
use crate::pipeline::store::Store;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::time::{Duration, SystemTime, UNIX_EPOCH};

/// One submitted job, as far as one stage is concerned.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Submission {
    /// Slurm job id.
    pub id: String,
    /// The array tasks that are this stage's (`None`: the whole job).
    pub tasks: Option<Vec<usize>>,
    /// 1 for the first submission, then one more per retry.
    pub attempt: u32,
    /// Directory of the job's logs (`<id>.out`, `<id>_<task>.out`).
    pub log_dir: PathBuf,
    /// The directory of a submission shared with other stages (an array
    /// of matrix expansions, a group job).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub batch: Option<PathBuf>,
    /// Seconds since the Unix epoch.
    pub submitted: u64,
    /// Host and pid of the submitting process.
    pub by: String,
}

impl Submission {
    pub fn submitted_at(&self) -> SystemTime {
        UNIX_EPOCH + Duration::from_secs(self.submitted)
    }

    /// The log of task `task` (or of the whole job).
    pub fn log(&self, task: Option<usize>) -> PathBuf {
        match task.or_else(|| self.tasks.as_ref().and_then(|t| t.first().copied())) {
            Some(t) if self.tasks.is_some() => self.log_dir.join(format!("{}_{t}.out", self.id)),
            _ => self.log_dir.join(format!("{}.out", self.id)),
        }
    }
}

/// Seconds since the Unix epoch, now.
pub fn now() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_secs())
}

/// `host:pid` of this process.
pub fn by() -> String {
    let host = std::fs::read_to_string("/proc/sys/kernel/hostname")
        .map(|h| h.trim().to_string())
        .unwrap_or_default();
    format!("{host}:{}", std::process::id())
}

fn path(dir: &Path, unit: &str) -> PathBuf {
    dir.join(format!("inflight-{unit}.json"))
}

/// The submission recorded for `unit` in job directory `dir`.
pub fn read(dir: &Path, unit: &str) -> Option<Submission> {
    let bytes = std::fs::read(path(dir, unit)).ok()?;
    serde_json::from_slice(&bytes).ok()
}

/// Every submission recorded for stage `key`.
pub fn of_key(store: &Store, key: &str) -> Vec<Submission> {
    ["shards", "job", "merge"]
        .iter()
        .filter_map(|u| read(&store.job_dir(key), u))
        .collect()
}

/// Record `s` as in flight for `unit` (atomically).
pub fn write(store: &Store, dir: &Path, unit: &str, s: &Submission) -> Result<(), ExecutorError> {
    let json = serde_json::to_vec_pretty(s).map_err(ExecutorError::Serialize)?;
    Ok(store.write_atomic(&path(dir, unit), &json)?)
}

/// The job of `unit` is no longer in flight.
pub fn remove(dir: &Path, unit: &str) {
    let _ = std::fs::remove_file(path(dir, unit));
}

/// Whether job directory `dir` has a submission in flight.
pub fn any(dir: &Path) -> bool {
    std::fs::read_dir(dir).is_ok_and(|d| {
        d.flatten()
            .any(|e| e.file_name().to_string_lossy().starts_with("inflight-"))
    })
}
