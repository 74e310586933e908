//! Reliability through the CLI (issue 17): results that cannot silently
//! rot (`verify`, restore on `run`), leftovers of dead runs, resource
//! bounds at validation, exit code 3 for cache and file-system failures
//! (a real full disk and real read-only mounts, in a private mount
//! namespace made with `unshare`), a read-only cache serving cached runs,
//! and run records bound to their key by a checksum.

use crate::util;

use serde_json::Value;
use std::process::Output;
use util::{text, Workspace};

/// A file output and a directory output, and a stage downstream.
const TREE: &str = r#"name: tree
stages:
  gen:
    kind: command
    params: {cmd: "echo gen >> executions.log; echo hello > a.txt; mkdir -p d/sub; echo x > d/x.txt; echo y > d/sub/y.txt", outs: [a.txt, d]}
  up:
    kind: command
    params: {cmd: "echo up >> executions.log; tr a-z A-Z < a.txt > b.txt", deps: [a.txt], outs: [b.txt]}
"#;

fn tree() -> Workspace {
    let ws = Workspace::new();
    ws.write("p.yaml", TREE);
    assert!(ws.run(&[], 0).all("ran"));
    ws
}

fn json(out: &Output) -> Value {
    serde_json::from_slice(&out.stdout)
        .unwrap_or_else(|e| panic!("json: {e}: {}\n{}", text(&out.stdout), text(&out.stderr)))
}

/// `sh -c SCRIPT` in a private user and mount namespace inside the
/// workspace (`$B` is the modalflow binary), or `None` where the system
/// does not allow one (then the test says so and passes).
fn in_namespace(ws: &Workspace, script: &str) -> Option<Output> {
    let out = std::process::Command::new("unshare")
        .args(["-rm", "sh", "-c", script])
        .current_dir(ws.path())
        .env("B", env!("CARGO_BIN_EXE_modalflow"))
        .env_remove("MODALFLOW_CACHE")
        .output()
        .ok()?;
    let err = text(&out.stderr);
    if err.starts_with("unshare:") || err.contains("mount: ") {
        eprintln!("skipped: no private mount namespace here ({err})");
        return None;
    }
    Some(out)
}

mod restore {
    use super::*;

    #[test]
    fn a_same_size_edit_and_a_deletion_inside_a_directory_output_are_restored() {
        let ws = tree();
        ws.write("results/tree/gen/a.txt", "jello\n");
        std::fs::remove_file(ws.path().join("results/tree/gen/d/sub/y.txt")).unwrap();
        let v = ws.cmd(&["verify", "p.yaml", "--json"]);
        assert_eq!(v.status.code(), Some(1), "{}", text(&v.stderr));
        let v = json(&v);
        assert_eq!(v["drifted"], 1, "{v}");
        let gen = &v["stages"][0];
        assert_eq!(
            (gen["stage"].as_str(), gen["status"].as_str()),
            (Some("gen"), Some("drift"))
        );
        let problems: Vec<(String, String)> = gen["problems"]
            .as_array()
            .unwrap()
            .iter()
            .map(|p| {
                (
                    p["path"].as_str().unwrap().into(),
                    p["problem"].as_str().unwrap().into(),
                )
            })
            .collect();
        assert_eq!(
            problems,
            [
                ("a.txt".into(), "modified".into()),
                ("d".into(), "modified".into())
            ]
        );
        assert_eq!(v["stages"][1]["status"], "ok");

        let r = ws.run(&[], 0);
        assert!(r.all("cached"), "{:?}", r.statuses());
        assert_eq!(ws.read("results/tree/gen/a.txt"), "hello\n");
        assert_eq!(ws.read("results/tree/gen/d/sub/y.txt"), "y\n");
        assert_eq!(ws.executions("gen"), 1, "restored, not recomputed");
        let v = ws.cmd(&["verify", "--json"]);
        assert_eq!(v.status.code(), Some(0));
        assert_eq!(json(&v)["drifted"], 0);
    }

    #[test]
    fn an_added_file_and_an_edited_manifest_are_drift_too() {
        let ws = tree();
        ws.write("results/tree/gen/d/extra.txt", "new\n");
        let manifest = ws.read("results/tree/up/manifest.json");
        let m: Value = serde_json::from_str(&manifest).unwrap();
        let hash = m["outputs"]["b.txt"]["hash"].as_str().unwrap();
        let forged = manifest.replace(hash, &"0".repeat(64));
        ws.write("results/tree/up/manifest.json", &forged);
        let v = json(&ws.cmd(&["verify", "p.yaml", "--json"]));
        assert_eq!(v["drifted"], 2, "{v}");
        ws.run(&[], 0);
        assert!(!ws.path().join("results/tree/gen/d/extra.txt").exists());
        assert_eq!(ws.read("results/tree/up/manifest.json"), manifest);
    }
}

mod leftovers {
    use super::*;

    #[test]
    fn staging_and_temp_files_of_dead_processes_go_a_live_processs_stay() {
        let ws = tree();
        // Pids above the kernel's maximum (2^22) never run.
        let dead_staging = ws.path().join("results/tree/.gen.staging-4194399");
        std::fs::create_dir_all(dead_staging.join("d")).unwrap();
        ws.write("results/tree/.gen.staging-4194399/a.txt", "half\n");
        ws.write("cache/tmp/obj-4194398-0123456789ab-0", "partial");
        ws.write("cache/tmp/stage-4194398-0123456789ab-1/x", "scratch");
        // Named by a process that runs (this test): kept.
        let live = format!("cache/tmp/obj-{}-cccccccccccc-0", std::process::id());
        ws.write(&live, "in use");
        assert!(ws.run(&[], 0).all("cached"));
        assert!(!dead_staging.exists());
        let left: Vec<String> = std::fs::read_dir(ws.path().join("cache/tmp"))
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        assert_eq!(left, [live.trim_start_matches("cache/tmp/")], "{left:?}");
    }
}

mod bounds {
    use super::*;

    /// Validate a synthesize or gsa stage with these params; returns the
    /// one problem's message.
    fn problem(kind: &str, params: &str, extra: &[&str]) -> String {
        let ws = util::study("quickstart", &[]);
        ws.write(
            "p.yaml",
            &format!("name: b\nstages:\n  s:\n    kind: {kind}\n    params: {params}\n"),
        );
        let mut args = vec!["validate", "p.yaml", "--json"];
        args.extend_from_slice(extra);
        let out = ws.cmd(&args);
        assert_eq!(out.status.code(), Some(2), "{}", text(&out.stderr));
        let v = json(&out);
        assert_eq!(v["problems"].as_array().unwrap().len(), 1, "{v}");
        v["problems"][0]["message"].as_str().unwrap().to_string()
    }

    const SYN: &str = "model: models/three_mass.yaml, frequency: {min: 0, max: 400, step: 0.25}";

    #[test]
    fn each_oversize_param_is_named_with_its_estimate_and_limit() {
        let m = problem(
            "synthesize",
            &format!("{{{SYN}, impact_test: {{block_size: 1048576, averages: 10000}}}}"),
            &[],
        );
        assert!(
            m.contains("`impact_test.averages`") && m.contains("limit"),
            "{m}"
        );
        let m = problem(
            "synthesize",
            &format!("{{{SYN}, impact_test: {{block_size: 1048576}}}}"),
            &["--max-memory", "64M"],
        );
        assert!(
            m.contains("`impact_test.block_size`")
                && m.contains("224.0 MiB")
                && m.contains("64.0 MiB"),
            "{m}"
        );
        // Within the bound with one mode and channel, over it with the
        // model's 3 modes and 3 sensors, once the model file is read.
        let m = problem(
            "synthesize",
            &format!("{{{SYN}, impact_test: {{block_size: 262144}}}}"),
            &["--max-memory", "64M"],
        );
        assert!(
            m.contains("`impact_test.block_size`") && m.contains("× 3 modes"),
            "{m}"
        );
        let m = problem(
            "gsa",
            "{model: models/three_mass.yaml, modes: 3, bands: {min: 0, max: 1e9, count: 10}}",
            &[],
        );
        assert!(
            m.contains("`bands`") && m.contains("2.000e9 frequency lines"),
            "{m}"
        );
        let m = problem(
            "gsa",
            "{model: models/three_mass.yaml, modes: 3, samples: 65536, bands: {min: 0, max: 100, count: 1000}}",
            &["--max-memory", "1G"],
        );
        assert!(m.contains("`samples`") && m.contains("1.0 GiB"), "{m}");
        let m = problem(
            "synthesize",
            &format!("{{{SYN}}}"),
            &["--max-memory", "100"],
        );
        assert!(m.contains("`model`") && m.contains("3 DOF"), "{m}");
        let m = problem(
            "synthesize",
            "{model: models/three_mass.yaml, frequency: {min: 0, max: 400, step: 0.001}}",
            &["--max-memory", "10M"],
        );
        assert!(
            m.contains("`frequency.step`") && m.contains("3 sensors"),
            "{m}"
        );
    }

    #[test]
    fn a_bad_max_memory_is_a_usage_error() {
        let ws = tree();
        let out = ws.cmd(&["status", "p.yaml", "--max-memory", "lots"]);
        assert_eq!(out.status.code(), Some(2));
    }
}

mod file_system {
    use super::*;

    #[test]
    fn a_full_disk_exits_3_naming_path_and_operation_once_and_leaves_nothing() {
        let ws = Workspace::new();
        ws.write(
            "p.yaml",
            "name: big\nstages:\n  big:\n    kind: command\n    params: {cmd: \"head -c 300000 /dev/zero > big.bin\", outs: [big.bin]}\n",
        );
        std::fs::create_dir(ws.path().join("cache")).unwrap();
        let script = "mount -t tmpfs -o size=128k tmpfs cache || exit 99; \
                      \"$B\" run p.yaml --progress none; echo \"rc=$?\"; ls -A cache/tmp";
        let Some(out) = in_namespace(&ws, script) else {
            return;
        };
        let (stdout, stderr) = (text(&out.stdout), text(&out.stderr));
        assert!(stdout.starts_with("rc=3\n"), "{stdout}\n{stderr}");
        assert!(
            stderr.contains("modalflow: cannot write ") && stderr.contains("/cache/tmp/"),
            "{stderr}"
        );
        assert_eq!(
            stderr.matches("No space left on device").count(),
            1,
            "{stderr}"
        );
        assert_eq!(stdout.trim_end(), "rc=3", "temp files left: {stdout}");
    }

    #[test]
    fn a_stage_whose_own_output_fills_the_disk_exits_3_too() {
        let ws = util::study("quickstart", &[]);
        ws.write(
            "p.yaml",
            "name: q\nstages:\n  truth:\n    kind: synthesize\n    params: {model: models/three_mass.yaml, frequency: {min: 0, max: 400, step: 0.25}}\n",
        );
        std::fs::create_dir(ws.path().join("cache")).unwrap();
        let script = "mount -t tmpfs -o size=16k tmpfs cache || exit 99; \
                      \"$B\" run p.yaml --progress none; echo \"rc=$?\"; ls -A cache/tmp";
        let Some(out) = in_namespace(&ws, script) else {
            return;
        };
        let (stdout, stderr) = (text(&out.stdout), text(&out.stderr));
        assert_eq!(stdout.trim_end(), "rc=3", "{stderr}");
        assert!(
            stderr.contains("stage truth: cannot write ") && stderr.contains("frf.uff"),
            "{stderr}"
        );
        assert_eq!(
            stderr.matches("No space left on device").count(),
            1,
            "{stderr}"
        );
    }

    #[test]
    fn a_read_only_complete_cache_serves_cached_runs_and_status() {
        let ws = tree();
        std::fs::remove_dir_all(ws.path().join("results")).unwrap();
        let script = "mount --bind cache cache && mount -o remount,bind,ro cache || exit 99; \
                      \"$B\" run p.yaml --progress none; echo \"run=$?\"; \
                      \"$B\" status p.yaml; echo \"status=$?\"; \
                      sed -i 's/echo hello/echo hullo/' p.yaml; \
                      \"$B\" run p.yaml --progress none; echo \"edited=$?\"";
        let Some(out) = in_namespace(&ws, script) else {
            return;
        };
        let (stdout, stderr) = (text(&out.stdout), text(&out.stderr));
        assert!(
            stdout.contains("0 ran, 2 cached") && stdout.contains("run=0"),
            "{stdout}\n{stderr}"
        );
        assert!(
            stdout.contains("status=0") && stdout.contains("cached    up"),
            "{stdout}"
        );
        assert!(stdout.contains("edited=3"), "{stdout}");
        assert!(
            stderr.contains("stage gen is not in the read-only cache")
                && stderr.contains("--cache"),
            "{stderr}"
        );
        assert_eq!(ws.read("results/tree/up/b.txt"), "HELLO\n");
    }

    #[test]
    fn a_read_only_results_directory_is_named_as_such() {
        let ws = tree();
        ws.write("results/tree/up/b.txt", "edited\n");
        let script =
            "mount --bind results results && mount -o remount,bind,ro results || exit 99; \
                      \"$B\" run p.yaml --progress none; echo \"rc=$?\"";
        let Some(out) = in_namespace(&ws, script) else {
            return;
        };
        let (stdout, stderr) = (text(&out.stdout), text(&out.stderr));
        assert!(stdout.contains("rc=3"), "{stdout}\n{stderr}");
        assert!(
            stderr.contains("modalflow: cannot create directory ")
                && stderr.contains("results/tree/.up.staging-"),
            "{stderr}"
        );
        assert!(!stderr.contains("cache create"), "{stderr}");
        assert_eq!(
            stderr.matches("Read-only file system").count(),
            1,
            "{stderr}"
        );
    }
}

mod records {
    use super::*;

    #[test]
    fn a_tampered_run_record_is_recomputed_as_corrupt() {
        let ws = tree();
        let key = ws.status().stage("up")["key"].as_str().unwrap().to_string();
        let path = format!("cache/runs/{key}.json");
        let mut rec: Value = ws.json(&path);
        assert_eq!(rec["key"], key.as_str());
        assert_eq!(rec["checksum"].as_str().map(str::len), Some(64));
        // Valid JSON pointing the output at another object of the cache.
        let gen_key = ws.status().stage("gen")["key"]
            .as_str()
            .unwrap()
            .to_string();
        let gen: Value = ws.json(&format!("cache/runs/{gen_key}.json"));
        rec["outputs"]["b.txt"]["hash"] = gen["outputs"]["a.txt"]["hash"].clone();
        rec["outputs"]["b.txt"]["bytes"] = gen["outputs"]["a.txt"]["bytes"].clone();
        ws.write(&path, &serde_json::to_string_pretty(&rec).unwrap());
        let status = ws.status();
        assert_eq!(status.status_of("up"), "will-run");
        let r = ws.run(&[], 0);
        assert_eq!(r.status_of("up"), "ran");
        let reason = r.stage("up")["reason"].as_str().unwrap();
        assert!(
            reason.contains("corrupt") && reason.contains("checksum"),
            "{reason}"
        );
        assert_eq!(ws.read("results/tree/up/b.txt"), "HELLO\n");
        assert!(ws.run(&[], 0).all("cached"));
    }
}

#[path = "../benchmarks/fuzz_targets.rs"]
mod fuzz_targets;

mod fuzz {
    use super::fuzz_targets::{mutate, seeds, targets, Rng};
    use std::path::Path;

    /// Every kept corpus entry and crasher of `benchmarks/fuzz.rs`, and a
    /// short seeded mutation burst from the seeds, parse without a panic.
    #[test]
    fn corpus_crashers_and_a_short_burst_parse_without_panics() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        modalflow::resources::set_memory_limit(256 << 20);
        for t in targets() {
            let mut inputs = seeds(root, &t);
            assert!(!inputs.is_empty(), "{}: no seeds", t.name);
            let ok = inputs.iter().filter(|i| (t.run)(i) == "ok").count();
            assert!(ok > 0, "{}: no seed parses", t.name);
            for dir in ["tests/fuzz/corpus", "tests/fuzz/crashers"] {
                let d = root.join(dir).join(t.name);
                for e in std::fs::read_dir(d).into_iter().flatten().flatten() {
                    inputs.push(std::fs::read(e.path()).unwrap());
                }
            }
            let mut rng = Rng(17);
            let seeds = inputs.len();
            for _ in 0..2000 {
                let (a, b) = (rng.below(seeds), rng.below(seeds));
                let m = mutate(&mut rng, &inputs[a], &inputs[b]);
                inputs.push(m);
            }
            for (i, input) in inputs.iter().enumerate() {
                let r = std::panic::catch_unwind(|| (t.run)(input));
                assert!(
                    r.is_ok(),
                    "{}: input {i} panics:\n{}",
                    t.name,
                    String::from_utf8_lossy(&input[..input.len().min(2000)])
                );
            }
        }
        super::fuzz_targets::cleanup();
    }
}
