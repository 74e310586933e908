//! The pipeline engine through the CLI, with `command` stages: caching,
//! reruns after edits, early cut-off, restore, corruption, kills,
//! concurrency.

use crate::util;

use std::time::{Duration, Instant};
use util::{Workspace, DIAMOND};

#[test]
fn second_run_is_all_cached() {
    let ws = Workspace::new();
    ws.write("p.yaml", DIAMOND);
    let first = ws.run(&[], 0);
    assert!(first.all("ran"), "{:?}", first.statuses());
    assert_eq!(ws.read("j.txt"), "HELLO\nHELLO\nOLLEH\n");
    let second = ws.run(&[], 0);
    assert!(second.all("cached"), "{:?}", second.statuses());
    assert_eq!(ws.executions("join"), 1);
    assert!(ws.status().all("cached"));
}

#[test]
fn editing_params_reruns_exactly_the_stage_and_its_dependents() {
    let ws = Workspace::new();
    ws.write("p.yaml", DIAMOND);
    ws.run(&[], 0);
    ws.write(
        "p.yaml",
        &DIAMOND.replace("rev b.txt > r.txt", "rev b.txt | tr O 0 > r.txt"),
    );
    let status = ws.status();
    assert_eq!(status.status_of("right"), "will-run");
    let reason = status.stage("right")["reason"]
        .as_str()
        .unwrap()
        .to_string();
    assert!(reason.starts_with("param cmd changed"), "{reason}");
    assert_eq!(status.status_of("join"), "will-run");
    assert_eq!(status.stage("join")["reason"], "upstream right will run");
    let r = ws.run(&[], 0);
    let ran: Vec<String> = r
        .statuses()
        .into_iter()
        .filter(|(_, s)| s == "ran")
        .map(|(n, _)| n)
        .collect();
    assert_eq!(ran, vec!["right", "join"]);
    assert_eq!(ws.read("j.txt"), "HELLO\nHELLO\n0LLEH\n");
    assert_eq!(ws.executions("left"), 1);
    assert_eq!(ws.executions("right"), 2);
}

#[test]
fn upstream_rerun_with_identical_output_leaves_downstream_cached() {
    let ws = Workspace::new();
    ws.write("p.yaml", DIAMOND);
    ws.run(&[], 0);
    // Same bytes, different command: early cut-off keeps left/right/join cached.
    ws.write(
        "p.yaml",
        &DIAMOND.replace("echo hello > a.txt", "printf 'hello\\n' > a.txt"),
    );
    let r = ws.run(&[], 0);
    assert_eq!(r.status_of("gen"), "ran");
    for s in ["up", "left", "right", "join", "solo"] {
        assert_eq!(r.status_of(s), "cached", "{s}");
    }
}

#[test]
fn deleting_results_restores_without_recomputing() {
    let ws = Workspace::new();
    ws.write("p.yaml", DIAMOND);
    ws.run(&[], 0);
    let manifest = ws.read("results/diamond/join/manifest.json");
    std::fs::remove_dir_all(ws.path().join("results")).unwrap();
    std::fs::remove_file(ws.path().join("j.txt")).unwrap();
    let r = ws.run(&[], 0);
    assert!(r.all("cached"));
    assert_eq!(
        ws.read("results/diamond/join/j.txt"),
        "HELLO\nHELLO\nOLLEH\n"
    );
    assert_eq!(
        ws.read("j.txt"),
        "HELLO\nHELLO\nOLLEH\n",
        "workspace outs restored"
    );
    assert_eq!(ws.read("results/diamond/join/manifest.json"), manifest);
    assert_eq!(ws.executions("join"), 1);
    let m: serde_json::Value = serde_json::from_str(&manifest).unwrap();
    assert_eq!(m["stage"], "join");
    assert_eq!(m["kind"], "command");
    assert_eq!(m["inputs"], serde_json::json!({}));
    assert_eq!(m["files"].as_object().unwrap().len(), 2);
    assert!(m["outputs"]["j.txt"]["hash"].as_str().unwrap().len() == 64);
    assert_eq!(m["modalflow_version"], env!("CARGO_PKG_VERSION"));
}

#[test]
fn a_corrupted_object_is_detected_and_recomputed() {
    let ws = Workspace::new();
    ws.write("p.yaml", DIAMOND);
    let r = ws.run(&[], 0);
    let key = r.stage("right")["key"].as_str().unwrap().to_string();
    let rec: serde_json::Value = ws.json(&format!("cache/runs/{key}.json"));
    let hash = rec["outputs"]["r.txt"]["hash"].as_str().unwrap();
    let obj = ws
        .path()
        .join("cache/objects")
        .join(&hash[..2])
        .join(&hash[2..]);
    std::fs::write(&obj, "tampered\n").unwrap();
    let out = ws.cmd(&["run", "p.yaml", "--json", "--progress", "lines"]);
    assert_eq!(out.status.code(), Some(0));
    let stderr = util::text(&out.stderr);
    assert!(stderr.contains("corrupt"), "{stderr}");
    let report = util::Report(serde_json::from_slice(&out.stdout).unwrap());
    assert_eq!(report.status_of("right"), "ran");
    assert_eq!(
        report.status_of("join"),
        "cached",
        "same bytes again: early cut-off"
    );
    assert_eq!(std::fs::read_to_string(&obj).unwrap(), "OLLEH\n");
}

#[test]
fn a_killed_run_leaves_a_cache_the_next_run_completes() {
    use std::os::unix::process::CommandExt;
    let ws = Workspace::new();
    let slow = DIAMOND.replace(
        "echo up >> executions.log; tr",
        "echo up >> executions.log; touch started; sleep 30; tr",
    );
    ws.write("p.yaml", &slow);
    let mut child = ws
        .command(&["run", "p.yaml", "--progress", "none"])
        .process_group(0)
        .spawn()
        .unwrap();
    let t0 = Instant::now();
    while !ws.path().join("started").exists() {
        assert!(
            t0.elapsed() < Duration::from_secs(30),
            "stage never started"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    let pgid = format!("-{}", child.id());
    let killed = std::process::Command::new("kill")
        .args(["-KILL", "--", &pgid])
        .status()
        .unwrap();
    assert!(killed.success());
    let _ = child.wait();
    ws.write("p.yaml", DIAMOND);
    let r = ws.run(&[], 0);
    assert_eq!(r.status_of("gen"), "cached", "finished before the kill");
    assert_eq!(r.status_of("up"), "ran");
    assert_eq!(ws.read("j.txt"), "HELLO\nHELLO\nOLLEH\n");
    assert!(ws.run(&[], 0).all("cached"));
}

#[test]
fn two_concurrent_runs_share_one_cache() {
    let ws = Workspace::new();
    let slowish = DIAMOND.replace(
        "echo left >> executions.log;",
        "echo left >> executions.log; sleep 0.3;",
    );
    ws.write("p.yaml", &slowish);
    let spawn = || {
        ws.command(&["run", "p.yaml", "--json", "--progress", "none"])
            .stdout(std::process::Stdio::piped())
            .spawn()
            .unwrap()
    };
    let (a, b) = (spawn(), spawn());
    let (a, b) = (a.wait_with_output().unwrap(), b.wait_with_output().unwrap());
    assert!(a.status.success() && b.status.success());
    let ra: serde_json::Value = serde_json::from_slice(&a.stdout).unwrap();
    let rb: serde_json::Value = serde_json::from_slice(&b.stdout).unwrap();
    let keys = |r: &serde_json::Value| -> Vec<String> {
        r["stages"]
            .as_array()
            .unwrap()
            .iter()
            .map(|s| s["key"].as_str().unwrap().to_string())
            .collect()
    };
    assert_eq!(keys(&ra), keys(&rb));
    for s in ["gen", "up", "left", "right", "join", "solo"] {
        assert_eq!(ws.executions(s), 1, "{s} computed once");
    }
    assert_eq!(
        ws.read("results/diamond/join/j.txt"),
        "HELLO\nHELLO\nOLLEH\n"
    );
}

#[test]
fn a_failing_stage_caches_nothing_and_keep_going_finishes_other_branches() {
    let ws = Workspace::new();
    let broken = DIAMOND.replace("rev b.txt > r.txt", "echo oops >&2; exit 3");
    ws.write("p.yaml", &broken);
    let runs_before = ws.runs_in_cache();
    let r = ws.run(&["--jobs", "1"], 1);
    assert_eq!(r.status_of("right"), "failed");
    let err = r.stage("right")["error"].as_str().unwrap();
    assert!(
        err.contains("exited with status 3") && err.contains("oops"),
        "{err}"
    );
    assert_eq!(r.status_of("join"), "skipped");
    assert_eq!(
        r.status_of("solo"),
        "skipped",
        "a failure stops new work without --keep-going"
    );
    assert!(r.stage("solo")["reason"]
        .as_str()
        .unwrap()
        .contains("right failed"));
    assert_eq!(
        ws.runs_in_cache(),
        runs_before + 3,
        "gen, up, left cached; right not"
    );
    let keep = ws.run(&["--keep-going", "--jobs", "1"], 1);
    assert_eq!(keep.status_of("solo"), "ran");
    assert_eq!(keep.status_of("left"), "cached");
    assert_eq!(keep.status_of("join"), "skipped");
    let key = keep.stage("right")["key"].as_str().unwrap();
    assert!(!ws.path().join(format!("cache/runs/{key}.json")).exists());
}

#[test]
fn force_reruns_a_cached_stage() {
    let ws = Workspace::new();
    ws.write("p.yaml", DIAMOND);
    ws.run(&[], 0);
    let r = ws.run(&["--force", "left"], 0);
    assert_eq!(r.status_of("left"), "ran");
    assert_eq!(r.stage("left")["reason"], "forced");
    assert_eq!(r.status_of("join"), "cached");
    let bad = ws.cmd(&["run", "p.yaml", "--force", "nope"]);
    assert_eq!(bad.status.code(), Some(2));
}

#[test]
fn matrix_expansion_names_and_list_inputs() {
    let ws = Workspace::new();
    ws.write(
        "p.yaml",
        r#"name: m
seed: 11
stages:
  sweep:
    kind: command
    matrix: {method: [pso, ga], seed: [1, 2]}
    params: {cmd: "echo ${matrix.method}-${matrix.seed}-$MODALFLOW_SEED > o-${matrix.method}-${matrix.seed}.txt", outs: ["o-${matrix.method}-${matrix.seed}.txt"]}
  pick:
    kind: command
    inputs: {one: "sweep[seed=2,method=ga].o-ga-2.txt"}
    params: {cmd: "cp $MODALFLOW_INPUT_ONE picked.txt", outs: [picked.txt]}
"#,
    );
    let r = ws.run(&[], 0);
    let names: Vec<String> = r.statuses().into_iter().map(|(n, _)| n).collect();
    assert_eq!(
        names,
        [
            "sweep[method=pso,seed=1]",
            "sweep[method=pso,seed=2]",
            "sweep[method=ga,seed=1]",
            "sweep[method=ga,seed=2]",
            "pick"
        ]
    );
    assert_eq!(ws.read("picked.txt"), "ga-2-11\n");
    let dag = ws.cmd(&["dag", "p.yaml", "--format", "mermaid"]);
    let dag = util::text(&dag.stdout);
    assert!(
        dag.starts_with("flowchart LR") && dag.contains("n3 --> n4"),
        "{dag}"
    );
    let dot = util::text(&ws.cmd(&["dag", "p.yaml", "--format", "dot"]).stdout);
    assert!(
        dot.contains("\"sweep[method=ga,seed=2]\" -> \"pick\""),
        "{dot}"
    );
}

#[test]
fn gc_drops_unreferenced_objects_only() {
    let ws = Workspace::new();
    ws.write("p.yaml", DIAMOND);
    ws.run(&[], 0);
    ws.write("p.yaml", &DIAMOND.replace("echo alone", "echo together"));
    ws.run(&[], 0);
    let out = ws.cmd(&["gc", "--json"]);
    let g: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(g["removed_objects"], 1, "{g}");
    assert_eq!(g["removed_records"], 1, "{g}");
    assert!(g["removed_bytes"].as_u64().unwrap() > 0);
    assert!(
        ws.run(&[], 0).all("cached"),
        "gc kept everything the last run needs"
    );
}

#[test]
fn show_prints_the_manifest() {
    let ws = Workspace::new();
    ws.write("p.yaml", DIAMOND);
    ws.run(&[], 0);
    let out = ws.cmd(&["show", "p.yaml", "join", "--json"]);
    let m: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(m["stage"], "join");
    std::fs::remove_dir_all(ws.path().join("results")).unwrap();
    let out = ws.cmd(&["show", "p.yaml", "join"]);
    assert!(
        util::text(&out.stdout).contains("key      "),
        "falls back to the cache"
    );
}
