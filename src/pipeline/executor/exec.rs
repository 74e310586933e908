//! Running a stage job: [`run`] is the one code path that runs a stage kind
//! in a scratch directory and commits its outputs and run record (objects
//! first, record last) — or, for one task of a job array, its shard's
//! partial result. The local executor calls it in-process; `modalflow exec`
//! calls it on a cluster node through [`exec`], from a [`Job`] description.

use super::error::ExecutorError;
use super::job::{self, Job, ShardRecord};
use crate::pipeline::store::{self, err, ArtifactKind, OutputRecord, RunRecord, Store, StoreError};
use crate::stages::shard::{Batch, Role as BatchRole};
use crate::stages::{self, InputSource, NoProgress, Progress, Stage, StageContext, StageError};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Why a stage job did not commit a result.
#[derive(Debug, thiserror::Error)]
pub enum JobError {
    /// The stage failed: bad input, a failing command, a kind's error.
    #[error("{0}")]
    Stage(String),
    /// The cache or the file system failed while preparing or committing
    /// the stage (full disk, read-only storage): the whole run stops with
    /// exit code 3.
    #[error(transparent)]
    Store(#[from] StoreError),
    /// The stage's own writes failed for lack of storage (full disk, quota,
    /// read-only file system): a file-system failure like `Store`, not the
    /// stage's fault.
    #[error("{0}")]
    Storage(String),
}

impl From<String> for JobError {
    fn from(message: String) -> JobError {
        JobError::Stage(message)
    }
}

/// Which part of the stage this run does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Role {
    /// The whole stage (merging `Job::partials` when there are any).
    Whole,
    /// Shard `index` of `Job::shards`.
    Shard(usize),
}

/// What a run committed.
#[derive(Debug)]
pub enum Finished {
    Record(Box<RunRecord>),
    Shard(ShardRecord),
}

/// One run of a stage job: what runs (the job, with its kind and parsed
/// params), and which part of it.
pub struct Run<'a> {
    pub job: &'a Job,
    pub role: Role,
    /// Check the files the key hashed before running (a job on another host
    /// must see the same pipeline directory).
    pub verify_files: bool,
    /// Node-local directory for the stage's scratch and input checkouts
    /// (`scratch:` of the executor block); `None`: the cache's `tmp/`.
    pub scratch: Option<PathBuf>,
}

/// Run (the `role` part of) the stage in a scratch directory and commit the
/// result: the outputs and run record, or a shard's partial and its record.
pub fn run(store: &Store, run: &Run, progress: &dyn Progress) -> Result<Finished, JobError> {
    let (inputs_dir, scratch, own) = match &run.scratch {
        Some(root) => {
            // Named like the cache's temp paths, unique across processes.
            let name = store.temp_path("node");
            let own = root.join(name.file_name().unwrap_or_default());
            (own.join("in"), own.join("stage"), Some(own))
        }
        None => (store.temp_path("in"), store.temp_path("stage"), None),
    };
    let result = run_in(store, run, progress, &inputs_dir, &scratch);
    let _ = std::fs::remove_dir_all(&scratch);
    let _ = std::fs::remove_dir_all(&inputs_dir);
    if let Some(own) = own {
        let _ = std::fs::remove_dir_all(own);
    }
    result
}

fn run_in(
    store: &Store,
    run: &Run,
    progress: &dyn Progress,
    inputs_dir: &Path,
    scratch: &Path,
) -> Result<Finished, JobError> {
    let Run {
        job,
        role,
        verify_files,
        ..
    } = *run;
    let typed = job.typed()?;
    let kind = typed.kind;
    std::fs::create_dir_all(scratch).map_err(err("create directory", scratch))?;
    let (inputs, sources) = checkout_inputs(store, job, inputs_dir)?;
    restore_workspace(store, job)?;
    if verify_files {
        verify_param_files(job)?;
    }
    let batch = batch_of(store, job, role, scratch);
    let ctx = StageContext {
        stage: &job.stage,
        seed: job.seed,
        inputs: &inputs,
        sources: &sources,
        pipeline: &job.pipeline,
        pipeline_dir: &job.pipeline_dir,
        scratch,
        progress,
        batch: &batch,
        upstream_warnings: &job.material.upstream_warnings,
    };
    let start = Instant::now();
    let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        kind.run(&typed.params, &ctx)
    }));
    let seconds = start.elapsed().as_secs_f64();
    if let Role::Shard(index) = role {
        return commit_shard(store, job, kind, &batch, outcome, index, seconds);
    }
    let produced = match outcome {
        Ok(Ok(p)) => p,
        Ok(Err(e)) if out_of_storage(&e) => return Err(JobError::Storage(stage_error_text(&e))),
        Ok(Err(e)) => return Err(stage_error_text(&e).into()),
        Err(panic) => return Err(panic_text(kind, panic).into()),
    };
    let outputs = commit_outputs(store, job, kind, &produced.files, scratch)?;
    let record = RunRecord {
        key: job.key.clone(),
        kind: kind.kind().to_string(),
        version: kind.version(),
        stage: job.stage.clone(),
        outputs,
        seconds: seconds + job.partial_seconds,
        counters: produced.counters,
        warnings: produced.warnings,
        modalflow_version: env!("CARGO_PKG_VERSION").to_string(),
        checksum: String::new(),
    };
    store.write_record(&record)?;
    Ok(Finished::Record(Box::new(record)))
}

/// The paths of the stage's inputs, per input name.
type InputPaths = BTreeMap<String, Vec<PathBuf>>;
/// Where each of the stage's inputs came from, per input name.
type InputSources = BTreeMap<String, Vec<InputSource>>;

/// Where the kind finds the stage's inputs: per input name, the paths of
/// its objects in the cache (a directory object is checked out below
/// `inputs_dir`) and the stage output each one came from. An object missing
/// from the cache (a host that does not share it) fails here, before the
/// kind runs.
fn checkout_inputs(
    store: &Store,
    job: &Job,
    inputs_dir: &Path,
) -> Result<(InputPaths, InputSources), JobError> {
    let mut inputs: BTreeMap<String, Vec<PathBuf>> = BTreeMap::new();
    let mut sources: BTreeMap<String, Vec<InputSource>> = BTreeMap::new();
    for (name, list) in &job.inputs {
        let mut paths = Vec::new();
        for (k, input) in list.iter().enumerate() {
            let object = store.object_path(&input.artifact.hash);
            if !object.exists() {
                return Err(JobError::Stage(format!(
                    "input `{name}` ({}.{}): object {} is not in the cache at {}; \
                     the cache must be on a file system this host shares",
                    input.stage,
                    input.output,
                    input.artifact.hash,
                    store.root().display()
                )));
            }
            let path = match input.artifact.kind {
                ArtifactKind::File => object,
                ArtifactKind::Dir => {
                    // The file name comes from a record: it must stay below.
                    let file = crate::paths::relative(&input.file).map_err(|problem| {
                        JobError::Stage(format!(
                            "input `{name}` ({}.{}): file name `{}` {problem}",
                            input.stage,
                            input.output,
                            input.file.escape_debug()
                        ))
                    })?;
                    let p = inputs_dir.join(name).join(k.to_string()).join(file);
                    store.checkout(&input.artifact, &p)?;
                    p
                }
            };
            paths.push(path);
        }
        inputs.insert(name.clone(), paths);
        let labels = list.iter().map(|i| InputSource {
            stage: i.stage.clone(),
            output: i.output.clone(),
            matrix: i.matrix.clone(),
        });
        sources.insert(name.clone(), labels.collect());
    }
    Ok((inputs, sources))
}

/// The batch the kind runs: the whole stage, the merge of the shards'
/// partials, or shard `index` of `job.shards` writing its partial into
/// `scratch`.
fn batch_of(store: &Store, job: &Job, role: Role, scratch: &Path) -> Batch {
    match role {
        Role::Whole if job.partials.is_empty() => Batch::whole(),
        Role::Whole => Batch::new(BatchRole::Merge {
            partials: job
                .partials
                .iter()
                .map(|a| store.object_path(&a.hash))
                .collect(),
        }),
        Role::Shard(index) => Batch::new(BatchRole::Shard {
            index,
            count: job.shards,
            out: scratch.join(format!("partial-{index}")),
        }),
    }
}

/// Put the outputs the kind produced (`files`, relative to `scratch`) into
/// the cache and return their records by output name; a missing output or a
/// link among them is the stage's fault, a failing cache the run's.
fn commit_outputs(
    store: &Store,
    job: &Job,
    kind: &dyn Stage,
    files: &[(String, PathBuf)],
    scratch: &Path,
) -> Result<BTreeMap<String, OutputRecord>, JobError> {
    let mut outputs = BTreeMap::new();
    for name in &job.outputs {
        let Some((_, path)) = files.iter().find(|(n, _)| n == name) else {
            return Err(JobError::Stage(format!(
                "kind `{}` did not produce its output `{name}`",
                kind.kind()
            )));
        };
        let full = if path.is_absolute() {
            path.clone()
        } else {
            scratch.join(path)
        };
        let file = if job.workspace_outputs {
            name.clone()
        } else {
            path.file_name()
                .map(|f| f.to_string_lossy().into_owned())
                .unwrap_or_else(|| name.clone())
        };
        let artifact = store.put(&full).map_err(|e| match e.cause.kind() {
            // A link among the outputs is the stage's fault, not the cache's.
            std::io::ErrorKind::InvalidInput => JobError::Stage(format!(
                "output `{name}`: {e}; fix the command or the outs list"
            )),
            _ => JobError::Store(e),
        })?;
        outputs.insert(name.clone(), OutputRecord { file, artifact });
    }
    Ok(outputs)
}

type RunResult = std::thread::Result<Result<stages::StageOutputs, StageError>>;

/// A shard succeeded when it wrote its partial, whatever the stage returned
/// after that (it stops with [`crate::simulator::EvalError::Sharded`]).
fn commit_shard(
    store: &Store,
    job: &Job,
    kind: &dyn Stage,
    batch: &Batch,
    run: RunResult,
    index: usize,
    seconds: f64,
) -> Result<Finished, JobError> {
    let Some(partial) = batch.written() else {
        return Err(JobError::Stage(match run {
            Ok(Err(e)) => stage_error_text(&e),
            Err(panic) => panic_text(kind, panic),
            Ok(Ok(_)) => format!(
                "kind `{}` finished without handing a batch to its shard; it cannot be sharded \
                 with these params (set `shards: 1`)",
                kind.kind()
            ),
        }));
    };
    let artifact = store.put(&partial)?;
    let rec = ShardRecord {
        index,
        count: job.shards,
        seconds,
        artifact,
    };
    let path = job::shard_record_path(store, &job.key, index, job.shards);
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(err("create directory", dir))?;
    }
    let json = serde_json::to_vec_pretty(&rec).map_err(ExecutorError::Serialize)?;
    store.write_atomic(&path, &json)?;
    Ok(Finished::Shard(rec))
}

/// DVC semantics: a dep that another stage writes into the workspace is put
/// back from the cache when it is missing or differs.
fn restore_workspace(store: &Store, job: &Job) -> Result<(), StoreError> {
    for r in &job.restore {
        let dest = crate::pipeline::execute::workspace_path(&job.pipeline_dir, &r.path)?;
        if store::hash_path(&dest).ok().as_deref() != Some(r.artifact.hash.as_str()) {
            store.checkout(&r.artifact, &dest)?;
        }
    }
    Ok(())
}

fn verify_param_files(job: &Job) -> Result<(), ExecutorError> {
    for (path, hash) in &job.material.files {
        let full = job.pipeline_dir.join(path);
        let seen = store::hash_path(&full).map_err(|cause| ExecutorError::ReadParamFile {
            path: path.clone(),
            full: full.clone(),
            cause,
        })?;
        if &seen != hash {
            return Err(ExecutorError::ParamFileDiffers {
                path: path.clone(),
                dir: job.pipeline_dir.clone(),
            });
        }
    }
    Ok(())
}

/// What `modalflow exec` did.
#[derive(Debug)]
pub enum ExecOutcome {
    Ran(Finished),
    /// The result was already in the cache (a requeued or repeated job).
    AlreadyDone,
}

/// `modalflow exec`: read the job description at `path` and run it (or
/// shard `shard` of it) against `store`. The submitting process holds the
/// key's lock; the job takes the cache's shared lock against `gc`.
pub fn exec(
    store: &Store,
    path: &Path,
    shard: Option<usize>,
    scratch: Option<&Path>,
) -> Result<ExecOutcome, ExecutorError> {
    let _guard = store.lock_cache(false)?;
    let mut job = Job::read(path)?;
    job.check()?;
    let role = match shard {
        None => Role::Whole,
        Some(i) if job.shards > 1 && i < job.shards => Role::Shard(i),
        Some(i) if job.shards > 1 => {
            return Err(ExecutorError::NoSuchShard {
                stage: job.stage.clone(),
                index: i,
                count: job.shards,
            })
        }
        Some(i) => {
            return Err(ExecutorError::NotSharded {
                stage: job.stage.clone(),
                index: i,
            })
        }
    };
    let done = match role {
        Role::Whole => store.record(&job.key).is_some_and(|r| {
            r.outputs
                .values()
                .all(|o| store.verify(&o.artifact).is_ok())
        }),
        Role::Shard(i) => job::shard_record(store, &job.key, i, job.shards).is_some(),
    };
    if done {
        return Ok(ExecOutcome::AlreadyDone);
    }
    let call = Run {
        job: &job,
        role,
        verify_files: true,
        scratch: scratch.map(Path::to_path_buf),
    };
    run(store, &call, &NoProgress)
        .map(ExecOutcome::Ran)
        .map_err(ExecutorError::Job)
}

fn panic_text(kind: &dyn Stage, panic: Box<dyn std::any::Any + Send>) -> String {
    let what = panic
        .downcast_ref::<String>()
        .cloned()
        .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
        .unwrap_or_default();
    format!(
        "internal error in kind `{}` (a bug, please report): {what}",
        kind.kind()
    )
}

/// Whether a stage failed because the storage refused its writes.
fn out_of_storage(e: &StageError) -> bool {
    use std::io::ErrorKind as K;
    matches!(e, StageError::Io { source, .. }
        if matches!(source.kind(), K::StorageFull | K::QuotaExceeded | K::ReadOnlyFilesystem))
}

/// A stage error with its sources, each once.
pub fn stage_error_text(e: &StageError) -> String {
    let mut s = e.to_string();
    let mut src = std::error::Error::source(e);
    while let Some(inner) = src {
        let t = inner.to_string();
        if !s.contains(&t) {
            s.push_str(": ");
            s.push_str(&t);
        }
        src = inner.source();
    }
    s
}
