//! The command line a pipeline user expects (issue 15): `--json` always one
//! object, exit codes as documented, common flags accepted, and
//! `run FILE [STAGE]...` running only the upstream closure.

mod util;

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
