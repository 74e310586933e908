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

/// Remove the directory [`pipeline_dir`] made.
pub fn cleanup() {
    if let Some(dir) = PIPELINE_DIR.get() {
        let _ = std::fs::remove_dir_all(dir);
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
