//! Never touch what is not yours: every way a pipeline file from someone
//! else, a planted link or a forged cache record could make modalflow
//! create, change, remove or read a file outside the pipeline directory,
//! its results and its cache. Each test plants decoys beside the project
//! (`outside/`) and in it (the pipeline file, `keep/`), runs the hostile
//! case through the CLI, and compares the decoys byte for byte afterwards;
//! the expected exit code is the README's (2: refused at validation).

use crate::util::{text, Workspace};
use modalflow::pipeline::store::{RunRecord, Store};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Output;

const DECOY: &str = "DECOY-CONTENT-7f3a\n";

/// A temp root with `outside/` (decoys no run may touch) and `proj/` (the
/// pipeline directory, cache and results).
struct Sandbox {
    root: Workspace,
}

impl Sandbox {
    fn new() -> Sandbox {
        let root = Workspace::new();
        root.write("outside/decoy.txt", DECOY);
        root.write("outside/dir/nested.txt", DECOY);
        root.write("proj/keep/precious.txt", DECOY);
        root.write("proj/models/m.txt", DECOY);
        Sandbox { root }
    }

    fn proj(&self) -> PathBuf {
        self.root.path().join("proj")
    }

    fn write(&self, rel: &str, body: &str) {
        self.root.write(&format!("proj/{rel}"), body);
    }

    /// `modalflow ARGS` in `proj/`.
    fn cmd(&self, args: &[&str]) -> Output {
        let mut c = self.root.command(args);
        c.current_dir(self.proj());
        c.output().expect("run modalflow")
    }

    /// Every file outside `proj/cache` and `proj/results`, with content.
    fn snapshot(&self) -> BTreeMap<PathBuf, Vec<u8>> {
        let mut out = BTreeMap::new();
        let mut stack = vec![self.root.path().to_path_buf()];
        while let Some(dir) = stack.pop() {
            for e in std::fs::read_dir(&dir).unwrap().flatten() {
                let p = e.path();
                if p == self.proj().join("cache") || p == self.proj().join("results") {
                    continue;
                }
                let t = e.file_type().unwrap();
                if t.is_dir() {
                    stack.push(p);
                } else if t.is_symlink() {
                    out.insert(
                        p.clone(),
                        std::fs::read_link(&p)
                            .unwrap()
                            .into_os_string()
                            .into_encoded_bytes(),
                    );
                } else {
                    out.insert(p.clone(), std::fs::read(&p).unwrap());
                }
            }
        }
        out
    }

    /// Run `args`, expect `code`, and check nothing outside the cache and
    /// results changed except `allowed` (paths below `proj/`).
    fn expect(&self, args: &[&str], code: i32, allowed: &[&str]) -> String {
        let before = self.snapshot();
        let out = self.cmd(args);
        let stderr = text(&out.stderr);
        assert_eq!(
            out.status.code(),
            Some(code),
            "{args:?}\nstdout: {}\nstderr: {stderr}",
            text(&out.stdout)
        );
        let mut after = self.snapshot();
        let mut before = before;
        for a in allowed {
            let p = self.proj().join(a);
            before.retain(|k, _| !k.starts_with(&p));
            after.retain(|k, _| !k.starts_with(&p));
        }
        assert_eq!(
            before.keys().collect::<Vec<_>>(),
            after.keys().collect::<Vec<_>>(),
            "{args:?} created or removed files outside its area\n{stderr}"
        );
        for (k, v) in &before {
            assert_eq!(Some(v), after.get(k), "{args:?} changed {}", k.display());
        }
        assert!(
            !stderr.contains(DECOY.trim()),
            "a decoy was quoted: {stderr}"
        );
        stderr
    }
}

fn command_stage(outs: &str) -> String {
    format!("name: p\nstages:\n  s:\n    kind: command\n    params: {{cmd: \"true\", outs: [{outs}]}}\n")
}

#[test]
fn outs_that_name_the_directory_its_parent_or_an_absolute_path_are_refused() {
    let sb = Sandbox::new();
    for outs in [
        "\".\"",
        "\"./\"",
        "\"./.\"",
        "\"\"",
        "\"keep/..\"",
        "\"../outside\"",
        "\"../outside/decoy.txt\"",
        "\"/tmp\"",
        "\"keep/\\n\"",
        "p.yaml",
    ] {
        sb.write("p.yaml", &command_stage(outs));
        for cmd in ["validate", "run", "status"] {
            let err = sb.expect(&[cmd, "p.yaml"], 2, &[]);
            assert!(err.contains("output"), "{outs}: {err}");
        }
    }
}

#[test]
fn outs_overlapping_the_cache_or_results_and_overlapping_roots_are_refused() {
    let sb = Sandbox::new();
    for outs in ["cache", "results", "results/p", "cache/objects"] {
        sb.write("p.yaml", &command_stage(outs));
        let err = sb.expect(&["run", "p.yaml"], 2, &["cache"]);
        assert!(err.contains("overlaps"), "{outs}: {err}");
    }
    // A results folder that is the project, or contains it.
    sb.write("study/p.yaml", "name: study\nstages:\n  keep:\n    kind: command\n    params: {cmd: \"echo x > o.txt\", outs: [o.txt]}\n");
    let err = sb.expect(&["run", "study/p.yaml", "--results", "."], 2, &["cache"]);
    assert!(err.contains("contains the pipeline directory"), "{err}");
    sb.expect(&["validate", "study/p.yaml", "--results", "."], 2, &[]);
    // A cache inside the results folder, and results inside the cache.
    sb.write("p.yaml", &command_stage("o.txt"));
    for (cache, results) in [
        ("results/p/s", "results"),
        ("cache", "cache/r"),
        (".", "results"),
    ] {
        let err = sb.expect(
            &["run", "p.yaml", "--cache", cache, "--results", results],
            2,
            &[],
        );
        assert!(err.contains("overlap") || err.contains("contains"), "{err}");
    }
}

#[test]
fn matrix_values_keys_and_long_names_cannot_make_paths() {
    let sb = Sandbox::new();
    for matrix in [
        "{v: [\"../../outside\"]}",
        "{v: [\"a/b\"]}",
        "{v: [\"..\"]}",
        "{v: [\"x\\ny\"]}",
        "{\"../k\": [1]}",
        "{k/x: [1]}",
    ] {
        sb.write(
            "p.yaml",
            &format!("name: p\nstages:\n  s:\n    kind: command\n    matrix: {matrix}\n    params: {{cmd: \"true\"}}\n"),
        );
        sb.expect(&["validate", "p.yaml"], 2, &[]);
        sb.expect(&["run", "p.yaml"], 2, &[]);
    }
    let long = "n".repeat(240);
    for file in [
        format!("name: {long}\nstages:\n  s:\n    kind: command\n    params: {{cmd: \"true\"}}\n"),
        format!("name: p\nstages:\n  {long}:\n    kind: command\n    params: {{cmd: \"true\"}}\n"),
        format!("name: p\nstages:\n  s:\n    kind: command\n    matrix: {{v: [{long}]}}\n    params: {{cmd: \"true\"}}\n"),
    ] {
        sb.write("p.yaml", &file);
        let err = sb.expect(&["run", "p.yaml"], 2, &[]);
        assert!(err.contains("200"), "{err}");
    }
}

#[test]
fn links_are_never_written_through_nor_followed_into_the_cache() {
    let sb = Sandbox::new();
    std::os::unix::fs::symlink(sb.root.path().join("outside"), sb.proj().join("link")).unwrap();
    sb.write("p.yaml", &command_stage("link/decoy.txt"));
    let err = sb.expect(&["run", "p.yaml"], 2, &[]);
    assert!(err.contains("symbolic link"), "{err}");
    sb.write("p.yaml", &command_stage("link"));
    sb.expect(&["validate", "p.yaml"], 2, &[]);
    // A link inside an output folder, made by the command itself.
    sb.write(
        "p.yaml",
        "name: p\nstages:\n  s:\n    kind: command\n    params: {cmd: \"mkdir -p d && ln -sf ../../outside/decoy.txt d/leak\", outs: [d]}\n",
    );
    let err = sb.expect(&["run", "p.yaml"], 1, &["cache", "d"]);
    assert!(err.contains("symbolic link"), "{err}");
    for entry in walk(&sb.proj().join("cache")) {
        let bytes = std::fs::read(&entry).unwrap_or_default();
        assert!(
            !String::from_utf8_lossy(&bytes).contains(DECOY.trim()),
            "{}",
            entry.display()
        );
    }
}

#[test]
fn files_outside_the_pipeline_directory_are_read_only_when_listed() {
    let sb = Sandbox::new();
    let deps = ["../outside/decoy.txt", "/etc/hostname", "link/decoy.txt"];
    std::os::unix::fs::symlink(sb.root.path().join("outside"), sb.proj().join("link")).unwrap();
    for dep in deps {
        sb.write(
            "p.yaml",
            &format!("name: p\nstages:\n  s:\n    kind: command\n    params: {{cmd: \"true\", deps: [\"{dep}\"]}}\n"),
        );
        let err = sb.expect(&["validate", "p.yaml"], 2, &[]);
        assert!(
            err.contains("outside the pipeline directory") && err.contains("read_outside"),
            "{err}"
        );
    }
    // A model file pulling in a matrix file from elsewhere: refused, and
    // the foreign file's content is never quoted.
    sb.write(
        "models/fe.yaml",
        "parameters:\n  - {name: k, value: 1.0e6, lower: 1.0e5, upper: 1.0e7, scale: log, kind: stiffness}\n\
         bodies:\n  - name: se\n    superelement:\n      mass: ../../outside/decoy.txt\n      \
         stiffness: ../../outside/decoy.txt\n      nodes:\n        - {id: 1, dofs: [0, 1, 2], position: [0, 0, 0]}\n      \
         points: {a: {node: 1}}\njoints:\n  - {name: s1, a: {body: se, point: a}, connections: [{dir: x, stiffness: k}]}\n\
         sensors:\n  - {name: a, body: se, point: a, node: 1, direction: 1}\n",
    );
    sb.write(
        "p.yaml",
        "name: p\nstages:\n  t:\n    kind: synthesize\n    params: {model: models/fe.yaml, frequency: {min: 0, max: 10, step: 1}}\n",
    );
    let err = sb.expect(&["validate", "p.yaml"], 2, &[]);
    assert!(
        err.contains("outside the pipeline and model directories"),
        "{err}"
    );
    // Listed on purpose: read.
    sb.write(
        "p.yaml",
        "name: p\nread_outside: [../outside]\nstages:\n  s:\n    kind: command\n    params: {cmd: \"cat ../outside/decoy.txt > o.txt\", deps: [../outside/decoy.txt], outs: [o.txt]}\n",
    );
    sb.expect(&["run", "p.yaml"], 0, &["cache", "results", "o.txt"]);
    assert_eq!(
        std::fs::read_to_string(sb.proj().join("o.txt")).unwrap(),
        DECOY
    );
}

/// A run of a two-output command stage, and its record.
fn cached_run(sb: &Sandbox, key_file: Option<&Path>) -> (Store, RunRecord) {
    sb.write(
        "p.yaml",
        "name: p\nstages:\n  s:\n    kind: command\n    params: {cmd: \"mkdir -p d && echo a > d/a.txt && echo b > o.txt\", outs: [d, o.txt]}\n",
    );
    let mut c = sb
        .root
        .command(&["run", "p.yaml", "--json", "--progress", "none"]);
    c.current_dir(sb.proj());
    if let Some(k) = key_file {
        c.env("MODALFLOW_CACHE_KEY_FILE", k);
    }
    let out = c.output().unwrap();
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let key = v["stages"][0]["key"].as_str().unwrap().to_string();
    let store = Store::open(&sb.proj().join("cache")).unwrap();
    let rec = store.record(&key).unwrap_or_else(|| {
        // Keyed records do not open without the key: read the file as JSON.
        let p = sb.proj().join("cache/runs").join(format!("{key}.json"));
        serde_json::from_slice(&std::fs::read(p).unwrap()).unwrap()
    });
    (store, rec)
}

/// One way to edit a genuine record.
type Forgery = Box<dyn Fn(&mut RunRecord)>;

#[test]
fn a_forged_record_can_at_worst_make_a_stage_rerun() {
    let sb = Sandbox::new();
    let (store, rec) = cached_run(&sb, None);
    let pwned = store.put_bytes(b"PWNED\n").unwrap();
    let escape = "../../outside/decoy.txt";
    let tree =
        format!("{{\"entries\":[{{\"path\":\"{escape}\",\"hash\":\"{pwned}\",\"bytes\":6}}]}}");
    let tree_hash = store.put_bytes(tree.as_bytes()).unwrap();
    let forgeries: Vec<Forgery> = vec![
        Box::new(|r| r.outputs.get_mut("o.txt").unwrap().file = escape.into()),
        Box::new(|r| r.outputs.get_mut("o.txt").unwrap().file = "/tmp/x".into()),
        Box::new(|r| r.outputs.get_mut("o.txt").unwrap().artifact.hash = escape.into()),
        Box::new(move |r| r.outputs.get_mut("d").unwrap().artifact.hash = tree_hash.clone()),
        Box::new(|r| {
            let o = r.outputs.remove("o.txt").unwrap();
            r.outputs.insert(escape.into(), o);
        }),
    ];
    for forge in forgeries {
        let mut forged = rec.clone();
        forge(&mut forged);
        store.write_record(&forged).unwrap();
        std::fs::remove_dir_all(sb.proj().join("results")).ok();
        std::fs::remove_dir_all(sb.proj().join("d")).ok();
        let err = sb.expect(
            &["run", "p.yaml", "--progress", "lines"],
            0,
            &["cache", "results", "d", "o.txt"],
        );
        assert!(err.contains("cache entry unusable"), "{err}");
        assert_eq!(
            std::fs::read_to_string(sb.proj().join("o.txt")).unwrap(),
            "b\n"
        );
        assert_eq!(
            std::fs::read_to_string(sb.proj().join("d/a.txt")).unwrap(),
            "a\n"
        );
    }
}

#[test]
fn with_a_cache_key_a_record_written_without_it_is_recomputed() {
    let sb = Sandbox::new();
    let key = sb
        .root
        .write("secret.key", "a long random secret, 32 bytes or so\n");
    let (store, rec) = cached_run(&sb, Some(&key));
    // Someone without the key swaps o.txt for other (valid) content.
    let forged_obj = store.put_bytes(b"forged\n").unwrap();
    let mut forged = rec.clone();
    forged.outputs.get_mut("o.txt").unwrap().artifact.hash = forged_obj;
    store.write_record(&forged).unwrap();
    let mut c = sb.root.command(&["run", "p.yaml", "--progress", "lines"]);
    c.current_dir(sb.proj())
        .env("MODALFLOW_CACHE_KEY_FILE", &key);
    let out = c.output().unwrap();
    let err = text(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{err}");
    assert!(err.contains("not sealed with this cache's key"), "{err}");
    assert_eq!(
        std::fs::read_to_string(sb.proj().join("o.txt")).unwrap(),
        "b\n"
    );
    assert_eq!(
        std::fs::read_to_string(sb.proj().join("results/p/s/o.txt")).unwrap(),
        "b\n"
    );
}

#[test]
fn deep_yaml_nesting_is_refused_before_parsing() {
    let sb = Sandbox::new();
    let n = 100_000;
    sb.write(
        "p.yaml",
        &format!(
            "name: p\nstages:\n  s:\n    kind: command\n    params: {{cmd: x, deps: {}{}}}\n",
            "[".repeat(n),
            "]".repeat(n)
        ),
    );
    let err = sb.expect(&["validate", "p.yaml"], 2, &[]);
    assert!(err.contains("nesting deeper than 64"), "{err}");
}

fn walk(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).into_iter().flatten().flatten() {
            if e.file_type().is_ok_and(|t| t.is_dir()) {
                stack.push(e.path());
            } else {
                out.push(e.path());
            }
        }
    }
    out
}
