//! Stage kinds: the [`Stage`] trait every kind implements, and the one
//! registry ([`registry`]) that lists them.
//!
//! A stage is a thin adapter between artifacts (files in the cache) and the
//! numerical core: it declares its params, inputs and outputs so the engine can
//! validate a pipeline file before anything runs, and a version constant that
//! is part of every cache key, bumped whenever the kind's results would change.

pub mod artifacts;
pub mod autoema;
pub mod command;
pub mod evaluate;
pub mod export;
pub mod gsa;
pub mod identify;
pub mod import;
pub mod report;
pub mod shard;
pub mod synthesize;
pub mod synthesize_params;
pub mod synthesize_values;

use crate::evaluation::{EvalError, Model};
use crate::pipeline::progress::Progress;
use serde_yaml_ng::{Mapping, Value};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The type a param value must have; checked during validation.
#[derive(Clone, Copy, Debug)]
pub enum ParamType {
    Bool,
    Integer,
    Number,
    String,
    /// A file or directory relative to the pipeline file; hashed by content
    /// into the cache key.
    Path,
    /// A list of [`ParamType::Path`].
    Paths,
    /// A path or glob pattern (`data/*.uff`) relative to the pipeline file;
    /// every matching file is hashed into the key. Must match at least one.
    Glob,
    Strings,
    /// One of the listed strings.
    Enum(&'static [&'static str]),
    Mapping,
    /// Free-form; the kind's [`Stage::check`] validates it.
    Any,
}

impl ParamType {
    pub fn describe(&self) -> String {
        match self {
            ParamType::Bool => "a boolean".into(),
            ParamType::Integer => "an integer".into(),
            ParamType::Number => "a number".into(),
            ParamType::String => "a string".into(),
            ParamType::Path => "a file path (relative to the pipeline file)".into(),
            ParamType::Paths => "a list of file paths".into(),
            ParamType::Glob => "a file path or glob pattern (relative to the pipeline file)".into(),
            ParamType::Strings => "a list of strings".into(),
            ParamType::Enum(options) => format!("one of: {}", options.join(", ")),
            ParamType::Mapping => "a mapping".into(),
            ParamType::Any => "any value".into(),
        }
    }
}

/// One declared param of a stage kind.
#[derive(Clone, Copy, Debug)]
pub struct ParamSpec {
    pub name: &'static str,
    pub ty: ParamType,
    pub required: bool,
    pub doc: &'static str,
}

/// One declared input of a stage kind.
#[derive(Clone, Copy, Debug)]
pub struct InputSpec {
    pub name: &'static str,
    pub required: bool,
    /// Accepts a list of artifacts (`stage[*].output`).
    pub list: bool,
    pub doc: &'static str,
}

/// A param problem found by a kind's own validation, located by its path
/// below `params` (e.g. `["frequency", "step"]`).
#[derive(Debug)]
pub struct ParamProblem {
    pub path: Vec<String>,
    pub message: String,
    pub help: Option<String>,
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

impl StageError {
    pub fn io(context: impl Into<String>, source: std::io::Error) -> Self {
        StageError::Io {
            context: context.into(),
            source,
        }
    }
}

/// The upstream stage (expanded name) and output an input artifact came from.
#[derive(Clone, Debug, PartialEq)]
pub struct InputSource {
    pub stage: String,
    pub output: String,
}

/// Everything a running stage may look at. Inputs are read-only artifact
/// paths; outputs go to `scratch`, which the engine moves into the cache.
pub struct StageContext<'a> {
    /// Expanded stage name, e.g. `ident[method=pso,seed=2]`.
    pub stage: &'a str,
    pub params: &'a Mapping,
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
    pub progress: &'a Progress,
    /// How [`StageContext::evaluate_batch`] treats the run's batch: whole,
    /// one shard of a job array, or merged from the shards' partials.
    pub batch: &'a shard::Batch,
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

    /// Deserialize the params into the kind's typed parameter struct.
    pub fn params_as<T: serde::de::DeserializeOwned>(&self) -> Result<T, StageError> {
        serde_yaml_ng::from_value(Value::Mapping(self.params.clone()))
            .map_err(|e| StageError::Failed(format!("params: {e}")))
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

    /// A path param resolved against the pipeline directory.
    pub fn path_param(&self, name: &str) -> Option<PathBuf> {
        self.params
            .get(name)
            .and_then(Value::as_str)
            .map(|p| self.pipeline_dir.join(p))
    }

    /// The files a [`ParamType::Glob`] param matches, sorted, with their
    /// paths relative to the pipeline directory (the same list the key hashed).
    pub fn glob_param(&self, name: &str) -> Result<Vec<(String, PathBuf)>, StageError> {
        let pattern = self
            .params
            .get(name)
            .and_then(Value::as_str)
            .unwrap_or_default();
        expand_glob(self.pipeline_dir, pattern).map_err(|message| StageError::InvalidParam {
            param: name.to_string(),
            message,
        })
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
}

/// A stage kind. Implementations are stateless unit structs registered in
/// [`registry`].
pub trait Stage: Sync + Send {
    /// The `kind:` name in pipeline files.
    fn kind(&self) -> &'static str;
    /// Algorithm version, part of every cache key: bump it whenever the same
    /// params and inputs would give different output bytes.
    fn version(&self) -> u32;
    /// One line for `modalflow` help and error messages.
    fn summary(&self) -> &'static str;
    fn params(&self) -> &'static [ParamSpec];
    /// Declared inputs; `None` accepts any input names (the `command` kind).
    fn inputs(&self) -> Option<&'static [InputSpec]>;
    /// Output names for these params.
    fn outputs(&self, params: &Mapping) -> Vec<String>;
    /// Kind-specific validation beyond types (ranges, consistency).
    fn check(&self, _params: &Mapping) -> Result<(), ParamProblem> {
        Ok(())
    }
    /// Look into the files the params name (relative to `dir`, the pipeline
    /// directory) during validation: report a bad file as a problem before
    /// anything runs, and return further files they reference (paths
    /// relative to `dir`, e.g. a model's Matrix Market matrices), which are
    /// hashed into the key like the params' own files.
    fn file_dependencies(
        &self,
        _params: &Mapping,
        _dir: &Path,
    ) -> Result<Vec<String>, ParamProblem> {
        Ok(Vec::new())
    }
    /// Check params against which inputs are bound (e.g. a strategy that
    /// needs an optional input); `bound` lists the bound input names.
    fn check_inputs(&self, _params: &Mapping, _bound: &[&str]) -> Result<(), ParamProblem> {
        Ok(())
    }
    /// Whether the stage draws random numbers, so its seed enters the key.
    fn uses_seed(&self) -> bool {
        false
    }
    /// Paths (relative to the pipeline file) that the stage writes into the
    /// workspace, DVC-style; another stage's `Paths` param naming one of them
    /// depends on this stage.
    fn workspace_outputs(&self, _params: &Mapping) -> Vec<String> {
        Vec::new()
    }
    /// Whether, with these params, the run's work is one batch of independent
    /// model evaluations handed to [`StageContext::evaluate_batch`], so an
    /// executor may split it over the tasks of a job array ([`shard`]).
    fn shardable(&self, _params: &Mapping) -> bool {
        false
    }
    fn run(&self, ctx: &StageContext) -> Result<StageOutputs, StageError>;
}

/// Every stage kind, in the order `modalflow` lists them.
pub fn registry() -> &'static [&'static dyn Stage] {
    &[
        &synthesize::Synthesize,
        &import::Import,
        &autoema::AutoEma,
        &gsa::Gsa,
        &identify::Identify,
        &evaluate::Evaluate,
        &export::Export,
        &report::Report,
        &command::Command,
    ]
}

/// Look up a kind by name.
pub fn find(kind: &str) -> Option<&'static dyn Stage> {
    registry().iter().copied().find(|s| s.kind() == kind)
}
