//! Model files named by a stage's `model` param (synthesize, gsa, identify):
//! loading one below the pipeline directory, the files it references (for
//! cache keys and model.json) and its eigenproblem against the memory limit.
//! Shared by the kinds that read model files, so none of them imports another.
//!
//! **Parse once per process.** Validation (`validate`, and the planning
//! before every `run` and `status`) checks every stage that names a model,
//! and a synthesize stage that runs loads it again; a 190k-DOF Matrix Market
//! export takes seconds to parse and assemble. Loaded models are memoized
//! per process, keyed by the model file's path and a blake3 hash over its
//! text and every referenced file's content, so an edited file is never
//! served stale and an unchanged one is built once. Across processes,
//! validation asks for the model's [`facts`](super::model_facts), which a
//! model of the same content that built before answers without building.

use super::model_facts::{self, ModelFacts};
use crate::artifacts::model::ReferencedFile;
use crate::dynamics::model_file;
use crate::dynamics::Model;
use std::cell::RefCell;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

/// Models kept by the memo (the most recently loaded): enough for the
/// few model files of one pipeline without holding every model of a
/// long-running process.
const MEMO_ENTRIES: usize = 4;

/// Referenced-file bytes the memo keeps besides its newest model: matrix
/// text is about the size of the built matrices (a 190k-DOF hex8 export:
/// 534 MB of text, ~0.4 GB of matrices), so older large models are dropped
/// rather than held for the life of the process next to the one in use.
const MEMO_BYTES: u64 = 1 << 30;

/// One memoized model: the absolute model file path, the content key, the
/// built model and its referenced files.
struct Loaded {
    path: PathBuf,
    key: blake3::Hash,
    model: Arc<Model>,
    files: Vec<ReferencedFile>,
}

static MEMO: Mutex<Vec<Loaded>> = Mutex::new(Vec::new());

/// Load and validate the model file named by `params.model` below `dir`:
/// the model (shared, from the per-process memo when the model file and
/// every file it references are unchanged) and the model file's text.
pub fn load_model(dir: &Path, rel: &str) -> Result<(Arc<Model>, String), String> {
    load(dir, rel).map(|(model, text, _)| (model, text))
}

/// [`load_model`] with the files the model references (path as written,
/// size, content hash), for model.json.
pub fn load(dir: &Path, rel: &str) -> Result<(Arc<Model>, String, Vec<ReferencedFile>), String> {
    let path = dir.join(rel);
    let text =
        std::fs::read_to_string(&path).map_err(|e| format!("cannot read model file {rel}: {e}"))?;
    let resolver = reader(dir, &path);
    let build = |resolve: &dyn Fn(&str) -> std::io::Result<Vec<u8>>| {
        Model::from_yaml(&text, rel, resolve).map_err(|e| e.to_string())
    };
    // The referenced files' bytes; if the spec does not parse or a file
    // cannot be read, the model builder reports it, located.
    let Some(bytes) = referenced_bytes(&text, rel, &resolver) else {
        return Err(build(&resolver)
            .err()
            .unwrap_or_else(|| format!("model file {rel}: a referenced file could not be read")));
    };
    let files: Vec<ReferencedFile> = bytes
        .iter()
        .map(|(p, b)| ReferencedFile::of(p, b))
        .collect();
    let key = content_key(&text, &files);
    let abs = crate::paths::absolute(&path);
    if let Some(m) = memo_get(&abs, &key) {
        return Ok((m, text, files));
    }
    // Serve each file once from the bytes already read (no second read of
    // a large export); a path asked twice is read again.
    let cell = RefCell::new(bytes);
    let model = build(&|p: &str| match cell.borrow_mut().remove(p) {
        Some(b) => Ok(b),
        None => resolver(p),
    })?;
    drop(cell);
    let model = Arc::new(model);
    memo_put(Loaded {
        path: abs,
        key,
        model: model.clone(),
        files: files.clone(),
    });
    Ok((model, text, files))
}

/// Where the files a model file at `path` (below the pipeline directory
/// `dir`) references are found: against the model file's directory, and
/// only below it or `dir`.
fn locator(dir: &Path, path: &Path) -> impl Fn(&str) -> std::io::Result<PathBuf> {
    let base = path.parent().unwrap_or(dir).to_path_buf();
    crate::paths::confined_path(base.clone(), vec![dir.to_path_buf(), base])
}

/// [`locator`]'s files, read.
fn reader(dir: &Path, path: &Path) -> impl Fn(&str) -> std::io::Result<Vec<u8>> {
    let locate = locator(dir, path);
    move |rel: &str| std::fs::read(locate(rel)?)
}

/// What the memo and the facts are keyed by: the model file's text and the
/// path (as written) and blake3 of every file it references.
fn content_key(text: &str, files: &[ReferencedFile]) -> blake3::Hash {
    let mut h = blake3::Hasher::new();
    h.update(text.as_bytes());
    for f in files {
        h.update(&(f.path.len() as u64).to_le_bytes());
        h.update(f.path.as_bytes());
        h.update(f.blake3.as_bytes());
    }
    h.finalize()
}

/// What validation needs of the model file `rel` below `dir` (its
/// [`ModelFacts`]) and the model file's text: from the facts of a model of
/// the same content that built before — the referenced files are then
/// hashed, not parsed — otherwise by building the model ([`load`]) and
/// learning its facts.
pub fn facts(dir: &Path, rel: &str) -> Result<(ModelFacts, String), String> {
    let path = dir.join(rel);
    let text =
        std::fs::read_to_string(&path).map_err(|e| format!("cannot read model file {rel}: {e}"))?;
    if let Some(files) = hashed_files(&text, rel, dir, &path) {
        let key = model_facts::key(&content_key(&text, &files));
        if let Some(f) = model_facts::lookup(&key) {
            return Ok((f, text));
        }
    }
    let (model, text, files) = load(dir, rel)?;
    let facts = ModelFacts::of(&model, &model_facts::key(&content_key(&text, &files)));
    model_facts::learn(facts.clone());
    Ok((facts, text))
}

/// The files the model file `text` (at `path`, `rel` below `dir`)
/// references, hashed without being read into memory; `None` when the spec
/// does not parse or a file cannot be read (building the model says why).
fn hashed_files(text: &str, rel: &str, dir: &Path, path: &Path) -> Option<Vec<ReferencedFile>> {
    let spec = model_file::parse(text, rel).ok()?;
    let locate = locator(dir, path);
    let mut out: Vec<ReferencedFile> = Vec::new();
    for f in spec.external_files() {
        if out.iter().any(|r| r.path == f) {
            continue;
        }
        let full = locate(&f).ok()?;
        let bytes = std::fs::metadata(&full).ok()?.len();
        let hash = crate::file_hash::hash(&full).ok()?;
        out.push(ReferencedFile {
            path: f,
            bytes,
            blake3: hash.to_hex().to_string(),
        });
    }
    out.sort_by(|a, b| a.path.cmp(&b.path));
    Some(out)
}

/// Every file the model file `text` references (as written, deduplicated)
/// and its bytes; `None` when the spec does not parse or a file is
/// unreadable.
fn referenced_bytes(
    text: &str,
    rel: &str,
    resolver: &dyn Fn(&str) -> std::io::Result<Vec<u8>>,
) -> Option<BTreeMap<String, Vec<u8>>> {
    let spec = model_file::parse(text, rel).ok()?;
    let mut out = BTreeMap::new();
    for f in spec.external_files() {
        if let std::collections::btree_map::Entry::Vacant(e) = out.entry(f) {
            let b = resolver(e.key()).ok()?;
            e.insert(b);
        }
    }
    Some(out)
}

fn memo_get(path: &Path, key: &blake3::Hash) -> Option<Arc<Model>> {
    let memo = MEMO.lock().unwrap_or_else(|e| e.into_inner());
    memo.iter()
        .find(|l| l.path == path && &l.key == key)
        .map(|l| l.model.clone())
}

fn memo_put(loaded: Loaded) {
    let mut memo = MEMO.lock().unwrap_or_else(|e| e.into_inner());
    memo.retain(|l| l.path != loaded.path);
    memo.push(loaded);
    let bytes = |l: &Loaded| l.files.iter().map(|f| f.bytes).sum();
    drop_oldest(&mut memo, bytes, MEMO_ENTRIES, MEMO_BYTES);
}

/// Drop the oldest (first) entries of `memo` until at most `entries` are
/// left and their `bytes` sum to at most `limit`; the newest always stays.
fn drop_oldest<T>(memo: &mut Vec<T>, bytes: impl Fn(&T) -> u64, entries: usize, limit: u64) {
    let total = |m: &[T]| m.iter().map(&bytes).sum::<u64>();
    while memo.len() > entries || (memo.len() > 1 && total(memo) > limit) {
        memo.remove(0);
    }
}

/// The files the model file `rel` references (path as written, size,
/// blake3), as its last load in this process found them; read and hashed
/// (not built) when the memo no longer holds it.
pub fn referenced_files(dir: &Path, rel: &str) -> Result<Vec<ReferencedFile>, String> {
    let path = dir.join(rel);
    let abs = crate::paths::absolute(&path);
    {
        let memo = MEMO.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(l) = memo.iter().rev().find(|l| l.path == abs) {
            return Ok(l.files.clone());
        }
    }
    let text =
        std::fs::read_to_string(&path).map_err(|e| format!("cannot read model file {rel}: {e}"))?;
    let resolver = reader(dir, &path);
    let bytes = referenced_bytes(&text, rel, &resolver)
        .ok_or_else(|| format!("model file {rel}: a referenced file could not be read"))?;
    Ok(bytes
        .iter()
        .map(|(p, b)| ReferencedFile::of(p, b))
        .collect())
}

/// Files a model file references, relative to the pipeline directory
/// (`rel` is the model file's path relative to it).
pub fn external_files(spec: &model_file::ModelFile, rel: &str) -> Vec<String> {
    let model_dir = Path::new(rel).parent().unwrap_or(Path::new(""));
    spec.external_files()
        .iter()
        .map(|f| model_dir.join(f).to_string_lossy().into_owned())
        .collect()
}

/// Validate the model file `rel` (relative to the pipeline directory `dir`)
/// and list the files it references, for cache keys of other kinds that
/// read model files.
pub fn model_file_dependencies(dir: &Path, rel: &str) -> Result<Vec<String>, String> {
    Ok(checked_model_file(dir, rel)?.1)
}

/// [`model_file_dependencies`] and the model's facts, for checks that need
/// them at validation (e.g. a budget against its parameter count).
pub fn checked_model_file(dir: &Path, rel: &str) -> Result<(ModelFacts, Vec<String>), String> {
    let (facts, text) = facts(dir, rel)?;
    if let Some(p) = facts.memory_problem() {
        return Err(p.message);
    }
    let spec = model_file::parse(&text, rel).map_err(|e| e.to_string())?;
    Ok((facts, external_files(&spec, rel)))
}

#[cfg(test)]
mod tests {
    use super::*;

    const MODEL: &str = "parameters: []\nbodies:\n  - name: se\n    superelement:\n      mass: se/m.mtx\n      stiffness: se/k.mtx\n      nodes:\n        - {id: 1, dofs: [0, 1, 2], position: [0, 0, 0]}\n      points: {a: {node: 1}}\nsensors: [{name: s, body: se, point: a, node: 1, direction: 1}]\nexcitations: [{name: s, body: se, point: a, node: 1, direction: 1}]\n";

    fn diagonal(v: f64) -> String {
        format!(
            "%%MatrixMarket matrix coordinate real symmetric\n3 3 3\n1 1 {v}\n2 2 {v}\n3 3 {v}\n"
        )
    }

    /// The memo keeps the newest entries within its count and bytes, and
    /// always the newest one, however large.
    #[test]
    fn the_memo_drops_its_oldest_entries_first() {
        let keep = |sizes: &[u64], entries: usize, limit: u64| {
            let mut m = sizes.to_vec();
            drop_oldest(&mut m, |&b| b, entries, limit);
            m
        };
        assert_eq!(keep(&[1, 2, 3, 4, 5], 4, 100), [2, 3, 4, 5]);
        assert_eq!(keep(&[50, 30, 20], 4, 100), [50, 30, 20]);
        assert_eq!(keep(&[60, 30, 20], 4, 100), [30, 20]);
        assert_eq!(keep(&[60, 30, 20, 40], 4, 100), [30, 20, 40]);
        assert_eq!(keep(&[10, 500], 4, 100), [500]);
    }

    /// The same files give the same (shared) model; an edited matrix gives
    /// a new one, and the references carry the files' blake3.
    #[test]
    fn a_model_is_built_once_per_content() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        std::fs::create_dir_all(d.join("models/se")).unwrap();
        std::fs::write(d.join("models/m.yaml"), MODEL).unwrap();
        std::fs::write(d.join("models/se/m.mtx"), diagonal(2.0)).unwrap();
        std::fs::write(d.join("models/se/k.mtx"), diagonal(8.0)).unwrap();
        let (a, _) = load_model(d, "models/m.yaml").unwrap();
        let (b, _) = load_model(d, "models/m.yaml").unwrap();
        assert!(Arc::ptr_eq(&a, &b));
        assert_eq!(a.n_dofs(), 3);
        let files = referenced_files(d, "models/m.yaml").unwrap();
        let hash = |t: String| blake3::hash(t.as_bytes()).to_hex().to_string();
        assert_eq!(files.len(), 2);
        assert_eq!(files[0].path, "se/k.mtx");
        assert_eq!(files[0].blake3, hash(diagonal(8.0)));
        assert_eq!(files[1].blake3, hash(diagonal(2.0)));
        std::fs::write(d.join("models/se/k.mtx"), diagonal(18.0)).unwrap();
        let (c, _) = load_model(d, "models/m.yaml").unwrap();
        assert!(!Arc::ptr_eq(&a, &c));
        let files = referenced_files(d, "models/m.yaml").unwrap();
        assert_eq!(files[0].blake3, hash(diagonal(18.0)));
        // A missing file is the model builder's located error.
        std::fs::remove_file(d.join("models/se/m.mtx")).unwrap();
        let e = load_model(d, "models/m.yaml").unwrap_err();
        assert!(e.contains("se/m.mtx") && e.contains("mass"), "{e}");
    }
}
