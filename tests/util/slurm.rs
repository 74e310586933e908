//! The Slurm stand-ins of `tests/slurm/fake/` on PATH, and what they record:
//! submissions, array tasks, and every scheduler call.

use super::{Report, Workspace};
use serde_json::Value;
use std::path::Path;
use std::process::Command;

/// `modalflow run p.yaml` with the stand-ins first on PATH.
pub fn command(ws: &Workspace, extra: &[&str], env: &[(&str, &str)]) -> Command {
    let fake = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/slurm/fake");
    let path = format!(
        "{}:{}",
        fake.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let mut args = vec!["run", "p.yaml", "--json", "--progress", "none"];
    args.extend_from_slice(extra);
    let mut c = ws.command(&args);
    c.env("PATH", path)
        .env("FAKE_SLURM_DIR", ws.path().join("fake"))
        .env_remove("FAKE_SLURM_TIMEOUT")
        .env_remove("FAKE_SLURM_FAIL_TASK")
        .env_remove("FAKE_SLURM_NO_SACCT")
        .env_remove("FAKE_SLURM_MINUTE");
    for (k, v) in env {
        c.env(k, v);
    }
    c
}

pub fn run(ws: &Workspace, extra: &[&str], env: &[(&str, &str)], code: i32) -> Report {
    let out = command(ws, extra, env).output().expect("run modalflow");
    assert_eq!(
        out.status.code(),
        Some(code),
        "stdout: {}\nstderr: {}",
        super::text(&out.stdout),
        super::text(&out.stderr)
    );
    Report(serde_json::from_slice(&out.stdout).expect("json report"))
}

/// Output name → content hash, from a stage's results manifest.
pub fn outputs(ws: &Workspace, stage: &str) -> Vec<(String, String)> {
    let m: Value = ws.json(&format!("results/cluster/{stage}/manifest.json"));
    let mut out: Vec<(String, String)> = m["outputs"]
        .as_object()
        .expect("outputs")
        .iter()
        .map(|(k, v)| {
            (
                k.clone(),
                v["hash"].as_str().unwrap_or_default().to_string(),
            )
        })
        .collect();
    out.sort();
    out
}

/// Job ids the sbatch stand-in handed out, in order.
pub fn submissions(ws: &Workspace) -> Vec<(String, String)> {
    std::fs::read_to_string(ws.path().join("fake/submitted.log"))
        .unwrap_or_default()
        .lines()
        .filter_map(|l| l.split_once(' '))
        .map(|(id, script)| (id.to_string(), script.to_string()))
        .collect()
}

/// Array tasks the stand-in ran for job `id`.
pub fn tasks(ws: &Workspace, id: &str) -> Vec<usize> {
    let mut t: Vec<usize> = std::fs::read_dir(ws.path().join("fake"))
        .map(|d| {
            d.flatten()
                .filter_map(|e| {
                    let name = e.file_name().to_string_lossy().into_owned();
                    let task = name
                        .strip_prefix(&format!("{id}_"))?
                        .strip_suffix(".state")?;
                    task.parse().ok()
                })
                .collect()
        })
        .unwrap_or_default();
    t.sort();
    t
}

/// The scheduler calls the stand-ins logged: (command, arguments).
pub fn calls(ws: &Workspace) -> Vec<(String, String)> {
    std::fs::read_to_string(ws.path().join("fake/calls.log"))
        .unwrap_or_default()
        .lines()
        .filter_map(|l| l.split_once(' '))
        .map(|(c, a)| (c.to_string(), a.to_string()))
        .collect()
}

/// The `#SBATCH` lines of every script the stand-in was handed, in order.
pub fn sbatch_lines(ws: &Workspace) -> Vec<Vec<String>> {
    submissions(ws)
        .iter()
        .map(|(id, _)| {
            std::fs::read_to_string(ws.path().join(format!("fake/{id}.sh")))
                .unwrap_or_default()
                .lines()
                .filter(|l| l.starts_with("#SBATCH"))
                .map(str::to_string)
                .collect()
        })
        .collect()
}
