//! The roots a run writes below — the pipeline directory (its declared
//! `outs`), the cache, and the pipeline's results folder
//! `<results>/<name>/` — must not contain one another: a results folder
//! that is the project would have its stage folders replace the project's
//! own (`--results .` with a pipeline named after its directory), a cache
//! inside a results folder is wiped by the next materialization, and an
//! out that is the cache (`outs: [cache]`) is removed before its command
//! runs. Checked before anything is written ([`check`]), by `validate`,
//! `status` and `run` alike.

use super::plan::Plan;
use crate::paths;
use std::path::{Path, PathBuf};

/// Why the roots of a run cannot be used together.
#[derive(Debug, thiserror::Error)]
#[error("{message}\n  = help: {help}")]
pub struct RootsOverlap {
    pub message: String,
    pub help: String,
}

fn refuse(message: String, help: &str) -> Result<(), RootsOverlap> {
    Err(RootsOverlap {
        message,
        help: help.to_string(),
    })
}

/// The pipeline's results folder, `<results>/<name>`, absolute.
pub fn results_dir(plan: &Plan, results: &Path) -> PathBuf {
    paths::absolute(&results.join(&plan.results_name))
}

/// Refuse cache, results folder, pipeline directory and declared outputs
/// that overlap, and a results folder that is a symbolic link.
pub fn check(plan: &Plan, cache: &Path, results: &Path) -> Result<(), RootsOverlap> {
    let project = paths::absolute(&plan.dir);
    let cache = paths::absolute(cache);
    let folder = results.join(&plan.results_name);
    if std::fs::symlink_metadata(&folder).is_ok_and(|m| m.file_type().is_symlink()) {
        return refuse(
            format!("the results folder {} is a symbolic link", folder.display()),
            "modalflow replaces stage folders there and does not write through links; \
             remove the link or choose another --results",
        );
    }
    let res = results_dir(plan, results);
    if paths::overlap(&cache, &res) {
        return refuse(
            format!(
                "the cache {} and the results folder {} overlap",
                cache.display(),
                res.display()
            ),
            "results folders are replaced from the cache on every run; keep --cache and \
             --results apart (defaults: ./cache and ./results)",
        );
    }
    if project.starts_with(&res) {
        return refuse(
            format!(
                "the results folder {} contains the pipeline directory {}",
                res.display(),
                project.display()
            ),
            "stage folders there would replace the project's own folders; use --results \
             on a folder of its own (default: ./results)",
        );
    }
    if project.starts_with(&cache) {
        return refuse(
            format!(
                "the cache {} contains the pipeline directory {}",
                cache.display(),
                project.display()
            ),
            "the cache writes objects/, runs/, pipelines/ and tmp/ below its root; use \
             --cache on a folder of its own (default: ./cache)",
        );
    }
    for node in &plan.nodes {
        for out in &node.workspace_outputs {
            let path = paths::absolute(&plan.dir.join(out));
            for (what, root) in [("the cache", &cache), ("the results folder", &res)] {
                if paths::overlap(&path, root) {
                    return refuse(
                        format!(
                            "stage `{}` declares output `{out}`, which overlaps {what} {}",
                            node.name,
                            root.display()
                        ),
                        "outputs are removed before their command runs; write them to a \
                         folder of their own below the pipeline directory",
                    );
                }
            }
        }
    }
    Ok(())
}
