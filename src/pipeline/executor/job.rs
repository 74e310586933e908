//! A stage run as a self-contained job: the [`Job`] description (stage key,
//! kind and version, params, seed, inputs by content hash) and [`run`], the
//! one code path that runs a stage kind in a scratch directory and commits
//! its outputs and run record (objects first, record last). The local
//! executor calls [`run`] in-process; on a cluster `modalflow exec` reads the
//! description from the shared cache and calls it ([`exec`]) without ever
//! parsing the pipeline file.

use crate::pipeline::execute::Done;
use crate::pipeline::key::{canonical_params, KeyMaterial};
use crate::pipeline::plan::{Node, Plan};
use crate::pipeline::progress::Progress;
use crate::pipeline::store::{self, Artifact, ArtifactKind, OutputRecord, RunRecord, Store};
use crate::stages::shard::{Batch, Role as BatchRole};
use crate::stages::{self, InputSource, Stage, StageContext, StageError};
use serde::{Deserialize, Serialize};
use serde_yaml_ng::{Mapping, Value};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Version of the description format.
pub const FORMAT: u32 = 1;

/// Everything one run of a stage needs.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Job {
    pub format: u32,
    pub key: String,
    /// Expanded stage name (messages, run record).
    pub stage: String,
    /// What the key was computed from; `exec` recomputes and compares.
    pub material: KeyMaterial,
    /// The params as YAML text (an exact round trip of the mapping).
    pub params: String,
    pub seed: u64,
    pub pipeline: String,
    /// Absolute directory of the pipeline file; relative params start here.
    pub pipeline_dir: PathBuf,
    /// Input name → bound artifacts in order.
    pub inputs: BTreeMap<String, Vec<JobInput>>,
    /// Workspace files another stage produced, put back before the run.
    pub restore: Vec<Restore>,
    /// Output names the run must produce.
    pub outputs: Vec<String>,
    /// Outputs are workspace paths (`command` outs): name records by output.
    pub workspace_outputs: bool,
    /// Array tasks the stage's batch is split over (1: not sharded).
    pub shards: usize,
    /// For the merge run of a sharded stage: the shards' partial results.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub partials: Vec<Artifact>,
    /// Seconds the shards spent, added to the merge's record.
    #[serde(default)]
    pub partial_seconds: f64,
}

/// One input artifact, by content hash.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct JobInput {
    /// Upstream stage and output (labels for reports).
    pub stage: String,
    pub output: String,
    /// File or directory name the upstream stage gave it.
    pub file: String,
    #[serde(flatten)]
    pub artifact: Artifact,
}

/// A workspace path (relative to the pipeline directory) and its content.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Restore {
    pub path: String,
    #[serde(flatten)]
    pub artifact: Artifact,
}

/// What one shard task left: its partial result.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ShardRecord {
    pub index: usize,
    pub count: usize,
    pub seconds: f64,
    #[serde(flatten)]
    pub artifact: Artifact,
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
    Record(RunRecord),
    Shard(ShardRecord),
}

impl Job {
    /// The description of `node` with key `key`, given finished upstream stages.
    pub fn new(
        plan: &Plan,
        node: &Node,
        key: &str,
        material: &KeyMaterial,
        done: &dyn Fn(usize) -> Option<Done>,
    ) -> Result<Job, String> {
        let output = |src: usize, out: &str| {
            done(src)
                .and_then(|d| d.outputs.get(out).cloned())
                .ok_or_else(|| format!("upstream `{}` has no output `{out}`", plan.nodes[src].name))
        };
        let mut inputs = BTreeMap::new();
        for b in &node.inputs {
            let mut list = Vec::new();
            for (src, out) in &b.sources {
                let rec = output(*src, out)?;
                list.push(JobInput {
                    stage: plan.nodes[*src].name.clone(),
                    output: out.clone(),
                    file: rec.file,
                    artifact: rec.artifact,
                });
            }
            inputs.insert(b.name.clone(), list);
        }
        let mut restore = Vec::new();
        for f in &node.files {
            if let Some((src, out)) = &f.producer {
                restore.push(Restore {
                    path: f.path.clone(),
                    artifact: output(*src, out)?.artifact,
                });
            }
        }
        let params = serde_yaml_ng::to_string(&Value::Mapping(node.params.clone()))
            .map_err(|e| format!("cannot write the params: {e}"))?;
        Ok(Job {
            format: FORMAT,
            key: key.to_string(),
            stage: node.name.clone(),
            material: material.clone(),
            params,
            seed: node.seed,
            pipeline: plan.name.clone(),
            pipeline_dir: plan.dir.clone(),
            inputs,
            restore,
            outputs: node.outputs.clone(),
            workspace_outputs: !node.workspace_outputs.is_empty(),
            shards: 1,
            partials: Vec::new(),
            partial_seconds: 0.0,
        })
    }

    /// Read a description written by [`Job::write`].
    pub fn read(path: &Path) -> Result<Job, String> {
        let bytes = std::fs::read(path)
            .map_err(|e| format!("cannot read job description {}: {e}", path.display()))?;
        let job: Job = serde_json::from_slice(&bytes)
            .map_err(|e| format!("job description {}: {e}", path.display()))?;
        if job.format != FORMAT {
            return Err(format!(
                "job description {} has format {}, this modalflow reads {FORMAT}: \
                 run the same modalflow version on the submitting machine and the compute nodes",
                path.display(),
                job.format
            ));
        }
        Ok(job)
    }

    /// Write the description atomically to `path`.
    pub fn write(&self, store: &Store, path: &Path) -> Result<(), String> {
        let json = serde_json::to_vec_pretty(self).map_err(|e| e.to_string())?;
        store.write_atomic(path, &json).map_err(|e| e.to_string())
    }

    /// The kind and params, checked against the key: the description is
    /// internally consistent and this binary has the same kind version.
    pub fn check(&self) -> Result<(&'static dyn Stage, Mapping), String> {
        let kind = stages::find(&self.material.kind).ok_or_else(|| {
            format!(
                "job {}: unknown stage kind `{}`; is the job run by an older modalflow?",
                self.stage, self.material.kind
            )
        })?;
        if kind.version() != self.material.version {
            return Err(format!(
                "job {}: kind `{}` is version {} in the job but {} in this modalflow: \
                 run the same modalflow version on the submitting machine and the compute nodes",
                self.stage,
                kind.kind(),
                self.material.version,
                kind.version()
            ));
        }
        let params = match serde_yaml_ng::from_str::<Value>(&self.params) {
            Ok(Value::Mapping(m)) => m,
            Ok(_) => Mapping::new(),
            Err(e) => return Err(format!("job {}: params: {e}", self.stage)),
        };
        if canonical_params(&Value::Mapping(params.clone())) != self.material.params
            || self.material.key() != self.key
        {
            return Err(format!(
                "job {}: the description does not match its key {}; it was edited or damaged",
                self.stage, self.key
            ));
        }
        Ok((kind, params))
    }
}

/// Where shard `index` of `count` of stage `key` records its partial.
pub fn shard_record_path(store: &Store, key: &str, index: usize, count: usize) -> PathBuf {
    store
        .job_dir(key)
        .join("shards")
        .join(format!("{count}-{index}.json"))
}

/// The shard's record, if it was written and its object verifies.
pub fn shard_record(store: &Store, key: &str, index: usize, count: usize) -> Option<ShardRecord> {
    let bytes = std::fs::read(shard_record_path(store, key, index, count)).ok()?;
    let rec: ShardRecord = serde_json::from_slice(&bytes).ok()?;
    store.verify(&rec.artifact).ok()?;
    Some(rec)
}

/// Run (the `role` part of) the stage in a scratch directory and commit the
/// result: the outputs and run record, or a shard's partial and its record.
/// With `verify_files`, the files the key hashed are checked first (a job on
/// another host must see the same pipeline directory).
pub fn run(
    store: &Store,
    job: &Job,
    kind: &dyn Stage,
    params: &Mapping,
    role: Role,
    progress: &Progress,
    verify_files: bool,
) -> Result<Finished, String> {
    let inputs_dir = store.temp_path("in");
    let scratch = store.temp_path("stage");
    let result = run_in(
        store,
        job,
        kind,
        params,
        role,
        progress,
        verify_files,
        &inputs_dir,
        &scratch,
    );
    let _ = std::fs::remove_dir_all(&scratch);
    let _ = std::fs::remove_dir_all(&inputs_dir);
    result
}

#[allow(clippy::too_many_arguments)]
fn run_in(
    store: &Store,
    job: &Job,
    kind: &dyn Stage,
    params: &Mapping,
    role: Role,
    progress: &Progress,
    verify_files: bool,
    inputs_dir: &Path,
    scratch: &Path,
) -> Result<Finished, String> {
    std::fs::create_dir_all(scratch)
        .map_err(|e| format!("cannot create scratch directory: {e}"))?;
    let mut inputs: BTreeMap<String, Vec<PathBuf>> = BTreeMap::new();
    let mut sources: BTreeMap<String, Vec<InputSource>> = BTreeMap::new();
    for (name, list) in &job.inputs {
        let mut paths = Vec::new();
        for (k, input) in list.iter().enumerate() {
            let object = store.object_path(&input.artifact.hash);
            if !object.exists() {
                return Err(format!(
                    "input `{name}` ({}.{}): object {} is not in the cache at {}; \
                     the cache must be on a file system this host shares",
                    input.stage,
                    input.output,
                    input.artifact.hash,
                    store.root().display()
                ));
            }
            let path = match input.artifact.kind {
                ArtifactKind::File => object,
                ArtifactKind::Dir => {
                    let p = inputs_dir.join(name).join(k.to_string()).join(&input.file);
                    store
                        .checkout(&input.artifact, &p)
                        .map_err(|e| e.to_string())?;
                    p
                }
            };
            paths.push(path);
        }
        inputs.insert(name.clone(), paths);
        let labels = list.iter().map(|i| InputSource {
            stage: i.stage.clone(),
            output: i.output.clone(),
        });
        sources.insert(name.clone(), labels.collect());
    }
    restore_workspace(store, job)?;
    if verify_files {
        verify_param_files(job)?;
    }
    let batch = match role {
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
    };
    let ctx = StageContext {
        stage: &job.stage,
        params,
        seed: job.seed,
        inputs: &inputs,
        sources: &sources,
        pipeline: &job.pipeline,
        pipeline_dir: &job.pipeline_dir,
        scratch,
        progress,
        batch: &batch,
    };
    let start = Instant::now();
    let run = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| kind.run(&ctx)));
    let seconds = start.elapsed().as_secs_f64();
    if let Role::Shard(index) = role {
        return commit_shard(store, job, kind, &batch, run, index, seconds);
    }
    let produced = match run {
        Ok(Ok(p)) => p,
        Ok(Err(e)) => return Err(stage_error_text(&e)),
        Err(panic) => return Err(panic_text(kind, panic)),
    };
    let mut outputs = BTreeMap::new();
    for name in &job.outputs {
        let Some((_, path)) = produced.files.iter().find(|(n, _)| n == name) else {
            return Err(format!(
                "kind `{}` did not produce its output `{name}`",
                kind.kind()
            ));
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
        let artifact = store
            .put(&full)
            .map_err(|e| format!("output `{name}`: {e}"))?;
        outputs.insert(name.clone(), OutputRecord { file, artifact });
    }
    let record = RunRecord {
        key: job.key.clone(),
        kind: kind.kind().to_string(),
        version: kind.version(),
        stage: job.stage.clone(),
        outputs,
        seconds: seconds + job.partial_seconds,
        counters: produced.counters,
        modalflow_version: env!("CARGO_PKG_VERSION").to_string(),
    };
    store.write_record(&record).map_err(|e| e.to_string())?;
    Ok(Finished::Record(record))
}

type RunResult = std::thread::Result<Result<stages::StageOutputs, StageError>>;

/// A shard succeeded when it wrote its partial, whatever the stage returned
/// after that (it stops with [`crate::evaluation::EvalError::Sharded`]).
fn commit_shard(
    store: &Store,
    job: &Job,
    kind: &dyn Stage,
    batch: &Batch,
    run: RunResult,
    index: usize,
    seconds: f64,
) -> Result<Finished, String> {
    let Some(partial) = batch.written() else {
        return Err(match run {
            Ok(Err(e)) => stage_error_text(&e),
            Err(panic) => panic_text(kind, panic),
            Ok(Ok(_)) => format!(
                "kind `{}` finished without handing a batch to its shard; it cannot be sharded \
                 with these params (set `shards: 1`)",
                kind.kind()
            ),
        });
    };
    let artifact = store.put(&partial).map_err(|e| e.to_string())?;
    let rec = ShardRecord {
        index,
        count: job.shards,
        seconds,
        artifact,
    };
    let path = shard_record_path(store, &job.key, index, job.shards);
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    }
    let json = serde_json::to_vec_pretty(&rec).map_err(|e| e.to_string())?;
    store
        .write_atomic(&path, &json)
        .map_err(|e| e.to_string())?;
    Ok(Finished::Shard(rec))
}

/// DVC semantics: a dep that another stage writes into the workspace is put
/// back from the cache when it is missing or differs.
fn restore_workspace(store: &Store, job: &Job) -> Result<(), String> {
    for r in &job.restore {
        let dest = job.pipeline_dir.join(&r.path);
        if store::hash_path(&dest).ok().as_deref() != Some(r.artifact.hash.as_str()) {
            store
                .checkout(&r.artifact, &dest)
                .map_err(|e| e.to_string())?;
        }
    }
    Ok(())
}

fn verify_param_files(job: &Job) -> Result<(), String> {
    for (path, hash) in &job.material.files {
        let full = job.pipeline_dir.join(path);
        let seen = store::hash_path(&full)
            .map_err(|e| format!("cannot read `{path}` at {}: {e}", full.display()))?;
        if &seen != hash {
            return Err(format!(
                "`{path}` differs on this host from what the key hashed: the pipeline \
                 directory {} must be on a file system shared with the submitting machine, \
                 and not edited while the run is on",
                job.pipeline_dir.display()
            ));
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
pub fn exec(store: &Store, path: &Path, shard: Option<usize>) -> Result<ExecOutcome, String> {
    let _guard = store.lock_cache(false).map_err(|e| e.to_string())?;
    let job = Job::read(path)?;
    let (kind, params) = job.check()?;
    let role = match shard {
        None => Role::Whole,
        Some(i) if job.shards > 1 && i < job.shards => Role::Shard(i),
        Some(i) if job.shards > 1 => {
            return Err(format!(
                "job {}: shard {i} does not exist (the job has {} shards, 0..{})",
                job.stage,
                job.shards,
                job.shards - 1
            ))
        }
        Some(i) => {
            return Err(format!(
                "job {}: shard {i} does not exist (the job is not sharded); run it without --shard",
                job.stage
            ))
        }
    };
    let done = match role {
        Role::Whole => store.record(&job.key).is_some_and(|r| {
            r.outputs
                .values()
                .all(|o| store.verify(&o.artifact).is_ok())
        }),
        Role::Shard(i) => shard_record(store, &job.key, i, job.shards).is_some(),
    };
    if done {
        return Ok(ExecOutcome::AlreadyDone);
    }
    run(store, &job, kind, &params, role, &Progress::hidden(), true).map(ExecOutcome::Ran)
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
