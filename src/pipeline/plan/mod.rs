//! From a pipeline file to a validated [`Plan`]: matrix expansion, kind and
//! param checks against each kind's schema, input resolution, file params,
//! and the DAG. Every problem is collected as a located [`Diagnostic`];
//! nothing runs unless the whole file validates.

mod executor_block;
mod files;
mod inputs;
mod names;
mod params;
mod set;

use executor_block::{check_binary, check_executor, check_executor_stages, check_shards};
pub use files::normalize;
use files::resolve_files;
use inputs::resolve_inputs;
use names::{check_matrix, valid_stage_name};
use params::parse_params;
pub use set::Override;

use super::diagnostic::{closest, Diagnostic, Diagnostics, Location};
use super::executor::ExecutorSpec;
use super::graph;
use super::matrix::{self, Combination};
use super::span::SpanIndex;
use super::spec::{PipelineSpec, StageSpec};
use crate::paths::{self, MAX_NAME_BYTES};
use crate::stages::{self, Output, Parsed, Stage};
use serde_yaml_ng::Mapping;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// A validated, expanded pipeline ready to run.
pub struct Plan {
    /// The pipeline file as named on the command line.
    pub file: PathBuf,
    /// Directory of the pipeline file; commands run and paths resolve here.
    pub dir: PathBuf,
    pub name: String,
    /// Where results and the last-run record go: `name`, or for a run with
    /// `--set` overrides `name--set-<hash>` ([`results_name`]), so an
    /// override never leaves the file's own results out of step with it.
    pub results_name: String,
    /// The `--set` overrides as given (sorted, deduplicated).
    pub overrides: Vec<String>,
    pub seed: u64,
    pub nodes: Vec<Node>,
    /// Upstream node indices of each node (deduplicated, sorted).
    pub upstream: Vec<Vec<usize>>,
    /// A topological order of all nodes.
    pub order: Vec<usize>,
    /// The `executor:` block (defaults when absent).
    pub executor: ExecutorSpec,
}

impl Plan {
    /// Every node `i` depends on, directly or not, in plan order.
    pub fn ancestors(&self, i: usize) -> Vec<usize> {
        let mut seen = vec![false; self.nodes.len()];
        let mut stack = vec![i];
        while let Some(n) = stack.pop() {
            for &u in &self.upstream[n] {
                if !std::mem::replace(&mut seen[u], true) {
                    stack.push(u);
                }
            }
        }
        (0..seen.len()).filter(|&u| seen[u]).collect()
    }

    /// The pipeline file's absolute path (its identity in a cache).
    pub fn path(&self) -> PathBuf {
        match self.file.file_name() {
            Some(name) => self.dir.join(name),
            None => self.file.clone(),
        }
    }
}

/// One expanded stage.
pub struct Node {
    /// Expanded name, e.g. `ident[method=pso,seed=2]`.
    pub name: String,
    /// The stage entry it came from.
    pub base: String,
    pub kind: &'static dyn Stage,
    /// The params as written (matrix values substituted, `--set` applied):
    /// canonical form for the key and the job description only.
    pub params: Mapping,
    /// The params parsed once into the kind's typed struct; every later
    /// use (checks, files, the run) sees this value.
    pub parsed: Parsed,
    pub matrix: Combination,
    pub seed: u64,
    pub inputs: Vec<Binding>,
    pub files: Vec<FileParam>,
    pub outputs: Vec<Output>,
    pub workspace_outputs: Vec<String>,
}

impl Node {
    /// Whether the node has an output named `name`.
    pub fn has_output(&self, name: &str) -> bool {
        self.outputs.iter().any(|o| o.name == name)
    }

    /// The output names, in declaration order.
    pub fn output_names(&self) -> Vec<String> {
        self.outputs.iter().map(|o| o.name.clone()).collect()
    }
}

/// An input name bound to one or more upstream outputs.
pub struct Binding {
    pub name: String,
    /// `(node index, output name)` in order.
    pub sources: Vec<(usize, String)>,
}

/// A file named in params, hashed by content into the key.
pub struct FileParam {
    /// Where it was named, e.g. `model` or `deps[1]`.
    pub param: String,
    /// Normalized path relative to the pipeline directory.
    pub path: String,
    /// The stage whose workspace output this is, if any (DVC-style edge).
    pub producer: Option<(usize, String)>,
}

/// Why a pipeline could not be planned.
#[derive(Debug, thiserror::Error)]
pub enum PlanError {
    #[error("cannot read pipeline file {}: {source}\n  = help: check the path; it is resolved against the current directory", path.display())]
    Read {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{0}")]
    Invalid(Diagnostics),
}

pub(super) struct Ctx<'a> {
    pub(super) file: &'a Path,
    pub(super) source: &'a str,
    pub(super) spans: SpanIndex,
    pub(super) diags: Vec<Diagnostic>,
    /// Stage entries that made no nodes (unknown kind, bad matrix, bad
    /// matrix reference): references to them are not reported again.
    pub(super) invalid: BTreeSet<String>,
    /// `--set` overrides and whether each applied to a stage.
    pub(super) sets: Vec<(Override, bool)>,
    /// The `read_outside:` directories, absolute with links resolved.
    pub(super) read_roots: Vec<PathBuf>,
}

impl Ctx<'_> {
    pub(super) fn at(&mut self, loc: Option<Location>, message: String, help: Option<String>) {
        let mut d = Diagnostic::new(self.file, self.source, loc, message);
        d.help = help;
        if !self
            .diags
            .iter()
            .any(|x| x.location == d.location && x.message == d.message)
        {
            self.diags.push(d);
        }
    }
}

/// Read, parse and validate a pipeline file.
pub fn load(file: &Path) -> Result<Plan, PlanError> {
    load_with(file, &[])
}

/// Read, parse and validate a pipeline file with `--set` overrides
/// (`STAGE.PARAM=VALUE`, see [`Override`]).
pub fn load_with(file: &Path, sets: &[String]) -> Result<Plan, PlanError> {
    let source = std::fs::read_to_string(file).map_err(|source| PlanError::Read {
        path: file.to_path_buf(),
        source,
    })?;
    // Absolute, so commands and path params resolve the same from any
    // working directory; the directory never enters a cache key.
    let parent = match file.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let dir = std::fs::canonicalize(&parent).map_err(|source| PlanError::Read {
        path: parent.clone(),
        source,
    })?;
    plan_sets(file, &dir, &source, sets)
}

/// Validate `source` as the pipeline file `file` located in `dir`.
pub fn plan_source(file: &Path, dir: &Path, source: &str) -> Result<Plan, PlanError> {
    plan_sets(file, dir, source, &[])
}

fn plan_sets(file: &Path, dir: &Path, source: &str, sets: &[String]) -> Result<Plan, PlanError> {
    let mut cx = Ctx {
        file,
        source,
        spans: SpanIndex::default(),
        diags: Vec::new(),
        invalid: BTreeSet::new(),
        sets: Vec::new(),
        read_roots: Vec::new(),
    };
    for text in sets {
        match Override::parse(text) {
            Ok(o) => cx.sets.push((o, false)),
            Err(e) => cx.at(None, e, None),
        }
    }
    let Some(mut spec) = parse_spec(&mut cx, source) else {
        return Err(PlanError::Invalid(Diagnostics(cx.diags)));
    };
    cx.spans = SpanIndex::build(source);
    for (path, loc) in cx.spans.duplicates.clone() {
        cx.at(
            Some(loc),
            format!("duplicate key `{}`", path.join(".")),
            Some("each key may appear once per mapping; remove or rename one".into()),
        );
    }
    check_executor(&mut cx, &spec.executor);
    cx.read_roots = files::read_roots(&mut cx, &spec.read_outside, dir);
    let mut nodes = expand(&mut cx, &spec, dir);
    check_sets(&mut cx, &nodes);
    check_shards(&mut cx, &spec.executor, &nodes);
    check_executor_stages(&mut cx, &spec.executor, &nodes);
    spec.executor.binary = check_binary(&mut cx, &spec.executor, dir);
    resolve_inputs(&mut cx, &spec, &mut nodes);
    resolve_files(&mut cx, dir, &mut nodes);
    files::check_workspace_outputs(&mut cx, dir, &nodes);
    let (upstream, order) = dependency_graph(&mut cx, &nodes);
    if !cx.diags.is_empty() {
        return Err(PlanError::Invalid(Diagnostics(cx.diags)));
    }
    let mut overrides = sets.to_vec();
    overrides.sort();
    overrides.dedup();
    Ok(Plan {
        file: file.to_path_buf(),
        dir: dir.to_path_buf(),
        results_name: results_name(&spec.name, &overrides),
        overrides,
        name: spec.name,
        seed: spec.seed,
        nodes,
        upstream,
        order,
        executor: spec.executor,
    })
}

/// The pipeline file's YAML as a [`PipelineSpec`], or `None` after
/// reporting why it is not one (nested too deep, invalid YAML, unknown or
/// missing fields); nothing else is checked without it.
fn parse_spec(cx: &mut Ctx, source: &str) -> Option<PipelineSpec> {
    if let Err(deep) = crate::yaml::check_depth(source) {
        let (line, column) = (deep.line, deep.column);
        cx.at(
            Some(Location { line, column }),
            format!("invalid pipeline file: {deep}"),
            None,
        );
        return None;
    }
    match serde_yaml_ng::from_str(source) {
        Ok(s) => Some(s),
        Err(e) => {
            let loc = e.location().map(|l| Location {
                line: l.line(),
                column: l.column(),
            });
            let help = "a pipeline file has `name`, optional `seed`, `description` and `executor`, and `stages`; \
                        each stage has `kind`, and optional `params`, `inputs`, `matrix`, `description`";
            cx.at(
                loc,
                format!("invalid pipeline file: {e}"),
                Some(help.into()),
            );
            None
        }
    }
}

/// The DAG of the nodes: each node's upstream nodes (through inputs and
/// produced file params; deduplicated, sorted) and a topological order,
/// empty after reporting a cycle.
fn dependency_graph(cx: &mut Ctx, nodes: &[Node]) -> (Vec<Vec<usize>>, Vec<usize>) {
    let upstream: Vec<Vec<usize>> = nodes
        .iter()
        .map(|n| {
            let set: BTreeSet<usize> = n
                .inputs
                .iter()
                .flat_map(|b| b.sources.iter().map(|s| s.0))
                .chain(
                    n.files
                        .iter()
                        .filter_map(|f| f.producer.as_ref().map(|p| p.0)),
                )
                .collect();
            set.into_iter().collect()
        })
        .collect();
    let order = match graph::topological_order(&upstream) {
        Ok(order) => order,
        Err(cycle) => {
            let names: Vec<&str> = cycle.iter().map(|&i| nodes[i].name.as_str()).collect();
            let first = &nodes[cycle[0]];
            let loc = cx.spans.key(&["stages", &first.base, "inputs"]);
            cx.at(
                loc,
                format!(
                    "the stages form a cycle: {} -> {}",
                    names.join(" -> "),
                    names[0]
                ),
                Some(
                    "a stage cannot depend on its own results; remove one of these inputs or deps"
                        .into(),
                ),
            );
            Vec::new()
        }
    };
    (upstream, order)
}

/// The results name of a pipeline run with `overrides` (sorted): its name,
/// or `name--set-` and 8 hex digits of a hash of the overrides. A `--set`
/// run's results and last-run record live under it, apart from the file's.
pub fn results_name(name: &str, overrides: &[String]) -> String {
    if overrides.is_empty() {
        return name.to_string();
    }
    let hash = blake3::hash(overrides.join("\n").as_bytes()).to_hex();
    format!("{name}--set-{}", &hash[..8])
}

/// Every `--set` must name a stage of the file.
fn check_sets(cx: &mut Ctx, nodes: &[Node]) {
    let unused: Vec<Override> = cx
        .sets
        .iter()
        .filter(|(o, used)| !used && !cx.invalid.contains(&o.stage))
        .map(|(o, _)| o.clone())
        .collect();
    for o in unused {
        let mut bases: Vec<&str> = nodes.iter().map(|n| n.base.as_str()).collect();
        bases.dedup();
        let mut help = format!("stages: {}", bases.join(", "));
        if let Some(c) = closest(&o.stage, bases.iter().copied()) {
            help = format!("did you mean `{c}`? {help}");
        }
        cx.at(
            None,
            format!("--set {}: no stage `{}` in this file", o.text, o.stage),
            Some(help),
        );
    }
}

/// Kinds, matrix expansion and param checks, one node per combination.
fn expand(cx: &mut Ctx, spec: &PipelineSpec, _dir: &Path) -> Vec<Node> {
    if !valid_stage_name(&spec.name) {
        let loc = cx.spans.value(&["name"]);
        cx.at(
            loc,
            format!("invalid pipeline name `{}`", spec.name),
            Some(format!(
                "use letters, digits, `_` and `-`, at most {MAX_NAME_BYTES} (it names the results directory)"
            )),
        );
    }
    if spec.stages.is_empty() {
        let loc = cx.spans.key(&["stages"]);
        cx.at(
            loc,
            "the pipeline has no stages".into(),
            Some("add at least one stage under `stages:`".into()),
        );
    }
    let mut nodes = Vec::new();
    for (base, st) in &spec.stages {
        if !valid_stage_name(base) {
            let loc = cx.spans.key(&["stages", base]);
            cx.at(
                loc,
                format!("invalid stage name `{base}`"),
                Some(format!("use letters, digits, `_` and `-`, at most {MAX_NAME_BYTES}; dots and brackets are reserved for references")),
            );
            continue;
        }
        let Some(kind) = stages::find(&st.kind) else {
            let known: Vec<&str> = stages::registry().iter().map(|s| s.kind()).collect();
            let mut help = format!("known kinds: {}", known.join(", "));
            if let Some(c) = closest(&st.kind, known.iter().copied()) {
                help = format!("did you mean `{c}`? {help}");
            }
            let loc = cx.spans.value(&["stages", base, "kind"]);
            cx.at(
                loc,
                format!("unknown stage kind `{}` in stage `{base}`", st.kind),
                Some(help),
            );
            cx.invalid.insert(base.clone());
            continue;
        };
        if !check_matrix(cx, base, st) {
            cx.invalid.insert(base.clone());
            continue;
        }
        for combo in matrix::combinations(&st.matrix) {
            match expand_one(cx, spec, base, st, kind, combo) {
                Some(node) => nodes.push(node),
                None => {
                    cx.invalid.insert(base.clone());
                }
            }
        }
    }
    nodes
}

fn expand_one(
    cx: &mut Ctx,
    spec: &PipelineSpec,
    base: &str,
    st: &StageSpec,
    kind: &'static dyn Stage,
    combo: Combination,
) -> Option<Node> {
    let name = matrix::expanded_name(base, &combo);
    if let Err(problem) = paths::name(&name) {
        let loc = cx.spans.key(&["stages", base, "matrix"]);
        cx.at(
            loc,
            format!("expanded stage name `{name}` {problem}"),
            Some("it names the stage's results folder: shorten the stage name or the matrix keys and values".into()),
        );
        return None;
    }
    let params = match matrix::substitute_map(&st.params, &combo, &mut Vec::new()) {
        Ok(mut p) => {
            for (o, used) in cx.sets.iter_mut() {
                if o.applies(base, &name) {
                    o.apply(&mut p);
                    *used = true;
                }
            }
            p
        }
        Err(e) => {
            let mut path = vec!["stages", base, "params"];
            path.extend(e.path.iter().map(String::as_str));
            let loc = cx.spans.nearest(&path);
            let keys: Vec<&str> = st.matrix.keys().map(String::as_str).collect();
            cx.at(
                loc,
                format!(
                    "`${{matrix.{}}}` in stage `{base}` names no matrix key",
                    e.key
                ),
                Some(if keys.is_empty() {
                    "this stage has no `matrix:`; add one or write the value directly".into()
                } else {
                    format!("matrix keys: {}", keys.join(", "))
                }),
            );
            return None;
        }
    };
    // A stage whose params are bad still takes part in the checks of
    // references and inputs, so one round reports every problem.
    let parsed = parse_params(cx, base, base, kind, &params).unwrap_or_else(Parsed::invalid);
    let seed = kind.seed(&parsed).unwrap_or(spec.seed);
    let outputs = if parsed.is_valid() {
        kind.outputs(&parsed)
    } else {
        kind.all_outputs()
            .iter()
            .map(|(n, a)| Output::new(*n, *a))
            .collect()
    };
    let workspace_outputs = kind
        .workspace_outputs(&parsed)
        .iter()
        .map(|p| normalize(p))
        .collect();
    Some(Node {
        name,
        base: base.to_string(),
        kind,
        params,
        parsed,
        matrix: combo,
        seed,
        inputs: Vec::new(),
        files: Vec::new(),
        outputs,
        workspace_outputs,
    })
}
