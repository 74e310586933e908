//! The last run of each pipeline, like `dvc.lock`: per stage, the key and
//! everything that went into it. `status` diffs against it to say *why* a
//! stage will run; `gc` keeps what it references.

use super::key::{param_changes, KeyMaterial};
use super::store::{Store, StoreError};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// One stage's entry in the last-run record.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct StageProvenance {
    pub key: String,
    #[serde(flatten)]
    pub material: KeyMaterial,
    /// Output name → content hash.
    pub outputs: BTreeMap<String, String>,
}

/// The last-run record of one pipeline.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct LastRun {
    pub pipeline: String,
    /// The pipeline file (absolute) whose runs this records: a pipeline is
    /// its `name:` in one cache, so a second file with that name is refused.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub file: Option<PathBuf>,
    pub stages: BTreeMap<String, StageProvenance>,
}

impl LastRun {
    /// The other pipeline file that owns this name, if `file` is not the
    /// owner and the owner still exists (a moved or renamed file takes over).
    pub fn owned_by_another(&self, file: &Path) -> Option<&Path> {
        let owner = self.file.as_deref()?;
        (owner != file && owner.exists()).then_some(owner)
    }
}

fn path(store: &Store, pipeline: &str) -> PathBuf {
    store
        .root()
        .join("pipelines")
        .join(format!("{pipeline}.json"))
}

/// The last-run record of `pipeline` (empty if it never ran on this cache).
pub fn load(store: &Store, pipeline: &str) -> LastRun {
    std::fs::read(path(store, pipeline))
        .ok()
        .and_then(|b| serde_json::from_slice(&b).ok())
        .unwrap_or_else(|| LastRun {
            pipeline: pipeline.to_string(),
            file: None,
            stages: BTreeMap::new(),
        })
}

/// Every pipeline's last-run record in the cache.
pub fn load_all(store: &Store) -> Vec<LastRun> {
    let Ok(dir) = std::fs::read_dir(store.root().join("pipelines")) else {
        return Vec::new();
    };
    dir.flatten()
        .filter(|e| e.path().extension().is_some_and(|x| x == "json"))
        .filter_map(|e| serde_json::from_slice(&std::fs::read(e.path()).ok()?).ok())
        .collect()
}

/// Merge `updates` into the pipeline's record, under a lock so two runs of
/// the same pipeline do not lose each other's entries. `keep` lists the
/// stage names of the current file; entries for stages no longer in the file
/// are dropped.
pub fn update(
    store: &Store,
    pipeline: &str,
    file: &Path,
    updates: Vec<(String, StageProvenance)>,
    keep: &[&str],
) -> Result<(), StoreError> {
    let _guard = store.lock_key(&format!("pipeline-{pipeline}"))?;
    let mut last = load(store, pipeline);
    last.file = Some(file.to_path_buf());
    last.stages.retain(|name, _| keep.contains(&name.as_str()));
    last.stages.extend(updates);
    let json = serde_json::to_vec_pretty(&last).unwrap_or_default();
    store.write_atomic(&path(store, pipeline), &json)
}

/// Why a stage whose key has no cache entry must run, compared with its
/// previous run. `upstream_running` names upstream stages that will run (so
/// input hashes are not known yet); `input_refs` gives each input's
/// reference text (`truth.frf`) for the message.
pub fn explain(
    previous: Option<&StageProvenance>,
    now: &KeyMaterial,
    upstream_running: &[String],
    input_refs: &BTreeMap<String, String>,
) -> String {
    let Some(prev) = previous else {
        return "never ran".into();
    };
    let prev = &prev.material;
    if prev.kind != now.kind {
        return format!("kind changed {} -> {}", prev.kind, now.kind);
    }
    if prev.version != now.version {
        return format!("kind version changed {} -> {}", prev.version, now.version);
    }
    let mut reasons: Vec<String> = param_changes(&prev.params, &now.params)
        .into_iter()
        .map(|c| format!("param {c}"))
        .collect();
    if prev.seed != now.seed {
        reasons.push(format!(
            "seed changed {} -> {}",
            prev.seed.map_or("none".into(), |s| s.to_string()),
            now.seed.map_or("none".into(), |s| s.to_string())
        ));
    }
    for (file, hash) in &now.files {
        match prev.files.get(file) {
            Some(h) if h == hash => {}
            Some(_) => reasons.push(format!("file {file} changed")),
            None => reasons.push(format!("file {file} added")),
        }
    }
    if upstream_running.is_empty() {
        for (input, hashes) in &now.inputs {
            if prev.inputs.get(input) != Some(hashes) {
                let name = input_refs.get(input).unwrap_or(input);
                reasons.push(format!("input {name} changed"));
            }
        }
    } else {
        reasons.push(format!("upstream {} will run", upstream_running.join(", ")));
    }
    if upstream_running.is_empty() && prev.upstream_warnings != now.upstream_warnings {
        reasons.push("upstream warnings changed".into());
    }
    if reasons.is_empty() {
        "no cache entry for an unchanged stage (removed by gc or another cache)".into()
    } else {
        reasons.join("; ")
    }
}
