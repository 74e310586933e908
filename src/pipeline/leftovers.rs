//! Leftovers of runs that died: temp files in `cache/tmp/` and hidden
//! `.<stage>.staging-<process>` folders in a results directory. A killed or
//! crashed run cannot clean up after itself, so the next run does, without
//! touching what a live run (on this host or another sharing the cache) is
//! still writing.
//!
//! Every process that opens a writable cache announces itself with a lock
//! file `tmp/live-<pid>-<nonce>.lock` that it holds (`flock`) for its
//! lifetime; its temp names carry the same `<pid>-<nonce>`. The lock file
//! appears already locked (created under another name, locked, renamed), so
//! a lock that can be taken means its owner is gone, on any host whose file
//! system supports `flock` (which sharing a cache requires anyway). Names
//! without an announcement (an older modalflow, a results staging folder of
//! a run on another cache) fall back to whether the pid runs on this host.

use super::store::{err, process_nonce, StoreError};
use std::collections::HashMap;
use std::fs::{self, File};
use std::io;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// Lock files this process holds, per cache `tmp/` directory (kept open,
/// and so locked, until the process ends).
static HELD: Mutex<Vec<(PathBuf, File)>> = Mutex::new(Vec::new());

/// Announce this process in the cache's `tmp` directory (once per cache).
pub fn announce(tmp: &Path) -> Result<(), StoreError> {
    let mut held = HELD.lock().unwrap_or_else(|p| p.into_inner());
    if held.iter().any(|(dir, _)| dir == tmp) {
        return Ok(());
    }
    let nonce = process_nonce();
    let pending = tmp.join(format!(".live-{nonce}.new"));
    let file = File::create(&pending).map_err(err("write", &pending))?;
    file.lock().map_err(err("lock", &pending))?;
    let path = tmp.join(format!("live-{nonce}.lock"));
    fs::rename(&pending, &path).map_err(err("rename", &path))?;
    held.push((tmp.to_path_buf(), file));
    Ok(())
}

/// Remove this process's announcements (at a normal exit; a killed
/// process leaves them to the next run's [`clean`]).
pub fn retire() {
    let mut held = HELD.lock().unwrap_or_else(|p| p.into_inner());
    for (tmp, _file) in held.drain(..) {
        let _ = fs::remove_file(tmp.join(format!("live-{}.lock", process_nonce())));
    }
}

/// What a cleanup removed.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct Cleaned {
    pub temp: usize,
    pub staging: usize,
}

/// Liveness of the processes named in a cache's `tmp/` directory.
struct Owners {
    tmp: PathBuf,
    /// `<pid>-<nonce>` → alive, for every announcement found.
    announced: HashMap<String, bool>,
    /// Lock files of dead owners, held until they are removed.
    dead_locks: Vec<(PathBuf, File)>,
}

impl Owners {
    fn scan(tmp: &Path) -> Owners {
        let mut owners = Owners {
            tmp: tmp.to_path_buf(),
            announced: HashMap::new(),
            dead_locks: Vec::new(),
        };
        for entry in fs::read_dir(tmp).into_iter().flatten().flatten() {
            let name = entry.file_name().to_string_lossy().into_owned();
            // An announcement, or one a process was killed while making.
            let owner = name
                .strip_prefix("live-")
                .and_then(|r| r.strip_suffix(".lock"))
                .or_else(|| {
                    name.strip_prefix(".live-")
                        .and_then(|r| r.strip_suffix(".new"))
                });
            let Some(owner) = owner else {
                continue;
            };
            // An announcement being made is unlocked between its creation
            // and its lock: a `.new` file whose process runs is that
            // moment, not a leftover (taking it for dead removed a
            // concurrent run's announcement under it).
            let making = name.ends_with(".new")
                && owner
                    .split('-')
                    .next()
                    .and_then(|p| p.parse::<u32>().ok())
                    .is_some_and(pid_runs_here);
            let alive = match File::open(entry.path()) {
                // Taken: nobody holds it. Any other failure: assume alive.
                Ok(f) if !making => match f.try_lock() {
                    Ok(()) => {
                        owners.dead_locks.push((entry.path(), f));
                        false
                    }
                    Err(_) => true,
                },
                _ => true,
            };
            owners.announced.insert(owner.to_string(), alive);
        }
        owners
    }

    /// Whether the process that named a file with `owner` (`<pid>-<nonce>`
    /// or a bare `<pid>`) may still be using it.
    fn alive(&self, owner: &str) -> bool {
        if owner == process_nonce() {
            return true;
        }
        if let Some(&alive) = self.announced.get(owner) {
            return alive;
        }
        let pid = owner.split('-').next().unwrap_or("");
        match pid.parse::<u32>() {
            Ok(pid) => pid_runs_here(pid),
            // Not a name we wrote: leave it alone.
            Err(_) => true,
        }
    }
}

/// Whether `pid` is a running process on this host; `true` when that
/// cannot be told (no `/proc`), so nothing is removed on a guess.
fn pid_runs_here(pid: u32) -> bool {
    if !Path::new("/proc/self").exists() {
        return true;
    }
    Path::new("/proc").join(pid.to_string()).exists()
}

/// The `<pid>-<nonce>` in a temp name `<label>-<pid>-<nonce>-<n>` (also
/// `.<file>.modalflow-tmp-<pid>-<nonce>-<n>`), if it has one.
fn temp_owner(name: &str) -> Option<String> {
    let parts: Vec<&str> = name.split('-').collect();
    parts.windows(2).find_map(|w| {
        let pid = !w[0].is_empty() && w[0].bytes().all(|b| b.is_ascii_digit());
        let nonce = w[1].len() == 12 && w[1].bytes().all(|b| b.is_ascii_hexdigit());
        (pid && nonce).then(|| format!("{}-{}", w[0], w[1]))
    })
}

fn remove(path: &Path) -> io::Result<()> {
    if path.is_dir() {
        fs::remove_dir_all(path)
    } else {
        fs::remove_file(path)
    }
}

/// Remove the temp files of dead processes from `cache/tmp`, their
/// staging folders from `results` (one pipeline's results directory) and
/// their half-restored `.<file>.modalflow-tmp-…` files from `workspace`
/// (the pipeline file's directory, top level). Removal is best effort:
/// what cannot be removed now is tried next time.
pub fn clean(cache_tmp: &Path, results: &Path, workspace: &Path) -> Cleaned {
    let owners = Owners::scan(cache_tmp);
    let mut cleaned = Cleaned::default();
    for entry in fs::read_dir(&owners.tmp).into_iter().flatten().flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        if name.starts_with("live-") || name.starts_with(".live-") {
            continue;
        }
        let dead = temp_owner(&name).is_some_and(|o| !owners.alive(&o));
        if dead && remove(&entry.path()).is_ok() {
            cleaned.temp += 1;
        }
    }
    for entry in fs::read_dir(results).into_iter().flatten().flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        let Some(owner) = name
            .strip_prefix('.')
            .and_then(|n| n.rsplit_once(".staging-"))
            .map(|(_, o)| o)
        else {
            continue;
        };
        if !owners.alive(owner) && remove(&entry.path()).is_ok() {
            cleaned.staging += 1;
        }
    }
    for entry in fs::read_dir(workspace).into_iter().flatten().flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        if !(name.starts_with('.') && name.contains(".modalflow-tmp-")) {
            continue;
        }
        let dead = temp_owner(&name).is_some_and(|o| !owners.alive(&o));
        if dead && entry.path().is_file() && fs::remove_file(entry.path()).is_ok() {
            cleaned.temp += 1;
        }
    }
    // Announcements of dead processes go last, after what they named, and
    // while still locked by us so that no one takes them for alive.
    for (path, _file) in &owners.dead_locks {
        let _ = fs::remove_file(path);
    }
    cleaned
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn owners_are_parsed_from_temp_names() {
        assert_eq!(
            temp_owner("obj-123-0123456789ab-7").as_deref(),
            Some("123-0123456789ab")
        );
        assert_eq!(
            temp_owner(".x.csv.modalflow-tmp-9-aaaaaaaaaaaa-0").as_deref(),
            Some("9-aaaaaaaaaaaa")
        );
        assert_eq!(temp_owner("notes.txt"), None);
    }

    #[test]
    fn dead_announced_and_unannounced_leftovers_go_live_ones_stay() {
        let dir = tempfile::tempdir().unwrap();
        let tmp = dir.path().join("tmp");
        let results = dir.path().join("results");
        fs::create_dir_all(&tmp).unwrap();
        fs::create_dir_all(results.join(".a.staging-4194399")).unwrap();
        fs::create_dir_all(results.join("a")).unwrap();
        // A dead announced process: its lock file is not held.
        fs::write(tmp.join("live-4194398-0123456789ab.lock"), "").unwrap();
        fs::write(tmp.join("obj-4194398-0123456789ab-0"), "x").unwrap();
        // Killed while announcing itself.
        fs::write(tmp.join(".live-4194396-dddddddddddd.new"), "").unwrap();
        // Announcing itself now (a running process between creating and
        // locking its file).
        let making = tmp.join(format!(".live-{}-eeeeeeeeeeee.new", std::process::id()));
        fs::write(&making, "").unwrap();
        // Unannounced, pid not running.
        fs::create_dir_all(tmp.join("stage-4194397-bbbbbbbbbbbb-1")).unwrap();
        // This process, announced.
        announce(&tmp).unwrap();
        let mine = tmp.join(format!("obj-{}-3", process_nonce()));
        fs::write(&mine, "y").unwrap();
        // Unannounced but running here (this test's pid).
        let running = tmp.join(format!("rec-{}-cccccccccccc-0", std::process::id()));
        fs::write(&running, "z").unwrap();
        let half = dir
            .path()
            .join(".j.txt.modalflow-tmp-4194398-0123456789ab-2");
        fs::write(&half, "half").unwrap();
        let c = clean(&tmp, &results, dir.path());
        let expected = Cleaned {
            temp: 3,
            staging: 1,
        };
        assert_eq!(c, expected);
        assert!(!half.exists());
        assert!(mine.exists() && running.exists() && results.join("a").exists());
        assert!(!tmp.join("live-4194398-0123456789ab.lock").exists());
        assert!(!tmp.join(".live-4194396-dddddddddddd.new").exists());
        assert!(making.exists());
        assert!(tmp.join(format!("live-{}.lock", process_nonce())).exists());
    }
}
