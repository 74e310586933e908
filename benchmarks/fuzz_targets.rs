//! The parsers the fuzz harness (`benchmarks/fuzz.rs`) drives, and the
//! mutator it drives them with; shared with the regression test in
//! `tests/reliability.rs`, which replays the corpus and the crashers kept
//! under `tests/fuzz/`.
//!
//! A target takes arbitrary bytes and returns a short class of the outcome
//! (`ok` or the start of the error message); a new class marks an input
//! worth keeping in the corpus, the cheap stand-in for coverage feedback
//! that the stable toolchain allows. A panic is a finding.

#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

pub struct Target {
    pub name: &'static str,
    /// Seed files below the repository root (files or whole directories).
    pub seeds: &'static [&'static str],
    pub run: fn(&[u8]) -> String,
}

pub fn targets() -> Vec<Target> {
    vec![
        Target {
            name: "uff",
            seeds: &["tests/fixtures/uff"],
            run: uff,
        },
        Target {
            name: "csv_frf",
            seeds: &["tests/fuzz/corpus/csv_frf"],
            run: csv_frf,
        },
        Target {
            name: "model",
            seeds: &["pipelines/models", "tests/fixtures/models"],
            run: model,
        },
        Target {
            name: "pipeline",
            seeds: &["pipelines/quickstart.yaml", "tests/fuzz/corpus/pipeline"],
            run: pipeline,
        },
        Target {
            name: "paths",
            seeds: &["tests/fuzz/corpus/paths"],
            run: paths,
        },
        Target {
            name: "record",
            seeds: &["tests/fuzz/corpus/record"],
            run: record,
        },
    ]
}

/// The class of an outcome: `ok`, or the error's first words (words with
/// numbers or quotes dropped, so one message shape is one class).
fn class<T, E: std::fmt::Display>(r: Result<T, E>) -> String {
    match r {
        Ok(_) => "ok".into(),
        Err(e) => e
            .to_string()
            .split_whitespace()
            .filter(|w| !w.contains(|c: char| c.is_ascii_digit() || "`\"'".contains(c)))
            .take(4)
            .collect::<Vec<_>>()
            .join(" "),
    }
}

fn uff(bytes: &[u8]) -> String {
    class(modalflow::io::uff::read_uff(bytes, "fuzz.uff"))
}

fn csv_frf(bytes: &[u8]) -> String {
    class(modalflow::io::csv_frf::read_frf_csv(bytes, "fuzz.csv"))
}

fn model(bytes: &[u8]) -> String {
    let text = String::from_utf8_lossy(bytes);
    let resolver = |_: &str| -> std::io::Result<Vec<u8>> {
        Err(std::io::Error::from(std::io::ErrorKind::NotFound))
    };
    class(modalflow::dynamics::Model::from_yaml(
        &text,
        "fuzz.yaml",
        &resolver,
    ))
}

/// A directory holding the example models, for pipelines that name them.
static PIPELINE_DIR: OnceLock<PathBuf> = OnceLock::new();

fn pipeline_dir() -> &'static Path {
    PIPELINE_DIR.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("modalflow-fuzz-{}", std::process::id()));
        let models = dir.join("models");
        let _ = std::fs::create_dir_all(&models);
        let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("pipelines/models");
        for e in std::fs::read_dir(src).into_iter().flatten().flatten() {
            let _ = std::fs::copy(e.path(), models.join(e.file_name()));
        }
        dir
    })
}

/// Remove the directories [`pipeline_dir`] and [`record_bench`] made.
pub fn cleanup() {
    if let Some(dir) = PIPELINE_DIR.get() {
        let _ = std::fs::remove_dir_all(dir);
    }
    if let Some(bench) = RECORD_BENCH.get() {
        let _ = std::fs::remove_dir_all(&bench.parent);
    }
}

fn pipeline(bytes: &[u8]) -> String {
    let text = String::from_utf8_lossy(bytes);
    let dir = pipeline_dir();
    match modalflow::pipeline::plan::plan_source(&dir.join("p.yaml"), dir, &text) {
        Err(modalflow::pipeline::plan::PlanError::Invalid(d)) => {
            let first = d.0.first().map(|d| d.message.clone()).unwrap_or_default();
            class::<(), _>(Err(first))
        }
        other => class(other),
    }
}

/// The path policy on arbitrary text: what it accepts must stay below its
/// root, whatever the spelling; a violation is a finding (a panic).
fn paths(bytes: &[u8]) -> String {
    use modalflow::paths::{name, relative};
    let text = String::from_utf8_lossy(bytes);
    let root = Path::new("/root-of-fuzz");
    if let Ok(rel) = relative(&text) {
        let joined = root.join(&rel);
        let escapes = Path::new(&rel)
            .components()
            .any(|c| !matches!(c, std::path::Component::Normal(_)));
        assert!(
            !escapes && joined.starts_with(root) && joined != root,
            "relative({text:?}) = {rel:?} leaves its root"
        );
        assert!(!rel.chars().any(char::is_control), "{rel:?}");
    }
    if name(&text).is_ok() {
        let joined = root.join(&*text);
        assert_eq!(
            joined.parent(),
            Some(root),
            "name({text:?}) is not one component"
        );
    }
    class(relative(&text))
}

/// A scratch cache and a sandbox beside decoys, on a RAM disk where there
/// is one (records are written with fsync).
struct RecordBench {
    store: modalflow::pipeline::store::Store,
    sandbox: PathBuf,
    decoy: PathBuf,
    parent: PathBuf,
}

static RECORD_BENCH: OnceLock<RecordBench> = OnceLock::new();

fn record_bench() -> &'static RecordBench {
    RECORD_BENCH.get_or_init(|| {
        let base = if Path::new("/dev/shm").is_dir() {
            PathBuf::from("/dev/shm")
        } else {
            std::env::temp_dir()
        };
        let parent = base.join(format!("modalflow-fuzz-record-{}", std::process::id()));
        let _ = std::fs::create_dir_all(parent.join("sandbox/a/b"));
        let decoy = parent.join("decoy.txt");
        let _ = std::fs::write(&decoy, "decoy");
        let store = modalflow::pipeline::store::Store::open(&parent.join("cache"))
            .unwrap_or_else(|e| panic!("fuzz cache: {e}"));
        // Objects the seeds refer to: "a\n" and "b\n".
        for blob in [b"a\n".as_slice(), b"b\n"] {
            let _ = store.put_bytes(blob);
        }
        RecordBench {
            store,
            sandbox: parent.join("sandbox/a/b"),
            decoy,
            parent,
        }
    })
}

/// A run record (its text; `TREE` in it stands for the hash of the tree
/// listing after the line `---`) sealed as the store would, read back, and
/// every output it lists checked out into a sandbox two levels below a
/// decoy: nothing may appear or change outside the sandbox and the cache.
fn record(bytes: &[u8]) -> String {
    use modalflow::pipeline::store::RunRecord;
    let bench = record_bench();
    let text = String::from_utf8_lossy(bytes);
    let (rec_text, tree) = text.split_once("\n---\n").unwrap_or((&text, ""));
    let tree_hash = match bench.store.put_bytes(tree.as_bytes()) {
        Ok(h) => h,
        Err(e) => return class::<(), _>(Err(e)),
    };
    let rec_text = rec_text.replace("TREE", &tree_hash);
    let mut rec: RunRecord = match serde_json::from_str(&rec_text) {
        Ok(r) => r,
        Err(e) => return class::<(), _>(Err(e)),
    };
    rec.key = "fuzz".into();
    if let Err(e) = bench.store.write_record(&rec) {
        return class::<(), _>(Err(e));
    }
    let read = match bench.store.read_record("fuzz") {
        Ok(Some(r)) => r,
        Ok(None) => return "none".into(),
        Err(e) => return class::<(), _>(Err(e)),
    };
    let mut outcome = Ok(());
    for out in read.outputs.values() {
        if let Err(e) = bench.store.verify(&out.artifact) {
            outcome = Err(e);
            continue;
        }
        if let Err(e) = bench
            .store
            .checkout(&out.artifact, &bench.sandbox.join(&out.file))
        {
            outcome = Err(e.to_string());
        }
    }
    let decoy = std::fs::read(&bench.decoy).unwrap_or_default();
    assert_eq!(decoy, b"decoy", "a record changed the decoy");
    let mut names: Vec<String> = std::fs::read_dir(&bench.parent)
        .into_iter()
        .flatten()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(
        names,
        ["cache", "decoy.txt", "sandbox"],
        "a record wrote outside"
    );
    let sandbox_parent = bench.sandbox.parent().unwrap_or(&bench.parent);
    let inside: Vec<_> = std::fs::read_dir(sandbox_parent)
        .into_iter()
        .flatten()
        .flatten()
        .collect();
    assert_eq!(inside.len(), 1, "a record wrote beside the sandbox");
    let _ = std::fs::remove_dir_all(&bench.sandbox);
    let _ = std::fs::create_dir_all(&bench.sandbox);
    class(outcome)
}

/// The seed files of a target, read from below `root`.
pub fn seeds(root: &Path, target: &Target) -> Vec<Vec<u8>> {
    let mut out = Vec::new();
    for s in target.seeds {
        let p = root.join(s);
        let files: Vec<PathBuf> = if p.is_dir() {
            let mut f: Vec<PathBuf> = std::fs::read_dir(&p)
                .into_iter()
                .flatten()
                .flatten()
                .map(|e| e.path())
                .filter(|p| p.is_file() && p.extension().is_none_or(|x| x != "py"))
                .collect();
            f.sort();
            f
        } else {
            vec![p]
        };
        out.extend(files.iter().filter_map(|f| std::fs::read(f).ok()));
    }
    out
}

/// splitmix64: a small seeded generator, so a run is reproducible from
/// its seed without any dependency.
pub struct Rng(pub u64);

impl Rng {
    pub fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    pub fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

/// Tokens worth inserting: numbers at the edges of what parsers accept,
/// YAML and UFF syntax, names the formats use.
const TOKENS: &[&[u8]] = &[
    b"-1",
    b"0",
    b"1e308",
    b"-1e308",
    b"NaN",
    b"inf",
    b"4294967297",
    b"18446744073709551616",
    b"1099511627776",
    b"    -1",
    b"\n",
    b"\r\n",
    b": ",
    b"- ",
    b"{",
    b"}",
    b"[",
    b"]",
    b",",
    b"~",
    b"&a",
    b"*a",
    b"!!binary",
    b"\"",
    b"'",
    b"#",
    b"${matrix.x}",
    b"kind: ",
    b"params: ",
    b"inputs: ",
    b"matrix: ",
    b"    -1\n    58\n",
    b"58b",
    b"  2  1  1  8",
    b"D+99",
    b"E-400",
    b"re:1+X/1+X",
    b"position",
    b"frequency_hz",
    b"rigid: ",
    b"beam: ",
    b"dofs: [x]",
    b"../",
    b"/",
    b"./",
    b"..",
    b"\\",
    b"//",
    b"\0",
    b"\"file\": \"",
    b"\"path\": \"",
    b"\"hash\": \"",
    b"../../decoy.txt",
];

/// One random mutation of `input` (`other`: a second corpus entry for
/// splicing).
pub fn mutate(rng: &mut Rng, input: &[u8], other: &[u8]) -> Vec<u8> {
    let mut v = input.to_vec();
    let rounds = 1 + rng.below(4);
    for _ in 0..rounds {
        let len = v.len();
        let at = rng.below(len + 1);
        match rng.below(9) {
            0 if len > 0 => v[at.min(len - 1)] ^= 1 << rng.below(8),
            1 if len > 0 => v[at.min(len - 1)] = rng.next() as u8,
            2 => {
                let n = rng.below(16).min(len - at);
                v.drain(at..at + n);
            }
            3 => {
                let t = TOKENS[rng.below(TOKENS.len())];
                v.splice(at..at, t.iter().copied());
            }
            4 if len > 0 => {
                // Duplicate a slice (repeated blocks, long lines).
                let from = rng.below(len);
                let n = rng.below(64).min(len - from);
                let piece: Vec<u8> = v[from..from + n].to_vec();
                v.splice(at..at, piece);
            }
            5 if !other.is_empty() => {
                let from = rng.below(other.len());
                let n = rng.below(256).min(other.len() - from);
                v.splice(at..at, other[from..from + n].iter().copied());
            }
            6 => {
                // Replace a run of digits by another number.
                if let Some(p) = (at..len).find(|&i| v[i].is_ascii_digit()) {
                    let end = (p..len).find(|&i| !v[i].is_ascii_digit()).unwrap_or(len);
                    let t = TOKENS[rng.below(9)];
                    v.splice(p..end, t.iter().copied());
                }
            }
            7 => v.truncate(at),
            _ => {
                let b = [b' ', b'\n', b'-', b'.', b'0', b':', 0, 0xff][rng.below(8)];
                v.insert(at, b);
            }
        }
    }
    v.truncate(1 << 16);
    v
}
