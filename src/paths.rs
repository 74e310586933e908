//! The path policy: every path modalflow derives or receives — `outs`,
//! `deps` and other file params, matrix names, stage and pipeline names,
//! the names and hashes in a cache record, `--cache` and `--results` —
//! passes here before it is joined to a root.
//!
//! - A path that modalflow **writes** is relative, has no `..`, names
//!   something strictly below its root (never the root itself), has no
//!   control characters and no component longer than [`MAX_NAME_BYTES`];
//!   no existing component of it below the root is a symbolic link
//!   ([`no_symlink_below`]), so a write never follows a link out of the root.
//! - A path that modalflow **reads** resolves (symbolic links followed)
//!   below the pipeline directory, or below a directory the pipeline file
//!   lists under `read_outside:` — reading elsewhere is the user's explicit
//!   choice ([`read_allowed`]).
//! - A **name** that becomes one folder (a stage or pipeline name, an
//!   expanded matrix name) is one component ([`name`]).
//! - The **roots** — the project (pipeline directory), the cache and the
//!   pipeline's results folder — never contain one another ([`overlap`]).

use std::io;
use std::path::{Component, Path, PathBuf};

/// Longest file or folder name modalflow creates from user text, in bytes.
/// File systems allow 255; temp and staging names add up to ~45 bytes
/// (`.NAME.staging-PID-NONCE`), so 200 leaves room for them.
pub const MAX_NAME_BYTES: usize = 200;

/// Why a path or name is refused.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum PathProblem {
    #[error("is empty")]
    Empty,
    #[error("is absolute; give a path relative to the pipeline file's directory")]
    Absolute,
    #[error("leaves its directory through `..`")]
    Parent,
    #[error("names the pipeline directory itself, not something below it")]
    Root,
    #[error("contains a control character (newline, tab, NUL …)")]
    Control,
    #[error("has a part of {0} bytes; at most {MAX_NAME_BYTES} are allowed")]
    TooLong(usize),
    #[error("contains a path separator (`/` or `\\`)")]
    Separator,
    #[error("is `.` or `..`")]
    Dots,
}

fn check_text(text: &str) -> Result<(), PathProblem> {
    if text.trim().is_empty() {
        return Err(PathProblem::Empty);
    }
    if text.chars().any(char::is_control) {
        return Err(PathProblem::Control);
    }
    Ok(())
}

/// A relative path that stays strictly below its root, normalized (`.`
/// dropped, `/` separators): the form every written path must have.
pub fn relative(path: &str) -> Result<String, PathProblem> {
    check_text(path)?;
    let p = Path::new(path);
    if p.has_root() || path.starts_with('\\') {
        return Err(PathProblem::Absolute);
    }
    let mut parts = Vec::new();
    for c in p.components() {
        match c {
            Component::CurDir => {}
            Component::Normal(s) => {
                let s = s.to_string_lossy();
                if s.contains('\\') {
                    return Err(PathProblem::Separator);
                }
                if s.len() > MAX_NAME_BYTES {
                    return Err(PathProblem::TooLong(s.len()));
                }
                parts.push(s.into_owned());
            }
            Component::ParentDir => return Err(PathProblem::Parent),
            Component::RootDir | Component::Prefix(_) => return Err(PathProblem::Absolute),
        }
    }
    if parts.is_empty() {
        return Err(PathProblem::Root);
    }
    Ok(parts.join("/"))
}

/// A name that becomes exactly one folder or file name.
pub fn name(text: &str) -> Result<(), PathProblem> {
    check_text(text)?;
    if text.contains(['/', '\\']) {
        return Err(PathProblem::Separator);
    }
    if text == "." || text == ".." {
        return Err(PathProblem::Dots);
    }
    if text.len() > MAX_NAME_BYTES {
        return Err(PathProblem::TooLong(text.len()));
    }
    Ok(())
}

/// Whether `text` is an object hash as the cache names objects (blake3,
/// 64 lower-case hex digits): anything else read from a cache record is
/// refused before it becomes part of an object path.
pub fn is_hash(text: &str) -> bool {
    text.len() == 64 && text.bytes().all(|b| matches!(b, b'0'..=b'9' | b'a'..=b'f'))
}

/// Refuse to write at `root/rel` when an existing component below `root`
/// (the target included) is a symbolic link: a link planted in the
/// workspace must not turn a write or a removal into one outside it.
/// `rel` has passed [`relative`].
pub fn no_symlink_below(root: &Path, rel: &str) -> io::Result<()> {
    let mut p = root.to_path_buf();
    for part in rel.split('/') {
        p.push(part);
        match std::fs::symlink_metadata(&p) {
            Ok(m) if m.file_type().is_symlink() => {
                return Err(io::Error::new(
                    io::ErrorKind::InvalidInput,
                    format!(
                        "{} is a symbolic link; modalflow does not write through links \
                         (remove the link or name the real path)",
                        p.display()
                    ),
                ))
            }
            Ok(_) => {}
            Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(()),
            Err(e) => return Err(e),
        }
    }
    Ok(())
}

/// `path` made absolute with links resolved as far as it exists: the
/// longest existing prefix canonicalized, the rest appended lexically (a
/// non-existing rest has no links to resolve). `..` in the rest is folded.
pub fn absolute(path: &Path) -> PathBuf {
    let base = if path.is_absolute() {
        path.to_path_buf()
    } else {
        std::env::current_dir().unwrap_or_default().join(path)
    };
    let mut existing = base.as_path();
    let mut rest = Vec::new();
    loop {
        if let Ok(c) = std::fs::canonicalize(existing) {
            let mut out = c;
            for part in rest.iter().rev() {
                match part {
                    Component::ParentDir => {
                        out.pop();
                    }
                    Component::Normal(s) => out.push(s),
                    _ => {}
                }
            }
            return out;
        }
        match (existing.parent(), existing.components().next_back()) {
            (Some(parent), Some(last)) => {
                rest.push(last);
                existing = parent;
            }
            _ => return base,
        }
    }
}

/// Whether `a` and `b` (absolute, as [`absolute`] gives them) are the same
/// path or one lies inside the other.
pub fn overlap(a: &Path, b: &Path) -> bool {
    a.starts_with(b) || b.starts_with(a)
}

/// Whether reading `path` (absolute; links resolved) is allowed: it lies
/// below `dir` (the pipeline directory) or below one of `roots` (the
/// pipeline's `read_outside:` directories, absolute).
pub fn read_allowed(path: &Path, dir: &Path, roots: &[PathBuf]) -> bool {
    path.starts_with(dir) || roots.iter().any(|r| path.starts_with(r))
}

/// A reader for the files a model file references (super-element
/// matrices): `rel` is resolved against `base` (the model file's
/// directory) and read only when it resolves, links followed, below one of
/// `allowed` (the pipeline directory and the model file's own directory),
/// so a model file cannot pull in — and quote in an error — a file
/// elsewhere on the machine.
pub fn confined_reader(
    base: PathBuf,
    allowed: Vec<PathBuf>,
) -> impl Fn(&str) -> io::Result<Vec<u8>> {
    let path = confined_path(base, allowed);
    move |rel: &str| std::fs::read(path(rel)?)
}

/// [`confined_reader`]'s check alone: the absolute path of `rel` below
/// `base` when it lies below one of `allowed`, else a located refusal.
pub fn confined_path(base: PathBuf, allowed: Vec<PathBuf>) -> impl Fn(&str) -> io::Result<PathBuf> {
    let allowed: Vec<PathBuf> = allowed.iter().map(|p| absolute(p)).collect();
    move |rel: &str| {
        let full = absolute(&base.join(rel));
        if !allowed.iter().any(|a| full.starts_with(a)) {
            return Err(io::Error::new(
                io::ErrorKind::PermissionDenied,
                format!(
                    "{} is outside the pipeline and model directories; modalflow does not read \
                     it (copy the file next to the model file)",
                    full.display()
                ),
            ));
        }
        Ok(full)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn relative_paths_stay_below_their_root() {
        assert_eq!(relative("data/out.csv").unwrap(), "data/out.csv");
        assert_eq!(relative("./data/./out.csv").unwrap(), "data/out.csv");
        for (bad, problem) in [
            (".", PathProblem::Root),
            ("./", PathProblem::Root),
            ("./.", PathProblem::Root),
            ("", PathProblem::Empty),
            ("  ", PathProblem::Empty),
            ("..", PathProblem::Parent),
            ("a/../b", PathProblem::Parent),
            ("a/..", PathProblem::Parent),
            ("/etc/passwd", PathProblem::Absolute),
            ("\\x", PathProblem::Absolute),
            ("a\\..\\b", PathProblem::Separator),
            ("a\nb", PathProblem::Control),
            ("a\0b", PathProblem::Control),
        ] {
            assert_eq!(relative(bad), Err(problem), "{bad:?}");
        }
        let long = "x".repeat(MAX_NAME_BYTES + 1);
        assert!(matches!(relative(&long), Err(PathProblem::TooLong(_))));
        assert!(relative(&format!("a/{}", "x".repeat(MAX_NAME_BYTES))).is_ok());
    }

    #[test]
    fn names_are_one_component() {
        assert!(name("ident[seed=2]").is_ok());
        for bad in [".", "..", "a/b", "a\\b", "", "a\nb"] {
            assert!(name(bad).is_err(), "{bad:?}");
        }
        assert!(name(&"n".repeat(MAX_NAME_BYTES + 1)).is_err());
    }

    #[test]
    fn hashes_are_hex_of_blake3_length() {
        let h = blake3::hash(b"x").to_hex().to_string();
        assert!(is_hash(&h));
        assert!(!is_hash(&h.to_uppercase()));
        assert!(!is_hash("../../../../etc/passwd"));
        assert!(!is_hash(&h[..63]));
    }

    #[test]
    fn symlinks_are_not_written_through() {
        let dir = tempfile::tempdir().unwrap();
        let outside = tempfile::tempdir().unwrap();
        std::os::unix::fs::symlink(outside.path(), dir.path().join("link")).unwrap();
        assert!(no_symlink_below(dir.path(), "link/file").is_err());
        assert!(no_symlink_below(dir.path(), "link").is_err());
        std::fs::create_dir(dir.path().join("real")).unwrap();
        assert!(no_symlink_below(dir.path(), "real/new/file").is_ok());
    }

    #[test]
    fn confined_reader_refuses_outside_files() {
        let dir = tempfile::tempdir().unwrap();
        let outside = tempfile::tempdir().unwrap();
        std::fs::create_dir(dir.path().join("models")).unwrap();
        std::fs::write(dir.path().join("models/k.mtx"), "inside").unwrap();
        std::fs::write(outside.path().join("secret"), "outside").unwrap();
        std::os::unix::fs::symlink(outside.path(), dir.path().join("models/link")).unwrap();
        let read = confined_reader(dir.path().join("models"), vec![dir.path().to_path_buf()]);
        assert_eq!(read("k.mtx").unwrap(), b"inside");
        let escape = format!("../../{}/secret", outside.path().display());
        assert!(read(&escape).is_err());
        assert!(read(&outside.path().join("secret").display().to_string()).is_err());
        assert!(read("link/secret").is_err());
    }

    #[test]
    fn overlap_and_absolute() {
        let dir = tempfile::tempdir().unwrap();
        let root = absolute(dir.path());
        let a = absolute(&dir.path().join("x/y/../z"));
        assert_eq!(a, root.join("x/z"));
        assert!(overlap(&root, &a));
        assert!(overlap(&a, &root));
        assert!(!overlap(&root.join("x1"), &root.join("x")));
        assert!(read_allowed(&a, &root, &[]));
        assert!(!read_allowed(Path::new("/etc/passwd"), &root, &[]));
        assert!(read_allowed(
            Path::new("/etc/passwd"),
            &root,
            &[PathBuf::from("/etc")]
        ));
    }
}
