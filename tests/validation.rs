//! Every class of bad pipeline file gives a located error that says how to
//! fix it, a non-zero exit, and leaves no cache entry.

use crate::util;

use util::Workspace;

/// Run `modalflow run p.yaml` on `yaml`; assert exit 2, no cache, and that
/// stderr contains every `needle`.
fn rejects(yaml: &str, needles: &[&str]) {
    let ws = Workspace::new();
    ws.write("p.yaml", yaml);
    ws.write("model.yaml", "m: 1\n");
    let out = ws.cmd(&["run", "p.yaml"]);
    let stderr = util::text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "stderr: {stderr}");
    for n in needles {
        assert!(stderr.contains(n), "missing {n:?} in:\n{stderr}");
    }
    assert!(stderr.starts_with("modalflow: "), "{stderr}");
    assert!(
        !ws.path().join("cache/runs").exists(),
        "nothing may be cached"
    );
    // validate agrees.
    let v = ws.cmd(&["validate", "p.yaml"]);
    assert_eq!(v.status.code(), Some(2));
}

const OK_STAGE: &str =
    "  a:\n    kind: command\n    params: {cmd: 'echo a > a.txt', outs: [a.txt]}\n";

#[test]
fn malformed_yaml() {
    rejects(
        "name: x\nstages:\n  a: [unclosed\n",
        &["p.yaml:", "invalid pipeline file"],
    );
}

#[test]
fn unknown_top_level_key() {
    rejects(
        &format!("name: x\nsteps: 1\nstages:\n{OK_STAGE}"),
        &["unknown field `steps`", "p.yaml:2:1"],
    );
}

#[test]
fn unknown_kind_lists_known_ones() {
    rejects(
        "name: x\nstages:\n  a:\n    kind: comand\n",
        &[
            "unknown stage kind `comand` in stage `a`",
            "p.yaml:4:11",
            "did you mean `command`?",
            "known kinds: synthesize, import, autoema,",
            "4 |     kind: comand",
        ],
    );
}

#[test]
fn unknown_param_lists_allowed_ones() {
    rejects(
        "name: x\nstages:\n  a:\n    kind: command\n    params: {cmd: 'true', out: [a.txt]}\n",
        &[
            "unknown param `out` for stage `a`",
            "p.yaml:5:27",
            "did you mean `outs`?",
            "accepts: cmd, deps, outs",
        ],
    );
}

#[test]
fn missing_required_param() {
    rejects(
        "name: x\nstages:\n  a:\n    kind: command\n",
        &["stage `a` (kind `command`) needs param `cmd`", "p.yaml:3:3"],
    );
}

#[test]
fn param_type_error() {
    rejects(
        "name: x\nstages:\n  a:\n    kind: command\n    params:\n      cmd: [not, a, string]\n",
        &["param `cmd` of stage `a` must be a string", "p.yaml:6:12"],
    );
}

#[test]
fn non_finite_param() {
    rejects(
        "name: x\nstages:\n  a:\n    kind: command\n    params: {cmd: 'true', deps: [], extra: .nan}\n",
        &["unknown param `extra`"],
    );
    rejects(
        "name: x\nseed: -1\nstages:\n  a:\n    kind: command\n    params: {cmd: 'true'}\n",
        &["invalid pipeline file", "p.yaml:2"],
    );
}

#[test]
fn missing_stage_lists_existing() {
    rejects(
        &format!("name: x\nstages:\n{OK_STAGE}  b:\n    kind: command\n    inputs: {{x: aa.a.txt}}\n    params: {{cmd: 'true'}}\n"),
        &["input `x` of stage `b`: no stage named `aa`", "did you mean `a`?", "stages: a, b", "p.yaml:8:17"],
    );
}

#[test]
fn missing_output_lists_existing() {
    rejects(
        &format!("name: x\nstages:\n{OK_STAGE}  b:\n    kind: command\n    inputs: {{x: a.b.txt}}\n    params: {{cmd: 'true'}}\n"),
        &["stage `a` has no output `b.txt`", "outputs of `a`: a.txt"],
    );
}

#[test]
fn matrix_stage_needs_a_selector() {
    rejects(
        "name: x\nstages:\n  a:\n    kind: command\n    matrix: {n: [1, 2]}\n    params: {cmd: 'true', outs: ['o${matrix.n}']}\n  b:\n    kind: command\n    inputs: {x: a.o1}\n    params: {cmd: 'true'}\n",
        &["`a` is a matrix of 2 stages", "a[n=1], a[n=2]"],
    );
}

#[test]
fn unknown_matrix_key() {
    rejects(
        "name: x\nstages:\n  a:\n    kind: command\n    matrix: {n: [1]}\n    params: {cmd: 'echo ${matrix.m}'}\n",
        &["`${matrix.m}` in stage `a` names no matrix key", "matrix keys: n", "p.yaml:6:19"],
    );
}

#[test]
fn cycles_are_named() {
    rejects(
        "name: x\nstages:\n  a:\n    kind: command\n    params: {cmd: 'cat c.txt > a.txt', deps: [c.txt], outs: [a.txt]}\n  b:\n    kind: command\n    params: {cmd: 'cat a.txt > b.txt', deps: [a.txt], outs: [b.txt]}\n  c:\n    kind: command\n    params: {cmd: 'cat b.txt > c.txt', deps: [b.txt], outs: [c.txt]}\n",
        &["the stages form a cycle: a -> b -> c -> a"],
    );
}

#[test]
fn missing_file_param() {
    rejects(
        "name: x\nstages:\n  a:\n    kind: command\n    params: {cmd: 'true', deps: [model.yaml, nothere.csv]}\n",
        &["file `nothere.csv` named by param `deps[1]` of stage `a` does not exist", "p.yaml:5:46"],
    );
}

#[test]
fn duplicate_stage_names() {
    rejects(
        &format!("name: x\nstages:\n{OK_STAGE}{OK_STAGE}"),
        &["duplicate"],
    );
}

#[test]
fn missing_pipeline_file() {
    let ws = Workspace::new();
    let out = ws.cmd(&["run", "nope.yaml"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(util::text(&out.stderr).contains("cannot read pipeline file nope.yaml"));
}

#[test]
fn all_problems_are_reported_at_once() {
    let ws = Workspace::new();
    ws.write(
        "p.yaml",
        "name: x\nstages:\n  a:\n    kind: nope\n  b:\n    kind: command\n    params: {cmd: 'true', bogus: 1}\n",
    );
    let out = ws.cmd(&["validate", "p.yaml"]);
    let stderr = util::text(&out.stderr);
    assert!(stderr.contains("2 problems"), "{stderr}");
}

/// The fenced block of `readme` (a Markdown page) that starts with `first`
/// (after the fence).
fn readme_block<'a>(readme: &'a str, first: &str) -> &'a str {
    let start = readme
        .find(&format!("\n{first}"))
        .map(|i| i + 1)
        .unwrap_or_else(|| panic!("the page has no block starting with {first:?}"));
    let end = readme[start..]
        .find("\n```")
        .map_or(readme.len(), |e| start + e);
    &readme[start..end]
}

#[test]
fn the_guides_sample_error_is_what_validate_prints() {
    let readme = include_str!("../docs/pipeline-file.md");
    let file = readme_block(
        readme,
        "name: quickstart\nseed: 7\nstages:\n  truth:\n    kind: synthesise",
    );
    let expected = readme_block(readme, "modalflow: 4 problems in pipeline file");
    let ws = Workspace::new();
    ws.write("pipelines/quickstart.yaml", &format!("{file}\n"));
    ws.write(
        "pipelines/models/three_mass.yaml",
        include_str!("../pipelines/models/three_mass.yaml"),
    );
    let out = ws.cmd(&["validate", "pipelines/quickstart.yaml"]);
    assert_eq!(out.status.code(), Some(2));
    let printed = String::from_utf8_lossy(&out.stderr);
    assert_eq!(printed.trim_end(), expected.trim_end());
}
