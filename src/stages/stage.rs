//! The contract between the engine and a stage kind.
//!
//! A kind implements [`Kind`] with its typed [`Kind::Params`] (declared
//! with [`params!`](crate::params)); the engine sees every kind through the
//! object-safe [`Stage`], which the blanket impl derives from [`Kind`]. The
//! engine parses a stage's params once, at validation ([`Stage::parse`]),
//! and hands the same typed value ([`Parsed`]) to every later call — the
//! checks, the key's file list and [`Stage::run`]. This module sits below
//! [`crate::pipeline`]: it knows nothing of plans, caches or executors, and
//! a running stage reports progress through the [`Progress`] callbacks.

use super::params::{Field, ParamProblem, ParamSet};
use super::shard;
use crate::simulator::{EvalError, Model};
use serde_yaml_ng::{Mapping, Value};
use std::any::Any;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

pub use crate::artifacts::Artifact;

/// One declared input of a stage kind.
#[derive(Clone, Copy, Debug)]
pub struct InputSpec {
    pub name: &'static str,
    pub required: bool,
    /// Accepts a list of artifacts (`stage[*].output`).
    pub list: bool,
    /// What the bound artifacts must hold.
    pub artifact: Artifact,
    pub doc: &'static str,
}

/// One output of a stage with these params.
#[derive(Clone, Debug, PartialEq)]
pub struct Output {
    pub name: String,
    pub artifact: Artifact,
}

impl Output {
    pub fn new(name: impl Into<String>, artifact: Artifact) -> Output {
        Output {
            name: name.into(),
            artifact,
        }
    }
}

/// A file a param names, relative to the pipeline directory; hashed by
/// content into the key.
#[derive(Clone, Debug, PartialEq)]
pub struct FileRef {
    /// Where it was named, e.g. `model` or `deps[1]` (messages).
    pub param: String,
    /// The path or glob pattern as written.
    pub path: String,
    /// A glob pattern: every matching file is hashed (at least one must match).
    pub glob: bool,
}

/// Why a stage run failed. The engine reports it with the stage name and
/// caches nothing.
#[derive(Debug, thiserror::Error)]
pub enum StageError {
    /// An input artifact cannot be used (wrong format, NaN data, ...).
    #[error("input `{input}`: {message}")]
    InvalidInput { input: String, message: String },
    /// A param value is valid YAML but unusable for this data.
    #[error("param `{param}`: {message}")]
    InvalidParam { param: String, message: String },
    /// File system trouble while reading inputs or writing outputs.
    #[error("{context}: {source}")]
    Io {
        context: String,
        #[source]
        source: std::io::Error,
    },
    /// The computation itself failed (external command, solver, ...).
    #[error("{0}")]
    Failed(String),
}

impl From<crate::artifacts::ArtifactError> for StageError {
    fn from(e: crate::artifacts::ArtifactError) -> Self {
        use crate::artifacts::ArtifactError as A;
        match e {
            A::Invalid { input, message } => StageError::InvalidInput { input, message },
            A::Io { context, source } => StageError::Io { context, source },
            other => StageError::Failed(other.to_string()),
        }
    }
}

impl StageError {
    pub fn io(context: impl Into<String>, source: std::io::Error) -> Self {
        StageError::Io {
            context: context.into(),
            source,
        }
    }
}

/// What a running stage reports: how much work there is, how much is done,
/// and what it is doing. The engine shows it (bars, heartbeat lines).
pub trait Progress: Sync {
    /// Total units of work, e.g. the evaluation budget.
    fn set_length(&self, n: u64);
    fn inc(&self, n: u64);
    /// What is being counted or done right now.
    fn set_message(&self, msg: String);
}

/// Progress that goes nowhere (tests, benches, cluster jobs).
pub struct NoProgress;

impl Progress for NoProgress {
    fn set_length(&self, _: u64) {}
    fn inc(&self, _: u64) {}
    fn set_message(&self, _: String) {}
}

/// The upstream stage (expanded name), its matrix values and the output an
/// input artifact came from.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct InputSource {
    pub stage: String,
    pub output: String,
    /// The upstream stage's matrix values (`[(key, value)]`, in matrix
    /// order; empty for a plain stage), as typed in the file.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub matrix: Vec<(String, serde_yaml_ng::Value)>,
}

impl InputSource {
    /// The matrix values as text (`0.75`, `worn`), as in expanded names.
    pub fn matrix_text(&self) -> Vec<(String, String)> {
        self.matrix
            .iter()
            .map(|(k, v)| {
                let text = match v {
                    serde_yaml_ng::Value::String(s) => s.clone(),
                    serde_yaml_ng::Value::Number(n) => n.to_string(),
                    serde_yaml_ng::Value::Bool(b) => b.to_string(),
                    _ => String::new(),
                };
                (k.clone(), text)
            })
            .collect()
    }
}

/// Everything a running stage may look at besides its params. Inputs are
/// read-only artifact paths; outputs go to `scratch`, which the engine
/// moves into the cache.
pub struct StageContext<'a> {
    /// Expanded stage name, e.g. `ident[method=pso,seed=2]`.
    pub stage: &'a str,
    /// `params.seed` when given, else the pipeline's seed.
    pub seed: u64,
    /// Input artifacts by input name; a single input has one path, a list
    /// input (`stage[*].output`) one per matched stage, in expansion order.
    pub inputs: &'a BTreeMap<String, Vec<PathBuf>>,
    /// Where each input came from, parallel to `inputs` (labels for reports).
    pub sources: &'a BTreeMap<String, Vec<InputSource>>,
    /// The pipeline's name.
    pub pipeline: &'a str,
    /// Directory of the pipeline file; relative paths in params start here.
    pub pipeline_dir: &'a Path,
    /// Empty directory owned by this run of the stage.
    pub scratch: &'a Path,
    pub progress: &'a dyn Progress,
    /// How [`StageContext::evaluate_batch`] treats the run's batch: whole,
    /// one shard of a job array, or merged from the shards' partials.
    pub batch: &'a shard::Batch,
    /// The warnings of every upstream stage (every stage this one depends
    /// on, directly or not), in plan order, for kinds that ask for them
    /// ([`Kind::reads_upstream_warnings`]); empty for the others.
    pub upstream_warnings: &'a [UpstreamWarnings],
}

/// One upstream stage's warnings (its run record's), as a stage that
/// reads them sees them; part of that stage's key, so a changed warning
/// upstream reruns it even when the upstream outputs are unchanged.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct UpstreamWarnings {
    pub stage: String,
    pub warnings: Vec<String>,
}

impl StageContext<'_> {
    /// Evaluate a batch of independent points (outputs in input order) the
    /// way the executor asked: here, one shard of it, or from the shards'
    /// partial results ([`shard`]). Shardable kinds evaluate through this.
    pub fn evaluate_batch(
        &self,
        model: &(impl Model + ?Sized),
        xs: &[Vec<f64>],
        chunk: usize,
    ) -> Result<Vec<Vec<f64>>, EvalError> {
        self.batch
            .evaluate(model, xs, chunk, &|k| self.progress.inc(k))
    }

    /// The single artifact bound to `name`.
    pub fn input(&self, name: &str) -> Result<&Path, StageError> {
        match self.inputs.get(name).map(Vec::as_slice) {
            Some([one]) => Ok(one),
            _ => Err(StageError::InvalidInput {
                input: name.into(),
                message: "expected exactly one artifact".into(),
            }),
        }
    }

    /// Whether input `name` is bound.
    pub fn has(&self, name: &str) -> bool {
        self.inputs.contains_key(name)
    }
}

/// Files matching `pattern` below `dir`, as `(relative path, absolute path)`,
/// sorted by relative path. A pattern without wildcards names one file.
pub fn expand_glob(dir: &Path, pattern: &str) -> Result<Vec<(String, PathBuf)>, String> {
    // The directory is literal text, only the pattern may hold wildcards.
    let text = format!(
        "{}/{pattern}",
        glob::Pattern::escape(&dir.to_string_lossy())
    );
    let paths = glob::glob(&text).map_err(|e| format!("invalid glob pattern `{pattern}`: {e}"))?;
    let mut out: Vec<(String, PathBuf)> = paths
        .filter_map(Result::ok)
        .filter(|p| p.is_file())
        .map(|p| {
            let rel = p
                .strip_prefix(dir)
                .unwrap_or(&p)
                .to_string_lossy()
                .replace('\\', "/");
            (rel, p)
        })
        .collect();
    out.sort();
    if out.is_empty() {
        return Err(format!("`{pattern}` matches no file in {}", dir.display()));
    }
    Ok(out)
}

/// What a successful run produced.
#[derive(Debug, Default)]
pub struct StageOutputs {
    /// Output name → file or directory (absolute, or relative to scratch).
    pub files: Vec<(String, PathBuf)>,
    /// Work counters shown in progress bars and manifests (e.g. `evaluations`).
    pub counters: BTreeMap<String, u64>,
    /// What the user should know about a result that did not fail: kept in
    /// the run record and shown as `warning: stage <name>: …` lines (and in
    /// `--json`'s stage reports) whenever the stage runs or is cached.
    pub warnings: Vec<String>,
}

/// A stage's params after [`Stage::parse`]: the kind's typed
/// [`Kind::Params`], shared by the plan, the job and the run.
#[derive(Clone)]
pub struct Parsed(Arc<dyn Any + Send + Sync>);

/// What [`Parsed::invalid`] holds.
struct Invalid;

impl Parsed {
    /// Stands in for params that failed to parse: the stage still takes part
    /// in validating references and inputs (so one round reports every
    /// problem), but the plan is rejected and nothing runs.
    pub fn invalid() -> Parsed {
        Parsed(Arc::new(Invalid))
    }

    /// Whether these are a kind's parsed params (not [`Parsed::invalid`]).
    pub fn is_valid(&self) -> bool {
        !self.0.is::<Invalid>()
    }
}

impl std::fmt::Debug for Parsed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Parsed(..)")
    }
}

/// A stage kind with typed params. Implementations are stateless unit
/// structs registered in [`super::registry`].
pub trait Kind: Sync + Send + 'static {
    type Params: ParamSet + Send + Sync + 'static;
    /// The `kind:` name in pipeline files.
    const NAME: &'static str;
    /// Algorithm version, part of every cache key: bump it whenever the same
    /// params and inputs would give different output bytes.
    fn version(&self) -> u32;
    /// One line for `modalflow kinds` and error messages.
    fn summary(&self) -> &'static str;
    /// Declared inputs; `None` accepts any input names (the `command` kind).
    fn inputs(&self) -> Option<&'static [InputSpec]>;
    /// Every output the kind can have (`modalflow kinds` lists them).
    const OUTPUTS: &'static [(&'static str, Artifact)];
    /// Outputs for these params (default: all of [`Kind::OUTPUTS`]).
    fn outputs(&self, _p: &Self::Params) -> Vec<Output> {
        Self::OUTPUTS
            .iter()
            .map(|(n, a)| Output::new(*n, *a))
            .collect()
    }
    /// Checks across params beyond each one's type and range.
    fn check(&self, _p: &Self::Params) -> Vec<ParamProblem> {
        Vec::new()
    }
    /// The seed the params give (`params.seed`); `None`: the pipeline's.
    fn seed(&self, _p: &Self::Params) -> Option<u64> {
        None
    }
    /// Whether the stage draws random numbers, so its seed enters the key.
    fn uses_seed(&self) -> bool {
        false
    }
    /// Whether the stage reads the warnings of every upstream stage
    /// ([`StageContext::upstream_warnings`], which then enter its key).
    fn reads_upstream_warnings(&self) -> bool {
        false
    }
    /// Files the params name (hashed by content into the key).
    fn files(&self, _p: &Self::Params) -> Vec<FileRef> {
        Vec::new()
    }
    /// The top-level params that name files, and whether each is a glob:
    /// with params that fail to parse, validation still checks these files
    /// from the values as written ([`Stage::raw_files`]), so one round
    /// reports every problem.
    const FILE_PARAMS: &'static [(&'static str, bool)] = &[];
    /// Look into the files the params name (relative to `dir`) during
    /// validation: a bad file is a problem before anything runs; returns
    /// further files they reference (relative to `dir`), hashed likewise.
    fn file_dependencies(
        &self,
        _p: &Self::Params,
        _dir: &Path,
    ) -> Result<Vec<String>, ParamProblem> {
        Ok(Vec::new())
    }
    /// Check params against which inputs are bound (`bound`: their names).
    fn check_inputs(&self, _p: &Self::Params, _bound: &[&str]) -> Vec<ParamProblem> {
        Vec::new()
    }
    /// Paths (relative to the pipeline file) the stage writes into the
    /// workspace, DVC-style; a stage naming one of them in a file param
    /// depends on this stage.
    fn workspace_outputs(&self, _p: &Self::Params) -> Vec<String> {
        Vec::new()
    }
    /// Whether the run's work is one batch of independent model evaluations
    /// handed to [`StageContext::evaluate_batch`], so an executor may split
    /// it over the tasks of a job array ([`shard`]).
    fn shardable(&self, _p: &Self::Params) -> bool {
        false
    }
    fn run(&self, p: &Self::Params, ctx: &StageContext) -> Result<StageOutputs, StageError>;
}

/// A stage kind as the engine sees it: object-safe, params type-erased.
pub trait Stage: Sync + Send {
    fn kind(&self) -> &'static str;
    fn version(&self) -> u32;
    fn summary(&self) -> &'static str;
    /// The params, described from the typed struct.
    fn params(&self) -> Vec<Field>;
    fn inputs(&self) -> Option<&'static [InputSpec]>;
    /// Every output the kind can have.
    fn all_outputs(&self) -> &'static [(&'static str, Artifact)];
    /// Parse the params once, with every problem (types, ranges, the kind's
    /// own checks).
    fn parse(&self, params: &Mapping) -> Result<Parsed, Vec<ParamProblem>>;
    fn outputs(&self, p: &Parsed) -> Vec<Output>;
    fn seed(&self, p: &Parsed) -> Option<u64>;
    fn uses_seed(&self) -> bool;
    fn reads_upstream_warnings(&self) -> bool;
    fn files(&self, p: &Parsed) -> Vec<FileRef>;
    /// The files the params name, read from the params as written (for
    /// params that failed to parse): string values of the kind's file
    /// params, and the strings of a list (`deps[1]`).
    fn raw_files(&self, params: &Mapping) -> Vec<FileRef>;
    fn file_dependencies(&self, p: &Parsed, dir: &Path) -> Result<Vec<String>, ParamProblem>;
    fn check_inputs(&self, p: &Parsed, bound: &[&str]) -> Vec<ParamProblem>;
    fn workspace_outputs(&self, p: &Parsed) -> Vec<String>;
    fn shardable(&self, p: &Parsed) -> bool;
    fn run(&self, p: &Parsed, ctx: &StageContext) -> Result<StageOutputs, StageError>;
}

impl<K: Kind> Stage for K {
    fn kind(&self) -> &'static str {
        K::NAME
    }
    fn version(&self) -> u32 {
        Kind::version(self)
    }
    fn summary(&self) -> &'static str {
        Kind::summary(self)
    }
    fn params(&self) -> Vec<Field> {
        K::Params::fields()
    }
    fn inputs(&self) -> Option<&'static [InputSpec]> {
        Kind::inputs(self)
    }
    fn all_outputs(&self) -> &'static [(&'static str, Artifact)] {
        K::OUTPUTS
    }
    fn parse(&self, params: &Mapping) -> Result<Parsed, Vec<ParamProblem>> {
        let p = K::Params::parse(params)?;
        let problems = Kind::check(self, &p);
        if problems.is_empty() {
            Ok(Parsed(Arc::new(p)))
        } else {
            Err(problems)
        }
    }
    fn outputs(&self, p: &Parsed) -> Vec<Output> {
        typed::<K>(p).map_or_else(Vec::new, |p| Kind::outputs(self, p))
    }
    fn seed(&self, p: &Parsed) -> Option<u64> {
        typed::<K>(p).and_then(|p| Kind::seed(self, p))
    }
    fn uses_seed(&self) -> bool {
        Kind::uses_seed(self)
    }
    fn reads_upstream_warnings(&self) -> bool {
        Kind::reads_upstream_warnings(self)
    }
    fn files(&self, p: &Parsed) -> Vec<FileRef> {
        typed::<K>(p).map_or_else(Vec::new, |p| Kind::files(self, p))
    }
    fn raw_files(&self, params: &Mapping) -> Vec<FileRef> {
        let mut out = Vec::new();
        for &(name, glob) in K::FILE_PARAMS {
            let file = |param: String, path: &str| FileRef {
                param,
                path: path.to_string(),
                glob,
            };
            match params.get(name) {
                Some(Value::String(path)) => out.push(file(name.to_string(), path)),
                Some(Value::Sequence(list)) => {
                    for (i, v) in list.iter().enumerate() {
                        if let Value::String(path) = v {
                            out.push(file(format!("{name}[{i}]"), path));
                        }
                    }
                }
                _ => {}
            }
        }
        out
    }
    fn file_dependencies(&self, p: &Parsed, dir: &Path) -> Result<Vec<String>, ParamProblem> {
        match typed::<K>(p) {
            Some(p) => Kind::file_dependencies(self, p, dir),
            None => Err(mismatch::<K>()),
        }
    }
    fn check_inputs(&self, p: &Parsed, bound: &[&str]) -> Vec<ParamProblem> {
        typed::<K>(p).map_or_else(
            || vec![mismatch::<K>()],
            |p| Kind::check_inputs(self, p, bound),
        )
    }
    fn workspace_outputs(&self, p: &Parsed) -> Vec<String> {
        typed::<K>(p).map_or_else(Vec::new, |p| Kind::workspace_outputs(self, p))
    }
    fn shardable(&self, p: &Parsed) -> bool {
        typed::<K>(p).is_some_and(|p| Kind::shardable(self, p))
    }
    fn run(&self, p: &Parsed, ctx: &StageContext) -> Result<StageOutputs, StageError> {
        match typed::<K>(p) {
            Some(p) => Kind::run(self, p, ctx),
            None => Err(StageError::Failed(mismatch::<K>().message)),
        }
    }
}

fn typed<K: Kind>(p: &Parsed) -> Option<&K::Params> {
    p.0.downcast_ref::<K::Params>()
}

fn mismatch<K: Kind>() -> ParamProblem {
    ParamProblem {
        path: Vec::new(),
        message: format!(
            "params parsed for another kind were handed to `{}` (a bug, please report)",
            K::NAME
        ),
        help: None,
        class: super::params::Class::Check,
    }
}
