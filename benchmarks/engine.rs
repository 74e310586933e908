//! Engine overhead on generated pipelines of 200, 1,000 and 5,000 stages
//! (groups of 10 trivial `command` stages: a source, a chain of 4, a fan-out
//! of 4, a join): wall time of `validate`, `status`, a fully cached `run` and
//! `dag`, end to end through the CLI, next to the floor of starting the
//! binary at all (`modalflow --version`) measured in the same run.
//!
//! Run with `cargo bench --bench engine [-- SIZES]` (default `200,1000,5000`).
//! With `MODALFLOW_BEFORE=/path/to/old/modalflow`, the old binary runs the
//! same commands interleaved with this one (best of n each, the machine is
//! shared) and each line gets the ratio after/before.
//! Target: < 100 ms each at 200 stages on 2 cores.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

/// `groups` × 10 stages: (1 source, a chain of 4, a fan-out of 4, a join).
fn pipeline(groups: usize) -> String {
    let mut y = format!("name: bench{}\nstages:\n", groups * 10);
    for g in 0..groups {
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

fn time(bin: &Path, dir: &Path, args: &[&str]) -> Duration {
    let t = Instant::now();
    let out = Command::new(bin)
        .args(args)
        .current_dir(dir)
        .output()
        .expect("run modalflow");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    t.elapsed()
}

fn main() {
    let sizes: Vec<usize> = std::env::args()
        .skip(1)
        .find(|a| !a.starts_with('-'))
        .map(|a| a.split(',').filter_map(|n| n.parse().ok()).collect())
        .unwrap_or_else(|| vec![200, 1000, 5000]);
    let now = PathBuf::from(env!("CARGO_BIN_EXE_modalflow"));
    let before = std::env::var_os("MODALFLOW_BEFORE").map(PathBuf::from);
    let bins: Vec<&Path> = std::iter::once(now.as_path())
        .chain(before.as_deref())
        .collect();
    let ms = |d: Duration| d.as_secs_f64() * 1e3;
    for stages in sizes {
        let reps = if stages >= 5000 { 5 } else { 11 };
        let dirs: Vec<tempfile::TempDir> = bins
            .iter()
            .map(|bin| {
                let dir = tempfile::tempdir().expect("temp dir");
                std::fs::write(dir.path().join("p.yaml"), pipeline(stages / 10))
                    .expect("write pipeline");
                let cold = time(bin, dir.path(), &["run", "p.yaml", "--progress", "none"]);
                eprintln!(
                    "{stages} stages, cold run ({}): {:.0} ms",
                    bin.display(),
                    ms(cold)
                );
                dir
            })
            .collect();
        let commands: [(&str, &[&str]); 5] = [
            ("startup (--version)", &["--version"]),
            ("validate", &["validate", "p.yaml"]),
            ("status", &["status", "p.yaml"]),
            (
                "run (fully cached)",
                &["run", "p.yaml", "--progress", "none"],
            ),
            ("dag", &["dag", "p.yaml"]),
        ];
        println!("engine overhead, {stages}-stage pipeline (best of {reps}):");
        for (name, args) in commands {
            let mut best = vec![Duration::MAX; bins.len()];
            for _ in 0..reps {
                for (k, (bin, dir)) in bins.iter().zip(&dirs).enumerate() {
                    best[k] = best[k].min(time(bin, dir.path(), args));
                }
            }
            let mut line = format!("  {name:<24} {:>9.1} ms", ms(best[0]));
            if let Some(old) = best.get(1) {
                line.push_str(&format!(
                    "   before {:>9.1} ms   after/before {:.2}",
                    ms(*old),
                    ms(best[0]) / ms(*old)
                ));
            }
            println!("{line}");
        }
    }
}
