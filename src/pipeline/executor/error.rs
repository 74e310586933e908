//! Why an executor could not hand a stage to its runner or see it through:
//! job descriptions that cannot be read, written or trusted, `modalflow
//! exec` asked for what a job does not have, and Slurm submissions and jobs
//! that fail. Messages name the file, job or stage and what to do; an
//! underlying error's text is part of the message, not a separate source,
//! so a printed chain does not repeat it (as [`StoreError`]).

use super::exec::JobError;
use super::job::FORMAT;
use super::script::ScriptError;
use crate::pipeline::store::StoreError;
use std::path::PathBuf;
use std::process::ExitStatus;
use std::sync::Arc;

/// Why an executor failed a stage or a `modalflow exec` call.
#[derive(Debug, thiserror::Error)]
pub enum ExecutorError {
    /// A job was run without its parsed params (a bug).
    #[error("job {stage}: its params were not parsed (a bug, please report)")]
    NotParsed { stage: String },
    /// The job description file could not be read.
    #[error("cannot read job description {}: {cause}", path.display())]
    ReadDescription {
        path: PathBuf,
        cause: std::io::Error,
    },
    /// The job description is not the JSON of a job.
    #[error("job description {}: {cause}", path.display())]
    ParseDescription {
        path: PathBuf,
        cause: serde_json::Error,
    },
    /// The job description has a format version this binary does not read.
    #[error(
        "job description {} has format {found}, this modalflow reads {FORMAT}: \
         run the same modalflow version on the submitting machine and the compute nodes",
        path.display()
    )]
    Format { path: PathBuf, found: u32 },
    /// A job description or in-flight record could not be serialized.
    #[error("{0}")]
    Serialize(serde_json::Error),
    /// The cache failed (its lock, an atomic write).
    #[error(transparent)]
    Store(#[from] StoreError),
    /// The job names a stage kind this binary does not have.
    #[error("job {stage}: unknown stage kind `{kind}`; is the job run by an older modalflow?")]
    UnknownKind { stage: String, kind: String },
    /// The job's kind version differs from this binary's.
    #[error(
        "job {stage}: kind `{kind}` is version {job} in the job but {this} in this modalflow: \
         run the same modalflow version on the submitting machine and the compute nodes"
    )]
    KindVersion {
        stage: String,
        kind: String,
        job: u32,
        this: u32,
    },
    /// The job's params are not YAML.
    #[error("job {stage}: params: {cause}")]
    ParamsYaml {
        stage: String,
        cause: serde_yaml_ng::Error,
    },
    /// The job's params do not parse for its kind (the problems, joined).
    #[error("job {stage}: params: {problems}")]
    ParamProblems { stage: String, problems: String },
    /// The description's params or key do not match its key.
    #[error("job {stage}: the description does not match its key {key}; it was edited or damaged")]
    KeyMismatch { stage: String, key: String },
    /// A file the key hashed cannot be read on this host.
    #[error("cannot read `{path}` at {}: {cause}", full.display())]
    ReadParamFile {
        path: String,
        full: PathBuf,
        cause: std::io::Error,
    },
    /// A file the key hashed has other content on this host.
    #[error(
        "`{path}` differs on this host from what the key hashed: the pipeline \
         directory {} must be on a file system shared with the submitting machine, \
         and not edited while the run is on",
        dir.display()
    )]
    ParamFileDiffers { path: String, dir: PathBuf },
    /// `--shard` names a shard beyond the job's.
    #[error(
        "job {stage}: shard {index} does not exist (the job has {count} shards, 0..{})",
        .count - 1
    )]
    NoSuchShard {
        stage: String,
        index: usize,
        count: usize,
    },
    /// `--shard` for a job that is not sharded.
    #[error(
        "job {stage}: shard {index} does not exist (the job is not sharded); run it without --shard"
    )]
    NotSharded { stage: String, index: usize },
    /// The stage job ran but did not commit a result.
    #[error(transparent)]
    Job(#[from] JobError),
    /// The path of this binary is unknown and `executor.binary` is not set.
    #[error("cannot find the modalflow binary ({cause}); set `executor.binary`")]
    NoBinary { cause: std::io::Error },
    /// A job directory could not be created.
    #[error("cannot create {}: {cause}", path.display())]
    CreateDir {
        path: PathBuf,
        cause: std::io::Error,
    },
    /// A job script or a batch's member list could not be written.
    #[error("cannot write {}: {cause}", path.display())]
    Write {
        path: PathBuf,
        cause: std::io::Error,
    },
    /// A value cannot go into the job script at `path`.
    #[error("job script {}: {cause}", path.display())]
    Script { path: PathBuf, cause: ScriptError },
    /// `sbatch` could not be started.
    #[error("cannot run sbatch ({cause}); is Slurm installed and on PATH on this machine?")]
    SbatchMissing { cause: std::io::Error },
    /// `sbatch` refused the script or answered without a job id (its
    /// stderr and stdout, trimmed).
    #[error("sbatch {} failed ({status}): {stderr}{stdout}", script.display())]
    SbatchFailed {
        script: PathBuf,
        status: ExitStatus,
        stderr: String,
        stdout: String,
    },
    /// A shard task ended without recording its partial result.
    #[error("shard {index} of {count} left no partial result")]
    MissingShard { index: usize, count: usize },
    /// The stage's run record was gone after its job committed it.
    #[error("the run record of {key} vanished from the cache")]
    RecordVanished { key: String },
    /// A job or task ended without the stage's result: which one, how,
    /// what to do and the tail of its log.
    #[error("{0}")]
    JobEnded(String),
    /// The submission of a batch failed; every member gets its error.
    #[error(transparent)]
    Batch(Arc<ExecutorError>),
    /// A batch member got no answer from the batch's submission (a bug).
    #[error("the batch's submission ended without an answer (a bug)")]
    NoAnswer,
}

/// A stage job that could not be prepared or submitted fails the stage with
/// the error's message (the engine tells stage failures from the cache's
/// by [`JobError`]).
impl From<ExecutorError> for JobError {
    fn from(e: ExecutorError) -> JobError {
        JobError::Stage(e.to_string())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_read_as_the_former_strings() {
        let e = ExecutorError::NoSuchShard {
            stage: "gsa".into(),
            index: 5,
            count: 3,
        };
        assert_eq!(
            e.to_string(),
            "job gsa: shard 5 does not exist (the job has 3 shards, 0..2)"
        );
        let e = ExecutorError::Format {
            path: "/c/jobs/k/job.json".into(),
            found: 9,
        };
        assert_eq!(
            e.to_string(),
            format!(
                "job description /c/jobs/k/job.json has format 9, this modalflow reads {FORMAT}: \
                 run the same modalflow version on the submitting machine and the compute nodes"
            )
        );
        let e = ExecutorError::Batch(Arc::new(ExecutorError::MissingShard { index: 1, count: 4 }));
        assert_eq!(e.to_string(), "shard 1 of 4 left no partial result");
        let e = JobError::from(ExecutorError::NotParsed { stage: "a".into() });
        assert!(matches!(&e, JobError::Stage(m)
            if m == "job a: its params were not parsed (a bug, please report)"));
    }
}
