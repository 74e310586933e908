//! The Slurm executor end to end, with the stand-ins in `tests/slurm/fake/`
//! on PATH in place of sbatch, sacct, squeue and scancel: every stage goes
//! through a job description in the cache, a batch script, and
//! `modalflow exec` in a separate process; a GSA's design is sharded over a
//! four-task job array and merged. Results must be bit-identical to a local
//! run; failures, timeouts, interrupts and resumption behave as locally.

use crate::util;

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};
use util::slurm::{command, outputs, run, submissions, tasks};
use util::{text, Workspace};

const STUDY: &str = r#"name: cluster
seed: 11
executor:
  kind: slurm
  poll: 0.5
  kinds:
    gsa: {shards: 4}
stages:
  prep:
    kind: command
    params: {cmd: "echo 3 > n.txt", outs: [n.txt]}
  sens:
    kind: gsa
    params: {model: {builtin: ishigami}, samples: 256, bootstrap: 20}
  sums:
    kind: command
    inputs: {indices: sens.indices}
    params: {cmd: "wc -l < $MODALFLOW_INPUT_INDICES > lines.txt; cat n.txt >> lines.txt", deps: [n.txt], outs: [lines.txt]}
"#;

fn local_reference() -> Workspace {
    let ws = Workspace::new();
    ws.write("p.yaml", STUDY);
    let r = ws.run(&["--executor", "local"], 0);
    assert!(r.all("ran"), "{:?}", r.statuses());
    ws
}

#[test]
fn sharded_study_through_job_scripts_is_bit_identical_to_a_local_run() {
    let local = local_reference();
    let ws = Workspace::new();
    ws.write("p.yaml", STUDY);
    let r = run(&ws, &[], &[], 0);
    assert!(r.all("ran"), "{:?}", r.statuses());
    for stage in ["sens", "sums", "prep"] {
        assert_eq!(outputs(&ws, stage), outputs(&local, stage), "{stage}");
    }
    assert_eq!(ws.read("lines.txt"), local.read("lines.txt"));
    // prep and sens are independent, so their submissions may interleave.
    let subs = submissions(&ws);
    let mut scripts: Vec<&str> = subs
        .iter()
        .map(|(_, s)| s.rsplit('/').next().unwrap_or_default())
        .collect();
    scripts.sort();
    assert_eq!(scripts, ["job.sh", "job.sh", "merge.sh", "shards.sh"]);
    let array = subs
        .iter()
        .find(|(_, s)| s.ends_with("shards.sh"))
        .map(|(id, _)| id.clone());
    assert_eq!(tasks(&ws, &array.unwrap_or_default()), [0, 1, 2, 3]);
    // The GSA's record counts the whole design, as locally.
    assert_eq!(r.stage("sens")["counters"]["evaluations"], 256 * 5);
    // Job directories go once their stage is committed.
    let jobs = std::fs::read_dir(ws.path().join("cache/jobs")).map_or(0, |d| d.count());
    assert_eq!(jobs, 0);
    // Everything is cached now, whichever executor asks.
    let again = run(&ws, &[], &[], 0);
    assert!(again.all("cached"), "{:?}", again.statuses());
    assert!(ws.run(&["--executor", "local"], 0).all("cached"));
    assert_eq!(submissions(&ws).len(), 4);
}

const FAILING: &str = r#"name: cluster
executor: {kind: slurm, poll: 0.5}
stages:
  bad:
    kind: command
    params: {cmd: "echo oops-from-the-job; exit 3", outs: [bad.txt]}
  slow:
    kind: command
    params: {cmd: "sleep 30; echo late > slow.txt", outs: [slow.txt]}
  good:
    kind: command
    params: {cmd: "echo fine > good.txt", outs: [good.txt]}
"#;

#[test]
fn failed_and_timed_out_jobs_fail_their_stage_with_the_job_and_its_log() {
    let ws = Workspace::new();
    ws.write("p.yaml", FAILING);
    let r = run(&ws, &["--keep-going"], &[("FAKE_SLURM_TIMEOUT", "3")], 1);
    assert_eq!(r.status_of("good"), "ran");
    assert_eq!(ws.read("good.txt"), "fine\n");
    let bad = r.stage("bad")["error"]
        .as_str()
        .unwrap_or_default()
        .to_string();
    assert_eq!(r.status_of("bad"), "failed");
    assert!(bad.starts_with("slurm job "), "{bad}");
    assert!(bad.contains("FAILED (exit 1:0)"), "{bad}");
    assert!(bad.contains("oops-from-the-job"), "log tail: {bad}");
    let slow = r.stage("slow")["error"]
        .as_str()
        .unwrap_or_default()
        .to_string();
    assert!(
        slow.contains("TIMEOUT") && slow.contains("raise `time`"),
        "{slow}"
    );
    // Nothing of the failed stages entered the cache; their logs stay.
    assert_eq!(ws.runs_in_cache(), 1);
    let kept = std::fs::read_dir(ws.path().join("cache/jobs")).map_or(0, |d| d.count());
    assert_eq!(kept, 2);
    // Without --keep-going the run stops after the first failure.
    let stop = run(&ws, &[], &[("FAKE_SLURM_TIMEOUT", "3")], 1);
    assert_eq!(stop.status_of("good"), "cached");
    assert_eq!(stop.status_of("bad"), "failed");
    // Fixed, the stage runs; gc clears the failed jobs' directories.
    ws.write(
        "p.yaml",
        &FAILING
            .replace("exit 3", "echo ok > bad.txt")
            .replace("sleep 30; ", ""),
    );
    assert!(run(&ws, &[], &[], 0)
        .statuses()
        .iter()
        .all(|(_, s)| s != "failed"));
    let gc = ws.cmd(&["gc"]);
    assert_eq!(gc.status.code(), Some(0), "{}", text(&gc.stderr));
    assert!(!ws
        .path()
        .join("cache/jobs")
        .read_dir()
        .is_ok_and(|mut d| d.next().is_some()));
}

#[test]
fn failed_shards_are_resumed_and_the_result_matches_a_local_run() {
    let local = local_reference();
    let ws = Workspace::new();
    ws.write("p.yaml", STUDY);
    let r = run(&ws, &[], &[("FAKE_SLURM_FAIL_TASK", "2")], 1);
    let error = r.stage("sens")["error"]
        .as_str()
        .unwrap_or_default()
        .to_string();
    assert!(error.contains("_2 FAILED"), "{error}");
    assert!(error.contains("task 2 fails on purpose"), "{error}");
    assert_eq!(r.status_of("sums"), "skipped");
    let key = r.stage("sens")["key"]
        .as_str()
        .unwrap_or_default()
        .to_string();
    let shards = ws.path().join("cache/jobs").join(&key).join("shards");
    let mut done: Vec<String> = std::fs::read_dir(&shards)
        .expect("shard records")
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    done.sort();
    assert_eq!(done, ["4-0.json", "4-1.json", "4-3.json"]);

    // A cluster without accounting: states come from squeue.
    let again = run(&ws, &[], &[("FAKE_SLURM_NO_SACCT", "1")], 0);
    assert_eq!(again.status_of("prep"), "cached");
    assert_eq!(again.status_of("sens"), "ran");
    let subs = submissions(&ws);
    let resumed = &subs[subs.len() - 3];
    assert!(resumed.1.ends_with("shards.sh"), "{subs:?}");
    assert_eq!(tasks(&ws, &resumed.0), [2], "only the failed shard reruns");
    for stage in ["sens", "sums"] {
        assert_eq!(outputs(&ws, stage), outputs(&local, stage), "{stage}");
    }
}

#[test]
fn an_interrupted_run_cancels_its_jobs() {
    let ws = Workspace::new();
    ws.write(
        "p.yaml",
        "name: cluster\nexecutor: {kind: slurm, poll: 0.5}\nstages:\n  long:\n    kind: command\n    params: {cmd: \"sleep 60 > /dev/null\", outs: [x.txt]}\n",
    );
    let mut child = command(&ws, &[], &[]).spawn().expect("spawn run");
    let start = Instant::now();
    // The stand-in scheduler writes the job's state before its task's pid:
    // wait for both (a busy machine shows the gap).
    let running = |ws: &Workspace| -> Option<(String, String)> {
        let (id, _) = submissions(ws).into_iter().next()?;
        let state = std::fs::read_to_string(ws.path().join(format!("fake/{id}.state"))).ok()?;
        let pid = std::fs::read_to_string(ws.path().join(format!("fake/{id}.pid"))).ok()?;
        let pid = pid.trim().to_string();
        (state.starts_with("RUNNING") && !pid.is_empty()).then_some((id, pid))
    };
    let (id, pid) = loop {
        if let Some(running) = running(&ws) {
            break running;
        }
        assert!(start.elapsed() < Duration::from_secs(20), "job never ran");
        std::thread::sleep(Duration::from_millis(50));
    };
    let kill = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .expect("kill");
    assert!(kill.success());
    let status = child.wait().expect("wait");
    assert_eq!(status.code(), Some(130));
    let cancelled = std::fs::read_to_string(ws.path().join("fake/scancel.log")).unwrap_or_default();
    assert_eq!(cancelled.trim(), id);
    let state =
        std::fs::read_to_string(ws.path().join(format!("fake/{id}.state"))).unwrap_or_default();
    assert!(state.starts_with("CANCELLED"), "{state}");
    // The job's process group is gone (give the kill a moment to land).
    let gone = (0..50).any(|_| {
        std::thread::sleep(Duration::from_millis(100));
        !Command::new("kill")
            .args(["-0", &pid])
            .status()
            .is_ok_and(|s| s.success())
    });
    assert!(gone, "task {pid} still running");
    assert_eq!(ws.runs_in_cache(), 0);
}

#[test]
fn exec_runs_a_description_without_the_pipeline_and_refuses_a_stale_one() {
    let ws = Workspace::new();
    ws.write("in.txt", "input\n");
    ws.write(
        "p.yaml",
        "name: cluster\nexecutor: {kind: slurm, poll: 0.5}\nstages:\n  s:\n    kind: command\n    params: {cmd: \"cat in.txt > out.txt; test -f go\", deps: [in.txt], outs: [out.txt]}\n",
    );
    let r = run(&ws, &[], &[], 1);
    let key = r.stage("s")["key"].as_str().unwrap_or_default().to_string();
    let job = format!("cache/jobs/{key}/job.json");
    std::fs::remove_file(ws.path().join("p.yaml")).expect("remove pipeline");
    let exec = |args: &[&str]| {
        let mut all = vec!["exec", job.as_str()];
        all.extend_from_slice(args);
        let out = ws.cmd(&all);
        (out.status.code(), text(&out.stderr))
    };
    let (code, err) = exec(&["--shard", "0"]);
    assert_eq!(code, Some(1));
    assert!(err.contains("shard 0 does not exist"), "{err}");
    // A file the key hashed changed since submission: refused.
    ws.write("in.txt", "edited\n");
    let (code, err) = exec(&[]);
    assert_eq!(code, Some(1));
    assert!(err.contains("`in.txt` differs on this host"), "{err}");
    ws.write("in.txt", "input\n");
    // The stage's own failure, as in the job's log.
    let (code, err) = exec(&[]);
    assert_eq!(code, Some(1));
    assert!(err.contains("stage failed"), "{err}");
    // Fixed in the workspace, the same description commits the result.
    ws.write("go", "");
    let (code, err) = exec(&[]);
    assert_eq!(code, Some(0), "{err}");
    assert!(ws.path().join(format!("cache/runs/{key}.json")).exists());
    let (code, err) = exec(&[]);
    assert_eq!(code, Some(0));
    assert!(err.contains("already in the cache"), "{err}");
    // An edited description no longer matches its key.
    let edited = ws.read(&job).replace("test -f go", "true");
    ws.write(&job, &edited);
    std::fs::remove_file(ws.path().join(format!("cache/runs/{key}.json"))).expect("remove record");
    let (code, err) = exec(&[]);
    assert_eq!(code, Some(1));
    assert!(err.contains("does not match its key"), "{err}");
}

#[test]
fn executor_block_problems_are_located() {
    let ws = Workspace::new();
    ws.write(
        "p.yaml",
        "name: v\nexecutor:\n  kind: slurm\n  time: one hour\n  kinds:\n    gsx: {cpus: 2}\nstages:\n  a: {kind: command, params: {cmd: \"true\", outs: [a.txt]}}\n",
    );
    let err = text(&ws.cmd(&["validate", "p.yaml"]).stderr);
    assert!(err.contains("2 problems"), "{err}");
    assert!(
        err.contains("p.yaml:4:9") && err.contains("not a Slurm time limit"),
        "{err}"
    );
    assert!(
        err.contains("p.yaml:6:5") && err.contains("did you mean `gsa`?"),
        "{err}"
    );
    ws.write("p.yaml", "name: v\nexecutor: {kind: pbs}\nstages:\n  a: {kind: command, params: {cmd: \"true\", outs: [a.txt]}}\n");
    let out = ws.cmd(&["validate", "p.yaml"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        text(&out.stderr).contains("unknown variant `pbs`"),
        "{}",
        text(&out.stderr)
    );
    ws.write("p.yaml", "name: v\nexecutor: {kinds: {command: {shards: 2}}}\nstages:\n  a: {kind: command, params: {cmd: \"true\", outs: [a.txt]}}\n");
    let err = text(&ws.cmd(&["validate", "p.yaml"]).stderr);
    assert!(
        err.contains("p.yaml:2:38")
            && err.contains("no `command` stage of this pipeline can be sharded"),
        "{err}"
    );
    // The cluster check's study validates.
    let study = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/slurm/gsa_study.yaml");
    let out = ws.cmd(&["validate", &study.to_string_lossy()]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
}

#[test]
fn a_structural_gsa_sharded_three_ways_is_bit_identical_to_a_local_run() {
    // Reference modes from synthesize, Sobol indices of a model file with FRF
    // bands: the shards' slices are uneven (64·5 = 320 points in 3), the merge
    // exact; the split's validation (30 + 1 evaluations) runs in the merge job.
    let study = r#"name: cluster
executor: {poll: 0.5, kinds: {gsa: {shards: 3}, synthesize: {local: true}}}
stages:
  truth:
    kind: synthesize
    params: {model: models/two_mass.yaml, frequency: {min: 0, max: 400, step: 1}}
  sens:
    kind: gsa
    inputs: {reference: truth.modes}
    params: {model: models/two_mass.yaml, samples: 64, bootstrap: 10, window: 0.5, bands: [[50, 150], [150, 350]], validation: 30}
"#;
    let model = include_str!("fixtures/models/two_mass.yaml");
    let local = Workspace::new();
    let ws = Workspace::new();
    for w in [&local, &ws] {
        w.write("p.yaml", study);
        w.write("models/two_mass.yaml", model);
    }
    assert!(local.run(&[], 0).all("ran"));
    let r = run(&ws, &["--executor", "slurm"], &[], 0);
    assert!(r.all("ran"), "{:?}", r.statuses());
    assert_eq!(r.stage("sens")["counters"]["evaluations"], 64 * 5 + 31);
    for stage in ["truth", "sens"] {
        assert_eq!(outputs(&ws, stage), outputs(&local, stage), "{stage}");
    }
    let array = submissions(&ws)
        .into_iter()
        .find(|(_, s)| s.ends_with("shards.sh"))
        .map(|(id, _)| id)
        .unwrap_or_default();
    assert_eq!(tasks(&ws, &array), [0, 1, 2]);
    // synthesize ran on the submitting machine: only the array and the merge queued.
    assert_eq!(submissions(&ws).len(), 2);
}

/// Files named `decoy*` anywhere below `dir`.
fn decoys(dir: &Path) -> Vec<String> {
    let mut found = Vec::new();
    for entry in std::fs::read_dir(dir).into_iter().flatten().flatten() {
        let path = entry.path();
        if entry.file_name().to_string_lossy().starts_with("decoy") {
            found.push(path.display().to_string());
        }
        if path.is_dir() {
            found.extend(decoys(&path));
        }
    }
    found
}

#[test]
fn matrix_values_with_shell_syntax_reach_no_shell() {
    // Matrix values become stage names, which enter the job name and the
    // script's comment line: an array of four expansions and a job alone.
    // Values with control characters or separators are refused at
    // validation (tests/path_safety.rs); these reach the scripts.
    // (The command reads its value as a quoted here-document: distinct
    // params, so distinct keys, and the stage itself runs nothing.)
    let ws = Workspace::new();
    ws.write(
        "p.yaml",
        r#"name: cluster
executor: {kind: slurm, poll: 0.5}
stages:
  s:
    kind: command
    matrix: {v: ["x; touch decoy1", "$(touch decoy2)", "`touch decoy3`; touch decoy4 #", "it's \"q\" ${HOME} && touch decoy5"]}
    params:
      cmd: |
        cat > /dev/null <<'END_OF_VALUE'
        ${matrix.v}
        END_OF_VALUE
  t:
    kind: command
    matrix: {v: ["y | touch decoy6"]}
    params: {cmd: "true"}
"#,
    );
    let r = run(&ws, &[], &[], 0);
    assert!(r.all("ran"), "{:?}", r.statuses());
    assert_eq!(decoys(ws.path()), Vec::<String>::new());
    let subs = submissions(&ws);
    assert_eq!(subs.len(), 2, "{subs:?}");
    for (id, _) in subs {
        // The stand-in keeps a copy of each script it ran.
        let copy = ws.path().join(format!("fake/{id}.sh"));
        let script = std::fs::read_to_string(&copy).expect("script copy");
        let parse = Command::new("sh")
            .arg("-n")
            .arg(&copy)
            .status()
            .expect("sh -n");
        assert!(parse.success(), "{script}");
        let comments = script
            .lines()
            .filter(|l| l.starts_with("# modalflow "))
            .count();
        assert_eq!(comments, 1, "{script}");
        // Only the script's own lines reach the shell.
        let shell: Vec<&str> = script
            .lines()
            .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
            .collect();
        assert!(
            shell.iter().all(|l| !l.contains("touch")),
            "{shell:#?}\n{script}"
        );
    }
}

#[test]
fn executor_values_that_would_inject_are_refused_at_validate_and_run() {
    let ws = Workspace::new();
    let decoy = ws.path().join("decoy");
    let decoy = decoy.display();
    ws.write(
        "p.yaml",
        &format!(
            r#"name: v
executor:
  kind: slurm
  sbatch: ["--qos=short", "--qos=x\ntouch {decoy}", "touch {decoy}"]
  scratch: "$(touch {decoy})"
  kinds:
    command: {{partition: "p\ntouch {decoy}", scratch: "`touch {decoy}`"}}
  stages:
    a: {{account: "acct\r\ntouch {decoy}", time: "10\ntouch {decoy}", memory: "4G\n* attempt"}}
stages:
  a: {{kind: command, params: {{cmd: "true", outs: [a.txt]}}}}
"#
        ),
    );
    let out = ws.cmd(&["validate", "p.yaml"]);
    let err = text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("8 problems"), "{err}");
    // Each problem: its message, then its location.
    let blocks: Vec<&str> = err.split("\n[").collect();
    for (at, what) in [
        ("p.yaml:4:27", "`sbatch` contains a control character (\\n)"),
        ("p.yaml:4:67", "`sbatch` entry `touch "),
        ("p.yaml:5:12", "`scratch: $(touch "),
        (
            "p.yaml:7:26",
            "`partition` contains a control character (\\n)",
        ),
        (
            "p.yaml:7:69",
            "backticks (command substitution) are not allowed",
        ),
        (
            "p.yaml:9:18",
            "`account` contains a control character (\\r)",
        ),
        ("p.yaml:9:63", "`time` contains a control character (\\n)"),
        (
            "p.yaml:9:106",
            "`memory` contains a control character (\\n)",
        ),
    ] {
        assert!(
            blocks.iter().any(|b| b.contains(at) && b.contains(what)),
            "{at} {what} in\n{err}"
        );
    }
    assert!(err.contains("`$NAME` or `${NAME}`"), "{err}");
    assert!(err.contains("not an sbatch option"), "{err}");
    // `run` refuses the same file before anything is submitted.
    let out = command(&ws, &[], &[]).output().expect("run modalflow");
    assert_eq!(out.status.code(), Some(2), "{}", text(&out.stderr));
    assert!(submissions(&ws).is_empty());
    assert_eq!(decoys(ws.path()), Vec::<String>::new());
    // Variables alone are what `scratch` may expand.
    ws.write(
        "p.yaml",
        "name: v\nexecutor: {kind: slurm, scratch: \"$TMPDIR/${USER}_mf\", sbatch: [\"--comment=it's #1\", \"-J x\"]}\nstages:\n  a: {kind: command, params: {cmd: \"true\", outs: [a.txt]}}\n",
    );
    let out = ws.cmd(&["validate", "p.yaml"]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
}
