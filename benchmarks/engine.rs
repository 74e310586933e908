//! Engine overhead on a generated 200-stage pipeline (chains and fan-outs of
//! trivial `command` stages): wall time of a fully cached `run` and of
//! `status`, end to end through the CLI, next to the floor of starting the
//! binary at all (`modalflow --version`) measured in the same run.
//!
//! Run with `cargo bench --bench engine`. Target: < 100 ms each on 2 cores.

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

/// 200 stages: 20 groups of (1 source, a chain of 4, a fan-out of 4, a join).
fn pipeline() -> String {
    let mut y = String::from("name: bench200\nstages:\n");
    for g in 0..20 {
        let stage = |name: &str, deps: &[String], out: &str| -> String {
            let deps_yaml = if deps.is_empty() {
                String::new()
            } else {
                format!(", deps: [{}]", deps.join(", "))
            };
            let cat = if deps.is_empty() {
                "echo seed".to_string()
            } else {
                format!("cat {}", deps.join(" "))
            };
            format!("  {name}:\n    kind: command\n    params: {{cmd: \"{cat} > {out}; echo {name} >> {out}\"{deps_yaml}, outs: [{out}]}}\n")
        };
        let src = format!("g{g}_src.txt");
        y += &stage(&format!("g{g}_src"), &[], &src);
        let mut prev = src;
        for c in 0..4 {
            let out = format!("g{g}_c{c}.txt");
            y += &stage(&format!("g{g}_c{c}"), std::slice::from_ref(&prev), &out);
            prev = out;
        }
        let mut fans = Vec::new();
        for f in 0..4 {
            let out = format!("g{g}_f{f}.txt");
            y += &stage(&format!("g{g}_f{f}"), std::slice::from_ref(&prev), &out);
            fans.push(out);
        }
        y += &stage(&format!("g{g}_join"), &fans, &format!("g{g}_join.txt"));
    }
    y
}

fn time(dir: &Path, args: &[&str], reps: usize) -> Duration {
    let mut best = Duration::MAX;
    for _ in 0..reps {
        let t = Instant::now();
        let out = Command::new(env!("CARGO_BIN_EXE_modalflow"))
            .args(args)
            .current_dir(dir)
            .output()
            .expect("run modalflow");
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        best = best.min(t.elapsed());
    }
    best
}

fn main() {
    let dir = tempfile::tempdir().expect("temp dir");
    std::fs::write(dir.path().join("p.yaml"), pipeline()).expect("write pipeline");
    let t = Instant::now();
    let cold = time(dir.path(), &["run", "p.yaml", "--progress", "none"], 1);
    eprintln!(
        "cold run (200 sh processes): {:.0} ms",
        cold.as_secs_f64() * 1e3
    );
    let _ = t;
    let reps = 15;
    let floor = time(dir.path(), &["--version"], reps);
    let cached = time(dir.path(), &["run", "p.yaml", "--progress", "none"], reps);
    let status = time(dir.path(), &["status", "p.yaml"], reps);
    let validate = time(dir.path(), &["validate", "p.yaml"], reps);
    let ms = |d: Duration| d.as_secs_f64() * 1e3;
    println!("engine overhead, 200-stage pipeline (best of {reps}):");
    println!("  {:<28} {:>8.1} ms", "startup (--version)", ms(floor));
    for (name, d) in [
        ("validate", validate),
        ("status", status),
        ("run (fully cached)", cached),
    ] {
        println!(
            "  {:<28} {:>8.1} ms  ({:.1}x startup)",
            name,
            ms(d),
            ms(d) / ms(floor)
        );
    }
}
