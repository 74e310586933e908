//! Results directories: `results/<pipeline>/<stage>/` holds a copy of each
//! output and a `manifest.json` saying where it came from. They are
//! materialized from the cache, so deleting them costs no recomputation.

use super::key::KeyMaterial;
use super::record::RunRecord;
use super::store::{err, hash_path, process_nonce, ArtifactKind, OutputRecord, Store, StoreError};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::fs;
use std::path::Path;

/// The provenance of one stage's results, as `manifest.json` and `modalflow show`.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Manifest {
    pub stage: String,
    pub kind: String,
    pub key: String,
    /// Input name → the references and content hashes it was bound to.
    pub inputs: BTreeMap<String, Vec<InputOrigin>>,
    pub params: serde_json::Value,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
    /// Files named in params → content hash.
    pub files: BTreeMap<String, String>,
    pub outputs: BTreeMap<String, OutputRecord>,
    /// Wall time of the run that produced the outputs.
    pub seconds: f64,
    pub counters: BTreeMap<String, u64>,
    /// The run's warnings (its run record's), what `run` printed as
    /// `warning:` lines; absent when there were none.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
    pub kind_version: u32,
    pub modalflow_version: String,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct InputOrigin {
    pub from: String,
    pub hash: String,
}

impl Manifest {
    /// The manifest of `record`, the run of `stage` under `key`.
    pub fn new(
        stage: &str,
        material: &KeyMaterial,
        key: &str,
        origins: BTreeMap<String, Vec<InputOrigin>>,
        record: &RunRecord,
    ) -> Manifest {
        Manifest {
            stage: stage.to_string(),
            kind: material.kind.clone(),
            key: key.to_string(),
            inputs: origins,
            params: material.params.clone(),
            seed: material.seed,
            files: material.files.clone(),
            outputs: record.outputs.clone(),
            seconds: record.seconds,
            counters: record.counters.clone(),
            warnings: record.warnings.clone(),
            kind_version: material.version,
            modalflow_version: env!("CARGO_PKG_VERSION").to_string(),
        }
    }
}

/// Make `dir` hold exactly the manifest's outputs and the manifest. Skips the
/// copy when the directory already holds them, checked by content: every
/// output file (every file of a directory output) hashes to the manifest's
/// hash and the manifest itself is the same text. Anything edited, missing
/// or added inside an output is replaced from the cache.
///
/// The content check reads every result file on every run. A stat
/// fingerprint (size, mtime, inode) would be cheaper on large results but
/// misses an edit that keeps size and mtime (`cp -p`, `rsync -t`, two
/// writes within the timestamp granularity); the cache verifies its own
/// objects by content on every run too, so this at most doubles that cost
/// (`benchmarks/engine.rs`).
pub fn materialize(store: &Store, dir: &Path, manifest: &Manifest) -> Result<(), StoreError> {
    let json = serde_json::to_vec_pretty(manifest).unwrap_or_default();
    if fs::read(dir.join("manifest.json")).is_ok_and(|old| old == json)
        && drift(dir, manifest).is_empty()
    {
        return Ok(());
    }
    let parent = dir.parent().unwrap_or(Path::new("."));
    fs::create_dir_all(parent).map_err(err("create directory", parent))?;
    let name = dir
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let staging = parent.join(format!(".{name}.staging-{}", process_nonce()));
    let result = stage_and_swap(store, dir, &staging, manifest, &json);
    if result.is_err() {
        // A full disk or a read-only results directory must not leave
        // half a copy behind.
        let _ = fs::remove_dir_all(&staging);
    }
    result
}

fn stage_and_swap(
    store: &Store,
    dir: &Path,
    staging: &Path,
    manifest: &Manifest,
    json: &[u8],
) -> Result<(), StoreError> {
    if staging.exists() {
        fs::remove_dir_all(staging).map_err(err("remove", staging))?;
    }
    fs::create_dir_all(staging).map_err(err("create directory", staging))?;
    for out in manifest.outputs.values() {
        store.checkout(&out.artifact, &staging.join(&out.file))?;
    }
    let path = staging.join("manifest.json");
    fs::write(&path, json).map_err(err("write", &path))?;
    // Another run of the same pipeline may materialize the same stage at the
    // same moment; whoever renames last wins, and a loser whose rename fails
    // accepts the winner's directory when it holds the same outputs.
    for _ in 0..3 {
        if dir.exists() {
            let _ = fs::remove_dir_all(dir);
        }
        if fs::rename(staging, dir).is_ok() {
            return Ok(());
        }
        if read_manifest(dir).is_some_and(|m| m.key == manifest.key)
            && drift(dir, manifest).is_empty()
        {
            let _ = fs::remove_dir_all(staging);
            return Ok(());
        }
    }
    fs::rename(staging, dir).map_err(err("rename", dir))
}

/// How one output in a results directory differs from its manifest.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct Drift {
    /// The output's file or directory name inside the stage's directory.
    pub path: String,
    /// `missing` or `modified` (a directory output: a file in it edited,
    /// missing or added).
    pub problem: &'static str,
}

/// The outputs of `dir` whose content differs from `manifest` (empty: all
/// intact).
pub fn drift(dir: &Path, manifest: &Manifest) -> Vec<Drift> {
    manifest
        .outputs
        .values()
        .filter_map(|o| {
            let path = dir.join(&o.file);
            let problem = match o.artifact.kind {
                ArtifactKind::File if !path.is_file() => "missing",
                ArtifactKind::Dir if !path.is_dir() => "missing",
                _ => match hash_path(&path) {
                    Ok(h) if h == o.artifact.hash => return None,
                    Ok(_) => "modified",
                    Err(_) => "missing",
                },
            };
            Some(Drift {
                path: o.file.clone(),
                problem,
            })
        })
        .collect()
}

/// The manifest in a results directory, if any.
pub fn read_manifest(dir: &Path) -> Option<Manifest> {
    serde_json::from_slice(&fs::read(dir.join("manifest.json")).ok()?).ok()
}

/// Remove the folders of stages no longer in the file from the pipeline's
/// results directory `results`: directories holding a `manifest.json`
/// whose name is not in `stages` (nothing else there is touched).
pub fn remove_stale(results: &Path, stages: &[&str]) {
    let Ok(dir) = std::fs::read_dir(results) else {
        return;
    };
    for entry in dir.flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        let path = entry.path();
        if !stages.contains(&name.as_str()) && path.join("manifest.json").is_file() {
            let _ = std::fs::remove_dir_all(&path);
        }
    }
}

/// The file in a `--set` run's results folder that records its overrides.
pub const OVERRIDES_FILE: &str = "overrides.json";

/// A run with `--set` overrides, recorded in its own results folder
/// `<results>/<pipeline>--set-<hash>/` (see `plan::results_name`): the
/// file's own results folder is never written by it.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct SetRun {
    /// The results folder's name.
    pub results: String,
    /// The overrides, as given on the command line.
    pub overrides: Vec<String>,
}

/// Record a `--set` run's overrides in its results folder `dir`.
pub fn write_set_run(dir: &Path, run: &SetRun) -> std::io::Result<()> {
    fs::create_dir_all(dir)?;
    let json = serde_json::to_vec_pretty(run).map_err(std::io::Error::other)?;
    fs::write(dir.join(OVERRIDES_FILE), json)
}

/// The `--set` runs of pipeline `name` recorded under the results root.
pub fn set_runs(root: &Path, name: &str) -> Vec<SetRun> {
    let prefix = format!("{name}--set-");
    let mut runs: Vec<SetRun> = fs::read_dir(root)
        .into_iter()
        .flatten()
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().starts_with(&prefix))
        .filter_map(|e| fs::read(e.path().join(OVERRIDES_FILE)).ok())
        .filter_map(|bytes| serde_json::from_slice::<SetRun>(&bytes).ok())
        .collect();
    runs.sort_by(|a, b| a.results.cmp(&b.results));
    runs
}

/// The key of the results in `dir` when they are of another run than
/// `key` (a manifest is there and names another key).
pub fn out_of_step(dir: &Path, key: &str) -> Option<String> {
    read_manifest(dir).map(|m| m.key).filter(|k| k != key)
}
