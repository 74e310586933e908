//! Helpers for CLI tests: a temp workspace with a pipeline file, and the
//! `modalflow` binary run inside it with `--json` output deserialized.

#![allow(dead_code)]

pub mod models;
pub mod slurm;

use modalflow::artifacts::cost::Cost;
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

pub struct Workspace {
    pub dir: tempfile::TempDir,
}

impl Workspace {
    pub fn new() -> Workspace {
        Workspace {
            dir: tempfile::tempdir().expect("temp dir"),
        }
    }

    pub fn path(&self) -> &Path {
        self.dir.path()
    }

    pub fn write(&self, rel: &str, text: &str) -> PathBuf {
        let p = self.path().join(rel);
        if let Some(d) = p.parent() {
            std::fs::create_dir_all(d).unwrap();
        }
        std::fs::write(&p, text).unwrap();
        p
    }

    /// Copy the repository's file `repo_rel` into the workspace as `name`.
    pub fn copy_in(&self, repo_rel: &str, name: &str) {
        let src = Path::new(env!("CARGO_MANIFEST_DIR")).join(repo_rel);
        std::fs::copy(&src, self.path().join(name))
            .unwrap_or_else(|e| panic!("copy {}: {e}", src.display()));
    }

    pub fn read(&self, rel: &str) -> String {
        std::fs::read_to_string(self.path().join(rel)).unwrap_or_else(|e| panic!("read {rel}: {e}"))
    }

    /// A JSON file of the workspace, parsed (a `serde_json::Value` or any
    /// type it deserializes into).
    pub fn json<T: serde::de::DeserializeOwned>(&self, rel: &str) -> T {
        serde_json::from_str(&self.read(rel)).unwrap_or_else(|e| panic!("parse {rel}: {e}"))
    }

    /// The `cost.json` of the identify stage whose results are in `dir`,
    /// read through the schema the stage writes it with.
    pub fn cost(&self, dir: &str) -> Cost {
        Cost::read(&self.path().join(dir).join("cost.json")).unwrap_or_else(|e| panic!("{e}"))
    }

    /// Run `modalflow ARGS` in the workspace.
    pub fn cmd(&self, args: &[&str]) -> Output {
        self.command(args).output().expect("run modalflow")
    }

    pub fn command(&self, args: &[&str]) -> Command {
        let mut c = Command::new(env!("CARGO_BIN_EXE_modalflow"));
        c.args(args)
            .current_dir(self.path())
            .env_remove("MODALFLOW_CACHE");
        c
    }

    /// `modalflow ARGS` in the workspace, asserting its exit code; its
    /// stderr.
    pub fn cmd_exit(&self, args: &[&str], code: i32) -> String {
        let out = self.cmd(args);
        let err = text(&out.stderr);
        assert_eq!(out.status.code(), Some(code), "{err}");
        err
    }

    /// `modalflow run p.yaml --json`, asserting the exit code.
    pub fn run(&self, extra: &[&str], expect_code: i32) -> Report {
        let mut args = vec!["run", "p.yaml", "--json", "--progress", "none"];
        args.extend_from_slice(extra);
        let out = self.cmd(&args);
        assert_eq!(
            out.status.code(),
            Some(expect_code),
            "stdout: {}\nstderr: {}",
            text(&out.stdout),
            text(&out.stderr)
        );
        Report(
            serde_json::from_slice(&out.stdout)
                .unwrap_or_else(|e| panic!("json: {e}: {}", text(&out.stdout))),
        )
    }

    pub fn status(&self) -> Report {
        let out = self.cmd(&["status", "p.yaml", "--json"]);
        assert_eq!(out.status.code(), Some(0), "stderr: {}", text(&out.stderr));
        Report(serde_json::from_slice(&out.stdout).unwrap())
    }

    /// Number of lines in the execution log that stages append to.
    pub fn executions(&self, stage: &str) -> usize {
        std::fs::read_to_string(self.path().join("executions.log"))
            .unwrap_or_default()
            .lines()
            .filter(|l| *l == stage)
            .count()
    }

    /// The frequencies (Hz, fourth column) of a `modes.csv` below the
    /// workspace, in file order.
    pub fn frequencies(&self, rel: &str) -> Vec<f64> {
        self.read(rel)
            .lines()
            .skip(1)
            .map(|l| l.split(',').nth(3).unwrap().parse().unwrap())
            .collect()
    }

    pub fn runs_in_cache(&self) -> usize {
        std::fs::read_dir(self.path().join("cache/runs"))
            .map(|d| d.count())
            .unwrap_or(0)
    }
}

/// Two runs' mode frequencies (Hz), `count` of them, equal to 1e-12.
pub fn assert_same_frequencies(a: &[f64], b: &[f64], count: usize) {
    assert_eq!(a.len(), count, "{a:?}");
    assert_eq!(b.len(), count, "{b:?}");
    for (x, y) in a.iter().zip(b) {
        assert!((x - y).abs() <= 1e-12 * x, "{x} vs {y}");
    }
}

/// The fields of the CSV line of `text` whose first field is `key`
/// (panics naming the key when there is none).
pub fn csv_row<'a>(text: &'a str, key: &str) -> Vec<&'a str> {
    text.lines()
        .find(|l| l.split(',').next() == Some(key))
        .unwrap_or_else(|| panic!("no row `{key}` in:\n{text}"))
        .split(',')
        .collect()
}

pub fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// A `run`/`status` JSON report.
pub struct Report(pub Value);

impl Report {
    pub fn status_of(&self, stage: &str) -> String {
        self.stage(stage)["status"]
            .as_str()
            .unwrap_or_default()
            .to_string()
    }

    pub fn stage(&self, stage: &str) -> &Value {
        self.0["stages"]
            .as_array()
            .and_then(|a| a.iter().find(|s| s["name"] == stage))
            .unwrap_or_else(|| panic!("no stage {stage} in {}", self.0))
    }

    /// `(name, status)` for every stage, in report order.
    pub fn statuses(&self) -> Vec<(String, String)> {
        self.0["stages"]
            .as_array()
            .unwrap()
            .iter()
            .map(|s| {
                (
                    s["name"].as_str().unwrap().to_string(),
                    s["status"].as_str().unwrap().to_string(),
                )
            })
            .collect()
    }

    pub fn all(&self, status: &str) -> bool {
        self.statuses().iter().all(|(_, s)| s == status)
    }
}

/// A diamond with a fan-out: gen -> up -> {left, right} -> join, plus an
/// independent `solo`. Every command appends its stage name to
/// executions.log (not an out), so tests can count real executions.
pub const DIAMOND: &str = r#"name: diamond
stages:
  gen:
    kind: command
    params: {cmd: "echo gen >> executions.log; echo hello > a.txt", outs: [a.txt]}
  up:
    kind: command
    params: {cmd: "echo up >> executions.log; tr a-z A-Z < a.txt > b.txt", deps: [a.txt], outs: [b.txt]}
  left:
    kind: command
    params: {cmd: "echo left >> executions.log; cat b.txt b.txt > l.txt", deps: [b.txt], outs: [l.txt]}
  right:
    kind: command
    params: {cmd: "echo right >> executions.log; rev b.txt > r.txt", deps: [b.txt], outs: [r.txt]}
  join:
    kind: command
    params: {cmd: "echo join >> executions.log; cat l.txt r.txt > j.txt", deps: [l.txt, r.txt], outs: [j.txt]}
  solo:
    kind: command
    params: {cmd: "echo solo >> executions.log; echo alone > s.txt", outs: [s.txt]}
"#;

/// A workspace holding `pipelines/models` and the study `name` as `p.yaml`,
/// with each (from, to) edit applied exactly as written.
pub fn study(name: &str, edits: &[(&str, &str)]) -> Workspace {
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/pipelines");
    let ws = Workspace::new();
    for entry in std::fs::read_dir(format!("{root}/models"))
        .unwrap()
        .flatten()
    {
        let text = std::fs::read_to_string(entry.path()).unwrap();
        ws.write(
            &format!("models/{}", entry.file_name().to_string_lossy()),
            &text,
        );
    }
    let mut text = std::fs::read_to_string(format!("{root}/{name}.yaml")).unwrap();
    for (from, to) in edits {
        assert!(
            text.contains(from),
            "{name}.yaml no longer contains `{from}`"
        );
        text = text.replace(from, to);
    }
    ws.write("p.yaml", &text);
    ws
}

/// Every figure of pipeline `name`'s report holds to the style guide's
/// structural rules (axes titled, no text outside the view box, bounded
/// ticks: `modalflow::report::lint`), has a PNG twin, and the page has
/// the figures inline. Returns the number of figures checked.
#[allow(dead_code)]
pub fn assert_report_figures(ws: &Workspace, name: &str) -> usize {
    let dir = ws.path().join(format!("results/{name}/report/report"));
    let html = std::fs::read_to_string(dir.join("index.html")).unwrap();
    let mut n = 0;
    let mut problems = Vec::new();
    for entry in std::fs::read_dir(dir.join("figures")).unwrap().flatten() {
        let path = entry.path();
        if path.extension().is_none_or(|e| e != "svg") {
            continue;
        }
        n += 1;
        let svg = std::fs::read_to_string(&path).unwrap();
        let file = path.file_name().unwrap().to_string_lossy().into_owned();
        problems.extend(
            modalflow::report::lint::check(&svg)
                .into_iter()
                .map(|p| format!("{file}: {p}")),
        );
        let png = path.with_extension("png");
        let bytes = std::fs::read(&png).unwrap_or_default();
        assert!(bytes.starts_with(b"\x89PNG"), "{} missing", png.display());
        assert!(
            html.contains(&format!("figures/{file}")),
            "{file} not linked"
        );
    }
    assert!(problems.is_empty(), "{name}: {problems:#?}");
    assert_eq!(
        html.matches("<figure").count(),
        n,
        "every figure inline once"
    );
    n
}

/// The real beam of `../shared/data/real/beam_ufsc_ss` (canonical path), or
/// None with a note when the folder is absent outside CI; in CI (which
/// always has `../shared` beside the clone) its absence fails the test.
pub fn real_beam_dir() -> Option<std::path::PathBuf> {
    let dir = std::path::Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../shared/data/real/beam_ufsc_ss"
    ));
    if !dir.is_dir() {
        assert!(
            std::env::var_os("CI").is_none(),
            "{} missing in CI",
            dir.display()
        );
        eprintln!("skipping: {} not found", dir.display());
        return None;
    }
    Some(dir.canonicalize().expect("real beam folder"))
}
pub mod hex8;
