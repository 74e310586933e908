//! The Slurm executor at cluster scale, with the stand-ins of
//! `tests/slurm/fake/` (which log every scheduler call): one status query
//! per poll interval for all jobs, adoption of a killed submitter's jobs,
//! retries with attempt-scaled resources, array throttles, matrix arrays and
//! group jobs in the generated `sbatch` lines, the run's trace, validation
//! of `binary` and per-stage overrides, node-local scratch.

use crate::util;

use serde_json::Value;
use std::time::{Duration, Instant};
use util::slurm::{calls, command, run, sbatch_lines, submissions};
use util::{text, Workspace};

/// The trace of the last run.
fn trace(ws: &Workspace, pipeline: &str) -> Vec<Value> {
    let t: Value = ws.json(&format!("results/{pipeline}/trace.json"));
    t.as_array().cloned().unwrap_or_default()
}

fn rows_of<'a>(trace: &'a [Value], stage: &str) -> Vec<&'a Value> {
    trace.iter().filter(|r| r["stage"] == stage).collect()
}

/// Status calls (not the trace's accounting call at the end).
fn status_calls(ws: &Workspace) -> Vec<String> {
    calls(ws)
        .into_iter()
        .filter(|(c, a)| {
            (c == "sacct" || c == "squeue") && !a.contains("NodeList") && !a.contains("%N")
        })
        .map(|(_, a)| a)
        .collect()
}

#[test]
fn one_status_query_per_interval_serves_every_job() {
    let ws = Workspace::new();
    let mut p = String::from("name: many\nexecutor: {kind: slurm, poll: 0.5}\nstages:\n");
    for i in 0..12 {
        p.push_str(&format!(
            "  s{i}: {{kind: command, params: {{cmd: \"sleep 2; echo {i} > o{i}.txt\", outs: [o{i}.txt]}}}}\n"
        ));
    }
    ws.write("p.yaml", &p);
    let start = Instant::now();
    let r = run(&ws, &["--jobs", "12"], &[], 0);
    let wall = start.elapsed().as_secs_f64();
    assert!(r.all("ran"), "{:?}", r.statuses());
    let queries = status_calls(&ws);
    // At most one query per 0.5 s interval, however many jobs (12 here).
    let bound = (wall / 0.5).ceil() as usize + 1;
    assert!(
        queries.len() <= bound,
        "{} status calls in {wall:.1} s: {queries:?}",
        queries.len()
    );
    assert!(!queries.is_empty());
    // Each query asks for every job in flight at once.
    let widest = queries
        .iter()
        .map(|a| a.split_whitespace().last().unwrap_or("").split(',').count())
        .max()
        .unwrap_or(0);
    assert!(widest >= 10, "{queries:?}");
    assert_eq!(submissions(&ws).len(), 12);
    // The trace has a job row per stage, with accounting from sacct.
    let t = trace(&ws, "many");
    assert_eq!(t.len(), 12);
    for row in &t {
        assert_eq!(row["executor"], "slurm", "{row}");
        assert_eq!(row["state"], "COMPLETED", "{row}");
        assert_eq!(
            (row["node"].as_str(), row["max_rss"].as_str()),
            (Some("fake-node"), Some("2048K"))
        );
        assert!(!row["job_id"].as_str().unwrap_or("").is_empty());
    }
    assert!(ws.path().join("results/many/trace.csv").exists());
}

#[test]
fn a_killed_submitter_s_jobs_are_adopted_not_submitted_again() {
    let ws = Workspace::new();
    ws.write(
        "p.yaml",
        "name: adopt\nexecutor: {kind: slurm, poll: 0.5}\nstages:\n  long:\n    kind: command\n    params: {cmd: \"sleep 4; echo done > a.txt\", outs: [a.txt]}\n",
    );
    let mut child = command(&ws, &[], &[]).spawn().expect("spawn run");
    let start = Instant::now();
    let id = loop {
        let running = submissions(&ws).into_iter().next().and_then(|(id, _)| {
            let state = std::fs::read_to_string(ws.path().join(format!("fake/{id}.state"))).ok()?;
            state.starts_with("RUNNING").then_some(id)
        });
        if let Some(id) = running {
            break id;
        }
        assert!(start.elapsed() < Duration::from_secs(20), "job never ran");
        std::thread::sleep(Duration::from_millis(50));
    };
    // kill -9: no handler runs, nothing is cancelled.
    child.kill().expect("kill");
    let _ = child.wait();
    assert!(!ws.path().join("fake/scancel.log").exists());
    // status names the job in flight.
    let fake = format!(
        "{}/tests/slurm/fake:{}",
        env!("CARGO_MANIFEST_DIR"),
        std::env::var("PATH").unwrap_or_default()
    );
    let status = |ws: &Workspace| {
        let out = ws
            .command(&["status", "p.yaml", "--json"])
            .env("PATH", &fake)
            .env("FAKE_SLURM_DIR", ws.path().join("fake"))
            .output()
            .expect("status");
        util::Report(serde_json::from_slice(&out.stdout).expect("json"))
    };
    let s = status(&ws);
    let reason = s.stage("long")["reason"].as_str().unwrap_or("").to_string();
    assert!(
        reason.starts_with(&format!("in flight: slurm job {id}: 1 RUNNING (attempt 1")),
        "{reason}"
    );
    // A detached run adopts the job and returns at once.
    let out = command(&ws, &["--detach"], &[]).output().expect("detach");
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    let detached: Value = serde_json::from_slice(&out.stdout).expect("json");
    assert!(detached["detached"].as_u64().is_some(), "{detached}");
    let start = Instant::now();
    while status(&ws).status_of("long") != "cached" {
        assert!(start.elapsed() < Duration::from_secs(30), "never finished");
        std::thread::sleep(Duration::from_millis(200));
    }
    assert_eq!(submissions(&ws).len(), 1, "submitted again");
    assert_eq!(ws.read("a.txt"), "done\n");
    // The background run's trace says it adopted the job.
    let start = Instant::now();
    let adopted = loop {
        let t =
            std::fs::read_to_string(ws.path().join("results/adopt/trace.json")).unwrap_or_default();
        if let Ok(Value::Array(rows)) = serde_json::from_str::<Value>(&t) {
            break rows;
        }
        assert!(start.elapsed() < Duration::from_secs(10), "no trace");
        std::thread::sleep(Duration::from_millis(100));
    };
    assert_eq!(adopted[0]["adopted"], true, "{adopted:?}");
    assert_eq!(adopted[0]["job_id"], id.as_str());
    let log = ws.read("results/adopt/run.log");
    assert!(log.contains("ran"), "{log}");
}

#[test]
fn a_timed_out_job_is_retried_with_more_time() {
    let ws = Workspace::new();
    let p = "name: retry\nexecutor:\n  kind: slurm\n  poll: 0.5\n  retries: 1\n  time: \"2 * attempt\"\nstages:\n  slow:\n    kind: command\n    params: {cmd: \"sleep 3; echo ok > r.txt\", outs: [r.txt]}\n";
    ws.write("p.yaml", p);
    // A minute of `--time` lasts one second on the stand-in.
    let r = run(&ws, &[], &[("FAKE_SLURM_MINUTE", "1")], 0);
    assert_eq!(r.status_of("slow"), "ran");
    assert_eq!(ws.read("r.txt"), "ok\n");
    let lines = sbatch_lines(&ws);
    assert_eq!(lines.len(), 2);
    assert!(
        lines[0].contains(&"#SBATCH --time=00:02:00".to_string()),
        "{lines:?}"
    );
    assert!(
        lines[1].contains(&"#SBATCH --time=00:04:00".to_string()),
        "{lines:?}"
    );
    let t = trace(&ws, "retry");
    let states: Vec<(u64, &str)> = rows_of(&t, "slow")
        .iter()
        .map(|r| {
            (
                r["attempt"].as_u64().unwrap_or(0),
                r["state"].as_str().unwrap_or(""),
            )
        })
        .collect();
    assert_eq!(states, [(1, "TIMEOUT"), (2, "COMPLETED")]);
    // Without retries the timeout fails the stage, naming the remedy.
    let ws = Workspace::new();
    ws.write("p.yaml", &p.replace("  retries: 1\n", ""));
    let r = run(&ws, &[], &[("FAKE_SLURM_MINUTE", "1")], 1);
    let e = r.stage("slow")["error"].as_str().unwrap_or("").to_string();
    assert!(e.contains("TIMEOUT") && e.contains("retries: 1"), "{e}");
}

#[test]
fn matrix_arrays_throttles_and_group_jobs_in_the_sbatch_lines() {
    let ws = Workspace::new();
    let p = r#"name: batches
executor:
  kind: slurm
  poll: 0.5
  array_parallelism: 2
  kinds:
    command: {group: 3}
  stages:
    "sens[samples=128]": {cpus: 1}
stages:
  sens:
    kind: gsa
    matrix: {samples: [64, 128, 256]}
    params: {model: {builtin: ishigami}, samples: "${matrix.samples}", bootstrap: 10}
  a: {kind: command, params: {cmd: "echo a > a.txt", outs: [a.txt]}}
  b: {kind: command, params: {cmd: "echo b > b.txt", outs: [b.txt]}}
  c: {kind: command, params: {cmd: "echo c > c.txt", outs: [c.txt]}}
"#;
    ws.write("p.yaml", p);
    let r = run(&ws, &[], &[], 0);
    assert!(r.all("ran"), "{:?}", r.statuses());
    let lines = sbatch_lines(&ws);
    assert_eq!(lines.len(), 2, "{lines:?}");
    let array = lines
        .iter()
        .find(|l| l.iter().any(|x| x.starts_with("#SBATCH --array")));
    let array = array.expect("one array");
    assert!(
        array.contains(&"#SBATCH --array=0-2%2".to_string()),
        "{array:?}"
    );
    assert!(array.contains(&"#SBATCH --mem=2G".to_string()), "{array:?}");
    // The group job runs the three command stages in turn.
    let (group_id, _) = submissions(&ws)
        .into_iter()
        .find(|(id, _)| !ws.read(&format!("fake/{id}.sh")).contains("--array"))
        .expect("group job");
    let script = ws.read(&format!("fake/{group_id}.sh"));
    let exec = script.lines().last().unwrap_or("");
    assert_eq!(exec.matches("job.json").count(), 3, "{script}");
    for (f, want) in [("a.txt", "a\n"), ("b.txt", "b\n"), ("c.txt", "c\n")] {
        assert_eq!(ws.read(f), want);
    }
    // Trace rows: a task each for the matrix, the group job for a, b, c.
    let t = trace(&ws, "batches");
    for s in ["sens[samples=64]", "sens[samples=128]", "sens[samples=256]"] {
        let rows = rows_of(&t, s);
        assert_eq!(rows.len(), 1, "{s}: {t:?}");
        assert!(rows[0]["array_index"].as_u64().is_some(), "{:?}", rows[0]);
    }
    for s in ["a", "b", "c"] {
        assert_eq!(rows_of(&t, s)[0]["job_id"], group_id.as_str());
    }
    // Shared directories go once every member committed.
    let left = std::fs::read_dir(ws.path().join("cache/jobs")).map_or(0, |d| d.count());
    assert_eq!(left, 0);
}

#[test]
fn binary_and_per_stage_overrides_are_checked_and_scratch_is_node_local() {
    let ws = Workspace::new();
    let p = "name: bin\nexecutor:\n  kind: slurm\n  poll: 0.5\n  binary: bin/modalflow\n  scratch: \"$NODE_SCRATCH\"\n  stages:\n    whre: {cpus: 2}\nstages:\n  where:\n    kind: command\n    params: {cmd: \"echo $MODALFLOW_SCRATCH > w.txt\", outs: [w.txt]}\n";
    ws.write("p.yaml", p);
    let out = ws.cmd(&["validate", "p.yaml"]);
    assert_eq!(out.status.code(), Some(2));
    let err = text(&out.stderr);
    assert!(
        err.contains("`binary: bin/modalflow` is not an executable file"),
        "{err}"
    );
    assert!(err.contains("p.yaml:5:11"), "{err}");
    assert!(
        err.contains("no stage `whre`") && err.contains("did you mean `where`?"),
        "{err}"
    );
    // Fixed: a relative binary starts at the pipeline file's directory.
    ws.write("p.yaml", &p.replace("whre", "where"));
    std::fs::create_dir_all(ws.path().join("bin")).expect("bin");
    std::os::unix::fs::symlink(
        env!("CARGO_BIN_EXE_modalflow"),
        ws.path().join("bin/modalflow"),
    )
    .expect("link");
    let scratch = ws.path().join("node");
    std::fs::create_dir_all(&scratch).expect("scratch");
    let r = run(&ws, &[], &[("NODE_SCRATCH", &scratch.to_string_lossy())], 0);
    assert_eq!(r.status_of("where"), "ran");
    let script = ws.read(&format!("fake/{}.sh", submissions(&ws)[0].0));
    let bin = ws.path().join("bin/modalflow");
    assert!(
        script.contains(&format!("exec '{}' exec", bin.display())),
        "{script}"
    );
    assert!(script.contains("#SBATCH --cpus-per-task=2"), "{script}");
    assert!(script.contains("--scratch \"$NODE_SCRATCH\""), "{script}");
    // The stage ran in the node-local directory, which is cleaned after.
    assert!(ws
        .read("w.txt")
        .starts_with(&scratch.to_string_lossy().to_string()));
    assert_eq!(std::fs::read_dir(&scratch).map_or(9, |d| d.count()), 0);
}
