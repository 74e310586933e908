//! Files named in params: linked to the stages that write them (DVC-style
//! edges), checked to exist, and extended by what the kinds report their
//! files reference.

use super::{Ctx, FileParam, Node};
use crate::paths;
use crate::stages;
use std::collections::HashMap;
use std::path::{Component, Path, PathBuf};

/// The `read_outside:` directories, resolved against `dir`; each must be
/// an existing directory.
pub(super) fn read_roots(cx: &mut Ctx, given: &[String], dir: &Path) -> Vec<PathBuf> {
    let mut roots = Vec::new();
    for (i, text) in given.iter().enumerate() {
        match std::fs::canonicalize(dir.join(text)) {
            Ok(p) if p.is_dir() => roots.push(p),
            _ => {
                let loc = cx.spans.value(&["read_outside", &i.to_string()]);
                cx.at(
                    loc,
                    format!("`read_outside: {text}` is not a directory"),
                    Some(format!(
                        "name existing directories, relative to the pipeline file's directory ({})",
                        dir.display()
                    )),
                );
            }
        }
    }
    roots
}

/// Whether a file param may be read: it resolves (links followed) below
/// the pipeline directory or a `read_outside:` directory. A file that does
/// not exist yet is judged by its path.
fn outside(dir: &Path, roots: &[PathBuf], path: &str) -> Option<PathBuf> {
    let full = paths::absolute(&dir.join(path));
    (!paths::read_allowed(&full, dir, roots)).then_some(full)
}

fn outside_help(dir: &Path) -> String {
    format!(
        "modalflow reads only below the pipeline file's directory ({}); to read elsewhere on \
         purpose, list the directory under `read_outside:` at the top of the pipeline file, \
         or copy the file below the pipeline directory",
        dir.display()
    )
}

/// Workspace outputs by normalized path: the producing node and the
/// output's name as the kind declares it.
type Producers = HashMap<String, (usize, String)>;

/// The workspace outputs (other than node `me`'s) that a file param reads:
/// the path is an output or lies below an output folder, or (a glob) the
/// pattern matches an output. Each comes with its normalized path.
fn produced_by(
    producers: &Producers,
    path: &str,
    glob: bool,
    me: usize,
) -> Vec<(String, (usize, String))> {
    let pattern = glob.then(|| glob::Pattern::new(path).ok()).flatten();
    let mut found: Vec<(String, (usize, String))> = producers
        .iter()
        .filter(|(_, (p, _))| *p != me)
        .filter(|(out, _)| {
            path == out.as_str()
                || path.starts_with(&format!("{out}/"))
                || pattern.as_ref().is_some_and(|g| g.matches(out))
        })
        .map(|(out, p)| (out.clone(), p.clone()))
        .collect();
    found.sort();
    found
}

/// `deps[1]` is at `params.deps.1` in the file.
fn param_path(base: &str, param: &str) -> Vec<String> {
    let mut loc_path = vec!["stages".to_string(), base.to_string(), "params".into()];
    match param.split_once('[') {
        Some((name, rest)) => {
            loc_path.push(name.into());
            loc_path.push(rest.trim_end_matches(']').into());
        }
        None => loc_path.push(param.to_string()),
    }
    loc_path
}

/// Collect path-typed params, link them to producing stages, and check that
/// the rest exist. Params that failed to parse are read as written, so a
/// missing file is reported in the same round as the param problems.
pub(super) fn resolve_files(cx: &mut Ctx, dir: &Path, nodes: &mut [Node]) {
    let producers = workspace_producers(cx, nodes);
    for (i, node) in nodes.iter_mut().enumerate() {
        let before = cx.diags.len();
        let refs = if node.parsed.is_valid() {
            node.kind.files(&node.parsed)
        } else {
            node.kind.raw_files(&node.params)
        };
        let mut files = Vec::new();
        for f in refs {
            files.extend(file_params(cx, dir, &producers, i, node, f));
        }
        // Look into the files once they all exist and the params are good
        // (a file another stage writes may not exist before it runs).
        let exist = files.iter().all(|f| dir.join(&f.path).exists());
        if node.parsed.is_valid() && cx.diags.len() == before && exist {
            referenced_files(cx, dir, node, &mut files);
        }
        node.files = files;
    }
}

/// Every stage's workspace outputs by normalized path, reporting a path two
/// stages write.
fn workspace_producers(cx: &mut Ctx, nodes: &[Node]) -> Producers {
    let mut producers: Producers = HashMap::new();
    for (i, n) in nodes.iter().enumerate() {
        for (out, raw) in n
            .workspace_outputs
            .iter()
            .zip(n.kind.workspace_outputs(&n.parsed))
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
    producers
}

/// The file params that file reference `f` of node `i` stands for: the
/// workspace outputs of other stages it names (edges), and the files it
/// names or its glob matches, each reported when outside the pipeline
/// directory or (a path nobody writes) missing.
fn file_params(
    cx: &mut Ctx,
    dir: &Path,
    producers: &Producers,
    i: usize,
    node: &Node,
    f: stages::FileRef,
) -> Vec<FileParam> {
    let mut files = Vec::new();
    let loc_path = param_path(&node.base, &f.param);
    let loc_path: Vec<&str> = loc_path.iter().map(String::as_str).collect();
    let path = normalize(&f.path);
    let made = produced_by(producers, &path, f.glob, i);
    // A file another stage writes is that stage's output: an edge,
    // hashed by the output's content and restored before this runs.
    for (out, producer) in &made {
        files.push(FileParam {
            param: f.param.clone(),
            path: out.clone(),
            producer: Some(producer.clone()),
        });
    }
    let below_made = |rel: &str| {
        made.iter()
            .any(|(out, _)| rel == out || rel.starts_with(&format!("{out}/")))
    };
    if f.glob {
        match stages::expand_glob(dir, &f.path) {
            Ok(found) => {
                for (rel, _) in found.into_iter().filter(|(r, _)| !below_made(r)) {
                    if let Some(full) = outside(dir, &cx.read_roots, &rel) {
                        let loc = cx.spans.value(&loc_path);
                        cx.at(loc, format!("param `{}` of stage `{}` matches `{}`, outside the pipeline directory", f.param, node.name, full.display()), Some(outside_help(dir)));
                        continue;
                    }
                    files.push(FileParam {
                        param: f.param.clone(),
                        path: rel,
                        producer: None,
                    });
                }
            }
            Err(_) if !made.is_empty() => {}
            Err(message) => {
                let loc = cx.spans.value(&loc_path);
                cx.at(
                    loc,
                    format!("param `{}` of stage `{}`: {message}", f.param, node.name),
                    Some(no_file_help(dir)),
                );
            }
        }
        return files;
    }
    if !made.is_empty() {
        return files;
    }
    if let Some(full) = outside(dir, &cx.read_roots, &path) {
        let loc = cx.spans.value(&loc_path);
        cx.at(loc, format!("file `{}` named by param `{}` of stage `{}` is outside the pipeline directory ({})", f.path, f.param, node.name, full.display()), Some(outside_help(dir)));
        return files;
    }
    if !dir.join(&path).exists() {
        let loc = cx.spans.value(&loc_path);
        cx.at(
            loc,
            format!(
                "file `{}` named by param `{}` of stage `{}` does not exist",
                f.path, f.param, node.name
            ),
            Some(no_file_help(dir)),
        );
    }
    files.push(FileParam {
        param: f.param,
        path,
        producer: None,
    });
    files
}

fn no_file_help(dir: &Path) -> String {
    format!(
        "paths are relative to the pipeline file's directory ({}); create the file, or let a \
         stage write it: a `command` stage's `outs` or an `export` stage's `to`",
        dir.display()
    )
}

/// Further files a node's files reference (a model file's super-elements).
fn referenced_files(cx: &mut Ctx, dir: &Path, node: &Node, files: &mut Vec<FileParam>) {
    match node.kind.file_dependencies(&node.parsed, dir) {
        Ok(extra) => {
            for path in extra {
                let path = normalize(&path);
                if let Some(full) = outside(dir, &cx.read_roots, &path) {
                    let loc = cx.spans.value(&["stages", &node.base, "params"]);
                    cx.at(loc, format!("stage `{}`: a file it references, `{path}`, is outside the pipeline directory ({})", node.name, full.display()), Some(outside_help(dir)));
                    continue;
                }
                files.push(FileParam {
                    param: "(referenced)".into(),
                    path,
                    producer: None,
                });
            }
        }
        Err(p) => {
            let mut path = vec!["stages", node.base.as_str(), "params"];
            path.extend(p.path.iter().map(String::as_str));
            let loc = cx.spans.nearest(&path);
            cx.at(loc, format!("stage `{}`: {}", node.name, p.message), p.help);
        }
    }
}

/// Declared workspace outputs (`outs`) are removed before their command
/// runs and restored from the cache: one must not be the pipeline file
/// itself, nor lie behind a symbolic link (the removal would reach
/// through it).
pub(super) fn check_workspace_outputs(cx: &mut Ctx, dir: &Path, nodes: &[Node]) {
    let own = cx
        .file
        .file_name()
        .map(|n| n.to_string_lossy().into_owned());
    for n in nodes {
        for out in &n.workspace_outputs {
            let Ok(rel) = paths::relative(out) else {
                continue; // reported by the kind's check
            };
            let problem = if own.as_deref() == Some(rel.as_str()) {
                Some("is the pipeline file itself".to_string())
            } else {
                paths::no_symlink_below(dir, &rel)
                    .err()
                    .map(|e| format!("cannot be written: {e}"))
            };
            if let Some(problem) = problem {
                let loc = cx.spans.value(&["stages", &n.base, "params", "outs"]);
                cx.at(
                    loc,
                    format!("output `{out}` of stage `{}` {problem}", n.name),
                    Some(
                        "name a file or folder of the stage's own below the pipeline directory"
                            .into(),
                    ),
                );
            }
        }
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
