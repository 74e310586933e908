//! The project root: where the default cache (`<root>/cache`) and results
//! (`<root>/results`) live, found from the pipeline file the way DVC finds
//! `.dvc/` — so `cd` into any folder of the project and `status` sees the
//! same cache.
//!
//! The root is the nearest folder at or above the pipeline file's folder
//! that holds the marker file [`MARKER`] (an empty file the user creates,
//! as `dvc init` does) or a modalflow cache (`cache/objects` and
//! `cache/runs`, as a first run leaves it). Without either, the current
//! directory is the root, as before. Explicit `--cache` and `--results`
//! (and `MODALFLOW_CACHE`) are taken as given, relative to the current
//! directory. Discovery only reads; nothing is created outside the cache,
//! the results and declared outputs.

use std::path::{Path, PathBuf};

/// The marker file naming a project root.
pub const MARKER: &str = ".modalflow";

/// Whether `dir` holds a modalflow cache as `dir/cache`.
fn has_cache(dir: &Path) -> bool {
    let cache = dir.join("cache");
    cache.join("objects").is_dir() && cache.join("runs").is_dir()
}

/// The project root for a pipeline in `start` (a folder); `cwd` when no
/// folder at or above `start` holds the marker or a cache.
pub fn root(start: &Path, cwd: &Path) -> PathBuf {
    let start = std::fs::canonicalize(start).unwrap_or_else(|_| crate::paths::absolute(start));
    for dir in start.ancestors() {
        if dir.join(MARKER).is_file() || has_cache(dir) {
            return dir.to_path_buf();
        }
    }
    cwd.to_path_buf()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn marker_or_cache_above_the_pipeline_names_the_root() {
        let t = tempfile::tempdir().unwrap();
        let top = std::fs::canonicalize(t.path()).unwrap();
        let sub = top.join("a/b");
        std::fs::create_dir_all(&sub).unwrap();
        let cwd = top.join("elsewhere");
        assert_eq!(root(&sub, &cwd), cwd);
        std::fs::write(top.join("a").join(MARKER), "").unwrap();
        assert_eq!(root(&sub, &cwd), top.join("a"));
        std::fs::create_dir_all(sub.join("cache/objects")).unwrap();
        std::fs::create_dir_all(sub.join("cache/runs")).unwrap();
        assert_eq!(root(&sub, &cwd), sub);
    }
}
