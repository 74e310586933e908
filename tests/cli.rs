//! The command line a pipeline user expects (issue 15): `--json` always one
//! object, exit codes as documented, common flags accepted, and
//! `run FILE [STAGE]...` running only the upstream closure.

use crate::util;

use serde_json::Value;
use util::{Workspace, DIAMOND};

fn diamond() -> Workspace {
    let ws = Workspace::new();
    ws.write("p.yaml", DIAMOND);
    ws
}

mod json_problems {
    use super::*;

    /// An invalid file under `--json`: one object on stdout with every
    /// problem located, whatever the command.
    #[test]
    fn invalid_file_gives_one_object_with_every_problem() {
        let ws = Workspace::new();
        ws.write(
            "p.yaml",
            "name: x\nstages:\n  a:\n    kind: command\n    params: {cmd: 'true', out: [a.txt]}\n  b:\n    kind: comand\n",
        );
        for cmd in [
            &["validate", "p.yaml", "--json"][..],
            &["status", "p.yaml", "--json"],
            &["run", "p.yaml", "--json", "--progress", "none"],
        ] {
            let out = ws.cmd(cmd);
            assert_eq!(out.status.code(), Some(2), "{cmd:?}");
            let v: Value = serde_json::from_slice(&out.stdout)
                .unwrap_or_else(|e| panic!("{cmd:?}: {e}: {}", util::text(&out.stdout)));
            assert_eq!(v["exit_code"], 2);
            let problems = v["problems"].as_array().unwrap();
            assert_eq!(problems.len(), 2, "{v}");
            assert_eq!(problems[0]["file"], "p.yaml");
            assert_eq!(
                (problems[0]["line"].as_u64(), problems[0]["column"].as_u64()),
                (Some(5), Some(27))
            );
            assert!(problems[0]["message"]
                .as_str()
                .unwrap()
                .contains("unknown param `out`"));
            assert!(problems[0]["help"]
                .as_str()
                .unwrap()
                .contains("did you mean `outs`?"));
            assert!(problems[1]["message"]
                .as_str()
                .unwrap()
                .contains("unknown stage kind `comand`"));
            // The human text still goes to stderr.
            assert!(util::text(&out.stderr).starts_with("modalflow: 2 problems"));
        }
    }

    /// Other errors under `--json` are one object too, with no problems.
    #[test]
    fn other_errors_give_an_object_without_problems() {
        let ws = diamond();
        let out = ws.cmd(&["run", "p.yaml", "nosuch", "--json"]);
        assert_eq!(out.status.code(), Some(2));
        let v: Value = serde_json::from_slice(&out.stdout).unwrap();
        assert!(v["error"].as_str().unwrap().contains("no stage `nosuch`"));
        assert_eq!(v["problems"].as_array().map(Vec::len), Some(0));
    }
}

mod exit_codes_and_flags {
    use super::*;

    #[test]
    fn show_with_an_unknown_stage_exits_2() {
        let ws = diamond();
        let out = ws.cmd(&["show", "p.yaml", "nosuch"]);
        assert_eq!(out.status.code(), Some(2));
        assert!(util::text(&out.stderr).contains("no stage `nosuch`"));
    }

    #[test]
    fn validate_takes_the_common_location_flags() {
        let ws = diamond();
        let out = ws.cmd(&[
            "validate",
            "p.yaml",
            "--cache",
            "elsewhere",
            "--results",
            "out",
        ]);
        assert_eq!(out.status.code(), Some(0), "{}", util::text(&out.stderr));
        assert!(
            !ws.path().join("elsewhere").exists(),
            "validate writes no cache"
        );
    }
}

mod run_targets {
    use super::*;

    fn ran(report: &util::Report) -> Vec<String> {
        report.statuses().into_iter().map(|(n, _)| n).collect()
    }

    /// `run FILE left` runs `left` and its upstream closure, nothing else;
    /// the rest stays for a later run, which reuses what ran.
    #[test]
    fn only_the_upstream_closure_runs() {
        let ws = diamond();
        let r = ws.run(&["left"], 0);
        assert_eq!(ran(&r), ["gen", "up", "left"]);
        assert!(r.all("ran"));
        for (stage, n) in [
            ("gen", 1),
            ("up", 1),
            ("left", 1),
            ("right", 0),
            ("join", 0),
            ("solo", 0),
        ] {
            assert_eq!(ws.executions(stage), n, "{stage}");
        }
        let r = ws.run(&[], 0);
        assert_eq!(r.status_of("left"), "cached");
        assert_eq!(r.status_of("right"), "ran");
        assert_eq!(ws.executions("gen"), 1);
    }

    /// Several targets, and `--dry-run` limited the same way.
    #[test]
    fn several_targets_and_dry_run() {
        let ws = diamond();
        let r = ws.run(&["solo", "right", "--dry-run"], 0);
        assert_eq!(ran(&r), ["gen", "up", "right", "solo"]);
        assert!(r.all("will-run"));
        assert_eq!(ws.executions("gen"), 0);
    }

    /// A matrix stage by its base name runs every expansion; one expansion
    /// runs alone.
    #[test]
    fn matrix_stage_by_base_name_or_expansion() {
        let ws = Workspace::new();
        ws.write(
            "p.yaml",
            "name: m\nstages:\n  a:\n    kind: command\n    matrix: {n: [1, 2]}\n    params: {cmd: 'echo a >> executions.log; echo ${matrix.n} > o${matrix.n}.txt', outs: ['o${matrix.n}.txt']}\n  b:\n    kind: command\n    params: {cmd: 'echo b >> executions.log', deps: []}\n",
        );
        let r = ws.run(&["a[n=2]"], 0);
        assert_eq!(ran(&r), ["a[n=2]"]);
        let r = ws.run(&["a"], 0);
        assert_eq!(ran(&r), ["a[n=1]", "a[n=2]"]);
        assert_eq!(r.status_of("a[n=2]"), "cached");
        assert_eq!(ws.executions("b"), 0);
    }

    #[test]
    fn unknown_target_exits_2_and_runs_nothing() {
        let ws = diamond();
        let out = ws.cmd(&["run", "p.yaml", "lft"]);
        assert_eq!(out.status.code(), Some(2));
        assert!(util::text(&out.stderr).contains("no stage `lft` to run"));
        assert_eq!(ws.executions("gen"), 0);
    }
}

mod overrides_identity_completions {
    use super::*;
    use util::text;

    const PIPE: &str = "name: same\nstages:\n  a: {kind: command, params: {cmd: \"echo $MODALFLOW_STAGE > a.txt\", outs: [a.txt]}}\n  b: {kind: command, params: {cmd: \"cat a.txt > b.txt\", deps: [a.txt], outs: [b.txt]}}\n";

    #[test]
    fn set_enters_the_key_the_manifest_and_status() {
        let ws = Workspace::new();
        ws.write("p.yaml", PIPE);
        assert!(ws.run(&[], 0).all("ran"));
        let edit = "a.cmd=echo edited > a.txt";
        let out = ws.cmd(&["status", "p.yaml", "--json", "--set", edit]);
        let s: Value = serde_json::from_slice(&out.stdout).expect("json");
        let a = &s["stages"][0];
        assert_eq!(a["status"], "will-run");
        let reason = a["reason"].as_str().unwrap_or("");
        assert!(reason.starts_with("param cmd changed"), "{reason}");
        assert_eq!(s["stages"][1]["reason"], "upstream a will run");
        let r = ws.run(&["--set", edit], 0);
        assert_eq!(r.status_of("a"), "ran");
        assert_eq!(ws.read("a.txt"), "edited\n");
        // The override's results go to a folder of their own (issue 29).
        let set_dir = std::fs::read_dir(ws.path().join("results"))
            .expect("results")
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .find(|n| n.starts_with("same--set-"))
            .expect("a results folder for the --set run");
        let manifest = ws.read(&format!("results/{set_dir}/a/manifest.json"));
        assert!(manifest.contains("echo edited > a.txt"), "{manifest}");
        assert!(!ws.read("results/same/a/manifest.json").contains("edited"));
        // Without the override the file's value is back, and cached; so is
        // the override's result.
        assert_eq!(ws.run(&[], 0).status_of("a"), "cached");
        assert_eq!(ws.read("a.txt"), "a\n");
        assert_eq!(ws.run(&["--set", edit], 0).status_of("a"), "cached");
        // A value is YAML; an unknown stage or a bad value is exit 2.
        let bad = ws.cmd(&["validate", "p.yaml", "--set", "c.cmd=x"]);
        assert_eq!(bad.status.code(), Some(2));
        assert!(
            text(&bad.stderr).contains("--set c.cmd=x: no stage `c`"),
            "{}",
            text(&bad.stderr)
        );
        let bad = ws.cmd(&["validate", "p.yaml", "--set", "a.outs=7"]);
        assert_eq!(bad.status.code(), Some(2), "{}", text(&bad.stderr));
        let ok = ws.cmd(&["validate", "p.yaml", "--set", "b.deps=[a.txt]"]);
        assert_eq!(ok.status.code(), Some(0), "{}", text(&ok.stderr));
    }

    #[test]
    fn two_files_with_one_name_are_refused_and_stale_stages_leave_results() {
        let ws = Workspace::new();
        ws.write("p.yaml", PIPE);
        ws.write("q.yaml", PIPE);
        assert!(ws.run(&[], 0).all("ran"));
        let out = ws.cmd(&["run", "q.yaml"]);
        assert_eq!(out.status.code(), Some(2));
        let err = text(&out.stderr);
        assert!(
            err.contains("pipeline name `same` belongs to") && err.contains("p.yaml"),
            "{err}"
        );
        assert_eq!(ws.cmd(&["status", "q.yaml"]).status.code(), Some(2));
        // The owner moved away: the other file takes the name over.
        std::fs::remove_file(ws.path().join("p.yaml")).expect("remove");
        assert_eq!(ws.cmd(&["run", "q.yaml"]).status.code(), Some(0));
        // A stage removed from the file leaves results/<name>/ too.
        ws.write("q.yaml", &PIPE.replace("  b: {kind: command, params: {cmd: \"cat a.txt > b.txt\", deps: [a.txt], outs: [b.txt]}}\n", ""));
        assert!(ws.path().join("results/same/b/manifest.json").exists());
        assert_eq!(ws.cmd(&["run", "q.yaml"]).status.code(), Some(0));
        assert!(!ws.path().join("results/same/b").exists());
        assert!(ws.path().join("results/same/a/manifest.json").exists());
        assert!(ws.path().join("results/same/trace.csv").exists());
    }

    #[test]
    fn completions_for_three_shells() {
        let ws = Workspace::new();
        for (shell, marker) in [
            ("bash", "complete -F"),
            ("zsh", "#compdef modalflow"),
            ("fish", "complete -c modalflow"),
        ] {
            let out = ws.cmd(&["completions", shell]);
            assert_eq!(out.status.code(), Some(0));
            let script = text(&out.stdout);
            assert!(script.contains(marker), "{shell}: {script}");
            assert!(
                script.contains("set") && script.contains("detach"),
                "{shell}"
            );
        }
        assert_eq!(ws.cmd(&["completions", "tcsh"]).status.code(), Some(2));
    }

    #[test]
    fn progress_lines_beat_for_every_running_stage_with_its_counters() {
        let ws = Workspace::new();
        ws.write(
            "p.yaml",
            "name: beat\nstages:\n  slow: {kind: command, params: {cmd: \"sleep 2; echo > s.txt\", outs: [s.txt]}}\n  sens: {kind: gsa, params: {model: {builtin: ishigami}, samples: 65536, bootstrap: 3000}}\n",
        );
        let out = ws
            .command(&["run", "p.yaml", "--progress", "lines"])
            .env("MODALFLOW_HEARTBEAT", "0.3")
            .output()
            .expect("run");
        assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
        let err = text(&out.stderr);
        let beats = err
            .lines()
            .filter(|l| l.starts_with("  running slow ("))
            .count();
        assert!(beats >= 3, "{err}");
        // The GSA's beat carries its counters; on a fast machine it may
        // finish before a beat is due, so demand one only when it ran for
        // several heartbeat periods (its own "ran" line says how long).
        let sens_seconds = err
            .lines()
            .find_map(|l| l.strip_prefix("  ran     sens ("))
            .and_then(|rest| rest.split(' ').next())
            .and_then(|secs| secs.parse::<f64>().ok())
            .expect("a ran line for sens");
        if sens_seconds > 1.0 {
            assert!(
                err.lines()
                    .any(|l| l.starts_with("  running sens (") && l.contains('/')),
                "{err}"
            );
        }
    }

    #[test]
    fn dag_takes_json_like_every_other_command() {
        let ws = diamond();
        let out = ws.cmd(&["dag", "p.yaml", "--json"]);
        assert_eq!(out.status.code(), Some(0));
        let d: Value = serde_json::from_slice(&out.stdout).expect("json");
        let names: Vec<&str> = d["stages"]
            .as_array()
            .map(|s| s.iter().filter_map(|x| x["name"].as_str()).collect())
            .unwrap_or_default();
        assert!(names.contains(&"gen") && names.contains(&"up"), "{d}");
        let edges = d["edges"].as_array().cloned().unwrap_or_default();
        assert!(edges.iter().any(|e| e[0] == "gen" && e[1] == "up"), "{d}");
    }
}
