//! From a pipeline file to a validated [`Plan`]: matrix expansion, kind and
//! param checks against each kind's schema, input resolution, file params,
//! and the DAG. Every problem is collected as a located [`Diagnostic`];
//! nothing runs unless the whole file validates.

use super::diagnostic::{closest, Diagnostic, Diagnostics, Location};
use super::graph;
use super::matrix::{self, Combination};
use super::span::SpanIndex;
use super::spec::{InputRef, PipelineSpec, Selector, StageSpec};
use crate::stages::{self, ParamType, Stage};
use serde_yaml_ng::{Mapping, Value};
use std::collections::{BTreeSet, HashMap};
use std::path::{Component, Path, PathBuf};

/// A validated, expanded pipeline ready to run.
pub struct Plan {
    /// The pipeline file as named on the command line.
    pub file: PathBuf,
    /// Directory of the pipeline file; commands run and paths resolve here.
    pub dir: PathBuf,
    pub name: String,
    pub seed: u64,
    pub nodes: Vec<Node>,
    /// Upstream node indices of each node (deduplicated, sorted).
    pub upstream: Vec<Vec<usize>>,
    /// A topological order of all nodes.
    pub order: Vec<usize>,
}

/// One expanded stage.
pub struct Node {
    /// Expanded name, e.g. `ident[method=pso,seed=2]`.
    pub name: String,
    /// The stage entry it came from.
    pub base: String,
    pub kind: &'static dyn Stage,
    pub params: Mapping,
    pub matrix: Combination,
    pub seed: u64,
    pub inputs: Vec<Binding>,
    pub files: Vec<FileParam>,
    pub outputs: Vec<String>,
    pub workspace_outputs: Vec<String>,
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

struct Ctx<'a> {
    file: &'a Path,
    source: &'a str,
    spans: SpanIndex,
    diags: Vec<Diagnostic>,
}

impl Ctx<'_> {
    fn at(&mut self, loc: Option<Location>, message: String, help: Option<String>) {
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
    plan_source(file, &dir, &source)
}

/// Validate `source` as the pipeline file `file` located in `dir`.
pub fn plan_source(file: &Path, dir: &Path, source: &str) -> Result<Plan, PlanError> {
    let mut cx = Ctx {
        file,
        source,
        spans: SpanIndex::default(),
        diags: Vec::new(),
    };
    let spec: PipelineSpec = match serde_yaml_ng::from_str(source) {
        Ok(s) => s,
        Err(e) => {
            let loc = e.location().map(|l| Location {
                line: l.line(),
                column: l.column(),
            });
            let help = "a pipeline file has `name`, optional `seed` and `description`, and `stages`; \
                        each stage has `kind`, and optional `params`, `inputs`, `matrix`, `description`";
            cx.at(
                loc,
                format!("invalid pipeline file: {e}"),
                Some(help.into()),
            );
            return Err(PlanError::Invalid(Diagnostics(cx.diags)));
        }
    };
    cx.spans = SpanIndex::build(source);
    for (path, loc) in cx.spans.duplicates.clone() {
        cx.at(
            Some(loc),
            format!("duplicate key `{}`", path.join(".")),
            Some("each key may appear once per mapping; remove or rename one".into()),
        );
    }
    let mut nodes = expand(&mut cx, &spec, dir);
    resolve_inputs(&mut cx, &spec, &mut nodes);
    resolve_files(&mut cx, dir, &mut nodes);
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
    if !cx.diags.is_empty() {
        return Err(PlanError::Invalid(Diagnostics(cx.diags)));
    }
    Ok(Plan {
        file: file.to_path_buf(),
        dir: dir.to_path_buf(),
        name: spec.name,
        seed: spec.seed,
        nodes,
        upstream,
        order,
    })
}

fn valid_stage_name(name: &str) -> bool {
    !name.is_empty()
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
}

/// Kinds, matrix expansion and param checks, one node per combination.
fn expand(cx: &mut Ctx, spec: &PipelineSpec, _dir: &Path) -> Vec<Node> {
    if !valid_stage_name(&spec.name) {
        let loc = cx.spans.value(&["name"]);
        cx.at(
            loc,
            format!("invalid pipeline name `{}`", spec.name),
            Some("use letters, digits, `_` and `-` (it names the results directory)".into()),
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
                Some("use letters, digits, `_` and `-`; dots and brackets are reserved for references".into()),
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
            continue;
        };
        if !check_matrix(cx, base, st) {
            continue;
        }
        for combo in matrix::combinations(&st.matrix) {
            if let Some(node) = expand_one(cx, spec, base, st, kind, combo) {
                nodes.push(node);
            }
        }
    }
    nodes
}

fn check_matrix(cx: &mut Ctx, base: &str, st: &StageSpec) -> bool {
    let mut ok = true;
    for (key, values) in &st.matrix {
        let loc = cx.spans.value(&["stages", base, "matrix", key]);
        if values.is_empty() {
            cx.at(
                loc,
                format!("matrix key `{key}` of stage `{base}` has no values"),
                Some("give at least one value".into()),
            );
            ok = false;
        }
        if values.iter().any(|v| matrix::scalar_text(v).is_none()) {
            cx.at(
                loc,
                format!("matrix key `{key}` of stage `{base}` has a non-scalar value"),
                Some("matrix values must be strings, numbers or booleans".into()),
            );
            ok = false;
        }
    }
    ok
}

fn expand_one(
    cx: &mut Ctx,
    spec: &PipelineSpec,
    base: &str,
    st: &StageSpec,
    kind: &'static dyn Stage,
    combo: Combination,
) -> Option<Node> {
    let params = match matrix::substitute_map(&st.params, &combo, &mut Vec::new()) {
        Ok(p) => p,
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
    check_params(cx, base, kind, &params);
    let seed = params
        .get("seed")
        .and_then(Value::as_u64)
        .unwrap_or(spec.seed);
    let outputs = kind.outputs(&params);
    let workspace_outputs = kind
        .workspace_outputs(&params)
        .iter()
        .map(|p| normalize(p))
        .collect();
    Some(Node {
        name: matrix::expanded_name(base, &combo),
        base: base.to_string(),
        kind,
        params,
        matrix: combo,
        seed,
        inputs: Vec::new(),
        files: Vec::new(),
        outputs,
        workspace_outputs,
    })
}

fn check_params(cx: &mut Ctx, base: &str, kind: &dyn Stage, params: &Mapping) {
    let before = cx.diags.len();
    let schema = kind.params();
    for (k, v) in params {
        let key = matrix::scalar_text(k).unwrap_or_default();
        let Some(ps) = schema.iter().find(|p| p.name == key) else {
            let allowed: Vec<&str> = schema.iter().map(|p| p.name).collect();
            let mut help = format!("`{}` accepts: {}", kind.kind(), allowed.join(", "));
            if let Some(c) = closest(&key, allowed.iter().copied()) {
                help = format!("did you mean `{c}`? {help}");
            }
            let loc = cx.spans.key(&["stages", base, "params", &key]);
            cx.at(
                loc,
                format!(
                    "unknown param `{key}` for stage `{base}` (kind `{}`)",
                    kind.kind()
                ),
                Some(help),
            );
            continue;
        };
        if let Some(bad) = non_finite(v, &mut vec![key.clone()]) {
            let mut path = vec!["stages", base, "params"];
            path.extend(bad.iter().map(String::as_str));
            let loc = cx.spans.nearest(&path);
            cx.at(
                loc,
                format!(
                    "param `{}` of stage `{base}` is not a finite number",
                    bad.join(".")
                ),
                Some(
                    "use a finite number; NaN and infinity cannot be hashed or computed with"
                        .into(),
                ),
            );
            continue;
        }
        if !type_matches(ps.ty, v) {
            let loc = cx.spans.value(&["stages", base, "params", &key]);
            cx.at(
                loc,
                format!(
                    "param `{key}` of stage `{base}` must be {}",
                    ps.ty.describe()
                ),
                Some(ps.doc.to_string()),
            );
        }
    }
    for ps in schema.iter().filter(|p| p.required) {
        if !params.contains_key(ps.name) {
            let loc = cx.spans.key(&["stages", base]);
            cx.at(
                loc,
                format!(
                    "stage `{base}` (kind `{}`) needs param `{}`",
                    kind.kind(),
                    ps.name
                ),
                Some(format!("`{}`: {}", ps.name, ps.doc)),
            );
        }
    }
    if cx.diags.len() == before {
        if let Err(p) = kind.check(params) {
            let mut path = vec!["stages", base, "params"];
            path.extend(p.path.iter().map(String::as_str));
            let loc = cx.spans.nearest(&path);
            cx.at(loc, format!("stage `{base}`: {}", p.message), p.help);
        }
    }
}

fn non_finite(v: &Value, path: &mut Vec<String>) -> Option<Vec<String>> {
    match v {
        Value::Number(n) if n.as_f64().is_some_and(|f| !f.is_finite()) => Some(path.clone()),
        Value::Sequence(items) => items.iter().enumerate().find_map(|(i, x)| {
            path.push(i.to_string());
            let r = non_finite(x, path);
            path.pop();
            r
        }),
        Value::Mapping(m) => m.iter().find_map(|(k, x)| {
            path.push(matrix::scalar_text(k).unwrap_or_default());
            let r = non_finite(x, path);
            path.pop();
            r
        }),
        _ => None,
    }
}

fn type_matches(ty: ParamType, v: &Value) -> bool {
    let strings = |v: &Value| {
        v.as_sequence()
            .is_some_and(|s| s.iter().all(Value::is_string))
    };
    match ty {
        ParamType::Bool => v.is_bool(),
        ParamType::Integer => v.is_i64() || v.is_u64(),
        ParamType::Number => v.is_number(),
        ParamType::String => v.is_string(),
        ParamType::Path | ParamType::Glob => v.as_str().is_some_and(|s| !s.trim().is_empty()),
        ParamType::Paths | ParamType::Strings => strings(v),
        ParamType::Enum(opts) => v.as_str().is_some_and(|s| opts.contains(&s)),
        ParamType::Mapping => v.is_mapping(),
        ParamType::Any => true,
    }
}

/// Bind every input reference to upstream nodes and outputs.
fn resolve_inputs(cx: &mut Ctx, spec: &PipelineSpec, nodes: &mut [Node]) {
    let mut by_base: HashMap<&str, Vec<usize>> = HashMap::new();
    for (i, n) in nodes.iter().enumerate() {
        by_base.entry(n.base.as_str()).or_default().push(i);
    }
    let mut bindings: Vec<Vec<Binding>> = Vec::with_capacity(nodes.len());
    for node in nodes.iter() {
        let st = &spec.stages[&node.base];
        let mut out = Vec::new();
        let declared = node.kind.inputs();
        for (input, value) in &st.inputs {
            let loc_key = cx.spans.key(&["stages", &node.base, "inputs", input]);
            let spec_in = declared.map(|d| d.iter().find(|s| s.name == input));
            if let Some(None) = spec_in {
                let allowed: Vec<&str> = declared.unwrap_or(&[]).iter().map(|s| s.name).collect();
                cx.at(
                    loc_key,
                    format!(
                        "unknown input `{input}` for stage `{}` (kind `{}`)",
                        node.base,
                        node.kind.kind()
                    ),
                    Some(format!(
                        "`{}` takes inputs: {}",
                        node.kind.kind(),
                        allowed.join(", ")
                    )),
                );
                continue;
            }
            let mut sources = Vec::new();
            for (ri, raw) in value.refs().into_iter().enumerate() {
                let text = match matrix::substitute_str(raw, &node.matrix, &[]) {
                    Ok(Value::String(s)) => s,
                    Ok(other) => matrix::scalar_text(&other).unwrap_or_default(),
                    Err(e) => {
                        cx.at(
                            loc_key,
                            format!(
                                "`${{matrix.{}}}` in input `{input}` names no matrix key",
                                e.key
                            ),
                            None,
                        );
                        continue;
                    }
                };
                let loc = match value {
                    super::spec::InputValue::One(_) => {
                        cx.spans.value(&["stages", &node.base, "inputs", input])
                    }
                    super::spec::InputValue::Many(_) => {
                        cx.spans
                            .value(&["stages", &node.base, "inputs", input, &ri.to_string()])
                    }
                };
                match resolve_ref(&text, &by_base, nodes) {
                    Ok(found) => sources.extend(found),
                    Err((msg, help)) => cx.at(
                        loc,
                        format!("input `{input}` of stage `{}`: {msg}", node.name),
                        Some(help),
                    ),
                }
            }
            let list_ok = spec_in.flatten().is_none_or(|s| s.list);
            if sources.len() > 1 && !list_ok {
                let loc = cx.spans.value(&["stages", &node.base, "inputs", input]);
                cx.at(loc, format!("input `{input}` of stage `{}` takes one artifact but the reference matches {}", node.name, sources.len()), Some("select one expansion, e.g. `stage[key=value].output`".into()));
            }
            out.push(Binding {
                name: input.clone(),
                sources,
            });
        }
        for s in declared.unwrap_or(&[]).iter().filter(|s| s.required) {
            if !st.inputs.contains_key(s.name) {
                let loc = cx.spans.key(&["stages", &node.base]);
                cx.at(
                    loc,
                    format!(
                        "stage `{}` (kind `{}`) needs input `{}`",
                        node.base,
                        node.kind.kind(),
                        s.name
                    ),
                    Some(format!("`{}`: {}", s.name, s.doc)),
                );
            }
        }
        bindings.push(out);
    }
    for (node, b) in nodes.iter_mut().zip(bindings) {
        node.inputs = b;
    }
}

type RefError = (String, String);

fn resolve_ref(
    text: &str,
    by_base: &HashMap<&str, Vec<usize>>,
    nodes: &[Node],
) -> Result<Vec<(usize, String)>, RefError> {
    let Some(r) = InputRef::parse(text) else {
        return Err((
            format!("`{text}` is not a reference"),
            "write `stage.output`, `stage[*].output` or `stage[key=value].output`".into(),
        ));
    };
    let Some(candidates) = by_base.get(r.stage.as_str()) else {
        let mut names: Vec<&str> = by_base.keys().copied().collect();
        names.sort();
        let mut help = format!("stages: {}", names.join(", "));
        if let Some(c) = closest(&r.stage, names.iter().copied()) {
            help = format!("did you mean `{c}`? {help}");
        }
        return Err((format!("no stage named `{}`", r.stage), help));
    };
    let chosen: Vec<usize> = match &r.selector {
        Selector::All => candidates.clone(),
        Selector::None if candidates.len() == 1 && nodes[candidates[0]].matrix.is_empty() => {
            candidates.clone()
        }
        Selector::None => {
            return Err((
                format!("`{}` is a matrix of {} stages", r.stage, candidates.len()),
                format!(
                    "use `{}[*].{}` for all of them, or one of: {}",
                    r.stage,
                    r.output,
                    names_of(candidates, nodes)
                ),
            ))
        }
        Selector::Exact(pairs) => {
            let hit: Vec<usize> = candidates
                .iter()
                .copied()
                .filter(|&i| {
                    let mut mine: Vec<(String, String)> = nodes[i]
                        .matrix
                        .iter()
                        .map(|(k, v)| (k.clone(), matrix::scalar_text(v).unwrap_or_default()))
                        .collect();
                    mine.sort();
                    &mine == pairs
                })
                .collect();
            if hit.is_empty() {
                return Err((
                    format!("no expansion of `{}` matches `{text}`", r.stage),
                    format!("expansions: {}", names_of(candidates, nodes)),
                ));
            }
            hit
        }
    };
    let mut out = Vec::new();
    for i in chosen {
        if !nodes[i].outputs.contains(&r.output) {
            return Err((
                format!("stage `{}` has no output `{}`", nodes[i].name, r.output),
                format!(
                    "outputs of `{}`: {}",
                    nodes[i].name,
                    nodes[i].outputs.join(", ")
                ),
            ));
        }
        out.push((i, r.output.clone()));
    }
    Ok(out)
}

fn names_of(ix: &[usize], nodes: &[Node]) -> String {
    ix.iter()
        .map(|&i| nodes[i].name.as_str())
        .collect::<Vec<_>>()
        .join(", ")
}

/// Collect path-typed params, link them to producing stages, and check that
/// the rest exist.
fn resolve_files(cx: &mut Ctx, dir: &Path, nodes: &mut [Node]) {
    let mut producers: HashMap<String, (usize, String)> = HashMap::new();
    for (i, n) in nodes.iter().enumerate() {
        for (out, raw) in n
            .workspace_outputs
            .iter()
            .zip(n.kind.workspace_outputs(&n.params))
        {
            if let Some((j, _)) = producers.insert(out.clone(), (i, raw)) {
                let loc = cx.spans.value(&["stages", &n.base, "params"]);
                cx.at(
                    loc,
                    format!(
                        "`{out}` is written by both `{}` and `{}`",
                        nodes[j].name, n.name
                    ),
                    Some("each output path may belong to one stage".into()),
                );
            }
        }
    }
    for (i, node) in nodes.iter_mut().enumerate() {
        let mut files = Vec::new();
        for ps in node.kind.params() {
            let Some(v) = node.params.get(ps.name) else {
                continue;
            };
            if let (ParamType::Glob, Value::String(pattern)) = (ps.ty, v) {
                match stages::expand_glob(dir, pattern) {
                    Ok(found) => files.extend(found.into_iter().map(|(rel, _)| FileParam {
                        param: ps.name.to_string(),
                        path: rel,
                        producer: None,
                    })),
                    Err(message) => {
                        let loc = cx.spans.value(&["stages", &node.base, "params", ps.name]);
                        cx.at(loc, format!("param `{}` of stage `{}`: {message}", ps.name, node.name), Some("paths are relative to the pipeline file's directory; check the pattern".into()));
                    }
                }
                continue;
            }
            let paths: Vec<(String, &str)> = match (ps.ty, v) {
                (ParamType::Path, Value::String(s)) => vec![(ps.name.to_string(), s.as_str())],
                (ParamType::Paths, Value::Sequence(items)) => items
                    .iter()
                    .enumerate()
                    .filter_map(|(k, x)| x.as_str().map(|s| (format!("{}[{k}]", ps.name), s)))
                    .collect(),
                _ => continue,
            };
            for (k, (param, raw)) in paths.into_iter().enumerate() {
                let path = normalize(raw);
                let producer = producers.get(&path).filter(|(p, _)| *p != i).cloned();
                if producer.is_none() && !dir.join(&path).exists() {
                    let loc = match ps.ty {
                        ParamType::Paths => cx.spans.value(&[
                            "stages",
                            &node.base,
                            "params",
                            ps.name,
                            &k.to_string(),
                        ]),
                        _ => cx.spans.value(&["stages", &node.base, "params", ps.name]),
                    };
                    cx.at(loc, format!("file `{raw}` named by param `{param}` of stage `{}` does not exist", node.name), Some(format!("paths are relative to the pipeline file's directory ({}); create the file or let a `command` stage produce it via `outs`", dir.display())));
                }
                files.push(FileParam {
                    param,
                    path,
                    producer,
                });
            }
        }
        if cx.diags.is_empty() {
            match node.kind.file_dependencies(&node.params, dir) {
                Ok(extra) => files.extend(extra.into_iter().map(|path| FileParam {
                    param: "(referenced)".into(),
                    path: normalize(&path),
                    producer: None,
                })),
                Err(p) => {
                    let mut path = vec!["stages", node.base.as_str(), "params"];
                    path.extend(p.path.iter().map(String::as_str));
                    let loc = cx.spans.nearest(&path);
                    cx.at(loc, format!("stage `{}`: {}", node.name, p.message), p.help);
                }
            }
        }
        node.files = files;
    }
}

/// Lexically normalize a relative path: drop `.`, fold `a/..`, use `/`.
pub fn normalize(p: &str) -> String {
    if Path::new(p).is_absolute() {
        return p.to_string();
    }
    let mut parts: Vec<String> = Vec::new();
    for c in Path::new(p).components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir if parts.last().is_some_and(|l| l != "..") => {
                parts.pop();
            }
            other => parts.push(other.as_os_str().to_string_lossy().into_owned()),
        }
    }
    parts.join("/")
}
