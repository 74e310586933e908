//! The Slurm executor: a stage becomes a batch job running `modalflow exec`
//! on the job description in the shared cache (`cache/jobs/<key>/`), as
//! Snakemake's and Nextflow's Slurm executors do with their job scripts.
//!
//! A shardable stage with `shards: m > 1` runs in two steps: a job array of
//! m tasks, each evaluating one slice of the stage's batch and recording its
//! partial result (`shards/<m>-<i>.json`), then one merge job that runs the
//! stage with the partials in place of the evaluations. Shards recorded by
//! an earlier, interrupted or failed attempt are reused.
//!
//! A job that ends without its result fails the stage with the job id, the
//! scheduler's state and the tail of its log; the job directory (description,
//! script, logs) is kept for inspection and removed after a success.

use super::config::{ExecutorSpec, Resolved};
use super::interrupt::{self, Live};
use super::job::{self, Job};
use super::queue::{self, Ended, TaskState};
use crate::pipeline::store::{RunRecord, Store};
use crate::stages::Progress;
use std::fmt::Write;
use std::path::{Path, PathBuf};

/// Lines of a failed job's log quoted in the error.
const LOG_TAIL: usize = 15;

/// The Slurm executor of one run.
pub struct Slurm {
    spec: ExecutorSpec,
    binary: PathBuf,
}

/// One submission: its script and how its logs are named.
struct Submission<'a> {
    description: &'a Path,
    script: PathBuf,
    /// Array task indices, or `None` for a single job.
    tasks: Option<Vec<usize>>,
}

impl Slurm {
    pub fn new(spec: &ExecutorSpec) -> Result<Slurm, String> {
        let binary = match &spec.binary {
            Some(b) => b.clone(),
            None => std::env::current_exe().map_err(|e| {
                format!("cannot find the modalflow binary ({e}); set `executor.binary`")
            })?,
        };
        interrupt::install();
        Ok(Slurm {
            spec: spec.clone(),
            binary,
        })
    }

    pub fn spec(&self) -> &ExecutorSpec {
        &self.spec
    }

    /// Compute the stage as one job, or as a job array plus a merge job.
    pub fn compute(
        &self,
        store: &Store,
        mut job: Job,
        resources: &Resolved,
        progress: &dyn Progress,
    ) -> Result<RunRecord, String> {
        let typed = job.typed()?.clone();
        let dir = store.job_dir(&job.key);
        if finished(store, &job.key) {
            // A forced recompute: the job and this process could not tell the
            // old result from the new one, so the old one goes first, with
            // any shards of earlier attempts.
            store.remove_record(&job.key);
            let _ = std::fs::remove_dir_all(&dir);
        }
        std::fs::create_dir_all(dir.join("log"))
            .map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
        let sharded = resources.shards > 1 && typed.kind.shardable(&typed.params);
        if sharded {
            job.shards = resources.shards;
            let description = dir.join("job.json");
            job.write(store, &description)?;
            let count = job.shards;
            let missing: Vec<usize> = (0..count)
                .filter(|&i| job::shard_record(store, &job.key, i, count).is_none())
                .collect();
            if !missing.is_empty() {
                let submission = Submission {
                    description: &description,
                    script: dir.join("shards.sh"),
                    tasks: Some(missing),
                };
                let key = job.key.clone();
                let ready =
                    || (0..count).all(|i| job::shard_record(store, &key, i, count).is_some());
                self.run_job(store, &job, resources, &submission, &ready, progress)?;
            }
            for i in 0..count {
                let rec = job::shard_record(store, &job.key, i, count)
                    .ok_or_else(|| format!("shard {i} of {count} left no partial result"))?;
                job.partial_seconds += rec.seconds;
                job.partials.push(rec.artifact);
            }
        }
        // One job runs the stage: the whole of it, or the merge of the shards.
        let name = if sharded { "merge" } else { "job" };
        let description = dir.join(format!("{name}.json"));
        job.write(store, &description)?;
        let submission = Submission {
            description: &description,
            script: dir.join(format!("{name}.sh")),
            tasks: None,
        };
        self.run_job(
            store,
            &job,
            resources,
            &submission,
            &|| finished(store, &job.key),
            progress,
        )?;
        let record = store
            .record(&job.key)
            .ok_or_else(|| format!("the run record of {} vanished from the cache", job.key))?;
        let _ = std::fs::remove_dir_all(&dir);
        Ok(record)
    }

    /// Write the script, submit it, wait; a failure names the job and quotes its log.
    fn run_job(
        &self,
        store: &Store,
        job: &Job,
        resources: &Resolved,
        submission: &Submission,
        ready: &dyn Fn() -> bool,
        progress: &dyn Progress,
    ) -> Result<(), String> {
        let text = self.script(store, job, resources, submission);
        std::fs::write(&submission.script, text)
            .map_err(|e| format!("cannot write {}: {e}", submission.script.display()))?;
        let id = queue::submit(&submission.script)?;
        let _live = Live::register(&id);
        progress.set_message(format!("slurm job {id}: submitted"));
        match queue::wait(&id, ready, self.spec.poll_max(), progress) {
            Ok(()) => Ok(()),
            Err(ended) => Err(failure(&id, submission, &ended, store, job)),
        }
    }

    /// The batch script: resources as `#SBATCH` lines, then `modalflow exec`.
    fn script(&self, store: &Store, job: &Job, r: &Resolved, s: &Submission) -> String {
        let dir = store.job_dir(&job.key);
        let mut t = String::from("#!/bin/sh\n");
        let name: String = job
            .stage
            .chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() || "_-.,=[]".contains(c) {
                    c
                } else {
                    '_'
                }
            })
            .collect();
        let log = match s.tasks {
            Some(_) => "%A_%a.out",
            None => "%j.out",
        };
        let mut line = |opt: String| {
            let _ = writeln!(t, "#SBATCH {opt}");
        };
        line(format!("--job-name=modalflow:{name}"));
        line(format!("--chdir={}", dir.display()));
        line(format!("--output={}", dir.join("log").join(log).display()));
        line(format!("--cpus-per-task={}", r.cpus));
        if let Some(tasks) = &s.tasks {
            line(format!("--array={}", array_spec(tasks)));
        }
        for (opt, value) in [
            ("partition", &r.partition),
            ("account", &r.account),
            ("time", &r.time),
            ("mem", &r.memory),
        ] {
            if let Some(v) = value {
                line(format!("--{opt}={v}"));
            }
        }
        for extra in &r.sbatch {
            line(extra.clone());
        }
        let _ = writeln!(t, "# modalflow stage {} (key {})", job.stage, job.key);
        let _ = writeln!(
            t,
            "export RAYON_NUM_THREADS=\"${{SLURM_CPUS_PER_TASK:-1}}\""
        );
        let mut exec = format!(
            "exec {} exec --cache {} {}",
            quote(&self.binary),
            quote(store.root()),
            quote(s.description)
        );
        if s.tasks.is_some() {
            exec.push_str(" --shard \"$SLURM_ARRAY_TASK_ID\"");
        }
        let _ = writeln!(t, "{exec}");
        t
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

/// `0-3,5,7-8` from sorted task indices.
pub fn array_spec(tasks: &[usize]) -> String {
    let mut parts: Vec<String> = Vec::new();
    let mut i = 0;
    while i < tasks.len() {
        let mut j = i;
        while j + 1 < tasks.len() && tasks[j + 1] == tasks[j] + 1 {
            j += 1;
        }
        parts.push(if i == j {
            tasks[i].to_string()
        } else {
            format!("{}-{}", tasks[i], tasks[j])
        });
        i = j + 1;
    }
    parts.join(",")
}

/// A path as one single-quoted shell word.
fn quote(p: &Path) -> String {
    format!("'{}'", p.display().to_string().replace('\'', "'\\''"))
}

/// The stage's error: which job or task ended how, what to do, its log's tail.
fn failure(id: &str, s: &Submission, ended: &Ended, store: &Store, job: &Job) -> String {
    let log_dir = store.job_dir(&job.key).join("log");
    let (mut text, log) = match ended {
        Ended::Vanished => (
            format!(
                "slurm job {id} left the queue without a result in the cache ({})",
                store.root().display()
            ),
            log_of(
                &log_dir,
                id,
                s.tasks.as_ref().and_then(|t| t.first().copied()),
            ),
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
                    t.push_str(&advice(&first.state, &job.material.kind));
                    (t, log_of(&log_dir, id, first.task))
                }
                None => (
                    format!(
                        "slurm job {id} COMPLETED but its result is not in the cache at {}: \
                         the cache must be on a file system shared by this machine and the compute nodes",
                        store.root().display()
                    ),
                    log_of(&log_dir, id, s.tasks.as_ref().and_then(|t| t.first().copied())),
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

fn log_of(dir: &Path, id: &str, task: Option<usize>) -> PathBuf {
    let base = id.split('_').next().unwrap_or(id);
    match task {
        Some(t) => dir.join(format!("{base}_{t}.out")),
        None => dir.join(format!("{base}.out")),
    }
}

fn advice(state: &str, kind: &str) -> String {
    match state {
        "TIMEOUT" => format!(
            "; raise `time` in the pipeline's executor block (for this kind: `kinds: {{{kind}: {{time: ...}}}}`)"
        ),
        "OUT_OF_MEMORY" => format!(
            "; raise `memory` in the pipeline's executor block (for this kind: `kinds: {{{kind}: {{memory: ...}}}}`)"
        ),
        "CANCELLED" => "; the job was cancelled (scancel, or by the administrator)".into(),
        "NODE_FAIL" | "BOOT_FAIL" => "; a node failed: run again to resubmit".into(),
        _ => String::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn array_specs_compress_runs() {
        assert_eq!(array_spec(&[0, 1, 2, 3]), "0-3");
        assert_eq!(array_spec(&[1, 3, 4, 5, 9]), "1,3-5,9");
        assert_eq!(array_spec(&[7]), "7");
        assert_eq!(quote(Path::new("/a b/it's")), "'/a b/it'\\''s'");
    }
}
