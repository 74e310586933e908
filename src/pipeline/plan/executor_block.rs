//! Checks of the pipeline file's `executor:` block against the stages and
//! kinds it names: known kinds, stages of the file, shardable kinds, an
//! executable `binary`.

use super::{Ctx, Node};
use crate::pipeline::diagnostic::closest;
use crate::pipeline::executor::ExecutorSpec;
use crate::stages;
use std::path::{Path, PathBuf};

/// `shards` under `kinds:` must name a kind whose stages here can be split.
pub(super) fn check_shards(cx: &mut Ctx, spec: &ExecutorSpec, nodes: &[Node]) {
    for (kind, resources) in &spec.kinds {
        if resources.shards.unwrap_or(1) <= 1 {
            continue;
        }
        let mut of_kind = nodes.iter().filter(|n| n.kind.kind() == kind).peekable();
        if of_kind.peek().is_none()
            || of_kind.any(|n| !n.parsed.is_valid() || n.kind.shardable(&n.parsed))
        {
            continue;
        }
        let loc = cx.spans.nearest(&["executor", "kinds", kind, "shards"]);
        cx.at(
            loc,
            format!("executor: no `{kind}` stage of this pipeline can be sharded"),
            Some(
                "`shards` splits a stage's batch of independent model evaluations over a job \
                 array (a `gsa` stage with method sobol); remove it here"
                    .into(),
            ),
        );
    }
}

/// Values and kind names of the `executor:` block (serde checked its shape).
pub(super) fn check_executor(cx: &mut Ctx, spec: &ExecutorSpec) {
    for p in spec.problems() {
        let path: Vec<&str> = std::iter::once("executor")
            .chain(p.path.iter().map(String::as_str))
            .collect();
        let loc = cx.spans.nearest(&path);
        cx.at(loc, format!("executor: {}", p.message), Some(p.help));
    }
    let known: Vec<&str> = stages::registry().iter().map(|s| s.kind()).collect();
    for kind in spec.kinds.keys() {
        if !known.contains(&kind.as_str()) {
            let mut help = format!("`kinds` are stage kinds: {}", known.join(", "));
            if let Some(c) = closest(kind, known.iter().copied()) {
                help = format!("did you mean `{c}`? {help}");
            }
            let loc = cx.spans.key(&["executor", "kinds", kind]);
            cx.at(
                loc,
                format!("executor: unknown stage kind `{kind}`"),
                Some(help),
            );
        }
    }
}

/// `executor.stages` names stages of the file (a base name or an expansion).
pub(super) fn check_executor_stages(cx: &mut Ctx, spec: &ExecutorSpec, nodes: &[Node]) {
    for name in spec.stages.keys() {
        if nodes.iter().any(|n| &n.name == name || &n.base == name) {
            continue;
        }
        let mut bases: Vec<&str> = nodes.iter().map(|n| n.base.as_str()).collect();
        bases.dedup();
        let mut help = format!(
            "`stages` under `executor` are stage names: {}",
            bases.join(", ")
        );
        if let Some(c) = closest(name, bases.iter().copied()) {
            help = format!("did you mean `{c}`? {help}");
        }
        let loc = cx.spans.key(&["executor", "stages", name]);
        cx.at(loc, format!("executor: no stage `{name}`"), Some(help));
    }
}

/// `executor.binary`, resolved against the pipeline file's directory, must
/// be an executable file (a job would fail with exit 127 otherwise).
pub(super) fn check_binary(cx: &mut Ctx, spec: &ExecutorSpec, dir: &Path) -> Option<PathBuf> {
    let given = spec.binary.as_ref()?;
    let path = dir.join(given);
    let executable = std::fs::metadata(&path).is_ok_and(|m| {
        use std::os::unix::fs::PermissionsExt;
        m.is_file() && m.permissions().mode() & 0o111 != 0
    });
    if !executable {
        let loc = cx.spans.value(&["executor", "binary"]);
        cx.at(
            loc,
            format!(
                "executor: `binary: {}` is not an executable file ({})",
                given.display(),
                path.display()
            ),
            Some(
                "a relative path starts at the pipeline file's directory; leave `binary` out \
                 to run this modalflow (its path must be visible on the compute nodes)"
                    .into(),
            ),
        );
    }
    Some(path)
}
