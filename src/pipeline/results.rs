//! Results directories: `results/<pipeline>/<stage>/` holds a copy of each
//! output and a `manifest.json` saying where it came from. They are
//! materialized from the cache, so deleting them costs no recomputation.

use super::key::KeyMaterial;
use super::store::{OutputRecord, Store, StoreError};
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
    pub kind_version: u32,
    pub modalflow_version: String,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct InputOrigin {
    pub from: String,
    pub hash: String,
}

impl Manifest {
    pub fn new(
        stage: &str,
        material: &KeyMaterial,
        key: &str,
        origins: BTreeMap<String, Vec<InputOrigin>>,
        outputs: BTreeMap<String, OutputRecord>,
        seconds: f64,
        counters: BTreeMap<String, u64>,
    ) -> Manifest {
        Manifest {
            stage: stage.to_string(),
            kind: material.kind.clone(),
            key: key.to_string(),
            inputs: origins,
            params: material.params.clone(),
            seed: material.seed,
            files: material.files.clone(),
            outputs,
            seconds,
            counters,
            kind_version: material.version,
            modalflow_version: env!("CARGO_PKG_VERSION").to_string(),
        }
    }
}

/// Make `dir` hold exactly the manifest's outputs and the manifest. Skips the
/// copy when the directory already holds this key's outputs (same sizes).
pub fn materialize(store: &Store, dir: &Path, manifest: &Manifest) -> Result<(), StoreError> {
    if up_to_date(dir, manifest) {
        return Ok(());
    }
    let parent = dir.parent().unwrap_or(Path::new("."));
    let io = |op: &'static str, p: &Path| {
        let p = p.to_path_buf();
        move |source| StoreError {
            op,
            path: p,
            source,
        }
    };
    fs::create_dir_all(parent).map_err(io("create", parent))?;
    let name = dir
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let staging = parent.join(format!(".{name}.staging-{}", std::process::id()));
    if staging.exists() {
        fs::remove_dir_all(&staging).map_err(io("remove", &staging))?;
    }
    fs::create_dir_all(&staging).map_err(io("create", &staging))?;
    for out in manifest.outputs.values() {
        store.checkout(&out.artifact, &staging.join(&out.file))?;
    }
    let json = serde_json::to_vec_pretty(manifest).unwrap_or_default();
    fs::write(staging.join("manifest.json"), json).map_err(io("write", &staging))?;
    // Another run of the same pipeline may materialize the same stage at the
    // same moment; whoever renames last wins, and a loser whose rename fails
    // accepts the winner's directory when it holds the same key.
    for _ in 0..3 {
        if dir.exists() {
            let _ = fs::remove_dir_all(dir);
        }
        if fs::rename(&staging, dir).is_ok() {
            return Ok(());
        }
        if up_to_date(dir, manifest) {
            let _ = fs::remove_dir_all(&staging);
            return Ok(());
        }
    }
    fs::rename(&staging, dir).map_err(io("rename", dir))
}

fn up_to_date(dir: &Path, manifest: &Manifest) -> bool {
    let Ok(bytes) = fs::read(dir.join("manifest.json")) else {
        return false;
    };
    let Ok(old) = serde_json::from_slice::<Manifest>(&bytes) else {
        return false;
    };
    old.key == manifest.key
        && manifest.outputs.values().all(|o| match o.artifact.kind {
            super::store::ArtifactKind::File => {
                fs::metadata(dir.join(&o.file)).is_ok_and(|m| m.len() == o.artifact.bytes)
            }
            super::store::ArtifactKind::Dir => dir.join(&o.file).is_dir(),
        })
}

/// The manifest in a results directory, if any.
pub fn read_manifest(dir: &Path) -> Option<Manifest> {
    serde_json::from_slice(&fs::read(dir.join("manifest.json")).ok()?).ok()
}
