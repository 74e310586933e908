//! A stage run as a self-contained job: the [`Job`] description — stage key,
//! kind and version, params, seed, inputs by content hash — that the engine
//! builds ([`crate::pipeline::execute`]) and the executors run: the local
//! executor in memory, with the params already parsed; the Slurm executor
//! writes it into the shared cache for `modalflow exec` ([`super::exec`]),
//! which parses the params again and never reads the pipeline file. And the
//! records shard tasks leave beside it.

use super::error::ExecutorError;
use crate::pipeline::key::{canonical_params, KeyMaterial};
use crate::pipeline::store::{Artifact, Store};
use crate::stages::{self, Parsed, Stage};
use serde::{Deserialize, Serialize};
use serde_yaml_ng::{Mapping, Value};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

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
    /// The kind and its typed params (in memory only; a description read
    /// from disk gets them from [`Job::check`]).
    #[serde(skip)]
    pub typed: Option<Typed>,
}

/// A job's kind and params, parsed.
#[derive(Clone)]
pub struct Typed {
    pub kind: &'static dyn Stage,
    pub params: Parsed,
}

impl std::fmt::Debug for Typed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Typed({})", self.kind.kind())
    }
}

/// One input artifact, by content hash.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct JobInput {
    /// Upstream stage and output (labels for reports).
    pub stage: String,
    pub output: String,
    /// The upstream stage's matrix values.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub matrix: Vec<(String, Value)>,
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

impl Job {
    /// The params as YAML text for the description. (The engine builds
    /// descriptions with `String` errors, so this stays one.)
    pub fn params_text(params: &Mapping) -> Result<String, String> {
        serde_yaml_ng::to_string(&Value::Mapping(params.clone()))
            .map_err(|e| format!("cannot write the params: {e}"))
    }

    /// The kind and typed params of the job.
    pub fn typed(&self) -> Result<&Typed, ExecutorError> {
        self.typed.as_ref().ok_or_else(|| ExecutorError::NotParsed {
            stage: self.stage.clone(),
        })
    }

    /// Read a description written by [`Job::write`].
    pub fn read(path: &Path) -> Result<Job, ExecutorError> {
        let bytes = std::fs::read(path).map_err(|cause| ExecutorError::ReadDescription {
            path: path.to_path_buf(),
            cause,
        })?;
        let job: Job =
            serde_json::from_slice(&bytes).map_err(|cause| ExecutorError::ParseDescription {
                path: path.to_path_buf(),
                cause,
            })?;
        if job.format != FORMAT {
            return Err(ExecutorError::Format {
                path: path.to_path_buf(),
                found: job.format,
            });
        }
        Ok(job)
    }

    /// Write the description atomically to `path`.
    pub fn write(&self, store: &Store, path: &Path) -> Result<(), ExecutorError> {
        let json = serde_json::to_vec_pretty(self).map_err(ExecutorError::Serialize)?;
        Ok(store.write_atomic(path, &json)?)
    }

    /// Parse the kind and params, checked against the key: the description
    /// is internally consistent and this binary has the same kind version.
    pub fn check(&mut self) -> Result<(), ExecutorError> {
        let kind = stages::find(&self.material.kind).ok_or_else(|| ExecutorError::UnknownKind {
            stage: self.stage.clone(),
            kind: self.material.kind.clone(),
        })?;
        if kind.version() != self.material.version {
            return Err(ExecutorError::KindVersion {
                stage: self.stage.clone(),
                kind: kind.kind().to_string(),
                job: self.material.version,
                this: kind.version(),
            });
        }
        let params = match serde_yaml_ng::from_str::<Value>(&self.params) {
            Ok(Value::Mapping(m)) => m,
            Ok(_) => Mapping::new(),
            Err(cause) => {
                return Err(ExecutorError::ParamsYaml {
                    stage: self.stage.clone(),
                    cause,
                })
            }
        };
        if canonical_params(&Value::Mapping(params.clone())) != self.material.params
            || self.material.key() != self.key
        {
            return Err(ExecutorError::KeyMismatch {
                stage: self.stage.clone(),
                key: self.key.clone(),
            });
        }
        let parsed = kind.parse(&params).map_err(|problems| {
            let text: Vec<String> = problems
                .iter()
                .map(|p| format!("{}: {}", p.path.join("."), p.message))
                .collect();
            ExecutorError::ParamProblems {
                stage: self.stage.clone(),
                problems: text.join("; "),
            }
        })?;
        self.typed = Some(Typed {
            kind,
            params: parsed,
        });
        Ok(())
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
