//! What validation needs to know of a model file — DOF count, DOFs with
//! mass, the eigenproblem's memory, the parameters — kept by content, so
//! `validate`, `status` and a fully cached `run` of a large FE model do not
//! parse and assemble its matrices again (a 190k-DOF Matrix Market export:
//! 534 MB of text, ~7 CPU-s to build, against ~0.3 s to hash).
//!
//! The facts of a model that built without error are a function of the
//! model file's text, the bytes of every file it references and the code
//! that builds models, so they are stored under a key over exactly these
//! ([`key`]): `<cache>/models/<key>.json`. A model that fails to build has
//! no facts, so its error is found again on every validation. Facts learned
//! while planning are written once the cache is known to be the pipeline's
//! ([`save`], after the run's location checks); reading them needs nothing
//! but the file.

use super::ParamProblem;
use crate::dynamics::{Model, Parameter};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// Bumped whenever the model builder changes what it accepts or the facts
/// it yields (the memory estimate, massless-DOF detection, parameters), so
/// facts of an older build are not trusted.
const FACTS_VERSION: u32 = 1;

/// A facts file larger than this is not read (parameters are the only
/// unbounded part: ~100 bytes each).
const MAX_FACTS_BYTES: u64 = 16 << 20;

/// What validation needs of a built model.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ModelFacts {
    /// The content key these facts belong to (hex), checked on reading.
    pub key: String,
    pub n_dofs: usize,
    /// DOFs with mass, hence modes with a finite frequency.
    pub finite_modes: usize,
    /// The eigenproblem's memory estimate, bytes, and what it is made of
    /// ([`Model::memory_estimate`]); the limit is applied on use.
    pub memory_bytes: f64,
    pub memory_what: String,
    pub parameters: Vec<Parameter>,
}

impl ModelFacts {
    /// The facts of a built model under the content key `key`.
    pub fn of(model: &Model, key: &str) -> Self {
        let (memory_bytes, memory_what) = model.memory_estimate();
        ModelFacts {
            key: key.to_string(),
            n_dofs: model.n_dofs(),
            finite_modes: model.finite_modes(),
            memory_bytes,
            memory_what,
            parameters: model.parameters.clone(),
        }
    }

    /// The eigenproblem against the memory limit (dense n × n matrices or a
    /// sparse factor).
    pub fn memory_problem(&self) -> Option<ParamProblem> {
        super::limits::memory_problem(&["model"], &self.memory_what, self.memory_bytes)
    }
}

/// The facts key of a model whose text and referenced files hash to
/// `content` (the model memo's key): the content and this build's facts
/// version and crate version.
pub fn key(content: &blake3::Hash) -> String {
    let mut h = blake3::Hasher::new();
    h.update(b"modalflow model facts\0");
    h.update(&FACTS_VERSION.to_le_bytes());
    h.update(env!("CARGO_PKG_VERSION").as_bytes());
    h.update(b"\0");
    h.update(content.as_bytes());
    h.finalize().to_hex().to_string()
}

/// Where facts are read from (`<cache>/models`), and the facts this process
/// learned, by key.
struct Store {
    dir: Option<PathBuf>,
    learned: BTreeMap<String, ModelFacts>,
}

static STORE: Mutex<Store> = Mutex::new(Store {
    dir: None,
    learned: BTreeMap::new(),
});

fn store() -> std::sync::MutexGuard<'static, Store> {
    STORE.lock().unwrap_or_else(|e| e.into_inner())
}

/// Read facts from the cache at `cache` from now on in this process.
pub fn read_from(cache: &Path) {
    store().dir = Some(cache.join("models"));
}

/// The facts under `key`: learned in this process, or read from the cache
/// (a missing, oversized, unreadable or mismatched file is no facts).
pub fn lookup(key: &str) -> Option<ModelFacts> {
    let dir = {
        let s = store();
        if let Some(f) = s.learned.get(key) {
            return Some(f.clone());
        }
        s.dir.clone()?
    };
    let path = dir.join(format!("{key}.json"));
    let meta = std::fs::symlink_metadata(&path).ok()?;
    if !meta.is_file() || meta.len() > MAX_FACTS_BYTES {
        return None;
    }
    let facts: ModelFacts = serde_json::from_slice(&std::fs::read(&path).ok()?).ok()?;
    (facts.key == key).then_some(facts)
}

/// Keep facts learned by building a model, for this process and [`save`].
pub fn learn(facts: ModelFacts) {
    store().learned.insert(facts.key.clone(), facts);
}

/// Write the facts this process learned into the cache at `cache`, when it
/// exists (validation does not create a cache), each file atomically
/// (written aside, then renamed). Facts are a convenience: a failure to
/// write them is not an error of the command.
pub fn save(cache: &Path) {
    if !cache.is_dir() {
        return;
    }
    let learned: Vec<ModelFacts> = store().learned.values().cloned().collect();
    if learned.is_empty() {
        return;
    }
    let dir = cache.join("models");
    if std::fs::create_dir_all(&dir).is_err() {
        return;
    }
    for f in learned {
        let path = dir.join(format!("{}.json", f.key));
        if path.exists() {
            continue;
        }
        let Ok(text) = serde_json::to_vec(&f) else {
            continue;
        };
        let aside = dir.join(format!(".{}.{}.tmp", f.key, std::process::id()));
        if std::fs::write(&aside, text).is_ok() && std::fs::rename(&aside, &path).is_err() {
            let _ = std::fs::remove_file(&aside);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn facts(key: &str) -> ModelFacts {
        ModelFacts {
            key: key.into(),
            n_dofs: 12,
            finite_modes: 9,
            memory_bytes: 1e6,
            memory_what: "test".into(),
            parameters: Vec::new(),
        }
    }

    /// Saved facts read back under their key; a file whose content names
    /// another key is not believed.
    #[test]
    fn facts_round_trip_through_the_cache_by_key() {
        let dir = tempfile::tempdir().unwrap();
        let cache = dir.path().join("cache");
        // No cache: nothing is written.
        let k1 = key(&blake3::hash(b"one"));
        learn(facts(&k1));
        save(&cache);
        assert!(!cache.exists());
        std::fs::create_dir(&cache).unwrap();
        save(&cache);
        let text = std::fs::read_to_string(cache.join("models").join(format!("{k1}.json")));
        let back: ModelFacts = serde_json::from_str(&text.unwrap()).unwrap();
        assert_eq!(back, facts(&k1));
        // Read from the file, not the learned set.
        store().learned.remove(&k1);
        read_from(&cache);
        assert_eq!(lookup(&k1), Some(facts(&k1)));
        let k2 = key(&blake3::hash(b"two"));
        std::fs::copy(
            cache.join("models").join(format!("{k1}.json")),
            cache.join("models").join(format!("{k2}.json")),
        )
        .unwrap();
        assert_eq!(lookup(&k2), None);
        assert_ne!(k1, k2);
    }
}
