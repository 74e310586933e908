//! The content-addressed cache: immutable objects named by their blake3
//! hash, run records mapping a stage key to output hashes, and advisory
//! locks so that several `modalflow` processes can share one cache.
//!
//! Layout under the cache root:
//! ```text
//! objects/ab/cdef…   file contents (blobs) and directory listings (trees)
//! runs/<key>.json     run record: outputs of the stage with that key
//! pipelines/<n>.json  last run of pipeline <n> (provenance, for status and gc)
//! locks/              one lock file per stage key being computed
//! tmp/                staging area; everything is written here, fsynced, renamed
//! jobs/<key>/         cluster jobs of a stage being computed (description, script, logs)
//! ```
//! Every write is atomic (temp file, fsync, rename, fsync of the directory)
//! and a run record is written only after all its objects, so a killed run
//! leaves either a complete entry or none.

pub use super::record::RunRecord;
use crate::paths;
use serde::{Deserialize, Serialize};
use std::fs::{self, File};
use std::io::{self, Read, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// What a cache or results operation was doing when the file system
/// failed. The message names the operation, the path and the system's
/// reason once (the reason is part of the text, not a separate `source`,
/// so a printed error chain does not repeat it).
#[derive(Debug, thiserror::Error)]
#[error("cannot {op} {}: {cause}", path.display())]
pub struct StoreError {
    pub op: &'static str,
    pub path: PathBuf,
    pub cause: io::Error,
}

pub(crate) fn err<'a>(
    op: &'static str,
    path: &'a Path,
) -> impl FnOnce(io::Error) -> StoreError + 'a {
    move |cause| StoreError {
        op,
        path: path.to_path_buf(),
        cause,
    }
}

/// Whether a failed write means the storage refuses writes (a read-only
/// mount or missing permissions) rather than a broken disk.
pub fn is_read_only(e: &io::Error) -> bool {
    matches!(
        e.kind(),
        io::ErrorKind::ReadOnlyFilesystem | io::ErrorKind::PermissionDenied
    )
}

pub type Result<T> = std::result::Result<T, StoreError>;

/// A stored output: one file (a blob) or a directory (a tree object listing
/// relative paths and blob hashes).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq, Eq)]
pub struct Artifact {
    #[serde(rename = "type")]
    pub kind: ArtifactKind,
    pub hash: String,
    pub bytes: u64,
}

#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum ArtifactKind {
    File,
    Dir,
}

#[derive(Debug, Serialize, Deserialize)]
struct Tree {
    entries: Vec<TreeEntry>,
}

#[derive(Debug, Serialize, Deserialize)]
struct TreeEntry {
    path: String,
    hash: String,
    bytes: u64,
}

/// One output in a run record.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct OutputRecord {
    /// File or directory name the stage gave it (relative path for `command` outs).
    pub file: String,
    #[serde(flatten)]
    pub artifact: Artifact,
}

/// Handle on a cache directory.
#[derive(Clone, Debug)]
pub struct Store {
    root: PathBuf,
    /// The cache refuses writes (a published or shared cache on read-only
    /// storage): cached results are served, nothing is written, no lock
    /// file is created.
    read_only: bool,
    /// Key of the records' seal, from `MODALFLOW_CACHE_KEY_FILE`.
    seal_key: Option<[u8; 32]>,
}

static TMP_COUNTER: AtomicU64 = AtomicU64::new(0);

impl Store {
    /// Open (creating if needed) the cache at `root`. A complete cache that
    /// refuses writes opens read-only (see [`Store::read_only`]); this
    /// process announces itself in `tmp/` otherwise, so that the temp files
    /// it leaves when killed can be told from a live run's
    /// ([`super::leftovers`]).
    pub fn open(root: &Path) -> Result<Store> {
        let seal_key = super::record::seal_key_from_env()?;
        let mut read_only = false;
        for sub in ["objects", "runs", "pipelines", "locks", "tmp"] {
            let p = root.join(sub);
            if let Err(e) = fs::create_dir_all(&p) {
                if !is_read_only(&e) {
                    return Err(err("create directory", &p)(e));
                }
                // A cache on storage that refuses writes is read: empty or
                // not, `status` lists what would run and `run` says which
                // stage it is missing.
                read_only = true;
                break;
            }
        }
        // Absolute, so scratch and object paths handed to stages (and to
        // commands running in another directory) stay valid.
        let root = match fs::canonicalize(root) {
            Ok(r) => r,
            Err(_) if read_only => paths::absolute(root),
            Err(e) => return Err(err("open", root)(e)),
        };
        if !read_only {
            // Existing directories on a read-only mount "create" fine; the
            // announcement is the first real write and tells.
            match super::leftovers::announce(&root.join("tmp")) {
                Ok(()) => {}
                Err(e) if is_read_only(&e.cause) => read_only = true,
                Err(e) => return Err(e),
            }
        }
        Ok(Store {
            root,
            read_only,
            seal_key,
        })
    }

    /// The key records are sealed with (`MODALFLOW_CACHE_KEY_FILE`), if any.
    pub fn seal_key(&self) -> Option<&[u8; 32]> {
        self.seal_key.as_ref()
    }

    pub fn root(&self) -> &Path {
        &self.root
    }

    /// Whether the cache refuses writes: fully cached runs and `status`
    /// work, computing a stage does not.
    pub fn read_only(&self) -> bool {
        self.read_only
    }

    /// A fresh path in the staging area, unique across the processes and
    /// hosts sharing the cache (cluster jobs write here too).
    pub fn temp_path(&self, label: &str) -> PathBuf {
        let n = TMP_COUNTER.fetch_add(1, Ordering::Relaxed);
        self.root
            .join("tmp")
            .join(format!("{label}-{}-{n}", process_nonce()))
    }

    /// Working directory of the cluster jobs computing stage `key`: job
    /// descriptions, scripts, logs and shard records (see
    /// [`super::executor`]). Not created here.
    pub fn job_dir(&self, key: &str) -> PathBuf {
        self.root.join("jobs").join(key)
    }

    pub fn object_path(&self, hash: &str) -> PathBuf {
        let (a, b) = hash.split_at(2.min(hash.len()));
        self.root.join("objects").join(a).join(b)
    }

    /// Store the file or directory at `path`; returns its artifact.
    pub fn put(&self, path: &Path) -> Result<Artifact> {
        // Not followed: a link among a stage's outputs would copy a file
        // from elsewhere into the cache and the results.
        let meta = fs::symlink_metadata(path).map_err(err("read", path))?;
        if meta.file_type().is_symlink() {
            return Err(err("store", path)(symlink_refused()));
        }
        if meta.is_dir() {
            let mut entries = Vec::new();
            for rel in walk(path).map_err(err("read", path))? {
                let a = self.put_file(&path.join(&rel))?;
                entries.push(TreeEntry {
                    path: rel,
                    hash: a.hash,
                    bytes: a.bytes,
                });
            }
            entries.sort_by(|a, b| a.path.cmp(&b.path));
            let bytes = entries.iter().map(|e| e.bytes).sum();
            let listing = serde_json::to_vec(&Tree { entries }).unwrap_or_default();
            let hash = self.put_bytes(&listing)?;
            Ok(Artifact {
                kind: ArtifactKind::Dir,
                hash,
                bytes,
            })
        } else {
            self.put_file(path)
        }
    }

    /// Copy one file into the object store, hashing while copying; a
    /// failed copy (a full disk) leaves no temp file behind.
    fn put_file(&self, path: &Path) -> Result<Artifact> {
        let tmp = self.temp_path("obj");
        let result = self.copy_in(path, &tmp);
        if result.is_err() {
            let _ = fs::remove_file(&tmp);
        }
        result
    }

    fn copy_in(&self, path: &Path, tmp: &Path) -> Result<Artifact> {
        let mut src = File::open(path).map_err(err("read", path))?;
        let mut dst = File::create(tmp).map_err(err("write", tmp))?;
        let mut hasher = blake3::Hasher::new();
        let mut buf = vec![0u8; 1 << 16];
        let mut bytes = 0u64;
        loop {
            let n = src.read(&mut buf).map_err(err("read", path))?;
            if n == 0 {
                break;
            }
            hasher.update(&buf[..n]);
            dst.write_all(&buf[..n]).map_err(err("write", tmp))?;
            bytes += n as u64;
        }
        dst.sync_all().map_err(err("sync", tmp))?;
        drop(dst);
        let hash = hasher.finalize().to_hex().to_string();
        self.commit_object(tmp, &hash)?;
        Ok(Artifact {
            kind: ArtifactKind::File,
            hash,
            bytes,
        })
    }

    /// Store bytes as a blob; returns the hash.
    pub fn put_bytes(&self, data: &[u8]) -> Result<String> {
        let hash = blake3::hash(data).to_hex().to_string();
        if self.object_path(&hash).exists() && self.verify_blob(&hash) {
            return Ok(hash);
        }
        let tmp = self.temp_path("obj");
        write_synced(&tmp, data)?;
        self.commit_object(&tmp, &hash)?;
        Ok(hash)
    }

    fn commit_object(&self, tmp: &Path, hash: &str) -> Result<()> {
        let dest = self.object_path(hash);
        if let Some(dir) = dest.parent() {
            fs::create_dir_all(dir).map_err(err("create directory", dir))?;
        }
        fs::rename(tmp, &dest).map_err(err("rename", &dest))?;
        sync_dir(dest.parent().unwrap_or(&self.root));
        Ok(())
    }

    fn verify_blob(&self, hash: &str) -> bool {
        hash_file(&self.object_path(hash)).is_ok_and(|h| h == hash)
    }

    /// Check that an artifact's objects exist and match their hashes.
    /// Returns a description of the first problem found.
    pub fn verify(&self, a: &Artifact) -> std::result::Result<(), String> {
        let check = |hash: &str| -> std::result::Result<(), String> {
            if !paths::is_hash(hash) {
                return Err(format!("`{}` is not an object hash", hash.escape_debug()));
            }
            match hash_file(&self.object_path(hash)) {
                Ok(h) if h == hash => Ok(()),
                Ok(h) => Err(format!("object {hash} is corrupt (content hashes to {h})")),
                Err(e) => Err(format!("object {hash} is missing ({e})")),
            }
        };
        check(&a.hash)?;
        if a.kind == ArtifactKind::Dir {
            for e in self.tree(&a.hash).map_err(|e| e.to_string())? {
                check(&e.hash)?;
            }
        }
        Ok(())
    }

    fn tree(&self, hash: &str) -> Result<Vec<TreeEntry>> {
        let p = self.object_path(hash);
        let bytes = fs::read(&p).map_err(err("read", &p))?;
        let invalid = |e: String| StoreError {
            op: "parse the tree object",
            path: p.clone(),
            cause: io::Error::new(io::ErrorKind::InvalidData, e),
        };
        let tree: Tree = serde_json::from_slice(&bytes).map_err(|e| invalid(e.to_string()))?;
        // A tree's names become paths below a checkout: each must stay there.
        for e in &tree.entries {
            if !paths::is_hash(&e.hash) {
                return Err(invalid(format!("entry `{}` has no valid hash", e.path)));
            }
            match paths::relative(&e.path) {
                Ok(rel) if rel == e.path => {}
                Ok(_) => return Err(invalid(format!("entry `{}` is not normalized", e.path))),
                Err(problem) => {
                    return Err(invalid(format!(
                        "entry `{}` {problem}",
                        e.path.escape_debug()
                    )))
                }
            }
        }
        Ok(tree.entries)
    }

    /// Object hashes an artifact consists of (its own and, for trees, entries').
    pub fn object_hashes(&self, a: &Artifact) -> Vec<String> {
        let mut out = vec![a.hash.clone()];
        if a.kind == ArtifactKind::Dir {
            out.extend(
                self.tree(&a.hash)
                    .unwrap_or_default()
                    .into_iter()
                    .map(|e| e.hash),
            );
        }
        out
    }

    /// Copy an artifact out of the cache to `dest` (replacing what is there),
    /// via a temp path and rename so readers never see half a file.
    pub fn checkout(&self, a: &Artifact, dest: &Path) -> Result<()> {
        if !paths::is_hash(&a.hash) {
            return Err(err("check out", dest)(io::Error::new(
                io::ErrorKind::InvalidData,
                "not an object hash",
            )));
        }
        if let Some(dir) = dest.parent() {
            fs::create_dir_all(dir).map_err(err("create directory", dir))?;
        }
        match a.kind {
            ArtifactKind::File => {
                let tmp = sibling_temp(dest);
                if let Err(e) = fs::copy(self.object_path(&a.hash), &tmp) {
                    let _ = fs::remove_file(&tmp);
                    return Err(err("write", dest)(e));
                }
                fs::rename(&tmp, dest).map_err(err("rename", dest))?;
            }
            ArtifactKind::Dir => {
                if dest.exists() {
                    let remove = if dest.is_dir() {
                        fs::remove_dir_all(dest)
                    } else {
                        fs::remove_file(dest)
                    };
                    remove.map_err(err("remove", dest))?;
                }
                for e in self.tree(&a.hash)? {
                    let target = dest.join(&e.path);
                    if let Some(dir) = target.parent() {
                        fs::create_dir_all(dir).map_err(err("create directory", dir))?;
                    }
                    fs::copy(self.object_path(&e.hash), &target).map_err(err("write", &target))?;
                }
            }
        }
        Ok(())
    }

    /// Write `data` to `dest` atomically (temp in the cache, fsync, rename).
    pub fn write_atomic(&self, dest: &Path, data: &[u8]) -> Result<()> {
        let tmp = self.temp_path("rec");
        write_synced(&tmp, data)?;
        fs::rename(&tmp, dest).map_err(err("rename", dest))?;
        sync_dir(dest.parent().unwrap_or(&self.root));
        Ok(())
    }

    /// Exclusive lock on one stage key while it is computed, so two runs that
    /// need the same result compute it once. A read-only cache computes
    /// nothing, so it needs none (`None`).
    pub fn lock_key(&self, key: &str) -> Result<Option<File>> {
        if self.read_only {
            return Ok(None);
        }
        lock(&self.root.join("locks").join(format!("{key}.lock")), true).map(Some)
    }

    /// Whole-cache lock: shared for runs, exclusive for `gc`. On a
    /// read-only cache a shared lock is taken on an existing lock file where
    /// the file system allows it (`None` otherwise); `gc` is refused.
    pub fn lock_cache(&self, exclusive: bool) -> Result<Option<File>> {
        let path = self.root.join("lock");
        if !self.read_only {
            return lock(&path, exclusive).map(Some);
        }
        if exclusive {
            return Err(err("lock for writing", &path)(io::Error::from(
                io::ErrorKind::ReadOnlyFilesystem,
            )));
        }
        Ok(File::open(&path).ok().filter(|f| f.lock_shared().is_ok()))
    }
}

fn lock(path: &Path, exclusive: bool) -> Result<File> {
    let f = fs::OpenOptions::new()
        .create(true)
        .truncate(false)
        .write(true)
        .open(path)
        .map_err(err("open the lock file", path))?;
    let r = if exclusive { f.lock() } else { f.lock_shared() };
    r.map_err(err("lock", path))?;
    Ok(f)
}

/// A name part unique to this process on any host: the host name, the pid
/// and the start time, hashed (pids repeat across the nodes of a cluster).
pub(crate) fn process_nonce() -> &'static str {
    static NONCE: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    NONCE.get_or_init(|| {
        let host = fs::read_to_string("/proc/sys/kernel/hostname")
            .or_else(|_| std::env::var("HOSTNAME"))
            .unwrap_or_default();
        let nanos = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.as_nanos())
            .unwrap_or(0);
        let seed = format!("{}|{}|{nanos}", host.trim(), std::process::id());
        let hash = blake3::hash(seed.as_bytes()).to_hex();
        format!("{}-{}", std::process::id(), &hash[..12])
    })
}

/// Write and fsync `path` (a temp file); on failure it is removed, so a
/// full disk leaves nothing behind.
fn write_synced(path: &Path, data: &[u8]) -> Result<()> {
    let write = || -> Result<()> {
        let mut f = File::create(path).map_err(err("write", path))?;
        f.write_all(data).map_err(err("write", path))?;
        f.sync_all().map_err(err("sync", path))
    };
    let result = write();
    if result.is_err() {
        let _ = fs::remove_file(path);
    }
    result
}

fn sync_dir(dir: &Path) {
    if let Ok(d) = File::open(dir) {
        let _ = d.sync_all();
    }
}

fn sibling_temp(dest: &Path) -> PathBuf {
    let name = dest
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let n = TMP_COUNTER.fetch_add(1, Ordering::Relaxed);
    dest.with_file_name(format!(".{name}.modalflow-tmp-{}-{n}", process_nonce()))
}

fn symlink_refused() -> io::Error {
    io::Error::new(
        io::ErrorKind::InvalidInput,
        "it is a symbolic link; modalflow stores regular files and folders only \
         (write the file itself, not a link to it)",
    )
}

/// blake3 of a file's content, hex.
pub fn hash_file(path: &Path) -> io::Result<String> {
    let h = crate::file_hash::hash_content(File::open(path)?)?;
    Ok(h.to_hex().to_string())
}

/// Content hash of a workspace path as the store would name it: a file's
/// blob hash, or for a directory the hash of its tree listing. Files are
/// hashed through [`crate::file_hash`], so a large input hashed once in
/// this process (a model's matrices at validation) is not read again.
pub fn hash_path(path: &Path) -> io::Result<String> {
    let remembered = |p: &Path| crate::file_hash::hash(p).map(|h| h.to_hex().to_string());
    if !path.is_dir() {
        return remembered(path);
    }
    let mut entries = Vec::new();
    for rel in walk(path)? {
        let p = path.join(&rel);
        entries.push(TreeEntry {
            hash: remembered(&p)?,
            bytes: fs::metadata(&p)?.len(),
            path: rel,
        });
    }
    entries.sort_by(|a, b| a.path.cmp(&b.path));
    let listing = serde_json::to_vec(&Tree { entries }).unwrap_or_default();
    Ok(blake3::hash(&listing).to_hex().to_string())
}

/// Relative paths (with `/`) of all files below `root`, sorted.
fn walk(root: &Path) -> io::Result<Vec<String>> {
    let mut out = Vec::new();
    let mut stack = vec![PathBuf::new()];
    while let Some(rel) = stack.pop() {
        for entry in fs::read_dir(root.join(&rel))? {
            let entry = entry?;
            let r = rel.join(entry.file_name());
            let kind = entry.file_type()?;
            if kind.is_symlink() {
                return Err(io::Error::new(
                    io::ErrorKind::InvalidInput,
                    format!("{} is a symbolic link", root.join(&r).display()),
                ));
            }
            if kind.is_dir() {
                stack.push(r);
            } else {
                out.push(r.to_string_lossy().replace('\\', "/"));
            }
        }
    }
    out.sort();
    Ok(out)
}

/// Names of all objects and run records, for `gc`.
pub fn list_objects(store: &Store) -> Vec<(String, PathBuf, u64)> {
    let mut out = Vec::new();
    let Ok(dirs) = fs::read_dir(store.root.join("objects")) else {
        return out;
    };
    for d in dirs.flatten() {
        let prefix = d.file_name().to_string_lossy().into_owned();
        let Ok(files) = fs::read_dir(d.path()) else {
            continue;
        };
        for f in files.flatten() {
            let len = f.metadata().map(|m| m.len()).unwrap_or(0);
            out.push((
                format!("{prefix}{}", f.file_name().to_string_lossy()),
                f.path(),
                len,
            ));
        }
    }
    out
}

#[cfg(test)]
#[path = "store_tests.rs"]
mod tests;
