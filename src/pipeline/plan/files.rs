//! Files named in params: linked to the stages that write them (DVC-style
//! edges), checked to exist, and extended by what the kinds report their
//! files reference.

use super::{Ctx, FileParam, Node};
use crate::stages::{self, ParamType};
use serde_yaml_ng::Value;
use std::collections::HashMap;
use std::path::{Component, Path};

/// Collect path-typed params, link them to producing stages, and check that
/// the rest exist.
pub(super) fn resolve_files(cx: &mut Ctx, dir: &Path, nodes: &mut [Node]) {
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
