//! Executors: where a stage that has to be computed runs.
//!
//! - `local` runs the stage kind in the `modalflow run` process;
//! - `slurm` writes a [`job::Job`] description into the shared cache and
//!   submits `modalflow exec` as a batch job ([`slurm`]); a shardable
//!   stage's batch is split over a job array and merged by a final job.
//!
//! Both end in [`exec::run`], the one code path that runs a kind and commits
//! its objects and run record. The engine ([`super::execute`]) keeps the
//! rest: keys, the key lock, cache lookup, results. Nothing about the
//! executor enters a key, so a stage computed on a cluster is a cache hit
//! locally and the other way round.

pub mod batch;
pub mod config;
pub mod error;
pub mod exec;
pub mod inflight;
pub mod interrupt;
pub mod job;
pub mod monitor;
pub mod queue;
pub mod resources;
pub mod script;
pub mod slurm;

pub use config::{ExecutorKind, ExecutorSpec};
pub use error::ExecutorError;

use super::store::{RunRecord, Store};
use crate::stages::Progress;
use exec::{Finished, JobError, Role, Run};
use job::Job;

/// The executor of one `modalflow run`.
pub enum Executor {
    Local,
    Slurm(Box<slurm::Slurm>),
}

impl Executor {
    /// The executor `kind` configured by `spec` (the pipeline's block).
    pub fn new(kind: ExecutorKind, spec: &ExecutorSpec) -> Result<Executor, ExecutorError> {
        Ok(match kind {
            ExecutorKind::Local => Executor::Local,
            ExecutorKind::Slurm => {
                let slurm = slurm::Slurm::new(spec)?;
                Executor::Slurm(Box::new(slurm))
            }
        })
    }

    /// Compute the stage described by `job` and return its committed record.
    pub fn compute(
        &self,
        store: &Store,
        job: Job,
        progress: &dyn Progress,
    ) -> Result<RunRecord, JobError> {
        match self {
            Executor::Slurm(s) => {
                let resources = s.spec().resources(&job.material.kind, &job.stage);
                if resources.local {
                    local(store, &job, progress)
                } else {
                    s.compute(store, job, &resources, progress)
                        .map_err(JobError::from)
                }
            }
            Executor::Local => local(store, &job, progress),
        }
    }

    /// The jobs the Slurm executor waited on (empty for local runs).
    pub fn jobs(&self) -> Vec<crate::pipeline::trace::JobRow> {
        match self {
            Executor::Slurm(s) => s.jobs(),
            Executor::Local => Vec::new(),
        }
    }

    /// Whether stage `stage` of kind `kind` runs in this process.
    pub fn is_local(&self, kind: &str, stage: &str) -> bool {
        match self {
            Executor::Slurm(s) => s.spec().resources(kind, stage).local,
            Executor::Local => true,
        }
    }
}

/// Run the whole stage in this process.
pub fn local(store: &Store, job: &Job, progress: &dyn Progress) -> Result<RunRecord, JobError> {
    let call = Run {
        job,
        role: Role::Whole,
        verify_files: false,
        scratch: None,
    };
    match exec::run(store, &call, progress)? {
        Finished::Record(r) => Ok(*r),
        Finished::Shard(_) => Err(JobError::Stage(
            "a whole run ended as a shard (a bug, please report)".into(),
        )),
    }
}
