//! Files named in params: linked to the stages that write them (DVC-style
//! edges), checked to exist, and extended by what the kinds report their
//! files reference.

use super::{Ctx, FileParam, Node};
use crate::stages;
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
    for (i, node) in nodes.iter_mut().enumerate() {
        let before = cx.diags.len();
        let mut files = Vec::new();
        for f in node.kind.files(&node.parsed) {
            // `deps[1]` is at `params.deps.1` in the file.
            let mut loc_path = vec!["stages".to_string(), node.base.clone(), "params".into()];
            match f.param.split_once('[') {
                Some((name, rest)) => {
                    loc_path.push(name.into());
                    loc_path.push(rest.trim_end_matches(']').into());
                }
                None => loc_path.push(f.param.clone()),
            }
            let loc_path: Vec<&str> = loc_path.iter().map(String::as_str).collect();
            if f.glob {
                match stages::expand_glob(dir, &f.path) {
                    Ok(found) => files.extend(found.into_iter().map(|(rel, _)| FileParam {
                        param: f.param.clone(),
                        path: rel,
                        producer: None,
                    })),
                    Err(message) => {
                        let loc = cx.spans.value(&loc_path);
                        cx.at(loc, format!("param `{}` of stage `{}`: {message}", f.param, node.name), Some("paths are relative to the pipeline file's directory; check the pattern".into()));
                    }
                }
                continue;
            }
            let path = normalize(&f.path);
            let producer = producers.get(&path).filter(|(p, _)| *p != i).cloned();
            if producer.is_none() && !dir.join(&path).exists() {
                let loc = cx.spans.value(&loc_path);
                cx.at(loc, format!("file `{}` named by param `{}` of stage `{}` does not exist", f.path, f.param, node.name), Some(format!("paths are relative to the pipeline file's directory ({}); create the file or let a `command` stage produce it via `outs`", dir.display())));
            }
            files.push(FileParam {
                param: f.param,
                path,
                producer,
            });
        }
        // Look into the files once they all exist and the params are good.
        if node.parsed.is_valid() && cx.diags.len() == before {
            match node.kind.file_dependencies(&node.parsed, dir) {
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
