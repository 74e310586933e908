//! blake3 of a file's content, remembered for the life of the process.
//!
//! A pipeline's input files are hashed more than once per process: a model
//! file's matrices for its facts (validation), then again for the stage's
//! cache key. A 190k-DOF Matrix Market export is 534 MB, about 0.3 CPU-s
//! per hash, so a fully cached `run` would spend most of its time hashing
//! the same bytes twice. A hash is reused only while the file's identity
//! and metadata are unchanged — device, inode, length, modification and
//! status-change time to the nanosecond — so an edited or replaced file is
//! hashed again (the status-change time moves on every write and cannot be
//! set back by the user), as Git's index and DVC's state do across runs;
//! here it never outlives the process. File times tick in kernel jiffies
//! (1–10 ms), so two writes in one tick can leave the same stamp; like Git
//! with a "racily clean" entry, a file modified less than [`SETTLED`] ago
//! is hashed every time.

use std::collections::HashMap;
use std::fs::{File, Metadata};
use std::io::{self, Read};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// Hashes remembered; a pipeline names far fewer files, and the memo is
/// cleared when full rather than grown without bound.
const MEMO_ENTRIES: usize = 4096;

/// How long ago a file must have been modified for its hash to be kept.
const SETTLED: std::time::Duration = std::time::Duration::from_secs(2);

/// What identifies one version of a file's content without reading it.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
struct Stamp {
    dev: u64,
    ino: u64,
    len: u64,
    mtime: (i64, i64),
    ctime: (i64, i64),
}

fn stamp(m: &Metadata) -> Stamp {
    use std::os::unix::fs::MetadataExt;
    Stamp {
        dev: m.dev(),
        ino: m.ino(),
        len: m.len(),
        mtime: (m.mtime(), m.mtime_nsec()),
        ctime: (m.ctime(), m.ctime_nsec()),
    }
}

static MEMO: Mutex<Option<HashMap<PathBuf, (Stamp, blake3::Hash)>>> = Mutex::new(None);

/// blake3 of the content of the regular file at `path` (links followed),
/// read in 64 KiB blocks; from the memo when the file is unchanged since
/// this process last hashed it.
pub fn hash(path: &Path) -> io::Result<blake3::Hash> {
    let mut f = File::open(path)?;
    let before = stamp(&f.metadata()?);
    let key = crate::paths::absolute(path);
    if let Some(h) = lookup(&key, before) {
        return Ok(h);
    }
    let h = hash_content(&mut f)?;
    // A file written while it was read, or too recently to tell the next
    // write from this one by its stamp, is not remembered.
    let after = f.metadata()?;
    let settled = after
        .modified()
        .ok()
        .and_then(|t| t.elapsed().ok())
        .is_some_and(|age| age >= SETTLED);
    if settled && stamp(&after) == before {
        remember(key, before, h);
    }
    Ok(h)
}

/// blake3 of everything `r` yields, read in 64 KiB blocks (no memo).
pub fn hash_content(mut r: impl Read) -> io::Result<blake3::Hash> {
    let mut hasher = blake3::Hasher::new();
    let mut buf = vec![0u8; 1 << 16];
    loop {
        let n = r.read(&mut buf)?;
        if n == 0 {
            break;
        }
        hasher.update(&buf[..n]);
    }
    Ok(hasher.finalize())
}

fn lookup(key: &Path, now: Stamp) -> Option<blake3::Hash> {
    let memo = MEMO.lock().unwrap_or_else(|e| e.into_inner());
    let (s, h) = memo.as_ref()?.get(key)?;
    (*s == now).then_some(*h)
}

fn remember(key: PathBuf, s: Stamp, h: blake3::Hash) {
    let mut memo = MEMO.lock().unwrap_or_else(|e| e.into_inner());
    let map = memo.get_or_insert_with(HashMap::new);
    if map.len() >= MEMO_ENTRIES {
        map.clear();
    }
    map.insert(key, (s, h));
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The memo answers for an unchanged, settled file and never for a
    /// changed one of the same length.
    #[test]
    fn an_edited_file_is_hashed_again() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("k.mtx");
        let key = crate::paths::absolute(&p);
        let now = |p: &Path| stamp(&std::fs::metadata(p).unwrap());
        // Just written: hashed, not remembered (its stamp could repeat).
        std::fs::write(&p, b"first").unwrap();
        assert_eq!(hash(&p).unwrap(), blake3::hash(b"first"));
        assert_eq!(lookup(&key, now(&p)), None);
        // Settled: remembered under its stamp.
        let hour_ago = std::time::SystemTime::now() - std::time::Duration::from_secs(3600);
        let f = File::options().write(true).open(&p).unwrap();
        f.set_modified(hour_ago).unwrap();
        drop(f);
        assert_eq!(hash(&p).unwrap(), blake3::hash(b"first"));
        assert_eq!(lookup(&key, now(&p)), Some(blake3::hash(b"first")));
        assert_eq!(hash(&p).unwrap(), blake3::hash(b"first"));
        // Rewritten with the same length: a new stamp, hashed again.
        std::fs::write(&p, b"other").unwrap();
        assert_eq!(hash(&p).unwrap(), blake3::hash(b"other"));
    }
}
