//! The Slurm executor: a stage becomes a batch job running `modalflow exec`
//! on the job description in the shared cache (`cache/jobs/<key>/`), as
//! Snakemake's and Nextflow's Slurm executors do with their job scripts.
//!
//! - A shardable stage with `shards: m > 1` runs in two steps: a job array
//!   of m tasks, each evaluating one slice of the stage's batch and
//!   recording its partial result (`shards/<m>-<i>.json`), then one merge
//!   job. Shards recorded by an earlier attempt are reused, so a retry or a
//!   new run resubmits only the missing tasks.
//! - Matrix expansions of one stage that become ready together with the
//!   same resources are one job array; stages of a kind with `group: n`
//!   share jobs of up to n stages ([`batch`](super::batch)).
//! - Every submission is recorded in the stage's job directory while in
//!   flight ([`inflight`]); a later run adopts it instead of submitting again.
//! - A job that ends in TIMEOUT, OUT_OF_MEMORY or a node failure is
//!   resubmitted up to `retries` times, with `* attempt` resources scaled.
//! - One status query per poll interval serves every job ([`Monitor`]).
//!
//! A job that ends without its result fails the stage with the job id, the
//! scheduler's state and the tail of its log; the job directory (description,
//! script, logs) is kept for inspection and removed after a success.

use super::batch::{Batcher, Member};
use super::config::ExecutorSpec;
use super::error::ExecutorError;
use super::inflight::{self, Submission};
use super::interrupt::{self, Live};
use super::job::{self, Job};
use super::monitor::{Monitor, Watch};
use super::queue::{self, Ended, TaskState};
use super::resources::{Resolved, MAX_SHARDS};
use super::script::{Body, Script};
use crate::pipeline::store::{RunRecord, Store};
use crate::pipeline::trace::JobRow;
use crate::stages::Progress;
use std::collections::HashMap;
use std::fmt::Write;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::Instant;

/// Lines of a failed job's log quoted in the error.
const LOG_TAIL: usize = 15;

/// Scheduler states after which a resubmission may succeed.
const RETRYABLE: [&str; 5] = [
    "TIMEOUT",
    "OUT_OF_MEMORY",
    "NODE_FAIL",
    "BOOT_FAIL",
    "PREEMPTED",
];

/// The Slurm executor of one run.
pub struct Slurm {
    spec: ExecutorSpec,
    binary: PathBuf,
    monitor: Monitor,
    batcher: Batcher<Submission>,
    /// Every job a stage waited on, for the trace.
    jobs: Mutex<Vec<JobRow>>,
    /// Shared submission directory → its members not yet committed.
    batches: Mutex<HashMap<PathBuf, usize>>,
}

impl Slurm {
    /// `spec.binary` is absolute here (the plan resolved it).
    pub fn new(spec: &ExecutorSpec) -> Result<Slurm, ExecutorError> {
        let binary = match &spec.binary {
            Some(b) => b.clone(),
            None => std::env::current_exe().map_err(|cause| ExecutorError::NoBinary { cause })?,
        };
        interrupt::install();
        let (first, max) = spec.poll_range();
        Ok(Slurm {
            spec: spec.clone(),
            binary,
            monitor: Monitor::new(first, max),
            batcher: Batcher::default(),
            jobs: Mutex::new(Vec::new()),
            batches: Mutex::new(HashMap::new()),
        })
    }

    pub fn spec(&self) -> &ExecutorSpec {
        &self.spec
    }

    /// The jobs waited on so far (for the trace).
    pub fn jobs(&self) -> Vec<JobRow> {
        self.jobs.lock().map(|j| j.clone()).unwrap_or_default()
    }

    /// Compute the stage as one job (alone, in an array or in a group), or
    /// as a job array plus a merge job.
    pub fn compute(
        &self,
        store: &Store,
        mut job: Job,
        resources: &Resolved,
        progress: &dyn Progress,
    ) -> Result<RunRecord, ExecutorError> {
        let typed = job.typed()?.clone();
        let dir = store.job_dir(&job.key);
        if finished(store, &job.key) {
            // A forced recompute: the job and this process could not tell the
            // old result from the new one, so the old one goes first, with
            // any shards of earlier attempts.
            store.remove_record(&job.key);
            let _ = std::fs::remove_dir_all(&dir);
        }
        std::fs::create_dir_all(dir.join("log")).map_err(|cause| ExecutorError::CreateDir {
            path: dir.clone(),
            cause,
        })?;
        let sharded = resources.shards > 1 && typed.kind.shardable(&typed.params);
        if sharded {
            job.shards = resources.shards;
            job.write(store, &dir.join("job.json"))?;
            self.attempts(store, &job, resources, "shards", progress)?;
            let count = job.shards;
            for i in 0..count {
                let rec = job::shard_record(store, &job.key, i, count)
                    .ok_or(ExecutorError::MissingShard { index: i, count })?;
                job.partial_seconds += rec.seconds;
                job.partials.push(rec.artifact);
            }
        }
        // One job runs the stage: the whole of it, or the merge of the shards.
        let unit = if sharded { "merge" } else { "job" };
        job.write(store, &dir.join(format!("{unit}.json")))?;
        self.attempts(store, &job, resources, unit, progress)?;
        let record = store
            .record(&job.key)
            .ok_or_else(|| ExecutorError::RecordVanished {
                key: job.key.clone(),
            })?;
        let _ = std::fs::remove_dir_all(&dir);
        Ok(record)
    }

    /// Submit (or adopt) `unit` of the stage and wait, resubmitting after a
    /// retryable end while `retries` allow.
    fn attempts(
        &self,
        store: &Store,
        job: &Job,
        r: &Resolved,
        unit: &str,
        progress: &dyn Progress,
    ) -> Result<(), ExecutorError> {
        let dir = store.job_dir(&job.key);
        let count = job.shards;
        let ready = || match unit {
            "shards" => (0..count).all(|i| job::shard_record(store, &job.key, i, count).is_some()),
            _ => finished(store, &job.key),
        };
        let mut adopt = inflight::read(&dir, unit);
        let mut attempt = 1;
        loop {
            if ready() {
                inflight::remove(&dir, unit);
                return Ok(());
            }
            let (sub, adopted) = match adopt.take() {
                Some(s) => {
                    progress.set_message(format!(
                        "slurm job {}: adopted (submitted by {})",
                        s.id, s.by
                    ));
                    attempt = s.attempt;
                    (s, true)
                }
                None => {
                    let s = self.submit(store, job, r, unit, attempt)?;
                    inflight::write(store, &dir, unit, &s)?;
                    progress.set_message(format!("slurm job {}: submitted", s.id));
                    (s, false)
                }
            };
            let start = Instant::now();
            let live = Live::register(&sub.id);
            let watch = Watch {
                id: sub.id.clone(),
                tasks: sub.tasks.clone(),
                submitted: sub.submitted_at(),
            };
            let result = self.monitor.wait(&watch, &ready, progress);
            drop(live);
            inflight::remove(&dir, unit);
            let (state, exit) = match &result {
                Ok(()) => ("COMPLETED".to_string(), String::new()),
                Err(Ended::Vanished) => ("VANISHED".to_string(), String::new()),
                Err(Ended::Terminal(states)) => {
                    let bad = states.iter().find(|t| t.state != "COMPLETED");
                    bad.map_or(("COMPLETED".into(), String::new()), |t| {
                        (t.state.clone(), t.exit.clone().unwrap_or_default())
                    })
                }
            };
            self.note(job, unit, &sub, &state, exit, start, adopted);
            self.batch_done(&sub, result.is_ok());
            let Err(ended) = result else {
                return Ok(());
            };
            let retry = RETRYABLE.contains(&state.as_str()) && attempt <= r.retries;
            if retry {
                attempt += 1;
                progress.set_message(format!(
                    "slurm job {} {state}: attempt {attempt} of {}",
                    sub.id,
                    r.retries + 1
                ));
            } else if !adopted {
                return Err(ExecutorError::JobEnded(failure(
                    &sub, &ended, store, job, attempt,
                )));
            }
            // An adopted job of an earlier run that ended without its
            // result is submitted again, as that run would have.
        }
    }

    /// A new submission of `unit` at `attempt`.
    fn submit(
        &self,
        store: &Store,
        job: &Job,
        r: &Resolved,
        unit: &str,
        attempt: u32,
    ) -> Result<Submission, ExecutorError> {
        let dir = store.job_dir(&job.key);
        if unit == "shards" {
            let count = job.shards;
            let missing: Vec<usize> = (0..count)
                .filter(|&i| job::shard_record(store, &job.key, i, count).is_none())
                .collect();
            let script = Script {
                name: &job.stage,
                dir: &dir,
                resources: r,
                attempt,
                tasks: Some(&missing),
                binary: &self.binary,
                cache: store.root(),
                body: Body::One {
                    description: &dir.join("job.json"),
                    shards: true,
                },
            };
            let id = send(&dir.join("shards.sh"), &script)?;
            return Ok(placed(id, Some(missing), attempt, &dir, None));
        }
        let member = Member {
            stage: job.stage.clone(),
            key: job.key.clone(),
            description: dir.join(format!("{unit}.json")),
        };
        let base = job.stage.split('[').next().unwrap_or(&job.stage);
        let batch = if attempt > 1 || unit != "job" {
            None
        } else if r.group > 1 {
            Some(format!(
                "group|{}|{}",
                job.material.kind,
                r.submission_key()
            ))
        } else if base != job.stage {
            Some(format!("array|{base}|{}", r.submission_key()))
        } else {
            None
        };
        match batch {
            Some(key) => self.batcher.join(&key, member, &|all| {
                self.submit_batch(store, all, r, key.starts_with("group"))
            }),
            None => self.submit_alone(store, &member, r, attempt),
        }
    }

    fn submit_alone(
        &self,
        store: &Store,
        m: &Member,
        r: &Resolved,
        attempt: u32,
    ) -> Result<Submission, ExecutorError> {
        let dir = store.job_dir(&m.key);
        let script = Script {
            name: &m.stage,
            dir: &dir,
            resources: r,
            attempt,
            tasks: None,
            binary: &self.binary,
            cache: store.root(),
            body: Body::One {
                description: &m.description,
                shards: false,
            },
        };
        let name = m
            .description
            .file_stem()
            .map_or("job".into(), |s| s.to_string_lossy().into_owned());
        let id = send(&dir.join(format!("{name}.sh")), &script)?;
        Ok(placed(id, None, attempt, &dir, None))
    }

    /// One array (a task per member) or group jobs (up to `group` members
    /// each) in a directory of their own.
    fn submit_batch(
        &self,
        store: &Store,
        members: &[Member],
        r: &Resolved,
        group: bool,
    ) -> Result<Vec<Submission>, ExecutorError> {
        if let [one] = members {
            return Ok(vec![self.submit_alone(store, one, r, 1)?]);
        }
        let dir = store.root().join("jobs").join(
            store
                .temp_path("batch")
                .file_name()
                .map_or_else(|| "batch".into(), |n| n.to_os_string()),
        );
        std::fs::create_dir_all(dir.join("log")).map_err(|cause| ExecutorError::CreateDir {
            path: dir.clone(),
            cause,
        })?;
        let keys: Vec<&str> = members.iter().map(|m| m.key.as_str()).collect();
        std::fs::write(dir.join("members"), keys.join("\n")).map_err(|cause| {
            ExecutorError::Write {
                path: dir.clone(),
                cause,
            }
        })?;
        let size = if group { r.group } else { MAX_SHARDS };
        let mut out = Vec::new();
        for (n, chunk) in members.chunks(size).enumerate() {
            let descriptions: Vec<PathBuf> = chunk.iter().map(|m| m.description.clone()).collect();
            let tasks: Vec<usize> = (0..chunk.len()).collect();
            let names: Vec<&str> = chunk.iter().map(|m| m.stage.as_str()).collect();
            let name = format!("{} (+{})", names[0], names.len() - 1);
            let script = Script {
                name: &name,
                dir: &dir,
                resources: r,
                attempt: 1,
                tasks: (!group).then_some(tasks.as_slice()),
                binary: &self.binary,
                cache: store.root(),
                body: if group {
                    Body::Group(&descriptions)
                } else {
                    Body::PerTask(&descriptions)
                },
            };
            let id = send(&dir.join(format!("batch-{n}.sh")), &script)?;
            for i in 0..chunk.len() {
                let tasks = (!group).then(|| vec![i]);
                out.push(placed(id.clone(), tasks, 1, &dir, Some(dir.clone())));
            }
        }
        if let Ok(mut b) = self.batches.lock() {
            b.insert(dir, members.len());
        }
        Ok(out)
    }

    /// A member of a shared submission is done: the directory goes once
    /// every member committed, and stays (logs) after a failure.
    fn batch_done(&self, sub: &Submission, ok: bool) {
        let Some(dir) = &sub.batch else {
            return;
        };
        let Ok(mut batches) = self.batches.lock() else {
            return;
        };
        if !ok {
            batches.remove(dir);
        } else if let Some(n) = batches.get_mut(dir) {
            *n -= 1;
            if *n == 0 {
                batches.remove(dir);
                let _ = std::fs::remove_dir_all(dir);
            }
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn note(
        &self,
        job: &Job,
        unit: &str,
        sub: &Submission,
        state: &str,
        exit: String,
        start: Instant,
        adopted: bool,
    ) {
        let row = JobRow {
            stage: job.stage.clone(),
            key: job.key.clone(),
            unit: unit.to_string(),
            id: sub.id.clone(),
            tasks: sub.tasks.clone(),
            attempt: sub.attempt,
            state: state.to_string(),
            exit,
            submitted: sub.submitted,
            waited: start.elapsed().as_secs_f64(),
            adopted,
        };
        if let Ok(mut jobs) = self.jobs.lock() {
            jobs.push(row);
        }
    }
}

/// Write `script` to `path` and submit it; a script with a value that
/// cannot go into it is neither written nor submitted.
fn send(path: &Path, script: &Script) -> Result<String, ExecutorError> {
    let text = script.text().map_err(|cause| ExecutorError::Script {
        path: path.to_path_buf(),
        cause,
    })?;
    std::fs::write(path, text).map_err(|cause| ExecutorError::Write {
        path: path.to_path_buf(),
        cause,
    })?;
    queue::submit(path)
}

fn placed(
    id: String,
    tasks: Option<Vec<usize>>,
    attempt: u32,
    dir: &Path,
    batch: Option<PathBuf>,
) -> Submission {
    Submission {
        id,
        tasks,
        attempt,
        log_dir: dir.join("log"),
        batch,
        submitted: inflight::now(),
        by: inflight::by(),
    }
}

/// The stage's record is committed and its objects verify.
fn finished(store: &Store, key: &str) -> bool {
    store.record(key).is_some_and(|r| {
        r.outputs
            .values()
            .all(|o| store.verify(&o.artifact).is_ok())
    })
}

/// The stage's error: which job or task ended how, what to do, its log's tail.
fn failure(s: &Submission, ended: &Ended, store: &Store, job: &Job, attempt: u32) -> String {
    let id = &s.id;
    let (mut text, log) = match ended {
        Ended::Vanished => (
            format!(
                "slurm job {id} left the queue without a result in the cache ({})",
                store.root().display()
            ),
            s.log(None),
        ),
        Ended::Terminal(states) => {
            let bad: Vec<&TaskState> = states.iter().filter(|t| t.state != "COMPLETED").collect();
            match bad.first() {
                Some(first) => {
                    let mut t = format!("slurm job {} {}", first.id, first.state);
                    if let Some(exit) = &first.exit {
                        let _ = write!(t, " (exit {exit})");
                    }
                    if bad.len() > 1 {
                        let _ = write!(t, "; {} of {} tasks failed", bad.len(), states.len());
                    }
                    if attempt > 1 {
                        let _ = write!(t, " at attempt {attempt}");
                    }
                    t.push_str(&advice(&first.state, &job.material.kind));
                    (t, s.log(first.task))
                }
                None => (
                    format!(
                        "slurm job {id} COMPLETED but its result is not in the cache at {}: \
                         the cache must be on a file system shared by this machine and the compute nodes",
                        store.root().display()
                    ),
                    s.log(None),
                ),
            }
        }
    };
    match std::fs::read_to_string(&log) {
        Ok(content) => {
            let lines: Vec<&str> = content.lines().collect();
            let tail = &lines[lines.len().saturating_sub(LOG_TAIL)..];
            let _ = write!(text, "\n  log {}:", log.display());
            for l in tail {
                let _ = write!(text, "\n    {l}");
            }
        }
        Err(_) => {
            let _ = write!(text, "\n  no log at {}", log.display());
        }
    }
    text
}

fn advice(state: &str, kind: &str) -> String {
    match state {
        "TIMEOUT" => format!(
            "; raise `time` in the pipeline's executor block (for this kind: `kinds: {{{kind}: {{time: ...}}}}`), \
             or let it grow with `retries: 1` and `time: \"... * attempt\"`"
        ),
        "OUT_OF_MEMORY" => format!(
            "; raise `memory` in the pipeline's executor block (for this kind: `kinds: {{{kind}: {{memory: ...}}}}`), \
             or let it grow with `retries: 1` and `memory: 4G * attempt`"
        ),
        "CANCELLED" => "; the job was cancelled (scancel, or by the administrator)".into(),
        "NODE_FAIL" | "BOOT_FAIL" => "; a node failed: run again to resubmit, or set `retries`".into(),
        _ => String::new(),
    }
}
